#include "observe/observe.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "geometry/mesh_io.h"
#include "sphere/frame.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

// A flat grid in z = 0 over [-1,1]^2 with n×n vertices, normals +Z.
TriangleMesh Grid(int n) {
  TriangleMesh m;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) m.vertices.emplace_back(-1 + 2.0f * i / (n - 1), -1 + 2.0f * j / (n - 1), 0.0f);
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i;
      m.faces.emplace_back(a, a + 1, a + n + 1);
      m.faces.emplace_back(a, a + n + 1, a + n);
    }
  m.ComputeVertexNormals();
  return m;
}

// A camera at `center` looking at the origin, +Z up in the image's upward direction.
ImageRecord LookAt(const Eigen::Vector3d& center) {
  const Eigen::Vector3d z = (-center).normalized();
  Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ());
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d r;
  r.row(0) = x;
  r.row(1) = y;
  r.row(2) = z;
  ImageRecord im;
  im.image_id = 1;
  im.camera_id = 1;
  im.name = "p.jpg";
  im.SetPose(r, center);
  return im;
}

// Linear image whose value is affine in the pixel coordinates: footprint means equal centre values.
Image AffineImage(int w, int h) {
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      img.at(x, y, 0) = 0.1f + 0.002f * (x + 0.5f);
      img.at(x, y, 1) = 0.2f + 0.003f * (y + 0.5f);
      img.at(x, y, 2) = 0.5f;
    }
  return img;
}

class ObserveTest : public ::testing::Test {
 protected:
  void SetUp() override { InitLogging("observe_test", "", LogLevel::kError); }
  Camera camera_ = Camera::Pinhole(1, 160, 120, 150, 150, 80, 60);
  ObserveOptions options_;
};

TEST_F(ObserveTest, ColourViewDirectionAndConfidenceOnAPlane) {
  const TriangleMesh grid = Grid(21);
  const RayCaster caster({&grid});
  const Image radiance = AffineImage(160, 120);
  const Image confidence(160, 120, 1, 1.0f);
  const ImageRecord pose = LookAt({0.3, -0.2, 3.0});
  PhotoView view{camera_, pose, &radiance, &confidence};
  const auto obs = ObservePhoto(grid, VertexFootprintRadius(grid), caster, view, 0, options_);
  ASSERT_GT(obs.size(), 250u);
  for (const Observation& o : obs) {
    const Eigen::Vector3d x = grid.vertices[o.vertex].cast<double>();
    const Eigen::Vector2d px = camera_.ImageFromCamera(pose.CamFromWorld(x));
    EXPECT_NEAR(o.rgb[0], 0.1 + 0.002 * px.x(), 1e-4);
    EXPECT_NEAR(o.rgb[1], 0.2 + 0.003 * px.y(), 1e-4);
    const Eigen::Vector3d view_world = (pose.ProjectionCenter() - x).normalized();
    const Eigen::Vector3d expected = FrameFromNormal<double>(Eigen::Vector3d::UnitZ()).ToLocal(view_world);
    EXPECT_NEAR(o.view_local[0], expected.x(), 1e-5);
    EXPECT_NEAR(o.view_local[2], expected.z(), 1e-5);
    EXPECT_GT(o.confidence, 0.0f);
    EXPECT_LE(o.confidence, 1.0f);
  }
  // Vertices at least edge_margin + footprint away from the plane's silhouette have full confidence.
  int full = 0;
  for (const Observation& o : obs) full += o.confidence > 0.999f;
  EXPECT_GT(full, 150);
}

TEST_F(ObserveTest, OccludedAndBackFacingVerticesAreNeverObserved) {
  const TriangleMesh grid = Grid(31);
  // A floating square blocker between the camera and part of the plane.
  TriangleMesh blocker;
  blocker.vertices = {{-0.5f, -0.5f, 1.0f}, {0.2f, -0.5f, 1.0f}, {0.2f, 0.2f, 1.0f}, {-0.5f, 0.2f, 1.0f}};
  blocker.faces = {{0, 1, 2}, {0, 2, 3}};
  const RayCaster caster({&grid, &blocker});
  const Image radiance(160, 120, 3, 0.5f), confidence(160, 120, 1, 1.0f);
  const ImageRecord pose = LookAt({0.0, 0.0, 3.0});
  PhotoView view{camera_, pose, &radiance, &confidence};
  const auto obs = ObservePhoto(grid, VertexFootprintRadius(grid), caster, view, 0, options_);
  ASSERT_FALSE(obs.empty());
  int shadowed_truth = 0;
  for (size_t v = 0; v < grid.num_vertices(); ++v) {
    const Eigen::Vector3f x = grid.vertices[v];
    const Eigen::Vector3f to_cam = pose.ProjectionCenter().cast<float>() - x;
    shadowed_truth += caster.Occluded({x + 1e-4f * Eigen::Vector3f::UnitZ(), to_cam, 0.0f, 0.999f});
  }
  EXPECT_GT(shadowed_truth, 50);
  for (const Observation& o : obs) {
    const Eigen::Vector3f x = grid.vertices[o.vertex];
    const Eigen::Vector3f to_cam = pose.ProjectionCenter().cast<float>() - x;
    EXPECT_FALSE(caster.Occluded({x + 1e-4f * Eigen::Vector3f::UnitZ(), to_cam, 0.0f, 0.999f})) << o.vertex;
  }
  // From below, the plane faces away: nothing is observed.
  PhotoView below{camera_, LookAt({0.0, 0.1, -3.0}), &radiance, &confidence};
  EXPECT_TRUE(ObservePhoto(grid, VertexFootprintRadius(grid), caster, below, 0, options_).empty());
}

TEST_F(ObserveTest, ClippedPixelsAndGrazingAnglesLowerConfidence) {
  const TriangleMesh grid = Grid(21);
  const RayCaster caster({&grid});
  const Image radiance(160, 120, 3, 0.5f);
  Image confidence(160, 120, 1, 1.0f);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 80; ++x) confidence.at(x, y) = 0.0f;  // left half over-exposed
  const ImageRecord pose = LookAt({0.0, 0.01, 3.0});
  PhotoView view{camera_, pose, &radiance, &confidence};
  for (const Observation& o : ObservePhoto(grid, VertexFootprintRadius(grid), caster, view, 0, options_)) {
    const Eigen::Vector2d px = camera_.ImageFromCamera(pose.CamFromWorld(grid.vertices[o.vertex].cast<double>()));
    EXPECT_GT(px.x(), 78.0);  // nothing observed from the clipped half (footprint may straddle the boundary)
  }
  // A camera 70° from the normal: the ramp from 60° (1) to 80° (0) gives 0.5.
  const double angle = 70 * M_PI / 180;
  const ImageRecord grazing = LookAt({0.0, -6 * std::sin(angle), 6 * std::cos(angle)});
  const Image all_ok(160, 120, 1, 1.0f);
  PhotoView view2{Camera::Pinhole(1, 160, 120, 400, 400, 80, 60), grazing, &radiance, &all_ok};
  const auto obs = ObservePhoto(grid, VertexFootprintRadius(grid), caster, view2, 0, options_);
  ASSERT_FALSE(obs.empty());
  int at_ramp = 0;
  for (const auto& o : obs) {
    const Eigen::Vector3d x = grid.vertices[o.vertex].cast<double>();
    const double deg = std::acos((grazing.ProjectionCenter() - x).normalized().z()) * 180 / M_PI;
    const double ramp = std::clamp((80.0 - deg) / 20.0, 0.0, 1.0);
    EXPECT_LE(o.confidence, ramp + 1e-4);  // other factors only lower it
    at_ramp += std::abs(o.confidence - ramp) < 1e-3;
    EXPECT_GT(deg, 60.0);
  }
  EXPECT_GT(at_ramp, static_cast<int>(obs.size()) / 3);
}

TEST_F(ObserveTest, FileRoundTripAndDamage) {
  testing::TempDir dir;
  ObservationSet set;
  set.num_photos = 2;
  set.num_vertices = 10;
  Observation o;
  o.photo = 1;
  o.vertex = 7;
  o.rgb[1] = 0.25f;
  o.confidence = 0.5f;
  o.view_local[0] = 0.6f;
  o.view_local[2] = 0.8f;
  set.records = {o, o};
  WriteObservations(dir / "o.bin", set);
  const ObservationSet back = ReadObservations(dir / "o.bin");
  ASSERT_EQ(back.records.size(), 2u);
  EXPECT_EQ(back.records[1].vertex, 7u);
  EXPECT_EQ(back.records[1].rgb[1], 0.25f);
  EXPECT_EQ(back.records[1].view_local[2], 0.8f);
  const std::string bytes = ReadFileToString(dir / "o.bin");
  WriteFileAtomic(dir / "cut.bin", bytes.substr(0, bytes.size() - 5));
  EXPECT_THROW(ReadObservations(dir / "cut.bin"), UserError);
}

TEST_F(ObserveTest, StageRunsOnAWorkspaceAndResumes) {
  setenv("RELIGHT_PROGRESS", "off", 1);
  testing::TempDir dir;
  for (const char* sub : {"sfm/sparse", "mesh", "lin/linear", "lin/confidence"}) fs::create_directories(dir / sub);
  Reconstruction model;
  model.cameras[1] = camera_;
  for (int k = 0; k < 3; ++k) {
    ImageRecord im = LookAt({0.5 * k - 0.5, 0.4, 3.0});
    im.image_id = k + 1;
    im.name = "photo_" + std::to_string(k) + ".jpg";
    model.images[im.image_id] = im;
    WriteImage(dir / ("lin/linear/photo_" + std::to_string(k) + ".exr"), AffineImage(160, 120), {PixelType::kFloat});
    WriteImage(dir / ("lin/confidence/photo_" + std::to_string(k) + ".exr"), Image(160, 120, 1, 1.0f),
               {PixelType::kHalf});
  }
  model.WriteBinary(dir / "sfm/sparse");
  WriteMeshPly(dir / "mesh/mesh.ply", Grid(15));
  const ObserveSummary s = RunObserve(options_, dir / "sfm", dir / "mesh", dir / "lin", dir / "out");
  EXPECT_EQ(s.photos, 3);
  EXPECT_EQ(s.reused_photos, 0);
  const ObservationSet set = ReadObservations(dir / "out/observations.bin");
  EXPECT_EQ(set.num_photos, 3u);
  EXPECT_EQ(set.records.size(), s.observations);
  for (size_t i = 1; i < set.records.size(); ++i) EXPECT_LE(set.records[i - 1].photo, set.records[i].photo);
  const auto photos = ReadObservedPhotos(dir / "out/photos.json");
  ASSERT_EQ(photos.size(), 3u);
  EXPECT_EQ(photos[2].name, "photo_2.jpg");
  EXPECT_TRUE(photos[1].pose.ProjectionCenter().isApprox(Eigen::Vector3d(0, 0.4, 3.0), 1e-9));
  const ObserveSummary again = RunObserve(options_, dir / "sfm", dir / "mesh", dir / "lin", dir / "out");
  EXPECT_EQ(again.reused_photos, 3);
  EXPECT_EQ(again.observations, s.observations);
}

}  // namespace
}  // namespace relight

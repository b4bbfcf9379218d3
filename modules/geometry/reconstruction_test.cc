#include "geometry/reconstruction.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "core/error.h"
#include "core/fs.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

Reconstruction MakeModel() {
  Reconstruction r;
  r.cameras[1] = Camera{1, "SIMPLE_RADIAL", 400, 300, {350, 200, 150, -0.05}};
  r.cameras[2] = Camera::Pinhole(2, 640, 480, 500, 501, 320.5, 240.25);
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  for (uint32_t i = 1; i <= 4; ++i) {
    ImageRecord im;
    im.image_id = i;
    im.name = "photo " + std::to_string(i) + ".jpg";  // names may contain spaces
    im.camera_id = i % 2 + 1;
    const Eigen::Vector3d center(4 * std::cos(i), 4 * std::sin(i), 1.0);
    const Eigen::Vector3d z = (-center).normalized();
    const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d y = z.cross(x);
    Eigen::Matrix3d rot;
    rot.row(0) = x;
    rot.row(1) = y;
    rot.row(2) = z;
    im.SetPose(rot, center);
    r.images[i] = im;
  }
  for (uint64_t p = 1; p <= 20; ++p) {
    Point3D pt;
    pt.point3d_id = p;
    pt.xyz = Eigen::Vector3d(n(rng), n(rng), n(rng)) * 0.5;
    pt.rgb = {static_cast<uint8_t>(p * 10), 20, 30};
    for (auto& [id, im] : r.images) {
      Eigen::Vector2d px;
      if (!r.Project(im, pt.xyz, &px)) continue;
      Point2D p2;
      p2.xy = px;
      p2.point3d_id = p;
      pt.track.emplace_back(id, static_cast<uint32_t>(im.points2d.size()));
      im.points2d.push_back(p2);
    }
    Point2D untriangulated;
    untriangulated.xy = {1, 2};
    r.images[1].points2d.push_back(untriangulated);
    r.points3d[p] = pt;
  }
  return r;
}

void ExpectSame(const Reconstruction& a, const Reconstruction& b, double tol) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  ASSERT_EQ(a.images.size(), b.images.size());
  ASSERT_EQ(a.points3d.size(), b.points3d.size());
  for (const auto& [id, c] : a.cameras) {
    EXPECT_EQ(c.model, b.cameras.at(id).model);
    for (size_t k = 0; k < c.params.size(); ++k) EXPECT_NEAR(c.params[k], b.cameras.at(id).params[k], tol);
  }
  for (const auto& [id, im] : a.images) {
    const ImageRecord& o = b.images.at(id);
    EXPECT_EQ(im.name, o.name);
    EXPECT_LE((im.ProjectionCenter() - o.ProjectionCenter()).norm(), tol + 1e-12);
    EXPECT_LE(im.cam_from_world_rotation.angularDistance(o.cam_from_world_rotation), tol + 1e-12);
    ASSERT_EQ(im.points2d.size(), o.points2d.size());
    for (size_t k = 0; k < im.points2d.size(); ++k) EXPECT_EQ(im.points2d[k].point3d_id, o.points2d[k].point3d_id);
  }
  for (const auto& [id, p] : a.points3d) {
    EXPECT_LE((p.xyz - b.points3d.at(id).xyz).norm(), tol);
    EXPECT_EQ(p.track.size(), b.points3d.at(id).track.size());
  }
}

TEST(ReconstructionTest, TextAndBinaryRoundTrip) {
  testing::TempDir dir;
  const Reconstruction model = MakeModel();
  fs::create_directories(dir / "txt");
  fs::create_directories(dir / "bin");
  model.WriteText(dir / "txt");
  model.WriteBinary(dir / "bin");
  ExpectSame(model, Reconstruction::ReadText(dir / "txt"), 1e-12);
  ExpectSame(model, Reconstruction::ReadBinary(dir / "bin"), 0.0);
  ExpectSame(model, Reconstruction::Read(dir / "bin"), 0.0);
}

TEST(ReconstructionTest, ColmapReadsOurBinaryModel) {
  // COLMAP's own converter must understand what we write.
  testing::TempDir dir;
  const Reconstruction model = MakeModel();
  fs::create_directories(dir / "bin");
  fs::create_directories(dir / "txt");
  model.WriteBinary(dir / "bin");
  std::string output;
  const int rc = testing::RunCommand("colmap model_converter --input_path " + (dir / "bin") + " --output_path " +
                                         (dir / "txt") + " --output_type TXT",
                                     &output);
  ASSERT_EQ(rc, 0) << output;
  ExpectSame(model, Reconstruction::ReadText(dir / "txt"), 1e-9);
}

TEST(ReconstructionTest, SimilarityKeepsProjections) {
  Reconstruction model = MakeModel();
  const Reconstruction original = model;
  Sim3 t;
  t.scale = 2.5;
  t.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  t.translation = {1, -2, 3};
  model.Transform(t);
  for (const auto& [pid, p] : original.points3d) {
    for (const auto& [iid, im] : original.images) {
      Eigen::Vector2d a, b;
      if (!original.Project(im, p.xyz, &a)) continue;
      ASSERT_TRUE(model.Project(model.images.at(iid), model.points3d.at(pid).xyz, &b));
      EXPECT_LT((a - b).norm(), 1e-8);
    }
  }
  EXPECT_NEAR(model.MeanReprojectionError(), original.MeanReprojectionError(), 1e-8);
  EXPECT_LT(original.MeanReprojectionError(), 1e-9);
}

TEST(ReconstructionTest, MissingAndDamagedFilesAreUserErrors) {
  testing::TempDir dir;
  EXPECT_THROW(Reconstruction::Read(dir.path()), UserError);
  WriteFileAtomic(dir / "cameras.txt", "1 PINHOLE 640 480 500 500\n");
  WriteFileAtomic(dir / "images.txt", "");
  EXPECT_THROW(Reconstruction::ReadText(dir.path()), UserError);
  WriteFileAtomic(dir / "cameras.bin", std::string("\x05\x00", 2));
  WriteFileAtomic(dir / "images.bin", "");
  EXPECT_THROW(Reconstruction::ReadBinary(dir.path()), UserError);
}

using testing::ErrorOf;

TEST(ReconstructionTest, ArbitraryTextIsAParseErrorNamingFileAndLine) {
  // Issue 34: a random cameras.txt given as sfm.model ended in an internal error (exit 3).
  testing::TempDir dir;
  WriteFileAtomic(dir / "images.txt", "");
  WriteFileAtomic(dir / "cameras.txt", "# cameras\n1 PINHOLE 640 480 500 500 320 240 junk\n");
  EXPECT_EQ(ErrorOf([&] { Reconstruction::Read(dir.path()); }),
            "'" + (dir / "cameras.txt") +
                "' line 2 is not a COLMAP model line ('1 PINHOLE 640 480 500 500 320 240 junk'; expected CAMERA_ID "
                "MODEL WIDTH HEIGHT PARAMS[]); give a model folder written by COLMAP");
  WriteFileAtomic(dir / "cameras.txt", "1 PINHOLE 640 480 nan 500 320 240\n");
  EXPECT_NE(ErrorOf([&] { Reconstruction::Read(dir.path()); }).find("line 1 is not a COLMAP model line"),
            std::string::npos);
  WriteFileAtomic(dir / "cameras.txt", "-1 PINHOLE 640 480 500 500 320 240\n");
  EXPECT_NE(ErrorOf([&] { Reconstruction::Read(dir.path()); }).find("line 1 is not a COLMAP model line"),
            std::string::npos);
  WriteFileAtomic(dir / "cameras.txt", "1 PINHOLE 640 480 500 500 320 240\n");
  WriteFileAtomic(dir / "images.txt", "1 0 0 0 0 0 0 0 1 a.jpg\n\n");  // a zero quaternion
  EXPECT_NE(ErrorOf([&] { Reconstruction::Read(dir.path()); }).find("a non-zero finite rotation"), std::string::npos);
  // Random bytes and random lines: always a UserError, never another exception or a crash.
  std::mt19937 rng(34);
  for (int trial = 0; trial < 300; ++trial) {
    std::string text;
    const int n = std::uniform_int_distribution<int>(0, 200)(rng);
    for (int k = 0; k < n; ++k) {
      const char* alphabet = trial % 2 ? "0123456789 .-e\nPINHOLE#" : nullptr;
      text += alphabet ? alphabet[rng() % 24] : static_cast<char>(rng());
    }
    WriteFileAtomic(dir / (trial % 3 ? "cameras.txt" : "images.txt"), text);
    try {
      Reconstruction::Read(dir.path());
    } catch (const UserError&) {
    }
  }
}

TEST(ReconstructionTest, BinaryCountsBeyondTheFileAreDamageNotAllocations) {
  testing::TempDir dir;
  MakeModel().WriteBinary(dir.path());
  std::string images = ReadFileToString(dir / "images.bin");
  // The first image's 2D point count: after id, pose, camera id and "photo 1.jpg\0".
  const size_t count_at = 8 + 4 + 7 * 8 + 4 + std::string("photo 1.jpg").size() + 1;
  const uint64_t huge = uint64_t(1) << 60;
  images.replace(count_at, 8, reinterpret_cast<const char*>(&huge), 8);
  WriteFileAtomic(dir / "images.bin", images);
  const std::string msg = ErrorOf([&] { Reconstruction::Read(dir.path()); });  // was std::length_error: exit 3
  EXPECT_NE(msg.find("it claims 1152921504606846976 2D points but has "), std::string::npos) << msg;
}

}  // namespace
}  // namespace relight

// Rendering from any cameras under any map: the map conventions against the tools' own formulas (Cycles'
// equirectangular mapping, Mitsuba 3's envmap), a sun-like blob in a Blender-convention map lighting a
// Lambertian sphere as the closed form E ρ max(0, n·s)/π says (turned and scaled as asked, and not when the
// convention is ignored), and RenderCameras end to end on files.
#include "relight/render_cameras.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>

#include "brdf/brdf.h"
#include "core/fs.h"
#include "core/json.h"
#include "geometry/mesh_io.h"
#include "image/image.h"
#include "relight/display.h"
#include "relight/relight.h"
#include "relight/transport_render.h"
#include "render/test_scenes.h"
#include "testing/testing.h"
#include "wavelet/haar.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

// A smooth function of the direction, different in every channel and along every axis.
Eigen::Vector3d Pattern(const Eigen::Vector3d& d) {
  return Eigen::Vector3d(1.5 + 0.9 * d.x() + 0.3 * d.z(), 1.5 + 0.9 * d.y() - 0.2 * d.x(), 1.5 + 0.9 * d.z());
}

// Cycles (kernel/camera/projection.h): u = 0.5 − atan2(y, x)/2π, v = 1 − acos(z)/π with v from the bottom
// row; inverted here per pixel centre (row 0 of the file at the top).
Eigen::Vector3d BlenderPixelDirection(int col, int row, int w, int h) {
  const double u = (col + 0.5) / w, v_top = (row + 0.5) / h;
  const double phi = 2 * M_PI * (0.5 - u), theta = M_PI * v_top;
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// Mitsuba 3 (emitters/envmap.cpp): uv = (atan2(x, −z)/2π, acos(y)/π) in its +Y-up frame, whose (x, y, z) is
// ours (x, z, −y).
Eigen::Vector3d MitsubaPixelDirection(int col, int row, int w, int h) {
  const double phi = 2 * M_PI * (col + 0.5) / w, theta = M_PI * (row + 0.5) / h;
  const Eigen::Vector3d m(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
  return {m.x(), -m.z(), m.y()};
}

TEST(EnvmapConvention, BlenderAndMitsubaMapsReadAsTheirToolsReadThem) {
  const int w = 256, h = 128;
  for (EnvmapConvention convention : {EnvmapConvention::kBlender, EnvmapConvention::kMitsuba}) {
    Image tool(w, h, 3);
    for (int row = 0; row < h; ++row)
      for (int col = 0; col < w; ++col) {
        const Eigen::Vector3d d = convention == EnvmapConvention::kBlender ? BlenderPixelDirection(col, row, w, h)
                                                                           : MitsubaPixelDirection(col, row, w, h);
        for (int c = 0; c < 3; ++c) tool.at(col, row, c) = float(Pattern(d)[c]);
      }
    const EnvMap ours = EnvMap::FromLatLong(LatLongToProjectConvention(tool, convention));
    const EnvMap ignored = EnvMap::FromLatLong(tool);  // the convention not converted
    double worst = 0, worst_ignored = 0;
    for (int k = 0; k < 500; ++k) {
      const double z = -0.95 + 1.9 * ((k * 0.618034) - std::floor(k * 0.618034)), a = 2.39996 * k;
      const Eigen::Vector3d d(std::sqrt(1 - z * z) * std::cos(a), std::sqrt(1 - z * z) * std::sin(a), z);
      worst = std::max(worst, (ours.Lookup(d) - Pattern(d)).cwiseAbs().maxCoeff());
      worst_ignored = std::max(worst_ignored, (ignored.Lookup(d) - Pattern(d)).cwiseAbs().maxCoeff());
    }
    // Bilinear reconstruction of a linear pattern on a 256 x 128 grid: errors of the grid's curvature only.
    EXPECT_LT(worst, 0.01) << EnvmapConventionName(convention);
    EXPECT_GT(worst_ignored, 0.5) << EnvmapConventionName(convention);
  }
  EXPECT_EQ(ParseEnvmapConvention("blender"), EnvmapConvention::kBlender);
  EXPECT_NE(testing::ErrorOf([] { ParseEnvmapConvention("cycles"); }).find("relight, blender or mitsuba"),
            std::string::npos);
}

// A sun-like blob (Gaussian, σ = 3°, total irradiance E on a surface facing it) at world direction `sun`,
// written in Blender's convention.
Image BlenderSunMap(const Eigen::Vector3d& sun, double irradiance, int w = 512) {
  const int h = w / 2;
  const double sigma = 3 * M_PI / 180;
  // Radiance L = E / (2π σ²) exp(−θ²/2σ²) integrates (small σ) to E.
  const double peak = irradiance / (2 * M_PI * sigma * sigma);
  Image img(w, h, 3);
  for (int row = 0; row < h; ++row)
    for (int col = 0; col < w; ++col) {
      const Eigen::Vector3d d = BlenderPixelDirection(col, row, w, h);
      const double angle = std::acos(std::clamp(d.dot(sun), -1.0, 1.0));
      const double l = peak * std::exp(-angle * angle / (2 * sigma * sigma)) + 0.01;  // plus a faint sky
      for (int c = 0; c < 3; ++c) img.at(col, row, c) = float(l);
    }
  return img;
}

Eigen::Vector3d Direction(double azimuth_deg, double elevation_deg) {
  const double az = azimuth_deg * M_PI / 180, el = elevation_deg * M_PI / 180;
  return {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
}

struct SphereModel {
  std::unique_ptr<Scene> scene;
  VisibilityData visibility;  // unblocked (a convex sphere alone)
};

SphereModel LambertianSphere(double albedo) {
  SphereModel s;
  TriangleMesh mesh = render_testing::Icosphere(1.0, Eigen::Vector3d::Zero(), 3);
  s.scene = std::make_unique<Scene>(ModelSurfaces(mesh, LambertianModel(Eigen::Vector3d::Constant(albedo)),
                                                  TriangleMesh(), 0.35),
                                    "sphere");
  s.visibility.resolution = 32;
  std::vector<float> ones(32 * 32, 1.0f), coeffs(32 * 32);
  HaarForward(ones.data(), 32, coeffs.data());
  s.visibility.per_vertex.assign(mesh.num_vertices(), SparseFromDense(coeffs.data(), 32));
  return s;
}

// Max over sphere vertices of |rendered − closed form| relative to the peak, for a sun at `sun`.
double WorstSunError(const SphereModel& model, const Lighting& lighting, const Eigen::Vector3d& sun, double e,
                     double albedo) {
  TransportRenderer renderer(*model.scene, model.visibility, 32);
  const TriangleMesh& mesh = model.scene->surface(0).mesh;
  const double peak = albedo / M_PI * e;
  double worst = 0;
  for (size_t v = 0; v < mesh.num_vertices(); ++v) {
    const Eigen::Vector3d n = mesh.normals[v].cast<double>();
    const double c = n.dot(sun);
    if (std::abs(c) < 0.3) continue;  // the terminator, where the filtered blob's width shows
    // The faint sky adds ρ · 0.01 · (1 + n_z)/2 ... bounded by ρ · 0.01: part of the tolerance below.
    const double expected = peak * std::max(0.0, c);
    const double got = renderer.VertexRadiance(lighting, 0, int(v), n.cast<float>()).mean();
    worst = std::max(worst, std::abs(got - expected) / peak);
  }
  return worst;
}

TEST(RenderCameras, SunInABlenderMapLightsTheSphereWhereBlenderPutsIt) {
  const testing::TempDir dir;
  const Eigen::Vector3d sun = Direction(60, 35);
  const double e = 3.0, albedo = 0.6;
  WriteExr((dir / "sun_blender.exr"), BlenderSunMap(sun, e));
  const SphereModel model = LambertianSphere(albedo);
  auto lighting = [&](EnvmapConvention c, double rotate, double strength) {
    return Lighting::FromEnvMap(LoadEnvmapInConvention((dir / "sun_blender.exr"), c, rotate, strength));
  };
  // Within 5 % of the peak: the faint sky (1 %) and the model's own resolution, a blob narrower than a texel
  // of the 32² octahedral map it is filtered to (up to 4 % depending on where it falls between texels; the
  // Monte Carlo renderer has no such limit).
  EXPECT_LT(WorstSunError(model, lighting(EnvmapConvention::kBlender, 0, 1), sun, e, albedo), 0.05);
  EXPECT_LT(WorstSunError(model, lighting(EnvmapConvention::kBlender, 30, 1), Direction(90, 35), e, albedo), 0.05);
  EXPECT_LT(WorstSunError(model, lighting(EnvmapConvention::kBlender, 0, 2), sun, 2 * e, albedo), 0.05);
  // Read as the project's convention the sun is mirrored and turned (azimuth 180° − 60° = 120°): far off.
  EXPECT_GT(WorstSunError(model, lighting(EnvmapConvention::kRelight, 0, 1), sun, e, albedo), 0.3);
  EXPECT_LT(WorstSunError(model, lighting(EnvmapConvention::kRelight, 0, 1), Direction(120, 35), e, albedo), 0.05);
}

TEST(RenderCameras, RendersEveryCameraOfAModelIntoFiles) {
  const testing::TempDir dir;
  const Eigen::Vector3d sun = Direction(60, 35);
  WriteExr((dir / "sun.exr"), BlenderSunMap(sun, 3.0, 256));
  // The recovered model: a Lambertian sphere (reflectance.ply with one material weight, materials.json).
  TriangleMesh mesh = render_testing::Icosphere(1.0, Eigen::Vector3d::Zero(), 3);
  mesh.Property("w0").assign(mesh.num_vertices(), 1.0f);
  EnsureDir((dir / "inverse"));
  WriteMeshPly((dir / "inverse/reflectance.ply"), mesh);
  WriteReflectanceModel((dir / "inverse/materials.json"), LambertianModel(Eigen::Vector3d::Constant(0.6)));
  const SphereModel model = LambertianSphere(0.6);
  EnsureDir((dir / "visibility"));
  WriteVisibility((dir / "visibility/visibility.bin"), model.visibility);
  // Two cameras: one towards the sun's side, one towards the far side.
  Reconstruction cameras;
  cameras.cameras[1] = Camera::Pinhole(1, 64, 48, 60, 60, 32, 24);
  for (int k = 0; k < 2; ++k) {
    ImageRecord image;
    image.image_id = k + 1;
    image.camera_id = 1;
    image.name = k == 0 ? "lit.jpg" : "dark.jpg";
    const Eigen::Vector3d eye = 5 * (k == 0 ? Direction(60, 20) : Direction(240, 20));
    image.SetPose(LookAtCamFromWorld(eye, Eigen::Vector3d::Zero()), eye);
    cameras.images[image.image_id] = image;
  }
  EnsureDir((dir / "cameras"));
  cameras.WriteText((dir / "cameras"));
  RenderCamerasRequest r;
  r.inverse_dir = (dir / "inverse");
  r.visibility_dir = (dir / "visibility");
  r.cameras_dir = (dir / "cameras");
  r.envmap = (dir / "sun.exr");
  r.convention = EnvmapConvention::kBlender;
  r.output_dir = (dir / "out");
  r.background = false;
  const RenderCamerasSummary summary = RenderCameras(r);
  ASSERT_EQ(summary.images.size(), 2u);
  const Json index = ReadJsonFile((dir / "out/render_summary.json"));
  EXPECT_EQ(index.at("convention"), "blender");
  double mean[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const RenderedCamera& image = summary.images[k];
    const Image radiance = ReadImage(JoinPath(r.output_dir, image.exr));
    const Image mask = ReadImage(JoinPath(r.output_dir, image.mask));
    EXPECT_TRUE(fs::is_regular_file(JoinPath(r.output_dir, image.png)));
    ASSERT_EQ(radiance.width, 64);
    size_t count = 0;
    for (int y = 0; y < radiance.height; ++y)
      for (int x = 0; x < radiance.width; ++x)
        if (mask.at(x, y) > 0.5f) {
          mean[image.name == "lit.jpg" ? 0 : 1] += radiance.at(x, y, 0);
          ++count;
        }
    ASSERT_GT(count, 300u);  // a disc of about 12 px radius
    mean[image.name == "lit.jpg" ? 0 : 1] /= count;
  }
  // Seen from the sun's side the sphere is lit; from the far side only the faint sky and a thin lit crescent
  // reach the camera.
  EXPECT_GT(mean[0], 5 * mean[1]);
  // A missing camera folder names it and what to give.
  r.cameras_dir = (dir / "nowhere");
  EXPECT_NE(testing::ErrorOf([&] { RenderCameras(r); }).find("COLMAP model"), std::string::npos);
}

}  // namespace
}  // namespace relight

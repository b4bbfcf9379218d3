// Stage-level test of `synthesize`: runs build/bin/synthesize on a small config
// and checks that the ground truth is complete and consistent with itself and
// with the photos:
//  - every file of docs/FORMATS.md "Ground truth folder" is there, with the right sizes;
//  - GT mesh vertices visible from a GT camera project onto the object mask, at
//    the depth the depth map holds;
//  - the linear render at a vertex equals the renderer's exitant radiance of that
//    vertex (scene rebuilt from the GT files, lit by the GT env map);
//  - the JPEG, with sRGB, exposure and white balance undone, equals the linear
//    render where nothing clipped (up to sensor noise and JPEG);
//  - EXIF focal lengths give the GT focal lengths;
//  - relighting references agree with the renderer under the held-out maps;
//  - a missing mesh or env map file is a user error naming the file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/fs.h"
#include "core/json.h"
#include "geometry/mesh_io.h"
#include "geometry/reconstruction.h"
#include "image/image.h"
#include "render/render_view.h"
#include "synth/cameras.h"
#include "synth/photography.h"
#include "testing/testing.h"

namespace relight {
namespace {

namespace fs = std::filesystem;

struct StageRun {
  testing::TempDir dir;
  std::string out;
  int status = -1;
  std::string log;
};

std::string EnvMapPath() {
  return testing::HasSharedData("envmaps/uffizi.hdr") ? testing::SharedDataDir() + "/envmaps/uffizi.hdr" : "";
}

void RunStage(StageRun* r);

// One run of the stage shared by the tests (about 5 s); its folder is removed at exit.
StageRun& Synthesized() {
  static StageRun run;
  static const bool done = (RunStage(&run), true);
  (void)done;
  return run;
}

void RunStage(StageRun* r) {
  {
    const std::string env = EnvMapPath();
    std::ofstream config(r->dir / "config.yaml");
    config << "synthesize:\n"
           << "  num_photos: 4\n"
           << "  image_size_min: 150\n"
           << "  image_size_max: 180\n"
           << "  object_vertices: 30000\n"
           << "  ground_cells: 96\n"
           << "  num_blockers: 1\n"
           << "  envmap_height: 64\n"
           << "  gt_oct_size: 16\n"
           << (env.empty() ? "" : "  envmaps: [" + env + "]\n") << "  transient_fraction: 0.25\n"
           << "  light_samples: 16\n"
           << "  brdf_samples: 16\n"
           << "  relight_views: 1\n"
           << "  relight_skies: 1\n"
           << "  relight_image_size: 96\n"
           << "  relight_pixel_samples_per_axis: 2\n"
           << "  relight_light_samples: 16\n"
           << "  relight_brdf_samples: 16\n";
    config.close();
    r->out = r->dir / "out";
    r->status = testing::RunCommand(
        testing::BinDir() + "/synthesize --config " + (r->dir / "config.yaml") + " --output " + r->out, &r->log);
  }
}

std::string Gt(const std::string& relative) { return Synthesized().out + "/ground_truth/" + relative; }

Scene GroundTruthScene() {
  std::vector<Scene::Surface> surfaces;
  surfaces.push_back({ReadMesh(Gt("mesh.ply")), ReadReflectanceModel(Gt("materials.json")), SurfaceRole::kObject});
  surfaces.push_back(
      {ReadMesh(Gt("occluders.ply")), ReadReflectanceModel(Gt("occluder_materials.json")), SurfaceRole::kOccluder});
  return Scene(std::move(surfaces), "ground truth");
}

// Visible vertices: the segment from the camera to the vertex is free (up to a small margin).
std::vector<int> VisibleVertices(const Scene& scene, const ImageRecord& image, int stride, float min_cos = 0.05f) {
  std::vector<int> out;
  const TriangleMesh& mesh = scene.surface(0).mesh;
  const Eigen::Vector3f c = image.ProjectionCenter().cast<float>();
  for (int v = 0; v < int(mesh.num_vertices()); v += stride) {
    const Eigen::Vector3f d = mesh.vertices[v] - c;
    if (d.dot(mesh.normals[v]) > -min_cos * d.norm()) continue;  // back-facing or grazing
    Ray ray;
    ray.origin = c;
    ray.dir = d;
    ray.t_far = 1.0f - 1e-4f;
    if (!scene.caster().Occluded(ray)) out.push_back(v);
  }
  return out;
}

bool InteriorOf(const Image& mask, int x, int y, int r) {
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      const int xx = x + dx, yy = y + dy;
      if (xx < 0 || yy < 0 || xx >= mask.width || yy >= mask.height || mask.at(xx, yy) < 0.5f) return false;
    }
  return true;
}

// The pixels around `pixel` (radius r) all see the object on the same surface patch as the vertex at
// `point_cam` (camera frame): their depth-map points lie within a few pixel footprints of it in 3D
// (allowing surfaces tilted up to about 70 degrees), so a pixel value there is a local average of that
// patch, not of a strand behind it.
bool SamePatch(const Camera& camera, const Image& mask, const Image& depth, const Eigen::Vector2d& pixel,
               const Eigen::Vector3d& point_cam, int r) {
  const int x = int(pixel.x()), y = int(pixel.y());
  if (!InteriorOf(mask, x, y, r)) return false;
  const double footprint = point_cam.z() / camera.FocalX();
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      const Eigen::Vector3d ray = camera.RayFromImage({x + dx + 0.5, y + dy + 0.5});
      const Eigen::Vector3d p = ray / ray.z() * depth.at(x + dx, y + dy);
      if ((p - point_cam).norm() > 3.0 * (std::abs(dx) + std::abs(dy) + 1.5) * footprint) return false;
    }
  return true;
}

// Compares a linear render with the renderer's vertex radiance over vertices seen frontally whose
// pixel neighbourhood lies on their own surface patch, by z-scores: the vertex estimate's standard
// error, and the pixel's, inferred from it by the sample counts (an upper bound: the bilinear lookup
// averages up to four pixels). Both use 16 + 16 samples per shading point, so per-sample variances
// carry over; a pixel averages `pixel_rays` camera rays.
struct RadianceCheck {
  int vertices = 0;
  double median_abs_z = 0;   // median over vertices of |pixel - vertex| / combined standard error
  double relative_bias = 0;  // sum(pixel - vertex) / sum(vertex)
  double relative_se = 0;    // standard error of relative_bias from the Monte Carlo noise
};
RadianceCheck CheckRadiance(const Scene& scene, const Reconstruction& model, const ImageRecord& image,
                            const Image& mask, const Image& depth, const Image& linear, const Lighting& light,
                            int pixel_rays, int stride) {
  RenderOptions options;
  options.light_samples = 16;
  options.brdf_samples = 16;
  const int estimates = 8;
  const double pixel_to_vertex_samples = double(pixel_rays) / estimates;
  double sum_difference = 0, sum_variance = 0, sum_vertex = 0;
  std::vector<double> abs_z;
  for (int v : VisibleVertices(scene, image, stride, 0.3f)) {
    Eigen::Vector2d pixel;
    const Eigen::Vector3d position = scene.surface(0).mesh.vertices[v].cast<double>();
    if (!model.Project(image, position, &pixel)) continue;
    if (!SamePatch(model.cameras.at(image.camera_id), mask, depth, pixel, image.CamFromWorld(position), 2)) continue;
    float rgb[3];
    SampleBilinear(linear, pixel.x(), pixel.y(), rgb);
    const Eigen::Vector3d dir = (image.ProjectionCenter() - position).normalized();
    const RadianceEstimate est = VertexRadiance(scene, light, 0, v, dir, options, estimates);
    const double difference = Luminance(Eigen::Vector3d(rgb[0], rgb[1], rgb[2])) - Luminance(est.mean);
    const double se = Luminance(est.std_error);
    const double variance = se * se * (1 + 1 / pixel_to_vertex_samples);
    sum_difference += difference;
    sum_variance += variance;
    sum_vertex += Luminance(est.mean);
    abs_z.push_back(std::abs(difference) / std::sqrt(variance + 1e-30));
  }
  RadianceCheck check;
  check.vertices = int(abs_z.size());
  if (abs_z.empty()) return check;
  std::sort(abs_z.begin(), abs_z.end());
  check.median_abs_z = abs_z[abs_z.size() / 2];
  check.relative_bias = sum_difference / sum_vertex;
  check.relative_se = std::sqrt(sum_variance) / sum_vertex;
  return check;
}

TEST(SynthesizeStageTest, RunsAndWritesEveryGroundTruthFile) {
  const StageRun& run = Synthesized();
  ASSERT_EQ(run.status, 0) << run.log;
  for (const char* f :
       {"cameras.txt", "images.txt", "points3D.txt", "mesh.ply", "occluders.ply", "materials.json",
        "occluder_materials.json", "lighting.json", "relight/index.json", "relight/cameras.txt", "relight/images.txt"})
    EXPECT_TRUE(fs::exists(Gt(f))) << f;
  EXPECT_TRUE(fs::exists(run.out + "/summary.json"));
  const Reconstruction model = Reconstruction::ReadText(Gt(""));
  ASSERT_EQ(model.images.size(), 4u);
  const Json lighting = ReadJsonFile(Gt("lighting.json"));
  ASSERT_EQ(lighting["photos"].size(), 4u);
  int transient = 0;
  for (const auto& [id, image] : model.images) {
    const Camera& camera = model.cameras.at(image.camera_id);
    const std::string stem = fs::path(image.name).stem().string();
    ImageMetadata meta;
    const Image photo = ReadImage(run.out + "/images/" + image.name, &meta);
    EXPECT_EQ(photo.width, camera.width);
    EXPECT_EQ(photo.height, camera.height);
    // EXIF carries the exact 35 mm-equivalent focal length.
    ASSERT_TRUE(meta.focal_length_35mm.has_value());
    EXPECT_NEAR(FocalPixelsFrom35mm(*meta.focal_length_35mm, camera.width, camera.height), camera.FocalX(), 1e-6);
    for (const std::string& f : {"linear/" + stem + ".exr", "depth/" + stem + ".exr", "masks/" + stem + ".png"}) {
      const Image im = ReadImage(Gt(f));
      EXPECT_EQ(im.width, camera.width) << f;
      EXPECT_EQ(im.height, camera.height) << f;
    }
    const Image latlong = ReadImage(Gt("envmaps/" + stem + "_latlong.exr"));
    EXPECT_EQ(latlong.width, 128);
    EXPECT_EQ(latlong.height, 64);
    const Image oct = ReadImage(Gt("envmaps/" + stem + "_oct.exr"));
    EXPECT_EQ(oct.width, 16);
    EXPECT_EQ(oct.height, 16);
    // The octahedral map is the same light: equal integrals over the sphere.
    const Eigen::Vector3d a = EnvMap::FromLatLong(latlong).Integral(), b = EnvMap::FromOctahedral(oct).Integral();
    // (16 x 16 texel averages of 4 x 4 samples each smear a one-pixel sun: a few percent.)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 0.03 * a[c]) << stem;
    const Json& entry = *std::find_if(lighting["photos"].begin(), lighting["photos"].end(),
                                      [&](const Json& p) { return p["name"] == image.name; });
    EXPECT_GT(entry["exposure"].get<double>(), 0);
    EXPECT_EQ(entry["white_balance"].size(), 3u);
    EXPECT_EQ(entry["envmap_latlong"], "envmaps/" + stem + "_latlong.exr");
    transient += entry["transient_occluder"].get<bool>();
  }
  EXPECT_EQ(transient, 1);
  if (!EnvMapPath().empty()) {
    int files = 0;
    for (const auto& p : lighting["photos"]) files += p["environment"]["source"] == "file";
    EXPECT_EQ(files, 2);
  }
  const Json index = ReadJsonFile(Gt("relight/index.json"));
  ASSERT_EQ(index["renders"].size(), 1u);
  for (const auto& r : index["renders"]) {
    const Image im = ReadImage(Gt("relight/" + r["image"].get<std::string>()));
    EXPECT_EQ(im.width, 96);
    EXPECT_TRUE(fs::exists(Gt("relight/" + r["mask"].get<std::string>())));
    EXPECT_TRUE(fs::exists(Gt("relight/envmaps/" + r["envmap"].get<std::string>() + "_latlong.exr")));
  }
}

TEST(SynthesizeStageTest, VerticesProjectOntoMaskAtTheirDepth) {
  ASSERT_EQ(Synthesized().status, 0);
  const Scene scene = GroundTruthScene();
  const Reconstruction model = Reconstruction::ReadText(Gt(""));
  const Json lighting = ReadJsonFile(Gt("lighting.json"));
  for (const auto& p : lighting["photos"]) {
    const ImageRecord& image = *model.FindImage(p["name"]);
    const std::string stem = fs::path(image.name).stem().string();
    const Image mask = ReadImage(Gt("masks/" + stem + ".png"));
    const Image depth = ReadImage(Gt("depth/" + stem + ".exr"));
    const bool transient = p["transient_occluder"].get<bool>();
    int on_mask = 0, total = 0, depth_checked = 0;
    std::vector<double> depth_error;
    for (int v : VisibleVertices(scene, image, 3)) {
      Eigen::Vector2d pixel;
      double z;
      ASSERT_TRUE(model.Project(image, scene.surface(0).mesh.vertices[v].cast<double>(), &pixel, &z));
      const int x = int(std::floor(pixel.x())), y = int(std::floor(pixel.y()));
      if (x < 1 || y < 1 || x + 1 >= mask.width || y + 1 >= mask.height) continue;
      ++total;
      bool hit = false;  // within one pixel of the mask (silhouette vertices)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) hit |= mask.at(x + dx, y + dy) > 0.5f;
      on_mask += hit;
      // Depth: bilinear between four object pixels around the projection.
      const int x0 = int(std::floor(pixel.x() - 0.5)), y0 = int(std::floor(pixel.y() - 0.5));
      if (x0 < 0 || y0 < 0 || x0 + 1 >= mask.width || y0 + 1 >= mask.height) continue;
      if (!(mask.at(x0, y0) > 0.5f && mask.at(x0 + 1, y0) > 0.5f && mask.at(x0, y0 + 1) > 0.5f &&
            mask.at(x0 + 1, y0 + 1) > 0.5f))
        continue;
      float d;
      SampleBilinear(depth, pixel.x(), pixel.y(), &d);
      depth_error.push_back(std::abs(d - z) / z);
      ++depth_checked;
    }
    ASSERT_GT(total, 100) << stem;
    // A transient occluder hides some visible-to-the-static-scene vertices.
    EXPECT_GE(on_mask, (transient ? 0.5 : 0.99) * total) << stem;
    ASSERT_GT(depth_checked, 50) << stem;
    std::sort(depth_error.begin(), depth_error.end());
    // Depth varies across a pixel by slope x half a pixel; the median error is far below that.
    EXPECT_LT(depth_error[depth_error.size() / 2], 2e-3) << stem;
    if (!transient) {
      EXPECT_LT(depth_error[depth_error.size() * 9 / 10], 2e-2) << stem;
    }
  }
}

TEST(SynthesizeStageTest, LinearRenderMatchesVertexRadianceAndPhotoMatchesLinear) {
  ASSERT_EQ(Synthesized().status, 0);
  const Scene scene = GroundTruthScene();
  const Reconstruction model = Reconstruction::ReadText(Gt(""));
  const Json lighting = ReadJsonFile(Gt("lighting.json"));
  for (const auto& p : lighting["photos"]) {
    if (p["transient_occluder"].get<bool>()) continue;
    const ImageRecord& image = *model.FindImage(p["name"]);
    const std::string stem = fs::path(image.name).stem().string();
    const Image mask = ReadImage(Gt("masks/" + stem + ".png"));
    const Image linear = ReadImage(Gt("linear/" + stem + ".exr"));
    const Image depth = ReadImage(Gt("depth/" + stem + ".exr"));
    const Lighting light = Lighting::FromEnvMap(EnvMap::Load(Gt("envmaps/" + stem + "_latlong.exr")));
    // (1) The linear render at a vertex is the renderer's radiance of that vertex under the GT map.
    const RadianceCheck check = CheckRadiance(scene, model, image, mask, depth, linear, light, 2 * 2, 3);
    ASSERT_GT(check.vertices, 40) << stem;
    // Pure noise gives a median |z| of 0.67; the pixel footprint (texture and shading gradients over
    // a pixel) adds to it: 0.67 to 1.15 over seeds 1 to 5.
    EXPECT_LT(check.median_abs_z, 1.5) << stem;
    // No bias beyond the footprint's: a pixel averages the surface over its footprint and the bilinear
    // lookup over four pixels, which lowers values where shading is concave (lit convex surfaces) by
    // about a percent; allow 2% plus 3 standard errors of the noise.
    EXPECT_LT(std::abs(check.relative_bias), 0.02 + 3 * check.relative_se) << stem;
    RecordProperty(stem + "_radiance_median_abs_z", std::to_string(check.median_abs_z));
    RecordProperty(stem + "_radiance_relative_bias", std::to_string(check.relative_bias));

    // (2) The JPEG with sRGB, exposure and white balance undone vs the linear render, where unclipped.
    const Image photo = ReadImage(Synthesized().out + "/images/" + image.name);
    const double exposure = p["exposure"].get<double>();
    const Eigen::Vector3d wb(p["white_balance"][0].get<double>(), p["white_balance"][1].get<double>(),
                             p["white_balance"][2].get<double>());
    double signed_error = 0;
    std::vector<double> abs_error;
    for (int y = 0; y < photo.height; ++y)
      for (int x = 0; x < photo.width; ++x)
        for (int c = 0; c < 3; ++c) {
          const double sensor = exposure * wb[c] * linear.at(x, y, c);
          if (sensor > 0.9 || sensor < 0.05) continue;  // clipped, or dominated by quantisation
          const double undone = SrgbDecode(photo.at(x, y, c));
          signed_error += undone - sensor;
          abs_error.push_back(std::abs(undone - sensor) / sensor);
        }
    ASSERT_GT(abs_error.size(), 1000u);
    std::sort(abs_error.begin(), abs_error.end());
    // Sensor noise (sigma ~ 0.01 at 0.2) and JPEG: a few percent typical, no bias. The default
    // mosaic ground has sharp cell edges where JPEG's 8x8 blocks ring: medians measured 0.050-0.065
    // over this test's photos (photo_003 the highest), so the bound is 0.08.
    EXPECT_LT(abs_error[abs_error.size() / 2], 0.08) << stem;
    RecordProperty(stem + "_jpeg_median_relative_error", std::to_string(abs_error[abs_error.size() / 2]));
    EXPECT_LT(std::abs(signed_error / abs_error.size()), 0.004) << stem;
  }
}

TEST(SynthesizeStageTest, RelightingReferencesMatchTheRenderer) {
  ASSERT_EQ(Synthesized().status, 0);
  const Scene scene = GroundTruthScene();
  const Reconstruction views = Reconstruction::ReadText(Gt("relight"));
  const Json index = ReadJsonFile(Gt("relight/index.json"));
  for (const auto& r : index["renders"]) {
    const ImageRecord& image = *views.FindImage(r["view"]);
    const Image mask = ReadImage(Gt("relight/" + r["mask"].get<std::string>()));
    const Image depth = ReadImage(Gt("relight/" + r["depth"].get<std::string>()));
    const Image linear = ReadImage(Gt("relight/" + r["image"].get<std::string>()));
    const Lighting light =
        Lighting::FromEnvMap(EnvMap::Load(Gt("relight/envmaps/" + r["envmap"].get<std::string>() + "_latlong.exr")));
    const RadianceCheck check = CheckRadiance(scene, views, image, mask, depth, linear, light, 2 * 2, 2);
    ASSERT_GT(check.vertices, 40);
    EXPECT_LT(check.median_abs_z, 1.5);
    EXPECT_LT(std::abs(check.relative_bias), 0.02 + 3 * check.relative_se);
    RecordProperty(r["image"].get<std::string>() + "_relative_bias", std::to_string(check.relative_bias));
  }
}

TEST(SynthesizeStageTest, MissingFilesAreUserErrorsNamingTheFile) {
  testing::TempDir dir;
  for (const std::string& key : {std::string("mesh"), std::string("envmaps")}) {
    const std::string missing = dir / ("no_such_" + key + (key == "mesh" ? ".obj" : ".hdr"));
    const std::string value = key == "mesh" ? missing : "[" + missing + "]";
    {
      std::ofstream config(dir / "c.yaml");
      config << "synthesize:\n  " << key << ": " << value << "\n  num_photos: 1\n";
    }
    std::string log;
    const int status = testing::RunCommand(
        testing::BinDir() + "/synthesize --config " + (dir / "c.yaml") + " --output " + (dir / ("out_" + key)), &log);
    EXPECT_EQ(status, 2) << log;
    EXPECT_NE(log.find("no_such_" + key), std::string::npos) << log;
  }
  // A bad value names the key.
  std::string log;
  const int status = testing::RunCommand(
      testing::BinDir() + "/synthesize --set synthesize.num_photos=0 --output " + (dir / "out_bad"), &log);
  EXPECT_EQ(status, 2) << log;
  EXPECT_NE(log.find("num_photos"), std::string::npos) << log;
}

}  // namespace
}  // namespace relight

// The relight stage: tone map and camera helpers against closed forms, and the
// stage on a scene whose model frame differs from the ground truth's by a
// known similarity: its held-out renders and re-renderings must agree with
// ground-truth-frame renders of the same scene within Monte Carlo noise (and
// must not agree when the frame change is ignored), and a rerun must resume.
#include "relight/relight.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "datasets/ground_truth.h"
#include "datasets/ground_truth_frame.h"
#include "geometry/mesh_io.h"
#include "relight/display.h"
#include "relight/views.h"
#include "render/render_view.h"
#include "render/test_scenes.h"
#include "sphere/octahedral.h"
#include "sphere/sky.h"
#include "testing/testing.h"
#include "visibility/visibility.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

TEST(Display, PercentileExposureAndSrgbCurve) {
  // Grey pixels of luminance 1 … 100: the 99th percentile interpolates to 99.01.
  Image image(100, 1, 3);
  for (int x = 0; x < 100; ++x)
    for (int c = 0; c < 3; ++c) image.at(x, 0, c) = float(x + 1);
  EXPECT_NEAR(PercentileExposure(image, nullptr, 99), 1.0 / 99.01, 1e-6);
  EXPECT_NEAR(PercentileExposure(image, nullptr, 100), 1.0 / 100, 1e-9);
  Image mask(100, 1, 1);
  for (int x = 0; x < 10; ++x) mask.at(x, 0) = 1;  // luminances 1 … 10
  EXPECT_NEAR(PercentileExposure(image, &mask, 50), 1.0 / 5.5, 1e-6);
  // IEC 61966-2-1.
  EXPECT_NEAR(SrgbEncode(0.5), 1.055 * std::pow(0.5, 1 / 2.4) - 0.055, 1e-12);
  EXPECT_NEAR(SrgbEncode(0.002), 12.92 * 0.002, 1e-12);
  EXPECT_EQ(SrgbEncode(7.0), 1.0);
  const Image mapped = ToneMapSrgb(image, 1.0 / 100);
  EXPECT_NEAR(mapped.at(49, 0, 1), SrgbEncode(0.5), 1e-6);
  // Erosion by one pixel removes a 1-pixel border.
  Image block(10, 10, 1);
  for (int y = 2; y < 8; ++y)
    for (int x = 2; x < 8; ++x) block.at(x, y) = 1;
  EXPECT_EQ(CountMask(ErodeMask(block, 1)), 16u);
  EXPECT_EQ(CountMask(ErodeMask(block, 0)), 36u);
}

using testing::ErrorOf;

TEST(Envmaps, EntriesThatAreNotUsableMapsNameTheEntryAndWhatToDo) {
  testing::TempDir dir;
  fs::create_directories(dir / "maps");
  EXPECT_EQ(ErrorOf([&] { LoadRelightEnvmaps({dir / "maps"}); }),
            "relight.envmaps: '" + (dir / "maps") + "' is a folder; list the map files in it (.exr/.hdr), one entry each");
  EXPECT_EQ(ErrorOf([&] { LoadRelightEnvmaps({dir / "sky.exr"}); }),
            "relight.envmaps: '" + (dir / "sky.exr") +
                "' does not exist; fix the path (relative to the config file) or remove the entry");
  std::ofstream(dir / "text.exr") << "not an image";
  const std::string unreadable = ErrorOf([&] { LoadRelightEnvmaps({dir / "text.exr"}); });
  EXPECT_EQ(unreadable.rfind("relight.envmaps: '" + (dir / "text.exr") + "' is not a readable image (", 0), 0u)
      << unreadable;
  EXPECT_EQ(unreadable.find("folder"), std::string::npos) << unreadable;  // said "remove it from the folder"
  Image map(16, 8, 3, 1.0f);
  map.at(3, 2, 0) = std::nanf("");
  WriteImage(dir / "nan.exr", map, {PixelType::kFloat});
  EXPECT_EQ(ErrorOf([&] { LoadRelightEnvmaps({dir / "nan.exr"}); }),
            "relight.envmaps: environment map " + (dir / "nan.exr") +
                " has 1 NaN or infinite value (the first at pixel (3, 2), channel 0: nan); radiance must be "
                "finite: repair or replace the map; or remove the entry from relight.envmaps");
  map.at(3, 2, 0) = 1.0f;
  WriteImage(dir / "good.exr", map, {PixelType::kFloat});
  EXPECT_EQ(LoadRelightEnvmaps({dir / "good.exr"}).size(), 1u);
}

// A sun the inverse stage solved as its own light sits in the one texel around its direction: re-renderings take
// exactly its irradiance out of that texel (the sky left as it was) and trace it as a delta light.
TEST(SolvedSun, TakesTheSunsIrradianceOutOfItsTexel) {
  const int n = 32;
  const Eigen::Vector3d sky_rgb(0.2, 0.3, 0.5), e(4.0, 3.5, 3.0);
  const Eigen::Vector3d d = Eigen::Vector3d(0.3, -0.5, 0.6).normalized();
  Image oct(n, n, 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) oct.at(i, j, c) = static_cast<float>(sky_rgb[c]);
  const Eigen::Vector2i t = OctTexelOf(d, n);
  const double omega = OctTexelSolidAngle(t.x(), t.y(), n);
  for (int c = 0; c < 3; ++c) oct.at(t.x(), t.y(), c) += static_cast<float>(e[c] / omega);
  const Json entry = {{"sun", {{"direction_world", {d.x(), d.y(), d.z()}}, {"irradiance_rgb", {e.x(), e.y(), e.z()}}}}};
  Image sky;
  const std::optional<DirectionalLight> sun = SolvedSun(entry, oct, &sky);
  ASSERT_TRUE(sun.has_value());
  EXPECT_LT((sun->dir_world - d).norm(), 1e-12);
  EXPECT_LT((sun->irradiance_rgb - e).norm(), 1e-12);
  Eigen::Vector3d taken = Eigen::Vector3d::Zero();
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(sky.at(i, j, c), sky_rgb[c], 1e-5 * e[c] / omega) << i << " " << j;
        taken[c] += (oct.at(i, j, c) - sky.at(i, j, c)) * OctTexelSolidAngle(i, j, n);
      }
  EXPECT_LT((taken - e).norm(), 1e-5 * e.norm()) << "the sun's irradiance, all of it and nothing more";
  // The daylight model's fitted sun alone (no irradiance solved), a malformed entry, no entry: no sun, no change.
  Image untouched;
  EXPECT_FALSE(SolvedSun(Json{{"sun", {{"direction_world", {0, 0, 1}}, {"irradiance_share", 0.7}}}}, oct, &untouched));
  EXPECT_FALSE(SolvedSun(Json{{"sun", {{"direction_world", {0, 0, 1}}, {"irradiance_rgb", {1, 2}}}}}, oct, &untouched));
  EXPECT_FALSE(
      SolvedSun(Json{{"sun", {{"direction_world", {0, 0, 0}}, {"irradiance_rgb", {1, 2, 3}}}}}, oct, &untouched));
  EXPECT_FALSE(
      SolvedSun(Json{{"sun", {{"direction_world", {0, 0, 1}}, {"irradiance_rgb", {1, -2, 3}}}}}, oct, &untouched));
  EXPECT_FALSE(SolvedSun(Json::object(), oct, &untouched));
  EXPECT_EQ(untouched.width, 0);
}

TEST(Views, OrbitCameraFramesTheBoundingSphere) {
  const Eigen::Vector3d center(1, 2, 3);
  const double radius = 0.5, fov = 40, fill = 0.8;
  const int size = 200;
  const RenderCamera v = OrbitCamera("v", center, radius, 30, 25, size, fov, fill);
  // The centre projects to the image centre, world up points up the image.
  const Eigen::Vector2d c = v.camera.ImageFromCamera(v.pose.CamFromWorld(center));
  EXPECT_NEAR(c.x(), 100, 1e-9);
  EXPECT_NEAR(c.y(), 100, 1e-9);
  EXPECT_LT(v.camera.ImageFromCamera(v.pose.CamFromWorld(center + Eigen::Vector3d(0, 0, 0.1))).y(), 100);
  // The silhouette (half-angle asin(r/d)) spans `fill` of the half image.
  const double d = (v.pose.ProjectionCenter() - center).norm();
  EXPECT_NEAR(v.camera.FocalX() * std::tan(std::asin(radius / d)), fill * size / 2, 1e-9);
  // Azimuth and elevation of the camera centre.
  const Eigen::Vector3d dir = (v.pose.ProjectionCenter() - center).normalized();
  EXPECT_NEAR(std::asin(dir.z()) * 180 / M_PI, 25, 1e-9);
  EXPECT_NEAR(std::atan2(dir.y(), dir.x()) * 180 / M_PI, 30, 1e-9);
}

TEST(Views, CameraJsonRoundTrip) {
  const RenderCamera v = OrbitCamera("v", Eigen::Vector3d(0, 0, 1), 1, 77, -10, 64, 50, 0.7);
  const RenderCamera w = CameraFromJson(CameraToJson(v.camera, v.pose), "test");
  EXPECT_EQ(w.camera.model, "PINHOLE");
  EXPECT_EQ(w.camera.width, 64);
  EXPECT_NEAR((w.pose.ProjectionCenter() - v.pose.ProjectionCenter()).norm(), 0, 1e-12);
  EXPECT_NEAR((w.pose.CamFromWorldRotation() - v.pose.CamFromWorldRotation()).norm(), 0, 1e-12);
  EXPECT_THROW(CameraFromJson(Json{{"model", "PINHOLE"}}, "broken.json"), UserError);
}

// A similarity between the ground truth's frame and a model frame.
Sim3 TruthFromModel() {
  Sim3 t;
  t.scale = 0.5;
  t.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  t.translation = Eigen::Vector3d(0.3, -0.2, 1.0);
  return t;
}

TEST(GroundTruthFrame, EnvironmentMapsAndPosesChangeFrame) {
  GroundTruthFrame frame;
  frame.available = true;
  frame.method = "similarity";
  frame.truth_from_model = TruthFromModel();
  Image ll(64, 32, 3, 0.1f);
  ll.at(10, 8, 0) = 50;  // a bright spot
  const EnvMap truth = EnvMap::FromLatLong(ll);
  const EnvMap model = frame.EnvToModel(truth);
  const EnvMap back = frame.EnvToTruth(model);
  for (const Eigen::Vector3d& d : {Eigen::Vector3d(0.3, -0.5, 0.8), Eigen::Vector3d(-1, 0.2, 0.1)}) {
    EXPECT_NEAR((model.Lookup(d) - truth.Lookup(frame.rotation() * d)).norm(), 0, 1e-9);
    EXPECT_NEAR((back.Lookup(d) - truth.Lookup(d)).norm(), 0, 1e-9);
  }
  // A model-frame camera sees a model point where its truth-frame pose sees the mapped point.
  const RenderCamera v = OrbitCamera("v", Eigen::Vector3d(0, 0, 0), 1, 10, 20, 64, 40, 0.8);
  const ImageRecord t = frame.PoseToTruth(v.pose);
  const Eigen::Vector3d p(0.2, -0.1, 0.3);
  const Eigen::Vector3d a = v.pose.CamFromWorld(p), b = t.CamFromWorld(frame.truth_from_model.Apply(p));
  EXPECT_NEAR((a.head<2>() / a.z() - b.head<2>() / b.z()).norm(), 0, 1e-12);
}

// Writes a whole set of stage folders for a sphere on a plane under a sun sky:
// ground truth in the truth frame, sfm/mesh/inverse outputs in a model frame.
class RelightStageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    setenv("RELIGHT_PROGRESS", "off", 1);
    InitLogging("relight_test", "", LogLevel::kWarning);
    const Sim3 truth_from_model = TruthFromModel();
    const Sim3 model_from_truth = truth_from_model.Inverse();
    // Truth-frame scene: a two-material sphere on a grey plane.
    sphere_ = render_testing::Icosphere(0.5, Eigen::Vector3d(0, 0, 0.5), 3);
    std::vector<float>& w0 = sphere_.Property("w0");
    std::vector<float>& w1 = sphere_.Property("w1");
    for (size_t v = 0; v < sphere_.num_vertices(); ++v) {
      w0[v] = std::clamp(0.5f + 2.0f * sphere_.vertices[v].x(), 0.0f, 1.0f);
      w1[v] = 1 - w0[v];
    }
    reflectance_.basis = {BrdfLobe{}, BrdfLobe{BrdfModel::kPhong, 0.3, 0.04, 50}};
    reflectance_.materials = {{"red", {{0.7, 0.2, 0.1}, {0, 0, 0}}}, {"glaze", {{0.1, 0.2, 0.5}, {0.3, 0.3, 0.3}}}};
    plane_ = render_testing::Plane(2.0, 0.0, 4);
    SunSkyParams sky;
    sky.sun_dir_world = Eigen::Vector3d(0.5, 0.3, 0.8).normalized();
    sky.sun_radius_deg = 3;
    truth_env_ = MakeSunSky(sky, 64);

    gt_ = dir_ / "ingest/ground_truth";
    fs::create_directories(gt_ + "/relight/envmaps");
    // Photo cameras (truth frame) and their model-frame copies for sfm.
    Reconstruction photos;
    for (int i = 0; i < 4; ++i) {
      RenderCamera v = OrbitCamera("photo_" + std::to_string(i) + ".jpg", Eigen::Vector3d(0, 0, 0.5), 0.5, 20 + 90 * i,
                                   20 + 5 * i, 40, 40, 0.8);
      v.camera.camera_id = i + 1;
      v.pose.camera_id = i + 1;
      v.pose.image_id = i + 1;
      photos.cameras[i + 1] = v.camera;
      photos.images[i + 1] = v.pose;
    }
    photos.WriteText(gt_);
    truth_photos_ = photos;
    Reconstruction sfm = photos;
    sfm.Transform(model_from_truth);
    fs::create_directories(dir_ / "sfm/sparse");
    sfm.WriteText(dir_ / "sfm/sparse");
    WriteJsonAtomic(dir_ / "sfm/sfm_summary.json", Json{{"mode", "colmap"}});
    // Held-out view and map (truth frame), with the reference render.
    held_ = OrbitCamera("view_0", Eigen::Vector3d(0, 0, 0.5), 0.5, 200, 30, 48, 40, 0.8);
    Reconstruction held;
    held.cameras[1] = held_.camera;
    held_.pose.image_id = 1;
    held.images[1] = held_.pose;
    held.WriteText(gt_ + "/relight");
    WriteExr(gt_ + "/relight/envmaps/sky_latlong.exr", truth_env_.image());
    const Scene truth_scene(Surfaces(sphere_, plane_), "truth");
    const RenderedView ref =
        RenderView(truth_scene, Lighting::FromEnvMap(truth_env_), held_.camera, held_.pose, Options(11), 0);
    WriteExr(gt_ + "/relight/view_0__sky.exr", ref.radiance);
    WritePng(gt_ + "/relight/view_0_mask.png", ref.mask);
    WriteJsonAtomic(
        gt_ + "/relight/index.json",
        Json{{"views", {"view_0"}},
             {"envmaps", {"sky"}},
             {"envmap_details", {{{"name", "sky"}, {"latlong", "envmaps/sky_latlong.exr"}}}},
             {"renders",
              {{{"view", "view_0"}, {"envmap", "sky"}, {"image", "view_0__sky.exr"}, {"mask", "view_0_mask.png"}}}}});
    heldout_reference_ = ref.radiance;
    heldout_mask_ = ErodeMask(ref.mask, 1);

    // Model-frame outputs of mesh and inverse.
    fs::create_directories(dir_ / "mesh");
    fs::create_directories(dir_ / "inverse/envmaps");
    TriangleMesh model_sphere = Transformed(sphere_, model_from_truth),
                 model_plane = Transformed(plane_, model_from_truth);
    WriteMeshPly(dir_ / "mesh/mesh.ply", model_sphere);
    WriteMeshPly(dir_ / "mesh/occluders.ply", model_plane);
    WriteMeshPly(dir_ / "inverse/reflectance.ply", model_sphere);
    {
      // The visibility stage's maps of the model sphere with the plane (the transport renderer's input).
      const Scene model_scene(Surfaces(model_sphere, model_plane), "model");
      const VisibilityData visibility =
          ComputeVisibility(model_scene.surface(0).mesh, model_scene.caster(), VisibilityOptions());
      fs::create_directories(dir_ / "visibility");
      WriteVisibility(dir_ / "visibility/visibility.bin", visibility);
    }
    WriteReflectanceModel(dir_ / "inverse/materials.json", reflectance_);
    GroundTruthFrame frame;
    frame.available = true;
    frame.method = "similarity";
    frame.truth_from_model = truth_from_model;
    model_env_oct_ = frame.EnvToModel(truth_env_).ToOctahedral(32);
    Json list = Json::array();
    for (int i = 0; i < 4; ++i) {
      const std::string stem = "photo_" + std::to_string(i);
      WriteExr(dir_ / ("inverse/envmaps/" + stem + "_oct.exr"), model_env_oct_);
      list.push_back({{"index", i}, {"name", stem + ".jpg"}, {"envmap_oct", "envmaps/" + stem + "_oct.exr"}});
    }
    WriteJsonAtomic(dir_ / "inverse/lighting.json", Json{{"photos", list}});
  }

  static TriangleMesh Transformed(TriangleMesh mesh, const Sim3& t) {
    for (auto& v : mesh.vertices) v = t.Apply(v.cast<double>()).cast<float>();
    for (auto& n : mesh.normals) n = (t.rotation * n.cast<double>()).normalized().cast<float>();
    return mesh;
  }
  std::vector<Scene::Surface> Surfaces(const TriangleMesh& sphere, const TriangleMesh& plane) const {
    return ModelSurfaces(sphere, reflectance_, plane, 0.35);
  }
  static RenderOptions Options(uint64_t seed) {
    RenderOptions r;
    r.pixel_samples_per_axis = 2;
    r.light_samples = 32;
    r.brdf_samples = 32;
    r.seed = seed;
    return r;
  }
  RelightOptions StageOptions() const {
    RelightOptions o;
    o.envmaps.clear();
    o.views = 1;
    o.image_size = 32;
    o.turntable_frames = 3;
    o.turntable_size = 24;
    o.turntable_light = "recovered";
    o.light_samples = 32;
    o.brdf_samples = 32;
    o.renderer = "monte_carlo";  // per-pixel reference: the frame checks below compare within its noise
    return o;
  }
  // The stage's inputs, with the held-out views as the stage's main gives them: the ground truth's, brought into
  // the model's frame by the frame relation.
  RelightInputs Inputs() const {
    const GroundTruth truth = *GroundTruth::Open(gt_);
    const GroundTruthFrame frame = RelateToGroundTruth(dir_ / "sfm", truth);
    RelightInputs in;
    in.heldout.frame_method = frame.method;
    in.heldout.cameras = frame.CamerasToModel(truth.ReadHeldoutCameras());
    in.heldout.envmaps["sky"] = frame.EnvToModel(truth_env_);
    in.heldout.renders = {{"view_0", "sky"}};
    in.sfm_dir = dir_ / "sfm";
    in.mesh_dir = dir_ / "mesh";
    in.inverse_dir = dir_ / "inverse";
    in.visibility_dir = dir_ / "visibility";
    return in;
  }

  // Photos 0 and 2 re-rendered into <dir_>/<out>: their means over the object equal a truth-frame Monte Carlo
  // render's under the same (rotated) map within `tolerance`.
  void ExpectRerendersMatchTruth(const std::string& out, double tolerance) const {
    const Scene truth_scene(Surfaces(sphere_, plane_), "truth");
    GroundTruthFrame frame;
    frame.method = "similarity";
    frame.truth_from_model = TruthFromModel();
    const Lighting truth_light = Lighting::FromEnvMap(frame.EnvToTruth(EnvMap::FromOctahedral(model_env_oct_)));
    for (int i : {0, 2}) {
      const RenderedView ref = RenderView(truth_scene, truth_light, truth_photos_.cameras.at(i + 1),
                                          truth_photos_.images.at(i + 1), Options(77), i);
      const Image est = ReadImage(dir_ / (out + "/renders/rerender/photo_" + std::to_string(i) + ".exr"));
      const Image mask = ErodeMask(ref.mask, 1);
      ASSERT_GT(CountMask(mask), 200u);
      const Eigen::Vector3d r = MaskMean(est, mask).cwiseQuotient(MaskMean(ref.radiance, mask));
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(r[c], 1.0, tolerance) << out << " photo " << i << " channel " << c;
    }
  }

  // Mean over the mask per channel.
  static Eigen::Vector3d MaskMean(const Image& image, const Image& mask) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double n = 0;
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x)
        if (mask.at(x, y) > 0.5f) {
          for (int c = 0; c < 3; ++c) sum[c] += image.at(x, y, c);
          n += 1;
        }
    return sum / std::max(1.0, n);
  }
  // Relative RMS difference over the mask.
  static double RelativeRms(const Image& a, const Image& b, const Image& mask) {
    double se = 0, ss = 0;
    for (int y = 0; y < a.height; ++y)
      for (int x = 0; x < a.width; ++x)
        if (mask.at(x, y) > 0.5f)
          for (int c = 0; c < 3; ++c) {
            se += std::pow(a.at(x, y, c) - b.at(x, y, c), 2);
            ss += std::pow(b.at(x, y, c), 2);
          }
    return std::sqrt(se / ss);
  }

  testing::TempDir dir_;
  std::string gt_;
  TriangleMesh sphere_, plane_;
  ReflectanceModel reflectance_;
  EnvMap truth_env_;
  Image model_env_oct_;
  Reconstruction truth_photos_;
  RenderCamera held_;
  Image heldout_reference_, heldout_mask_;
};

TEST_F(RelightStageTest, RendersAgreeWithGroundTruthFrameRendersAndResume) {
  const RelightSummary s = RunRelight(StageOptions(), Inputs(), dir_ / "out");
  EXPECT_EQ(s.frame_method, "similarity");
  std::map<std::string, int> kinds;
  for (const auto& r : s.renders) ++kinds[r.kind];
  EXPECT_EQ(kinds["rerender"], 4);
  EXPECT_EQ(kinds["heldout"], 1);
  EXPECT_EQ(kinds["novel"], 2);   // directional + point from one view
  EXPECT_EQ(kinds["albedo"], 0);  // the test mesh has no albedo_r/g/b
  EXPECT_EQ(kinds["material"], 1);
  EXPECT_EQ(kinds["turntable"], 3);
  EXPECT_EQ(s.rendered, 10);

  // Held-out view: the model-frame render equals the truth-frame reference within Monte Carlo noise
  // (2x2 rays x 64 samples per pixel, ~600 pixels: the means agree to well under 1%).
  const Image heldout = ReadImage(dir_ / "out/renders/heldout/view_0__sky.exr");
  ASSERT_GT(CountMask(heldout_mask_), 300u);
  const Eigen::Vector3d ratio =
      MaskMean(heldout, heldout_mask_).cwiseQuotient(MaskMean(heldout_reference_, heldout_mask_));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(ratio[c], 1.0, 0.02) << "channel " << c;
  EXPECT_LT(RelativeRms(heldout, heldout_reference_, heldout_mask_), 0.1);
  // Sensitivity: ignoring the frame change (the truth-frame map used as is) is far off.
  {
    const RecoveredModel model = LoadRecoveredModel(dir_ / "inverse", dir_ / "mesh");
    const Scene scene(ModelSurfaces(model.mesh, model.reflectance, model.occluders, 0.35), "model");
    const GroundTruthFrame frame = RelateToGroundTruth(dir_ / "sfm", *GroundTruth::Open(gt_));
    ASSERT_TRUE(frame.available);
    const Reconstruction views = frame.CamerasToModel(Reconstruction::Read(gt_ + "/relight"));
    const ImageRecord& pose = views.images.at(1);
    const RenderedView wrong =
        RenderView(scene, Lighting::FromEnvMap(truth_env_), views.cameras.at(1), pose, Options(5), 0);
    EXPECT_GT(RelativeRms(wrong.radiance, heldout_reference_, heldout_mask_), 0.15);
  }

  // Re-renderings: photo i's model-frame render equals a truth-frame render under the same (rotated) map.
  ExpectRerendersMatchTruth("out", 0.02);

  // The turntable GIF holds one frame per render.
  ASSERT_FALSE(s.turntable_gif.empty());
  auto in = OIIO::ImageInput::open(dir_ / ("out/" + s.turntable_gif));
  ASSERT_TRUE(in);
  int frames = 0;
  while (in->seek_subimage(frames, 0)) ++frames;
  EXPECT_EQ(frames, 3);
  in->close();

  // The index reads back.
  const std::vector<RenderRecord> index = ReadRenderIndex(dir_ / "out");
  ASSERT_EQ(index.size(), s.renders.size());
  EXPECT_EQ(index[0].kind, "rerender");
  EXPECT_EQ(index[0].camera.camera.width, 40);

  // A rerun reuses every image; a lost image is rendered again, identically (deterministic streams).
  const std::string lost = dir_ / "out/renders/rerender/photo_1.exr";
  const Image before = ReadImage(lost);
  const RelightSummary again = RunRelight(StageOptions(), Inputs(), dir_ / "out");
  EXPECT_EQ(again.rendered, 0);
  EXPECT_EQ(again.reused, 10);
  fs::remove(lost);
  const RelightSummary third = RunRelight(StageOptions(), Inputs(), dir_ / "out");
  EXPECT_EQ(third.rendered, 1);
  EXPECT_EQ(ReadImage(lost).pixels, before.pixels);
}


// The default renderer (relight/transport_render.h, tested against Monte Carlo there) in the stage: the
// held-out view and the re-renderings agree with the truth-frame references in their means over the object
// (within 4 %: the 642-vertex sphere's Gouraud shading of a Phong highlight and the 3° sun filtered to the
// 32² map), and a rerun in a fresh folder gives the same pixels (no noise, no seed).
TEST_F(RelightStageTest, TransportRendererAgreesInTheMeanAndIsDeterministic) {
  RelightOptions o = StageOptions();
  o.renderer = "transport";
  const RelightSummary s = RunRelight(o, Inputs(), dir_ / "out_transport");
  EXPECT_EQ(s.rendered, 10);
  const Image heldout = ReadImage(dir_ / "out_transport/renders/heldout/view_0__sky.exr");
  const Eigen::Vector3d ratio =
      MaskMean(heldout, heldout_mask_).cwiseQuotient(MaskMean(heldout_reference_, heldout_mask_));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(ratio[c], 1.0, 0.04) << "channel " << c;
  ExpectRerendersMatchTruth("out_transport", 0.04);
  RunRelight(o, Inputs(), dir_ / "out_transport_again");
  for (const std::string f : {"heldout/view_0__sky.exr", "rerender/photo_1.exr", "novel/view_0__directional.exr"}) {
    EXPECT_EQ(ReadImage(dir_ / ("out_transport/renders/" + f)).pixels,
              ReadImage(dir_ / ("out_transport_again/renders/" + f)).pixels)
        << f;
  }
  // Without the visibility stage's maps the transport renderer cannot run: the message says what to do.
  RelightInputs no_visibility = Inputs();
  no_visibility.visibility_dir.clear();
  EXPECT_NE(testing::ErrorOf([&] { RunRelight(o, no_visibility, dir_ / "out_none"); }).find("monte_carlo"),
            std::string::npos);
}

TEST_F(RelightStageTest, UnseenTexelsAreBelowTheGroundAndZeroingThemOnlyRemovesNoise) {
  const Scene scene(Surfaces(sphere_, plane_), "truth");
  const int n = 32;
  const std::vector<char> unseen = UnseenOctTexels(scene, n);
  // Every texel of the upper hemisphere is seen (from the top of the sphere); every texel far enough below
  // the horizon that the plane (half-size 2) blocks it from every point of the sphere is unseen: a point at
  // height <= 1 within 0.5 of the axis hits the plane within 1.83 at 37 degrees down (z < -0.6); one texel
  // of dilation is ~6 degrees.
  int seen_lower = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double z = OctTexelDirection(i, j, n).z();
      if (z > 0.05) {
        EXPECT_FALSE(unseen[j * n + i]) << i << "," << j;
      }
      if (z < -0.75) {
        EXPECT_TRUE(unseen[j * n + i]) << i << "," << j;
      }
      seen_lower += z < 0 && !unseen[j * n + i];
    }
  EXPECT_GT(seen_lower, 0) << "the grazing band below the horizon that passes the plane's edge stays";
  // What the inverse stage leaves in a recovered map: the seen texels carry the light (here the true sky,
  // including its grazing band below the horizon), the unseen ones whatever the regularisation extrapolated
  // (here 20 times the brightest texel of the sky, sun included, as a smooth solve under a bright horizon
  // can give). Zeroing the unseen texels keeps the object's expected radiance (high-sample renders agree to
  // Monte Carlo noise) and lowers the noise of a cheap render (4 + 4 samples) against the high-sample
  // reference: with the full map nearly every light sample goes to a blocked direction, so only the BRDF
  // samples carry light (MIS gives them full weight), whereas the zeroed map's light samples reach the sky.
  // (Brightening the whole lower hemisphere instead would keep the seen grazing band brightest, and light
  // samples would mostly be wasted with both maps: zeroing can only remove what no object point sees.)
  Image oct = truth_env_.ToOctahedral(n);
  double sky = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) sky = std::max<double>(sky, oct.at(i, j, 1) * (OctTexelDirection(i, j, n).z() > 0));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      if (unseen[j * n + i])
        for (int c = 0; c < 3; ++c) oct.at(i, j, c) = float(20 * sky);
  const Lighting full = Lighting::FromEnvMap(EnvMap::FromOctahedral(oct));
  const Lighting zeroed = Lighting::FromEnvMap(EnvMap::FromOctahedral(ZeroTexels(oct, unseen)));
  RenderOptions cheap = Options(3), rich = Options(4);
  cheap.light_samples = cheap.brdf_samples = 4;
  rich.light_samples = rich.brdf_samples = 256;
  const RenderedView reference = RenderView(scene, zeroed, held_.camera, held_.pose, rich, 0);
  const RenderedView reference_full = RenderView(scene, full, held_.camera, held_.pose, rich, 1);
  const Eigen::Vector3d ratio =
      MaskMean(reference_full.radiance, heldout_mask_).cwiseQuotient(MaskMean(reference.radiance, heldout_mask_));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(ratio[c], 1.0, 0.02) << "channel " << c;
  const double noise_full =
      RelativeRms(RenderView(scene, full, held_.camera, held_.pose, cheap, 2).radiance, reference.radiance,
                  heldout_mask_);
  const double noise_zeroed =
      RelativeRms(RenderView(scene, zeroed, held_.camera, held_.pose, cheap, 2).radiance, reference.radiance,
                  heldout_mask_);
  RecordProperty("noise_full", std::to_string(noise_full));
  RecordProperty("noise_zeroed", std::to_string(noise_zeroed));
  EXPECT_LT(noise_zeroed, 0.7 * noise_full) << noise_zeroed << " vs " << noise_full;
}

TEST_F(RelightStageTest, ExportHoldsTheModelAndEveryPhotosMapAndCamera) {
  RelightOptions o = StageOptions();
  o.views = 0;
  o.turntable_frames = 0;
  o.heldout = false;
  o.rerender_max_size = 16;
  const RelightSummary s = RunRelight(o, Inputs(), dir_ / "out");
  EXPECT_EQ(s.exported.model, "export/model.glb");
  EXPECT_EQ(s.exported.scene, "export/scene.json");
  EXPECT_EQ(s.exported.vertices, int(sphere_.num_vertices()));  // the object only: no occluder
  EXPECT_EQ(s.exported.triangles, int(sphere_.num_faces()));
  EXPECT_EQ(s.exported.primitives, 2);
  EXPECT_EQ(s.exported.albedo_scale, 1.0);  // blended Lambertian albedo <= 0.7
  EXPECT_GT(fs::file_size(dir_ / "out/export/model.glb"), 12 + 40 * sphere_.num_vertices());
  ExportRecord listed;
  ReadRenderIndex(dir_ / "out", nullptr, &listed);
  EXPECT_EQ(listed.envmaps, s.exported.envmaps);
  EXPECT_EQ(listed.vertices, s.exported.vertices);

  const Json scene = ReadJsonFile(dir_ / "out/export/scene.json");
  EXPECT_EQ(scene["format"], "relight-export");
  EXPECT_EQ(scene["version"], 1);
  EXPECT_EQ(scene["model"], "model.glb");
  ASSERT_EQ(scene["photos"].size(), 4u);
  const Reconstruction sfm = Reconstruction::Read(dir_ / "sfm/sparse");
  // The brightest direction of the model-frame map (the sun; above the ground, so never zeroed).
  const EnvMap truth_model = EnvMap::FromOctahedral(model_env_oct_);
  int best = 0;
  for (int k = 1; k < model_env_oct_.width * model_env_oct_.height; ++k)
    if (model_env_oct_.pixels[3 * k + 1] > model_env_oct_.pixels[3 * best + 1]) best = k;
  const Eigen::Vector3d sun = OctTexelDirection(best % 32, best / 32, 32);
  for (int i = 0; i < 4; ++i) {
    const Json& p = scene["photos"][i];
    const std::string stem = "photo_" + std::to_string(i);
    EXPECT_EQ(p["photo"], stem + ".jpg");
    EXPECT_EQ(p["envmap"], "envmaps/" + stem + ".exr");
    EXPECT_EQ(s.exported.envmaps[i], "export/envmaps/" + stem + ".exr");
    // A lat-long float map, 2:1, 64 high (as the inverse stage's for a 32² octahedral map), whose brightest
    // pixel is the sun's direction under the project's lat-long convention.
    const Image map = ReadImage(dir_ / ("out/export/envmaps/" + stem + ".exr"));
    ASSERT_EQ(map.height, 64);
    ASSERT_EQ(map.width, 128);
    int peak = 0;
    for (int k = 1; k < map.width * map.height; ++k)
      if (map.pixels[3 * k + 1] > map.pixels[3 * peak + 1]) peak = k;
    const double theta = M_PI * (peak / map.width + 0.5) / map.height,
                 phi = 2 * M_PI * (peak % map.width + 0.5) / map.width;
    const Eigen::Vector3d d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    EXPECT_GT(d.dot(sun), std::cos(8 * M_PI / 180)) << stem;
    EXPECT_NEAR(EnvMap::FromLatLong(map).Lookup(sun).y() / truth_model.Lookup(sun).y(), 1.0, 0.35) << stem;
    // The photo's camera: COLMAP intrinsics and pose as sfm has them, and its glTF pose.
    const ImageRecord& pose = *sfm.FindImage(stem + ".jpg");
    const RenderCamera camera = CameraFromJson(p["camera"], "scene.json");
    EXPECT_EQ(camera.camera.width, 40);
    EXPECT_NEAR((camera.pose.ProjectionCenter() - pose.ProjectionCenter()).norm(), 0, 1e-9);
    const Eigen::Vector3d c = pose.ProjectionCenter();
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(p["camera"]["gltf_world_from_camera"][k][3].get<double>(), Eigen::Vector3d(c.x(), c.z(), -c.y())[k],
                  1e-9);
  }
}

TEST_F(RelightStageTest, MissingInputsAreUserErrorsNamingTheFile) {
  fs::remove(dir_ / "inverse/reflectance.ply");
  try {
    RunRelight(StageOptions(), Inputs(), dir_ / "out");
    FAIL() << "expected a UserError";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("reflectance.ply"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("inverse"), std::string::npos) << e.what();
  }
  RelightOptions o = StageOptions();
  o.envmaps = {dir_ / "nowhere.exr"};
  EXPECT_THROW(RunRelight(o, Inputs(), dir_ / "out"), UserError);
}

}  // namespace
}  // namespace relight

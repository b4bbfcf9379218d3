// The evaluation's numbers against closed forms: scale-invariant PSNR of a
// scaled copy (perfect) and of a copy with Gaussian noise (10 log10(peak²/σ²)),
// the peak percentile and clipping, the environment-map error of a map that
// misses a known share of the sphere, Chamfer distances of concentric spheres,
// leave-one-photo-out on the solver's own forward model (the held-out photo's
// sun is found with reflectance fitted without it), and stage timings.
#include "evaluate/evaluate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "datasets/ground_truth_frame.h"
#include "datasets/light_evaluation.h"
#include "evaluate/envmap_metrics.h"
#include "evaluate/image_metrics.h"
#include "evaluate/leave_one_out.h"
#include "evaluate/shadow_contrast.h"
#include "evaluate/surface_distance.h"
#include "geometry/mesh_io.h"
#include "geometry/primitives.h"
#include "geometry/reconstruction.h"
#include "relight/display.h"
#include "relight/views.h"
#include "render/test_scenes.h"
#include "solver/synthetic_problem.h"
#include "sphere/envmap.h"
#include "sphere/octahedral.h"
#include "sphere/sky.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

Image RandomImage(int w, int h, double lo, double hi, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  Image image(w, h, 3);
  for (auto& p : image.pixels) p = float(u(rng));
  return image;
}

TEST(ImageMetrics, PerChannelScaledCopyIsPerfect) {
  const Image ref = RandomImage(64, 48, 0.1, 0.9, 1);
  const Image est = ScaleChannels(ref, Eigen::Vector3d(0.5, 2.0, 3.0));
  const Image mask(64, 48, 1, 1.0f);
  const ImageComparison c = CompareScaleInvariant(ref, est, mask, {});
  EXPECT_NEAR(c.scale[0], 2.0, 1e-6);
  EXPECT_NEAR(c.scale[1], 0.5, 1e-6);
  EXPECT_NEAR(c.scale[2], 1.0 / 3.0, 1e-6);
  EXPECT_DOUBLE_EQ(c.psnr_db, kMaxPsnrDb);
  EXPECT_LT(c.relative_rmse, 1e-6);
  EXPECT_EQ(c.pixels, size_t(64 * 48));
}

TEST(ImageMetrics, GaussianNoiseMatchesTheClosedForm) {
  // Reference in [0.2, 0.8] with one pixel at 1 (the peak); estimate = reference + N(0, σ²) per value.
  // PSNR = 10 log10(1 / σ²) = 40 dB for σ = 0.01. The fitted scale shrinks the error by σ²/E[R²] ≈ 4e-4
  // (0.002 dB); the MSE of 786k values has a relative standard deviation of sqrt(2/N) = 0.0016 (0.007 dB).
  const int w = 512, h = 512;
  Image ref = RandomImage(w, h, 0.2, 0.8, 2);
  for (int c = 0; c < 3; ++c) ref.at(7, 7, c) = 1.0f;
  Image est = ref;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (auto& p : est.pixels) p = float(p + noise(rng));
  ImageCompareOptions o;
  o.peak_percentile = 100;
  const ImageComparison c = CompareScaleInvariant(ref, est, Image(w, h, 1, 1.0f), o);
  EXPECT_DOUBLE_EQ(c.peak, 1.0);
  EXPECT_NEAR(c.psnr_db, 40.0, 0.03);
  EXPECT_NEAR(c.rmse, 0.01, 0.0001);
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(c.scale[ch], 1.0, 0.001);
  // Half the mask: same statistics; an empty mask is a user error.
  Image half(w, h, 1);
  for (int y = 0; y < h / 2; ++y)
    for (int x = 0; x < w; ++x) half.at(x, y) = 1;
  EXPECT_NEAR(CompareScaleInvariant(ref, est, half, o).psnr_db, 40.0, 0.05);
  EXPECT_THROW(CompareScaleInvariant(ref, est, Image(w, h, 1), o), UserError);
  EXPECT_THROW(CompareScaleInvariant(ref, RandomImage(4, 4, 0, 1, 1), Image(w, h, 1, 1.0f), o), UserError);
}

TEST(ImageMetrics, HighlightsAboveThePeakPercentileAreClipped) {
  // 0.4% of the pixels are highlights of 100 (the rest 0.5); the estimate is twice the reference but gets
  // the highlights wrong (50). The 99th percentile is 0.5: the scale comes from the other pixels (0.5) and
  // the highlights clip to the peak on both sides, so the match is perfect.
  const int w = 100, h = 50;
  Image ref(w, h, 3, 0.5f);
  Image est(w, h, 3, 1.0f);
  for (int x = 0; x < 20; ++x)
    for (int c = 0; c < 3; ++c) {
      ref.at(x, 10, c) = 100;
      est.at(x, 10, c) = 50;
    }
  const Image mask(w, h, 1, 1.0f);
  const ImageComparison c = CompareScaleInvariant(ref, est, mask, {});
  EXPECT_DOUBLE_EQ(c.peak, 0.5);
  EXPECT_NEAR(c.scale[1], 0.5, 1e-9);
  EXPECT_DOUBLE_EQ(c.psnr_db, kMaxPsnrDb);
  // Unclipped, the highlights count: 20 pixels off by 75 in all channels, 5000 pixels, peak 0.5.
  ImageCompareOptions unclipped;
  unclipped.clip_to_peak = false;
  const ImageComparison u = CompareScaleInvariant(ref, est, mask, unclipped);
  const double mse = u.mse;
  EXPECT_GT(mse, 0);
  EXPECT_NEAR(u.psnr_db, 10 * std::log10(0.25 / mse), 1e-9);
  // The maximum as the peak.
  ImageCompareOptions max_peak;
  max_peak.peak_percentile = 100;
  EXPECT_DOUBLE_EQ(CompareScaleInvariant(ref, est, mask, max_peak).peak, 100.0);
}

TEST(EnvMapMetrics, MissingLowerHemisphereClosedForm) {
  // Truth: 1 everywhere; estimate: 2 on texels above the horizon, 0 below. The best scale is 1/2, the
  // error the square root of the lower texels' share of the sphere; above the horizon it is exact.
  const int n = 32;
  Image truth(n, n, 3, 1.0f), est(n, n, 3, 0.0f);
  const std::vector<double> omega = OctTexelSolidAngles(n);
  double lower = 0, all = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      all += omega[j * n + i];
      if (OctTexelDirection(i, j, n).z() > 0) {
        for (int c = 0; c < 3; ++c) est.at(i, j, c) = 2.0f;
      } else {
        lower += omega[j * n + i];
      }
    }
  EXPECT_NEAR(all, 4 * M_PI, 1e-9);
  const EnvMapComparison c = CompareEnvMaps(est, truth, false);
  EXPECT_NEAR(c.relative_error, std::sqrt(lower / all), 1e-9);
  EXPECT_NEAR(c.scale[0], 0.5, 1e-9);
  const EnvMapComparison upper = CompareEnvMaps(est, truth, true);
  EXPECT_NEAR(upper.relative_error, 0.0, 1e-9);
  EXPECT_NEAR(std::sqrt(lower / all), std::sqrt(0.5), 0.02);  // about half the sphere
  EXPECT_NEAR(AngleDeg(Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(1, 1, 0)), 45.0, 1e-9);
  EXPECT_THROW(CompareEnvMaps(Image(16, 16, 3), truth, false), UserError);
}

// A reconstruction that includes the ground the object stands on: against the
// object alone the ground samples are gross errors; with the true ground as
// context, only the estimate around the object counts, and the 0.1 offset of
// the sphere shell is what remains.
TEST(SurfaceDistance, ReconstructedGroundIsNotAnErrorWithGroundContext) {
  const TriangleMesh truth = render_testing::Icosphere(1.0, Eigen::Vector3d(0, 0, 1), 5);
  const TriangleMesh ground = render_testing::Plane(10, 0, 20);
  TriangleMesh estimate = render_testing::Icosphere(1.1, Eigen::Vector3d(0, 0, 1), 5);
  estimate.Append(render_testing::Plane(10, 0, 20));
  const MeshDistances without = CompareMeshes(estimate, truth, 20000);
  EXPECT_GT(without.accuracy_mean, 1.0);  // most of the estimate's area is far-away ground
  const MeshDistances with = CompareMeshes(estimate, truth, 20000, 1, &ground);
  // Inside the box, the ground patch is exact (0) and the shell is 0.1 off: mean in (0, 0.1].
  EXPECT_GT(with.accuracy_mean, 0.03);
  EXPECT_LE(with.accuracy_mean, 0.1 + 1e-3);
  // Completeness: 0.1 to the shell, a little less near the bottom where the estimate's ground is closer.
  EXPECT_GT(with.completeness_mean, 0.09);
  EXPECT_LE(with.completeness_mean, 0.1 + 1e-3);
}

// The mesh stage once kept only the Poisson underside of the ground: no
// estimate surface near the object. Scored whole, it is as far off as it is.
TEST(SurfaceDistance, EstimateWithNothingNearTheObjectIsScoredWhole) {
  const TriangleMesh truth = render_testing::Icosphere(1.0, Eigen::Vector3d(0, 0, 1), 4);
  const TriangleMesh ground = render_testing::Plane(10, 0, 20);
  const TriangleMesh estimate = render_testing::Plane(10, -5, 20);  // 5 below the ground, the box reaches -0.35
  const MeshDistances d = CompareMeshes(estimate, truth, 5000, 1, &ground);
  EXPECT_EQ(d.estimate_samples_near_object, 0u);
  EXPECT_NEAR(d.accuracy_mean, 5.0, 1e-6);  // every sample 5 below the true ground
  EXPECT_GT(d.completeness_mean, 5.0);      // the sphere's points lie 5 to 7 above the plane
  EXPECT_LT(d.completeness_mean, 7.0);
}

TEST(SurfaceDistance, ConcentricSpheresAreATenthApart) {
  // Spheres of radius 1 and 1.1 (icospheres, 5 subdivisions: the faces lie within 2e-4 of the sphere).
  const TriangleMesh inner = render_testing::Icosphere(1.0, Eigen::Vector3d::Zero(), 5);
  const TriangleMesh outer = render_testing::Icosphere(1.1, Eigen::Vector3d::Zero(), 5);
  const MeshDistances d = CompareMeshes(outer, inner, 5000);
  EXPECT_NEAR(d.accuracy_mean, 0.1, 1e-3);
  EXPECT_NEAR(d.completeness_mean, 0.1, 1e-3);
  EXPECT_NEAR(d.chamfer, 0.1, 1e-3);
  EXPECT_NEAR(d.diagonal, 2 * std::sqrt(3.0), 1e-3);
  // Closest points and their interpolation: geometry/mesh_distance_test.cc.
}

// A box standing on a plane under a sun: each pixel's region against the closed form (the camera ray's
// first hit by slab and plane tests, its normal, and a slab test from the hit towards the sun).
TEST(ShadowContrast, RegionsOfABoxOnAPlaneMatchTheClosedForm) {
  const Eigen::Vector3f lo(-0.3f, -0.3f, 0.0f), hi(0.3f, 0.3f, 0.6f);
  TriangleMesh box = MakeBox(lo, hi);
  box.normals.clear();  // flat faces: the shading normal is the face's
  const TriangleMesh ground = MakeGrid(-3, 3, -3, 3, 0, 6, 6);
  const RayCaster caster({&box, &ground});
  const Camera camera = Camera::Pinhole(1, 160, 120, 150, 150, 80, 60);
  ImageRecord pose;
  const Eigen::Vector3d centre(1.2, -2.2, 2.0);
  pose.SetPose(LookAtCamFromWorld(centre, Eigen::Vector3d(0, 0.4, 0.2)), centre);
  const Eigen::Vector3d sun = Eigen::Vector3d(-1.0, 0.8, 1.1).normalized();
  const SunRegions regions = SunAndShadowRegions(caster, camera, pose, sun, Image(), 2, 0.2);

  // Slab test of the ray o + t d against the box: entry distance and the entry face's normal.
  auto slab = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& d, double* t_hit, Eigen::Vector3d* n) {
    double t0 = 1e-9, t1 = 1e30;
    int axis = -1;
    double sign = 0;
    for (int a = 0; a < 3; ++a) {
      const double lo_a = lo[a], hi_a = hi[a];
      if (std::abs(d[a]) < 1e-12) {
        if (o[a] < lo_a || o[a] > hi_a) return false;
        continue;
      }
      double ta = (lo_a - o[a]) / d[a], tb = (hi_a - o[a]) / d[a];
      double s = -1;
      if (ta > tb) std::swap(ta, tb), s = 1;
      if (ta > t0) t0 = ta, axis = a, sign = s;
      t1 = std::min(t1, tb);
      if (t0 > t1) return false;
    }
    if (t_hit) *t_hit = t0;
    if (n && axis >= 0) *n = Eigen::Vector3d::Unit(axis) * sign;
    return true;
  };
  const Eigen::Matrix3d world_from_cam = pose.CamFromWorldRotation().transpose();
  size_t lit_true = 0, shadow_true = 0, lit_agree = 0, shadow_agree = 0, lit_wrong = 0, shadow_wrong = 0;
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector3d d = world_from_cam * Eigen::Vector3d((x + 0.5 - 80) / 150, (y + 0.5 - 60) / 150, 1);
      double t = 0;
      Eigen::Vector3d n(0, 0, 1), p;
      if (slab(centre, d, &t, &n)) {
        p = centre + t * d;
      } else {
        if (d.z() >= 0) continue;
        p = centre + (-centre.z() / d.z()) * d;
        if (p.head<2>().cwiseAbs().maxCoeff() > 3) continue;
      }
      const double cos_sun = n.dot(sun);
      bool is_lit = false;
      if (cos_sun > 0) {
        if (cos_sun < 0.2) continue;
        is_lit = !slab(p + 1e-6 * n, sun, nullptr, nullptr);
      }
      (is_lit ? lit_true : shadow_true)++;
      const bool in_lit = regions.lit.at(x, y) > 0.5f, in_shadow = regions.shadow.at(x, y) > 0.5f;
      lit_agree += is_lit && in_lit;
      shadow_agree += !is_lit && in_shadow;
      lit_wrong += !is_lit && in_lit;
      shadow_wrong += is_lit && in_shadow;
    }
  ASSERT_GT(shadow_true, 1000u);  // the view shows the box's cast and attached shadows
  ASSERT_GT(lit_true, 5000u);
  // Erosion by 2 px keeps every region pixel away from the edges: none on the wrong side.
  EXPECT_EQ(lit_wrong, 0u);
  EXPECT_EQ(shadow_wrong, 0u);
  // ... and most of each region's inside.
  EXPECT_GT(double(lit_agree) / lit_true, 0.85);
  EXPECT_GT(double(shadow_agree) / shadow_true, 0.6);

  // Ratios: reference lit 2.0 and shadow 0.5 (ratio 4); the estimate at a tenth of the scale with its
  // shadows lifted to 0.1 (lit 0.2: ratio 2, relative error -0.5); both grey so luminance = value.
  Image reference(160, 120, 3, 1.0f), estimate(160, 120, 3, 1.0f);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x)
      for (int c = 0; c < 3; ++c) {
        const bool lit = regions.lit.at(x, y) > 0.5f, shadow = regions.shadow.at(x, y) > 0.5f;
        reference.at(x, y, c) = lit ? 2.0f : shadow ? 0.5f : 7.0f;
        estimate.at(x, y, c) = lit ? 0.2f : shadow ? 0.1f : 0.0f;
      }
  const ShadowContrast c = MeasureShadowContrast(reference, estimate, regions, "box");
  EXPECT_NEAR(c.reference_ratio, 4.0, 1e-5);
  EXPECT_NEAR(c.estimate_ratio, 2.0, 1e-5);
  EXPECT_NEAR(c.relative_error, -0.5, 1e-5);
  // A black shadow has no ratio: a clear error, not infinity.
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x)
      if (regions.shadow.at(x, y) > 0.5f)
        for (int c = 0; c < 3; ++c) estimate.at(x, y, c) = 0;
  EXPECT_THROW(MeasureShadowContrast(reference, estimate, regions, "box"), UserError);
}

TEST(LeaveOneOut, RestrictAndSpread) {
  ObservationSet all;
  all.num_photos = 3;
  all.num_vertices = 2;
  for (uint32_t p = 0; p < 3; ++p)
    for (uint32_t v = 0; v < 2; ++v) {
      Observation o;
      o.photo = p;
      o.vertex = v;
      o.rgb[0] = float(10 * p + v);
      all.records.push_back(o);
    }
  const ObservationSet sub = RestrictObservations(all, {2, 0});
  ASSERT_EQ(sub.num_photos, 2u);
  ASSERT_EQ(sub.records.size(), 4u);
  EXPECT_EQ(sub.records[0].photo, 0u);
  EXPECT_EQ(sub.records[0].rgb[0], 20.0f);  // old photo 2 is new photo 0
  EXPECT_EQ(sub.records[3].rgb[0], 1.0f);
  EXPECT_EQ(SpreadPhotos(10, 4), (std::vector<uint32_t>{1, 3, 6, 8}));
  EXPECT_EQ(SpreadPhotos(3, 0), (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_EQ(SpreadPhotos(3, 5), (std::vector<uint32_t>{0, 1, 2}));
  // Groups of at most a fifth of the collection, spread round robin.
  using Groups = std::vector<std::vector<uint32_t>>;
  EXPECT_EQ(LeaveOutGroups({1, 3, 6, 8}, 10), (Groups{{1, 6}, {3, 8}}));
  EXPECT_EQ(LeaveOutGroups({0, 1, 2, 3, 4, 5, 6, 7, 8, 9}, 10), (Groups{{0, 5}, {1, 6}, {2, 7}, {3, 8}, {4, 9}}));
  EXPECT_EQ(LeaveOutGroups({1, 3}, 4), (Groups{{1}, {3}}));
  EXPECT_EQ(LeaveOutGroups({2, 7, 12}, 100), (Groups{{2, 7, 12}}));
}

TEST(LeaveOneOut, HeldOutPhotoLightingFromReflectanceFittedWithoutIt) {
  InitLogging("evaluate_test", "", LogLevel::kWarning);
  setenv("RELIGHT_PROGRESS", "off", 1);
  SyntheticProblemOptions po;
  po.vertices = 2000;
  po.photos = 6;
  po.env_resolution = 16;
  SyntheticProblem s = MakeSyntheticProblem(po);
  InverseOptions o;
  o.env_resolution = 16;
  o.basis = po.basis;
  o.materials = 2;
  o.max_iterations = 6;
  const size_t vis = s.problem.visibility.per_vertex.size();
  const uint32_t photo = 2;
  const LeaveOneOutFit fit = LeaveOneOut(&s.problem, o, photo, 0);
  EXPECT_EQ(s.problem.visibility.per_vertex.size(), vis) << "the problem is restored";
  ASSERT_EQ(fit.lighting_oct.width, 16);
  // The held-out photo's map against its truth (upper hemisphere, scale-invariant) and its sun.
  Image truth(16, 16, 3);
  for (size_t k = 0; k < truth.pixels.size(); ++k) truth.pixels[k] = s.truth.lighting_oct_rgb[photo][k];
  const EnvMapComparison c = CompareEnvMaps(fit.lighting_oct, truth, true);
  // The same photo's map from the joint solve on all photos (in-sample).
  const InverseResult joint = SolveInverse(s.problem, o);
  Image in_sample(16, 16, 3);
  const std::vector<float> rgb = joint.lighting.OctahedralRgb(photo, 16);
  for (size_t k = 0; k < rgb.size(); ++k) in_sample.pixels[k] = std::max(0.0f, rgb[k]);
  const double in_sample_error = CompareEnvMaps(in_sample, truth, true).relative_error;
  // Measured: 0.350 held out against 0.331 in-sample; the sun 6.0 degrees off (in-sample 1.6; a 16² texel
  // spans about 11 degrees).
  EXPECT_LT(c.relative_error, 1.25 * in_sample_error);
  EXPECT_LT(c.relative_error, 0.45);
  EXPECT_LT(AngleDeg(BrightestLobeDirection(fit.lighting_oct), s.sun_dirs_world[photo]), 11.0);
  // Reflectance from 5 of 6 photos: every material weight is finite and non-negative.
  for (float w : fit.reflectance.weights) EXPECT_TRUE(std::isfinite(w) && w >= 0);

  // The stage's way: photos 2 and 5 left out together, one solve from scratch without both, then a fold of
  // 3 iterations for photo 2 started from it (photo 5 added back). Its start never saw photo 2: it predicts
  // the held-out map and observations about as well as the fold from scratch.
  const ReflectanceState group_start = SolveWithout(&s.problem, o, {photo, 5});
  EXPECT_EQ(s.problem.visibility.per_vertex.size(), vis) << "the problem is restored";
  const LeaveOneOutFit warm = LeaveOneOut(&s.problem, o, photo, 3, &group_start);
  EXPECT_LE(warm.reflectance_summary.iterations.size(), 3u);
  ASSERT_EQ(warm.lighting_oct.width, 16);
  const double warm_error = CompareEnvMaps(warm.lighting_oct, truth, true).relative_error;
  std::printf("held-out map error %.4f (warm fold) vs %.4f (from scratch); photo RMSE %.5f vs %.5f\n", warm_error,
              c.relative_error, warm.photo_rmse, fit.photo_rmse);
  EXPECT_NEAR(warm_error, c.relative_error, 0.1 * c.relative_error);
  EXPECT_NEAR(warm.photo_rmse, fit.photo_rmse, 0.1 * fit.photo_rmse);
  EXPECT_GT(fit.photo_rmse, 0);
}

// Stage folders whose model frame differs from the truth's by a known similarity, holding the true
// albedo, mesh and (rotated) environment maps as the "recovered" model: every ground-truth metric must be
// near perfect; claiming the frames are identical must ruin them.
class EvaluateFramesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    InitLogging("evaluate_test", "", LogLevel::kWarning);
    setenv("RELIGHT_PROGRESS", "off", 1);
    truth_from_model_.scale = 2.0;
    truth_from_model_.rotation = Eigen::AngleAxisd(0.9, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix();
    truth_from_model_.translation = Eigen::Vector3d(-0.4, 0.1, 0.7);
    const Sim3 model_from_truth = truth_from_model_.Inverse();
    const std::string gt = dir_ / "ingest/ground_truth";
    fs::create_directories(gt + "/envmaps");
    // Truth: a sphere with a smooth albedo, on a ground (occluders.ply) under a sun sky.
    TriangleMesh sphere = render_testing::Icosphere(0.5, Eigen::Vector3d(0, 0, 0.5), 4);
    auto& r = sphere.Property("albedo_r");
    auto& g = sphere.Property("albedo_g");
    auto& b = sphere.Property("albedo_b");
    for (size_t v = 0; v < sphere.num_vertices(); ++v) {
      const Eigen::Vector3f p = sphere.vertices[v];
      r[v] = 0.5f + 0.4f * p.x();
      g[v] = 0.4f + 0.3f * p.y();
      b[v] = 0.2f + 0.2f * (p.z() - 0.5f);
    }
    WriteMeshPly(gt + "/mesh.ply", sphere);
    WriteMeshPly(gt + "/occluders.ply", render_testing::Plane(2, 0, 2));
    SunSkyParams sky;
    sky.sun_dir_world = Eigen::Vector3d(-0.3, 0.6, 0.7).normalized();
    sky.sun_radius_deg = 4;
    const EnvMap truth_env = MakeSunSky(sky, 64);
    WriteExr(gt + "/envmaps/photo_0_latlong.exr", truth_env.image());
    const Eigen::Vector3d s = sky.sun_dir_world;
    WriteJsonAtomic(gt + "/lighting.json",
                    Json{{"photos",
                          {{{"name", "photo_0.jpg"},
                            {"envmap_latlong", "envmaps/photo_0_latlong.exr"},
                            {"environment", {{"source", "sky"}, {"sun_dir_world", {s.x(), s.y(), s.z()}}}}}}}});
    Reconstruction cameras;
    for (int i = 0; i < 4; ++i) {
      RenderCamera v = OrbitCamera("photo_" + std::to_string(i) + ".jpg", Eigen::Vector3d(0, 0, 0.5), 0.5, 90 * i,
                                   20 + 10 * i, 32, 40, 0.8);
      v.camera.camera_id = v.pose.camera_id = v.pose.image_id = i + 1;
      cameras.cameras[i + 1] = v.camera;
      cameras.images[i + 1] = v.pose;
    }
    cameras.WriteText(gt);
    // The model frame: sfm cameras, the reconstructed mesh, the recovered model and its map.
    Reconstruction model_cameras = cameras;
    model_cameras.Transform(model_from_truth);
    fs::create_directories(dir_ / "sfm/sparse");
    model_cameras.WriteText(dir_ / "sfm/sparse");
    WriteJsonAtomic(dir_ / "sfm/sfm_summary.json", Json{{"mode", "colmap"}});
    TriangleMesh model_sphere = sphere;
    for (auto& v : model_sphere.vertices) v = model_from_truth.Apply(v.cast<double>()).cast<float>();
    for (auto& n : model_sphere.normals) n = (model_from_truth.rotation * n.cast<double>()).cast<float>();
    fs::create_directories(dir_ / "mesh");
    fs::create_directories(dir_ / "inverse/envmaps");
    WriteMeshPly(dir_ / "mesh/mesh.ply", model_sphere);
    WriteJsonAtomic(dir_ / "mesh/mesh_summary.json", Json{{"source", "mvs"}});
    // Recovered albedo: the truth times per-channel factors (the gauge), on the model-frame mesh.
    for (auto& [name, values] : model_sphere.properties) {
      const float f = name == "albedo_r" ? 3.0f : name == "albedo_g" ? 0.5f : 2.0f;
      for (float& x : values) x *= f;
    }
    WriteMeshPly(dir_ / "inverse/reflectance.ply", model_sphere);
    GroundTruthFrame frame;
    frame.available = true;
    frame.method = "similarity";
    frame.truth_from_model = truth_from_model_;
    WriteExr(dir_ / "inverse/envmaps/photo_0_oct.exr", frame.EnvToModel(truth_env).ToOctahedral(32));
    WriteJsonAtomic(
        dir_ / "inverse/lighting.json",
        Json{{"photos", {{{"index", 0}, {"name", "photo_0.jpg"}, {"envmap_oct", "envmaps/photo_0_oct.exr"}}}}});
  }
  EvaluateInputs Inputs() const {
    EvaluateInputs in;
    in.ingest_dir = dir_ / "ingest";
    in.sfm_dir = dir_ / "sfm";
    in.mesh_dir = dir_ / "mesh";
    in.inverse_dir = dir_ / "inverse";
    return in;
  }
  testing::TempDir dir_;
  Sim3 truth_from_model_;
};

TEST_F(EvaluateFramesTest, GroundTruthMetricsInTheTruthsFrame) {
  EvaluateOptions o;
  o.mesh_samples = 4000;
  const OrderedJson m = RunEvaluate(o, Inputs(), dir_ / "out").metrics;
  EXPECT_EQ(m["frame"]["method"], "similarity");
  EXPECT_NEAR(m["frame"]["truth_from_model"]["scale"].get<double>(), 2.0, 1e-6);
  // Cameras: exact up to the similarity.
  EXPECT_EQ(m["cameras"]["matched"].get<int>(), 4);
  EXPECT_LT(m["cameras"]["median_rotation_deg"].get<double>(), 1e-6);
  // Mesh: the same surface (float rounding of the transformed vertices only).
  EXPECT_LT(m["mesh"]["chamfer_relative"].get<double>(), 1e-5);
  // Albedo: the per-channel gauge factors are undone exactly; closest points are the vertices themselves.
  EXPECT_GT(m["albedo_psnr_db"].get<double>(), 60.0);
  EXPECT_NEAR(m["albedo"]["scale"][0].get<double>(), 1.0 / 3.0, 1e-5);
  EXPECT_EQ(m["albedo"]["correspondence"], "closest point on the true surfaces");
  EXPECT_EQ(m["albedo"]["surroundings_vertices"].get<int>(), 0);  // the truth's ground carries no albedo here
  // Environment map: the recovered map is the truth at 32² carried through the rotation and back, so only
  // resampling separates them (the sun disk, 4 degrees, spreads over neighbouring texels; measured 0.169 and
  // 1.6 degrees); upper hemisphere because the truth has a ground.
  EXPECT_EQ(m["envmaps"]["region"], "upper hemisphere (z > 0)");
  EXPECT_LT(m["envmap_rel_error"].get<double>(), 0.25);
  EXPECT_LT(m["light_dir_error_deg"].get<double>(), 3.0);
  EXPECT_EQ(m["envmaps"]["light_dir_error_from"], "photos under a sun sky (sun direction)");
  // What is not there is reported, not invented.
  EXPECT_TRUE(m["relight_psnr_db"].is_null());
  EXPECT_TRUE(m["rerender_psnr_db"].is_null());
  EXPECT_TRUE(m["not_available"].contains("relight_psnr_db"));
  EXPECT_TRUE(m["loo_psnr_db"].is_null());
  EXPECT_TRUE(fs::exists(dir_ / "out/metrics.json"));
  EXPECT_TRUE(fs::exists(dir_ / "out/figures/envmaps/photo_0_truth_oct.png"));
}

TEST_F(EvaluateFramesTest, IgnoringTheFrameChangeIsVisible) {
  // Claim the sfm stage used the true cameras: the model is then scored in the wrong frame.
  WriteJsonAtomic(dir_ / "sfm/sfm_summary.json", Json{{"mode", "ground_truth"}});
  EvaluateOptions o;
  o.mesh_samples = 2000;
  const OrderedJson m = RunEvaluate(o, Inputs(), dir_ / "out").metrics;
  EXPECT_EQ(m["frame"]["method"], "identity");
  // Measured: 50 degrees and 0.9998 (against 1.6 degrees and 0.169 in the right frame).
  EXPECT_GT(m["light_dir_error_deg"].get<double>(), 20.0);
  EXPECT_GT(m["envmap_rel_error"].get<double>(), 0.4);
}

// A reconstruction covers the ground around the object and a stray blob: its ground vertices are
// scored against the truth's ground (occluders.ply with albedo), the blob against nothing, and the
// object's albedo alone makes the headline figure.
TEST_F(EvaluateFramesTest, AlbedoOfTheObjectAloneAndOfItsSurroundingsApart) {
  const std::string gt = dir_ / "ingest/ground_truth";
  TriangleMesh ground = render_testing::Plane(2, 0, 7);  // no vertex right under the sphere's contact point
  for (const char* p : {"albedo_r", "albedo_g", "albedo_b"}) ground.Property(p).assign(ground.num_vertices(), 0.3f);
  for (size_t v = 0; v < ground.num_vertices(); ++v)
    ground.Property("albedo_g")[v] = 0.2f + 0.1f * ground.vertices[v].x();
  WriteMeshPly(gt + "/occluders.ply", ground);
  // The recovered model: the object as before, plus the ground (0.01 below the truth's) and a blob
  // 1.5 above the object, all in the model frame with the gauge factors (3, 0.5, 2).
  TriangleMesh model = ReadMesh(dir_ / "inverse/reflectance.ply");
  const size_t object_vertices = model.num_vertices();
  const Sim3 model_from_truth = truth_from_model_.Inverse();
  TriangleMesh around = ground, blob = render_testing::Icosphere(0.1, Eigen::Vector3d(0, 0, 2.0), 2);
  for (auto& v : around.vertices) v.z() -= 0.01f;
  for (const char* p : {"albedo_r", "albedo_g", "albedo_b"}) blob.Property(p).assign(blob.num_vertices(), 0.9f);
  for (TriangleMesh* part : {&around, &blob}) {
    for (auto& v : part->vertices) v = model_from_truth.Apply(v.cast<double>()).cast<float>();
    for (auto& n : part->normals) n = (model_from_truth.rotation * n.cast<double>()).cast<float>();
    for (auto& [name, values] : part->properties) {
      const float f = name == "albedo_r" ? 3.0f : name == "albedo_g" ? 0.5f : 2.0f;
      for (float& x : values) x *= f;
    }
    model.Append(*part);
  }
  WriteMeshPly(dir_ / "inverse/reflectance.ply", model);
  EvaluateOptions o;
  o.mesh_samples = 2000;
  const OrderedJson m = RunEvaluate(o, Inputs(), dir_ / "out").metrics;
  // Every vertex is observed (no observations.bin): the object's, the ground's and the blob's go apart.
  EXPECT_EQ(m["albedo"]["vertices"].get<size_t>(), object_vertices);
  EXPECT_EQ(m["albedo"]["surroundings_vertices"].get<size_t>(), around.num_vertices());
  EXPECT_EQ(m["albedo"]["off_surface_vertices"].get<size_t>(), blob.num_vertices());
  EXPECT_GT(m["albedo_psnr_db"].get<double>(), 60.0);
  EXPECT_NEAR(m["albedo"]["scale"][1].get<double>(), 2.0, 1e-5);
  // The ground's albedo is linear across it, so the closest points interpolate it exactly.
  EXPECT_GT(m["albedo"]["surroundings_psnr_db"].get<double>(), 60.0);
  EXPECT_TRUE(m["albedo"]["confident_psnr_db"].is_null());  // no observations: no confidence to count
}

// A true ground whose faces have no area is nothing to lie on: it is ignored, not a crash.
TEST_F(EvaluateFramesTest, DegenerateSurroundingsAreIgnored) {
  TriangleMesh flat = render_testing::Plane(2, 0, 4);
  for (auto& v : flat.vertices) v = Eigen::Vector3f(0.3f, 0.2f, 0.0f);
  for (const char* p : {"albedo_r", "albedo_g", "albedo_b"}) flat.Property(p).assign(flat.num_vertices(), 0.5f);
  WriteMeshPly(dir_ / "ingest/ground_truth/occluders.ply", flat);
  EvaluateOptions o;
  o.mesh_samples = 2000;
  const OrderedJson m = RunEvaluate(o, Inputs(), dir_ / "out").metrics;
  EXPECT_GT(m["albedo_psnr_db"].get<double>(), 60.0);
  EXPECT_EQ(m["albedo"]["surroundings_vertices"].get<int>(), 0);
}

TEST(Evaluate, StageSecondsFollowUpstreamKeys) {
  testing::TempDir dir;
  const std::string a = dir / "ws/cache/relight/k1", b = dir / "ws/cache/inverse/k2", c = dir / "ws/cache/ingest/k3";
  for (const auto& d : {a, b, c}) fs::create_directories(d);
  WriteJsonAtomic(a + "/status.json", Json{{"seconds", 2.0}, {"upstream", {{"inverse", "k2"}}}});
  WriteJsonAtomic(b + "/status.json", Json{{"seconds", 3.0}, {"upstream", {{"ingest", "k3"}}}});
  WriteJsonAtomic(c + "/status.json", Json{{"seconds", 0.5}, {"upstream", Json::object()}});
  const OrderedJson s = CollectStageSeconds({{"relight", a}});
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s.begin().key(), "ingest");  // pipeline order
  EXPECT_DOUBLE_EQ(s["inverse"].get<double>(), 3.0);
  EXPECT_DOUBLE_EQ(s["relight"].get<double>(), 2.0);
  EXPECT_TRUE(CollectStageSeconds({{"relight", dir / "nowhere"}}).empty());
}

}  // namespace
}  // namespace relight

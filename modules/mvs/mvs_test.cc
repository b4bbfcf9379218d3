// Unit tests of the mvs module: COLMAP map format, pixel conventions, the NCC
// cost against its plain reference, PatchMatch on a fronto-parallel plane
// (exact depth), source-view selection and depth ranges (with and without
// sparse points), geometric iterations on noisy views and COLMAP's
// stereo_fusion reading our maps. (The scores against ground truth:
// evaluate/mvs_evaluation_test.cc.)
#include "mvs/mvs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <set>

#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "core/stats.h"
#include "geometry/mesh_io.h"
#include "mvs/colmap_mat.h"
#include "mvs/colmap_tools.h"
#include "mvs/hole_filling.h"
#include "mvs/mesh_metrics.h"
#include "mvs/mvs_workspace.h"
#include "mvs/ncc_cost.h"
#include "mvs/patch_match.h"
#include "mvs/stereo_view.h"
#include "mvs/test_scene.h"
#include "mvs/view_selection.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;
using mvs_test::TestScene;

class MvsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    InitLogging("mvs_test", "", LogLevel::kError);
    setenv("RELIGHT_PROGRESS", "off", 1);
  }
};

TEST_F(MvsTest, ColmapMatHasColmapsByteLayoutAndRoundTrips) {
  ColmapMat mat(3, 2, 2);
  for (size_t i = 0; i < mat.data.size(); ++i) mat.data[i] = 0.5f * float(i) - 1.0f;
  mat.at(1, 2, 1) = 42.0f;  // row 1, col 2, channel 1
  const std::string bytes = EncodeColmapMat(mat);
  ASSERT_EQ(bytes.substr(0, 6), "3&2&2&");
  ASSERT_EQ(bytes.size(), 6 + 3 * 2 * 2 * sizeof(float));
  // Planar, row-major: (row 1, col 2, channel 1) is element 1·6 + 1·3 + 2 = 11 (COLMAP's Mat::Get).
  float value;
  std::memcpy(&value, bytes.data() + 6 + 11 * sizeof(float), sizeof(float));
  EXPECT_EQ(value, 42.0f);

  testing::TempDir dir;
  WriteColmapMat(dir / "m.bin", mat);
  const ColmapMat back = ReadColmapMat(dir / "m.bin");
  EXPECT_EQ(back.width, 3);
  EXPECT_EQ(back.height, 2);
  EXPECT_EQ(back.channels, 2);
  EXPECT_EQ(back.data, mat.data);

  WriteFileAtomic(dir / "truncated.bin", bytes.substr(0, bytes.size() - 3));
  EXPECT_THROW(ReadColmapMat(dir / "truncated.bin"), UserError);
  WriteFileAtomic(dir / "text.bin", "hello world");
  EXPECT_THROW(ReadColmapMat(dir / "text.bin"), UserError);
  EXPECT_THROW(ReadColmapMat(dir / "missing.bin"), UserError);
}

TEST_F(MvsTest, ColmapConventionMapsPutPixelsOnTheEstimatedPlane) {
  // A slanted plane n·X = q seen by a pinhole camera.
  Eigen::Matrix3d K;
  K << 200, 0, 80.3, 0, 190, 61.7, 0, 0, 1;
  const Eigen::Vector3f n = Eigen::Vector3f(0.4f, -0.3f, -1.0f).normalized();
  const float q = n.dot(Eigen::Vector3f(0, 0, 4.0f));
  const Eigen::Matrix3f K_inv = K.inverse().cast<float>();
  DepthNormalMap map(160, 120);
  for (int row = 0; row < 120; ++row) {
    for (int col = 0; col < 160; ++col) {
      const Eigen::Vector3f ray = K_inv * Eigen::Vector3f(col + 0.5f, row + 0.5f, 1);
      map.depth[map.index(col, row)] = q / n.dot(ray);
      map.normal_cam[map.index(col, row)] = n;
    }
  }
  map.depth[map.index(5, 5)] = 0;  // an empty pixel stays empty
  map.normal_cam[map.index(5, 5)].setZero();
  ColmapMat depth, normal;
  ToColmapMaps(map, K, &depth, &normal);
  double max_plane_error = 0, max_shift = 0;
  for (int row = 0; row < 120; ++row) {
    for (int col = 0; col < 160; ++col) {
      if (col == 5 && row == 5) continue;
      // stereo_fusion's back-projection: d · K⁻¹ (col, row, 1).
      const Eigen::Vector3f X = depth.at(row, col) * (K_inv * Eigen::Vector3f(float(col), float(row), 1));
      max_plane_error = std::max(max_plane_error, double(std::abs(n.dot(X) - q)));
      max_shift = std::max(max_shift, double(std::abs(depth.at(row, col) - map.depth[map.index(col, row)])));
      EXPECT_FLOAT_EQ(normal.at(row, col, 2), n.z());
    }
  }
  EXPECT_LT(max_plane_error, 1e-5);
  EXPECT_GT(max_shift, 1e-3);  // the conversion really moves depths on a slanted plane
  EXPECT_EQ(depth.at(5, 5), 0.0f);
  const DepthNormalMap back = FromColmapMaps(depth, normal, K, "test");
  for (size_t i = 0; i < map.depth.size(); ++i) ASSERT_NEAR(back.depth[i], map.depth[i], 2e-5f * 5) << i;
  EXPECT_EQ(back.depth[back.index(5, 5)], 0.0f);
}

Image RandomTexture(int w, int h, uint32_t seed) {
  // Smooth random texture: bilinear upsampling of coarse noise.
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.1f, 0.9f);
  Image coarse(w / 4 + 2, h / 4 + 2, 1);
  for (float& v : coarse.pixels) v = u(rng);
  Image img(w, h, 1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) SampleBilinear(coarse, (x + 0.5) / 4.0, (y + 0.5) / 4.0, &img.at(x, y));
  }
  return img;
}

TEST_F(MvsTest, VectorizedNccMatchesPlainLoopAndClosedForms) {
  const Image ref = RandomTexture(64, 48, 1);
  const Image src = RandomTexture(64, 48, 2);
  for (int radius : {3, 5}) {
    for (int step : {1, 2}) {
      const WindowPattern pattern = MakeWindowPattern(radius, step, 5.0f);
      std::mt19937 rng(radius * 10 + step);
      std::uniform_real_distribution<float> jitter(-0.05f, 0.05f), shift(-6, 6);
      RefWindow window;
      const SamplingImage sampling = MakeSamplingImage(src);
      double max_diff = 0, max_diff_portable = 0;
      for (int trial = 0; trial < 200; ++trial) {
        Homography H;
        H << 1 + jitter(rng), jitter(rng), shift(rng), jitter(rng), 1 + jitter(rng), shift(rng),
            0.002f * jitter(rng), 0.002f * jitter(rng), 1;
        const int col = 2 + trial % 60, row = 2 + (trial * 7) % 44;
        PrepareRefWindow(ref, col, row, pattern, 0.2f, &window);
        const float fast = NccCost(window, pattern, H, sampling);
        const float portable = NccCostPortable(window, pattern, H, sampling);
        const float plain = NccCostPlain(ref, col, row, radius, step, 0.2f, 5.0f, H, src);
        max_diff = std::max(max_diff, double(std::abs(fast - plain)));
        max_diff_portable = std::max(max_diff_portable, double(std::abs(portable - plain)));
      }
      EXPECT_LT(max_diff, 2e-4) << "radius " << radius << " step " << step << " avx2 " << NccCostUsesAvx2();
      EXPECT_LT(max_diff_portable, 2e-4) << "radius " << radius << " step " << step;
    }
  }
  // Identity warp of the same image: NCC 1; of the negated image: NCC -1; flat source: maximal cost.
  const WindowPattern pattern = MakeWindowPattern(5, 2, 5.0f);
  RefWindow window;
  PrepareRefWindow(ref, 30, 20, pattern, 0.2f, &window);
  const Homography I = Homography::Identity();
  EXPECT_NEAR(NccCost(window, pattern, I, MakeSamplingImage(ref)), 0.0f, 1e-4f);
  Image negated = ref;
  for (float& v : negated.pixels) v = 1.0f - v;
  EXPECT_NEAR(NccCost(window, pattern, I, MakeSamplingImage(negated)), 2.0f, 1e-4f);
  EXPECT_EQ(NccCost(window, pattern, I, MakeSamplingImage(Image(64, 48, 1, 0.5f))), kMaxNccCost);
  // A window that maps outside the source image sees nothing.
  Homography far = I;
  far(0, 2) = 500;
  EXPECT_EQ(NccCost(window, pattern, far, MakeSamplingImage(ref)), kMaxNccCost);
}

// Cameras 3 units in front of a textured square, all looking along +z, displaced sideways.
TestScene PlaneScene(double tilt_deg) {
  TriangleMesh square = mvs_test::MakeSquare(8.0, 0.0);
  const Eigen::Matrix3f R = Eigen::AngleAxisf(float(tilt_deg * M_PI / 180), Eigen::Vector3f::UnitX()).toRotationMatrix();
  for (auto& v : square.vertices) v = R * v + Eigen::Vector3f(0, 0, 3);
  square.ComputeVertexNormals();
  const std::vector<ImageRecord> poses =
      mvs_test::CamerasLookingAlongZ({{0, 0, 0}, {0.5, 0, 0}, {-0.5, 0, 0}, {0, 0.5, 0}, {0, -0.5, 0}}, "plane_");
  const Camera camera = Camera::Pinhole(1, 160, 120, 150, 150, 80, 60);
  return mvs_test::RenderScene(square, camera, poses, 400, 3);
}

std::vector<StereoView> ViewsWithImages(const TestScene& scene, int max_image_size = 0) {
  std::vector<StereoView> views;
  size_t k = 0;
  for (const auto& [id, image] : scene.model.images) {
    StereoView v = MakeStereoView(scene.model, image, max_image_size);
    v.gray = mvs_test::ToGray(scene.images[k++]);
    views.push_back(std::move(v));
  }
  return views;
}

TEST_F(MvsTest, PatchMatchRecoversTheExactDepthOfAFrontoParallelPlane) {
  const TestScene scene = PlaneScene(0.0);
  const std::vector<StereoView> views = ViewsWithImages(scene);
  MvsOptions options;
  const std::vector<ViewSelection> plans = SelectViews(scene.model, views, options);
  ASSERT_EQ(plans[0].sources.size(), 4u);
  EXPECT_LT(plans[0].depth_min, 3.0);
  EXPECT_GT(plans[0].depth_max, 3.0);
  PatchMatchProblem problem;
  problem.ref = &views[0];
  for (int s : plans[0].sources) problem.sources.push_back(&views[s]);
  problem.depth_min = plans[0].depth_min;
  problem.depth_max = plans[0].depth_max;
  DepthNormalMap map = RunPatchMatch(options, problem, false, options.num_iterations);
  // Every source sees the centre 120×80 pixels (the cameras move by 25 px at depth 3).
  std::vector<double> depth_error, normal_error_deg;
  for (int row = 20; row < 100; ++row) {
    for (int col = 30; col < 130; ++col) {
      const size_t i = map.index(col, row);
      depth_error.push_back(std::abs(map.depth[i] - 3.0) / 3.0);
      normal_error_deg.push_back(std::acos(std::clamp(-double(map.normal_cam[i].z()), -1.0, 1.0)) * 180 / M_PI);
    }
  }
  std::sort(depth_error.begin(), depth_error.end());
  std::sort(normal_error_deg.begin(), normal_error_deg.end());
  const double median = depth_error[depth_error.size() / 2], p95 = depth_error[depth_error.size() * 95 / 100];
  std::printf("fronto-parallel plane: relative depth error median %.2e, 95%% %.2e; normal error median %.2f deg\n",
              median, p95, normal_error_deg[normal_error_deg.size() / 2]);
  EXPECT_LT(median, 3e-4);  // 0.03% of the depth: ~1/30 pixel of disparity
  EXPECT_LT(p95, 2e-3);
  EXPECT_LT(normal_error_deg[normal_error_deg.size() * 9 / 10], 3.0);

  // Filtering keeps (almost) all of the central region and the geometric pass agrees with it.
  const FilterStats stats = FilterDepthMap(options, problem, false, &map);
  EXPECT_GT(stats.valid_after, 0.8);
}

TEST_F(MvsTest, SourceSelectionPicksNeighboursAndBoundsTheTrueDepths) {
  const Camera camera = Camera::Pinhole(1, 96, 72, 90, 90, 48, 36);
  const auto poses = mvs_test::LookAtCameras(mvs_test::TwoRingCenters(6, 3.5), Eigen::Vector3d::Zero());
  const TestScene scene = mvs_test::RenderScene(mvs_test::MakeBumpySphere(3), camera, poses, 1500, 5);
  std::vector<StereoView> views;
  for (const auto& [id, image] : scene.model.images) views.push_back(MakeStereoView(scene.model, image, 0));
  MvsOptions options;
  options.max_source_images = 3;
  const std::vector<ViewSelection> plans = SelectViews(scene.model, views, options);
  ASSERT_EQ(plans.size(), 12u);
  for (const ViewSelection& plan : plans) {
    ASSERT_TRUE(plan.skip_reason.empty()) << plan.skip_reason;
    ASSERT_EQ(plan.sources.size(), 3u);
    // The best source is among the 4 nearest cameras.
    const Eigen::Vector3d c = views[plan.ref].CenterWorld();
    std::vector<double> distances;
    for (size_t j = 0; j < views.size(); ++j) {
      if (int(j) != plan.ref) distances.push_back((views[j].CenterWorld() - c).norm());
    }
    std::sort(distances.begin(), distances.end());
    EXPECT_LE((views[plan.sources[0]].CenterWorld() - c).norm(), distances[3] + 1e-9);
    // The depth range holds every true depth of the view.
    const Image& depth = scene.depths[plan.ref];
    float lo = 1e9f, hi = 0;
    for (float d : depth.pixels) {
      if (d > 0) lo = std::min(lo, d), hi = std::max(hi, d);
    }
    EXPECT_LE(plan.depth_min, lo);
    EXPECT_GE(plan.depth_max, hi);
  }
  // Without sparse points (cameras given as ground truth) the poses alone choose: still neighbours, still
  // a range holding every true depth.
  Reconstruction no_points = scene.model;
  no_points.points3d.clear();
  const std::vector<ViewSelection> from_poses = SelectViews(no_points, views, options);
  for (const ViewSelection& plan : from_poses) {
    ASSERT_TRUE(plan.skip_reason.empty()) << plan.skip_reason;
    EXPECT_TRUE(plan.from_poses);
    ASSERT_EQ(plan.sources.size(), 3u);
    const Eigen::Vector3d c = views[plan.ref].CenterWorld();
    std::vector<double> distances;
    for (size_t j = 0; j < views.size(); ++j) {
      if (int(j) != plan.ref) distances.push_back((views[j].CenterWorld() - c).norm());
    }
    std::sort(distances.begin(), distances.end());
    EXPECT_LE((views[plan.sources[0]].CenterWorld() - c).norm(), distances[3] + 1e-9);
    const Image& depth = scene.depths[plan.ref];
    float lo = 1e9f, hi = 0;
    for (float d : depth.pixels) {
      if (d > 0) lo = std::min(lo, d), hi = std::max(hi, d);
    }
    EXPECT_LE(plan.depth_min, lo);
    EXPECT_GE(plan.depth_max, hi);
  }
}

TEST_F(MvsTest, FrustumOverlapBoundsTheDepthsThatSourcesSee) {
  // Closed form: a source beside the reference (baseline b along +x, parallel axes, focal f, width w, principal
  // point at the centre). Reference ray through image column u sees the source's image from depth f b / u on,
  // up to infinity; the rays at the right border (u = w) enter first: depth_min = f b / w, depth_max = ∞.
  const double f = 90, b = 0.5;
  const int w = 96, h = 72;
  const Camera camera = Camera::Pinhole(1, w, h, f, f, w / 2.0, h / 2.0);
  Reconstruction model;
  model.cameras[1] = camera;
  for (uint32_t id = 1; id <= 3; ++id) {
    ImageRecord image;
    image.image_id = id;
    image.camera_id = 1;
    image.name = "view_" + std::to_string(id);
    image.SetPose(Eigen::Matrix3d::Identity(), Eigen::Vector3d((id - 1) * b, 0, 0));
    model.images[id] = image;
  }
  std::vector<StereoView> views;
  for (const auto& [id, image] : model.images) views.push_back(MakeStereoView(model, image, 0));
  double lo = 0, hi = 0;
  ASSERT_TRUE(FrustumOverlapDepthRange(views[0], {&views[1]}, 1, &lo, &hi));
  EXPECT_NEAR(lo, f * b / w, 1e-12);
  EXPECT_TRUE(std::isinf(hi));
  // Two sources (baselines b and 2b): both see the point only from f · 2b / w on.
  ASSERT_TRUE(FrustumOverlapDepthRange(views[0], {&views[1], &views[2]}, 2, &lo, &hi));
  EXPECT_NEAR(lo, f * 2 * b / w, 1e-12);
  // A source looking away sees nothing of the reference's frustum.
  model.images[3].SetPose(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix(),
                          Eigen::Vector3d(0, 0, -1));
  const StereoView away = MakeStereoView(model, model.images[3], 0);
  EXPECT_FALSE(FrustumOverlapDepthRange(views[0], {&away}, 1, &lo, &hi));
}

TEST_F(MvsTest, DepthRangeWithoutSparsePointsIsTheSourcesOverlapOnARing) {
  // A ring of 16 cameras 6 units from a bumpy sphere of radius ~1 (true depths 4.9..6.2), 30° up, a 35° field
  // of view, the sphere filling about half the image width, as in configs/synthetic_ring.yaml. Without sparse
  // points the range was the scene centre's depth ÷/× 3, [2, 18] (an inverse-depth span of 8 / (3 z)); where
  // three quarters of the 8 sources see the reference's rays, it must still hold every true depth and be at
  // least 2.5 times narrower in inverse depth ([3.80, 9.97] here: 2.73 times).
  const Camera camera = Camera::Pinhole(1, 96, 72, 150, 150, 48, 36);
  std::vector<Eigen::Vector3d> centers;
  for (int k = 0; k < 16; ++k) {
    const double azimuth = 2 * M_PI * k / 16, elevation = M_PI / 6;
    centers.emplace_back(6 * std::cos(elevation) * std::cos(azimuth), 6 * std::cos(elevation) * std::sin(azimuth),
                         6 * std::sin(elevation));
  }
  const auto poses = mvs_test::LookAtCameras(centers, Eigen::Vector3d::Zero());
  TestScene scene = mvs_test::RenderScene(mvs_test::MakeBumpySphere(3), camera, poses, 0, 5);
  scene.model.points3d.clear();
  std::vector<StereoView> views;
  for (const auto& [id, image] : scene.model.images) views.push_back(MakeStereoView(scene.model, image, 0));
  const MvsOptions options;  // 8 sources
  const std::vector<ViewSelection> plans = SelectViews(scene.model, views, options);
  for (const ViewSelection& plan : plans) {
    ASSERT_TRUE(plan.skip_reason.empty()) << plan.skip_reason;
    ASSERT_TRUE(plan.from_poses);
    ASSERT_EQ(plan.sources.size(), 8u);
    const Image& depth = scene.depths[plan.ref];
    float lo = 1e9f, hi = 0;
    for (float d : depth.pixels) {
      if (d > 0) lo = std::min(lo, d), hi = std::max(hi, d);
    }
    ASSERT_GT(hi, lo);
    EXPECT_LE(plan.depth_min, lo);
    EXPECT_GE(plan.depth_max, hi);
    const double z = 6.0;  // the scene centre's depth
    const double old_span = 3 / z - 1 / (3 * z);
    const double span = 1 / plan.depth_min - 1 / plan.depth_max;
    EXPECT_LE(span, old_span / 2.5) << plan.depth_min << " " << plan.depth_max;
  }
}

TEST_F(MvsTest, SourceSelectionPrefersNeighboursToViewsFromTheFarSide) {
  // A ring of 8 cameras (45° apart) around the origin. The reference (view 0) shares 30 sparse points with its
  // neighbour (view 1, 45° triangulation angle), 60 with the camera opposite (view 4, about 180°) and 40 with
  // view 3 (135°), as a ground mosaic matched from both sides of a ring would. Ranked by shared points alone,
  // as COLMAP's __auto__ selection does, views 4 and 3 would come first. Weighted by (1 + cos α) / 2 the scores
  // are 30 · 0.854 = 25.6, 40 · 0.146 = 5.9 and 60 · ~0.001: the neighbour first, view 3 second, and view 4
  // not at all (below min_shared_points = 5).
  const Camera camera = Camera::Pinhole(1, 96, 72, 90, 90, 48, 36);
  std::vector<Eigen::Vector3d> centers;
  for (int k = 0; k < 8; ++k) centers.emplace_back(4 * std::cos(k * M_PI / 4), 4 * std::sin(k * M_PI / 4), 0);
  Reconstruction model;
  model.cameras[1] = camera;
  for (const ImageRecord& image : mvs_test::LookAtCameras(centers, Eigen::Vector3d::Zero()))
    model.images[image.image_id] = image;
  std::vector<uint32_t> ids;
  for (const auto& [id, image] : model.images) ids.push_back(id);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(-0.05, 0.05);
  uint64_t next_id = 1;
  const auto add_points = [&](int count, uint32_t a, uint32_t b) {
    for (int k = 0; k < count; ++k) {
      Point3D point;
      point.point3d_id = next_id++;
      point.xyz = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
      point.track = {{a, 0}, {b, 0}};
      model.points3d[point.point3d_id] = point;
    }
  };
  add_points(30, ids[0], ids[1]);
  add_points(60, ids[0], ids[4]);
  add_points(40, ids[0], ids[3]);
  std::vector<StereoView> views;
  for (const auto& [id, image] : model.images) views.push_back(MakeStereoView(model, image, 0));
  MvsOptions options;
  options.max_source_images = 3;
  const std::vector<ViewSelection> plans = SelectViews(model, views, options);
  ASSERT_TRUE(plans[0].skip_reason.empty()) << plans[0].skip_reason;
  ASSERT_EQ(plans[0].sources.size(), 3u);
  EXPECT_EQ(views[plans[0].sources[0]].image_id, ids[1]);
  EXPECT_EQ(views[plans[0].sources[1]].image_id, ids[3]);
  // Two sharing sources are fewer than the cost's num_best_views (3): the third comes from the poses, the
  // other neighbour (45° at the scene centre, nearest to the preferred 15°).
  EXPECT_EQ(plans[0].num_pose_sources, 1);
  EXPECT_EQ(views[plans[0].sources[2]].image_id, ids[7]);
  EXPECT_EQ(plans[0].shared_points[0], 30);
  EXPECT_EQ(plans[0].shared_points[1], 40);
  // Points within 0.05 of the centre, cameras 4 away: angles within 1.5° of 45° and 135°.
  EXPECT_NEAR(plans[0].shared_score[0], 30 * 0.5 * (1 + std::cos(M_PI / 4)), 0.6);
  EXPECT_NEAR(plans[0].shared_score[1], 40 * 0.5 * (1 - std::cos(M_PI / 4)), 0.8);
  EXPECT_NEAR(plans[0].median_angle_deg[0], 45.0, 1.5);
  // View 4 shares points with the reference only, at about 180°: no source from the points; its neighbours
  // (views 3 and 5, 45°) come from the poses.
  ASSERT_TRUE(plans[4].skip_reason.empty()) << plans[4].skip_reason;
  ASSERT_GE(plans[4].sources.size(), 2u);
  EXPECT_EQ(plans[4].num_pose_sources, static_cast<int>(plans[4].sources.size()));
  const std::set<uint32_t> first_two{views[plans[4].sources[0]].image_id, views[plans[4].sources[1]].image_id};
  EXPECT_EQ(first_two, (std::set<uint32_t>{ids[3], ids[5]}));
}

TEST_F(MvsTest, GeometricIterationsMakeNoisyViewsAgree) {
  // The bumpy sphere seen by 12 cameras (96 × 72 px, 4 sources each), each photo with its own strong pixel
  // noise (σ 0.08 on [0, 1]), so the photometric maps are noisy. Each geometric iteration matches against the
  // sources' maps of the one before: one must put at least 0.02 more of the sphere's pixels within 1% of each
  // view's true depth range than the photometric maps, three at least 0.02 more than one (0.22, 0.27 and 0.31
  // here); the intermediate maps are deleted, and a second run reuses every image.
  const Camera camera = Camera::Pinhole(1, 96, 72, 90, 90, 48, 36);
  const auto poses = mvs_test::LookAtCameras(mvs_test::TwoRingCenters(6, 3.5), Eigen::Vector3d::Zero());
  TestScene scene = mvs_test::RenderScene(mvs_test::MakeBumpySphere(4), camera, poses, 1500, 5);
  std::mt19937 rng(11);
  std::normal_distribution<float> noise(0.0f, 0.08f);
  for (Image& image : scene.images) {
    for (float& v : image.pixels) v = std::clamp(v + noise(rng), 0.0f, 1.0f);
  }
  testing::TempDir dir;
  mvs_test::WriteSfmWorkspace(scene, dir / "sfm");
  const auto completeness = [&](const MvsWorkspace& ws, const std::string& type) {
    double sum = 0;
    size_t k = 0;
    for (const auto& [id, image] : scene.model.images) {
      const DepthNormalMap map = ws.ReadMaps(MakeStereoView(scene.model, image, 0), type);
      const Image& depth = scene.depths[k++];
      float lo = 1e9f, hi = 0;
      for (float d : depth.pixels) {
        if (d > 0) lo = std::min(lo, d), hi = std::max(hi, d);
      }
      size_t good = 0, object = 0;
      for (size_t i = 0; i < map.depth.size(); ++i) {
        if (!(depth.pixels[i] > 0)) continue;
        ++object;
        good += std::abs(map.depth[i] - depth.pixels[i]) <= 0.01f * (hi - lo);
      }
      sum += double(good) / object;
    }
    return sum / scene.images.size();
  };
  MvsOptions options;
  options.max_source_images = 4;
  options.geom_iterations = 1;
  MvsSummary one_summary;
  const MvsWorkspace one = PrepareMvsWorkspace(dir / "sfm", dir / "one");
  ComputeDepthMaps(options, one, &one_summary);
  options.geom_iterations = 3;
  MvsSummary three_summary;
  const MvsWorkspace three = PrepareMvsWorkspace(dir / "sfm", dir / "three");
  ComputeDepthMaps(options, three, &three_summary);
  const double photometric = completeness(one, "photometric");
  const double after_one = completeness(one, "geometric_unfiltered");
  const double after_three = completeness(three, "geometric_unfiltered");
  std::printf("noisy sphere: completeness photometric %.3f, 1 geometric iteration %.3f, 3 iterations %.3f\n",
              photometric, after_one, after_three);
  EXPECT_GT(after_one, photometric + 0.02);
  EXPECT_GT(after_three, after_one + 0.02);
  const std::string name = scene.model.images.begin()->second.name;
  EXPECT_FALSE(three.HasMaps(name, "geometric_unfiltered_1"));
  EXPECT_FALSE(three.HasMaps(name, "geometric_unfiltered_2"));
  MvsSummary again;
  ComputeDepthMaps(options, three, &again);
  EXPECT_EQ(again.num_reused, 12);
}

TEST_F(MvsTest, StereoFusionFusesOurMapsOntoTheSurface) {
  // True depth and normal maps of a slanted plane, written in our format: COLMAP's stereo_fusion must read
  // them and put every fused point on the plane (a half-pixel convention error would miss it by ~5e-3).
  const TestScene scene = PlaneScene(30.0);
  testing::TempDir dir;
  mvs_test::WriteSfmWorkspace(scene, dir / "sfm");
  const MvsWorkspace ws = PrepareMvsWorkspace(dir / "sfm", dir / "out");
  std::vector<std::string> names;
  const Eigen::Vector3d n_world =
      Eigen::AngleAxisd(30 * M_PI / 180, Eigen::Vector3d::UnitX()) * Eigen::Vector3d(0, 0, -1);
  size_t k = 0;
  for (const auto& [id, image] : scene.model.images) {
    const StereoView view = MakeStereoView(scene.model, image, 0);
    DepthNormalMap map(view.width, view.height);
    const Image& depth = scene.depths[k++];
    for (size_t i = 0; i < map.depth.size(); ++i) {
      map.depth[i] = depth.pixels[i];
      if (depth.pixels[i] > 0) map.normal_cam[i] = (view.R_cam_from_world * n_world).cast<float>();
    }
    ws.WriteMaps(view, map, "geometric");
    names.push_back(image.name);
  }
  WriteFusionConfig(ws, names);
  // Without maps listed, COLMAP fuses nothing: a clear error, not an empty file.
  WriteFusionConfig(ws, {});
  EXPECT_THROW(RunStereoFusion(MvsOptions{}, ws.dir, "geometric", dir / "out/empty.ply"), UserError);
  EXPECT_FALSE(fs::exists(dir / "out/empty.ply"));
  WriteFusionConfig(ws, names);
  const size_t points = RunStereoFusion(MvsOptions{}, ws.dir, "geometric", dir / "out/fused.ply");
  EXPECT_GT(points, 4000u);  // about one per pixel seen by all five views (fusion_min_num_pixels = 5)
  const TriangleMesh fused = ReadMesh(dir / "out/fused.ply");
  ASSERT_EQ(fused.num_vertices(), points);
  ASSERT_EQ(fused.normals.size(), points);
  const std::vector<double> distances = DistancesToMesh(fused.vertices, scene.mesh);
  std::printf("fusion of true maps: %zu points, mean distance to the plane %.2e, max %.2e\n", points,
              Mean(distances), *std::max_element(distances.begin(), distances.end()));
  EXPECT_LT(Mean(distances), 2e-4);
  EXPECT_GT(std::abs(fused.normals[0].cast<double>().dot(n_world)), 0.99);
  // Deterministic (one thread, colmap_tools.h): the same maps give the same file, byte for byte.
  RunStereoFusion(MvsOptions{}, ws.dir, "geometric", dir / "out/fused_again.ply");
  EXPECT_EQ(ReadFileToString(dir / "out/fused.ply"), ReadFileToString(dir / "out/fused_again.ply"));
}

TEST_F(MvsTest, HoleFillingClosesClippedSurfaces) {
  // A sphere cut flat at z = -0.6, as COLMAP's Poisson box clips unobserved sides: one boundary loop.
  TriangleMesh sphere = mvs_test::MakeBumpySphere(3);
  TriangleMesh cut;
  cut.vertices = sphere.vertices;
  for (const auto& f : sphere.faces) {
    if (sphere.vertices[f[0]].z() > -0.6f && sphere.vertices[f[1]].z() > -0.6f && sphere.vertices[f[2]].z() > -0.6f) {
      cut.faces.push_back(f);
    }
  }
  ASSERT_FALSE(AnalyzeTopology(cut).closed());
  const size_t faces_before = cut.num_faces();
  const HoleFillingStats stats = FillHoles(&cut);
  EXPECT_EQ(stats.holes_filled, 1);
  EXPECT_EQ(stats.holes_failed, 0);
  const MeshTopology topology = AnalyzeTopology(cut);
  EXPECT_TRUE(topology.closed()) << topology.boundary_edges << " boundary edges";
  EXPECT_EQ(cut.num_faces(), faces_before + stats.faces_added);
  EXPECT_GT(stats.faces_added, 10u);
  // A closed mesh is left alone.
  TriangleMesh closed = mvs_test::MakeBumpySphere(2);
  EXPECT_EQ(FillHoles(&closed).holes_filled, 0);
}

TEST_F(MvsTest, BadInputsGiveClearErrors) {
  testing::TempDir dir;
  fs::create_directories(dir / "sfm");
  try {
    PrepareMvsWorkspace(dir / "sfm", dir / "out");
    FAIL() << "expected a UserError";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("dense/images"), std::string::npos) << e.what();
  }
  // Debian's COLMAP has no CUDA: engine colmap says so.
  if (!ColmapHasCuda()) {
    try {
      RunColmapPatchMatch(MvsOptions{}, dir.path());
      FAIL() << "expected a UserError";
    } catch (const UserError& e) {
      EXPECT_NE(std::string(e.what()).find("no CUDA"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("mvs.engine: patchmatch"), std::string::npos) << e.what();
    }
  }
  // Cameras that share no sparse points and whose optical axes are parallel (no scene centre for the
  // pose-only fallback): no image can be a reference.
  TestScene scene = PlaneScene(0.0);
  for (auto& [id, image] : scene.model.images) image.points2d.clear();
  scene.model.points3d.clear();
  mvs_test::WriteSfmWorkspace(scene, dir / "nopoints");
  MvsSummary summary;
  const MvsWorkspace ws = PrepareMvsWorkspace(dir / "nopoints", dir / "out2");
  try {
    ComputeDepthMaps(MvsOptions{}, ws, &summary);
    FAIL() << "expected a UserError";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("can be a reference image"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("optical axes"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace relight

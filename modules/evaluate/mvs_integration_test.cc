// End-to-end test of the mvs stage on a synthetic scene with ground truth
// (issue 9, "Done when"): a textured bumpy sphere seen by 16 cameras on two
// rings, rendered with true depth, run through RunMvs with the default
// options and scored by EvaluateMvs: per-view depth completeness (object
// pixels within 1% of the view's true depth range), fused-point accuracy and
// completeness against the true surface and the final mesh's Chamfer distance
// (as fractions of the bounding-box diagonal), a closed mesh, and per-image
// resume after an interrupted run.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "core/log.h"
#include "core/timer.h"
#include "evaluate/mvs_evaluation.h"
#include "mvs/mvs.h"
#include "mvs/test_scene.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

TEST(MvsIntegrationTest, SyntheticSceneMeetsTheAccuracyTargets) {
  InitLogging("mvs_integration_test", "", LogLevel::kWarning);
  setenv("RELIGHT_PROGRESS", "off", 1);
  Timer timer;
  const Camera camera = Camera::Pinhole(1, 320, 240, 300, 300, 160, 120);
  const auto poses = mvs_test::LookAtCameras(mvs_test::TwoRingCenters(8, 3.5), Eigen::Vector3d::Zero());
  const mvs_test::TestScene scene = mvs_test::RenderScene(mvs_test::MakeBumpySphere(5), camera, poses, 3000, 7);
  testing::TempDir dir;
  mvs_test::WriteSfmWorkspace(scene, dir / "sfm");
  mvs_test::WriteGroundTruth(scene, dir / "ground_truth");
  std::printf("scene: %zu views %dx%d, %zu sparse points, diagonal %.3f (%.1fs)\n", scene.images.size(), camera.width,
              camera.height, scene.model.points3d.size(), scene.bbox_diagonal, timer.Seconds());

  const MvsOptions options;  // the defaults
  const MvsSummary summary = RunMvs(options, {dir / "sfm"}, dir / "out");
  std::printf("%s\n", summary.BriefReport().c_str());
  ASSERT_EQ(summary.num_reference_images, 16);
  EXPECT_TRUE(summary.mesh_closed);
  EXPECT_TRUE(fs::exists(dir / "out/meshed_preview.png"));

  const MvsEvaluation e = EvaluateMvs(dir / "out", dir / "ground_truth");
  std::printf("%s\n", e.BriefReport().c_str());
  ASSERT_EQ(e.views.size(), 16u);
  EXPECT_EQ(e.map_type, "geometric");
  EXPECT_NEAR(e.scale, 1.0, 1e-6);             // same frame: the alignment is the identity
  EXPECT_GE(e.mean_depth_completeness, 0.80);  // issue 9: ≥ 80% of visible pixels within 1% of the depth range
  EXPECT_GE(e.min_depth_completeness, 0.70);
  EXPECT_GE(e.fused_accuracy, 0.90);      // within 0.5% of the diagonal
  EXPECT_GE(e.fused_completeness, 0.90);  // within 1% of the diagonal
  ASSERT_TRUE(e.has_mesh);
  EXPECT_LE(e.chamfer, 0.01 * e.diagonal);  // issue 9: Chamfer ≤ 1% of the diagonal

  // A killed run resumes image by image: only the missing image is recomputed.
  const MvsWorkspace ws{dir / "out/dense"};
  const std::string name = scene.model.images.begin()->second.name;
  fs::remove(ws.DepthMapPath(name, "geometric"));
  MvsSummary again;
  ComputeDepthMaps(options, ws, &again);
  EXPECT_EQ(again.num_reused, 15);
  EXPECT_TRUE(fs::exists(ws.DepthMapPath(name, "geometric")));
  std::printf("total %.1fs\n", timer.Seconds());
}

}  // namespace
}  // namespace relight

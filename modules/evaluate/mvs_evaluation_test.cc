// The depth-map scores of EvaluateMvs (mvs_evaluation.h) on a known error
// pattern, against closed forms.
#include "evaluate/mvs_evaluation.h"

#include <gtest/gtest.h>

#include <string>

#include "core/fs.h"
#include "geometry/mesh_io.h"
#include "image/image.h"
#include "mvs/mvs_workspace.h"
#include "mvs/stereo_view.h"
#include "mvs/test_scene.h"
#include "testing/testing.h"

namespace relight {
namespace {

TEST(MvsEvaluation, ScoresDepthMapsAgainstObjectAndSceneRanges) {
  // Four views with the same hand-made true depth: an object rectangle (columns 16..47, rows 12..35) whose depth
  // rises linearly from 3.0 to 3.2 along x (object range 0.2, no step above 2%), on a background at depth 5.0
  // (scene range 2.0). Our depth maps add a known error by column: x % 4 = 0: +0.001 (0.5% of the object range:
  // within both tolerances), 1: -0.01 (5% of the object range, 0.5% of the scene range: within the scene's
  // only), 2: +0.05 (outside both), 3: no depth. Closed forms: object-range completeness 1/4, scene-range 1/2,
  // missing 1/4, median error 0.05 / 0.2; with a 3-pixel edge band the interior is columns 19..44 × rows
  // 15..32 (468 of 768 pixels), 7 of its 26 columns are good (7/26), and the band keeps 66 good of 300 (0.22).
  // Every error is at least a factor 2 from a threshold, so the counts are exact in float. The background is
  // exact except rows 0..5, which have no depth: over every visible pixel (64 × 48) the scene-range completeness
  // is (2304 - 384 background + 384 object) / 3072 = 0.75.
  const Camera camera = Camera::Pinhole(1, 64, 48, 60, 60, 32, 24);
  Reconstruction model;
  model.cameras[1] = camera;
  for (const ImageRecord& image :
       mvs_test::CamerasLookingAlongZ({{0, 0, 0}, {0.3, 0, 0}, {0, 0.3, 0}, {0.3, 0.3, 0.1}}, "eval_"))
    model.images[image.image_id] = image;
  testing::TempDir dir;
  const std::string truth_dir = dir / "ground_truth", out_dir = dir / "out";
  EnsureDir(truth_dir + "/depth");
  EnsureDir(truth_dir + "/masks");
  EnsureDir(out_dir + "/dense/sparse");
  model.WriteText(truth_dir);
  model.WriteBinary(out_dir + "/dense/sparse");
  const TriangleMesh object = mvs_test::MakeSquare(1.0, 3.0);
  WriteMeshPly(truth_dir + "/mesh.ply", object);
  WriteMeshPly(out_dir + "/fused.ply", object);
  const MvsWorkspace ws{out_dir + "/dense"};
  const auto in_object = [](int x, int y) { return x >= 16 && x < 48 && y >= 12 && y < 36; };
  for (const auto& [id, image] : model.images) {
    Image depth(64, 48, 1, 5.0f), mask(64, 48, 1, 0.0f);
    const StereoView view = MakeStereoView(model, image, 0);
    DepthNormalMap map(64, 48);
    for (int y = 0; y < 48; ++y) {
      for (int x = 0; x < 64; ++x) {
        const size_t i = map.index(x, y);
        map.normal_cam[i] = Eigen::Vector3f(0, 0, -1);  // fronto-parallel: the COLMAP conversion keeps the depth
        if (!in_object(x, y)) {
          map.depth[i] = y < 6 ? 0.0f : 5.0f;
          continue;
        }
        depth.at(x, y) = 3.0f + 0.2f * float(x - 16) / 31.0f;
        mask.at(x, y) = 1.0f;
        const float errors[4] = {0.001f, -0.01f, 0.05f, 0.0f};
        map.depth[i] = x % 4 == 3 ? 0.0f : depth.at(x, y) + errors[x % 4];
        if (x % 4 == 3) map.normal_cam[i].setZero();
      }
    }
    const std::string stem = image.name.substr(0, image.name.rfind('.'));
    WriteImage(truth_dir + "/depth/" + stem + ".exr", depth, {PixelType::kFloat});
    WriteImage(truth_dir + "/masks/" + stem + ".png", mask);
    ws.WriteMaps(view, map, "geometric");
  }
  const MvsEvaluation e = EvaluateMvs(out_dir, truth_dir);
  ASSERT_EQ(e.views.size(), 4u);
  EXPECT_EQ(e.map_type, "geometric");
  EXPECT_NEAR(e.scale, 1.0, 1e-9);
  for (const ViewDepthScore& v : e.views) {
    EXPECT_EQ(v.object_pixels, 768u) << v.name;
    EXPECT_NEAR(v.object_depth_range, 0.2, 1e-6) << v.name;
    EXPECT_NEAR(v.scene_depth_range, 2.0, 1e-6) << v.name;
    EXPECT_NEAR(v.completeness, 0.25, 1e-12) << v.name;
    EXPECT_NEAR(v.completeness_scene, 0.5, 1e-12) << v.name;
    EXPECT_NEAR(v.missing, 0.25, 1e-12) << v.name;
    EXPECT_EQ(v.visible_pixels, 3072u) << v.name;
    EXPECT_NEAR(v.completeness_visible, 0.75, 1e-12) << v.name;
    EXPECT_NEAR(v.median_error, 0.05, 1e-4) << v.name;  // float depths near 3: ~1e-7 off
    EXPECT_NEAR(v.edge_fraction, 300.0 / 768.0, 1e-12) << v.name;
    EXPECT_NEAR(v.completeness_interior, 7.0 / 26.0, 1e-12) << v.name;
    EXPECT_NEAR(v.completeness_edge, 0.22, 1e-12) << v.name;
  }
  EXPECT_NEAR(e.mean_depth_completeness, 0.25, 1e-12);
  EXPECT_NEAR(e.min_depth_completeness, 0.25, 1e-12);
  EXPECT_NEAR(e.mean_depth_completeness_scene, 0.5, 1e-12);
  EXPECT_NEAR(e.min_depth_completeness_scene, 0.5, 1e-12);
  EXPECT_NEAR(e.mean_depth_completeness_visible, 0.75, 1e-12);
  EXPECT_NEAR(e.min_depth_completeness_visible, 0.75, 1e-12);
  EXPECT_NEAR(e.mean_missing, 0.25, 1e-12);
  EXPECT_FALSE(e.has_mesh);
}

}  // namespace
}  // namespace relight

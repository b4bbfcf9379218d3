#include "datasets/diligent.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "datasets/light_evaluation.h"
#include "geometry/mesh_io.h"
#include "geometry/reconstruction.h"
#include "image/image.h"
#include "sphere/envmap.h"
#include "sphere/octahedral.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

const std::string kBall = "photometric/diligent_ball";

TEST(DiligentTest, ImportedBallProjectsOntoTheMaskAndLightsExplainTheShading) {
  ASSERT_TRUE(testing::HasSharedData(kBall));
  testing::TempDir dir;
  const std::string folder = testing::SharedDataDir() + "/" + kBall;
  const DiligentScene scene = ImportDiligent(folder, dir / "scene", {4, 100.0});
  EXPECT_EQ(scene.lights.size(), 96u);
  EXPECT_NEAR(scene.radius_px, 70.9, 0.5);
  const Reconstruction model = Reconstruction::ReadText(dir / "scene/ground_truth");
  const TriangleMesh ball = ReadMesh(dir / "scene/ground_truth/mesh.ply");
  const Image mask = ReadImage(folder + "/mask.png");
  // Every camera-facing vertex projects inside the mask, and the silhouette matches its radius.
  const ImageRecord& im = model.images.begin()->second;
  double max_r = 0;
  for (const auto& v : ball.vertices) {
    const Eigen::Vector3d p = v.cast<double>();
    if ((im.ProjectionCenter() - p).dot(p) <= 0) continue;
    Eigen::Vector2d px;
    ASSERT_TRUE(model.Project(im, p, &px));
    max_r = std::max(max_r, (px - scene.center_px).norm());
    const int x = static_cast<int>(px.x()), y = static_cast<int>(px.y());
    if ((px - scene.center_px).norm() < scene.radius_px - 2) {
      EXPECT_GT(mask.at(x, y, 0), 0.5f);
    }
  }
  EXPECT_NEAR(max_r, scene.radius_px, 1.0);
  // The lights explain the photos: Lambertian shading max(0, n·l) correlates with photo 1.
  const Image photo = ReadImage(dir / "scene/images/001.png");
  const Eigen::Vector3d l = scene.lights[0].direction_world;
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  int n = 0;
  for (const auto& v : ball.vertices) {
    const Eigen::Vector3d p = v.cast<double>();
    if ((im.ProjectionCenter() - p).normalized().dot(p) < 0.3) continue;
    Eigen::Vector2d px;
    model.Project(im, p, &px);
    const double a = std::max(0.0, p.dot(l));
    const double b = photo.at(static_cast<int>(px.x()), static_cast<int>(px.y()), 1);
    sa += a;
    sb += b;
    saa += a * a;
    sbb += b * b;
    sab += a * b;
    ++n;
  }
  const double corr = (sab / n - sa / n * sb / n) / std::sqrt((saa / n - sa * sa / n / n) * (sbb / n - sb * sb / n / n));
  EXPECT_GT(corr, 0.9);
  EXPECT_EQ(ReadDirectionalLights(dir / "scene/ground_truth/lights.json").size(), 96u);
}

TEST(DiligentTest, IncompleteFolderIsAClearError) {
  testing::TempDir dir;
  std::ofstream(dir / "filenames.txt") << "001.png\n002.png\n";
  std::ofstream(dir / "light_directions.txt") << "0 0 1\n";
  Image(8, 8, 3, 1.0f);
  WriteImage(dir / "mask.png", Image(8, 8, 3, 1.0f));
  try {
    ImportDiligent(dir.path(), dir / "out");
    FAIL();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("light_directions.txt"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(IsDiligentFolder(dir / "nowhere"));
}

}  // namespace
}  // namespace relight

namespace relight {
namespace {

TEST(LightEvaluationTest, BrightestLobeOfASyntheticMapIsTheLightDirection) {
  const int n = 32;
  const Eigen::Vector3d light = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  Image oct(n, n, 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double a = std::acos(std::clamp(OctTexelDirection(i, j, n).dot(light), -1.0, 1.0));
      for (int c = 0; c < 3; ++c) oct.at(i, j, c) = static_cast<float>((c + 1) * std::exp(-a * a / (2 * 0.08 * 0.08)) + 0.01);
    }
  // A lobe between texel centres is located to a fraction of a texel (texels are ~6°).
  const double deg = std::acos(BrightestLobeDirection(oct).dot(light)) * 180 / M_PI;
  EXPECT_LT(deg, 1.5);
  // Power of a constant map is 4π times its radiance.
  const Image flat(n, n, 3, 2.0f);
  EXPECT_NEAR(OctahedralPower(flat).x(), 8 * M_PI, 1e-9);
}

}  // namespace
}  // namespace relight

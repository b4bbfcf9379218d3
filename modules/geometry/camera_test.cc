#include "geometry/camera.h"

#include <gtest/gtest.h>

#include "core/error.h"

namespace relight {
namespace {

std::vector<Camera> Cameras() {
  std::vector<Camera> cams;
  cams.push_back({1, "SIMPLE_PINHOLE", 640, 480, {500, 320, 240}});
  cams.push_back(Camera::Pinhole(2, 640, 480, 500, 520, 321, 239));
  cams.push_back({3, "SIMPLE_RADIAL", 640, 480, {500, 320, 240, -0.12}});
  cams.push_back({4, "RADIAL", 640, 480, {500, 320, 240, -0.1, 0.02}});
  cams.push_back({5, "OPENCV", 640, 480, {500, 510, 320, 240, -0.1, 0.01, 0.001, -0.002}});
  cams.push_back({6, "FULL_OPENCV", 640, 480, {500, 510, 320, 240, -0.1, 0.01, 0.001, -0.002, 0.001, 0.0, 0.0, 0.0}});
  return cams;
}

TEST(CameraTest, PinholeProjectionClosedForm) {
  const Camera c = Camera::Pinhole(1, 640, 480, 500, 520, 320, 240);
  const Eigen::Vector2d px = c.ImageFromCamera(Eigen::Vector3d(0.2, -0.1, 2.0));
  EXPECT_NEAR(px.x(), 500 * 0.1 + 320, 1e-12);
  EXPECT_NEAR(px.y(), 520 * -0.05 + 240, 1e-12);
  // The optical axis hits the principal point; pixel centres are at +0.5.
  EXPECT_TRUE(c.ImageFromCamera(Eigen::Vector3d(0, 0, 1)).isApprox(Eigen::Vector2d(320, 240)));
}

TEST(CameraTest, UnprojectInvertsProjectForAllModels) {
  for (const Camera& c : Cameras()) {
    c.Check("test");
    for (double x = 5; x < 640; x += 97) {
      for (double y = 5; y < 480; y += 83) {
        const Eigen::Vector3d ray = c.RayFromImage({x, y});
        EXPECT_NEAR(ray.norm(), 1.0, 1e-12);
        const Eigen::Vector2d back = c.ImageFromCamera(ray * 3.0);
        EXPECT_NEAR(back.x(), x, 1e-9) << c.model;
        EXPECT_NEAR(back.y(), y, 1e-9) << c.model;
      }
    }
  }
}

TEST(CameraTest, RescaleMatchesScaledImage) {
  for (Camera c : Cameras()) {
    const Eigen::Vector3d p(0.3, 0.2, 1.5);
    const Eigen::Vector2d before = c.ImageFromCamera(p);
    c.Rescale(0.5);
    EXPECT_EQ(c.width, 320);
    EXPECT_TRUE(c.ImageFromCamera(p).isApprox(before * 0.5, 1e-12)) << c.model;
  }
}

TEST(CameraTest, ValidationNamesProblem) {
  Camera bad{1, "PINHOLE", 640, 480, {500, 500, 320}};
  EXPECT_THROW(bad.Check("cameras.txt"), UserError);
  EXPECT_THROW(Camera::ModelId("FISHEYE_42"), UserError);
}

}  // namespace
}  // namespace relight

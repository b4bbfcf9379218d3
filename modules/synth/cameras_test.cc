// Camera placement: the object is in view at the requested fill, cameras are
// upright within the roll limit, focal lengths follow the 35 mm-equivalent
// definition exactly, and held-out views lie between the photos.
#include "synth/cameras.h"

#include <gtest/gtest.h>

#include <cmath>

namespace relight {
namespace {

TEST(CamerasTest, FocalFrom35mmMatchesFullFrameGeometry) {
  // A 3:2 image is a scaled 36 x 24 mm frame: f_px = f_mm * width_px / 36.
  EXPECT_NEAR(FocalPixelsFrom35mm(50, 3000, 2000), 50.0 * 3000 / 36, 1e-9);
  EXPECT_NEAR(FocalPixelsFrom35mm(28, 600, 400), 28.0 * 600 / 36, 1e-9);
}

TEST(CamerasTest, PhotosSeeTheObjectUprightAtTheRequestedFill) {
  SynthesizeOptions o;
  o.num_photos = 24;
  o.roll_deg_max = 3;
  const Eigen::Vector3d center(0.1, -0.2, 0.4);
  const double radius = 0.6;
  Pcg32 rng(3);
  const std::vector<SyntheticView> views = PlacePhotoCameras(o, center, radius, &rng);
  ASSERT_EQ(views.size(), 24u);
  Reconstruction model = ViewsToReconstruction(views);
  ASSERT_EQ(model.images.size(), 24u);
  double min_az_gap = 360;
  for (size_t i = 0; i < views.size(); ++i) {
    const SyntheticView& v = views[i];
    const Camera& cam = v.camera;
    EXPECT_EQ(v.pose.name, v.name);
    EXPECT_GE(std::max(cam.width, cam.height), o.image_size_min);
    EXPECT_LE(std::max(cam.width, cam.height), o.image_size_max);
    EXPECT_NEAR(cam.FocalX(), FocalPixelsFrom35mm(v.focal_35mm, cam.width, cam.height), 1e-9);
    EXPECT_GE(v.elevation_deg, o.elevation_min_deg);
    EXPECT_LE(v.elevation_deg, o.elevation_max_deg);
    // The object's centre projects near the image centre (aim jitter 0.05 of the object size).
    Eigen::Vector2d pixel;
    double depth;
    ASSERT_TRUE(model.Project(v.pose, center, &pixel, &depth));
    const double shorter = std::min(cam.width, cam.height);
    EXPECT_LT((pixel - Eigen::Vector2d(cam.width / 2.0, cam.height / 2.0)).norm(), 0.1 * shorter);
    // Fill: angular diameter of the bounding sphere over the shorter side.
    const double fill = 2 * cam.FocalX() * std::tan(std::asin(radius / v.distance)) / shorter;
    EXPECT_GE(fill, o.object_fill_min - 1e-9);
    EXPECT_LE(fill, o.object_fill_max + 1e-9);
    // Upright: world +Z at the object projects upwards in the image, tilted by at most the roll.
    Eigen::Vector2d above;
    ASSERT_TRUE(model.Project(v.pose, center + Eigen::Vector3d(0, 0, 0.05), &above));
    const Eigen::Vector2d up = above - pixel;
    EXPECT_LT(up.y(), 0);
    const double tilt_deg = std::atan2(std::abs(up.x()), -up.y()) * 180 / M_PI;
    // Perspective adds a little tilt away from the image centre.
    EXPECT_LT(tilt_deg, o.roll_deg_max + 2.0) << v.name;
    for (size_t j = 0; j < i; ++j) {
      const double d = std::fmod(std::abs(v.azimuth_deg - views[j].azimuth_deg) + 360, 360);
      min_az_gap = std::min(min_az_gap, std::min(d, 360 - d));
    }
  }
  // Evenly spaced (15 degrees) with up to 10 degrees of jitter each.
  EXPECT_GT(min_az_gap, 360.0 / 24 - 2 * o.azimuth_jitter_deg - 1e-9);

  std::vector<double> azimuths;
  for (const auto& v : views) azimuths.push_back(v.azimuth_deg);
  o.relight_views = 3;
  const std::vector<SyntheticView> held = PlaceHeldOutCameras(o, center, radius, azimuths);
  ASSERT_EQ(held.size(), 3u);
  for (const auto& h : held) {
    EXPECT_EQ(h.camera.width, o.relight_image_size);
    EXPECT_EQ(h.camera.model, "PINHOLE");
    double nearest = 360;
    for (double a : azimuths) {
      const double d = std::fmod(std::abs(h.azimuth_deg - a) + 360, 360);
      nearest = std::min(nearest, std::min(d, 360 - d));
    }
    EXPECT_GT(nearest, 2.0) << h.name;  // not a training view
  }
}

}  // namespace
}  // namespace relight

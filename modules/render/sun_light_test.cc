// The sun split out of an environment map against the closed form: a uniform sky plus a 0.5° disk of
// known irradiance gives that irradiance and direction back, and a residual that integrates to the sky
// alone; maps without a compact dominant lobe are left whole.
#include "render/sun_light.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace relight {
namespace {

// Lat-long map (height h) of a uniform sky `sky_rgb` plus a disk of angular radius `disk_rad` around
// `sun_dir` with irradiance `sun_e` (per channel, on a surface facing it); each pixel averages 8x8 samples.
EnvMap SkyWithSun(int h, const Eigen::Vector3d& sky_rgb, const Eigen::Vector3d& sun_dir, double disk_rad,
                  const Eigen::Vector3d& sun_e) {
  const int w = 2 * h, ss = 8;
  const double disk_sr = 2 * M_PI * (1 - std::cos(disk_rad));
  const Eigen::Vector3d disk_radiance = sun_e / disk_sr;
  const double cos_disk = std::cos(disk_rad);
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      // Solid-angle-weighted average over the pixel.
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double weight = 0;
      for (int j = 0; j < ss; ++j)
        for (int i = 0; i < ss; ++i) {
          const double theta = M_PI * (y + (j + 0.5) / ss) / h, phi = 2 * M_PI * (x + (i + 0.5) / ss) / w;
          const Eigen::Vector3d d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
          const double jw = std::sin(theta);
          sum += jw * (sky_rgb + (d.dot(sun_dir) >= cos_disk ? disk_radiance : Eigen::Vector3d::Zero()));
          weight += jw;
        }
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = static_cast<float>(sum[c] / weight);
    }
  return EnvMap::FromLatLong(std::move(img));
}

TEST(SunLight, SplitsASunDiskFromAUniformSky) {
  const Eigen::Vector3d sun_dir = Eigen::Vector3d(0.4, -0.3, 0.6).normalized();
  const Eigen::Vector3d sky(0.2, 0.3, 0.5), sun_e(6.0, 5.0, 4.0);
  // The disk is wider than the 0.7° pixels so that sampling puts its irradiance in the pixels exactly.
  const EnvMap env = SkyWithSun(256, sky, sun_dir, 1.5 * M_PI / 180, sun_e);
  const SunSplit split = SplitSun(env, 3.0 * M_PI / 180);
  ASSERT_TRUE(split.found);
  EXPECT_LT(std::acos(std::min(1.0, split.sun.dir_world.dot(sun_dir))) * 180 / M_PI, 0.2);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(split.sun.irradiance_rgb[c], sun_e[c], 0.02 * sun_e[c]) << c;
  // The residual is the sky: its integral 4 pi sky, and it is flat where the sun was.
  const Eigen::Vector3d residual = split.residual.PixelIntegral();
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(residual[c], 4 * M_PI * sky[c], 0.005 * 4 * M_PI * sky[c]) << c;
  EXPECT_NEAR(split.residual.Lookup(sun_dir).x(), sky.x(), 1e-4);
  const double sun_lum = 0.2126 * 6 + 0.7152 * 5 + 0.0722 * 4, sky_lum = 0.2126 * 0.2 + 0.7152 * 0.3 + 0.0722 * 0.5;
  EXPECT_NEAR(split.share, sun_lum / (sun_lum + 4 * M_PI * sky_lum), 0.01);
  // Rotation and intensity of the map carry over to the sun.
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const SunSplit turned = SplitSun(env.Transformed(turn, 2.0), 3.0 * M_PI / 180);
  ASSERT_TRUE(turned.found);
  EXPECT_LT((turned.sun.dir_world - turn * sun_dir).norm(), 0.005);
  EXPECT_NEAR(turned.sun.irradiance_rgb.x(), 2 * sun_e.x(), 0.04 * sun_e.x());
}

TEST(SunLight, LeavesMapsWithoutACompactDominantLobeWhole) {
  const Eigen::Vector3d sun_dir = Eigen::Vector3d(0.1, 0.5, 0.7).normalized();
  // No sun.
  EXPECT_FALSE(
      SplitSun(SkyWithSun(128, Eigen::Vector3d(1, 1, 1), sun_dir, 0.01, Eigen::Vector3d::Zero()), 3.0 * M_PI / 180)
          .found);
  // A wide lobe (15°) is not a sun at R = 3°: the ring around its peak is as bright.
  EXPECT_FALSE(
      SplitSun(SkyWithSun(128, Eigen::Vector3d(0.1, 0.1, 0.1), sun_dir, 15 * M_PI / 180, Eigen::Vector3d(10, 10, 10)),
               3.0 * M_PI / 180)
          .found);
  // A compact but faint one: 1 % of the light.
  EXPECT_FALSE(SplitSun(SkyWithSun(256, Eigen::Vector3d(1, 1, 1), sun_dir, 1.5 * M_PI / 180,
                                   Eigen::Vector3d::Constant(0.01 * 4 * M_PI)),
                        3.0 * M_PI / 180)
                   .found);
  // Octahedral maps (the recovered maps) are left whole.
  const EnvMap oct = EnvMap::FromOctahedral(
      SkyWithSun(128, Eigen::Vector3d(0.1, 0.1, 0.1), sun_dir, 1.5 * M_PI / 180, Eigen::Vector3d(10, 10, 10))
          .ToOctahedral(32));
  EXPECT_FALSE(SplitSun(oct, 3.0 * M_PI / 180).found);
}

}  // namespace
}  // namespace relight

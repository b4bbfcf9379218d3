// Photography against closed forms: the sRGB curve, grey-world white balance and
// log-average exposure on images with known answers, and the sensor-noise model
// checked statistically (mean and variance of many pixels).
#include "synth/photography.h"

#include <gtest/gtest.h>

#include <cmath>

namespace relight {
namespace {

TEST(PhotographyTest, SrgbCurve) {
  EXPECT_NEAR(SrgbEncode(0.0031308), 0.04045, 1e-6);
  EXPECT_NEAR(SrgbEncode(0.5), 0.735356983, 1e-8);
  EXPECT_NEAR(SrgbEncode(1.0), 1.0, 1e-12);
  EXPECT_EQ(SrgbEncode(0.0), 0.0);
  for (double x = 0; x <= 1.0; x += 0.01) EXPECT_NEAR(SrgbDecode(SrgbEncode(x)), x, 1e-12);
}

PhotoStyle Exact() {
  PhotoStyle style;
  style.white_balance_jitter_ev = 0;
  style.exposure_jitter_ev = 0;
  return style;
}

TEST(PhotographyTest, GreyWorldAndKeyValue) {
  Image image(40, 30, 3);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) {
      image.at(x, y, 0) = 5.0f;
      image.at(x, y, 1) = 4.0f;
      image.at(x, y, 2) = 2.0f;
    }
  Pcg32 rng(1);
  const PhotoSettings s = ChoosePhotoSettings(image, Exact(), &rng);
  EXPECT_NEAR(s.white_balance.x(), 0.8, 1e-9);
  EXPECT_NEAR(s.white_balance.y(), 1.0, 1e-12);
  EXPECT_NEAR(s.white_balance.z(), 2.0, 1e-9);
  // White-balanced grey of value 4 everywhere: log-average 4 (up to delta = 1e-3 of the mean) maps to the key.
  EXPECT_NEAR(s.exposure * 4.0, 0.18 / (1 + 1e-3), 1e-6);
  const Image sensor = SensorImage(image, s);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(sensor.at(3, 4, c), 0.18 / (1 + 1e-3), 1e-6);
  PhotoStyle none = Exact();
  none.auto_white_balance = false;
  EXPECT_EQ(ChoosePhotoSettings(image, none, &rng).white_balance, Eigen::Vector3d::Ones());
  // A few very bright pixels (the sun) above the 95th percentile do not tint the grey world.
  for (int x = 0; x < 40; ++x) image.at(x, 0, 2) = 1e6f;
  const PhotoSettings bright = ChoosePhotoSettings(image, Exact(), &rng);
  EXPECT_NEAR(bright.white_balance.z(), 2.0, 1e-9);
}

TEST(PhotographyTest, NoiseHasTheModelledMeanAndVariance) {
  const int w = 300, h = 300;
  Image image(w, h, 3, 1.0f);
  PhotoSettings s;
  s.exposure = 0.25;
  s.noise_shot = 4e-3;
  s.noise_read = 0.01;
  Pcg32 rng(5);
  double clipped = -1;
  const Image photo = DevelopPhoto(image, s, &rng, &clipped);
  EXPECT_EQ(clipped, 0.0);
  // Decode (no clipping happens at 0.25 +- 0.035) and compare the sample moments.
  double sum = 0, sum2 = 0;
  const size_t n = photo.pixels.size();
  for (float v : photo.pixels) {
    const double x = SrgbDecode(v);
    sum += x;
    sum2 += x * x;
  }
  const double mean = sum / n, var = sum2 / n - mean * mean;
  const double expected_var = s.noise_shot * 0.25 + s.noise_read * s.noise_read;
  EXPECT_NEAR(mean, 0.25, 4 * std::sqrt(expected_var / n));
  // Variance of a sample variance of n normals: 2 sigma^4 / (n - 1).
  EXPECT_NEAR(var, expected_var, 4 * std::sqrt(2.0 / (n - 1)) * expected_var);
  // Over-exposure clips.
  s.exposure = 2.0;
  DevelopPhoto(image, s, &rng, &clipped);
  EXPECT_GT(clipped, 0.999);
}

}  // namespace
}  // namespace relight

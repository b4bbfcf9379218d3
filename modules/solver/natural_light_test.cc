// The daylight model of the lighting step's natural-light prior, against maps whose sun and ground are known.
#include "solver/natural_light.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "sphere/octahedral.h"
#include "sphere/sky.h"

namespace relight {
namespace {

constexpr double kPi = 3.14159265358979323846;

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / kPi;
}

// An n×n octahedral map as three channel arrays.
struct OctMap {
  int n = 0;
  std::array<std::vector<double>, 3> c;
  std::array<const double*, 3> Channels() const { return {c[0].data(), c[1].data(), c[2].data()}; }
};

OctMap FromImage(const Image& image) {
  OctMap m;
  m.n = image.width;
  for (int ch = 0; ch < 3; ++ch) {
    m.c[ch].resize(static_cast<size_t>(m.n) * m.n);
    for (int j = 0; j < m.n; ++j)
      for (int i = 0; i < m.n; ++i) m.c[ch][static_cast<size_t>(j) * m.n + i] = image.at(i, j, ch);
  }
  return m;
}

// Weight 1 on the texels whose centre is above the horizon, 0 below: photos that see only the sky.
std::vector<double> UpperWeights(int n) {
  std::vector<double> w(static_cast<size_t>(n) * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) w[static_cast<size_t>(j) * n + i] = OctTexelDirection(i, j, n).z() > 0 ? 1.0 : 0.0;
  return w;
}

// Horizontal irradiance of the upper hemisphere of a map, per channel.
Eigen::Vector3d HorizontalIrradiance(const OctMap& m) {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  for (int j = 0; j < m.n; ++j)
    for (int i = 0; i < m.n; ++i) {
      const Eigen::Vector3d d = OctTexelDirection(i, j, m.n);
      if (d.z() <= 0) continue;
      for (int ch = 0; ch < 3; ++ch)
        e[ch] += m.c[ch][static_cast<size_t>(j) * m.n + i] * d.z() * OctTexelSolidAngle(i, j, m.n);
    }
  return e;
}

TEST(NaturalLightTest, RecoversItsOwnParametersFromAWholeMap) {
  // A map made by the model itself, the sun between the candidate grid's texels.
  NaturalLight truth;
  truth.sun_dir_world = Eigen::Vector3d(0.41, -0.63, 0.52).normalized();
  const int n = 32;
  truth.sun_sigma_rad = 0.5 * std::sqrt(4 * kPi) / n;
  const double coefficients[3][5] = {
      {0.8, 0.3, 0.25, 40.0, 2.0}, {0.9, 0.35, 0.22, 38.0, 1.8}, {1.2, 0.4, 0.2, 33.0, 1.5}};
  for (int ch = 0; ch < 3; ++ch)
    for (int t = 0; t < 5; ++t) truth.coefficients[ch][t] = coefficients[ch][t];
  OctMap m;
  m.n = n;
  m.c = truth.Octahedral(n);
  const NaturalLight fit = FitNaturalLight(m.Channels(), std::vector<double>(n * n, 1.0), n);
  EXPECT_LT(AngleDeg(fit.sun_dir_world, truth.sun_dir_world), 0.5);
  for (int ch = 0; ch < 3; ++ch)
    for (int t = 0; t < 5; ++t)
      EXPECT_NEAR(fit.coefficients[ch][t], coefficients[ch][t], 0.02 * coefficients[ch][t]) << ch << " " << t;
  double sq = 0, area = 0;  // the map's own RMS, weighted as the fit's
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double omega = OctTexelSolidAngle(i, j, n);
      for (int ch = 0; ch < 3; ++ch) sq += omega * std::pow(m.c[ch][static_cast<size_t>(j) * n + i], 2);
      area += 3 * omega;
    }
  EXPECT_LT(fit.weighted_rms, 0.02 * std::sqrt(sq / area));
}

TEST(NaturalLightTest, FindsThePreethamSunAndLightsTheUnseenGroundFromTheSky) {
  // Preetham's clear sky (a different family from the model's), sun 38° high between grid texels; the fit sees
  // only the upper hemisphere.
  SunSkyParams sky;
  sky.sun_dir_world = Eigen::Vector3d(std::cos(0.66) * std::cos(2.1), std::cos(0.66) * std::sin(2.1), std::sin(0.66));
  sky.turbidity = 3;
  sky.ground_albedo = 0.2;
  sky.sun_radius_deg = 3;
  const int n = 32;
  const OctMap m = FromImage(MakeSunSky(sky, 128).ToOctahedral(n));
  const NaturalLight fit = FitNaturalLight(m.Channels(), UpperWeights(n), n);
  EXPECT_LT(AngleDeg(fit.sun_dir_world, sky.sun_dir_world), 3.0);
  EXPECT_GT(fit.sun_irradiance_share, 0.5);  // a clear day: most of the light from the sun
  // The ground nobody saw: the model's Lambertian ground under the fitted sky, against the truth's
  // (same albedo), within 15 %: the fitted sky's irradiance is right.
  const Eigen::Vector3d e = HorizontalIrradiance(m);
  const Eigen::Vector3d ground = fit.Radiance(Eigen::Vector3d(0.3, 0.2, -0.9));
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(ground[ch], 0.2 * e[ch] / kPi, 0.15 * 0.2 * e[ch] / kPi) << ch;
}

TEST(NaturalLightTest, AGroundThePhotosSeeOverridesTheAssumedAlbedo) {
  SunSkyParams sky;
  sky.sun_dir_world = Eigen::Vector3d(-0.3, 0.5, 0.81).normalized();
  sky.ground_albedo = 0.45;  // far from the assumed 0.2
  sky.sun_radius_deg = 3;
  const int n = 32;
  const OctMap m = FromImage(MakeSunSky(sky, 128).ToOctahedral(n));
  const NaturalLight fit = FitNaturalLight(m.Channels(), std::vector<double>(n * n, 1.0), n);
  const Eigen::Vector3d e = HorizontalIrradiance(m);
  const Eigen::Vector3d ground = fit.Radiance(Eigen::Vector3d(0.1, -0.2, -0.95));
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(ground[ch], 0.45 * e[ch] / kPi, 0.1 * 0.45 * e[ch] / kPi) << ch;
}

TEST(NaturalLightTest, NoWeightGivesNoLight) {
  const int n = 16;
  OctMap m;
  m.n = n;
  for (auto& ch : m.c) ch.assign(n * n, 1.0);
  const NaturalLight fit = FitNaturalLight(m.Channels(), std::vector<double>(n * n, 0.0), n);
  EXPECT_EQ(fit.Radiance(Eigen::Vector3d::UnitZ()).norm(), 0.0);
}

// How much of a map the model explains (lighting.json's daylight_explained_variation): a clear sky is described
// by the model, the view up from a street between lit and shaded walls is not (less than half).
TEST(NaturalLightTest, ExplainsTheVariationOfASkyButNotOfAStreet) {
  const int n = 32;
  SunSkyParams sky;
  sky.sun_dir_world = Eigen::Vector3d(0.5, 0.2, 0.6).normalized();
  sky.turbidity = 4;
  sky.sun_radius_deg = 3;
  const NaturalLight clear =
      FitNaturalLight(FromImage(MakeSunSky(sky, 128).ToOctahedral(n)).Channels(), UpperWeights(n), n);
  EXPECT_GT(clear.explained_variation, 0.9);
  // The street runs along x: a strip of overcast sky overhead (|y| < 0.3), walls up to it whose facades alternate
  // between sunlit and shaded every 45° of azimuth (windows, balconies), and the photos see all of it.
  OctMap street;
  street.n = n;
  for (auto& ch : street.c) ch.assign(static_cast<size_t>(n) * n, 0.0);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d d = OctTexelDirection(i, j, n);
      const double azimuth = std::atan2(d.y(), d.x());
      double v = (static_cast<int>(std::floor(azimuth / (kPi / 4))) % 2 == 0) ? 0.6 : 0.05;
      if (d.z() > 0 && std::abs(d.y()) < 0.3) v = 1.0;
      if (d.z() < -0.2) v = 0.1;
      for (int ch = 0; ch < 3; ++ch) street.c[ch][static_cast<size_t>(j) * n + i] = v;
    }
  const NaturalLight walls = FitNaturalLight(street.Channels(), std::vector<double>(n * n, 1.0), n);
  EXPECT_LT(walls.explained_variation, 0.5);
  std::printf("explained variation: clear sky %.3f, street %.3f\n", clear.explained_variation,
              walls.explained_variation);
}

}  // namespace
}  // namespace relight

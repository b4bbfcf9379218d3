#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "core/error.h"
#include "image/image.h"
#include "sphere/envmap.h"
#include "sphere/frame.h"
#include "sphere/octahedral.h"
#include "sphere/sh.h"
#include "sphere/sky.h"
#include "testing/testing.h"

namespace relight {
namespace {

Eigen::Vector3d RandomDir(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
}

// Gauss-Legendre nodes/weights on [-1, 1] (Newton on Legendre polynomials).
void GaussLegendre(int n, std::vector<double>* x, std::vector<double>* w) {
  x->resize(n);
  w->resize(n);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(M_PI * (i + 0.75) / (n + 0.5)), pp = 0;
    for (int it = 0; it < 100; ++it) {
      double p1 = 1, p2 = 0;
      for (int k = 1; k <= n; ++k) {
        const double p3 = p2;
        p2 = p1;
        p1 = ((2 * k - 1) * z * p2 - (k - 1) * p3) / k;
      }
      pp = n * (z * p1 - p2) / (z * z - 1);
      const double dz = p1 / pp;
      z -= dz;
      if (std::abs(dz) < 1e-15) break;
    }
    (*x)[i] = z;
    (*w)[i] = 2 / ((1 - z * z) * pp * pp);
  }
}

// Product Gauss quadrature over the sphere, exact for polynomials of degree < 2 n.
template <typename F>
double IntegrateSphereExact(F f, int n = 24) {
  std::vector<double> x, w;
  GaussLegendre(n, &x, &w);
  double sum = 0;
  const int n_phi = 2 * n;
  for (int i = 0; i < n; ++i) {
    const double r = std::sqrt(1 - x[i] * x[i]);
    for (int k = 0; k < n_phi; ++k) {
      const double phi = 2 * M_PI * (k + 0.5) / n_phi;
      sum += w[i] * (2 * M_PI / n_phi) * f(Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), x[i]));
    }
  }
  return sum;
}

// A smooth positive test environment.
Eigen::Vector3d SmoothRadiance(const Eigen::Vector3d& d) {
  return {1.0 + 0.5 * d.z() + 0.3 * d.x() * d.y(), 0.8 + 0.4 * std::exp(2 * (d.x() - 1)), 0.5 + 0.2 * d.y() * d.y()};
}

Image LatLongOf(int h, Eigen::Vector3d (*f)(const Eigen::Vector3d&)) {
  Image img(2 * h, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < 2 * h; ++x) {
      const double theta = M_PI * (y + 0.5) / h, phi = 2 * M_PI * (x + 0.5) / (2 * h);
      const Eigen::Vector3d v = f({std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)});
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = float(v[c]);
    }
  return img;
}

TEST(OctahedralTest, EncodeDecodeRoundTrip) {
  std::mt19937 rng(1);
  for (int k = 0; k < 20000; ++k) {
    const Eigen::Vector3d d = RandomDir(rng);
    const Eigen::Vector2d st = OctEncode(d);
    ASSERT_GE(st.minCoeff(), 0.0);
    ASSERT_LE(st.maxCoeff(), 1.0);
    EXPECT_LT((OctDecode(st) - d).norm(), 1e-12);
    const Eigen::Vector3d h(d.x(), d.y(), std::abs(d.z()));
    const Eigen::Vector2d ab = HemiOctEncode(h);
    ASSERT_LE(ab.cwiseAbs().maxCoeff(), 1.0 + 1e-15);
    EXPECT_LT((HemiOctDecode(ab) - h).norm(), 1e-12);
  }
  // Landmarks of docs/FORMATS.md: zenith at the centre, nadir at the corners, row 0 towards -Y.
  EXPECT_LT((OctEncode({0, 0, 1}) - Eigen::Vector2d(0.5, 0.5)).norm(), 1e-15);
  EXPECT_LT((OctDecode({0, 0}) - Eigen::Vector3d(0, 0, -1)).norm(), 1e-15);
  EXPECT_LT((OctDecode({1, 1}) - Eigen::Vector3d(0, 0, -1)).norm(), 1e-15);
  EXPECT_LT((OctEncode({0, -1, 0}) - Eigen::Vector2d(0.5, 0.0)).norm(), 1e-15);
  EXPECT_LT((OctEncode({1, 0, 0}) - Eigen::Vector2d(1.0, 0.5)).norm(), 1e-15);
  EXPECT_LT((HemiOctEncode({0, 0, 1})).norm(), 1e-15);
  EXPECT_LT((HemiOctEncode({1, 0, 0}) - Eigen::Vector2d(1, 1)).norm(), 1e-15);
  EXPECT_LT((HemiOctEncode({0, 1, 0}) - Eigen::Vector2d(1, -1)).norm(), 1e-15);
}

TEST(OctahedralTest, TexelIndexConvention) {
  for (int n : {1, 2, 8, 32}) {
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        EXPECT_EQ(OctTexelOf(OctTexelDirection(i, j, n), n), Eigen::Vector2i(i, j));
        EXPECT_EQ(HemiOctTexelOf(HemiOctTexelDirection(i, j, n), n), Eigen::Vector2i(i, j));
      }
  }
  // Texel centre direction = decode of the centre coordinates.
  const Eigen::Vector3d d = OctTexelDirection(3, 5, 16);
  EXPECT_LT((d - OctDecode({3.5 / 16, 5.5 / 16})).norm(), 1e-15);
  const Eigen::Vector3d h = HemiOctTexelDirection(3, 5, 16);
  EXPECT_LT((h - HemiOctDecode({-1 + 7.0 / 16, -1 + 11.0 / 16})).norm(), 1e-15);
}

TEST(OctahedralTest, SolidAnglesSumToSphereAndHemisphere) {
  for (int n : {1, 2, 4, 8, 16, 32, 64, 128}) {
    const auto oct = OctTexelSolidAngles(n);
    const auto hemi = HemiOctTexelSolidAngles(n);
    double sum_oct = 0, sum_hemi = 0;
    for (double a : oct) sum_oct += a;
    for (double a : hemi) sum_hemi += a;
    EXPECT_NEAR(sum_oct, 4 * M_PI, 1e-9) << "n=" << n;
    EXPECT_NEAR(sum_hemi, 2 * M_PI, 1e-9) << "n=" << n;
    if (n == 32) {
      const double ratio_oct = *std::max_element(oct.begin(), oct.end()) / *std::min_element(oct.begin(), oct.end());
      const double ratio_hemi =
          *std::max_element(hemi.begin(), hemi.end()) / *std::min_element(hemi.begin(), hemi.end());
      std::printf("32^2 solid angle max/min: octahedral %.3f, hemi-octahedral %.3f\n", ratio_oct, ratio_hemi);
      EXPECT_NEAR(ratio_oct, 4.6, 0.15);
      EXPECT_NEAR(ratio_hemi, 4.8, 0.15);
    }
  }
}

TEST(OctahedralTest, SolidAnglesMatchJacobianQuadrature) {
  // Exact polygon areas against fine midpoint quadrature of the Jacobian, including fold texels.
  const int n = 8, q = 400;
  for (auto [i, j] : {std::pair{0, 0}, {3, 4}, {1, 2}, {7, 3}, {2, 5}}) {
    double oct = 0, hemi = 0;
    for (int b = 0; b < q; ++b)
      for (int a = 0; a < q; ++a) {
        const double fs = (i + (a + 0.5) / q) / n, ft = (j + (b + 0.5) / q) / n;
        oct += OctJacobian({fs, ft}) / (double(n) * n * q * q);
        hemi += HemiOctJacobian({2 * fs - 1, 2 * ft - 1}) * 4 / (double(n) * n * q * q);
      }
    EXPECT_NEAR(OctTexelSolidAngle(i, j, n), oct, 2e-6 * oct) << i << "," << j;
    EXPECT_NEAR(HemiOctTexelSolidAngle(i, j, n), hemi, 2e-6 * hemi) << i << "," << j;
  }
}

TEST(OctahedralTest, FoldNeighboursAreAdjacentOnTheSphere) {
  const int n = 16;
  const double texel_angle = M_PI / n * 1.6;
  for (int k = 0; k < n; ++k) {
    for (auto [i, j, di, dj] : {std::tuple{0, k, -1, 0}, {n - 1, k, 1, 0}, {k, 0, 0, -1}, {k, n - 1, 0, 1}}) {
      const Eigen::Vector2i w = OctWrapTexel(i + di, j + dj, n);
      ASSERT_TRUE(w.x() >= 0 && w.x() < n && w.y() >= 0 && w.y() < n);
      const double angle =
          std::acos(std::clamp(OctTexelDirection(i, j, n).dot(OctTexelDirection(w.x(), w.y(), n)), -1.0, 1.0));
      EXPECT_LT(angle, texel_angle) << i << "," << j << " -> " << w.transpose();
    }
  }
}

// A sun (a Gaussian lobe of 0.6 texel) on a bright sky with a gradient, at 300 random directions over the whole
// sphere (folds included): CompactLobeDirection finds it within 0.35 texel. BrightestLobeDirection finds a broad
// lobe (2 texels) within 0.35 texel (on the compact one its threshold region is a texel or two: up to 0.65 texel
// off). Both give a single bright texel's direction exactly.
TEST(OctahedralTest, LobeDirectionsFindASunOnASky) {
  const int n = 32;
  const double texel_rad = std::sqrt(4 * M_PI / (n * n)), sigma = 0.6 * texel_rad, sigma_broad = 2 * texel_rad;
  const std::vector<Eigen::Vector3d> dirs = OctTexelDirections(n);
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  double worst_compact = 0, worst_brightest = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d sun = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    std::vector<double> sky(n * n), lobe(n * n);
    for (int k = 0; k < n * n; ++k) {
      const double angle = std::acos(std::clamp(dirs[k].dot(sun), -1.0, 1.0));
      sky[k] = 40 * std::exp(-0.5 * angle * angle / (sigma * sigma)) + 3 + 2 * dirs[k].z() + dirs[k].x();
      lobe[k] = std::exp(-0.5 * angle * angle / (sigma_broad * sigma_broad));
    }
    auto error = [&](const Eigen::Vector3d& d) { return std::acos(std::clamp(d.dot(sun), -1.0, 1.0)) / texel_rad; };
    worst_compact = std::max(worst_compact, error(CompactLobeDirection(sky, n)));
    worst_brightest = std::max(worst_brightest, error(BrightestLobeDirection(lobe, n)));
  }
  EXPECT_LT(worst_compact, 0.35);
  EXPECT_LT(worst_brightest, 0.35);
  std::vector<double> one(n * n, 0.0);
  one[5 * n + 20] = 1;
  EXPECT_LT((BrightestLobeDirection(one, n) - OctTexelDirection(20, 5, n)).norm(), 1e-12);
  EXPECT_LT((CompactLobeDirection(one, n) - OctTexelDirection(20, 5, n)).norm(), 1e-12);
}

TEST(EnvMapTest, LookupIsSeamlessAndMatchesPixels) {
  const EnvMap ll = EnvMap::FromLatLong(LatLongOf(32, SmoothRadiance));
  const EnvMap oct = EnvMap::FromOctahedral(ll.ToOctahedral(32));
  std::mt19937 rng(3);
  for (int k = 0; k < 2000; ++k) {
    const Eigen::Vector3d d = RandomDir(rng);
    // Smooth map: both layouts agree with the function to interpolation accuracy.
    EXPECT_LT((ll.Lookup(d) - SmoothRadiance(d)).norm(), 0.02);
    EXPECT_LT((oct.Lookup(d) - SmoothRadiance(d)).norm(), 0.03);
  }
  // Across the lat-long seam (phi = 0) and the poles, and the octahedral folds.
  for (double z : {-0.9, -0.3, 0.2, 0.8, 0.9999}) {
    const double r = std::sqrt(1 - z * z);
    const Eigen::Vector3d a(r * std::cos(1e-7), r * std::sin(1e-7), z), b(r * std::cos(-1e-7), r * std::sin(-1e-7), z);
    EXPECT_LT((ll.Lookup(a) - ll.Lookup(b)).norm(), 1e-5);
  }
  for (const Eigen::Vector3d& d : {Eigen::Vector3d(0.3, 0.4, -1e-9), Eigen::Vector3d(0.7, 1e-9, -0.3),
                                   Eigen::Vector3d(-1e-9, -0.5, -0.4), Eigen::Vector3d(1e-9, 1e-9, -1)}) {
    const Eigen::Vector3d e = d + Eigen::Vector3d(-2e-9, -2e-9, 2e-9);
    EXPECT_LT((oct.Lookup(d) - oct.Lookup(e)).norm(), 1e-5) << d.transpose();
  }
  // The texel centre returns the texel value exactly.
  const Image& img = oct.image();
  const Eigen::Vector3d v = oct.Lookup(OctTexelDirection(5, 9, 32));
  EXPECT_NEAR(v.x(), img.at(5, 9, 0), 1e-6);
}

TEST(EnvMapTest, ResamplingPreservesIntegral) {
  for (const char* name : {"uffizi.hdr", "grace.hdr"}) {
    const std::string path = testing::SharedDataDir() + "/envmaps/" + name;
    ASSERT_TRUE(testing::HasSharedData(std::string("envmaps/") + name)) << path;
    const EnvMap ll = EnvMap::Load(path);
    const Eigen::Vector3d reference = ll.Integral(8);
    std::printf("%s: integral of the bilinear lookup vs sum of pixels: %.2e\n", name,
                (ll.PixelIntegral() - reference).norm() / reference.norm());
    for (int n : {32, 64}) {
      const EnvMap oct = EnvMap::FromOctahedral(ll.ToOctahedral(n));
      const Eigen::Vector3d integral = oct.PixelIntegral();
      const double rel = (integral - reference).norm() / reference.norm();
      std::printf("%s: lat-long -> oct %d^2 relative integral change %.2e\n", name, n, rel);
      EXPECT_LT(rel, 2e-3) << name << " n=" << n;
      const EnvMap back = EnvMap::FromLatLong(oct.ToLatLong(64));
      EXPECT_LT((back.PixelIntegral() - reference).norm() / reference.norm(), 4e-3) << name << " n=" << n;
    }
  }
}

TEST(EnvMapTest, TransformRotatesFeaturesForward) {
  const EnvMap ll = EnvMap::Load(testing::SharedDataDir() + "/envmaps/uffizi.hdr");
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const EnvMap moved = ll.Transformed(r, 2.5);
  std::mt19937 rng(5);
  for (int k = 0; k < 100; ++k) {
    const Eigen::Vector3d d0 = RandomDir(rng);
    EXPECT_LT((moved.Lookup(r * d0) - 2.5 * ll.Lookup(d0)).norm(), 1e-9 * (1 + ll.Lookup(d0).norm()));
  }
  EXPECT_LT((moved.Integral() - 2.5 * ll.Integral()).norm(), 1e-9 * ll.Integral().norm());
  // Composition: (R2, s2) after (R, s) equals (R2 R, s2 s).
  const Eigen::Matrix3d r2 = Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d d = RandomDir(rng);
  EXPECT_LT((moved.Transformed(r2, 0.5).Lookup(r2 * r * d) - 1.25 * ll.Lookup(d)).norm(), 1e-6);
}

TEST(EnvMapTest, LoadRejectsBadFilesWithTheirName) {
  testing::TempDir dir;
  const std::string square = dir / "square.exr";
  WriteOptions options;
  options.type = PixelType::kFloat;
  WriteImage(square, Image(16, 16, 3, 1.0f), options);
  try {
    EnvMap::Load(square);
    FAIL() << "expected UserError";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("square.exr"), std::string::npos) << e.what();
  }
  try {
    EnvMap::Load(dir / "missing.hdr");
    FAIL() << "expected UserError";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.hdr"), std::string::npos) << e.what();
  }
}

TEST(EnvMapTest, LoadRejectsNanAndClampsNegativeRadiance) {
  testing::TempDir dir;
  WriteOptions options;
  options.type = PixelType::kFloat;
  Image nan_map(16, 8, 3, 0.5f);
  nan_map.at(5, 3, 1) = std::numeric_limits<float>::quiet_NaN();
  nan_map.at(6, 3, 0) = std::numeric_limits<float>::infinity();
  WriteImage(dir / "nan.exr", nan_map, options);
  try {
    EnvMap::Load(dir / "nan.exr");  // was accepted: every render sampling it was NaN
    FAIL() << "expected UserError";
  } catch (const UserError& e) {
    EXPECT_EQ(std::string(e.what()), "environment map " + (dir / "nan.exr") +
                                         " has 2 NaN or infinite values (the first at pixel (5, 3), channel 1: "
                                         "nan); radiance must be finite: repair or replace the map");
  }
  // Negative texels (lossy EXR compression leaves small ones) are clamped: the map equals the one with zeros.
  Image negative(16, 8, 3, 0.5f), zeroed(16, 8, 3, 0.5f);
  negative.at(0, 7, 2) = -0.25f;
  zeroed.at(0, 7, 2) = 0.0f;
  WriteImage(dir / "negative.exr", negative, options);
  WriteImage(dir / "zeroed.exr", zeroed, options);
  const EnvMap clamped = EnvMap::Load(dir / "negative.exr");
  const EnvMap expected = EnvMap::Load(dir / "zeroed.exr");
  EXPECT_LT((clamped.Integral() - expected.Integral()).norm(), 1e-7);
  const Image fine(16, 8, 3, 0.0f);  // zero radiance is allowed
  WriteImage(dir / "zero.exr", fine, options);
  EXPECT_NO_THROW(EnvMap::Load(dir / "zero.exr"));
}

TEST(EnvMapTest, SaveAndReload) {
  testing::TempDir dir;
  const EnvMap ll = EnvMap::FromLatLong(LatLongOf(16, SmoothRadiance));
  ll.SaveLatLong(dir / "a_latlong.exr", 16);
  ll.SaveOctahedral(dir / "a_oct.exr", 16);
  const EnvMap back = EnvMap::Load(dir / "a_latlong.exr");
  EXPECT_LT((back.Integral() - ll.Integral()).norm(), 2e-3 * ll.Integral().norm());
  const EnvMap oct = EnvMap::FromOctahedral(ReadImage(dir / "a_oct.exr"));
  EXPECT_LT((oct.Integral() - ll.Integral()).norm(), 3e-3 * ll.Integral().norm());
}

TEST(EnvMapTest, ImportanceSamplingIsConsistentAndUnbiased) {
  for (int layout = 0; layout < 2; ++layout) {
    EnvMap env = EnvMap::Load(testing::SharedDataDir() + "/envmaps/grace.hdr");
    if (layout == 1) env = EnvMap::FromOctahedral(env.ToOctahedral(64));
    env = env.Transformed(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()).toRotationMatrix(), 1.0);
    env.PrepareSampling();
    // The density integrates to one (midpoint quadrature over a fine lat-long grid).
    const int h = 600;
    double total = 0;
    for (int y = 0; y < h; ++y) {
      const double theta = M_PI * (y + 0.5) / h;
      for (int x = 0; x < 2 * h; ++x) {
        const double phi = M_PI * (x + 0.5) / h;
        total += env.Pdf({std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)}) *
                 std::sin(theta) * (M_PI / h) * (M_PI / h);
      }
    }
    EXPECT_NEAR(total, 1.0, 5e-3) << "layout " << layout;
    // Sample() reports the density of Pdf(); MC irradiance agrees with quadrature.
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    const Eigen::Vector3d normal = Eigen::Vector3d(0.3, -0.2, 0.9).normalized();
    const int samples = 200000;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
    for (int k = 0; k < samples; ++k) {
      double pdf;
      const Eigen::Vector3d d = env.Sample(u(rng), u(rng), &pdf);
      ASSERT_NEAR(d.norm(), 1.0, 1e-9);
      ASSERT_NEAR(pdf, env.Pdf(d), 1e-6 * pdf);
      const Eigen::Vector3d f = env.Lookup(d) * std::max(0.0, normal.dot(d)) / pdf;
      sum += f;
      sum2 += f.cwiseProduct(f);
    }
    const Eigen::Vector3d mean = sum / samples;
    const Eigen::Vector3d sigma = ((sum2 / samples - mean.cwiseProduct(mean)) / samples).cwiseSqrt();
    const Eigen::Vector3d reference = env.Irradiance(normal, 8);
    for (int c = 0; c < 3; ++c) {
      std::printf("layout %d channel %d: MC %.5f +- %.5f, quadrature %.5f\n", layout, c, mean[c], sigma[c],
                  reference[c]);
      EXPECT_NEAR(mean[c], reference[c], 4 * sigma[c] + 1e-3 * reference[c]);
    }
  }
}

TEST(ShTest, OrthonormalAndEvaluatesKnownBands) {
  const int order = kMaxShOrder, nc = ShNumCoefficients(order);
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(nc, nc);
  std::vector<double> x, w;
  GaussLegendre(20, &x, &w);
  for (int i = 0; i < 20; ++i) {
    const double r = std::sqrt(1 - x[i] * x[i]);
    for (int k = 0; k < 40; ++k) {
      const double phi = 2 * M_PI * (k + 0.5) / 40;
      const Eigen::VectorXd y = ShEvaluate(order, {r * std::cos(phi), r * std::sin(phi), x[i]});
      gram += (w[i] * 2 * M_PI / 40) * y * y.transpose();
    }
  }
  EXPECT_LT((gram - Eigen::MatrixXd::Identity(nc, nc)).cwiseAbs().maxCoeff(), 1e-12);
  const Eigen::Vector3d d = Eigen::Vector3d(0.2, -0.5, 0.7).normalized();
  const Eigen::VectorXd y = ShEvaluate(2, d);
  const double c1 = std::sqrt(3 / (4 * M_PI));
  EXPECT_NEAR(y[ShIndex(0, 0)], 0.5 / std::sqrt(M_PI), 1e-15);
  EXPECT_NEAR(y[ShIndex(1, -1)], c1 * d.y(), 1e-15);
  EXPECT_NEAR(y[ShIndex(1, 0)], c1 * d.z(), 1e-15);
  EXPECT_NEAR(y[ShIndex(1, 1)], c1 * d.x(), 1e-15);
  EXPECT_NEAR(y[ShIndex(2, -2)], 0.5 * std::sqrt(15 / M_PI) * d.x() * d.y(), 1e-14);
  EXPECT_NEAR(y[ShIndex(2, 0)], 0.25 * std::sqrt(5 / M_PI) * (3 * d.z() * d.z() - 1), 1e-14);
  EXPECT_NEAR(y[ShIndex(2, 2)], 0.25 * std::sqrt(15 / M_PI) * (d.x() * d.x() - d.y() * d.y()), 1e-14);
}

TEST(ShTest, ProjectionReconstructsBandLimitedFunctionsAndRotates) {
  std::mt19937 rng(9);
  std::normal_distribution<double> g;
  for (int order = 2; order <= kMaxShOrder; ++order) {
    const int nc = ShNumCoefficients(order);
    Eigen::VectorXd c(nc);
    for (int k = 0; k < nc; ++k) c[k] = g(rng);
    // Project with exact quadrature (degree 2 * order polynomials).
    Eigen::VectorXd projected(nc);
    for (int k = 0; k < nc; ++k)
      projected[k] =
          IntegrateSphereExact([&](const Eigen::Vector3d& d) { return ShReconstruct(c, d) * ShEvaluate(order, d)[k]; });
    EXPECT_LT((projected - c).cwiseAbs().maxCoeff(), 1e-11) << "order " << order;
    // Rotation: coefficients of f(R^-1 d).
    const Eigen::Matrix3d r = Eigen::AngleAxisd(1.3, RandomDir(rng)).toRotationMatrix();
    Eigen::VectorXd rotated(nc);
    ShRotation(order, r).Apply(c.data(), rotated.data());
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d d = RandomDir(rng);
      EXPECT_NEAR(ShReconstruct(rotated, d), ShReconstruct(c, r.transpose() * d), 1e-10) << "order " << order;
    }
  }
}

TEST(ShTest, IrradianceAndTransportMatchQuadrature) {
  // A lighting that is band-limited to order 2 has exact order-2 irradiance.
  const EnvMap env = EnvMap::FromLatLong(LatLongOf(64, [](const Eigen::Vector3d& d) -> Eigen::Vector3d {
    return {1.0 + 0.5 * d.z() + 0.3 * d.x() * d.y(), 0.8 + 0.2 * d.x() - 0.1 * d.z() * d.z(),
            0.5 + 0.2 * d.y() * d.y()};
  }));
  const Eigen::MatrixXd coeffs = ShProjectEnvMap(env, 2, 4);
  for (const Eigen::Vector3d& n : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.6, -0.3, 0.2).normalized()}) {
    const Eigen::Vector3d e_sh = ShIrradiance(coeffs, n), e_quad = env.Irradiance(n, 8);
    EXPECT_LT((e_sh - e_quad).norm(), 2e-3 * e_quad.norm()) << e_sh.transpose() << " vs " << e_quad.transpose();
  }
  // Hemi-octahedral projection of the cosine (texel integrals) equals the closed-form transport up to order 8.
  const int n = 64, order = 8;
  const ShHemiOctProjector projector(n, order);
  std::vector<float> cos_integrals(n * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      double sum = 0;
      const int q = 4;
      for (int b = 0; b < q; ++b)
        for (int a = 0; a < q; ++a) {
          const Eigen::Vector2d ab(-1 + 2 * (i + (a + 0.5) / q) / n, -1 + 2 * (j + (b + 0.5) / q) / n);
          sum += HemiOctDecode(ab).z() * HemiOctJacobian(ab) * 4.0 / (double(n) * n * q * q);
        }
      cos_integrals[j * n + i] = float(sum);
    }
  const Eigen::Vector3d normal = Eigen::Vector3d(0.4, 0.5, -0.3).normalized();
  Eigen::VectorXd t(ShNumCoefficients(order));
  projector.ProjectIntegrals(cos_integrals.data(), FrameFromNormal(normal), t.data());
  const Eigen::VectorXd reference = ShClampedCosineTransport(order, normal);
  EXPECT_LT((t - reference).cwiseAbs().maxCoeff(), 3e-3) << (t - reference).transpose();
}

TEST(SkyTest, SunAtStatedDirectionAndPlausible) {
  SunSkyParams params;
  params.sun_dir_world = Eigen::Vector3d(-0.3, 0.6, 0.5).normalized();
  params.sun_radius_deg = 2.0;
  const int h = 128;
  const EnvMap sky = MakeSunSky(params, h);
  const Image& img = sky.image();
  int best_x = 0, best_y = 0;
  double best = -1;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < 2 * h; ++x) {
      const double lum = Luminance({img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)});
      if (lum > best) {
        best = lum;
        best_x = x;
        best_y = y;
      }
    }
  const auto dir_of = [&](int x, int y) {
    const double theta = M_PI * (y + 0.5) / h, phi = 2 * M_PI * (x + 0.5) / (2 * h);
    return Eigen::Vector3d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < 2 * h; ++x) {
      const Eigen::Vector3d d = dir_of(x, y);
      if (d.dot(params.sun_dir_world) > std::cos(0.2))
        centroid += Luminance({img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)}) * sky.PixelSolidAngle(x, y) * d;
    }
  const double pixel = M_PI / h;
  EXPECT_LT(std::acos(std::min(1.0, dir_of(best_x, best_y).dot(params.sun_dir_world))), 1.5 * pixel);
  EXPECT_LT(std::acos(std::min(1.0, centroid.normalized().dot(params.sun_dir_world))), 0.25 * pixel);
  // The disk carries the sun's illuminance; sky is bluer than the sun; the ground is uniform.
  const Eigen::Vector3d e_sun = SunIlluminance(params);
  const Eigen::Vector3d e_total = sky.Irradiance(params.sun_dir_world, 2);
  EXPECT_GT(Luminance(e_total), Luminance(e_sun));
  EXPECT_LT(Luminance(e_total), 1.5 * Luminance(e_sun));
  const Eigen::Vector3d zenith = PreethamSkyRadiance(params, Eigen::Vector3d::UnitZ());
  EXPECT_GT(zenith.z() / zenith.x(), e_sun.z() / e_sun.x());
  EXPECT_GT(Luminance(e_sun), 50.0);  // clear-sky direct illuminance, klx
  EXPECT_LT(Luminance(e_sun), 128.0);
  EXPECT_NEAR(img.at(10, h - 1, 1), img.at(200, h - 3, 1), 1e-4 * img.at(10, h - 1, 1));
  EXPECT_THROW(MakeSunSky(SunSkyParams{Eigen::Vector3d(0, 0, -1)}, 32), UserError);
}

}  // namespace
}  // namespace relight

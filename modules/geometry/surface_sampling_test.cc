#include "geometry/surface_sampling.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "geometry/primitives.h"

namespace relight {
namespace {

// The unit square [0,1]^2 at z = 0 as a fan of four triangles of unequal area
// around (0.8, 0.3): sampling per face instead of per area would put the mean
// at the mean of the face centroids, (0.6, 0.43).
TriangleMesh UnevenUnitSquare() {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.8f, 0.3f, 0}};
  m.faces = {{4, 0, 1}, {4, 1, 2}, {4, 2, 3}, {4, 3, 0}};
  return m;
}

TEST(SurfaceSampling, UnitSquareSamplesAreUniform) {
  // Uniform on [0,1]^2: mean 1/2 and variance 1/12 per axis. For N samples the
  // mean has standard deviation sqrt(1/12 / N) = 6.5e-4 and the variance
  // sqrt((1/80 - 1/144) / N) = 1.7e-4; the tolerances are about 6 of those.
  const size_t n = 200000;
  const std::vector<Eigen::Vector3f> samples = SampleSurface(UnevenUnitSquare(), n, 1);
  ASSERT_EQ(samples.size(), n);
  Eigen::Vector2d sum = Eigen::Vector2d::Zero(), sum_sq = Eigen::Vector2d::Zero();
  for (const Eigen::Vector3f& p : samples) {
    ASSERT_EQ(p.z(), 0.0f);
    ASSERT_TRUE(p.x() >= 0 && p.x() <= 1 && p.y() >= 0 && p.y() <= 1) << p.transpose();
    const Eigen::Vector2d q = p.head<2>().cast<double>();
    sum += q;
    sum_sq += q.cwiseProduct(q);
  }
  const Eigen::Vector2d mean = sum / n;
  const Eigen::Vector2d variance = sum_sq / n - mean.cwiseProduct(mean);
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(mean[k], 0.5, 4e-3) << "axis " << k;
    EXPECT_NEAR(variance[k], 1.0 / 12.0, 1e-3) << "axis " << k;
  }
}

TEST(SurfaceSampling, BoxFacesGetSamplesInProportionToTheirArea) {
  // A 1 x 2 x 3 box: the faces normal to x, y, z have 6, 3 and 2 of the 11
  // area units per pair. A fraction p of N samples has standard deviation
  // sqrt(p (1 - p) / N) <= 1.6e-3 for N = 100000; tolerance 8e-3 (5 of those).
  const TriangleMesh box = MakeBox(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1, 2, 3));
  const Eigen::Vector3f hi(1, 2, 3);
  const size_t n = 100000;
  Eigen::Vector3d count = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& p : SampleSurface(box, n, 7)) {
    int on = -1;  // the axis whose face holds p
    for (int k = 0; k < 3; ++k) {
      if (std::abs(p[k]) < 1e-6f || std::abs(p[k] - hi[k]) < 1e-6f) on = k;
    }
    ASSERT_GE(on, 0) << p.transpose();
    ++count[on];
  }
  EXPECT_NEAR(count[0] / n, 6.0 / 11.0, 8e-3);
  EXPECT_NEAR(count[1] / n, 3.0 / 11.0, 8e-3);
  EXPECT_NEAR(count[2] / n, 2.0 / 11.0, 8e-3);
}

TEST(SurfaceSampling, DeterministicForASeed) {
  const TriangleMesh sphere = MakeOctasphere(2);
  EXPECT_EQ(SampleSurface(sphere, 100, 3), SampleSurface(sphere, 100, 3));
  EXPECT_NE(SampleSurface(sphere, 100, 3), SampleSurface(sphere, 100, 4));
  EXPECT_TRUE(SampleSurface(sphere, 0, 3).empty());
}

TEST(SurfaceSampling, MeshWithoutAreaIsABug) {
  EXPECT_THROW(SampleSurface(TriangleMesh(), 10, 1), InternalError);
  TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.faces = {{0, 1, 2}};
  EXPECT_THROW(SampleSurface(flat, 10, 1), InternalError);
}

}  // namespace
}  // namespace relight

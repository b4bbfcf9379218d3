// The exact descriptor matcher against a brute-force reference written out
// loop by loop, on descriptors with a known correspondence.
#include "sfm/descriptor_matching.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace relight {
namespace {

DescriptorMatrix RandomUnitRows(int n, std::mt19937* rng) {
  std::normal_distribution<float> g(0, 1);
  DescriptorMatrix m(n, 128);
  for (int i = 0; i < n; ++i) {
    for (int c = 0; c < 128; ++c) m(i, c) = std::abs(g(*rng));  // SIFT descriptors are non-negative
    m.row(i).normalize();
  }
  return m;
}

// COLMAP's definition, one pair at a time in double precision.
std::vector<std::array<uint32_t, 2>> Reference(const DescriptorMatrix& a, const DescriptorMatrix& b,
                                               const DescriptorMatchingOptions& o) {
  auto best = [&](const DescriptorMatrix& x, const DescriptorMatrix& y, int i, int* j_best) {
    double a1 = 1e9, a2 = 1e9;
    for (int j = 0; j < y.rows(); ++j) {
      double dot = 0;
      for (int c = 0; c < x.cols(); ++c) dot += double(x(i, c)) * y(j, c);
      const double angle = std::acos(std::min(1.0, std::max(-1.0, dot)));
      if (angle < a1) {
        a2 = a1;
        a1 = angle;
        *j_best = j;
      } else if (angle < a2) {
        a2 = angle;
      }
    }
    return a1 <= o.max_angle_rad && a1 < o.max_ratio * a2;
  };
  std::vector<std::array<uint32_t, 2>> out;
  for (int i = 0; i < a.rows(); ++i) {
    int j = -1, back = -1;
    if (!best(a, b, i, &j)) continue;
    if (o.cross_check && (!best(b, a, j, &back) || back != i)) continue;
    out.push_back({uint32_t(i), uint32_t(j)});
  }
  return out;
}

TEST(DescriptorMatching, FindsTheHiddenCorrespondenceAndAgreesWithTheReference) {
  std::mt19937 rng(3);
  const DescriptorMatrix a = RandomUnitRows(300, &rng);
  // b: a noisy copy of the first 200 rows of a in reversed order, then 150 unrelated rows.
  DescriptorMatrix b = RandomUnitRows(350, &rng);
  std::normal_distribution<float> noise(0, 0.02f);
  for (int i = 0; i < 200; ++i) {
    for (int c = 0; c < 128; ++c) b(199 - i, c) = std::max(0.0f, a(i, c) + noise(rng));
    b.row(199 - i).normalize();
  }
  const DescriptorMatchingOptions options;
  const auto matches = MatchDescriptors(a, b, options);
  int correct = 0;
  for (const auto& [i, j] : matches) correct += (i < 200 && j == 199 - i) ? 1 : 0;
  EXPECT_EQ(correct, 200);
  EXPECT_EQ(matches.size(), 200u);  // unrelated random rows fail the ratio test
  EXPECT_EQ(matches, Reference(a, b, options));
}

TEST(DescriptorMatching, AmbiguousDescriptorsFailTheRatioTest) {
  std::mt19937 rng(4);
  const DescriptorMatrix a = RandomUnitRows(50, &rng);
  // Every row of a appears twice in b: the best and second-best angles are (nearly) equal.
  DescriptorMatrix b(100, 128);
  for (int i = 0; i < 50; ++i) {
    b.row(2 * i) = a.row(i);
    b.row(2 * i + 1) = a.row(i);
  }
  EXPECT_TRUE(MatchDescriptors(a, b, DescriptorMatchingOptions{}).empty());
  // More rows than one block (1024): the blocked search gives the reference's answer.
  const DescriptorMatrix big_a = RandomUnitRows(1500, &rng);
  DescriptorMatrix big_b = big_a;
  for (int i = 0; i < big_b.rows(); i += 3) big_b.row(i) = RandomUnitRows(1, &rng);
  const auto matches = MatchDescriptors(big_a, big_b, DescriptorMatchingOptions{});
  EXPECT_EQ(matches.size(), 1000u);  // the 1000 rows not replaced
  EXPECT_EQ(matches, Reference(big_a, big_b, DescriptorMatchingOptions{}));
}

}  // namespace
}  // namespace relight

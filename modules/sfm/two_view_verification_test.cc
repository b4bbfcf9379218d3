// Geometric verification against closed forms: two pinhole cameras looking at
// a known scene, exact projections plus a known fraction of random matches.
#include "sfm/two_view_verification.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>
#include <set>

namespace relight {
namespace {

struct Scene {
  std::vector<Eigen::Vector2d> p1, p2;
  std::set<int> true_matches;  // indices of the correct correspondences
  Eigen::Matrix3d F_true;
};

// Camera 1 at the origin looking along +z, camera 2 turned by 20 deg about y and moved sideways; f = 500 px,
// 640 x 480. Points in a box 4..6 deep (`planar`: all on the plane z = 5). `outlier_fraction` of the matches
// are pairs of random pixels.
Scene MakeScene(int n, double outlier_fraction, bool planar, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), depth(4, 6), px(0, 640), py(0, 480), unit(0, 1);
  Eigen::Matrix3d k;
  k << 500, 0, 320, 0, 500, 240, 0, 0, 1;
  const Eigen::Matrix3d r = Eigen::AngleAxisd(20 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d t(-1.5, 0.1, 0.3);
  Scene s;
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  s.F_true = k.inverse().transpose() * tx * r * k.inverse();
  while (static_cast<int>(s.p1.size()) < n) {
    if (unit(rng) < outlier_fraction) {
      s.p1.emplace_back(px(rng), py(rng));
      s.p2.emplace_back(px(rng), py(rng));
      continue;
    }
    const double z = planar ? 5.0 : depth(rng);
    const Eigen::Vector3d x(u(rng) * 2 * z / 5, u(rng) * 1.5 * z / 5, z);
    const Eigen::Vector3d y = r * x + t;
    if (y.z() <= 0) continue;
    const Eigen::Vector2d a = (k * x).hnormalized(), b = (k * y).hnormalized();
    if (b.x() < 0 || b.x() > 640 || b.y() < 0 || b.y() > 480) continue;
    s.true_matches.insert(static_cast<int>(s.p1.size()));
    std::normal_distribution<double> noise(0, 0.5);
    s.p1.push_back(a + Eigen::Vector2d(noise(rng), noise(rng)));
    s.p2.push_back(b + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  return s;
}

TEST(TwoViewVerification, FindsTheTrueMatchesAmongHalfOutliers) {
  const Scene s = MakeScene(400, 0.5, false, 1);
  const TwoViewVerification v = VerifyTwoView(s.p1, s.p2, TwoViewVerificationOptions{});
  ASSERT_TRUE(v.verified);
  EXPECT_EQ(v.config, kTwoViewUncalibrated);
  // Every inlier is a true match or a random pair that happens to lie within 4 px of its epipolar line
  // (probability about 2 * 4 * 800 / (640 * 480) = 2 % per random pair: about 4 of ~200).
  int true_kept = 0;
  for (int i : v.inliers) true_kept += s.true_matches.count(i) ? 1 : 0;
  EXPECT_GE(true_kept, 0.97 * s.true_matches.size());
  EXPECT_LE(static_cast<int>(v.inliers.size()) - true_kept, 12);
  // The estimated F explains the noise-free geometry: the true correspondences' epipolar distances are small.
  double worst = 0;
  for (int i : s.true_matches) {
    const Eigen::Vector3d l = v.F * s.p1[i].homogeneous();
    worst = std::max(worst, std::abs(s.p2[i].homogeneous().dot(l)) / l.head<2>().norm());
  }
  EXPECT_LT(worst, 4.0);
}

TEST(TwoViewVerification, PlanarScenesAreFlagged) {
  const Scene s = MakeScene(300, 0.2, true, 2);
  const TwoViewVerification v = VerifyTwoView(s.p1, s.p2, TwoViewVerificationOptions{});
  ASSERT_TRUE(v.verified);
  EXPECT_EQ(v.config, kTwoViewPlanarOrPanoramic);
  EXPECT_GT(v.num_h_inliers, 0.8 * v.inliers.size());
}

TEST(TwoViewVerification, RandomMatchesAreRejected) {
  const Scene s = MakeScene(300, 1.0, false, 3);
  EXPECT_FALSE(VerifyTwoView(s.p1, s.p2, TwoViewVerificationOptions{}).verified);
  // Too few matches to verify at all.
  const Scene few = MakeScene(10, 0.0, false, 4);
  EXPECT_FALSE(VerifyTwoView(few.p1, few.p2, TwoViewVerificationOptions{}).verified);
}

TEST(TwoViewVerification, SameInputSameResult) {
  const Scene s = MakeScene(500, 0.6, false, 5);
  const TwoViewVerification a = VerifyTwoView(s.p1, s.p2, TwoViewVerificationOptions{});
  const TwoViewVerification b = VerifyTwoView(s.p1, s.p2, TwoViewVerificationOptions{});
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.F, b.F);
}

}  // namespace
}  // namespace relight

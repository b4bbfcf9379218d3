// Geometric verification of the putative matches between two photos: which
// matches one epipolar geometry explains, and whether the pair is planar or
// a pure rotation (so the mapper does not start from it).
//
// We verify instead of COLMAP because COLMAP's matcher verifies in worker
// threads whose random generators are not seeded: identical photos gave
// different verified pairs on every run (59 of 276 pairs of one collection
// changed their inlier counts between two runs), so a photo could register
// once and fail the next time. Here the fundamental matrix comes from OpenCV's
// USAC (MAGSAC++ scoring, local optimisation, a fixed generator state), the
// homography test follows COLMAP's (H inliers over F inliers), and the same
// input always gives the same result.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace relight {

struct TwoViewVerificationOptions {
  double max_error_px = 4.0;        // epipolar distance of an inlier, pixels (COLMAP's default)
  int min_num_inliers = 15;         // fewer inliers: the pair is not verified
  double min_inlier_ratio = 0.25;   // inliers over putative matches below this: not verified
  double max_h_inlier_ratio = 0.8;  // H inliers over F inliers above this: planar or panoramic
  int max_iterations = 10000;       // RANSAC iterations
  double confidence = 0.999;        // RANSAC confidence
  int seed = 0;                     // random generator state: same input, same result
};

// COLMAP's two-view configurations the mapper distinguishes (TwoViewGeometry::ConfigurationType).
inline constexpr int kTwoViewUncalibrated = 3;
inline constexpr int kTwoViewPlanarOrPanoramic = 6;

struct TwoViewVerification {
  bool verified = false;
  std::vector<int> inliers;      // indices into the putative matches
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();  // x2^T F x1 = 0 (pixels)
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();  // x2 ~ H x1 (pixels)
  int num_h_inliers = 0;         // inliers of the homography among the F inliers
  int config = 0;                // kTwoViewUncalibrated or kTwoViewPlanarOrPanoramic when verified
};

// Verifies the putative matches points1[i] <-> points2[i] (pixels).
TwoViewVerification VerifyTwoView(const std::vector<Eigen::Vector2d>& points1,
                                  const std::vector<Eigen::Vector2d>& points2,
                                  const TwoViewVerificationOptions& options);

}  // namespace relight

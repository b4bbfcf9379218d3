#include "sfm/two_view_verification.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "core/error.h"

namespace relight {
namespace {

cv::UsacParams Usac(const TwoViewVerificationOptions& options) {
  cv::UsacParams p;
  p.confidence = options.confidence;
  p.isParallel = false;  // deterministic
  p.maxIterations = options.max_iterations;
  p.randomGeneratorState = options.seed;
  p.sampler = cv::SAMPLING_UNIFORM;
  p.score = cv::SCORE_METHOD_MAGSAC;
  p.loMethod = cv::LOCAL_OPTIM_SIGMA;
  p.threshold = options.max_error_px;
  return p;
}

Eigen::Matrix3d ToEigen(const cv::Mat& m) {
  Eigen::Matrix3d e = Eigen::Matrix3d::Zero();
  if (m.rows >= 3 && m.cols == 3) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) e(r, c) = m.at<double>(r, c);
  }
  return e;
}

}  // namespace

TwoViewVerification VerifyTwoView(const std::vector<Eigen::Vector2d>& points1,
                                  const std::vector<Eigen::Vector2d>& points2,
                                  const TwoViewVerificationOptions& options) {
  RELIGHT_CHECK_EQ(points1.size(), points2.size());
  TwoViewVerification result;
  const int n = static_cast<int>(points1.size());
  if (n < std::max(options.min_num_inliers, 8)) return result;
  std::vector<cv::Point2d> p1(n), p2(n);
  for (int i = 0; i < n; ++i) {
    p1[i] = {points1[i].x(), points1[i].y()};
    p2[i] = {points2[i].x(), points2[i].y()};
  }
  cv::Mat mask;
  cv::Mat F;
  try {
    F = cv::findFundamentalMat(p1, p2, mask, Usac(options));
  } catch (const cv::Exception&) {
    return result;  // degenerate input (e.g. all points on a line)
  }
  if (F.empty() || mask.empty()) return result;
  for (int i = 0; i < n; ++i) {
    if (mask.at<uchar>(i)) result.inliers.push_back(i);
  }
  const int num_inliers = static_cast<int>(result.inliers.size());
  if (num_inliers < options.min_num_inliers || num_inliers < options.min_inlier_ratio * n) {
    result.inliers.clear();
    return result;
  }
  result.F = ToEigen(F);
  result.verified = true;
  result.config = kTwoViewUncalibrated;
  // Planar scene or pure rotation: a homography explains nearly every F inlier.
  std::vector<cv::Point2d> q1, q2;
  for (int i : result.inliers) {
    q1.push_back(p1[i]);
    q2.push_back(p2[i]);
  }
  cv::Mat h_mask;
  cv::Mat H;
  try {
    H = cv::findHomography(q1, q2, h_mask, Usac(options));
  } catch (const cv::Exception&) {
    H = cv::Mat();
  }
  if (!H.empty() && !h_mask.empty()) {
    result.H = ToEigen(H);
    result.num_h_inliers = cv::countNonZero(h_mask);
    if (result.num_h_inliers > options.max_h_inlier_ratio * num_inliers) result.config = kTwoViewPlanarOrPanoramic;
  }
  return result;
}

}  // namespace relight

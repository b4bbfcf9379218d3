#include "geometry/align.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "core/error.h"
#include "core/stats.h"

namespace relight {
namespace {


}  // namespace

Sim3 EstimateSimilarity(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst) {
  RELIGHT_CHECK_EQ(src.size(), dst.size());
  RELIGHT_CHECK_GE(src.size(), 3u);
  Eigen::Matrix3Xd a(3, src.size()), b(3, dst.size());
  for (size_t i = 0; i < src.size(); ++i) {
    a.col(i) = src[i];
    b.col(i) = dst[i];
  }
  const Eigen::Matrix4d m = Eigen::umeyama(a, b, true);
  Sim3 s;
  const Eigen::Matrix3d sr = m.topLeftCorner<3, 3>();
  s.scale = std::cbrt(sr.determinant());
  s.rotation = sr / s.scale;
  s.translation = m.topRightCorner<3, 1>();
  return s;
}

Sim3 EstimateSimilarityRobust(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                              double inlier_fraction) {
  RELIGHT_CHECK_EQ(src.size(), dst.size());
  const size_t n = src.size();
  if (n < 4) return EstimateSimilarity(src, dst);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : dst) centroid += p;
  centroid /= static_cast<double>(n);
  std::vector<double> spread;
  for (const auto& p : dst) spread.push_back((p - centroid).norm());
  const double threshold = inlier_fraction * std::max(1e-12, Median(spread));
  std::mt19937 rng(12345);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  std::vector<size_t> best;
  for (int iter = 0; iter < 500; ++iter) {
    size_t i = pick(rng), j = pick(rng), k = pick(rng);
    if (i == j || j == k || i == k) continue;
    const Sim3 s = EstimateSimilarity({src[i], src[j], src[k]}, {dst[i], dst[j], dst[k]});
    if (!std::isfinite(s.scale) || s.scale <= 0) continue;
    std::vector<size_t> inliers;
    for (size_t q = 0; q < n; ++q)
      if ((s.Apply(src[q]) - dst[q]).norm() < threshold) inliers.push_back(q);
    if (inliers.size() > best.size()) best = inliers;
  }
  if (best.size() < 3) return EstimateSimilarity(src, dst);
  std::vector<Eigen::Vector3d> a, b;
  for (size_t q : best) {
    a.push_back(src[q]);
    b.push_back(dst[q]);
  }
  return EstimateSimilarity(a, b);
}

CameraErrors CompareCameras(const Reconstruction& estimate, const Reconstruction& truth) {
  CameraErrors e;
  std::vector<Eigen::Vector3d> est_centers, true_centers;
  std::vector<const ImageRecord*> est_images, true_images;
  for (const auto& [id, t] : truth.images) {
    const ImageRecord* m = estimate.FindImage(t.name);
    if (m == nullptr) {
      ++e.missing;
      continue;
    }
    est_images.push_back(m);
    true_images.push_back(&t);
    est_centers.push_back(m->ProjectionCenter());
    true_centers.push_back(t.ProjectionCenter());
    e.names.push_back(t.name);
  }
  e.matched = static_cast<int>(e.names.size());
  if (e.matched < 3) return e;
  e.truth_from_estimate = EstimateSimilarityRobust(est_centers, true_centers);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& c : true_centers) centroid += c;
  centroid /= e.matched;
  std::vector<double> radii;
  for (const auto& c : true_centers) radii.push_back((c - centroid).norm());
  e.scene_radius = Median(radii);
  for (int i = 0; i < e.matched; ++i) {
    // Rotation of the aligned estimate: R_est * R_align^T maps truth-world to camera.
    const Eigen::Matrix3d r_est = est_images[i]->CamFromWorldRotation() * e.truth_from_estimate.rotation.transpose();
    const Eigen::Matrix3d r_true = true_images[i]->CamFromWorldRotation();
    const Eigen::AngleAxisd diff(r_est * r_true.transpose());
    const double deg = std::abs(diff.angle()) * 180.0 / M_PI;
    e.rotation_deg.push_back(deg);
    e.center_error.push_back((e.truth_from_estimate.Apply(est_centers[i]) - true_centers[i]).norm());
  }
  e.median_rotation_deg = Median(e.rotation_deg);
  e.max_rotation_deg = *std::max_element(e.rotation_deg.begin(), e.rotation_deg.end());
  e.median_center_error = Median(e.center_error);
  e.median_center_error_relative = e.scene_radius > 0 ? e.median_center_error / e.scene_radius : 0;
  return e;
}

}  // namespace relight

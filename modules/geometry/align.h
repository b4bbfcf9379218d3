// Aligning a reconstruction to ground truth (similarity transform) and the
// camera errors the evaluation reports.
#pragma once

#include <string>
#include <vector>

#include "geometry/reconstruction.h"

namespace relight {

// Least-squares similarity dst ≈ s R src + t (Umeyama 1991, via Eigen::umeyama).
Sim3 EstimateSimilarity(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst);

// Robust similarity: least squares on the inlier set of a RANSAC over minimal
// triples, inliers within `inlier_fraction` of the point spread. Falls back to
// all points when fewer than 4 are given.
Sim3 EstimateSimilarityRobust(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                              double inlier_fraction = 0.05);

// Camera errors of `estimate` against `truth`, matching images by name, after
// aligning the estimated camera centres to the true ones.
struct CameraErrors {
  int matched = 0;                      // images present in both
  int missing = 0;                      // images of `truth` absent from `estimate`
  double median_rotation_deg = 0;
  double max_rotation_deg = 0;
  double median_center_error = 0;       // in the units of `truth`
  double median_center_error_relative = 0;  // relative to `scene_radius`
  double scene_radius = 0;              // median distance of the true centres from their centroid
  Sim3 truth_from_estimate;
  std::vector<std::string> names;       // matched names
  std::vector<double> rotation_deg;     // per matched image
  std::vector<double> center_error;     // per matched image
};
CameraErrors CompareCameras(const Reconstruction& estimate, const Reconstruction& truth);

}  // namespace relight

#include "sfm/model_consensus.h"

#include <set>
#include <string>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "geometry/align.h"

namespace relight {

Eigen::Matrix3d EssentialMatrix(const ImageRecord& a, const ImageRecord& b) {
  const Eigen::Matrix3d r = b.CamFromWorldRotation() * a.CamFromWorldRotation().transpose();
  const Eigen::Vector3d t = b.cam_from_world_translation - r * a.cam_from_world_translation;
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  return tx * r;
}

double SampsonDistance(const Eigen::Matrix3d& e, const Eigen::Vector3d& xa, const Eigen::Vector3d& xb) {
  const Eigen::Vector3d exa = e * xa, etxb = e.transpose() * xb;
  const double num = xb.dot(exa);
  const double den = exa.head<2>().squaredNorm() + etxb.head<2>().squaredNorm();
  return den > 0 ? std::abs(num) / std::sqrt(den) : std::numeric_limits<double>::infinity();
}

ModelAgreement CompareModels(const Reconstruction& a, const Reconstruction& b, double tolerance_deg) {
  ModelAgreement agreement;
  const CameraErrors e = CompareCameras(a, b);
  agreement.shared = e.matched;
  if (e.matched < 3) return agreement;
  std::vector<double> rotations = e.rotation_deg;
  for (size_t i = 0; i < e.names.size(); ++i) {
    if (e.rotation_deg[i] <= tolerance_deg) {
      ++agreement.within_tolerance;
    } else {
      agreement.differing.push_back(e.names[i]);
    }
  }
  std::nth_element(rotations.begin(), rotations.begin() + rotations.size() / 2, rotations.end());
  agreement.median_rotation_deg = rotations[rotations.size() / 2];
  return agreement;
}

TwoViewAgreement CheckTwoViewAgreement(const Reconstruction& model, const std::vector<PairObservations>& pairs,
                                       double max_error_px, int min_matches) {
  TwoViewAgreement agreement;
  for (const PairObservations& p : pairs) {
    const ImageRecord* a = model.FindImage(p.name1);
    const ImageRecord* b = model.FindImage(p.name2);
    if (a == nullptr || b == nullptr || static_cast<int>(p.points1.size()) < min_matches) continue;
    const Camera& ca = model.cameras.at(a->camera_id);
    const Camera& cb = model.cameras.at(b->camera_id);
    // The epipolar geometry the model implies between the two photos.
    const Eigen::Matrix3d e = EssentialMatrix(*a, *b);
    const double focal = std::sqrt(ca.FocalX() * cb.FocalX());
    int explained = 0;
    for (size_t i = 0; i < p.points1.size(); ++i) {
      const Eigen::Vector3d x1 = ca.NormalizedFromImage(p.points1[i]).homogeneous();
      const Eigen::Vector3d x2 = cb.NormalizedFromImage(p.points2[i]).homogeneous();
      if (SampsonDistance(e, x1, x2) * focal <= max_error_px) ++explained;
    }
    const bool agrees = 2 * explained >= static_cast<int>(p.points1.size());
    ++agreement.pairs;
    agreement.agreeing += agrees ? 1 : 0;
    for (const std::string& name : {p.name1, p.name2}) {
      auto& counts = agreement.per_photo[name];
      counts.first += agrees ? 1 : 0;
      ++counts.second;
    }
  }
  return agreement;
}

int ChooseConsensusRun(std::vector<MapperRun>* runs, double tolerance_deg) {
  const int n = static_cast<int>(runs->size());
  for (auto& r : *runs) r.agrees_with.clear();
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      MapperRun& a = (*runs)[i];
      MapperRun& b = (*runs)[j];
      if (a.model.images.empty() || b.model.images.empty()) continue;
      // A confirming run must cover at least half of the larger model: a few photos agreeing say little.
      const ModelAgreement g = CompareModels(a.model, b.model, tolerance_deg);
      const size_t larger = std::max(a.model.images.size(), b.model.images.size());
      if (g.agree() && 2 * static_cast<size_t>(g.shared) >= larger) {
        a.agrees_with.push_back(j);
        b.agrees_with.push_back(i);
      }
    }
  }
  int best = -1;
  auto consistent = [](const MapperRun& r) { return Consistent(r.two_view); };
  auto better = [&](const MapperRun& x, const MapperRun& y) {
    if (consistent(x) != consistent(y)) return consistent(x);
    if (x.agrees_with.size() != y.agrees_with.size()) return x.agrees_with.size() > y.agrees_with.size();
    if (x.num_registered != y.num_registered) return x.num_registered > y.num_registered;
    return x.mean_reprojection_error_px < y.mean_reprojection_error_px;
  };
  for (int i = 0; i < n; ++i) {
    if ((*runs)[i].model.images.empty()) continue;
    if (best < 0 || better((*runs)[i], (*runs)[best])) best = i;
  }
  return best;
}

std::set<std::string> SplitOffPhotos(const std::vector<Reconstruction>& models) {
  std::set<std::string> largest, outside;
  if (models.size() < 2) return outside;
  for (const auto& [id, image] : models[0].images) largest.insert(image.name);
  for (size_t m = 1; m < models.size(); ++m) {
    for (const auto& [id, image] : models[m].images) {
      if (!largest.count(image.name)) outside.insert(image.name);
    }
  }
  return outside;
}

}  // namespace relight

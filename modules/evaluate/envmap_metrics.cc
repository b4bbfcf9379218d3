#include "evaluate/envmap_metrics.h"

#include <cmath>

#include "core/error.h"
#include "sphere/octahedral.h"

namespace relight {

EnvMapComparison CompareEnvMaps(const Image& est, const Image& truth, bool upper_only) {
  const int n = truth.width;
  if (est.width != n || est.height != n || truth.height != n || !IsPowerOfTwo(n) || est.channels < 3 ||
      truth.channels < 3) {
    RELIGHT_USER_ERROR() << "environment maps to compare must be square RGB octahedral maps of one power-of-two "
                         << "size; got " << est.width << "x" << est.height << " and " << truth.width << "x"
                         << truth.height;
  }
  const std::vector<double> omega = OctTexelSolidAngles(n);
  EnvMapComparison r;
  Eigen::Vector3d te = Eigen::Vector3d::Zero(), ee = Eigen::Vector3d::Zero();
  std::vector<char> in(size_t(n) * n, 0);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      if (upper_only && OctTexelDirection(i, j, n).z() <= 0) continue;
      in[size_t(j) * n + i] = 1;
      ++r.texels;
      const double w = omega[size_t(j) * n + i];
      for (int c = 0; c < 3; ++c) {
        te[c] += w * truth.at(i, j, c) * est.at(i, j, c);
        ee[c] += w * est.at(i, j, c) * est.at(i, j, c);
      }
    }
  for (int c = 0; c < 3; ++c) r.scale[c] = ee[c] > 0 ? te[c] / ee[c] : 1.0;
  double num = 0, den = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      if (!in[size_t(j) * n + i]) continue;
      const double w = omega[size_t(j) * n + i];
      for (int c = 0; c < 3; ++c) {
        const double d = r.scale[c] * est.at(i, j, c) - truth.at(i, j, c);
        num += w * d * d;
        den += w * truth.at(i, j, c) * truth.at(i, j, c);
      }
    }
  if (!(den > 0)) RELIGHT_USER_ERROR() << "the true environment map is black over the compared region";
  r.relative_error = std::sqrt(num / den);
  return r;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double c = a.normalized().dot(b.normalized());
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace relight

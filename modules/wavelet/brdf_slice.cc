#include "wavelet/brdf_slice.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.h"
#include "sphere/octahedral.h"
#include "wavelet/haar.h"

namespace relight {

void BrdfSliceOptions::Check() const {
  if (!IsPowerOfTwo(resolution) || resolution < 2)
    RELIGHT_USER_ERROR() << "BRDF slice resolution " << resolution << " must be a power of two >= 2";
  if (!(min_supersampling >= 1 && max_supersampling >= min_supersampling && max_supersampling <= 256))
    RELIGHT_USER_ERROR() << "BRDF slice supersampling must satisfy 1 <= min (" << min_supersampling << ") <= max ("
                         << max_supersampling << ") <= 256";
  if (!(samples_per_lobe_width > 0))
    RELIGHT_USER_ERROR() << "BRDF slice samples_per_lobe_width " << samples_per_lobe_width << " must be > 0";
}

int BrdfSliceSupersampling(const BrdfLobe& lobe, const BrdfSliceOptions& options) {
  // Angular width [rad] of the lobe in w_i.
  double width = M_PI;
  switch (lobe.model) {
    case BrdfModel::kLambertian:
      return options.min_supersampling;
    case BrdfModel::kPhong:
      width = std::sqrt(2.0 / std::max(lobe.exponent, 1.0));
      break;
    case BrdfModel::kCookTorrance:
    case BrdfModel::kGgx:
      width = 2.0 * lobe.roughness;  // half-vector width alpha, doubled in w_i
      break;
  }
  const double texel_rad = M_PI / options.resolution;  // texel side near the pole of the hemi map
  const int ss = int(std::ceil(options.samples_per_lobe_width * texel_rad / width));
  return std::clamp(ss, options.min_supersampling, options.max_supersampling);
}

void BrdfSliceTexels(const BrdfLobe& lobe, const Eigen::Vector3d& wo_local, const BrdfSliceOptions& options,
                     double* texels) {
  const int n = options.resolution;
  const int sharp_ss = BrdfSliceSupersampling(lobe, options);
  const Eigen::Vector3d wo = wo_local.normalized();
  // Phong lobes depend only on the angle to the mirror direction: texels whose every direction is
  // further than `cut` from it (lobe < 1e-7 of its peak) are integrated at the smooth rate.
  const bool phong = lobe.model == BrdfModel::kPhong && sharp_ss > options.min_supersampling;
  const Eigen::Vector3d mirror(-wo.x(), -wo.y(), wo.z());
  const double cut = phong ? std::acos(std::exp(std::log(1e-7) / std::max(lobe.exponent, 1.0))) : 0.0;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      int ss = sharp_ss;
      if (phong) {
        const Eigen::Vector3d centre = HemiOctTexelDirection(i, j, n);
        double radius = 0;  // largest angle from the centre to a corner (texels are convex)
        for (int c = 0; c < 4; ++c) {
          const Eigen::Vector3d corner =
              HemiOctDecode({-1.0 + 2.0 * (i + (c & 1)) / n, -1.0 + 2.0 * (j + (c >> 1)) / n});
          radius = std::max(radius, std::acos(std::clamp(centre.dot(corner), -1.0, 1.0)));
        }
        if (std::acos(std::clamp(centre.dot(mirror), -1.0, 1.0)) > cut + radius) ss = options.min_supersampling;
      }
      const double sub_area = (2.0 / (n * ss)) * (2.0 / (n * ss));  // (a, b) area of a sub-sample
      double sum = 0;
      for (int sy = 0; sy < ss; ++sy) {
        const double b = -1.0 + 2.0 * (j + (sy + 0.5) / ss) / n;
        for (int sx = 0; sx < ss; ++sx) {
          const Eigen::Vector2d ab(-1.0 + 2.0 * (i + (sx + 0.5) / ss) / n, b);
          const Eigen::Vector3d wi = HemiOctDecode(ab);
          if (wi.z() <= 0) continue;
          sum += lobe.Eval<double>(wi, wo) * wi.z() * HemiOctJacobian(ab);
        }
      }
      texels[size_t(j) * n + i] = sum * sub_area;
    }
  }
}

void BrdfSliceHaar(const BrdfLobe& lobe, const Eigen::Vector3d& wo_local, const BrdfSliceOptions& options,
                   double* coeffs) {
  BrdfSliceTexels(lobe, wo_local, options, coeffs);
  HaarForward(coeffs, options.resolution, coeffs);
}

}  // namespace relight

// Scale-invariant HDR image comparison (docs/METRICS.md), after Stanford-ORB
// (Kuang et al., NeurIPS 2023): the estimate is scaled by one least-squares
// factor per colour channel, s_c = sum R_c E_c / sum E_c^2, because inverse
// rendering recovers light and reflectance only up to such scales. The peak of
// the PSNR is a percentile of the reference inside the mask (HDR images have
// no white level), and both images are clipped to [0, peak] so a few sun
// highlights do not dominate (the scale is fitted over the pixels whose
// reference does not exceed the peak, for the same reason):
//   MSE  = mean over mask pixels and channels of (clip(s_c E_c) - clip(R_c))^2
//   PSNR = 10 log10(peak^2 / MSE), capped at kMaxPsnrDb.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/stats.h"  // Percentile
#include "image/image.h"

namespace relight {

// PSNR reported for a perfect match (MSE = 0).
inline constexpr double kMaxPsnrDb = 100.0;

struct ImageCompareOptions {
  double peak_percentile = 99;  // peak = this percentile of the reference's values (pooled channels) in the mask
  bool clip_to_peak = true;     // clip both images to [0, peak] before the error
};

struct ImageComparison {
  size_t pixels = 0;                                // pixels in the mask
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();  // per-channel factor applied to the estimate
  double peak = 0;                                  // PSNR peak (reference units)
  double mse = 0;                                   // reference units squared
  double rmse = 0;                                  // sqrt(mse), reference units
  double relative_rmse = 0;                         // sqrt(sum (sE - R)^2 / sum R^2), unclipped
  double psnr_db = 0;                               // 10 log10(peak^2 / mse), at most kMaxPsnrDb
};

// Compares `estimate` with `reference` (RGB, same size) over pixels with mask > 0.5. A channel whose
// estimate is zero everywhere in the mask keeps scale 1. Throws UserError when the sizes differ or the mask
// is empty (naming `what`, e.g. the file).
ImageComparison CompareScaleInvariant(const Image& reference, const Image& estimate, const Image& mask,
                                      const ImageCompareOptions& options, const std::string& what = "image");

// Per-pixel error |s E - R| (RMS over the three channels), divided by `peak`; 1 channel.
Image RelativeErrorImage(const Image& reference, const Image& estimate, const Eigen::Vector3d& scale, double peak);

// `image` with channel c multiplied by scale[c].
Image ScaleChannels(const Image& image, const Eigen::Vector3d& scale);

}  // namespace relight

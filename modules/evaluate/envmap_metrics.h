// Environment-map comparison (docs/METRICS.md): a recovered map against the
// true one on the same octahedral grid (texel averages), both in the
// ground truth's frame, scale-invariant per channel and solid-angle weighted:
//   s_c = sum w T_c E_c / sum w E_c^2,   rel = sqrt(sum w |s E - T|^2 / sum w |T|^2)
// over the texels of the region (whole sphere, or the upper hemisphere z > 0
// when a ground hides the lower one), w the exact texel solid angles; and the
// angle between the maps' brightest lobes (datasets/light_evaluation.h).
#pragma once

#include <Eigen/Core>

#include "image/image.h"

namespace relight {

struct EnvMapComparison {
  double relative_error = 0;                        // as above
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();  // per-channel factor applied to the estimate
  int texels = 0;                                   // texels in the region
};

// Compares octahedral RGB maps of one size; `upper_only` keeps texels whose centre has z > 0.
// Throws UserError when the sizes differ or the truth is black over the region.
EnvMapComparison CompareEnvMaps(const Image& estimate_oct, const Image& truth_oct, bool upper_only);

// Angle in degrees between two directions (any length > 0).
double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

}  // namespace relight

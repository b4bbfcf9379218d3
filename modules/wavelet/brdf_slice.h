// BRDF slices in the Haar basis: for a lobe and a local view direction w_o,
// the hemi-octahedral map of rho(., w_o) cos(theta_i) (Haber et al. 2009 §4,
// eq. 5; local frame of sphere/frame.h) and its Haar coefficients.
//
// Normalisation: the solid angle is folded into the slice and only there.
// Texel tau holds the *integral* of rho cos over the texel,
//     slice_tau = integral_tau rho(w_i, w_o) cos(theta_i) dw_i,
// while visibility and lighting are plain texel *averages*. Then
//     y = integral V rho cos L dw  ~=  sum_tau V_tau slice_tau L_tau
//       = TripleProduct(Haar(V), Haar(slice), Haar(L))   (wavelet/triple_product.h).
// Texel integrals are supersampled (midpoint rule with the exact
// hemi-octahedral Jacobian); the number of sub-samples grows with the lobe's
// sharpness (Phong 500 needs ~13 x 13 per 32^2 texel, but only near the
// mirror direction; elsewhere the lobe is < 1e-7 of its peak). Written by hand: no
// library bakes BRDF slices on this parameterisation.
#pragma once

#include <Eigen/Core>

#include "brdf/brdf.h"

namespace relight {

// How slices are sampled.
struct BrdfSliceOptions {
  int resolution = 32;                // side N of the hemi-octahedral map (power of two)
  int min_supersampling = 4;          // sub-samples per texel side for smooth lobes (Lambertian)
  int max_supersampling = 24;         // cap for sharp lobes (cost grows with its square)
  double samples_per_lobe_width = 8;  // sub-sample density relative to the lobe's angular width

  // Throws UserError naming the violated constraint.
  void Check() const;
};

// Sub-samples per texel side used for `lobe` under `options`.
int BrdfSliceSupersampling(const BrdfLobe& lobe, const BrdfSliceOptions& options);
// Texel integrals of rho(w_i, wo_local) cos(theta_i) over each hemi-octahedral texel (N*N, row-major).
void BrdfSliceTexels(const BrdfLobe& lobe, const Eigen::Vector3d& wo_local, const BrdfSliceOptions& options,
                     double* texels);
// Haar coefficients (wavelet/haar.h layout) of BrdfSliceTexels.
void BrdfSliceHaar(const BrdfLobe& lobe, const Eigen::Vector3d& wo_local, const BrdfSliceOptions& options,
                   double* coeffs);

}  // namespace relight

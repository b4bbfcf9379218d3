// The lighting step (Haber et al. 2009, §5.1, eq. 10): with the reflectance
// fixed, each photo's environment map solves a convex QP per colour channel,
//   min Σ_o α_o w_o (y_o − r_o·L)² + λ |Δ L|²   subject to  L ≥ 0 (pixel domain),
// with rows r_o = Σ_b ρ_{v,b} a_{o,b}, confidences α_o, robust weights w_o
// (iteratively reweighted least squares, restarted in every lighting step),
// the octahedral grid Laplacian Δ and λ a fraction of the system's largest
// diagonal value. For the SH baseline L is a coefficient vector, the Laplacian
// is diagonal (l(l+1)) and non-negativity holds at the octahedral texel centres.
// With light_prior = natural (Haar) the priors act on the map's departure from a
// daylight model M fitted to what the photos determine of the current map
// (solver/natural_light.h; texels weighted by the photos' share of their
// curvature): λ |Δ(L − M)|² + λ |L − M|² and the wavelet sparsity of L − M, so
// directions no observation sees take M's sky, sun and ground.
// A lower bound (kObservationLowerBound: a clipped footprint) contributes the
// censored max(0, y_o − r_o·L)², by an active set (semismooth Newton): the
// bounds that the current map misses enter the QP as ordinary rows, and the QP
// is solved again until that set stops changing (at most 16 rounds).
#pragma once

#include <array>
#include <vector>

#include "solver/inverse_options.h"
#include "solver/model.h"

namespace relight {

// When the lighting step solves a photo's sun as its own light (SolveLighting): when the daylight model fitted to
// the map (NaturalLight) describes it (explained_variation at least kSunSplitExplained), takes most of the
// horizontal irradiance from its sun and aureole (sun_irradiance_share at least kSunSplitShare), and most of that
// from the sun's disc, sharper than a texel, rather than from the aureole (sun_disc_share at least
// kSunSplitDiscShare): a clear sky's sun, not a hazy one, a bright patch of cloud or light that is not daylight.
inline constexpr double kSunSplitExplained = 0.85;
// With the daylight prior, how much it fills each photo's map (SolveLighting): a weight that rises smoothly from 0 to 1
// as the fitted daylight model explains from kDaylightFillExplainedFrom to kDaylightFillExplainedTo of the determined
// part's variation (NaturalLight::explained_variation), read at the start of every pass. The priors act on the map's
// departure from the model scaled by the weight, and the pull towards the model is scaled by it: at 1 the daylight
// fill, at 0 the smooth fill, for light no sky model describes (walls, a courtyard), whose model would impose its sky,
// sun and ground on what the photos see weakly as well as on what they do not see. A ramp, not a threshold: a map
// near the boundary gets nearly the same fill from nearby starts (a warm-started fold and a solve from scratch).
inline constexpr double kDaylightFillExplainedFrom = 0.3;
inline constexpr double kDaylightFillExplainedTo = 0.7;
double DaylightFillWeight(double explained_variation);
inline constexpr double kSunSplitShare = 0.5;
inline constexpr double kSunSplitDiscShare = 0.5;

struct LightingStepResult {
  std::vector<double> photo_rmse;   // weighted RMSE over the lighting subset, per photo
  std::vector<int> qp_iterations;   // summed over channels and IRLS passes, per photo
  double seconds = 0;
};

// Solves every photo's map. With the daylight prior (light_prior natural, Haar) a photo whose fitted daylight
// model has a clear sky's sun (kSunSplitExplained, kSunSplitShare, kSunSplitDiscShare) gets that sun as a variable of
// its own: a delta at the map's CompactLobeDirection (SunSplat), its RGB irradiance free of the priors,
// which act on the rest of the map (the sky) only. A sun far smaller than a texel otherwise reaches the map as a lobe
// the smoothness prior widens over several texels. The split is kept in `lighting` (sun_dir_world, sun_irradiance).
// `subset[i]` lists the observation indices of photo i to fit.
// `solve_resolution` (Haar only, a power of two <= env_resolution) restricts the
// maps to piecewise-constant blocks of that resolution: in the non-standard Haar
// layout the coarse levels are exactly the top-left block of the coefficients,
// so rows are restricted, the QP is smaller (coarse-to-fine), and the result is
// written back at full resolution.
LightingStepResult SolveLighting(const TransportStore& transport, const ObservationSet& observations,
                                 const std::vector<std::vector<uint32_t>>& subset, const ReflectanceState& reflectance,
                                 const InverseOptions& options, LightingState* lighting, int solve_resolution = 0);

// What the photos determine of each recovered map: the resolution matrix of
// the lighting step's estimate (Backus-Gilbert; "model resolution" in
// geophysical inversion). With H = Σ α r a aᵀ the data term of a photo's rows
// under the final reflectance (confidences α, the step's robust weights r; a
// lower bound, a clipped highlight, only says "at least" and does not count)
// and P the priors at the final map (the Laplacian, the wavelet sparsity's
// reweighted quadratic, the ridge), the linearised estimate responds to the
// data through
// R = (H + P)⁻¹ H. trace(R) is the number of degrees of freedom the photos fix:
// how many of the map's coefficients they support, out of n² (Haar) or
// (order + 1)² (SH); the rest comes from the priors. The diagonal of R in the
// Haar basis (SH: per coefficient) says which: summed per level, it tells how
// fine a detail the photos resolve. The non-negativity constraints are left
// out (the estimate is linearised as if no texel were at zero). Per photo, the
// mean over the three channels.
struct MapResolution {
  double dof = 0;                     // trace(R)
  // Haar: [scaling, level 0, level 1, ...] (level l: 3·4^l wavelets of squares of side n / 2^l
  // texels, wavelet/haar.h); SH: per band l = 0 .. order. Sums of R's diagonal in that basis.
  std::vector<double> dof_per_level;
  std::vector<int> coefficients_per_level;  // how many coefficients each entry sums over
  // Haar: per texel of the n×n octahedral map (row-major), the share of its curvature in the lighting
  // step's objective that the photos provide, H_kk / (H + priors)_kk, mean over the channels: near 1 where
  // observations receive light from the texel's directions, 0 where only the priors set its value.
  // Empty for SH.
  std::vector<float> data_share;
};
std::vector<MapResolution> LightingResolution(const TransportStore& transport, const ObservationSet& observations,
                                              const std::vector<std::vector<uint32_t>>& subset,
                                              const ReflectanceState& reflectance, const InverseOptions& options,
                                              const LightingState& lighting);

// The finest detail a Haar map resolves, in degrees: the detail of the finest
// wavelet level down to which at least half of every level's coefficients are
// determined (a level-l wavelet tells apart the halves of a square 2^-l of the
// map's side, about sqrt(4π) / 2^(l+1) radians). 0 when not even the coarsest
// level is (only the mean), and for SH.
double ResolvedDetailDegrees(const MapResolution& m, const std::string& basis);

// A sun as the maps hold it: a delta of irradiance E from direction d, in the bilinear reconstruction whose
// control values the maps are, is E w_j(d) / ω_j on the (up to) four texels j around d (bilinear weights w_j,
// texel solid angles ω_j): every vertex then receives the delta's light up to the transport's own filtering.
// Lists (texel index j, w_j / ω_j) of an n×n map, texels merged where the fold rule joins them.
std::vector<std::pair<int, double>> SunSplat(const Eigen::Vector3d& dir_world, int n);

// Dense Δ^T Δ of the graph Laplacian of an n×n octahedral grid (4-neighbours across the folds).
Eigen::MatrixXd OctahedralLaplacianGram(int n);

// Reweighted group-L1 penalty of the maps' Haar coefficients (the RGB
// channels share a weight per coefficient): Wᵀ diag(m / max(f·m, |h_k|)) W in
// the pixel domain, with h the orthonormal Haar coefficients of `maps` (three
// n×n channels), m their mean radiance and f `floor_fraction`; the scaling
// coefficient is not penalised. Zero when the maps are zero.
Eigen::MatrixXd HaarL1Penalty(const std::array<const float*, 3>& maps, int n, double floor_fraction);

// Robust IRLS weights of residual magnitudes (huber, cauchy; none gives 1).
std::vector<double> RobustWeights(const std::vector<double>& residuals, const std::string& loss, double scale);

}  // namespace relight

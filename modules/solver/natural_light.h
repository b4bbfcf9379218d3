// A few-parameter model of daylight, fitted to the part of an environment map
// the photos determine and used as the lighting step's prior for the rest.
//
// Per colour channel the model is a non-negative combination of five functions
// of the direction ω (world frame, +Z up, as the sfm stage aligns it):
//   zenith sky   max(0, ω_z)             (clear sky: brighter overhead)
//   horizon sky  [ω_z > 0] (1 − ω_z)     (overcast or hazy: brighter near the horizon)
//   ground       [ω_z ≤ 0]               (a uniform lower hemisphere)
//   sun          exp((d·ω − 1) / σ_s²)   (σ_s: half a texel; averaged over each texel, as the maps are)
//   circumsolar  exp((d·ω − 1) / σ_c²)   (σ_c = 0.35 rad, the aureole and hazy sun)
// with one sun direction d (z ≥ 0) for the three channels. This is the shape of
// the analytic daylight models (Perez et al. 1993, Preetham et al. 1999) reduced to
// what a 16² or 32² map resolves, linear in its coefficients once d is fixed,
// so the fit is an exhaustive search over d (every upper texel of a 16² grid,
// then a local refinement to a sixteenth of a texel) with a 5-variable
// non-negative least-squares per channel and candidate.
//
// Where no texel below the horizon is determined, the ground is set by a weak
// pseudo-observation: a Lambertian plane of albedo `ground_albedo` lit by the
// fitted sky and sun, radiance ρ E_horizontal / π (the model of sphere/sky.h
// and of most renderers' "ground" in a sky shader).
//
// Written by hand: no Debian library fits a parametric sky to a partial map.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

namespace relight {

struct NaturalLight {
  static constexpr int kTerms = 5;  // zenith sky, horizon sky, ground, sun, circumsolar
  Eigen::Vector3d sun_dir_world = Eigen::Vector3d::UnitZ();
  double sun_sigma_rad = 0.1;  // angular width of the sun term (averaged over each texel)
  // Per channel, the non-negative coefficient of each term.
  using Terms = Eigen::Matrix<double, kTerms, 1>;
  std::array<Terms, 3> coefficients{Terms::Zero(), Terms::Zero(), Terms::Zero()};
  double weighted_rms = 0;          // weighted RMS of the fit over the map's texels
  // Share of the weighted texels' variation about their weighted mean (per channel, summed) that the model
  // explains, in [0, 1]: near 1 for daylight, low for light the model cannot describe (an interior, a street
  // between walls), for which the daylight prior is the wrong fill (inverse.light_prior smooth).
  double explained_variation = 0;
  double sun_irradiance_share = 0;  // share of the horizontal irradiance from the sun and circumsolar terms
  // Share of the sun and circumsolar terms' horizontal irradiance from the sun term: above a half for a sun
  // sharper than a texel, below for a hazy sun or a bright patch of cloud, whose light spreads over the aureole.
  double sun_disc_share = 0;

  // Radiance (RGB) in a world direction.
  Eigen::Vector3d Radiance(const Eigen::Vector3d& dir_world) const;
  // The model on an n×n octahedral grid: per channel, row-major texel values.
  std::array<std::vector<double>, 3> Octahedral(int n) const;
};

struct NaturalLightFitOptions {
  double ground_albedo = 0.2;  // albedo of the ground assumed where the photos see nothing below the horizon
  // Weight of that assumption, relative to the fit's summed texel weights: small, so that any part of the ground
  // the photos determine outweighs it.
  double ground_prior_weight = 1e-3;
};

// Fits the model to an n×n octahedral RGB map (three channels, row-major texel
// values) with per-texel weights (e.g. what the photos determine of each texel;
// multiplied here by the texel's solid angle). Weights all zero give a model of
// zero radiance.
NaturalLight FitNaturalLight(const std::array<const double*, 3>& map, const std::vector<double>& weight, int n,
                             const NaturalLightFitOptions& options = {});

}  // namespace relight

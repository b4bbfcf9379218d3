// The unknowns of the bilinear model (Haber et al. 2009, eqs. 9, 11):
// per-photo environment maps L_i and per-vertex reflectance
// ρ_v = Σ_m w_{v,m} Σ_b c_{m,b} f_b (materials c, weights w, basis lobes f_b).
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "brdf/brdf.h"
#include "observe/observations.h"
#include "solver/transport.h"

namespace relight {

struct ReflectanceState {
  std::vector<BrdfLobe> basis;
  int num_materials = 0;
  std::vector<Eigen::Vector3d> coefficients;  // [m * B + b]: RGB weight of lobe b in material m (>= 0)
  std::vector<float> weights;                 // [v * M + m]: material weights of vertex v (>= 0)
  std::vector<char> lobe_enabled;             // per lobe; empty: all. Disabled lobes keep coefficient 0.
  // Diffuse RGB albedo of the occluders (<mesh>/occluders.ply), one for all of them: recovered with
  // inverse.interreflection from the light they bounce onto the mesh (solver/interreflection.h); zero otherwise.
  Eigen::Vector3d occluder_albedo = Eigen::Vector3d::Zero();

  bool enabled(int lobe) const { return lobe_enabled.empty() || lobe_enabled[lobe]; }

  int num_lobes() const { return static_cast<int>(basis.size()); }
  // ρ_{v,b,c} for all lobes b and channels c into out[b * 3 + c].
  void VertexLobeWeights(uint32_t vertex, float* out) const;
  // The ReflectanceModel (materials.json) of this state.
  ReflectanceModel Model() const;
};

struct LightingState {
  std::string basis = "haar";  // haar or sh
  int env_resolution = 32;
  int sh_order = 2;
  int dim = 0;                 // coefficients per channel
  // Per photo and channel: haar -> pixel values of the octahedral map (the bilinear
  // reconstruction's control values); sh -> SH coefficients.
  std::vector<std::array<std::vector<float>, 3>> values;
  // Per photo and channel: coefficients in the transport rows' basis (Haar of
  // `values`, or the SH coefficients themselves). Refresh with UpdateCoefficients().
  std::vector<std::array<std::vector<float>, 3>> coefficients;
  // Per photo: the sun the lighting step solved as its own light (solver/lighting.h, SunSplat), a delta of
  // irradiance `sun_irradiance` (RGB, the maps' radiance times steradians) from `sun_dir_world`; `values` holds
  // it as its bilinear splat. Zero irradiance: no sun was split out of the photo's map.
  std::vector<Eigen::Vector3d> sun_dir_world;
  std::vector<Eigen::Vector3d> sun_irradiance;
  // Per photo, with the daylight prior (inverse.light_prior natural): the weight of the daylight model in the last
  // lighting pass's fill, 1 where the priors acted on the map's departure from the model, 0 where the model described
  // too little of the map and the smooth fill filled it (solver/lighting.h, DaylightFillWeight). Empty without it.
  std::vector<float> daylight_fill;

  void Resize(int num_photos);
  bool has_sun(size_t photo) const { return photo < sun_irradiance.size() && sun_irradiance[photo].maxCoeff() > 0; }
  void UpdateCoefficients();
  // Scales channel c of every map and of every sun by s[c] (the solver's gauge); refreshes the coefficients.
  void ScaleChannels(const Eigen::Vector3d& s);
  // Moves to prev + step (this − prev), a Haar map clamped to non-negative values; a sun split out at the same
  // direction in both moves with its map, otherwise this state's sun is kept. Refreshes the coefficients.
  void ExtrapolateFrom(const LightingState& prev, double step);
  // Octahedral N×N RGB radiance image of a photo's map (SH evaluated at texel centres).
  std::vector<float> OctahedralRgb(int photo, int n) const;
};

// Prediction Σ_b ρ_{v,b,c} a_{o,b}·L_{i,c} of observation `o` for all channels.
void Predict(const TransportStore& transport, const ObservationSet& obs, size_t o, const ReflectanceState& r,
             const LightingState& l, float out[3]);

// Per-lobe predictions p_{o,b,c} = a_{o,b}·L_{i,c}, into out[b * 3 + c].
void LobePredictions(const TransportStore& transport, const ObservationSet& obs, size_t o, const LightingState& l,
                     float* out);

}  // namespace relight

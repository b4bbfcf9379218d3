// One bounce of light between the mesh's own vertices, in the solve. The model
// of Haber et al. (2009) lights a vertex only by the distant environment through
// its unblocked directions; where the mesh blocks the sky it sees other parts of
// the object (or of the ground it reconstructed), which reflect light onto it.
// With the bounce, the measurement of observation o (vertex v, photo i) is
//     y_o = Σ_b ρ_{v,b} a_{o,b}·L_i  +  Σ_{b Lambertian} ρ_{v,b} I_{v,i},
//     I_{v,i} = Σ_s w_s B_{h_s,i},   B_{h,i} = Σ_{b Lambertian} ρ_{h,b} a_{h,b}·L_i,
// with (h_s, w_s) the vertex's bounce samples (visibility/bounce.h) and B the
// diffuse exit radiance of a vertex: the light a blocked direction brings is
// what the surface there reflects diffusely (its glossy lobes' share, which
// depends on the direction, is left out), and it reaches the receiving vertex's
// Lambertian lobes only (a glossy lobe would need the bounce per view).
//
// Occluders (<mesh>/occluders.ply: a ground the object stands on, blockers)
// bounce light too: their vertices that the mesh sees get Lambertian rows of
// their own (visibility baked against the scene, albedo 1), and one RGB albedo
// for all of them, ρ_occ, is recovered from the photos with the rest:
//     I_{v,i} += ρ_occ Σ_s w'_s a'_{h_s}·L_i
// over the vertex's occluder samples (h_s, w'_s). After every reflectance step
// ρ_occ takes the value that best explains the photos under the current model
// (one Gauss-Newton step per channel: I is linear in ρ_occ).
//
// I is bilinear in the reflectance and the light (and of higher degree in the
// reflectance through ρ_h), so the alternation lags it: each step holds I at
// the other quantities' current values (a fixed-point, Picard iteration, which
// converges because a bounce returns less light than it receives). The
// reflectance step sees I as part of the Lambertian lobes' responses; the
// lighting step fits the photos minus the indirect light under the current
// reflectance. At convergence the model's predictions are the full model's.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/raycaster.h"
#include "observe/observations.h"
#include "solver/model.h"
#include "solver/transport.h"
#include "visibility/bounce.h"

namespace relight {

// Side of the occluder vertices' visibility maps (their diffuse light needs no finer ones).
inline constexpr int kOccluderBounceVisibilityResolution = 16;

// Where ρ_occ starts: a mid-grey ground (relight.occluder_albedo's default).
inline constexpr double kOccluderAlbedoStart = 0.35;

// The occluders' side of the bounce.
struct OccluderBounce {
  BounceSamples samples;           // per mesh vertex; hit_vertex indexes `vertices`
  std::vector<uint32_t> vertices;  // the occluder mesh's vertices some mesh vertex sees
  TransportStore rows;             // their Lambertian rows (albedo 1), vertex k's as vertex k's
};

// From ComputeBounceSamples' occluder samples (hit_vertex indexing `occluders`): bakes the visibility of the
// occluder vertices they reach (`visibility_resolution`², against `caster`, which holds the mesh and the
// occluders) and builds their rows with `transport` (its basis replaced by a Lambertian lobe, no footprints).
OccluderBounce BuildOccluderBounce(const TriangleMesh& occluders, const RayCaster& caster, BounceSamples samples,
                                   TransportOptions transport, int visibility_resolution);

class IndirectLight {
 public:
  // All must outlive the object. `bounce` has one entry list per mesh vertex; `occluders` may be null.
  IndirectLight(const TransportStore& transport, const BounceSamples& bounce, const ObservationSet& observations,
                const OccluderBounce* occluders = nullptr);

  bool has_occluders() const { return occluders_ != nullptr && !occluders_->vertices.empty(); }

  // B_{h,i} of every vertex and photo under (lighting, reflectance): call whenever either changed before
  // the functions below.
  void Update(const LightingState& lighting, const ReflectanceState& reflectance);

  // I_{v,i} of observation o (RGB).
  void Indirect(size_t observation, float out[3]) const;
  // Adds sign × I to the Lambertian lobes' responses of observations `ids` (the layout of
  // ComputeLobeResponses): +1 makes them the bounce model's, -1 takes it out again.
  void AddToResponses(const std::vector<uint32_t>& ids, float sign, std::vector<float>* responses) const;
  // The observations with the indirect light the vertex reflects under `reflectance` taken off their
  // values: what the environment maps must explain (the lighting step's targets).
  ObservationSet DirectTargets(const ReflectanceState& reflectance) const;

  // The occluder albedo that best explains observations `ids` (weighted by confidence; lower bounds left
  // out) given their responses (ComputeLobeResponses plus this bounce) and the reflectance: one
  // Gauss-Newton step per channel from reflectance.occluder_albedo, kept non-negative. Then
  // SetOccluderAlbedo changes what Indirect returns without a new Update.
  Eigen::Vector3d FitOccluderAlbedo(const std::vector<uint32_t>& ids, const std::vector<float>& responses,
                                    const ReflectanceState& reflectance) const;
  void SetOccluderAlbedo(const Eigen::Vector3d& albedo) { occluder_albedo_ = albedo.cast<float>(); }

  // Mean over the observations of I's share of the Lambertian response, Σ I / Σ (a·L + I) over
  // channels: how much the bounce contributes (for the log).
  double IndirectShare(const std::vector<uint32_t>& ids, const std::vector<float>& responses) const;

 private:
  const TransportStore& transport_;
  const BounceSamples& bounce_;
  const ObservationSet& observations_;
  std::vector<int> lambertian_;           // lobes without view dependence
  std::vector<std::vector<float>> exit_;  // [photo][vertex * 3 + c]: B
  const OccluderBounce* occluders_ = nullptr;
  std::vector<std::vector<float>> occluder_exit_;  // [photo][k * 3 + c]: a'_k·L_i (albedo 1)
  Eigen::Vector3f occluder_albedo_ = Eigen::Vector3f::Zero();

  // Σ_s w'_s a'_{h_s}·L of observation o (albedo 1), RGB.
  void OccluderGather(size_t observation, float out[3]) const;
};

}  // namespace relight

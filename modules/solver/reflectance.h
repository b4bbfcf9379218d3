// The reflectance step (Haber et al. 2009, §5.2, eqs. 11-12): with every
// environment map fixed, each observation's per-lobe responses
// p_{o,b,c} = a_{o,b}·L_{i,c} make the model linear in the reflectance.
// Alternately: per-vertex material weights w_v ≥ 0 (a tiny NNLS per vertex,
// with a penalty on Σ_m w_{v,m} favouring few materials) and the materials
// c_{m,b} ≥ 0 (one NNLS per channel over all observations).
// Initialisation: k-means on (cos 2πH, sin 2πH, S) of the per-vertex mean
// colours, each region's median colour as its diffuse colour, weights from
// the distance to the centroids (§5.2, last paragraph).
// Robust variant (not in the paper): every observation's confidence α_o is
// multiplied by an IRLS weight r_o of its residual under the current model
// (ReflectanceRobustWeights), as the lighting step does per photo.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "solver/inverse_options.h"
#include "solver/model.h"

namespace relight {

// Per-lobe responses of the given observations under the current lighting:
// out[(k * B + b) * 3 + c] for observation ids[k].
std::vector<float> ComputeLobeResponses(const TransportStore& transport, const ObservationSet& observations,
                                        const std::vector<uint32_t>& ids, const LightingState& lighting);

// Responses (as from ComputeLobeResponses) of the lighting with channel c
// scaled by s_c: every response of channel c times s_c.
void ScaleResponses(const Eigen::Vector3d& s, std::vector<float>* responses);

// k-means initialisation of materials and weights from the observations `train`.
// `gloss` > 0 (not in the paper; inverse.init_gloss): every material also
// starts with a neutral specular of `gloss` times its diffuse luminance,
// shared evenly by the glossy lobes (those `lobe_enabled` keeps, when given).
ReflectanceState InitializeReflectance(const ObservationSet& observations, const std::vector<uint32_t>& train,
                                       size_t num_vertices, const std::vector<BrdfLobe>& basis, int num_materials,
                                       int seed, double gloss = 0, const std::vector<char>* lobe_enabled = nullptr);

// Initialisation from per-vertex fits (not in the paper): with the lighting
// known or estimated, every vertex's reflectance is fitted on its own (a small
// non-negative least-squares problem per channel over all lobes, `responses`
// as from ComputeLobeResponses over `train`), and k-means groups the
// well-observed vertices (total confidence at least the lower quartile) by
// what a material is: the direction of the diffuse RGB and each other lobe's
// share of the appearance, s_b / (1 + s_b) with s_b the lobe's radiance over
// the diffuse radiance. Each group's median fit is its material; every vertex
// starts on its nearest material with the least-squares scale. Unlike k-means
// on mean colours it tells apart materials of one hue that differ in gloss
// (a dark polished metal beside a matte paint). Needs a Lambertian lobe; falls
// back to InitializeReflectance without one.
ReflectanceState InitializeReflectanceFromFits(const ObservationSet& observations, const std::vector<uint32_t>& train,
                                               const std::vector<float>& responses, size_t num_vertices,
                                               const std::vector<BrdfLobe>& basis, int num_materials, int seed);

// Robust IRLS weights r_k of the observations train[k] under the current model
// (`responses` as from ComputeLobeResponses over `train`): RobustWeights of the
// RGB residual magnitudes |y − ŷ| (censored for lower bounds), with the robust sigma (1.4826 × MAD) of each
// photo's residuals. All 1 for loss "none".
std::vector<float> ReflectanceRobustWeights(const ObservationSet& observations, const std::vector<uint32_t>& train,
                                            const std::vector<float>& responses, const ReflectanceState& state,
                                            const std::string& loss, double scale);

// `robust` (optional, below): per-position weights r_k multiplying the
// confidence of train[k] (ReflectanceRobustWeights); nullptr: all 1.
// `censored` (optional, below): MetLowerBounds over `train`; flagged channels
// are left out; nullptr or empty: none.

// Weights step; `responses` as from ComputeLobeResponses over `train`. With
// `smoothness` > 0 each vertex's weights are also pulled towards its mesh
// neighbours' (Σ_edges |w_u − w_v|², weighted relative to the vertex's data term;
// one Jacobi sweep per call).
void SolveWeights(const ObservationSet& observations, const std::vector<uint32_t>& train,
                  const std::vector<float>& responses, double sparsity, ReflectanceState* state,
                  const std::vector<std::vector<uint32_t>>* neighbours = nullptr, double smoothness = 0.0,
                  const std::vector<float>* robust = nullptr, const std::vector<uint8_t>* censored = nullptr);

// Vertex adjacency of a mesh (each neighbour once).
std::vector<std::vector<uint32_t>> VertexNeighbours(const TriangleMesh& mesh);

// Materials step.
void SolveMaterials(const ObservationSet& observations, const std::vector<uint32_t>& train,
                    const std::vector<float>& responses, ReflectanceState* state,
                    const std::vector<float>* robust = nullptr, const std::vector<uint8_t>* censored = nullptr);

// Weights of vertices without observations, by averaging over mesh neighbours (repeated diffusion).
void FillUnobservedWeights(const TriangleMesh& mesh, const std::vector<char>& observed, ReflectanceState* state);

// Lower bounds (kObservationLowerBound: clipped highlights) contribute the
// censored max(0, y − ŷ)². The reflectance steps treat them by active sets:
// a bound that the current model meets (ŷ ≥ y) is left out of the next
// solve, one that it misses enters as an ordinary observation. A fixed point
// is a minimiser of the censored objective (the left-out terms have zero
// value and gradient). Returns, per position k of `ids` and channel c, 1 at
// [3k + c] where a lower bound is met under the current model; empty when
// `ids` holds no lower bound.
std::vector<uint8_t> MetLowerBounds(const ObservationSet& observations, const std::vector<uint32_t>& ids,
                                    const std::vector<float>& responses, const ReflectanceState& state);

// Weighted sum of squared residuals Σ α r (y − ŷ)² and the weight sum Σ 3 α r over `ids`
// (r: `robust` per position in `ids`, or 1); lower bounds add their censored residual
// (0 where ŷ ≥ y, CensoredResidual).
void ResidualStats(const ObservationSet& observations, const std::vector<uint32_t>& ids,
                   const std::vector<float>& responses, const ReflectanceState& state, double* sse, double* weight,
                   const std::vector<float>* robust = nullptr);

}  // namespace relight

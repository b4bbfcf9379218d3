// Transport rows of the bilinear model (Haber et al. 2009, §4.3, eqs. 7-8):
// for an observation o of vertex v from local view direction w_o and a basis
// lobe b, the row a_{o,b} such that
//     ∫ V_v(w) f_b(w, w_o) cos(w) L(R_v w) dw = a_{o,b} · L,
// with L a photo's environment map. A measurement is then
//     y_o = Σ_b ρ_{v,b} a_{o,b} · L_i        (bilinear in ρ and L).
//
// Rows are built once per solve. "pixel" route: the vertex's visibility map
// (hemi-octahedral, local frame), the BRDF slice f_b(·, w_o) cos dω and the
// visibility multiply texel by texel; each local texel is splatted with
// bilinear weights onto the global octahedral map (the same bilinear
// reconstruction the recovered maps are rendered with), and the result is
// Haar-transformed and truncated to the coefficients carrying its energy.
// When the global map is finer than the visibility map, each visibility
// texel is sub-sampled (TransportSupersampling) so the splats resolve it.
// Lambertian lobes do not depend on w_o and are stored once per vertex.
// An observation is the photo's mean over a footprint (observe), not a point:
// where the interpolated normals turn inside it, a narrow lobe's highlight is
// wider and lower than at the vertex. The pixel route therefore averages each
// row over normals sampled across the footprint (SampleFootprintNormals), for
// the lobes narrow enough for that spread to matter (LobeFootprintSpread); the
// visibility stays the vertex's. This is the normal-variance filtering of
// specular highlights in real-time rendering (Toksvig 2005), done by
// quadrature instead of a widened lobe, since the basis lobes are fixed.
// For the SH baseline the same texel integrals are projected onto world-frame
// spherical harmonics (dense rows).
//
// "wavelet" route (the seed's, §4.2): the visibility and a BRDF slice, both in
// the local Haar basis, multiply by product projection (wavelet/triple_product.h),
// and the product is rotated into the global basis with the transposed wavelet
// rotation of the vertex normal, blended from a grid of normals
// (wavelet/rotation.h). Slices are tabulated on a grid of view directions
// (nearest entry). Both routes produce rows in the same basis; the pixel route
// is exact per vertex and view, the wavelet route carries the normal-grid and
// view-grid interpolation of the seed (docs/BENCHMARKS.md compares them).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "brdf/brdf.h"
#include "geometry/mesh.h"
#include "observe/observations.h"
#include "visibility/visibility.h"

namespace relight {

struct TransportOptions {
  std::vector<BrdfLobe> basis;
  std::string lighting_basis = "haar";  // haar or sh
  int env_resolution = 32;              // global octahedral side (haar)
  int sh_order = 2;
  double keep_energy = 0.999;           // haar row truncation
  int max_coefficients = 256;
  std::string route = "pixel";          // pixel or wavelet (haar only)
  int normal_grid = 32;                 // wavelet route: grid of rotation matrices (G×G octahedral normals)
  int view_grid = 32;                   // wavelet route: tabulated BRDF slices (G×G hemi-octahedral views)
  // Pixel route: each row is the mean over the observation's footprint on the
  // surface (a disc of footprint_scale × the vertex's area radius, as `observe`
  // samples the photo), with the interpolated normals of the mesh inside it,
  // instead of the vertex normal alone. 0 disables it.
  double footprint_scale = 1.0;
  // Haar pixel route: sub-samples per visibility texel side (0: automatic,
  // TransportSupersampling).
  int supersampling = 0;
  // Where the rows live: empty keeps them in memory; a folder keeps them in
  // an unnamed file there (TransportStore, "Rows on disk").
  std::string spill_dir;
  // Bytes of rows built before they are written out as one wave (TransportStore).
  size_t wave_bytes = size_t(256) << 20;
};

// Sub-samples per side of each visibility texel on the Haar pixel route: the
// BRDF slice and the splat onto the global map are evaluated at `s`² points
// of the texel (the texel's visibility held), so a global map finer than the
// visibility map still gets one splat per global texel side. `requested` > 0
// forces it; 0 picks the smallest s with s·N·√2 ≥ M (N the visibility side,
// M the global side): 1 for the defaults (N = M = 32), 2 for M = 2N.
int TransportSupersampling(int visibility_resolution, int env_resolution, int requested);

// Normals sampled over each vertex's footprint, in the vertex's local frame,
// with quadrature weights summing to 1: the centre (weight 1/3) and one point
// towards every mesh neighbour at √3/2 of the footprint radius (together 2/3),
// which integrates a quadratic function over the disc exactly for a regular
// ring. Normals along the way are the renderer's linear interpolation.
// An observation whose kernel is g times the nominal disc (Observation::kernel_scale)
// takes its normals at g times the distance, up to the neighbour (ScaledNormal).
struct FootprintNormals {
  std::vector<uint32_t> first;              // vertex v: [first[v], first[v + 1])
  std::vector<Eigen::Vector3f> normal_local;
  std::vector<float> weight;
  std::vector<Eigen::Vector3f> toward_local;  // the neighbour's normal the sample lies towards (centre: +Z)
  std::vector<float> reach;                   // the sample's share of the way there at g = 1, unclamped (centre: 0)

  // Sample s's normal for a kernel g times the nominal disc (g = 1: normal_local[s]).
  Eigen::Vector3f ScaledNormal(uint32_t s, float g) const;
};
FootprintNormals SampleFootprintNormals(const TriangleMesh& mesh, double footprint_scale);

// Compact storage of all rows: one pool of records, row r's values (floats)
// followed by its coefficient indices (uint16), at byte offsets_[r].
//
// Rows on disk: with TransportOptions::spill_dir the pool is an unnamed file
// in that folder (O_TMPFILE, or a name unlinked at once: nothing is left
// behind when the process ends or is killed), written as the rows are built
// and mapped read-only. The solver's memory then no longer grows with the
// rows (about 15 MiB a photo at the defaults): the kernel keeps the pages
// it has room for in its cache and reads the others back. The file is laid
// out for the two passes that read it: the rows are built per wave of
// vertices (about TransportOptions::wave_bytes of rows) and each wave is
// written in row order, where observation rows follow photo by photo (observations are
// sorted by photo, then vertex), so the lighting step's rows of one photo and
// the reflectance step's rows of consecutive observations are a few long
// runs. Evict() tells the kernel a range has been used, so that the process's
// resident set stays near one photo's rows instead of growing to the file.
// Written by hand: the layout is the solver's (the file: core/scratch_file.h).
class TransportStore {
 public:
  TransportStore();
  // Dimension of a row: env_resolution² (haar) or (sh_order+1)² (sh).
  int dim() const { return dim_; }
  int num_lobes() const { return static_cast<int>(view_dependent_.size()); }
  bool view_dependent(int lobe) const { return view_dependent_[lobe]; }
  // Row of observation `o` (index into the observation set) and lobe `b`.
  struct Row {
    const uint16_t* index;
    const float* value;
    uint32_t size;
  };
  Row Get(size_t observation, uint32_t vertex, int lobe) const;
  // Dot product of a row with a dense coefficient vector.
  float Dot(size_t observation, uint32_t vertex, int lobe, const float* dense) const;
  size_t num_coefficients() const { return num_coefficients_; }
  // Bytes of the rows (in memory or on disk) and of their index.
  size_t bytes() const;
  // True when the rows are in a file (TransportOptions::spill_dir).
  bool on_disk() const;
  // The rows of observations [begin, end) are not needed again soon: their
  // pages leave the process's resident set (they stay in the kernel's cache
  // while memory allows). The rows stay valid. No-op in memory.
  void Evict(size_t observation_begin, size_t observation_end) const;
  // Every page leaves the resident set (no-op in memory).
  void EvictAll() const;

  struct Pool;  // the record bytes: a vector or a mapped file

 private:
  friend TransportStore BuildTransport(const TriangleMesh&, const VisibilityData&, const ObservationSet&,
                                       const TransportOptions&);
  int dim_ = 0;
  std::vector<bool> view_dependent_;
  std::vector<int> slot_;                 // lobe -> slot among view-(in)dependent lobes
  int num_independent_ = 0, num_dependent_ = 0;
  // Row r: record at byte offsets_[r] of the pool, sizes_[r] coefficients. Vertex rows first:
  // v * num_independent_ + slot; then observation rows: vertex_rows_ + o * num_dependent_ + slot.
  size_t vertex_rows_ = 0;
  std::vector<uint64_t> offsets_;
  std::vector<uint32_t> sizes_;
  size_t num_coefficients_ = 0;
  std::vector<uint64_t> wave_begin_;  // byte offset where each wave's records start (ascending)
  std::shared_ptr<const Pool> pool_;
  const char* data_ = nullptr;  // the pool's first byte
};

// Builds every row for the observations (vertex normals required).
TransportStore BuildTransport(const TriangleMesh& mesh, const VisibilityData& visibility,
                              const ObservationSet& observations, const TransportOptions& options);

// Cosine of the half-vector angle beyond which a microfacet lobe's D is below
// 1e-5 of its peak (used to skip texels); -1 for lobes evaluated everywhere.
double LobeHalfVectorCutoff(const BrdfLobe& lobe);
// The footprint spread of normals [rad] from which a lobe's rows average over
// the footprint: below it the lobe is too wide for the spread to matter (under 2 %).
double LobeFootprintSpread(const BrdfLobe& lobe);
// Cosine of the angle to the mirror direction beyond which a Phong lobe is below 1e-5 of its peak.
double PhongMirrorCutoff(const BrdfLobe& lobe);

}  // namespace relight

// One-bounce light paths between mesh vertices: for every vertex v, which other
// vertices it sees along its blocked directions, and with what cosine weight.
// The indirect radiance that reaches v's Lambertian lobes is then
//     E_ind(v) / π = Σ_s w_s B(h_s),      w_s = (1/π) ∫_{Ω_s} cos θ dω,
// with B(h) the (diffuse) exit radiance of the vertex a sample's ray hits. The
// sum of a vertex's weights is its cosine-weighted blocked share of the
// hemisphere (1 minus the open share the visibility map integrates).
//
// Directions are k² points of a Fibonacci lattice on the unit square, mapped to
// the disc (Shirley-Chiu concentric map) and lifted to the hemisphere (Malley's
// method): cosine-distributed, each ray of weight 1/k². A hit's weight is split over
// the hit triangle's three vertices by its barycentric coordinates and merged
// per vertex, so a sample list is as long as the number of distinct vertices a
// vertex sees. Rays that leave the scene or hit the back of a face (the unlit
// side) carry no bounce; those that hit an occluder are listed apart when the
// caller asks (the occluders are not the mesh's vertices).
//
// Written by hand: Embree casts the rays (geometry/raycaster.h); the gather of
// the hits into per-vertex form-factor lists is the method's.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/mesh.h"
#include "geometry/raycaster.h"

namespace relight {

struct BounceOptions {
  int rays_per_side = 12;       // k: k² cosine-weighted rays per vertex
  double origin_offset = 0.05;  // ray origins leave the surface by this share of the vertex's mean edge length
};

struct BounceSamples {
  std::vector<uint32_t> first;       // vertex v: samples [first[v], first[v + 1])
  std::vector<uint32_t> hit_vertex;  // the mesh vertex the light comes from
  std::vector<float> weight;         // its share of (1/π) ∫ cos θ dω over v's hemisphere

  size_t num_vertices() const { return first.empty() ? 0 : first.size() - 1; }
  bool empty() const { return hit_vertex.empty(); }
  // Σ_s weight_s · values[hit_vertex_s] for vertex v (values per mesh vertex, `stride` floats apart, channel `c`).
  float Gather(uint32_t v, const float* values, int stride, int c) const {
    float sum = 0.0f;
    for (uint32_t s = first[v]; s < first[v + 1]; ++s) sum += weight[s] * values[size_t(hit_vertex[s]) * stride + c];
    return sum;
  }
};

// The bounce samples of every vertex of `mesh` (geom_id 0 of `caster`; vertex normals required). Other
// meshes of `caster` (occluders) block rays and carry no bounce, unless `occluder_samples` is given: then
// the hits on the caster's mesh 1 (the occluders) are listed there, per vertex of `mesh`, their hit_vertex
// indexing the occluder mesh's vertices (whose radiance the caller knows how to get). The occluder vertices
// that are hit are grouped by cells of twice `mesh`'s mean edge length and one of each cell stands for the
// cell (diffuse light on a surface varies little over a few edges): a finely tessellated ground then costs
// about the mesh's density.
BounceSamples ComputeBounceSamples(const TriangleMesh& mesh, const RayCaster& caster, const BounceOptions& options,
                                   BounceSamples* occluder_samples = nullptr);

}  // namespace relight

#include "visibility/bounce.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <utility>

#include "core/error.h"
#include "sphere/frame.h"

namespace relight {
namespace {

// N = k² points of the Fibonacci lattice on [0, 1]² (u = (i + ½)/N, v = frac(i/φ): low discrepancy along every
// direction, so no boundary lines up with the points as with a grid), mapped to the unit disc (Shirley and
// Chiu 1997) and lifted to the hemisphere (Malley): cosine-distributed local directions of equal weight.
std::vector<Eigen::Vector3f> CosineLatticeDirections(int k) {
  const int count = k * k;
  std::vector<Eigen::Vector3f> dirs;
  dirs.reserve(size_t(count));
  const double quarter_pi = 0.25 * M_PI, inv_golden = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int i = 0; i < count; ++i) {
    const double u = (i + 0.5) / count, t = i * inv_golden;
    const double a = 2.0 * u - 1.0, b = 2.0 * (t - std::floor(t)) - 1.0;
    double r = 0, phi = 0;
    if (a == 0 && b == 0) {
      r = 0;
    } else if (std::abs(a) > std::abs(b)) {
      r = a;
      phi = quarter_pi * (b / a);
    } else {
      r = b;
      phi = 2 * quarter_pi - quarter_pi * (a / b);
    }
    const double x = r * std::cos(phi), y = r * std::sin(phi);
    const double z = std::sqrt(std::max(0.0, 1.0 - x * x - y * y));
    dirs.emplace_back(float(x), float(y), float(z));
  }
  return dirs;
}

}  // namespace

namespace {

// Per-vertex (source vertex, weight) lists, merged by source, into BounceSamples.
BounceSamples Flatten(std::vector<std::vector<std::pair<uint32_t, float>>>* per_vertex) {
  const size_t nv = per_vertex->size();
  BounceSamples samples;
  samples.first.assign(nv + 1, 0);
  for (size_t v = 0; v < nv; ++v) samples.first[v + 1] = samples.first[v] + uint32_t((*per_vertex)[v].size());
  samples.hit_vertex.reserve(samples.first[nv]);
  samples.weight.reserve(samples.first[nv]);
  for (size_t v = 0; v < nv; ++v) {
    for (const auto& [h, w] : (*per_vertex)[v]) {
      samples.hit_vertex.push_back(h);
      samples.weight.push_back(w);
    }
    std::vector<std::pair<uint32_t, float>>().swap((*per_vertex)[v]);
  }
  return samples;
}

void MergeBySource(std::vector<std::pair<uint32_t, float>>* out) {
  std::sort(out->begin(), out->end());
  size_t w = 0;
  for (size_t r = 0; r < out->size(); ++r) {
    if (w > 0 && (*out)[w - 1].first == (*out)[r].first)
      (*out)[w - 1].second += (*out)[r].second;
    else
      (*out)[w++] = (*out)[r];
  }
  out->resize(w);
  out->shrink_to_fit();
}

}  // namespace

BounceSamples ComputeBounceSamples(const TriangleMesh& mesh, const RayCaster& caster, const BounceOptions& o,
                                   BounceSamples* occluder_samples) {
  RELIGHT_CHECK(o.rays_per_side >= 1 && o.rays_per_side <= 256) << "bounce rays_per_side out of range";
  RELIGHT_CHECK(mesh.normals.size() == mesh.num_vertices()) << "bounce samples need vertex normals";
  const size_t nv = mesh.num_vertices();
  const std::vector<Eigen::Vector3f> local = CosineLatticeDirections(o.rays_per_side);
  const float ray_weight = 1.0f / float(local.size());
  // Ray origins leave the surface by a share of the vertex's own mean edge length (as the visibility maps').
  std::vector<float> edge_sum(nv, 0.0f);
  std::vector<int> degree(nv, 0);
  for (const auto& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) {
      const float len = (mesh.vertices[f[(k + 1) % 3]] - mesh.vertices[f[k]]).norm();
      edge_sum[f[k]] += len;
      edge_sum[f[(k + 1) % 3]] += len;
      ++degree[f[k]];
      ++degree[f[(k + 1) % 3]];
    }
  }
  std::vector<std::vector<std::pair<uint32_t, float>>> per_vertex(nv), per_vertex_occluder(nv);
  const bool want_occluders = occluder_samples != nullptr;
  struct Scratch {
    std::vector<Ray> rays;
    std::vector<RayHit> hits;
  };
  tbb::enumerable_thread_specific<Scratch> scratch;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 64), [&](const tbb::blocked_range<size_t>& range) {
    Scratch& s = scratch.local();
    s.rays.resize(local.size());
    for (size_t v = range.begin(); v < range.end(); ++v) {
      const Eigen::Vector3f nrm = mesh.normals[v];
      if (!(nrm.squaredNorm() > 0.5f)) continue;  // isolated or degenerate vertex: no hemisphere
      const LocalFrame<float> frame = FrameFromNormal<float>(nrm);
      const float edge = degree[v] ? edge_sum[v] / degree[v] : 0.0f;
      const Eigen::Vector3f origin = mesh.vertices[v] + (float(o.origin_offset) * edge + caster.Epsilon()) * nrm;
      for (size_t k = 0; k < local.size(); ++k) {
        s.rays[k].origin = origin;
        s.rays[k].dir = frame.ToWorld(local[k]);
        s.rays[k].t_near = 0.0f;
        s.rays[k].t_far = std::numeric_limits<float>::infinity();
      }
      caster.IntersectStream(s.rays, false, &s.hits);
      for (size_t k = 0; k < local.size(); ++k) {
        const RayHit& hit = s.hits[k];
        if (!hit.hit || hit.geom_id > (want_occluders ? 1u : 0u)) continue;
        // The lit side faces the ray: its interpolated normal points back towards the origin.
        if (caster.ShadingNormal(hit).dot(s.rays[k].dir) >= 0.0f) continue;
        const auto& face = caster.mesh(hit.geom_id).faces[hit.prim_id];
        const float bary[3] = {1.0f - hit.u - hit.v, hit.u, hit.v};
        std::vector<std::pair<uint32_t, float>>& out = hit.geom_id == 0 ? per_vertex[v] : per_vertex_occluder[v];
        for (int c = 0; c < 3; ++c)
          if (bary[c] > 0.0f && (hit.geom_id != 0 || uint32_t(face[c]) != v))
            out.emplace_back(uint32_t(face[c]), ray_weight * bary[c]);
      }
      MergeBySource(&per_vertex[v]);
      if (want_occluders) MergeBySource(&per_vertex_occluder[v]);
    }
  });
  if (want_occluders) {
    // Occluder vertices by cells of twice the mesh's mean edge: the hit vertex nearest each cell's centroid
    // stands for the others, so that a finely tessellated ground costs the callers rows of about the
    // mesh's density, not of its own.
    double edge_total = 0;
    size_t edge_count = 0;
    for (size_t v = 0; v < nv; ++v) {
      edge_total += edge_sum[v];
      edge_count += degree[v];
    }
    const double cell = edge_count > 0 ? 2.0 * edge_total / edge_count : 0.0;
    const TriangleMesh& occluders = caster.mesh(1);
    std::vector<char> hit(occluders.num_vertices(), 0);
    for (const auto& list : per_vertex_occluder)
      for (const auto& entry : list) hit[entry.first] = 1;
    std::vector<uint32_t> stand_in(occluders.num_vertices(), UINT32_MAX);
    if (cell > 0) {
      // Per cell: the centroid of its hit vertices, then the hit vertex nearest it stands in.
      struct Cell {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        int count = 0;
        uint32_t best = UINT32_MAX;
        double best_distance = 0;
      };
      std::map<std::array<int64_t, 3>, Cell> cells;
      auto key_of = [&](const Eigen::Vector3f& p) {
        return std::array<int64_t, 3>{int64_t(std::floor(p.x() / cell)), int64_t(std::floor(p.y() / cell)),
                                      int64_t(std::floor(p.z() / cell))};
      };
      for (uint32_t h = 0; h < occluders.num_vertices(); ++h) {
        if (!hit[h]) continue;
        Cell& c = cells[key_of(occluders.vertices[h])];
        c.sum += occluders.vertices[h].cast<double>();
        ++c.count;
      }
      for (uint32_t h = 0; h < occluders.num_vertices(); ++h) {
        if (!hit[h]) continue;
        Cell& c = cells[key_of(occluders.vertices[h])];
        const double d = (occluders.vertices[h].cast<double>() - c.sum / c.count).squaredNorm();
        if (c.best == UINT32_MAX || d < c.best_distance) {
          c.best = h;
          c.best_distance = d;
        }
      }
      for (uint32_t h = 0; h < occluders.num_vertices(); ++h)
        if (hit[h]) stand_in[h] = cells[key_of(occluders.vertices[h])].best;
    }
    for (auto& list : per_vertex_occluder) {
      for (auto& entry : list)
        if (stand_in[entry.first] != UINT32_MAX) entry.first = stand_in[entry.first];
      MergeBySource(&list);
    }
    *occluder_samples = Flatten(&per_vertex_occluder);
  }
  return Flatten(&per_vertex);
}

}  // namespace relight

// Visibility baking throughput against the raw Embree occlusion throughput of
// a bare loop over the same rays, measured in the same run (issue 5).
//
//   build/bin/visibility_benchmark --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <tbb/parallel_for.h>

#include <cmath>

#include "core/log.h"
#include "render/test_scenes.h"
#include "sphere/frame.h"
#include "visibility/visibility.h"

namespace relight {
namespace {

using render_testing::Terrain;

struct Fixture {
  TriangleMesh mesh = Terrain(317);
  RayCaster caster{{&mesh}};
  std::vector<uint32_t> vertices;
  VisibilityOptions options;
  Fixture() {
    InitLogging("visibility_benchmark", "", LogLevel::kWarning);
    for (uint32_t v = 0; v < mesh.num_vertices(); v += 50) vertices.push_back(v);  // ≈2000 vertices
    options.resolution = 32;
    options.supersampling = 2;
  }
};

Fixture& Get() {
  static Fixture f;
  return f;
}

// The same rays as the bake, precomputed, traced by a bare parallel loop.
void BM_RawEmbreeOcclusion(benchmark::State& state) {
  Fixture& f = Get();
  const int n = f.options.resolution, ss = f.options.supersampling;
  const auto local = HemiOctSampleDirections(n, ss);
  const size_t per_vertex = local.size();
  std::vector<Ray> rays(f.vertices.size() * per_vertex);
  const float offset = static_cast<float>(f.options.origin_offset * f.mesh.MeanEdgeLength()) + f.caster.Epsilon();
  // (The bake uses each vertex's own edge length; on this uniform grid both agree.)
  for (size_t q = 0; q < f.vertices.size(); ++q) {
    const uint32_t v = f.vertices[q];
    const auto frame = FrameFromNormal<float>(f.mesh.normals[v]);
    for (size_t k = 0; k < per_vertex; ++k) {
      rays[q * per_vertex + k] = {f.mesh.vertices[v] + offset * f.mesh.normals[v], frame.ToWorld(local[k])};
    }
  }
  std::vector<uint8_t> occluded(rays.size());
  for (auto _ : state) {
    tbb::parallel_for(size_t(0), f.vertices.size(), [&](size_t q) {
      f.caster.OccludedStream(rays.data() + q * per_vertex, per_vertex, false, occluded.data() + q * per_vertex);
    });
    benchmark::DoNotOptimize(occluded.data());
  }
  state.counters["Mrays/s"] = benchmark::Counter(static_cast<double>(rays.size()) * state.iterations() / 1e6,
                                                 benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RawEmbreeOcclusion)->Unit(benchmark::kMillisecond)->UseRealTime();

// The stage's baking loop (ray generation in the local frame, tracing, texel averaging).
void BM_BakeVisibility(benchmark::State& state) {
  Fixture& f = Get();
  std::vector<float> maps;
  const double rays = double(f.vertices.size()) * f.options.resolution * f.options.resolution *
                      f.options.supersampling * f.options.supersampling;
  for (auto _ : state) {
    BakeVisibilityMaps(f.mesh, f.caster, f.vertices, f.options, &maps);
    benchmark::DoNotOptimize(maps.data());
  }
  state.counters["Mrays/s"] = benchmark::Counter(rays * state.iterations() / 1e6, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BakeVisibility)->Unit(benchmark::kMillisecond)->UseRealTime();

// The whole 100K-vertex mesh at 32² with 2×2 supersampling (410M rays), once.
void BM_BakeVisibilityAllVertices(benchmark::State& state) {
  Fixture& f = Get();
  std::vector<uint32_t> all(f.mesh.num_vertices());
  for (uint32_t v = 0; v < all.size(); ++v) all[v] = v;
  std::vector<float> maps;
  const double rays = double(all.size()) * f.options.resolution * f.options.resolution * f.options.supersampling *
                      f.options.supersampling;
  for (auto _ : state) {
    BakeVisibilityMaps(f.mesh, f.caster, all, f.options, &maps);
    benchmark::DoNotOptimize(maps.data());
  }
  state.counters["Mrays/s"] = benchmark::Counter(rays * state.iterations() / 1e6, benchmark::Counter::kIsRate);
  state.counters["vertices"] = double(all.size());
}
BENCHMARK(BM_BakeVisibilityAllVertices)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

// Haar transform + energy truncation per vertex map (the rest of the stage's per-vertex work).
void BM_HaarCompress(benchmark::State& state) {
  Fixture& f = Get();
  std::vector<float> maps;
  BakeVisibilityMaps(f.mesh, f.caster, f.vertices, f.options, &maps);
  const int n = f.options.resolution;
  std::vector<float> coeffs(n * n);
  size_t kept = 0;
  for (auto _ : state) {
    for (size_t q = 0; q < f.vertices.size(); ++q) {
      HaarForward(maps.data() + q * n * n, n, coeffs.data());
      kept += KeepEnergy(coeffs.data(), n, f.options.keep_energy).size();
    }
  }
  state.counters["maps/s"] =
      benchmark::Counter(double(f.vertices.size()) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["coeffs/map"] = double(kept) / (f.vertices.size() * state.iterations());
}
BENCHMARK(BM_HaarCompress)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace relight

BENCHMARK_MAIN();

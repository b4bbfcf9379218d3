// Benchmarks of the wavelet core (docs/BENCHMARKS.md, "Wavelet core").
//   build-wavelet/bin/wavelet_benchmark --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>
#include <vector>

#include "brdf/brdf.h"
#include "sphere/octahedral.h"
#include "wavelet/brdf_slice.h"
#include "wavelet/haar.h"
#include "wavelet/rotation.h"
#include "wavelet/triple_product.h"

namespace relight {
namespace {

template <typename T>
std::vector<T> RandomCoefficients(int n, int seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<T> v(size_t(n) * n);
  for (auto& x : v) x = T(u(rng));
  HaarForward(v.data(), n, v.data());
  return v;
}

void SetPerCoefficient(benchmark::State& state, int n) {
  state.counters["coeffs"] = double(n) * n;
  // Seconds per coefficient, printed with an SI prefix ("1.5n" = 1.5 ns).
  state.counters["time_per_coeff"] =
      benchmark::Counter(double(n) * n, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

template <typename T>
void BM_TripleProduct(benchmark::State& state) {
  const int n = int(state.range(0));
  const auto f = RandomCoefficients<T>(n, 1), g = RandomCoefficients<T>(n, 2), h = RandomCoefficients<T>(n, 3);
  for (auto _ : state) benchmark::DoNotOptimize(TripleProduct(f.data(), g.data(), h.data(), n));
  SetPerCoefficient(state, n);
}
BENCHMARK_TEMPLATE(BM_TripleProduct, double)->Arg(32)->Arg(64);
BENCHMARK_TEMPLATE(BM_TripleProduct, float)->Arg(32)->Arg(64);

// Baseline: the same integral when f, g, h are already pixel arrays (one multiply-add loop).
void BM_PixelDomainTripleBaseline(benchmark::State& state) {
  const int n = int(state.range(0));
  std::vector<double> f(n * n), g(n * n), h(n * n);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0, 1);
  for (int k = 0; k < n * n; ++k) f[k] = u(rng), g[k] = u(rng), h[k] = u(rng);
  for (auto _ : state) {
    double sum = 0;
    for (int k = 0; k < n * n; ++k) sum += f[k] * g[k] * h[k];
    benchmark::DoNotOptimize(sum);
  }
  SetPerCoefficient(state, n);
}
BENCHMARK(BM_PixelDomainTripleBaseline)->Arg(32)->Arg(64);

// Baseline: brute force from coefficients, three inverse transforms and the pixel loop.
void BM_InverseThenPixelBaseline(benchmark::State& state) {
  const int n = int(state.range(0));
  const auto f = RandomCoefficients<double>(n, 1), g = RandomCoefficients<double>(n, 2),
             h = RandomCoefficients<double>(n, 3);
  std::vector<double> pf(n * n), pg(n * n), ph(n * n);
  for (auto _ : state) {
    HaarInverse(f.data(), n, pf.data());
    HaarInverse(g.data(), n, pg.data());
    HaarInverse(h.data(), n, ph.data());
    double sum = 0;
    for (int k = 0; k < n * n; ++k) sum += pf[k] * pg[k] * ph[k];
    benchmark::DoNotOptimize(sum);
  }
  SetPerCoefficient(state, n);
}
BENCHMARK(BM_InverseThenPixelBaseline)->Arg(32)->Arg(64);

void BM_ProductProjection(benchmark::State& state) {
  const int n = int(state.range(0));
  const auto f = RandomCoefficients<double>(n, 1), g = RandomCoefficients<double>(n, 2);
  std::vector<double> out(n * n);
  for (auto _ : state) {
    ProductProjection(f.data(), g.data(), n, out.data());
    benchmark::DoNotOptimize(out.data());
  }
  SetPerCoefficient(state, n);
}
BENCHMARK(BM_ProductProjection)->Arg(32)->Arg(64);

// Sparse inputs: each function keeps its largest `range(1)` percent of coefficients.
void BM_SparseTripleProduct(benchmark::State& state) {
  const int n = int(state.range(0));
  const size_t keep = size_t(n) * n * state.range(1) / 100;
  const auto f = RandomCoefficients<double>(n, 1), g = RandomCoefficients<double>(n, 2),
             h = RandomCoefficients<double>(n, 3);
  const auto sf = KeepLargest(f.data(), n, keep), sg = KeepLargest(g.data(), n, keep),
             sh = KeepLargest(h.data(), n, keep);
  for (auto _ : state) benchmark::DoNotOptimize(TripleProduct(sf, sg, sh));
  state.counters["kept"] = double(keep);
  state.counters["time_per_kept"] =
      benchmark::Counter(double(keep), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SparseTripleProduct)->Args({32, 10})->Args({64, 10})->Args({64, 2});

void BM_HaarForward(benchmark::State& state) {
  const int n = int(state.range(0));
  std::vector<float> v = RandomCoefficients<float>(n, 5);
  for (auto _ : state) {
    HaarForward(v.data(), n, v.data());
    benchmark::DoNotOptimize(v.data());
  }
  SetPerCoefficient(state, n);
}
BENCHMARK(BM_HaarForward)->Arg(32)->Arg(64);

// One exact rotation matrix (N_g = N_l = range(0)), single thread.
void BM_RotationMatrixBuild(benchmark::State& state) {
  RotationOptions options;
  options.global_resolution = options.local_resolution = int(state.range(0));
  size_t nnz = 0;
  int k = 0;
  for (auto _ : state) {
    const Eigen::Vector3d normal = OctTexelDirection(k % 32, (k * 7) % 32, 32);
    ++k;
    nnz = BuildRotationMatrix(normal, options).nnz();
  }
  state.counters["nnz_per_matrix"] = double(nnz);
  state.counters["density_pct"] = 100.0 * nnz / std::pow(double(state.range(0)), 4);
}
BENCHMARK(BM_RotationMatrixBuild)->Arg(16)->Arg(32)->Arg(64)->Unit(benchmark::kMillisecond);

// The full default grid (32^2 normals), TBB on all cores.
void BM_RotationGridBuild(benchmark::State& state) {
  RotationOptions options;
  options.global_resolution = options.local_resolution = int(state.range(0));
  RotationSummary summary;
  for (auto _ : state) {
    const RotationGrid grid = RotationGrid::Build(options, &summary);
    benchmark::DoNotOptimize(grid.nnz());
  }
  state.counters["nnz_total"] = double(summary.nnz_total);
  state.counters["MB"] = summary.bytes / 1e6;
  state.counters["max_dropped_rel"] = summary.max_dropped_rel;
}
BENCHMARK(BM_RotationGridBuild)->Arg(16)->Arg(32)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// Loading the cached default grid (built and written once, outside the timing).
void BM_RotationGridLoad(benchmark::State& state) {
  RotationOptions options;
  options.global_resolution = options.local_resolution = int(state.range(0));
  const std::string dir = std::filesystem::temp_directory_path() / "relight_wavelet_benchmark";
  RotationGrid::LoadOrBuild(options, dir);
  const std::string path = dir + "/" + RotationGrid::CacheFileName(options);
  for (auto _ : state) benchmark::DoNotOptimize(RotationGrid::Load(path).nnz());
  state.counters["file_MB"] = std::filesystem::file_size(path) / 1e6;
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_RotationGridLoad)->Arg(16)->Arg(32)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// Blended rotation of one lighting vector and the transposed accumulation (transport rows).
void BM_RotateBlended(benchmark::State& state) {
  RotationOptions options;
  options.global_resolution = options.local_resolution = int(state.range(0));
  options.normal_grid = 8;  // the cost per call does not depend on the grid size
  const RotationGrid grid = RotationGrid::Build(options);
  const int n = options.global_resolution;
  const auto lighting = RandomCoefficients<float>(n, 6);
  std::vector<float> local(n * n);
  std::vector<double> local_d(n * n, 0.1), global(n * n, 0.0);
  const Eigen::Vector3d normal = Eigen::Vector3d(0.3, 0.2, 0.9).normalized();
  const bool transposed = state.range(1) != 0;
  for (auto _ : state) {
    if (transposed) {
      grid.AccumulateTransposed(normal, local_d.data(), 1.0, global.data());
      benchmark::DoNotOptimize(global.data());
    } else {
      grid.Rotate(normal, lighting.data(), local.data());
      benchmark::DoNotOptimize(local.data());
    }
  }
}
BENCHMARK(BM_RotateBlended)->Args({16, 0})->Args({32, 0})->Args({32, 1})->Unit(benchmark::kMicrosecond);

// The same with S_n stored (ResamplingGrid): two Haar transforms around a sparse resampling.
void BM_ResamplingRotateBlended(benchmark::State& state) {
  RotationOptions options;
  options.global_resolution = options.local_resolution = int(state.range(0));
  options.normal_grid = 8;
  const ResamplingGrid grid = ResamplingGrid::Build(options);
  const int n = options.global_resolution;
  const auto lighting = RandomCoefficients<float>(n, 6);
  std::vector<float> local(n * n);
  std::vector<double> local_d(n * n, 0.1), global(n * n, 0.0);
  const Eigen::Vector3d normal = Eigen::Vector3d(0.3, 0.2, 0.9).normalized();
  const bool transposed = state.range(1) != 0;
  for (auto _ : state) {
    if (transposed) {
      grid.AccumulateTransposed(normal, local_d.data(), 1.0, global.data());
      benchmark::DoNotOptimize(global.data());
    } else {
      grid.Rotate(normal, lighting.data(), local.data());
      benchmark::DoNotOptimize(local.data());
    }
  }
  state.counters["nnz_per_matrix"] = double(grid.nnz()) / grid.num_normals();
}
BENCHMARK(BM_ResamplingRotateBlended)->Args({16, 0})->Args({32, 0})->Args({32, 1})->Unit(benchmark::kMicrosecond);

// Building the default 32^2 grid of S_n, TBB on all cores.
void BM_ResamplingGridBuild(benchmark::State& state) {
  RotationOptions options;
  options.global_resolution = options.local_resolution = int(state.range(0));
  RotationSummary summary;
  for (auto _ : state) benchmark::DoNotOptimize(ResamplingGrid::Build(options, &summary).nnz());
  state.counters["nnz_total"] = double(summary.nnz_total);
  state.counters["MB"] = summary.bytes / 1e6;
}
BENCHMARK(BM_ResamplingGridBuild)->Arg(16)->Arg(32)->Arg(64)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

void BM_BrdfSlice(benchmark::State& state) {
  BrdfSliceOptions options;
  const BrdfLobe lobe =
      state.range(0) == 0 ? BrdfLobe{BrdfModel::kLambertian} : BrdfLobe{BrdfModel::kPhong, 0.3, 0.04, 500};
  std::vector<double> coeffs(options.resolution * options.resolution);
  const Eigen::Vector3d wo = Eigen::Vector3d(0.3, 0.1, 0.9).normalized();
  for (auto _ : state) {
    BrdfSliceHaar(lobe, wo, options, coeffs.data());
    benchmark::DoNotOptimize(coeffs.data());
  }
  state.SetLabel(lobe.Describe());
}
BENCHMARK(BM_BrdfSlice)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace relight

BENCHMARK_MAIN();

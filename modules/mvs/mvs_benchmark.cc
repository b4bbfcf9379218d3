// Speed of PatchMatch stereo in seconds per megapixel of reference image,
// with the vectorised NCC cost against the plain-loop reference of the same
// cost (ncc_cost.h) measured in the same run, on a synthetic scene (a
// textured bumpy sphere, 12 views on two rings, default options: 8 source
// views, window radius 3 step 1, 3 photometric iterations).
//
//   build-mvs/bin/mvs_benchmark [--size=640] [--threads=2]
//
// Counters: s_per_MP (wall seconds per reference megapixel for the whole
// pass; BM_GeometricPass: one geometric iteration and the filter); BM_NccCost's
// time is one cost evaluation (49 window samples).
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>

#include "core/log.h"
#include "mvs/mvs_options.h"
#include "mvs/ncc_cost.h"
#include "mvs/patch_match.h"
#include "mvs/test_scene.h"
#include "mvs/view_selection.h"

namespace relight {
namespace {

int g_size = 640;  // longest side of the reference image

struct Fixture {
  mvs_test::TestScene scene;
  std::vector<StereoView> views;
  std::vector<ViewSelection> plans;
  MvsOptions options;
  PatchMatchProblem problem;
  DepthNormalMap photometric;  // maps for the geometric pass
  std::vector<DepthNormalMap> source_maps;

  Fixture() {
    const int width = g_size, height = g_size * 3 / 4;
    const Camera camera = Camera::Pinhole(1, width, height, 0.95 * width, 0.95 * width, width / 2.0, height / 2.0);
    const auto poses = mvs_test::LookAtCameras(mvs_test::TwoRingCenters(6, 3.5), Eigen::Vector3d::Zero());
    scene = mvs_test::RenderScene(mvs_test::MakeBumpySphere(5), camera, poses, 3000, 7);
    size_t k = 0;
    for (const auto& [id, image] : scene.model.images) {
      StereoView v = MakeStereoView(scene.model, image, 0);
      v.gray = mvs_test::ToGray(scene.images[k++]);
      views.push_back(std::move(v));
    }
    plans = SelectViews(scene.model, views, options);
    problem = MakeProblem(0);
  }

  PatchMatchProblem MakeProblem(int r) const {
    PatchMatchProblem p;
    p.ref = &views[r];
    for (int s : plans[r].sources) p.sources.push_back(&views[s]);
    p.depth_min = plans[r].depth_min;
    p.depth_max = plans[r].depth_max;
    p.image_seed = r;
    return p;
  }
};

Fixture& GetFixture() {
  static Fixture fixture;
  return fixture;
}

double ReferenceMegapixels(const Fixture& f) { return f.problem.ref->width * double(f.problem.ref->height) * 1e-6; }

void BM_PhotometricPass(benchmark::State& state) {
  Fixture& f = GetFixture();
  const CostKernel kernel = state.range(0) == 0 ? CostKernel::kVectorized : CostKernel::kPlain;
  PatchMatchStats stats;
  for (auto _ : state) {
    DepthNormalMap map = RunPatchMatch(f.options, f.problem, false, f.options.num_iterations, nullptr, 0, kernel, &stats);
    benchmark::DoNotOptimize(map.depth.data());
  }
  state.counters["s_per_MP"] = benchmark::Counter(ReferenceMegapixels(f), benchmark::Counter::kIsIterationInvariantRate |
                                                                             benchmark::Counter::kInvert);
  state.counters["sources"] = double(f.problem.sources.size());
  state.counters["mean_cost"] = stats.mean_cost;
  state.SetLabel(kernel == CostKernel::kVectorized ? "vectorized" : "plain");
}
BENCHMARK(BM_PhotometricPass)->Arg(0)->Arg(1)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

void BM_GeometricPass(benchmark::State& state) {
  Fixture& f = GetFixture();
  // Photometric maps of the reference and its sources (once).
  if (f.source_maps.empty()) {
    f.photometric = RunPatchMatch(f.options, f.problem, false, f.options.num_iterations);
    for (size_t k = 0; k < f.problem.sources.size(); ++k) {
      const int s = f.plans[0].sources[k];
      f.source_maps.push_back(RunPatchMatch(f.options, f.MakeProblem(s), false, f.options.num_iterations));
    }
  }
  PatchMatchProblem problem = f.problem;
  for (const auto& m : f.source_maps) problem.source_maps.push_back(&m);
  for (auto _ : state) {
    // One geometric iteration (the stage runs mvs.geom_iterations of them, each against the sources' maps of
    // the one before; here the photometric ones), then the filter.
    DepthNormalMap map = RunPatchMatch(f.options, problem, true, 1, &f.photometric, f.options.num_iterations);
    FilterDepthMap(f.options, problem, true, &map);
    benchmark::DoNotOptimize(map.depth.data());
  }
  state.counters["s_per_MP"] = benchmark::Counter(ReferenceMegapixels(f), benchmark::Counter::kIsIterationInvariantRate |
                                                                             benchmark::Counter::kInvert);
}
BENCHMARK(BM_GeometricPass)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// One cost evaluation (reference window × one source view × one plane) on one thread.
void BM_NccCost(benchmark::State& state) {
  Fixture& f = GetFixture();
  const bool plain = state.range(0) == 1;
  const StereoView& ref = *f.problem.ref;
  const StereoView& src = *f.problem.sources[0];
  const WindowPattern pattern = MakeWindowPattern(f.options.window_radius, f.options.window_step,
                                                  float(f.options.sigma_spatial));
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> col(10, ref.width - 10), row(10, ref.height - 10);
  Homography H = Homography::Identity();
  H(0, 2) = 3.0f;
  RefWindow window;
  PrepareRefWindow(ref.gray, ref.width / 2, ref.height / 2, pattern, 0.2f, &window);
  const SamplingImage sampling = MakeSamplingImage(src.gray);
  float sink = 0;
  for (auto _ : state) {
    if (plain) {
      sink += NccCostPlain(ref.gray, ref.width / 2, ref.height / 2, f.options.window_radius, f.options.window_step,
                           0.2f, float(f.options.sigma_spatial), H, src.gray);
    } else {
      sink += NccCost(window, pattern, H, sampling);
    }
    H(0, 2) += 1e-6f;
  }
  benchmark::DoNotOptimize(sink);
  state.counters["samples"] = pattern.num_samples;
  state.SetLabel(plain ? "plain" : (NccCostUsesAvx2() ? "vectorized (AVX2)" : "vectorized (portable)"));
}
BENCHMARK(BM_NccCost)->Arg(0)->Arg(1);

}  // namespace
}  // namespace relight

int main(int argc, char** argv) {
  int threads = 2;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::strncmp(argv[i], "--size=", 7) == 0) {
      relight::g_size = std::atoi(argv[i] + 7);
    } else if (std::strncmp(argv[i], "--threads=", 10) == 0) {
      threads = std::atoi(argv[i] + 10);
    } else {
      rest.push_back(argv[i]);
    }
  }
  int rest_argc = static_cast<int>(rest.size());
  relight::InitLogging("mvs_benchmark", "", relight::LogLevel::kWarning);
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, size_t(threads));
  benchmark::Initialize(&rest_argc, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

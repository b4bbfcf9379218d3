// Observation extraction for the seed's problem size (issue 5): a 100K-vertex
// mesh seen in 13 photos of 1 MP (1152 x 864). One iteration observes all 13
// photos: depth map by Embree ray casting, per-vertex visibility, footprint
// colour from the image pyramid, confidence. The depth-map ray cast alone is
// measured in the same run as the baseline it cannot beat.
//
//   build/bin/observe_benchmark --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cmath>

#include "core/log.h"
#include "render/test_scenes.h"
#include "observe/observe.h"

namespace relight {
namespace {

using render_testing::Terrain;

// Camera at `center` looking at the origin.
ImageRecord LookAt(const Eigen::Vector3d& center) {
  const Eigen::Vector3d z = (-center).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d r;
  r.row(0) = x;
  r.row(1) = y;
  r.row(2) = z;
  ImageRecord im;
  im.SetPose(r, center);
  return im;
}

struct Fixture {
  static constexpr int kPhotos = 13;
  TriangleMesh mesh = Terrain(317);
  RayCaster caster{{&mesh}};
  std::vector<float> footprint;
  Camera camera = Camera::Pinhole(1, 1152, 864, 1000, 1000, 576, 432);
  std::vector<ImageRecord> poses;
  Image radiance{1152, 864, 3};
  Image confidence{1152, 864, 1, 1.0f};
  ObserveOptions options;
  Fixture() {
    InitLogging("observe_benchmark", "", LogLevel::kWarning);
    footprint = VertexFootprintRadius(mesh);
    for (int p = 0; p < kPhotos; ++p) {  // a ring of views from 35-55 degrees above the horizon
      const double azimuth = 2 * M_PI * p / kPhotos, elevation = (35.0 + 20.0 * (p % 3) / 2.0) * M_PI / 180;
      poses.push_back(LookAt(3.2 * Eigen::Vector3d(std::cos(azimuth) * std::cos(elevation),
                                                   std::sin(azimuth) * std::cos(elevation), std::sin(elevation))));
    }
    for (size_t i = 0; i < radiance.pixels.size(); ++i) radiance.pixels[i] = 0.2f + 0.1f * std::sin(0.01f * i);
  }
};

Fixture& Get() {
  static Fixture f;
  return f;
}

void BM_DepthMapsOnly(benchmark::State& state) {
  Fixture& f = Get();
  for (auto _ : state) {
    for (const ImageRecord& pose : f.poses) benchmark::DoNotOptimize(RenderDepthMap(f.caster, f.camera, pose));
  }
  state.counters["photos/s"] = benchmark::Counter(double(Fixture::kPhotos) * state.iterations(),
                                                  benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DepthMapsOnly)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_ObserveAllPhotos(benchmark::State& state) {
  Fixture& f = Get();
  size_t observations = 0;
  for (auto _ : state) {
    observations = 0;
    for (int p = 0; p < Fixture::kPhotos; ++p) {
      PhotoView view{f.camera, f.poses[p], &f.radiance, &f.confidence};
      observations += ObservePhoto(f.mesh, f.footprint, f.caster, view, p, f.options).size();
    }
  }
  state.counters["photos/s"] = benchmark::Counter(double(Fixture::kPhotos) * state.iterations(),
                                                  benchmark::Counter::kIsRate);
  state.counters["observations"] = double(observations);
}
BENCHMARK(BM_ObserveAllPhotos)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace relight

BENCHMARK_MAIN();

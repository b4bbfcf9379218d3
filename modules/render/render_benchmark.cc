// Throughput of the renderer: RenderView of a glossy sphere on a ground plane
// under a sunny sky (all lobe kinds, shadows), and VertexRadiance. Counters:
// shading samples per second (camera rays x (light + BRDF samples)).
//
//   build/bin/render_benchmark --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include "render/render_view.h"
#include "render/test_scenes.h"
#include "sphere/sky.h"

namespace relight {
namespace {

struct BenchScene {
  std::unique_ptr<Scene> scene;
  Lighting lighting;
  Camera camera = Camera::Pinhole(1, 256, 192, 220, 220, 128, 96);
  ImageRecord pose;

  BenchScene() {
    ReflectanceModel glossy;
    BrdfLobe lambert, phong, ggx;
    phong.model = BrdfModel::kPhong;
    phong.exponent = 50;
    ggx.model = BrdfModel::kGgx;
    ggx.roughness = 0.15;
    glossy.basis = {lambert, phong, ggx};
    glossy.materials = {
        {"m", {Eigen::Vector3d(0.5, 0.3, 0.2), Eigen::Vector3d(0.2, 0.2, 0.2), Eigen::Vector3d(1, 1, 1)}}};
    std::vector<Scene::Surface> surfaces;
    surfaces.push_back({render_testing::Icosphere(0.5, Eigen::Vector3d(0, 0, 0.5), 6), glossy});
    surfaces.push_back(
        {render_testing::Plane(3, 0, 128), LambertianModel(Eigen::Vector3d(0.4, 0.4, 0.4)), SurfaceRole::kOccluder});
    scene = std::make_unique<Scene>(std::move(surfaces), "benchmark");
    SunSkyParams sky;
    sky.sun_dir_world = Eigen::Vector3d(0.5, 0.3, 0.6).normalized();
    lighting = Lighting::FromEnvMap(MakeSunSky(sky, 128));
    const Eigen::Vector3d center(0, -3, 1.5), target(0, 0, 0.4);
    const Eigen::Vector3d forward = (target - center).normalized();
    const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
    Eigen::Matrix3d r;
    r.row(0) = right;
    r.row(1) = forward.cross(right);
    r.row(2) = forward;
    pose.SetPose(r, center);
    pose.camera_id = 1;
  }
};

BenchScene& Bench() {
  static BenchScene bench;
  return bench;
}

void BM_RenderView(benchmark::State& state) {
  BenchScene& b = Bench();
  RenderOptions options;
  options.light_samples = int(state.range(0));
  options.brdf_samples = int(state.range(0));
  for (auto _ : state) {
    RenderedView view = RenderView(*b.scene, b.lighting, b.camera, b.pose, options);
    benchmark::DoNotOptimize(view.radiance.pixels.data());
  }
  const double samples = double(b.camera.width) * b.camera.height * options.pixel_samples_per_axis *
                         options.pixel_samples_per_axis * (options.light_samples + options.brdf_samples);
  state.counters["samples_per_s"] = benchmark::Counter(samples, benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_RenderView)->Arg(8)->Arg(16)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_VertexRadiance(benchmark::State& state) {
  BenchScene& b = Bench();
  RenderOptions options;
  int vertex = 0;
  for (auto _ : state) {
    const RadianceEstimate e =
        VertexRadiance(*b.scene, b.lighting, 0, vertex, Eigen::Vector3d(0, -1, 0.3).normalized(), options, 64);
    benchmark::DoNotOptimize(e.mean.data());
    vertex = (vertex + 97) % int(b.scene->surface(0).mesh.num_vertices());
  }
}
BENCHMARK(BM_VertexRadiance)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace relight

BENCHMARK_MAIN();

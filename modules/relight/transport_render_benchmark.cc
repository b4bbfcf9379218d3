// A 512 x 512 view of a 100K-vertex model (the bumpy terrain of render/test_scenes.h, real self-occlusion,
// a Lambertian + GGX + Phong blend) relit under a sun-and-sky map: the transport renderer against the Monte
// Carlo renderer at the relight stage's sample counts, in the same run (issue 36).
//
//   build/bin/transport_render_benchmark --benchmark_counters_tabular=true
//
// TransportNewLight: a new light every view (the Lambertian sums are computed; the visibility maps were
// decoded by an earlier view, as in a session of relighting). TransportSameLight: a further view under a
// light already used (a turntable). TransportColdStart: a fresh renderer (maps decoded on the way).
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>

#include "core/log.h"
#include "relight/relight.h"
#include "relight/transport_render.h"
#include "relight/views.h"
#include "render/render_view.h"
#include "render/test_scenes.h"
#include "sphere/sky.h"

namespace relight {
namespace {

struct Fixture {
  std::unique_ptr<Scene> scene;
  VisibilityData visibility;
  RenderCamera view;
  std::vector<std::shared_ptr<const Lighting>> lights;

  Fixture() {
    InitLogging("transport_render_benchmark", "", LogLevel::kWarning);
    TriangleMesh mesh = render_testing::Terrain(317);  // 100,489 vertices
    ReflectanceModel model;
    model.basis = {BrdfLobe{}, BrdfLobe{BrdfModel::kGgx, 0.3, 0.04, 50}, BrdfLobe{BrdfModel::kPhong, 0.3, 0.04, 50}};
    model.materials = {{"matte", {{0.6, 0.5, 0.4}, {0, 0, 0}, {0, 0, 0}}},
                       {"glossy", {{0.2, 0.3, 0.5}, {0.5, 0.5, 0.5}, {0.2, 0.2, 0.2}}}};
    std::vector<float>& w0 = mesh.Property("w0");
    std::vector<float>& w1 = mesh.Property("w1");
    for (size_t v = 0; v < mesh.num_vertices(); ++v) {
      w1[v] = 0.5f + 0.5f * std::sin(4 * mesh.vertices[v].x());
      w0[v] = 1 - w1[v];
    }
    scene = std::make_unique<Scene>(ModelSurfaces(mesh, model, TriangleMesh(), 0.35), "terrain");
    VisibilityOptions vo;
    vo.supersampling = 1;
    visibility = ComputeVisibility(scene->surface(0).mesh, scene->caster(), vo);
    view = OrbitCamera("view", Eigen::Vector3d(0, 0, 0), 1.45, 30, 40, 512, 40, 0.9);
    for (int k = 0; k < 64; ++k) {
      SunSkyParams p;
      const double az = 0.4 * k, el = 0.35 + 0.3 * std::sin(0.7 * k);
      p.sun_dir_world = Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      p.sun_radius_deg = 2;
      lights.push_back(std::make_shared<const Lighting>(Lighting::FromEnvMap(MakeSunSky(p, 128))));
    }
  }
};

Fixture& Get() {
  static Fixture f;
  return f;
}

void BM_TransportNewLight(benchmark::State& state) {
  Fixture& f = Get();
  TransportRenderer renderer(*f.scene, f.visibility, 32);
  TransportRenderOptions o;
  renderer.Render(*f.lights[0], f.view.camera, f.view.pose, o);  // decodes the maps the view needs
  size_t k = 1;
  for (auto _ : state) {
    const Lighting& light = *f.lights[k++ % f.lights.size()];
    benchmark::DoNotOptimize(renderer.Render(light, f.view.camera, f.view.pose, o).radiance.pixels.data());
    renderer.Forget(light);
  }
  state.counters["vertices"] = double(f.scene->surface(0).mesh.num_vertices());
}
BENCHMARK(BM_TransportNewLight)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3);

void BM_TransportSameLight(benchmark::State& state) {
  Fixture& f = Get();
  TransportRenderer renderer(*f.scene, f.visibility, 32);
  TransportRenderOptions o;
  renderer.Render(*f.lights[0], f.view.camera, f.view.pose, o);
  for (auto _ : state) {
    benchmark::DoNotOptimize(renderer.Render(*f.lights[0], f.view.camera, f.view.pose, o).radiance.pixels.data());
  }
}
BENCHMARK(BM_TransportSameLight)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3);

void BM_TransportColdStart(benchmark::State& state) {
  Fixture& f = Get();
  TransportRenderOptions o;
  for (auto _ : state) {
    TransportRenderer renderer(*f.scene, f.visibility, 32);
    benchmark::DoNotOptimize(renderer.Render(*f.lights[1], f.view.camera, f.view.pose, o).radiance.pixels.data());
  }
}
BENCHMARK(BM_TransportColdStart)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3);

// Monte Carlo at the relight stage's counts: 8 + 8 samples (new views), 32 + 32 (scored renders).
void BM_MonteCarlo(benchmark::State& state) {
  Fixture& f = Get();
  RenderOptions o;
  o.light_samples = o.brdf_samples = static_cast<int>(state.range(0));
  for (auto _ : state) {
    benchmark::DoNotOptimize(RenderView(*f.scene, *f.lights[2], f.view.camera, f.view.pose, o).radiance.pixels.data());
  }
}
BENCHMARK(BM_MonteCarlo)->Arg(8)->Arg(32)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

}  // namespace
}  // namespace relight

BENCHMARK_MAIN();

// The transport renderer against the Monte Carlo reference on a scene where both are exact up to their
// stated approximations (a smooth light, which the octahedral filtering keeps, and fine visibility maps):
// per-vertex radiance within the reference's noise plus 3 % and unbiased, images of the same view with equal object
// masks and equal mean radiance, and delta lights against the closed form E ρ cos θ / π with hard shadows. The
// one-bounce term inside a white hemispherical bowl, where it is over a quarter of the light: against its closed
// form under a uniform sky and against the Monte Carlo renderer's bounce; and the bounce off a coloured
// occluder ground onto a sphere, against the Monte Carlo renderer's.
#include "relight/transport_render.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>

#include "relight/display.h"
#include "relight/relight.h"
#include "relight/views.h"
#include "render/test_scenes.h"

namespace relight {
namespace {

// A smooth sky: a vertical gradient plus a broad warm lobe (about 30° wide) at elevation 35°.
EnvMap SmoothSky() {
  Image img(128, 64, 3);
  const Eigen::Vector3d s(std::cos(0.61) * std::cos(0.52), std::cos(0.61) * std::sin(0.52), std::sin(0.61));
  for (int row = 0; row < img.height; ++row)
    for (int col = 0; col < img.width; ++col) {
      const double th = M_PI * (row + 0.5) / img.height, ph = 2 * M_PI * (col + 0.5) / img.width;
      const Eigen::Vector3d d(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
      const double sky = 0.3 + 0.7 * std::max(0.0, d.z());
      const double lobe = 4 * std::exp(6 * (d.dot(s) - 1));
      img.at(col, row, 0) = float(0.8 * sky + 1.0 * lobe);
      img.at(col, row, 1) = float(0.9 * sky + 0.8 * lobe);
      img.at(col, row, 2) = float(1.1 * sky + 0.5 * lobe);
    }
  return EnvMap::FromLatLong(img);
}

struct TestScene {
  std::unique_ptr<Scene> scene;
  VisibilityData visibility;
};

// A sphere (Lambertian + Phong n = 30 + GGX α = 0.3) resting just above a ground square (Lambertian 0.35),
// with the sphere's visibility maps baked as the visibility stage bakes them.
TestScene MakeScene(int subdivisions) {
  TriangleMesh sphere = render_testing::Icosphere(0.5, Eigen::Vector3d(0, 0, 0.52), subdivisions);
  ReflectanceModel model;
  model.basis = {BrdfLobe{}, BrdfLobe{BrdfModel::kPhong, 0.3, 0.04, 30}, BrdfLobe{BrdfModel::kGgx, 0.3, 0.04, 50}};
  model.materials = {{"glossy", {{0.55, 0.45, 0.35}, {0.15, 0.15, 0.15}, {0.4, 0.4, 0.4}}}};
  TriangleMesh ground = render_testing::Plane(2.0, 0.0, 40);
  std::vector<Scene::Surface> surfaces = ModelSurfaces(sphere, model, ground, 0.35);
  TestScene t;
  t.scene = std::make_unique<Scene>(std::move(surfaces), "test");
  t.visibility = ComputeVisibility(t.scene->surface(0).mesh, t.scene->caster(), VisibilityOptions());
  return t;
}

TEST(TransportRender, VertexRadianceAgreesWithMonteCarlo) {
  const TestScene t = MakeScene(3);
  const Lighting lighting = Lighting::FromEnvMap(SmoothSky());
  TransportRenderer renderer(*t.scene, t.visibility, 32);
  RenderOptions mc;
  mc.light_samples = 16;
  mc.brdf_samples = 16;
  const Eigen::Vector3d eye(2.5, -2.0, 1.8);
  int compared = 0, shadowed = 0;
  double sum_rel = 0;
  for (int s = 0; s < 2; ++s) {
    const TriangleMesh& mesh = t.scene->surface(s).mesh;
    for (size_t v = 0; v < mesh.num_vertices(); v += s == 0 ? 5 : 3) {
      const Eigen::Vector3d x = mesh.vertices[v].cast<double>();
      if (s == 1 && x.head<2>().norm() > 1.2) continue;  // ground near the sphere (its shadow and contact)
      const Eigen::Vector3d wo = (eye - x).normalized();
      if (wo.dot(mesh.normals[v].cast<double>()) < 0.2) continue;  // the view sees the vertex's front
      const RadianceEstimate ref = VertexRadiance(*t.scene, lighting, s, int(v), wo, mc, 32);
      const Eigen::Vector3f got = renderer.VertexRadiance(lighting, s, int(v), wo.cast<float>());
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(got[c], ref.mean[c], 4 * ref.std_error[c] + 0.03 * ref.mean[c])
            << "surface " << s << " vertex " << v << " channel " << c;
      }
      sum_rel += (got.sum() - ref.mean.sum()) / ref.mean.sum();
      ++compared;
      if (s == 1 && x.head<2>().norm() < 0.3) ++shadowed;
    }
  }
  std::printf("%d vertices (%d in the shadow), mean signed relative difference %.4f\n", compared, shadowed,
              sum_rel / compared);
  EXPECT_GT(compared, 80);
  EXPECT_GT(shadowed, 0);
  // No bias: the mean signed difference is far below one vertex's noise (about 2 %).
  EXPECT_LT(std::abs(sum_rel / compared), 0.01);
}

TEST(TransportRender, ImageAgreesWithMonteCarloAndRerendersAreReused) {
  const TestScene t = MakeScene(4);
  const Lighting lighting = Lighting::FromEnvMap(SmoothSky());
  const RenderCamera view = OrbitCamera("v", Eigen::Vector3d(0, 0, 0.5), 0.6, 30, 25, 80, 35, 0.7);
  RenderOptions mc;
  mc.light_samples = 64;
  mc.brdf_samples = 64;
  mc.pixel_samples_per_axis = 2;
  const RenderedView ref = RenderView(*t.scene, lighting, view.camera, view.pose, mc);
  TransportRenderer renderer(*t.scene, t.visibility, 32);
  TransportRenderOptions o;
  const RenderedView got = renderer.Render(lighting, view.camera, view.pose, o);
  size_t agree = 0, object = 0, ground = 0;
  Eigen::Vector3d ref_object = Eigen::Vector3d::Zero(), got_object = ref_object, ref_ground = ref_object,
                  got_ground = ref_object;
  for (int y = 0; y < view.camera.height; ++y)
    for (int x = 0; x < view.camera.width; ++x) {
      agree += got.mask.at(x, y) == ref.mask.at(x, y);
      Eigen::Vector3d r, g;
      for (int c = 0; c < 3; ++c) {
        r[c] = ref.radiance.at(x, y, c);
        g[c] = got.radiance.at(x, y, c);
      }
      if (ref.mask.at(x, y) > 0 && ref.coverage.at(x, y) == 1) {
        ++object;
        ref_object += r;
        got_object += g;
      } else if (ref.surface.at(x, y) == 1 && got.surface.at(x, y) == 1) {
        ++ground;
        ref_ground += r;
        got_ground += g;
      }
    }
  EXPECT_EQ(agree, size_t(view.camera.width) * view.camera.height);
  ASSERT_GT(object, 1000u);
  ASSERT_GT(ground, 500u);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(got_object[c] / ref_object[c], 1.0, 0.02) << c;
    EXPECT_NEAR(got_ground[c] / ref_ground[c], 1.0, 0.02) << c;
  }
  // A second view under the same light reuses the Lambertian sums and baked occluder maps: same pixels.
  const RenderedView again = renderer.Render(lighting, view.camera, view.pose, o);
  for (int y = 0; y < view.camera.height; ++y)
    for (int x = 0; x < view.camera.width; ++x)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(again.radiance.at(x, y, c), got.radiance.at(x, y, c));
}

// A white hemispherical bowl (render_testing::Bowl), Lambertian albedo 0.8. Inside a sphere every surface
// element sees every other with the same form factor, dA / (4π R²), so the bowl has closed forms: each point
// sees the opening (the upper half, the sky) with a cosine-weighted share f = 1/2 and the bowl with 1 - f;
// under a uniform sky L the direct radiance is ρ f L everywhere and one bounce adds ρ (1 - f) times it.
TestScene MakeBowl(int rings, int segments) {
  const TriangleMesh bowl = render_testing::Bowl(rings, segments);
  TestScene t;
  t.scene = std::make_unique<Scene>(
      ModelSurfaces(bowl, LambertianModel(Eigen::Vector3d::Constant(0.8)), TriangleMesh(), 0.35), "bowl");
  t.visibility = ComputeVisibility(t.scene->surface(0).mesh, t.scene->caster(), VisibilityOptions());
  return t;
}

// Mean radiance (RGB) over the pixels wholly on the object in `ref`.
Eigen::Vector3d MeanObjectRadiance(const RenderedView& view, const RenderedView& ref, size_t* count) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  *count = 0;
  for (int y = 0; y < view.radiance.height; ++y)
    for (int x = 0; x < view.radiance.width; ++x) {
      if (ref.mask.at(x, y) == 0 || ref.coverage.at(x, y) < 1) continue;
      for (int c = 0; c < 3; ++c) sum[c] += view.radiance.at(x, y, c);
      ++*count;
    }
  return sum / std::max<size_t>(1, *count);
}

// One thread or all give the same bits (vectorised loops round differently on their scalar ends, so each thread's
// scratch must split its buffers alike): the Slurm test compares a run on one CPU per job with a local one.
TEST(TransportRender, ImagesAreBitIdenticalOnOneOrAllThreads) {
  const TestScene t = MakeScene(3);
  const Lighting lighting = Lighting::FromEnvMap(SmoothSky());
  const RenderCamera view = OrbitCamera("v", Eigen::Vector3d(0, 0, 0.5), 0.6, 30, 25, 96, 35, 0.7);
  RenderedView one;
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    TransportRenderer renderer(*t.scene, t.visibility, 32);
    one = renderer.Render(lighting, view.camera, view.pose, TransportRenderOptions());
  }
  TransportRenderer renderer(*t.scene, t.visibility, 32);
  const RenderedView all = renderer.Render(lighting, view.camera, view.pose, TransportRenderOptions());
  ASSERT_GT(CountMask(all.mask), 1000u);
  EXPECT_TRUE(one.radiance.pixels == all.radiance.pixels);
}

TEST(TransportRender, InterreflectionMatchesClosedFormAndMonteCarloBounceInABowl) {
  const TestScene t = MakeBowl(16, 64);
  const TriangleMesh& mesh = t.scene->surface(0).mesh;
  Image white(64, 32, 3, 1.0f), dim(64, 32, 3, 0.2f);
  // A uniform sky, and a sun (delta light) lighting part of the bowl under a dim sky.
  std::vector<std::pair<std::string, Lighting>> lights;
  lights.emplace_back("uniform sky", Lighting::FromEnvMap(EnvMap::FromLatLong(white)));
  Lighting sun = Lighting::FromEnvMap(EnvMap::FromLatLong(dim));
  sun.directional.push_back({Eigen::Vector3d(-0.5, -0.3, 1.0).normalized(), Eigen::Vector3d(3.0, 2.5, 2.0)});
  lights.emplace_back("sun and dim sky", std::move(sun));
  // From above the bowl's middle: only its inside is seen.
  const RenderCamera view = OrbitCamera("top", Eigen::Vector3d(0, 0, 0.25), 0.56, 20, 89.5, 80, 40, 0.9);
  TransportRenderer renderer(*t.scene, t.visibility, 32);
  TransportRenderOptions o;
  std::vector<RenderedView> direct;
  for (const auto& [name, lighting] : lights) direct.push_back(renderer.Render(lighting, view.camera, view.pose, o));
  std::vector<float> direct_vertex;
  for (size_t v = 0; v < mesh.num_vertices(); ++v)
    direct_vertex.push_back(renderer.VertexRadiance(lights[0].second, 0, int(v), mesh.normals[v])[0]);
  const InterreflectionSummary bounce = renderer.EnableInterreflection(BounceOptions(), false);
  std::printf("bounce samples: %zu over %zu vertices in %.3f s\n", bounce.num_samples, mesh.num_vertices(),
              bounce.seconds);

  // Closed form under the uniform sky (L = 1, ρ = 0.8, f = 1/2): direct 0.4, with the bounce 0.4 (1 + 0.4) = 0.56.
  double sum_direct = 0, sum_bounce = 0, max_error = 0;
  for (size_t v = 0; v < mesh.num_vertices(); ++v) {
    const float got = renderer.VertexRadiance(lights[0].second, 0, int(v), mesh.normals[v])[0];
    sum_direct += direct_vertex[v];
    sum_bounce += got;
    max_error = std::max(max_error, std::abs(got / 0.56 - 1));
  }
  const double mean_direct = sum_direct / mesh.num_vertices(), mean_bounce = sum_bounce / mesh.num_vertices();
  std::printf("closed form: vertex mean %.4f direct (0.4), %.4f with the bounce (0.56), largest error %.2f %%\n",
              mean_direct, mean_bounce, 100 * max_error);
  // The inscribed facets and the visibility maps' texels: 2 % on the mean, 5 % at any vertex.
  EXPECT_NEAR(mean_direct, 0.4, 0.008);
  EXPECT_NEAR(mean_bounce, 0.56, 0.011);
  EXPECT_LT(max_error, 0.05);

  // Images against the Monte Carlo renderer's bounce.
  RenderOptions mc;
  mc.light_samples = 16;
  mc.brdf_samples = 16;
  mc.interreflection = true;
  for (size_t l = 0; l < lights.size(); ++l) {
    const Lighting& lighting = lights[l].second;
    const RenderedView ref = RenderView(*t.scene, lighting, view.camera, view.pose, mc);
    const RenderedView got = renderer.Render(lighting, view.camera, view.pose, o);
    size_t count = 0;
    const Eigen::Vector3d ref_mean = MeanObjectRadiance(ref, ref, &count);
    const Eigen::Vector3d got_mean = MeanObjectRadiance(got, ref, &count);
    const Eigen::Vector3d direct_mean = MeanObjectRadiance(direct[l], ref, &count);
    std::printf(
        "%s: %zu pixels, mean R: Monte Carlo %.4f, transport %.4f (%+.2f %%), without the bounce %.4f "
        "(%+.2f %%); %.2f s and %.2f s\n",
        lights[l].first.c_str(), count, ref_mean[0], got_mean[0], 100 * (got_mean[0] / ref_mean[0] - 1), direct_mean[0],
        100 * (direct_mean[0] / ref_mean[0] - 1), ref.seconds, got.seconds);
    ASSERT_GT(count, 2000u);
    for (int c = 0; c < 3; ++c) {
      // Within 2 %: the visibility maps, the 12² bounce rays and the Gouraud shading of the sun's shadow edge,
      // against a reference whose mean has far less noise.
      EXPECT_NEAR(got_mean[c] / ref_mean[c], 1.0, 0.02) << lights[l].first << " channel " << c;
      // Without the bounce the bowl is far darker (the bounce is over a quarter of its light here).
      EXPECT_LT(direct_mean[c] / ref_mean[c], 0.85) << lights[l].first << " channel " << c;
    }
  }
}

// An occluder bounces light too: a grey Lambertian sphere resting above a coloured ground (an occluder of
// albedo (0.8, 0.5, 0.2), as the inverse stage recovers it), lit by a sun and a dim sky, seen from low so that
// its underside, lit mostly by the ground, fills much of the view. Against the Monte Carlo renderer's bounce.
TEST(TransportRender, InterreflectionFromAnOccluderMatchesMonteCarlo) {
  const TriangleMesh sphere = render_testing::Icosphere(0.5, Eigen::Vector3d(0, 0, 0.52), 3);
  const TriangleMesh ground = render_testing::Plane(2.0, 0.0, 40);
  TestScene t;
  t.scene = std::make_unique<Scene>(
      ModelSurfaces(sphere, LambertianModel(Eigen::Vector3d::Constant(0.5)), ground, Eigen::Vector3d(0.8, 0.5, 0.2)),
      "sphere on a coloured ground");
  t.visibility = ComputeVisibility(t.scene->surface(0).mesh, t.scene->caster(), VisibilityOptions());
  Image dim(64, 32, 3, 0.2f);
  Lighting lighting = Lighting::FromEnvMap(EnvMap::FromLatLong(dim));
  lighting.directional.push_back({Eigen::Vector3d(0.4, -0.2, 1.0).normalized(), Eigen::Vector3d(3.0, 3.0, 3.0)});
  const RenderCamera view = OrbitCamera("low", Eigen::Vector3d(0, 0, 0.52), 0.5, 30, 3, 80, 35, 0.9);
  TransportRenderer renderer(*t.scene, t.visibility, 32);
  TransportRenderOptions o;
  o.background = false;
  const RenderedView direct = renderer.Render(lighting, view.camera, view.pose, o);
  renderer.EnableInterreflection(BounceOptions(), true);
  const RenderedView got = renderer.Render(lighting, view.camera, view.pose, o);
  RenderOptions mc;
  mc.light_samples = 16;
  mc.brdf_samples = 16;
  mc.interreflection = true;
  mc.background = false;
  const RenderedView ref = RenderView(*t.scene, lighting, view.camera, view.pose, mc);
  size_t count = 0;
  const Eigen::Vector3d ref_mean = MeanObjectRadiance(ref, ref, &count);
  const Eigen::Vector3d got_mean = MeanObjectRadiance(got, ref, &count);
  const Eigen::Vector3d direct_mean = MeanObjectRadiance(direct, ref, &count);
  std::printf(
      "occluder bounce: %zu pixels, mean RGB: Monte Carlo %.4f %.4f %.4f, transport %.4f %.4f %.4f, without "
      "the bounce %.4f %.4f %.4f\n",
      count, ref_mean[0], ref_mean[1], ref_mean[2], got_mean[0], got_mean[1], got_mean[2], direct_mean[0],
      direct_mean[1], direct_mean[2]);
  ASSERT_GT(count, 1000u);
  for (int c = 0; c < 3; ++c) {
    // Within 3 %: the sphere's and the ground's visibility maps (the ground's baked at 16²), the 12² bounce
    // rays, the Gouraud shading of the sun's shadow on the ground.
    EXPECT_NEAR(got_mean[c] / ref_mean[c], 1.0, 0.03) << "channel " << c;
  }
  // The ground's colour: its red light raises the red channel most (without the bounce all three are equal).
  EXPECT_LT(direct_mean[0] / ref_mean[0], 0.9);
  EXPECT_GT(got_mean[0] / got_mean[2], 1.1);
  // Occluders that only block (inverse.interreflection: mesh): a convex sphere then gets no bounce at all, in
  // both renderers.
  mc.bounce_from_occluders = false;
  const RenderedView ref_blocking = RenderView(*t.scene, lighting, view.camera, view.pose, mc);
  const Eigen::Vector3d blocking_mean = MeanObjectRadiance(ref_blocking, ref, &count);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(blocking_mean[c] / direct_mean[c], 1.0, 0.03) << "channel " << c;
}

TEST(TransportRender, DirectionalLightMatchesClosedFormWithHardShadows) {
  const TestScene t = MakeScene(3);
  Lighting lighting;
  const Eigen::Vector3d to_sun = Eigen::Vector3d(0.3, 0.0, 1.0).normalized();
  lighting.directional.push_back({to_sun, Eigen::Vector3d(2.0, 1.5, 1.0)});
  TransportRenderer renderer(*t.scene, t.visibility, 32);
  const TriangleMesh& ground = t.scene->surface(1).mesh;
  int lit = 0, dark = 0;
  for (size_t v = 0; v < ground.num_vertices(); ++v) {
    const Eigen::Vector3d x = ground.vertices[v].cast<double>();
    // The sphere's shadow on the ground: the ray towards the sun passes within the radius of its centre.
    const Eigen::Vector3d c(0, 0, 0.52);
    const double t_closest = (c - x).dot(to_sun);
    const double miss = (x + t_closest * to_sun - c).norm();
    const Eigen::Vector3f got = renderer.VertexRadiance(lighting, 1, int(v), Eigen::Vector3f(0, 0, 1));
    if (miss > 0.52) {
      for (int ch = 0; ch < 3; ++ch)
        EXPECT_NEAR(got[ch], 0.35 / M_PI * to_sun.z() * lighting.directional[0].irradiance_rgb[ch], 1e-5);
      ++lit;
    } else if (miss < 0.48 && t_closest > 0) {
      EXPECT_EQ(got.norm(), 0.0f) << "vertex " << v << " is in the shadow";
      ++dark;
    }
  }
  EXPECT_GT(lit, 1000);
  EXPECT_GT(dark, 20);
}

}  // namespace
}  // namespace relight

// The transport renderer against the Monte Carlo reference on a scene where both are exact up to their
// stated approximations (a smooth light, which the octahedral filtering keeps, and fine visibility maps):
// per-vertex radiance within the reference's noise plus 3 % and unbiased, images of the same view with equal object
// masks and equal mean radiance, and delta lights against the closed form E ρ cos θ / π with hard shadows.
#include "relight/transport_render.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

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

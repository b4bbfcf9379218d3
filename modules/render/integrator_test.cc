// The integrator against closed forms: white furnace (Lambertian and glossy
// lobes: radiance = E x directional albedo), delta lights (exact), a small
// bright environment source (BRDF lobe x source power, and a fine quadrature of
// the same integral), full occlusion (exactly black), and one-bounce
// interreflection inside a sphere (closed form L_d (1 + rho)). Stochastic
// results are compared by z-tests against the estimator's own standard error.
#include "render/integrator.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "render/render_view.h"
#include "render/test_scenes.h"
#include "sphere/frame.h"
#include "sphere/octahedral.h"

namespace relight {
namespace {

using render_testing::Icosphere;
using render_testing::Plane;

Lighting UniformLighting(double radiance) {
  return Lighting::FromEnvMap(EnvMap::FromLatLong(Image(16, 8, 3, float(radiance))));
}

ReflectanceModel OneLobe(const BrdfLobe& lobe, const Eigen::Vector3d& rgb) {
  ReflectanceModel model;
  model.basis.push_back(lobe);
  model.materials.push_back(Material{"m", {rgb}});
  return model;
}

BrdfLobe Lobe(BrdfModel model, double roughness = 0.3, double exponent = 50) {
  BrdfLobe lobe;
  lobe.model = model;
  lobe.roughness = roughness;
  lobe.exponent = exponent;
  return lobe;
}

std::vector<BrdfLobe> AllLobes() {
  return {Lobe(BrdfModel::kLambertian), Lobe(BrdfModel::kCookTorrance, 0.3), Lobe(BrdfModel::kGgx, 0.2),
          Lobe(BrdfModel::kPhong, 0.3, 50), Lobe(BrdfModel::kPhong, 0.3, 500)};
}

// ∫ f(wi, wo) cos θi dwi over the hemisphere by midpoint quadrature on the hemi-octahedral square.
double DirectionalAlbedo(const BrdfLobe& lobe, const Eigen::Vector3d& wo, int n = 2048) {
  double sum = 0;
  const double cell = 2.0 / n;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d ab(-1 + (i + 0.5) * cell, -1 + (j + 0.5) * cell);
      const Eigen::Vector3d wi = HemiOctDecode(ab);
      sum += lobe.Eval<double>(wi, wo) * wi.z() * HemiOctJacobian(ab);
    }
  return sum * cell * cell;
}

Eigen::Vector3d LocalDir(double theta_deg, double phi_deg) {
  const double t = theta_deg * M_PI / 180, p = phi_deg * M_PI / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

// |estimate - expected| within 4.5 standard errors (or a relative floor for near-deterministic estimators).
void ExpectZ(const RadianceEstimate& est, const Eigen::Vector3d& expected, double rel_floor, const std::string& what) {
  for (int c = 0; c < 3; ++c) {
    const double tol = std::max(4.5 * est.std_error[c], rel_floor * std::abs(expected[c]) + 1e-12);
    EXPECT_NEAR(est.mean[c], expected[c], tol) << what << " channel " << c << " std_error " << est.std_error[c];
  }
}

TEST(IntegratorTest, QuadratureReferenceIsSane) {
  // The reference itself: a Lambertian lobe reflects everything, ∫cos/π = 1.
  EXPECT_NEAR(DirectionalAlbedo(Lobe(BrdfModel::kLambertian), LocalDir(30, 0)), 1.0, 1e-5);
}

TEST(IntegratorTest, WhiteFurnaceLambertianGivesAlbedoTimesRadiance) {
  const Eigen::Vector3d albedo(0.8, 0.5, 0.2);
  const double radiance = 2.5;
  Scene scene({{Icosphere(1.0, Eigen::Vector3d::Zero(), 3), OneLobe(Lobe(BrdfModel::kLambertian), albedo)}});
  const Lighting lighting = UniformLighting(radiance);
  RenderOptions options;
  // Independent batches: the batch means must scatter like their own standard errors say (z ~ N(0, 1)).
  std::vector<double> z;
  const auto& mesh = scene.surface(0).mesh;
  for (int batch = 0; batch < 40; ++batch) {
    const int vertex = (batch * 37) % int(mesh.num_vertices());
    const LocalFrame<double> frame = FrameFromNormal<double>(mesh.normals[vertex].cast<double>());
    const Eigen::Vector3d wo = frame.ToWorld(LocalDir(10 + batch, 7 * batch));
    options.seed = 100 + batch;
    const RadianceEstimate est = VertexRadiance(scene, lighting, 0, vertex, wo, options, 64);
    for (int c = 0; c < 3; ++c) {
      ASSERT_GT(est.std_error[c], 0);
      z.push_back((est.mean[c] - albedo[c] * radiance) / est.std_error[c]);
    }
  }
  double mean = 0, var = 0;
  for (double v : z) mean += v / z.size();
  for (double v : z) var += (v - mean) * (v - mean) / (z.size() - 1);
  // 120 z-values: their mean has standard deviation ~0.09 (if batches were independent per channel);
  // the channels share samples, so allow 4 sigma of the batch count instead.
  EXPECT_LT(std::abs(mean), 4.0 / std::sqrt(40.0)) << "bias in units of the standard error";
  EXPECT_GT(std::sqrt(var), 0.6) << "standard errors overstated";
  EXPECT_LT(std::sqrt(var), 1.5) << "standard errors understated";
}

TEST(IntegratorTest, WhiteFurnaceGlossyLobesGiveDirectionalAlbedo) {
  const double radiance = 1.7;
  const Eigen::Vector3d k(1.0, 0.6, 0.3);
  const Lighting lighting = UniformLighting(radiance);
  for (const BrdfLobe& lobe : AllLobes()) {
    Scene scene({{Icosphere(1.0, Eigen::Vector3d::Zero(), 3), OneLobe(lobe, k)}});
    const int vertex = 5;
    const Eigen::Vector3d n = scene.surface(0).mesh.normals[vertex].cast<double>();
    const LocalFrame<double> frame = FrameFromNormal<double>(n);
    for (double theta : {0.0, 35.0, 70.0}) {
      const Eigen::Vector3d wo_local = LocalDir(theta, 20);
      const double albedo = DirectionalAlbedo(lobe, wo_local);
      RenderOptions options;
      const RadianceEstimate est = VertexRadiance(scene, lighting, 0, vertex, frame.ToWorld(wo_local), options, 400);
      ExpectZ(est, radiance * albedo * k, 2e-3, lobe.Describe() + " theta_o " + std::to_string(theta));
    }
  }
}

TEST(IntegratorTest, DeltaLightsGiveExactLobeValues) {
  for (const BrdfLobe& lobe : AllLobes()) {
    const Eigen::Vector3d k(0.9, 0.4, 0.2);
    Scene scene({{Plane(10, 0, 2), OneLobe(lobe, k)}});
    const int vertex = 4;  // the centre (0, 0, 0), normal +Z: local frame = world frame
    const Eigen::Vector3d wo = LocalDir(40, 0);
    // The mirror direction tilted by 3 degrees: on the lobe's flank, where its value changes fastest.
    const Eigen::Vector3d wi = LocalDir(43, 180);
    const Eigen::Vector3d irradiance(2.0, 3.0, 4.0);
    Lighting lighting;
    lighting.directional.push_back({wi, irradiance});
    RenderOptions options;
    const RadianceEstimate est = VertexRadiance(scene, lighting, 0, vertex, wo, options, 4);
    const Eigen::Vector3d expected = k.cwiseProduct(irradiance) * lobe.Eval<double>(wi, wo) * wi.z();
    ASSERT_GT(expected.minCoeff(), 0) << lobe.Describe();
    // Exact up to float storage of the mesh and the lobe coefficients.
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(est.mean[c], expected[c], 1e-6 * expected[c]) << lobe.Describe();
    // A point light at distance 2 in the same direction: I cos / r^2.
    Lighting point;
    point.points.push_back({2.0 * wi, irradiance * 4.0});
    const RadianceEstimate est_point = VertexRadiance(scene, point, 0, vertex, wo, options, 4);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(est_point.mean[c], expected[c], 1e-5 * expected[c]) << lobe.Describe();  // float ray origin
  }
}

// A black lat-long map with one small bright disk of `radius_deg` around `dir`.
EnvMap SmallSource(const Eigen::Vector3d& dir, double radius_deg, double radiance) {
  const int h = 512, w = 1024;
  Image image(w, h, 3, 0.0f);
  const double cos_r = std::cos(radius_deg * M_PI / 180);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double theta = M_PI * (y + 0.5) / h, phi = 2 * M_PI * (x + 0.5) / w;
      const Eigen::Vector3d d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      if (d.dot(dir) >= cos_r)
        for (int c = 0; c < 3; ++c) image.at(x, y, c) = float(radiance);
    }
  return EnvMap::FromLatLong(std::move(image));
}

TEST(IntegratorTest, SmallBrightSourceGivesLobeValue) {
  const Eigen::Vector3d wo = LocalDir(40, 0);
  for (const BrdfLobe& lobe : AllLobes()) {
    const Eigen::Vector3d source = LocalDir(43, 180);
    const EnvMap env = SmallSource(source, 0.6, 5000.0);
    const Lighting lighting = Lighting::FromEnvMap(env);
    const Eigen::Vector3d k(0.9, 0.4, 0.2);
    Scene scene({{Plane(10, 0, 2), OneLobe(lobe, k)}});
    RenderOptions options;
    const RadianceEstimate est = VertexRadiance(scene, lighting, 0, 4, wo, options, 200);
    // Fine quadrature of ∫ f cos L over a 2-degree cap around the source (the map's bilinear
    // lookup spreads the disk by less than a pixel, 0.35 degrees).
    const LocalFrame<double> around = FrameFromNormal<double>(source);
    const int n = 600;
    const double cap = 2.0 * M_PI / 180;
    double integral = 0, power = 0;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (int i = 0; i < n; ++i) {
      const double alpha = cap * (i + 0.5) / n;
      for (int j = 0; j < n; ++j) {
        const double phi = 2 * M_PI * (j + 0.5) / n;
        const Eigen::Vector3d d =
            around.ToWorld({std::sin(alpha) * std::cos(phi), std::sin(alpha) * std::sin(phi), std::cos(alpha)});
        const double dw = std::sin(alpha) * (cap / n) * (2 * M_PI / n);
        const double radiance = env.Lookup(d).x();
        integral += lobe.Eval<double>(d, wo) * d.z() * radiance * dw;
        power += radiance * dw;
        centroid += radiance * dw * d;
      }
    }
    centroid.normalize();
    ExpectZ(est, integral * k, 2e-3, lobe.Describe() + " vs quadrature");
    // The lobe's analytic value at the source's centroid (the rasterised disk is off `source` by up to
    // a tenth of a degree) times the source's power; the lobe's curvature across the 1.2-degree source
    // changes the mean by about 1% for the narrowest lobe (Phong 500, 3 degrees off its peak).
    const double analytic = lobe.Eval<double>(centroid, wo) * centroid.z() * power;
    EXPECT_NEAR(est.mean.x(), analytic * k.x(), 0.03 * analytic * k.x()) << lobe.Describe() << " vs analytic";
  }
}

TEST(IntegratorTest, FullyOccludedPointIsBlack) {
  // A sphere inside a closed sphere: no direction reaches the environment or the light.
  ReflectanceModel white = OneLobe(Lobe(BrdfModel::kLambertian), Eigen::Vector3d(0.9, 0.9, 0.9));
  Scene scene({{Icosphere(0.5, Eigen::Vector3d::Zero(), 2), white},
               {Icosphere(3.0, Eigen::Vector3d::Zero(), 2, /*inward=*/true), white, SurfaceRole::kOccluder}});
  Lighting lighting = UniformLighting(10.0);
  lighting.directional.push_back({Eigen::Vector3d(0.3, 0.2, 0.9).normalized(), Eigen::Vector3d(100, 100, 100)});
  for (bool bounce : {false, true}) {
    RenderOptions options;
    options.interreflection = bounce;
    options.light_samples = 16;
    options.brdf_samples = 16;
    for (int vertex : {0, 7, 41}) {
      const Eigen::Vector3d n = scene.surface(0).mesh.normals[vertex].cast<double>();
      const RadianceEstimate est = VertexRadiance(scene, lighting, 0, vertex, n, options, 32);
      EXPECT_EQ(est.mean, Eigen::Vector3d::Zero()) << "vertex " << vertex << " bounce " << bounce;
    }
    // The same vertex without the enclosure is lit.
  }
  Scene open({{Icosphere(0.5, Eigen::Vector3d::Zero(), 2), white}});
  RenderOptions options;
  const Eigen::Vector3d n = open.surface(0).mesh.normals[0].cast<double>();
  EXPECT_GT(VertexRadiance(open, lighting, 0, 0, n, options, 4).mean.minCoeff(), 1.0);
}

TEST(IntegratorTest, OneBounceInsideSphereMatchesClosedForm) {
  // Point light of intensity I at the centre of a sphere of radius R with Lambertian albedo rho (inside):
  // direct L_d = rho/pi I/R^2 everywhere; the wall sees radiance L_d over its whole hemisphere, so one
  // bounce adds rho L_d.
  const double rho = 0.6, intensity = 3.0, radius = 1.0;
  Scene scene({{Icosphere(radius, Eigen::Vector3d::Zero(), 5, /*inward=*/true),
                OneLobe(Lobe(BrdfModel::kLambertian), Eigen::Vector3d(rho, rho, rho))}});
  Lighting lighting;
  lighting.points.push_back({Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(intensity)});
  const double direct = rho / M_PI * intensity / (radius * radius);
  RenderOptions options;
  const int vertex = 123;
  const Eigen::Vector3d inward = scene.surface(0).mesh.normals[vertex].cast<double>();
  const Eigen::Vector3d wo = (inward + Eigen::Vector3d(0.3, -0.2, 0.1)).normalized();
  const RadianceEstimate est_direct = VertexRadiance(scene, lighting, 0, vertex, wo, options, 8);
  EXPECT_NEAR(est_direct.mean.x(), direct, 1e-5 * direct);
  options.interreflection = true;
  options.brdf_samples = 16;
  const RadianceEstimate est = VertexRadiance(scene, lighting, 0, vertex, wo, options, 64);
  // Secondary points lie on flat faces slightly inside the sphere (at most 2e-4 R): 1e-3 covers it.
  ExpectZ(est, Eigen::Vector3d::Constant(direct * (1 + rho)), 1e-3, "one bounce");
}

TEST(IntegratorTest, BadOptionsAndScenesAreUserErrors) {
  RenderOptions options;
  options.pixel_samples_per_axis = 0;
  EXPECT_THROW(options.Check(), UserError);
  options = RenderOptions();
  options.light_samples = 0;
  options.brdf_samples = 0;
  EXPECT_THROW(options.Check(), UserError);
  ReflectanceModel two = OneLobe(Lobe(BrdfModel::kLambertian), Eigen::Vector3d(0.5, 0.5, 0.5));
  two.materials.push_back(Material{"second", {Eigen::Vector3d(0.1, 0.1, 0.1)}});
  // Two materials but no w0/w1 properties on the mesh.
  EXPECT_THROW(Scene({{Plane(1, 0, 1), two}}), UserError);
}

}  // namespace
}  // namespace relight

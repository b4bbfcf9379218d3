#include "brdf/brdf.h"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <random>

#include <Eigen/Geometry>

#include "core/error.h"

namespace relight {
namespace {

Eigen::Vector3d Dir(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// Midpoint quadrature over the sphere (full = true) or the upper hemisphere.
template <typename F>
double IntegrateSphere(F f, bool full, int n_theta = 1200, int n_phi = 1200) {
  const double theta_max = full ? M_PI : M_PI / 2;
  const double dt = theta_max / n_theta, dp = 2 * M_PI / n_phi;
  double sum = 0;
  for (int i = 0; i < n_theta; ++i) {
    const double t = (i + 0.5) * dt;
    double ring = 0;
    for (int j = 0; j < n_phi; ++j) ring += f(Dir(t, (j + 0.5) * dp));
    sum += ring * std::sin(t);
  }
  return sum * dt * dp;
}

std::vector<BrdfLobe> AllLobes() {
  std::vector<BrdfLobe> lobes;
  lobes.push_back(BrdfLobe{BrdfModel::kLambertian});
  for (double n : {50.0, 500.0}) lobes.push_back(BrdfLobe{BrdfModel::kPhong, 0.3, 0.04, n});
  for (double a : {0.1, 0.3, 0.6}) {
    lobes.push_back(BrdfLobe{BrdfModel::kGgx, a, 1.0});
    lobes.push_back(BrdfLobe{BrdfModel::kCookTorrance, a, 1.0});
  }
  return lobes;
}

TEST(BrdfTest, LambertianAndPhongAlbedoIsOneAtNormalIncidence) {
  const Eigen::Vector3d wo = Eigen::Vector3d::UnitZ();
  for (const auto& lobe : {BrdfLobe{BrdfModel::kLambertian}, BrdfLobe{BrdfModel::kPhong, 0, 0, 50},
                           BrdfLobe{BrdfModel::kPhong, 0, 0, 500}}) {
    const double albedo =
        IntegrateSphere([&](const Eigen::Vector3d& wi) { return lobe.Eval<double>(wi, wo) * wi.z(); }, false);
    EXPECT_NEAR(albedo, 1.0, 2e-3) << lobe.Describe();
  }
}

TEST(BrdfTest, SamplingDensitiesIntegrateToOne) {
  for (const auto& lobe : AllLobes()) {
    for (double theta_o : {0.0, 0.6, 1.2}) {
      const Eigen::Vector3d wo = Dir(theta_o, 0.3);
      const double total = IntegrateSphere([&](const Eigen::Vector3d& wi) { return lobe.Pdf(wo, wi); }, true);
      // Phong lobes near grazing angles lose the part of the cone below the horizon only
      // in Eval, not in Pdf: the density covers the whole sphere.
      EXPECT_NEAR(total, 1.0, 5e-3) << lobe.Describe() << " theta_o=" << theta_o;
    }
  }
}

TEST(BrdfTest, ReciprocityAndEnergyConservation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  for (const auto& lobe : AllLobes()) {
    for (int k = 0; k < 200; ++k) {
      const Eigen::Vector3d a = Dir(std::acos(u(rng)), 2 * M_PI * u(rng));
      const Eigen::Vector3d b = Dir(std::acos(u(rng)), 2 * M_PI * u(rng));
      const double fab = lobe.Eval<double>(a, b), fba = lobe.Eval<double>(b, a);
      EXPECT_NEAR(fab, fba, 1e-9 * std::max(1.0, fab)) << lobe.Describe();
      EXPECT_GE(fab, 0.0);
    }
    for (double theta_o : {0.0, 0.7, 1.3}) {
      const Eigen::Vector3d wo = Dir(theta_o, 0.0);
      const double albedo =
          IntegrateSphere([&](const Eigen::Vector3d& wi) { return lobe.Eval<double>(wi, wo) * wi.z(); }, false);
      EXPECT_LE(albedo, 1.0 + 3e-3) << lobe.Describe() << " theta_o=" << theta_o;
    }
  }
  // A smooth GGX mirror (f0 = 1) reflects nearly everything at normal incidence.
  const BrdfLobe smooth{BrdfModel::kGgx, 0.1, 1.0};
  const double albedo = IntegrateSphere(
      [&](const Eigen::Vector3d& wi) { return smooth.Eval<double>(wi, Eigen::Vector3d::UnitZ()) * wi.z(); }, false);
  EXPECT_GT(albedo, 0.97);
}

TEST(BrdfTest, ImportanceSampledEstimateMatchesQuadrature) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  for (const auto& lobe : AllLobes()) {
    const Eigen::Vector3d wo = Dir(0.5, 1.0);
    const double reference =
        IntegrateSphere([&](const Eigen::Vector3d& wi) { return lobe.Eval<double>(wi, wo) * wi.z(); }, false);
    const int n = 200000;
    double sum = 0, sum2 = 0;
    for (int k = 0; k < n; ++k) {
      double pdf;
      const Eigen::Vector3d wi = lobe.Sample(wo, u(rng), u(rng), &pdf);
      EXPECT_NEAR(pdf, lobe.Pdf(wo, wi), 1e-6 * std::max(1.0, pdf));
      const double x = pdf > 0 ? lobe.Eval<double>(wi, wo) * std::max(0.0, wi.z()) / pdf : 0.0;
      sum += x;
      sum2 += x * x;
    }
    const double mean = sum / n;
    const double sigma = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
    EXPECT_NEAR(mean, reference, 4 * sigma + 2e-3) << lobe.Describe();
  }
}

// EvalCosines takes what the lobe depends on as cosines, which no rotation
// changes: with the normal, wi and wo rotated anywhere, it must give Eval's value
// in the normal's own frame (the transport rows evaluate footprint normals so).
TEST(BrdfTest, EvalFromCosinesEqualsEvalInTheNormalsFrame) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto random_unit = [&] {
    const double z = 2 * u(rng) - 1, phi = 2 * M_PI * u(rng), r = std::sqrt(1 - z * z);
    return Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z);
  };
  int evaluated = 0;
  for (const BrdfLobe& lobe : AllLobes()) {
    SCOPED_TRACE(lobe.Describe());
    for (int k = 0; k < 2000; ++k) {
      // Local directions; the Phong ones near the mirror direction so its narrow lobe is non-zero.
      const Eigen::Vector3d wo_local = Dir(std::acos(u(rng)), 2 * M_PI * u(rng));
      Eigen::Vector3d wi_local = Dir(std::acos(u(rng)), 2 * M_PI * u(rng));
      if (k % 2 == 0) wi_local = (Eigen::Vector3d(-wo_local.x(), -wo_local.y(), wo_local.z()) + 0.1 * random_unit()).normalized();
      const double expected = lobe.Eval<double>(wi_local, wo_local);
      // A random rotation R: world directions R·w, normal R·z.
      const Eigen::Matrix3d rotation = Eigen::Quaterniond(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5)
                                           .normalized()
                                           .toRotationMatrix();
      const Eigen::Vector3d n = rotation.col(2), wi = rotation * wi_local, wo = rotation * wo_local;
      const Eigen::Vector3d h = (wi + wo).normalized();
      const double cos_o = n.dot(wo);
      const double got = lobe.EvalCosines<double>(n.dot(wi), cos_o, n.dot(h), std::max(0.0, wo.dot(h)),
                                                  wi.dot(2 * cos_o * n - wo));
      ASSERT_NEAR(got, expected, 1e-9 * std::max(1.0, expected)) << "wi " << wi_local.transpose() << ", wo "
                                                                   << wo_local.transpose();
      evaluated += expected > 0;
    }
  }
  EXPECT_GT(evaluated, 5000);
}

TEST(BrdfTest, TemplatedEvalGivesDerivatives) {
  using Jet = ceres::Jet<double, 1>;
  const BrdfLobe lobe{BrdfModel::kGgx, 0.3, 0.5};
  const double theta = 0.4, h = 1e-6;
  const Eigen::Vector3d wo = Dir(0.2, 0.1);
  const Jet t(theta, 0);
  const Eigen::Matrix<Jet, 3, 1> wi(sin(t), Jet(0.0), cos(t));
  const Jet value = lobe.Eval<Jet>(wi, wo.cast<Jet>());
  EXPECT_NEAR(value.a, lobe.Eval<double>(Dir(theta, 0), wo), 1e-12);
  const double fd = (lobe.Eval<double>(Dir(theta + h, 0), wo) - lobe.Eval<double>(Dir(theta - h, 0), wo)) / (2 * h);
  EXPECT_NEAR(value.v[0], fd, 1e-5 * std::max(1.0, std::abs(fd)));
}

TEST(BrdfTest, ReflectanceModelJsonRoundTripAndValidation) {
  ReflectanceModel model;
  model.basis = {BrdfLobe{BrdfModel::kLambertian}, BrdfLobe{BrdfModel::kPhong, 0.3, 0.04, 50}};
  model.materials = {{"red", {{0.8, 0.1, 0.1}, {0.2, 0.2, 0.2}}}, {"white", {{0.9, 0.9, 0.9}, {0, 0, 0}}}};
  const ReflectanceModel back = ReflectanceModelFromJson(ReflectanceModelToJson(model), "test");
  ASSERT_EQ(back.basis.size(), 2u);
  EXPECT_EQ(back.basis[1].model, BrdfModel::kPhong);
  EXPECT_EQ(back.basis[1].exponent, 50);
  EXPECT_EQ(back.materials[0].coefficients[0], Eigen::Vector3d(0.8, 0.1, 0.1));
  EXPECT_TRUE(back.DiffuseAlbedo({0.5, 0.5}).isApprox(Eigen::Vector3d(0.85, 0.5, 0.5)));
  Json bad = ReflectanceModelToJson(model);
  bad["materials"][0]["coefficients"].erase(1);
  EXPECT_THROW(ReflectanceModelFromJson(bad, "bad.json"), UserError);
  bad = ReflectanceModelToJson(model);
  bad["basis"][1]["model"] = "blinn";
  EXPECT_THROW(ReflectanceModelFromJson(bad, "bad.json"), UserError);
}

}  // namespace
}  // namespace relight

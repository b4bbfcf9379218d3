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

// GGX is evaluated in a factored, division-light form (GgxViewFactor ·
// Schlick · GgxHalfFactor, used by Eval and by the transport rows). Against
// the textbook form of Walter et al. 2007 written out here: D with tan²θ_h,
// separable Smith G1 with tan²θ, D G F / (4 cos_i cos_o), in double to 1e-12
// and in float (what the rows use) to 2e-5, relative, down to grazing angles.
TEST(BrdfTest, FactoredGgxEqualsTheTextbookFormula) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int compared = 0;
  for (double alpha : {0.02, 0.08, 0.3, 0.7, 1.0}) {
    for (double f0 : {0.04, 1.0}) {
      const BrdfLobe lobe{BrdfModel::kGgx, alpha, f0};
      SCOPED_TRACE(lobe.Describe());
      for (int k = 0; k < 4000; ++k) {
        // Down to 89.4° from the normal for both directions; half of the wi near the mirror direction.
        const Eigen::Vector3d wo = Dir(std::acos(0.01 + 0.99 * u(rng)), 2 * M_PI * u(rng));
        Eigen::Vector3d wi = Dir(std::acos(0.01 + 0.99 * u(rng)), 2 * M_PI * u(rng));
        if (k % 2 == 0) {
          wi = (Eigen::Vector3d(-wo.x(), -wo.y(), wo.z()) + alpha * Dir(std::acos(u(rng)), 2 * M_PI * u(rng))).normalized();
          if (wi.z() < 0.01) continue;
        }
        const Eigen::Vector3d h = (wi + wo).normalized();
        const double a2 = alpha * alpha;
        auto textbook = [&](double ci, double co, double ch, double o_dot_h) {
          const double tan_h2 = (1 - ch * ch) / (ch * ch);
          const double d = a2 / (M_PI * std::pow(ch, 4) * (a2 + tan_h2) * (a2 + tan_h2));
          auto g1 = [&](double c) { return 2 / (1 + std::sqrt(1 + a2 * (1 - c * c) / (c * c))); };
          const double fresnel = f0 + (1 - f0) * std::pow(1 - std::max(0.0, o_dot_h), 5);
          return d * g1(ci) * g1(co) * fresnel / (4 * ci * co);
        };
        const double expected = textbook(wi.z(), wo.z(), h.z(), wo.dot(h));
        ASSERT_NEAR(lobe.Eval<double>(wi, wo), expected, 1e-12 * expected) << "wi " << wi.transpose() << ", wo " << wo.transpose();
        // Float: against the textbook at the float-rounded cosines (a narrow lobe
        // amplifies the rounding of cos_h itself by 1/α², whatever the form).
        const float ci = float(wi.z()), co = float(wo.z()), ch = float(h.z()), o_dot_h = float(std::max(0.0, wo.dot(h)));
        const double expected_f = textbook(ci, co, ch, o_dot_h) * ci;
        const float factored = lobe.GgxViewFactor<float>(co) * brdf_internal::Schlick(float(f0), o_dot_h) *
                               lobe.GgxHalfFactor<float>(ci, ch);
        ASSERT_NEAR(factored, expected_f, 2e-5 * expected_f) << "wi " << wi.transpose() << ", wo " << wo.transpose();
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 35000);
}

// The vectorised batch against EvalCosines in float, one direction at a time: every lobe, 2,000 incident
// directions per outgoing one (half near the mirror direction, so the narrow lobes are non-zero, some below the
// horizon), to 1e-5 relative (Phong's c^n as exp(n log c) loses a few ulps of n log c).
TEST(BrdfTest, BatchEvalEqualsEvalCosines) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int nonzero = 0;
  for (const BrdfLobe& lobe : AllLobes()) {
    SCOPED_TRACE(lobe.Describe());
    for (int view = 0; view < 6; ++view) {
      const Eigen::Vector3d wo = Dir(std::acos(0.02 + 0.98 * u(rng)), 2 * M_PI * u(rng));
      const Eigen::Vector3d mirror(-wo.x(), -wo.y(), wo.z());
      const int n = 2003;  // not a multiple of the packet size
      std::vector<float> cos_i(n), cos_h(n), o_dot_h(n), cos_mirror(n), out(n, -1.0f);
      for (int k = 0; k < n; ++k) {
        Eigen::Vector3d wi = Dir(std::acos(2 * u(rng) - 1), 2 * M_PI * u(rng));
        if (k % 2 == 0) wi = (mirror + 0.2 * u(rng) * Dir(std::acos(2 * u(rng) - 1), 2 * M_PI * u(rng))).normalized();
        const Eigen::Vector3d h = (wi + wo).normalized();
        cos_i[k] = float(wi.z());
        cos_h[k] = float(h.z());
        o_dot_h[k] = float(std::max(0.0, wo.dot(h)));
        cos_mirror[k] = float(wi.dot(mirror));
      }
      lobe.EvalCosinesBatch(float(wo.z()), n, cos_i.data(), cos_h.data(), o_dot_h.data(), cos_mirror.data(),
                            out.data());
      for (int k = 0; k < n; ++k) {
        const float expected = lobe.EvalCosines<float>(cos_i[k], float(wo.z()), cos_h[k], o_dot_h[k], cos_mirror[k]);
        ASSERT_NEAR(out[k], expected, 1e-5f * std::max(1e-3f, expected)) << "k " << k << ", cos_i " << cos_i[k];
        nonzero += expected > 0;
      }
    }
  }
  EXPECT_GT(nonzero, 40000);
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

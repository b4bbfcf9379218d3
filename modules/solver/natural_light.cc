#include "solver/natural_light.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "solver/qp.h"
#include "sphere/octahedral.h"

namespace relight {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kCircumsolarSigmaRad = 0.35;
constexpr int kCandidateGrid = 16;  // sun directions tried: the upper texels of a 16² octahedral grid
constexpr int kRefineRounds = 6;    // then halving steps around the best, down to 1/64 of that grid's texel
constexpr int kSunSamples = 3;      // the sun term is averaged over 3×3 points of each texel

using Terms = Eigen::Matrix<double, NaturalLight::kTerms, 1>;
using TermMatrix = Eigen::Matrix<double, NaturalLight::kTerms, NaturalLight::kTerms>;

// The terms at a texel centre `w`; the sun term averaged over the texel's `sub` points (or at `w` alone).
Terms EvaluateTerms(const Eigen::Vector3d& w, const std::vector<Eigen::Vector3d>* sub, const Eigen::Vector3d& sun,
                    double sun_sigma) {
  Terms b;
  const double z = w.z();
  b[0] = std::max(0.0, z);
  b[1] = z > 0 ? 1.0 - z : 0.0;
  b[2] = z > 0 ? 0.0 : 1.0;
  const double inv_sun = 1.0 / (sun_sigma * sun_sigma);
  if (sub && !sub->empty()) {
    double sum = 0;
    for (const Eigen::Vector3d& p : *sub) sum += std::exp((sun.dot(p) - 1.0) * inv_sun);
    b[3] = sum / static_cast<double>(sub->size());
  } else {
    b[3] = std::exp((sun.dot(w) - 1.0) * inv_sun);
  }
  b[4] = std::exp((sun.dot(w) - 1.0) / (kCircumsolarSigmaRad * kCircumsolarSigmaRad));
  return b;
}

std::vector<Eigen::Vector3d> SubTexelDirections(int i, int j, int n) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(kSunSamples * kSunSamples);
  for (int b = 0; b < kSunSamples; ++b)
    for (int a = 0; a < kSunSamples; ++a)
      out.push_back(OctDecode(Eigen::Vector2d((i + (a + 0.5) / kSunSamples) / n, (j + (b + 0.5) / kSunSamples) / n)));
  return out;
}

struct Texel {
  Eigen::Vector3d dir;
  std::vector<Eigen::Vector3d> sub;  // sub-texel points for the sun term
  double weight;                     // fit weight × solid angle
  double irradiance;                 // max(0, z) × solid angle: contribution to an upward plane's irradiance
  Eigen::Vector3d value;
};

struct Candidate {
  NaturalLight model;
  double cost = std::numeric_limits<double>::infinity();
};

Candidate FitAtSun(const std::vector<Texel>& texels, const std::vector<Texel>& sky_texels, const Eigen::Vector3d& sun,
                   double sun_sigma, double weight_sum, double weighted_sq, const NaturalLightFitOptions& options) {
  TermMatrix q = TermMatrix::Zero();
  std::array<Terms, 3> rhs{Terms::Zero(), Terms::Zero(), Terms::Zero()};
  for (const Texel& t : texels) {
    const Terms b = EvaluateTerms(t.dir, &t.sub, sun, sun_sigma);
    q.selfadjointView<Eigen::Lower>().rankUpdate(b, t.weight);
    for (int c = 0; c < 3; ++c) rhs[c] += (t.weight * t.value[c]) * b;
  }
  // Horizontal irradiance of each term over the upper hemisphere, for the ground's pseudo-observation.
  Terms irradiance = Terms::Zero();
  for (const Texel& t : sky_texels) irradiance += t.irradiance * EvaluateTerms(t.dir, &t.sub, sun, sun_sigma);
  irradiance[2] = 0;
  Terms ground_row = -(options.ground_albedo / kPi) * irradiance;
  ground_row[2] += 1.0;
  q.selfadjointView<Eigen::Lower>().rankUpdate(ground_row, options.ground_prior_weight * weight_sum);
  const TermMatrix full = q.selfadjointView<Eigen::Lower>();
  Eigen::MatrixXd qd = full;
  qd.diagonal().array() += 1e-12 * std::max(1e-30, qd.diagonal().maxCoeff());
  Candidate out;
  out.model.sun_dir_world = sun;
  out.model.sun_sigma_rad = sun_sigma;
  double cost = weighted_sq;
  for (int c = 0; c < 3; ++c) {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(NaturalLight::kTerms);
    const Eigen::VectorXd r = rhs[c];
    SolveNonNegativeQp(qd, r, &x);
    out.model.coefficients[c] = x;
    cost += x.dot(full * x) - 2 * x.dot(r);
  }
  out.cost = cost;
  out.model.weighted_rms = std::sqrt(std::max(0.0, cost) / std::max(1e-30, 3 * weight_sum));
  double sun_part = 0, disc = 0, total = 0;
  for (int c = 0; c < 3; ++c) {
    const Terms e = irradiance.cwiseProduct(out.model.coefficients[c]);
    sun_part += e[3] + e[4];
    disc += e[3];
    total += e.sum();
  }
  out.model.sun_irradiance_share = total > 0 ? sun_part / total : 0.0;
  out.model.sun_disc_share = sun_part > 0 ? disc / sun_part : 0.0;
  return out;
}

}  // namespace

Eigen::Vector3d NaturalLight::Radiance(const Eigen::Vector3d& dir_world) const {
  const Terms b = EvaluateTerms(dir_world.normalized(), nullptr, sun_dir_world, sun_sigma_rad);
  return {b.dot(coefficients[0]), b.dot(coefficients[1]), b.dot(coefficients[2])};
}

std::array<std::vector<double>, 3> NaturalLight::Octahedral(int n) const {
  std::array<std::vector<double>, 3> out;
  for (auto& c : out) c.assign(static_cast<size_t>(n) * n, 0.0);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const std::vector<Eigen::Vector3d> sub = SubTexelDirections(i, j, n);
      const Terms b = EvaluateTerms(OctTexelDirection(i, j, n), &sub, sun_dir_world, sun_sigma_rad);
      for (int c = 0; c < 3; ++c) out[c][static_cast<size_t>(j) * n + i] = b.dot(coefficients[c]);
    }
  return out;
}

NaturalLight FitNaturalLight(const std::array<const double*, 3>& map, const std::vector<double>& weight, int n,
                             const NaturalLightFitOptions& options) {
  std::vector<Texel> texels, sky_texels;
  double weight_sum = 0, weighted_sq = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const size_t k = static_cast<size_t>(j) * n + i;
      Texel t;
      t.dir = OctTexelDirection(i, j, n);
      t.sub = SubTexelDirections(i, j, n);
      const double solid_angle = OctTexelSolidAngle(i, j, n);
      t.weight = std::max(0.0, weight[k]) * solid_angle;
      t.irradiance = std::max(0.0, t.dir.z()) * solid_angle;
      for (int c = 0; c < 3; ++c) t.value[c] = map[c][k];
      if (t.dir.z() > 0) sky_texels.push_back(t);
      if (t.weight > 0) {
        texels.push_back(t);
        weight_sum += t.weight;
        weighted_sq += t.weight * t.value.squaredNorm();
      }
    }
  NaturalLight zero;
  if (texels.empty() || weight_sum <= 0) return zero;
  // The variation about the weighted mean: the residual of the best constant map.
  Eigen::Vector3d weighted_value = Eigen::Vector3d::Zero();
  for (const Texel& t : texels) weighted_value += t.weight * t.value;
  const double variation = weighted_sq - weighted_value.squaredNorm() / weight_sum;
  const double sun_sigma = 0.5 * std::sqrt(4 * kPi) / n;  // half a texel, averaged over the texel

  Candidate best;
  for (int j = 0; j < kCandidateGrid; ++j)
    for (int i = 0; i < kCandidateGrid; ++i) {
      const Eigen::Vector3d d = OctTexelDirection(i, j, kCandidateGrid);
      if (d.z() < 0) continue;
      Candidate c = FitAtSun(texels, sky_texels, d, sun_sigma, weight_sum, weighted_sq, options);
      if (c.cost < best.cost) best = c;
    }
  double step = std::sqrt(4 * kPi) / kCandidateGrid / 2;
  for (int round = 0; round < kRefineRounds; ++round, step /= 2) {
    const Eigen::Vector3d d0 = best.model.sun_dir_world;
    const Eigen::Vector3d t1 = d0.unitOrthogonal(), t2 = d0.cross(t1);
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b) {
        if (a == 0 && b == 0) continue;
        Eigen::Vector3d d = d0 + step * (a * t1 + b * t2);
        d.z() = std::max(0.0, d.z());
        if (d.squaredNorm() < 1e-12) continue;
        Candidate c = FitAtSun(texels, sky_texels, d.normalized(), sun_sigma, weight_sum, weighted_sq, options);
        if (c.cost < best.cost) best = c;
      }
  }
  const double residual = std::max(0.0, best.cost);
  best.model.explained_variation = variation > 0 ? std::clamp(1 - residual / variation, 0.0, 1.0) : 1.0;
  return best.model;
}

}  // namespace relight

#include "sphere/sh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>

#include "core/error.h"
#include "sphere/octahedral.h"

namespace relight {
namespace {

// Normalisation K_lm = sqrt((2l+1)/(4 pi) (l-m)!/(l+m)!), times sqrt(2) for m > 0.
const std::array<double, ShNumCoefficients(kMaxShOrder)>& NormTable() {
  static const auto table = [] {
    std::array<double, ShNumCoefficients(kMaxShOrder)> t{};
    for (int l = 0; l <= kMaxShOrder; ++l) {
      for (int m = 0; m <= l; ++m) {
        double ratio = 1.0;  // (l-m)!/(l+m)!
        for (int k = l - m + 1; k <= l + m; ++k) ratio /= k;
        double k_lm = std::sqrt((2 * l + 1) / (4 * M_PI) * ratio);
        if (m > 0) k_lm *= std::sqrt(2.0);
        t[ShIndex(l, m)] = k_lm;
      }
    }
    return t;
  }();
  return table;
}

void CheckOrder(int order) {
  RELIGHT_CHECK(order >= 0 && order <= kMaxShOrder) << "SH order " << order << " outside [0, " << kMaxShOrder << "]";
}

// Fixed, well spread sample directions (Fibonacci sphere) for the rotation fits.
std::vector<Eigen::Vector3d> FibonacciDirections(int count) {
  std::vector<Eigen::Vector3d> dirs(count);
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < count; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    dirs[k] = {r * std::cos(golden * k), r * std::sin(golden * k), z};
  }
  return dirs;
}

struct BandFit {
  std::vector<Eigen::Vector3d> dirs;
  Eigen::MatrixXd pinv;  // (2l+1) x K pseudo-inverse of the band's values at dirs
};

const std::vector<BandFit>& BandFits() {
  static const auto fits = [] {
    std::vector<BandFit> f(kMaxShOrder + 1);
    double values[ShNumCoefficients(kMaxShOrder)];
    for (int l = 0; l <= kMaxShOrder; ++l) {
      const int k = 3 * (2 * l + 1);
      f[l].dirs = FibonacciDirections(k);
      Eigen::MatrixXd a(k, 2 * l + 1);
      for (int s = 0; s < k; ++s) {
        ShEvaluate(l, f[l].dirs[s], values);
        for (int m = -l; m <= l; ++m) a(s, m + l) = values[ShIndex(l, m)];
      }
      f[l].pinv = a.completeOrthogonalDecomposition().pseudoInverse();
    }
    return f;
  }();
  return fits;
}

}  // namespace

void ShEvaluate(int order, const Eigen::Vector3d& dir, double* values) {
  CheckOrder(order);
  const auto& norm = NormTable();
  const double inv = 1.0 / dir.norm();
  const double x = dir.x() * inv, y = dir.y() * inv, z = dir.z() * inv;
  double cm = 1.0, sm = 0.0;  // Re, Im of (x + i y)^m
  double q_mm = 1.0;          // (2m-1)!!
  for (int m = 0; m <= order; ++m) {
    if (m > 0) {
      const double c = cm * x - sm * y, s = cm * y + sm * x;
      cm = c;
      sm = s;
      q_mm *= (2 * m - 1);
    }
    double q_prev2 = 0.0, q_prev = q_mm;  // Q_{l-2}^m, Q_{l-1}^m (P_l^m / sin^m theta)
    for (int l = m; l <= order; ++l) {
      double q;
      if (l == m) {
        q = q_mm;
      } else if (l == m + 1) {
        q = z * (2 * m + 1) * q_mm;
      } else {
        q = ((2 * l - 1) * z * q_prev - (l + m - 1) * q_prev2) / (l - m);
      }
      if (l > m) {
        q_prev2 = q_prev;
        q_prev = q;
      }
      const double k = norm[ShIndex(l, m)] * q;
      if (m == 0) {
        values[ShIndex(l, 0)] = k;
      } else {
        values[ShIndex(l, m)] = k * cm;
        values[ShIndex(l, -m)] = k * sm;
      }
    }
  }
}

Eigen::VectorXd ShEvaluate(int order, const Eigen::Vector3d& dir) {
  Eigen::VectorXd v(ShNumCoefficients(order));
  ShEvaluate(order, dir, v.data());
  return v;
}

int ShOrderOf(int num_coefficients) {
  for (int order = 0; order <= kMaxShOrder; ++order)
    if (ShNumCoefficients(order) == num_coefficients) return order;
  RELIGHT_CHECK(false) << num_coefficients << " is not an SH coefficient count";
  return -1;
}

double ShReconstruct(const Eigen::VectorXd& coeffs, const Eigen::Vector3d& dir) {
  return coeffs.dot(ShEvaluate(ShOrderOf(int(coeffs.size())), dir));
}

Eigen::Vector3d ShReconstructRgb(const Eigen::MatrixXd& coeffs, const Eigen::Vector3d& dir) {
  RELIGHT_CHECK_EQ(coeffs.cols(), 3);
  return coeffs.transpose() * ShEvaluate(ShOrderOf(int(coeffs.rows())), dir);
}

Eigen::MatrixXd ShProjectEnvMap(const EnvMap& env, int order, int supersampling) {
  CheckOrder(order);
  const int nc = ShNumCoefficients(order);
  const Image& img = env.image();
  const int w = img.width, h = img.height;
  const bool latlong = env.layout() == EnvMap::Layout::kLatLong;
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, h), Eigen::MatrixXd(Eigen::MatrixXd::Zero(nc, 3)),
      [&](const tbb::blocked_range<int>& rows, Eigen::MatrixXd acc) {
        Eigen::VectorXd y(nc);
        for (int row = rows.begin(); row < rows.end(); ++row) {
          for (int x = 0; x < w; ++x) {
            for (int sy = 0; sy < supersampling; ++sy) {
              for (int sx = 0; sx < supersampling; ++sx) {
                const double u = (x + (sx + 0.5) / supersampling) / w, v = (row + (sy + 0.5) / supersampling) / h;
                Eigen::Vector3d d;
                double jac;
                if (latlong) {
                  const double theta = M_PI * v, phi = 2 * M_PI * u;
                  d = {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
                  jac = 2 * M_PI * M_PI * std::sin(theta);
                } else {
                  d = OctDecode({u, v});
                  jac = OctJacobian({u, v});
                }
                d = env.rotation_world() * d;
                const double weight = jac / (double(w) * h * supersampling * supersampling);
                ShEvaluate(order, d, y.data());
                acc += (weight * y) * env.Lookup(d).transpose();
              }
            }
          }
        }
        return acc;
      },
      [](const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) -> Eigen::MatrixXd { return a + b; });
}

Eigen::VectorXd ShProjectOct(const float* texel_averages, int n, int order) {
  return ShProjectSamples(OctTexelDirections(n), OctTexelSolidAngles(n), texel_averages, order);
}

Eigen::VectorXd ShProjectSamples(const std::vector<Eigen::Vector3d>& dirs_world, const std::vector<double>& weights_sr,
                                 const float* values, int order) {
  CheckOrder(order);
  RELIGHT_CHECK_EQ(dirs_world.size(), weights_sr.size());
  const int nc = ShNumCoefficients(order);
  Eigen::VectorXd out = Eigen::VectorXd::Zero(nc), y(nc);
  for (size_t k = 0; k < dirs_world.size(); ++k) {
    if (values[k] == 0.0f) continue;
    ShEvaluate(order, dirs_world[k], y.data());
    out += (weights_sr[k] * values[k]) * y;
  }
  return out;
}

std::vector<float> ShToOct(const Eigen::VectorXd& coeffs, int n) {
  const int order = ShOrderOf(int(coeffs.size()));
  std::vector<float> out(size_t(n) * n);
  Eigen::VectorXd y(coeffs.size());
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      ShEvaluate(order, OctTexelDirection(i, j, n), y.data());
      out[size_t(j) * n + i] = float(coeffs.dot(y));
    }
  return out;
}

double ShClampedCosineWeight(int l) {
  if (l == 0) return M_PI;
  if (l == 1) return 2 * M_PI / 3;
  if (l % 2 == 1) return 0.0;
  double fact_ratio = 1.0;  // l! / (2^l ((l/2)!)^2)
  for (int k = 1; k <= l; ++k) fact_ratio *= k;
  double half = 1.0;
  for (int k = 1; k <= l / 2; ++k) half *= k;
  fact_ratio /= std::pow(2.0, l) * half * half;
  const double sign = ((l / 2 - 1) % 2 == 0) ? 1.0 : -1.0;
  return 2 * M_PI * sign / ((l + 2) * (l - 1)) * fact_ratio;
}

Eigen::Vector3d ShIrradiance(const Eigen::MatrixXd& lighting_coeffs, const Eigen::Vector3d& normal_world) {
  const int order = ShOrderOf(int(lighting_coeffs.rows()));
  Eigen::VectorXd y = ShEvaluate(order, normal_world);
  for (int l = 0; l <= order; ++l)
    for (int m = -l; m <= l; ++m) y[ShIndex(l, m)] *= ShClampedCosineWeight(l);
  return lighting_coeffs.transpose() * y;
}

Eigen::VectorXd ShClampedCosineTransport(int order, const Eigen::Vector3d& normal_world) {
  Eigen::VectorXd y = ShEvaluate(order, normal_world);
  for (int l = 0; l <= order; ++l)
    for (int m = -l; m <= l; ++m) y[ShIndex(l, m)] *= ShClampedCosineWeight(l);
  return y;
}

ShRotation::ShRotation(int order, const Eigen::Matrix3d& rotation) : order_(order) {
  CheckOrder(order);
  const auto& fits = BandFits();
  const Eigen::Matrix3d inverse = rotation.transpose();
  double values[ShNumCoefficients(kMaxShOrder)];
  bands_.resize(order + 1);
  for (int l = 0; l <= order; ++l) {
    const BandFit& fit = fits[l];
    // g(d_k) = f(R^-1 d_k) = Y_l(R^-1 d_k)^T c  and  g(d_k) = Y_l(d_k)^T c'  =>  c' = A^+ B c.
    Eigen::MatrixXd b(fit.dirs.size(), 2 * l + 1);
    for (size_t s = 0; s < fit.dirs.size(); ++s) {
      ShEvaluate(l, inverse * fit.dirs[s], values);
      for (int m = -l; m <= l; ++m) b(s, m + l) = values[ShIndex(l, m)];
    }
    bands_[l] = fit.pinv * b;
  }
}

void ShRotation::Apply(const double* in, double* out) const {
  for (int l = 0; l <= order_; ++l) {
    const int offset = l * l;
    Eigen::Map<Eigen::VectorXd>(out + offset, 2 * l + 1) =
        bands_[l] * Eigen::Map<const Eigen::VectorXd>(in + offset, 2 * l + 1);
  }
}

Eigen::MatrixXd ShRotation::Matrix() const {
  const int nc = ShNumCoefficients(order_);
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(nc, nc);
  for (int l = 0; l <= order_; ++l) m.block(l * l, l * l, 2 * l + 1, 2 * l + 1) = bands_[l];
  return m;
}

ShHemiOctProjector::ShHemiOctProjector(int n, int order) : n_(n), order_(order) {
  CheckOrder(order);
  RELIGHT_CHECK(IsPowerOfTwo(n));
  const int nc = ShNumCoefficients(order);
  basis_.resize(nc, n * n);
  Eigen::VectorXd y(nc);
  const auto dirs = HemiOctTexelDirections(n);
  const auto omega = HemiOctTexelSolidAngles(n);
  solid_angle_sr_.assign(omega.begin(), omega.end());
  for (int t = 0; t < n * n; ++t) {
    ShEvaluate(order, dirs[t], y.data());
    basis_.col(t) = y.cast<float>();
  }
}

void ShHemiOctProjector::ProjectIntegralsLocal(const float* texel_integrals, double* coeffs_local) const {
  const Eigen::Map<const Eigen::VectorXf> v(texel_integrals, n_ * n_);
  Eigen::Map<Eigen::VectorXd>(coeffs_local, basis_.rows()) = (basis_ * v).cast<double>();
}

void ShHemiOctProjector::ProjectIntegrals(const float* texel_integrals, const LocalFrame<double>& frame,
                                          double* coeffs_world) const {
  Eigen::VectorXd local(basis_.rows());
  ProjectIntegralsLocal(texel_integrals, local.data());
  ShRotation(order_, frame.LocalFromWorld().transpose()).Apply(local.data(), coeffs_world);
}

void ShHemiOctProjector::ProjectAverages(const float* texel_averages, const LocalFrame<double>& frame,
                                         double* coeffs_world) const {
  std::vector<float> integrals(size_t(n_) * n_);
  for (size_t t = 0; t < integrals.size(); ++t) integrals[t] = texel_averages[t] * solid_angle_sr_[t];
  ProjectIntegrals(integrals.data(), frame, coeffs_world);
}

}  // namespace relight

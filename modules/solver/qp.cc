#include "solver/qp.h"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <vector>

#include "core/error.h"

namespace relight {
namespace {

double Objective(const Eigen::MatrixXd& Q, const Eigen::VectorXd& q, const Eigen::VectorXd& x) {
  return 0.5 * x.dot(Q * x) - q.dot(x);
}

double ProjectedGradientNorm(const Eigen::VectorXd& x, const Eigen::VectorXd& g) {
  double s = 0;
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    const double pg = x[k] > 0 ? g[k] : std::min(g[k], 0.0);
    s += pg * pg;
  }
  return std::sqrt(s);
}

}  // namespace

QpSummary SolveNonNegativeQp(const Eigen::MatrixXd& Q, const Eigen::VectorXd& q, Eigen::VectorXd* x_io,
                             int max_iterations, double tolerance) {
  const Eigen::Index n = q.size();
  RELIGHT_CHECK(Q.rows() == n && Q.cols() == n);
  Eigen::VectorXd& x = *x_io;
  if (x.size() != n) x = Eigen::VectorXd::Zero(n);
  x = x.cwiseMax(0.0);
  QpSummary summary;
  const double scale = 1.0 + q.norm();
  std::vector<Eigen::Index> free_index;
  free_index.reserve(n);
  // The gradient is carried along (g ← g + QΔ); each iteration costs one product Q·d, and every
  // trial of the line search only the columns of the variables its projection clipped.
  Eigen::VectorXd g = Q * x - q;
  double f = 0.5 * x.dot(g - q);  // ½xᵀQx − qᵀx = ½xᵀ(g − q)
  std::vector<Eigen::Index> clipped;
  for (int iter = 0; iter < max_iterations; ++iter) {
    summary.iterations = iter + 1;
    summary.projected_gradient_norm = ProjectedGradientNorm(x, g);
    if (summary.projected_gradient_norm <= tolerance * scale) {
      summary.converged = true;
      break;
    }
    // Binding set (Bertsekas' epsilon-active set): at the bound, gradient pushing outward.
    const double eps = std::min(1e-9 * (1.0 + x.cwiseAbs().maxCoeff()), (x - (x - g).cwiseMax(0.0)).norm());
    free_index.clear();
    for (Eigen::Index k = 0; k < n; ++k)
      if (!(x[k] <= eps && g[k] > 0)) free_index.push_back(k);
    const Eigen::Index m = static_cast<Eigen::Index>(free_index.size());
    summary.free_variables = static_cast<int>(m);
    Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
    if (m > 0) {
      Eigen::MatrixXd qff(m, m);
      Eigen::VectorXd gf(m);
      for (Eigen::Index a = 0; a < m; ++a) {
        gf[a] = g[free_index[a]];
        for (Eigen::Index b = 0; b <= a; ++b) qff(a, b) = Q(free_index[a], free_index[b]);
      }
      Eigen::LLT<Eigen::MatrixXd, Eigen::Lower> llt(qff);
      Eigen::VectorXd df;
      if (llt.info() == Eigen::Success) {
        df = -llt.solve(gf);
      } else {  // numerically semi-definite: a tiny ridge keeps the step defined
        const double ridge = 1e-12 * (1.0 + qff.diagonal().cwiseAbs().maxCoeff());
        qff.diagonal().array() += ridge;
        df = -Eigen::LLT<Eigen::MatrixXd, Eigen::Lower>(qff).solve(gf);
      }
      for (Eigen::Index a = 0; a < m; ++a) d[free_index[a]] = df[a];
    }
    // Variables in the binding set keep d = 0 (they have g > 0 at x = 0, so they stay there).
    // Projected Armijo search on x(t) = max(0, x + t d): Δ = t d + c, c non-zero only where the
    // projection clipped, so QΔ = t Qd + Q c and f(x + Δ) = f + gᵀΔ + ½ΔᵀQΔ.
    const Eigen::VectorXd qd = Q * d;
    double t = 1.0;
    Eigen::VectorXd delta(n), q_delta(n);
    double f_new = f;
    bool accepted = false;
    for (int ls = 0; ls < 40; ++ls) {
      clipped.clear();
      for (Eigen::Index k = 0; k < n; ++k) {
        const double v = x[k] + t * d[k];
        if (v < 0) {
          delta[k] = -x[k];
          clipped.push_back(k);
        } else {
          delta[k] = t * d[k];
        }
      }
      q_delta = t * qd;
      for (Eigen::Index k : clipped) q_delta += (-x[k] - t * d[k]) * Q.col(k);
      f_new = f + g.dot(delta) + 0.5 * delta.dot(q_delta);
      if (f_new <= f + 1e-4 * g.dot(delta)) {
        accepted = true;
        break;
      }
      t *= 0.5;
    }
    if (!accepted || delta.norm() <= 1e-15 * (1.0 + x.norm())) {
      summary.converged = summary.projected_gradient_norm <= 1e-6 * scale;
      break;
    }
    x += delta;
    for (Eigen::Index k : clipped) x[k] = 0.0;  // exactly on the bound
    g += q_delta;
    f = f_new;
  }
  summary.objective = Objective(Q, q, x);
  return summary;
}

namespace {
// Residuals R x - z of the least-squares form, with the constant Jacobian R.
class LinearResidual : public ceres::CostFunction {
 public:
  LinearResidual(const Eigen::MatrixXd& r, const Eigen::VectorXd& z) : r_(r), z_(z) {
    set_num_residuals(static_cast<int>(r.rows()));
    mutable_parameter_block_sizes()->push_back(static_cast<int32_t>(r.cols()));
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Map<const Eigen::VectorXd> x(parameters[0], r_.cols());
    Eigen::Map<Eigen::VectorXd>(residuals, r_.rows()) = r_ * x - z_;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[0], r_.rows(),
                                                                                           r_.cols()) = r_;
    }
    return true;
  }

 private:
  Eigen::MatrixXd r_;
  Eigen::VectorXd z_;
};
}  // namespace

QpSummary SolveNonNegativeQpCeres(const Eigen::MatrixXd& Q, const Eigen::VectorXd& q, Eigen::VectorXd* x_io) {
  const Eigen::Index n = q.size();
  Eigen::VectorXd& x = *x_io;
  if (x.size() != n) x = Eigen::VectorXd::Zero(n);
  x = x.cwiseMax(0.0);
  Eigen::LLT<Eigen::MatrixXd> llt(Q);
  RELIGHT_CHECK(llt.info() == Eigen::Success) << "lighting system is not positive definite";
  const Eigen::MatrixXd r = llt.matrixU();
  const Eigen::VectorXd z = llt.matrixL().solve(q);
  ceres::Problem problem;
  problem.AddResidualBlock(new LinearResidual(r, z), nullptr, x.data());
  for (Eigen::Index k = 0; k < n; ++k) problem.SetParameterLowerBound(x.data(), static_cast<int>(k), 0.0);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.trust_region_strategy_type = ceres::DOGLEG;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-14;
  options.gradient_tolerance = 1e-14;
  options.parameter_tolerance = 1e-14;
  options.num_threads = 1;
  ceres::Solver::Summary s;
  ceres::Solve(options, &problem, &s);
  QpSummary summary;
  summary.iterations = static_cast<int>(s.iterations.size());
  summary.converged = s.termination_type == ceres::CONVERGENCE;
  summary.objective = Objective(Q, q, x);
  summary.projected_gradient_norm = ProjectedGradientNorm(x, Q * x - q);
  return summary;
}

QpSummary SolveNonNegativeQp(const std::string& solver, const Eigen::MatrixXd& Q, const Eigen::VectorXd& q,
                             Eigen::VectorXd* x) {
  if (solver == "ceres") return SolveNonNegativeQpCeres(Q, q, x);
  return SolveNonNegativeQp(Q, q, x);
}

}  // namespace relight

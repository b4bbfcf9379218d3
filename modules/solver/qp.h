// Convex quadratic programs of the solver:
//   minimise 0.5 x^T Q x - q^T x  subject to  x >= 0   (Q symmetric positive definite)
// the per-photo lighting step in the pixel domain (Haber et al. 2009, §5.1,
// eq. 10) and the small non-negative least-squares problems of the reflectance
// step (eqs. 11-12).
//
// Projected Newton (Bertsekas 1982): Newton steps on the free variables,
// projected Armijo line search; converges in a handful of iterations from a
// warm start, each one Cholesky factorisation of the free block. Written by
// hand because no Debian-packaged library solves dense bound-constrained QPs
// directly (Ceres handles bounds in its trust-region solvers; that variant is
// kept for comparison: docs/BENCHMARKS.md).
#pragma once

#include <Eigen/Core>
#include <string>

namespace relight {

struct QpSummary {
  int iterations = 0;
  int free_variables = 0;
  double objective = 0;
  double projected_gradient_norm = 0;
  bool converged = false;
};

// Solves in place; `x` holds the warm start (clamped to >= 0 first).
QpSummary SolveNonNegativeQp(const Eigen::MatrixXd& Q, const Eigen::VectorXd& q, Eigen::VectorXd* x,
                             int max_iterations = 50, double tolerance = 1e-10);

// The same problem through Ceres (bounded Levenberg-Marquardt on the
// equivalent least-squares form |R x - z|^2 with Q = R^T R, q = R^T z).
QpSummary SolveNonNegativeQpCeres(const Eigen::MatrixXd& Q, const Eigen::VectorXd& q, Eigen::VectorXd* x);

// Dispatch on the option value "projected_newton" / "ceres".
QpSummary SolveNonNegativeQp(const std::string& solver, const Eigen::MatrixXd& Q, const Eigen::VectorXd& q,
                             Eigen::VectorXd* x);

}  // namespace relight

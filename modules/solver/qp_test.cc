#include "solver/qp.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>

namespace relight {
namespace {

// Exhaustive solution of a tiny non-negative QP: try every active set.
Eigen::VectorXd BruteForce(const Eigen::MatrixXd& Q, const Eigen::VectorXd& q) {
  const int n = static_cast<int>(q.size());
  Eigen::VectorXd best = Eigen::VectorXd::Zero(n);
  double best_f = 0;
  for (int mask = 1; mask < (1 << n); ++mask) {
    std::vector<int> f;
    for (int k = 0; k < n; ++k)
      if (mask & (1 << k)) f.push_back(k);
    Eigen::MatrixXd qff(f.size(), f.size());
    Eigen::VectorXd qf(f.size());
    for (size_t a = 0; a < f.size(); ++a) {
      qf[a] = q[f[a]];
      for (size_t b = 0; b < f.size(); ++b) qff(a, b) = Q(f[a], f[b]);
    }
    const Eigen::VectorXd xf = qff.llt().solve(qf);
    if ((xf.array() < 0).any()) continue;
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    for (size_t a = 0; a < f.size(); ++a) x[f[a]] = xf[a];
    const double fx = 0.5 * x.dot(Q * x) - q.dot(x);
    if (fx < best_f) {
      best_f = fx;
      best = x;
    }
  }
  return best;
}

TEST(QpTest, MatchesExhaustiveSolutionAndKkt) {
  std::mt19937 rng(4);
  std::normal_distribution<double> n01(0, 1);
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 6;
    Eigen::MatrixXd a(10, n);
    for (int i = 0; i < a.size(); ++i) a.data()[i] = n01(rng);
    const Eigen::MatrixXd Q = a.transpose() * a + 1e-3 * Eigen::MatrixXd::Identity(n, n);
    Eigen::VectorXd q(n);
    for (int i = 0; i < n; ++i) q[i] = n01(rng);
    const Eigen::VectorXd truth = BruteForce(Q, q);
    Eigen::VectorXd x;
    const QpSummary s = SolveNonNegativeQp(Q, q, &x);
    EXPECT_TRUE(s.converged);
    EXPECT_LT((x - truth).norm(), 1e-8 * (1 + truth.norm())) << "trial " << trial;
    const Eigen::VectorXd g = Q * x - q;
    for (int k = 0; k < n; ++k) {
      EXPECT_GE(x[k], 0.0);
      if (x[k] > 1e-9) {
        EXPECT_NEAR(g[k], 0.0, 1e-8);
      } else {
        EXPECT_GE(g[k], -1e-8);
      }
    }
    // Ceres' bounded trust region (the comparison solver) stays feasible and close,
    // but stops short of the exact optimum that the active-set Newton method reaches.
    Eigen::VectorXd xc;
    const QpSummary c = SolveNonNegativeQpCeres(Q, q, &xc);
    EXPECT_GE(xc.minCoeff(), 0.0);
    EXPECT_GE(c.objective, s.objective - 1e-9) << "trial " << trial;
    EXPECT_LE(c.objective, s.objective + 0.2 * std::abs(s.objective) + 1e-9) << "ceres, trial " << trial;
  }
}

TEST(QpTest, LargeSystemWarmStartConvergesQuickly) {
  std::mt19937 rng(9);
  std::normal_distribution<double> n01(0, 1);
  const int n = 256;
  Eigen::MatrixXd a(600, n);
  for (int i = 0; i < a.size(); ++i) a.data()[i] = n01(rng);
  const Eigen::MatrixXd Q = a.transpose() * a;
  Eigen::VectorXd q(n);
  for (int i = 0; i < n; ++i) q[i] = n01(rng) * 10;
  Eigen::VectorXd x;
  const QpSummary cold = SolveNonNegativeQp(Q, q, &x);
  EXPECT_TRUE(cold.converged);
  Eigen::VectorXd warm = x;
  const QpSummary again = SolveNonNegativeQp(Q, q + 1e-3 * Eigen::VectorXd::Ones(n), &warm);
  EXPECT_TRUE(again.converged);
  EXPECT_LE(again.iterations, cold.iterations);
}

}  // namespace
}  // namespace relight

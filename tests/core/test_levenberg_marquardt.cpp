// JacobianRows and the inexact Levenberg-Marquardt step of the area polishes.
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <vector>

#include "core/levenberg_marquardt.h"

namespace authalic {
namespace {

// A random sparse Jacobian with `per_row` entries a row (no repeated column in a row), as rows
// and as an Eigen matrix.
struct RandomJacobian {
  JacobianRows rows;
  SparseMatrix eigen;
  RandomJacobian(int nrows, int ncols, int per_row, unsigned seed) : rows(ncols, nrows), eigen(nrows, ncols) {
    auto rnd = [&] {
      seed = seed * 1103515245u + 12345u;
      return ((seed >> 8) % 10000) / 5000.0 - 1.0;
    };
    std::vector<Eigen::Triplet<double>> t;
    for (int i = 0; i < nrows; ++i) {
      for (int k = 0; k < per_row; ++k) {
        const int c = static_cast<int>((static_cast<long>(i) * 7 + k * 13) % ncols);
        const double v = rnd();
        rows.add(c, v);
        t.emplace_back(i, c, v);
      }
      rows.end_row();
    }
    eigen.setFromTriplets(t.begin(), t.end());
  }
};

TEST(LevenbergMarquardt, MatrixFreeStepMatchesTheDenseNormalEquations) {
  // With enough iterations the CG step is the exact solution of (Jᵀ J + 1e-3 diag(Jᵀ J)) δ = −Jᵀ r;
  // with 3 it is not yet (the budget is honoured).
  const RandomJacobian J(60, 40, 4, 7);
  VectorXd r(60);
  unsigned seed = 99;
  for (int i = 0; i < 60; ++i) r[i] = ((seed = seed * 1103515245u + 12345u) >> 8) % 10000 / 5000.0 - 1.0;
  const Eigen::MatrixXd Jd(J.eigen);
  Eigen::MatrixXd N = Jd.transpose() * Jd;
  N.diagonal() *= 1.0 + 1e-3;
  const VectorXd exact = N.ldlt().solve(-Jd.transpose() * r);
  const VectorXd step = levenberg_marquardt_step(J.rows, r, 500);
  EXPECT_LT((step - exact).norm() / exact.norm(), 1e-3);
  const VectorXd short_step = levenberg_marquardt_step(J.rows, r, 3);
  EXPECT_GT((short_step - exact).norm() / exact.norm(), 1e-3);
  // A zero residual asks for no move.
  EXPECT_EQ(levenberg_marquardt_step(J.rows, VectorXd::Zero(60), 50).norm(), 0.0);
}

TEST(LevenbergMarquardt, RowProductsAgreeWithEigenAndSplitRowsGiveTheBitsOfOneThread) {
  // 120,000 rows: above the size where Jᵀ (J x) runs as two halves on two threads.
  const RandomJacobian J(120000, 70000, 6, 3);
  VectorXd x(70000), q(120000);
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] = std::sin(0.37 * static_cast<double>(i));
  for (Eigen::Index i = 0; i < q.size(); ++i) q[i] = std::cos(0.11 * static_cast<double>(i));
  EXPECT_LT((J.rows.transpose_times(q) - J.eigen.transpose() * q).norm(), 1e-12 * (J.eigen.transpose() * q).norm());
  const VectorXd normal = J.eigen.transpose() * (J.eigen * x);
  const VectorXd diagonal = J.eigen.cwiseAbs2().transpose() * VectorXd::Ones(J.eigen.rows());
  EXPECT_LT((J.rows.normal_diagonal() - diagonal).norm(), 1e-12 * diagonal.norm());
  const int threads = omp_get_max_threads();
  VectorXd one, two;
  omp_set_num_threads(1);
  J.rows.normal_times(x, one);
  const VectorXd step_one = levenberg_marquardt_step(J.rows, q, 20);
  omp_set_num_threads(2);
  J.rows.normal_times(x, two);
  const VectorXd step_two = levenberg_marquardt_step(J.rows, q, 20);
  omp_set_num_threads(threads);
  EXPECT_LT((one - normal).norm(), 1e-12 * normal.norm());
  EXPECT_EQ(one, two);
  EXPECT_EQ(step_one, step_two);
}

}  // namespace
}  // namespace authalic

// DCT Neumann Poisson solver (core/poisson_dct): transforms against their definition, exact
// solves of cosine modes, convergence to a continuous solution, and the Neumann gradient.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/poisson_dct.h"

using namespace authalic;

namespace {

MatrixXd random_matrix(int rows, int cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  MatrixXd m(rows, cols);
  for (int c = 0; c < cols; ++c)
    for (int r = 0; r < rows; ++r) m(r, c) = u(rng);
  return m;
}

// DCT-II straight from its definition.
MatrixXd dct_by_definition(const MatrixXd& x) {
  const int n = static_cast<int>(x.rows());
  MatrixXd X = MatrixXd::Zero(n, x.cols());
  for (int c = 0; c < x.cols(); ++c)
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j) X(k, c) += x(j, c) * std::cos(M_PI * k * (2.0 * j + 1.0) / (2.0 * n));
  return X;
}

// 5-point Neumann Laplacian applied to a cell-centred field (ghost cells mirror the walls).
MatrixXd apply_laplacian(const MatrixXd& g, double hx, double hy) {
  const int ny = static_cast<int>(g.rows()), nx = static_cast<int>(g.cols());
  MatrixXd out(ny, nx);
  for (int c = 0; c < nx; ++c)
    for (int r = 0; r < ny; ++r) {
      const double left = g(r, c > 0 ? c - 1 : c), right = g(r, c + 1 < nx ? c + 1 : c);
      const double down = g(r > 0 ? r - 1 : r, c), up = g(r + 1 < ny ? r + 1 : r, c);
      out(r, c) = (left - 2 * g(r, c) + right) / (hx * hx) + (down - 2 * g(r, c) + up) / (hy * hy);
    }
  return out;
}

}  // namespace

TEST(PoissonDct, FftTransformMatchesDefinition) {
  for (int n : {4, 8, 64, 256}) {
    const MatrixXd x = random_matrix(n, 5, 1u + n);  // odd column count exercises the unpaired column
    MatrixXd X = x;
    dct2_columns(X);
    EXPECT_LT((X - dct_by_definition(x)).cwiseAbs().maxCoeff(), 1e-10 * n) << "n = " << n;
    idct2_columns(X);
    EXPECT_LT((X - x).cwiseAbs().maxCoeff(), 1e-12 * n) << "round trip, n = " << n;
  }
}

TEST(PoissonDct, MatrixPathForOtherLengthsMatchesDefinition) {
  for (int n : {1, 2, 3, 12, 30}) {
    const MatrixXd x = random_matrix(n, 4, 7u + n);
    MatrixXd X = x;
    dct2_columns(X);
    EXPECT_LT((X - dct_by_definition(x)).cwiseAbs().maxCoeff(), 1e-12 * n + 1e-14) << "n = " << n;
    idct2_columns(X);
    EXPECT_LT((X - x).cwiseAbs().maxCoeff(), 1e-12) << "round trip, n = " << n;
  }
}

TEST(PoissonDct, SolvesDiscreteCosineModeExactly) {
  // A cosine mode is an eigenvector of the discrete Neumann Laplacian: f = λ g must return g.
  const int nx = 64, ny = 32;
  const double hx = 2.0 / nx, hy = 1.0 / ny;  // the 2 x 1 rectangle
  const int k = 3, l = 2;
  MatrixXd g(ny, nx);
  for (int c = 0; c < nx; ++c)
    for (int r = 0; r < ny; ++r) g(r, c) = std::cos(M_PI * k * (c + 0.5) / nx) * std::cos(M_PI * l * (r + 0.5) / ny);
  const double lambda = (2 * std::cos(M_PI * k / nx) - 2) / (hx * hx) + (2 * std::cos(M_PI * l / ny) - 2) / (hy * hy);
  NeumannPoissonGrid solver(nx, ny, hx, hy);
  const MatrixXd sol = solver.solve(lambda * g);
  EXPECT_LT((sol - g).cwiseAbs().maxCoeff(), 1e-11);
}

TEST(PoissonDct, SolutionSatisfiesTheDiscreteEquationForAnyRightHandSide) {
  for (auto [nx, ny] : {std::pair{32, 32}, std::pair{24, 40}}) {  // FFT and cosine-matrix paths
    const double hx = 1.0 / nx, hy = 1.3 / ny;
    const MatrixXd f = random_matrix(ny, nx, 11u + nx);
    NeumannPoissonGrid solver(nx, ny, hx, hy);
    const MatrixXd g = solver.solve(f);
    const MatrixXd expected = f.array() - f.mean();
    EXPECT_LT((apply_laplacian(g, hx, hy) - expected).cwiseAbs().maxCoeff(), 1e-8) << nx << "x" << ny;
    EXPECT_NEAR(g.mean(), 0.0, 1e-12);
  }
}

TEST(PoissonDct, ConvergesToTheContinuousNeumannSolution) {
  // g = cos(πx) cos(2πy) on the unit square: Δg = −5π² g, ∂g/∂n = 0 on the walls. Second-order
  // accurate: the error must drop about 4x when the grid is refined 2x.
  double previous = 0;
  for (int n : {32, 64, 128}) {
    const double h = 1.0 / n;
    MatrixXd g(n, n), f(n, n);
    for (int c = 0; c < n; ++c)
      for (int r = 0; r < n; ++r) {
        const double x = (c + 0.5) * h, y = (r + 0.5) * h;
        g(r, c) = std::cos(M_PI * x) * std::cos(2 * M_PI * y);
        f(r, c) = -5 * M_PI * M_PI * g(r, c);
      }
    NeumannPoissonGrid solver(n, n, h, h);
    const double err = (solver.solve(f) - g).cwiseAbs().maxCoeff();
    EXPECT_LT(err, 4.0 * h * h);  // measured 2.8 h^2
    if (previous > 0) {
      EXPECT_NEAR(previous / err, 4.0, 0.3) << "n = " << n;
    }
    previous = err;
  }
}

TEST(PoissonDct, SmoothingKeepsTheMeanAndDampsHighModes) {
  const int n = 64;
  const double h = 1.0 / n;
  MatrixXd f(n, n);
  for (int c = 0; c < n; ++c)
    for (int r = 0; r < n; ++r) f(r, c) = 1.0 + std::cos(M_PI * 40 * (c + 0.5) / n) + 0.5 * std::cos(M_PI * 1 * (r + 0.5) / n);
  NeumannPoissonGrid solver(n, n, h, h);
  const double sigma = 1.5 * h;
  const MatrixXd s = solver.smooth(f, sigma);
  EXPECT_NEAR(s.mean(), f.mean(), 1e-12);
  // Mode 40 in x is multiplied by exp(−σ² ω² / 2), ω = 40π; mode 1 in y is almost untouched.
  const double damp40 = std::exp(-0.5 * sigma * sigma * std::pow(40 * M_PI, 2));
  const double damp1 = std::exp(-0.5 * sigma * sigma * std::pow(M_PI, 2));
  for (int c = 0; c < n; ++c)
    for (int r = 0; r < n; ++r) {
      const double expected = 1.0 + damp40 * std::cos(M_PI * 40 * (c + 0.5) / n) + 0.5 * damp1 * std::cos(M_PI * (r + 0.5) / n);
      ASSERT_NEAR(s(r, c), expected, 1e-12);
    }
  // Sigma 0 is the identity.
  EXPECT_LT((solver.smooth(f, 0.0) - f).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(PoissonDct, StaggeredGradientHasZeroWallFluxAndItsDivergenceIsTheRightHandSide) {
  const int nx = 16, ny = 8;
  const double hx = 1.0 / nx, hy = 0.5 / ny;
  const MatrixXd f = random_matrix(ny, nx, 3);
  NeumannPoissonGrid solver(nx, ny, hx, hy);
  const MatrixXd g = solver.solve(f);
  MatrixXd gx, gy;
  staggered_gradient(g, hx, hy, &gx, &gy);
  ASSERT_EQ(gx.rows(), ny);
  ASSERT_EQ(gx.cols(), nx + 1);
  ASSERT_EQ(gy.rows(), ny + 1);
  ASSERT_EQ(gy.cols(), nx);
  EXPECT_EQ(gx.col(0).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(gx.col(nx).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(gy.row(0).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(gy.row(ny).cwiseAbs().maxCoeff(), 0.0);
  double worst = 0;
  for (int c = 0; c < nx; ++c)
    for (int r = 0; r < ny; ++r) {
      const double div = (gx(r, c + 1) - gx(r, c)) / hx + (gy(r + 1, c) - gy(r, c)) / hy;
      worst = std::max(worst, std::abs(div - (f(r, c) - f.mean())));
    }
  EXPECT_LT(worst, 1e-9);
}

TEST(PoissonDct, RejectsMismatchedField) {
  NeumannPoissonGrid solver(8, 8, 0.125, 0.125);
  EXPECT_THROW(solver.solve(MatrixXd::Zero(4, 8)), std::invalid_argument);
}

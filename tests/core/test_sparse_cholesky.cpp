// SpdSolver (one analysis reused across systems of one pattern, re-analysed when the pattern
// changes) and the matrix-free Levenberg-Marquardt step of the polishes: known answers.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <future>
#include <thread>
#include <vector>

#include "common/hard_meshes.h"
#include "core/sparse_cholesky.h"

using namespace authalic;

namespace {

// 1D Dirichlet Laplacian scaled by `s` plus a diagonal shift: SPD, n unknowns.
SparseMatrix path_laplacian(int n, double s, double shift) {
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2 * s + shift);
    if (i + 1 < n) t.emplace_back(i, i + 1, -s), t.emplace_back(i + 1, i, -s);
  }
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

double residual(const SparseMatrix& A, const MatrixXd& x, const MatrixXd& b) { return (A * x - b).norm() / b.norm(); }

// 2D grid Laplacian (n x n unknowns, 5-point) plus a diagonal shift, with irregular weights so
// that the ordering changes the rounding of the solution.
SparseMatrix grid_laplacian(int n, double phase = 0) {
  std::vector<Eigen::Triplet<double>> t;
  auto id = [n](int i, int j) { return j * n + i; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      double diag = 1e-3;
      for (const auto& [di, dj] : {std::pair{1, 0}, std::pair{0, 1}}) {
        if (i + di >= n || j + dj >= n) continue;
        const double w = 1.0 + 0.5 * std::sin(0.37 * i + 0.91 * j + di + phase);
        t.emplace_back(id(i, j), id(i + di, j + dj), -w);
        t.emplace_back(id(i + di, j + dj), id(i, j), -w);
        t.emplace_back(id(i + di, j + dj), id(i + di, j + dj), w);
        diag += w;
      }
      t.emplace_back(id(i, j), id(i, j), diag);
    }
  SparseMatrix A(n * n, n * n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

}  // namespace

TEST(SpdSolver, RefactorReusesTheAnalysisAndSolvesTheNewValues) {
  // Eigen's LDLT up to 20k unknowns, CHOLMOD's supernodal factorisation (through the BLAS) above,
  // ordered by AMD up to 250k and by METIS beyond: all three exercised.
  for (int n : {500, 120000, 260000}) {
    const MatrixXd b = MatrixXd::Ones(n, 2);
    SpdSolver solver;
    ASSERT_TRUE(solver.refactor(path_laplacian(n, 1.0, 0.1)));  // first call computes
    EXPECT_LT(residual(path_laplacian(n, 1.0, 0.1), solver.solve(b), b), 1e-10) << n;
    const SparseMatrix A2 = path_laplacian(n, 3.0, 0.5);  // same pattern, other values
    ASSERT_TRUE(solver.refactor(A2));
    EXPECT_LT(residual(A2, solver.solve(b), b), 1e-10) << n;
  }
}

TEST(SpdSolver, RefactorWithAnotherPatternReanalyses) {
  SpdSolver solver(path_laplacian(300, 1.0, 0.1));
  // Another size, then the same size with an extra coupling: both must be solved exactly,
  // which a stale ordering or symbolic factor would not do.
  const SparseMatrix A = path_laplacian(400, 2.0, 0.2);
  ASSERT_TRUE(solver.refactor(A));
  const MatrixXd b = MatrixXd::Ones(400, 1);
  EXPECT_LT(residual(A, solver.solve(b), b), 1e-10);
  SparseMatrix B = path_laplacian(400, 2.0, 0.2);
  B.coeffRef(0, 399) = -0.5;
  B.coeffRef(399, 0) = -0.5;
  ASSERT_TRUE(solver.refactor(B));
  EXPECT_LT(residual(B, solver.solve(b), b), 1e-10);
}

TEST(SpdSolver, PreconditionedSolveReachesTheDirectSolution) {
  // CG preconditioned with the factorisation of other weights of the same grid (the stretch-energy
  // steps after the first): it converges to A's own direct solution, counts its iterations, and
  // reports a budget too small to reach the tolerance.
  const SparseMatrix A = grid_laplacian(60), nearby = grid_laplacian(60, 0.4);
  MatrixXd b(A.rows(), 2);
  for (Eigen::Index i = 0; i < b.rows(); ++i) b(i, 0) = std::sin(0.01 * i), b(i, 1) = 1.0;
  const MatrixXd direct = SpdSolver(A).solve(b);
  const SpdSolver preconditioner(nearby);
  MatrixXd x = MatrixXd::Zero(A.rows(), 2);
  int iterations = 0;
  ASSERT_TRUE(preconditioner.solve_preconditioned(A, b, x, 1e-12, 100, &iterations));
  EXPECT_LT((x - direct).norm() / direct.norm(), 1e-10);
  EXPECT_GT(iterations, 2);   // the weights differ by up to 2x: not a solve in one step
  EXPECT_LT(iterations, 60);  // but far fewer steps than unpreconditioned CG on 3600 unknowns
  MatrixXd y = MatrixXd::Zero(A.rows(), 2);
  EXPECT_FALSE(preconditioner.solve_preconditioned(A, b, y, 1e-12, 2));
  // The tolerance is relative to the starting guess's residual: started at the solution it stays.
  MatrixXd z = direct;
  ASSERT_TRUE(preconditioner.solve_preconditioned(A, b, z, 1e-3, 20));
  EXPECT_LT((z - direct).norm() / direct.norm(), 1e-12);
}

TEST(SpdSolver, TwoSolversAtOnceGiveTheBitsOfOne) {
  // `run` maps both hemispheres side by side. Two hazards of the libraries under CHOLMOD, each of
  // which made these bits change from run to run: METIS's random generator is process-global
  // (two analyses at once drew from one sequence: other orderings, and maps differing by up to
  // 0.05 mm on fs741), and the serial OpenBLAS shares its work buffers between callers (two
  // supernodal solves at once on one factor gave other numbers than the same solves in turn).
  for (int n : {160, 510}) {  // 25,600 unknowns (AMD) and 260,100 (METIS): CHOLMOD, supernodal
    const SparseMatrix A = grid_laplacian(n);
    MatrixXd b(A.rows(), 2);
    for (Eigen::Index i = 0; i < b.rows(); ++i) b(i, 0) = std::sin(0.37 * i), b(i, 1) = 1.0 + 0.1 * std::cos(0.11 * i);
    const MatrixXd alone = SpdSolver(A).solve(b);
    ASSERT_LT(residual(A, alone, b), 1e-10);
    const SpdSolver shared(A);
    const int rounds = n > 200 ? 1 : 3;
    for (int round = 0; round < rounds; ++round) {
      MatrixXd x[2], y[2];
      // Each thread: its own analysis and factorisation, then many solves with the shared factor.
      auto work = [&](int k) {
        x[k] = SpdSolver(A).solve(b);
        for (int rep = 0; rep < 20; ++rep) y[k] = shared.solve(b);
      };
      std::thread other(work, 1);
      work(0);
      other.join();
      for (int k = 0; k < 2; ++k) {
        EXPECT_EQ((x[k] - alone).cwiseAbs().maxCoeff(), 0.0) << "n " << n << ", round " << round << ", thread " << k;
        EXPECT_EQ((y[k] - alone).cwiseAbs().maxCoeff(), 0.0) << "n " << n << ", round " << round << ", thread " << k;
      }
    }
  }
}

TEST(SpdSolver, MeshVertexOrderingOrdersTheSystemTheSameAheadOrAtTheAnalysis) {
  // The square map orders its systems by METIS on the region's mesh (mesh_vertex_ordering), ahead
  // of the analysis when it has a second thread: the unknowns are the n x n interior vertices of a
  // triangulated (n + 2) x (n + 2) grid, its border fixed (no row).
  const int n = 510, m = n + 2;  // 260,100 unknowns: CHOLMOD with METIS
  const SparseMatrix A = grid_laplacian(n);
  const MatrixXi F = test::square_grid(m - 1).F;  // vertex j m + i at column i, row j
  std::vector<int> row_of_vertex(static_cast<std::size_t>(m * m), -1);
  for (int j = 1; j <= n; ++j)
    for (int i = 1; i <= n; ++i) row_of_vertex[static_cast<std::size_t>(j * m + i)] = (j - 1) * n + (i - 1);

  std::vector<int> order = mesh_vertex_ordering(F, m * m);
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (int v = 0; v < m * m; ++v) ASSERT_EQ(sorted[static_cast<std::size_t>(v)], v) << "not a permutation of the vertices";

  const MatrixXd b = MatrixXd::Ones(A.rows(), 2);
  const MatrixXd by_system = SpdSolver(A).solve(b);
  MatrixXd x[2];
  for (auto policy : {std::launch::deferred, std::launch::async}) {
    SpdSolver solver;
    solver.order_by_vertices(std::async(policy, mesh_vertex_ordering, F, m * m).share());
    ASSERT_TRUE(solver.compute(A, &row_of_vertex));
    x[policy == std::launch::async] = solver.solve(b);
  }
  EXPECT_LT(residual(A, x[0], b), 1e-10);
  EXPECT_EQ((x[0] - x[1]).cwiseAbs().maxCoeff(), 0.0) << "computed ahead, the ordering gave other bits";
  // The mesh's ordering was used: the rounding differs from METIS on the system itself.
  EXPECT_GT((x[0] - by_system).cwiseAbs().maxCoeff(), 0.0);
}

// Optimal-transport refinement (core/optimal_transport): the Leray projection's known answers and
// the refinement undoing a known area-preserving swirl (the identity is the optimal map between
// two uniform measures, so the refinement must bring the transport cost back to about 0).
#include <gtest/gtest.h>

#include <cmath>

#include "common/hard_meshes.h"
#include "core/conformal_map.h"
#include "core/optimal_transport.h"

using namespace authalic;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Cell averages (midpoint rule) of a field given as a function, on an n x n grid of the unit square.
template <class Field>
void sample_cells(int n, const Field& field, MatrixXd* fx, MatrixXd* fy) {
  fx->resize(n, n);
  fy->resize(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const Eigen::Vector2d f = field((c + 0.5) / n, (r + 0.5) / n);
      (*fx)(r, c) = f.x();
      (*fy)(r, c) = f.y();
    }
}

// The swirl J∇ψ with ψ = A sin²(πx) sin²(πy): divergence-free, zero with its gradient on the walls.
Eigen::Vector2d swirl(double x, double y, double amplitude) {
  const double sx = std::sin(kPi * x), sy = std::sin(kPi * y);
  const double psi_x = amplitude * 2 * kPi * sx * std::cos(kPi * x) * sy * sy;
  const double psi_y = amplitude * 2 * kPi * sy * std::cos(kPi * y) * sx * sx;
  return {-psi_y, psi_x};
}

double max_abs_divergence(const MatrixXd& wx, const MatrixXd& wy, double h) {
  double worst = 0;
  for (Eigen::Index r = 0; r < wy.rows() - 1; ++r)
    for (Eigen::Index c = 0; c < wx.cols() - 1; ++c)
      worst = std::max(worst, std::abs((wx(r, c + 1) - wx(r, c)) / h + (wy(r + 1, c) - wy(r, c)) / h));
  return worst;
}

}  // namespace

TEST(OptimalTransport, LerayProjectionKeepsADivergenceFreeFieldAndRemovesAGradient) {
  const int n = 64;
  const double h = 1.0 / n;
  MatrixXd fx, fy, wx, wy;
  // A gradient with zero normal component on the walls, ∇ cos(πx) cos(πy): projected to ~0.
  sample_cells(n, [](double x, double y) {
    return Eigen::Vector2d(-kPi * std::sin(kPi * x) * std::cos(kPi * y), -kPi * std::cos(kPi * x) * std::sin(kPi * y));
  }, &fx, &fy);
  leray_projection(fx, fy, h, h, &wx, &wy);
  EXPECT_LT(wx.cwiseAbs().maxCoeff(), 0.01 * kPi);
  EXPECT_LT(wy.cwiseAbs().maxCoeff(), 0.01 * kPi);
  // The swirl is its own projection (to the discretisation error), and the result is divergence-free.
  sample_cells(n, [](double x, double y) { return swirl(x, y, 1.0); }, &fx, &fy);
  leray_projection(fx, fy, h, h, &wx, &wy);
  const double peak = fx.cwiseAbs().maxCoeff();
  for (int r = 0; r < n; ++r)
    for (int c = 1; c < n; ++c) EXPECT_NEAR(wx(r, c), swirl(c * h, (r + 0.5) * h, 1.0).x(), 0.01 * peak);
  EXPECT_LT(max_abs_divergence(wx, wy, h), 1e-9 * peak / h);
  // The walls carry no flux.
  EXPECT_EQ(wx.col(0).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(wy.row(n).cwiseAbs().maxCoeff(), 0.0);
}

TEST(OptimalTransport, RefinementUndoesAnAreaPreservingSwirl) {
  // Uniform measure on both sides: the optimal map is the identity. Start from the identity moved
  // by a swirl (area-preserving, boundary fixed); the refinement must remove it.
  const TriMesh m = test::square_grid(40);
  const MatrixXd X = m.V.leftCols(2);
  MatrixXd Y = X;
  const int steps = 50;
  for (Eigen::Index v = 0; v < Y.rows(); ++v)
    for (int k = 0; k < steps; ++k) {  // RK2 over unit time
      const Eigen::Vector2d p = Y.row(v).transpose();
      const Eigen::Vector2d mid = p + 0.5 / steps * swirl(p.x(), p.y(), 0.02);
      Y.row(v) = (p + 1.0 / steps * swirl(mid.x(), mid.y(), 0.02)).transpose();
    }
  const VectorXi sides = test::square_sides(m.V);
  const VectorXd measure = face_areas(m.V, m.F);
  ASSERT_EQ(count_flipped(Y, m.F), 0);
  const double before = transport_cost(X, Y, m.F, measure);
  ASSERT_GT(before, 1e-5);

  const OptimalTransportResult r = optimal_transport_refine(X, Y, m.F, sides, 1.0, measure);
  EXPECT_NEAR(r.report.initial_cost, before, 1e-15);
  EXPECT_LT(r.report.final_cost, 0.01 * before) << r.report.stop_reason << " after " << r.report.iterations;
  EXPECT_NEAR(transport_cost(X, r.UV, m.F, measure), r.report.final_cost, 1e-15);
  EXPECT_EQ(count_flipped(r.UV, m.F), 0);
  // Area kept: each step follows a divergence-free field (the swirl itself left 2 % at most).
  const VectorXd a = signed_face_areas_2d(r.UV, m.F);
  EXPECT_LT((a / measure.mean()).array().log().abs().maxCoeff(), 0.05);
  // Boundary vertices stayed on their sides.
  for (Eigen::Index v = 0; v < X.rows(); ++v) {
    if (sides[v] & (kSideLeft | kSideRight)) {
      EXPECT_EQ(r.UV(v, 0), X(v, 0));
    }
    if (sides[v] & (kSideBottom | kSideTop)) {
      EXPECT_EQ(r.UV(v, 1), X(v, 1));
    }
  }
}

TEST(OptimalTransport, AnOptimalMapIsLeftAlone) {
  const TriMesh m = test::square_grid(20);
  const MatrixXd X = m.V.leftCols(2);
  const OptimalTransportResult r =
      optimal_transport_refine(X, X, m.F, test::square_sides(m.V), 1.0, face_areas(m.V, m.F));
  EXPECT_EQ(r.report.final_cost, 0.0);
  EXPECT_EQ(r.report.iterations, 0);
  EXPECT_TRUE(r.UV == X);
}

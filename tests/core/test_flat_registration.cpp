// Incompressible demons on the flat square (core/flat_registration.h): a known divergence-free
// swirl of a subject's map is undone, area is kept, nothing folds, and identical maps stay put.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>

#include "core/conformal_map.h"
#include "core/error.h"
#include "core/flat_registration.h"
#include "core/poisson_dct.h"

using namespace authalic;

namespace {

// A regular triangulation of the unit square, n x n vertices, counter-clockwise faces.
void square_grid(int n, MatrixXd* UV, MatrixXi* F) {
  UV->resize(n * n, 2);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) UV->row(r * n + c) << c / (n - 1.0), r / (n - 1.0);
  F->resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int r = 0; r + 1 < n; ++r)
    for (int c = 0; c + 1 < n; ++c) {
      const int a = r * n + c, b = a + 1, d = a + n, e = d + 1;
      F->row(f++) << a, b, e;
      F->row(f++) << a, e, d;
    }
}

// The "anatomy": a smooth pattern with structure at about a fifth of the side.
double feature(double x, double y) {
  return std::sin(2 * M_PI * x) * std::sin(2 * M_PI * y) + 0.6 * std::cos(3 * M_PI * x + 1) * std::cos(M_PI * y);
}

// The flow of the stream function ψ = a sin²(πx) sin²(πy) (divergence-free, no flux through the
// sides) for unit time, by 200 RK4 steps: a swirl about the centre.
MatrixXd swirl(const MatrixXd& UV, double a) {
  auto vel = [a](double, double x, double y, double* vx, double* vy) {
    const double sx = std::sin(M_PI * x), sy = std::sin(M_PI * y);
    *vx = a * sx * sx * 2 * M_PI * sy * std::cos(M_PI * y);    // ∂ψ/∂y
    *vy = -a * sy * sy * 2 * M_PI * sx * std::cos(M_PI * x);   // −∂ψ/∂x
  };
  MatrixXd out = UV;
  for (Eigen::Index i = 0; i < UV.rows(); ++i) {
    double x = UV(i, 0), y = UV(i, 1);
    for (int s = 0; s < 200; ++s) rk4_step(vel, 0.0, 1.0 / 200, x, y);
    out(i, 0) = x;
    out(i, 1) = y;
  }
  return out;
}

double face_area(const MatrixXd& UV, const MatrixXi& F, Eigen::Index f) {
  const Eigen::Vector2d a = UV.row(F(f, 0)), b = UV.row(F(f, 1)), c = UV.row(F(f, 2));
  return 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
}

double mean_abs_ln_area_ratio(const MatrixXd& UV, const MatrixXd& ref, const MatrixXi& F) {
  double s = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) s += std::abs(std::log(face_area(UV, F, f) / face_area(ref, F, f)));
  return s / static_cast<double>(F.rows());
}

double mean_distance(const MatrixXd& A, const MatrixXd& B) { return (A - B).rowwise().norm().mean(); }

}  // namespace

TEST(FlatRegistration, UndoesAKnownDivergenceFreeSwirlKeepingAreaAndOrientation) {
  MatrixXd atlas;
  MatrixXi F;
  square_grid(61, &atlas, &F);
  VectorXd f(atlas.rows());
  for (Eigen::Index i = 0; i < atlas.rows(); ++i) f[i] = feature(atlas(i, 0), atlas(i, 1));
  // The subject: the same anatomy (each vertex keeps its feature) moved by the swirl.
  const MatrixXd subject = swirl(atlas, 0.02);
  const double before = mean_distance(subject, atlas);
  ASSERT_GT(before, 0.02);  // about 0.7 of a 32 x 32 element on average

  FlatRegistrationReport rep;
  const MatrixXd X = register_flat_map(subject, F, f, atlas, F, f, 1.0, {}, &rep);
  const double after = mean_distance(X, atlas);
  std::cout << "[ swirl: mean distance to the truth " << before << " -> " << after << ", correlation " << rep.correlation_before
            << " -> " << rep.correlation_after << ", " << rep.iterations << " iterations; |ln area ratio| mean "
            << mean_abs_ln_area_ratio(X, subject, F) << " ]\n";
  EXPECT_LT(after, 0.25 * before);
  EXPECT_GT(rep.correlation_after, rep.correlation_before);
  EXPECT_GT(rep.correlation_after, 0.99);
  // Divergence-free steps keep each triangle's area (up to the advection's discretisation error)
  // and fold nothing; the boundary stays on the square.
  EXPECT_LT(mean_abs_ln_area_ratio(X, subject, F), 0.01);
  EXPECT_EQ(count_flipped(X, F), 0);
  EXPECT_GE(X.minCoeff(), 0.0);
  EXPECT_LE(X.maxCoeff(), 1.0);
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    if (subject(i, 0) == 0.0 || subject(i, 0) == 1.0) {
      EXPECT_EQ(X(i, 0), subject(i, 0));  // sides: slide only
    }
    if (subject(i, 1) == 0.0 || subject(i, 1) == 1.0) {
      EXPECT_EQ(X(i, 1), subject(i, 1));
    }
  }
}

TEST(FlatRegistration, IdenticalMapsDoNotMove) {
  MatrixXd UV;
  MatrixXi F;
  square_grid(41, &UV, &F);
  VectorXd f(UV.rows());
  for (Eigen::Index i = 0; i < UV.rows(); ++i) f[i] = feature(UV(i, 0), UV(i, 1));
  FlatRegistrationReport rep;
  const MatrixXd X = register_flat_map(UV, F, f, UV, F, f, 1.0, {}, &rep);
  EXPECT_LT(rep.max_move, 1e-12);
  EXPECT_LT((X - UV).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(rep.correlation_before, 1.0, 1e-12);
}

TEST(FlatRegistration, RefusesAConstantFeatureAndMismatchedSizes) {
  MatrixXd UV;
  MatrixXi F;
  square_grid(11, &UV, &F);
  const VectorXd constant = VectorXd::Ones(UV.rows());
  try {
    register_flat_map(UV, F, constant, UV, F, constant, 1.0);
    FAIL() << "a constant feature was accepted";
  } catch (const ProcessingError& e) {
    EXPECT_NE(std::string(e.what()).find("constant"), std::string::npos) << e.what();
  }
  EXPECT_THROW(register_flat_map(UV, F, VectorXd::Ones(3), UV, F, constant, 1.0), ProcessingError);
}

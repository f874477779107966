// The stretch-energy start with its boundary slid by a Moser pass, the per-face polish (plane and
// sphere) and the sphere through the square map:
// the two steps that made native-resolution surfaces authalic (issue 12, fs741's 96 % mask and
// pial surface). Known answers on small meshes; the real-mesh numbers are in bench/bench_real.sh.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "common/hard_meshes.h"
#include "core/authalic_flow.h"
#include "core/conformal_map.h"
#include "core/error.h"
#include "core/metrics.h"
#include "core/sphere_flow.h"
#include "core/sphere_from_square.h"
#include "core/sphere_map.h"
#include "core/square_map.h"
#include "core/stretch_energy.h"

using namespace authalic;
using namespace authalic::test;

namespace {

// A planar 4 x 1 rectangle as an (4n) x n grid. Its authalic map onto the unit square is the
// affine squeeze (x / 4, y); the arc-length boundary instead puts the rectangle's corners in the
// middle of the square's sides, so with the boundary held no map is close to authalic near them.
TriMesh long_rectangle(int n) {
  const int cols = 4 * n + 1;
  MatrixXd V(cols * (n + 1), 3);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i < cols; ++i) V.row(j * cols + i) << 4.0 * i / (4 * n), double(j) / n, 0.0;
  MatrixXi F(2 * 4 * n * n, 3);
  int f = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < 4 * n; ++i) {
      const int a = j * cols + i, b = a + 1, c = a + cols, d = c + 1;
      F.row(f++) << a, b, d;
      F.row(f++) << a, d, c;
    }
  TriMesh m;
  m.V = V;
  m.F = F;
  return m;
}

double log_stretch_after(const TriMesh& m, bool slide) {
  SquareMapOptions o;
  o.anatomical_anchor = false;
  o.orient_outward = false;
  o.stretch.moser_boundary = slide;
  o.stretch.max_iterations = 20;
  o.flow.grid.max_passes = 0;
  o.flow.polish.enabled = false;
  return square_map(m.V, m.F, o).stretch.final_log_stretch;
}

}  // namespace

TEST(StretchEnergy, MoserBoundarySlideRemovesTheArcLengthBoundaryError) {
  const TriMesh m = long_rectangle(12);
  const double held = log_stretch_after(m, false), slid = log_stretch_after(m, true);
  // Held: the corners' error stays (measured 0.27); slid: most of it goes (measured 0.073).
  EXPECT_GT(held, 0.1);
  EXPECT_LT(slid, 0.5 * held);
}

TEST(StretchEnergy, InexactStepsEndWhereExactStepsDo) {
  // Steps after the first by preconditioned CG (the default above 100k unknowns, forced here on
  // 1,100): the same error within a few per cent, and an embedding.
  const TriMesh m = long_rectangle(12);
  auto run = [&](bool inexact) {
    SquareMapOptions o;
    o.anatomical_anchor = false;
    o.orient_outward = false;
    o.stretch.max_iterations = 20;
    o.stretch.inexact_min_unknowns = 0;
    if (!inexact) o.stretch.inexact_tolerance = 0;
    o.flow.grid.max_passes = 0;
    o.flow.polish.enabled = false;
    return square_map(m.V, m.F, o);
  };
  const SquareMapResult exact = run(false), inexact = run(true);
  EXPECT_EQ(count_flipped(inexact.UV, inexact.F), 0);
  EXPECT_GT(inexact.stretch.iterations, 2);
  EXPECT_NEAR(inexact.stretch.final_log_stretch, exact.stretch.final_log_stretch, 0.05 * exact.stretch.final_log_stretch);
  EXPECT_GT((inexact.UV - exact.UV).cwiseAbs().maxCoeff(), 0.0);  // the inexact path was taken
}

TEST(StretchEnergy, SlidBoundaryStaysOnItsSidesInOrder) {
  const TriMesh m = long_rectangle(8);
  SquareMapOptions o;
  o.anatomical_anchor = false;
  o.orient_outward = false;
  o.flow.grid.max_passes = 0;
  o.flow.polish.enabled = false;
  const SquareMapResult r = square_map(m.V, m.F, o);
  EXPECT_EQ(count_flipped(r.UV, r.F), 0);
  for (Eigen::Index v = 0; v < r.UV.rows(); ++v) {
    const int s = r.side_mask[v];
    if (s & kSideLeft) {
      EXPECT_EQ(r.UV(v, 0), 0.0);
    }
    if (s & kSideRight) {
      EXPECT_EQ(r.UV(v, 0), 1.0);
    }
    if (s & kSideBottom) {
      EXPECT_EQ(r.UV(v, 1), 0.0);
    }
    if (s & kSideTop) {
      EXPECT_EQ(r.UV(v, 1), 1.0);
    }
  }
}

TEST(FacePolish, NewtonStepRestoresPerturbedAreas) {
  // Known answer: the regular grid is authalic for its own areas; perturb the interior and take
  // full Gauss-Newton steps on the face areas: the per-face error falls by orders of magnitude.
  const TriMesh g = square_grid(16);
  const VectorXd target = signed_face_areas_2d(g.V.leftCols(2), g.F);
  VectorXi side = VectorXi::Zero(g.num_vertices());
  std::vector<char> free_vertex(g.num_vertices(), 0);
  MatrixXd UV = g.V.leftCols(2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.15 / 16, 0.15 / 16);
  for (int v = 0; v < g.num_vertices(); ++v) {
    const double x = g.V(v, 0), y = g.V(v, 1);
    if (x == 0 || x == 1 || y == 0 || y == 1) {
      side[v] = (y == 0 ? kSideBottom : 0) | (x == 1 ? kSideRight : 0) | (y == 1 ? kSideTop : 0) | (x == 0 ? kSideLeft : 0);
      continue;
    }
    free_vertex[v] = 1;
    UV(v, 0) += u(rng);
    UV(v, 1) += u(rng);
  }
  auto error = [&](const MatrixXd& X) {
    const VectorXd a = signed_face_areas_2d(X, g.F);
    return (a.array() / target.array()).log().abs().mean();
  };
  const double before = error(UV);
  ASSERT_GT(before, 0.05);
  for (int k = 0; k < 3; ++k) UV += face_area_newton_displacement(UV, g.F, target, side, free_vertex, 200);
  EXPECT_EQ(count_flipped(UV, g.F), 0);
  EXPECT_LT(error(UV), 1e-2 * before);
}

TEST(FacePolish, FixedVerticesAndCornersDoNotMove) {
  const TriMesh g = square_grid(6);
  VectorXd target = signed_face_areas_2d(g.V.leftCols(2), g.F);
  target[0] *= 2;  // a face that wants to grow, at the corner (0, 0)
  target *= target.size() / target.sum();
  VectorXi side = VectorXi::Zero(g.num_vertices());
  side[0] = kSideBottom | kSideLeft;  // corner
  side[1] = kSideBottom;
  std::vector<char> free_vertex(g.num_vertices(), 1);
  free_vertex[8] = 0;
  const MatrixXd D = face_area_newton_displacement(g.V.leftCols(2), g.F, target, side, free_vertex);
  EXPECT_EQ(D.row(0).norm(), 0.0);  // the corner
  EXPECT_EQ(D(1, 1), 0.0);          // a bottom-side vertex slides along x only
  EXPECT_NE(D(1, 0), 0.0);
  EXPECT_EQ(D.row(8).norm(), 0.0);  // held by the caller
}

TEST(FacePolish, FarFaceStepsOpenACrushedEarAgainstTheSide) {
  // The ear the grid flow leaves at a side (seed-2 phantom control19 lh, fsaverage5 vertex 1527):
  // an interior vertex pressed against the bottom side and the side vertices beside it bunched,
  // so its faces are products of two small lengths (e^-18 of their target here). On that map the
  // area residual's steps did not open them: where targets compete, (a − T)²/T prices a crushed
  // face at no more than T and trades it for larger faces (faces left at e^-10, element CV
  // 0.0056); the far-face steps now use the log residual √T ln(a/T) (e^-0.76, CV 0.0027). Here the
  // targets are reachable and a known answer checks the log steps reach them.
  const int n = 16;
  const double h = 1.0 / n, eps = 1e-4 * h;
  const TriMesh g = square_grid(n);
  auto id = [&](int i, int j) { return j * (n + 1) + i; };
  ASSERT_NEAR(g.V(id(8, 1), 0), 8 * h, 1e-12);
  VectorXi side = VectorXi::Zero(g.num_vertices());
  for (int v = 0; v < g.num_vertices(); ++v) {
    const double x = g.V(v, 0), y = g.V(v, 1);
    side[v] = (y == 0 ? kSideBottom : 0) | (x == 1 ? kSideRight : 0) | (y == 1 ? kSideTop : 0) | (x == 0 ? kSideLeft : 0);
  }
  MatrixXd UV = g.V.leftCols(2);
  UV(id(8, 1), 1) = eps;
  UV(id(7, 0), 0) = 8 * h - eps;
  UV(id(9, 0), 0) = 8 * h + eps;
  ASSERT_EQ(count_flipped(UV, g.F), 0);
  const VectorXd target = signed_face_areas_2d(g.V.leftCols(2), g.F);
  auto worst = [&](const MatrixXd& X) {
    return (signed_face_areas_2d(X, g.F).array() / target.array()).log().abs().maxCoeff();
  };
  ASSERT_GT(worst(UV), 15.0);
  // Gauss-Newton steps of the vertices within two rings, flip-safe, as the far-face polish takes them.
  std::vector<char> free_vertex(g.num_vertices(), 0);
  for (int j = 0; j <= 2; ++j)
    for (int i = 6; i <= 10; ++i) free_vertex[id(i, j)] = 1;
  auto steps = [&](FaceAreaResidual residual) {
    MatrixXd X = UV;
    const VectorXd limit = VectorXd::Constant(g.F.rows(), 0.0);
    for (int k = 0; k < 10; ++k)
      X = local_step_positions(X, g.F, face_area_newton_displacement(X, g.F, target, side, free_vertex, 200, residual), 0.5,
                               limit, [&](Eigen::Index v, double& x, double& y) { constrain_to_rectangle(x, y, side[v], 1.0); });
    return X;
  };
  const MatrixXd by_log = steps(FaceAreaResidual::LogArea);
  EXPECT_EQ(count_flipped(by_log, g.F), 0);
  EXPECT_LT(worst(by_log), 1e-3);  // the targets are reachable here (the grid): the steps reach them
  // Near the targets the residual √T ln(a/T) is the area residual (a − T)/√T to first order, so
  // maps without far faces get the same steps as before: a 1e-3 h perturbation moves both steps alike.
  // Uneven targets (x -> (x + x²)/2: cells 1:3 across), as the residuals' weights then matter.
  MatrixXd uneven = g.V.leftCols(2);
  uneven.col(0) = (uneven.col(0).array() + uneven.col(0).array().square()) / 2;
  const VectorXd uneven_target = signed_face_areas_2d(uneven, g.F);
  MatrixXd near = uneven;
  near(id(8, 1), 1) += 1e-3 * h;
  near(id(5, 5), 0) -= 1e-3 * h;
  std::fill(free_vertex.begin(), free_vertex.end(), 1);
  const MatrixXd d_log = face_area_newton_displacement(near, g.F, uneven_target, side, free_vertex, 200, FaceAreaResidual::LogArea);
  const MatrixXd d_area = face_area_newton_displacement(near, g.F, uneven_target, side, free_vertex, 200, FaceAreaResidual::Area);
  ASSERT_GT(d_area.norm(), 1e-4 * h);
  EXPECT_LT((d_log - d_area).norm(), 1e-2 * d_area.norm());
}

TEST(ConformalMap, ClampedCotangentFallbackIsAnEmbeddingSolvedByCholesky) {
  // A strongly folded patch: its cotangent map folds 128 triangles (negative weights of obtuse
  // 3D triangles); the clamped-cotangent fall-back has positive weights, so with the convex
  // boundary it cannot fold (Tutte/Floater).
  const TriMesh m = folded_patch(30, 0.4, 5);
  RectangleBoundaryMap b;
  b.fallback = HarmonicWeights::ClampedCotangent;
  const ConformalMapResult r = conformal_rectangle_map(m.V, m.F, b);
  EXPECT_EQ(count_flipped(r.UV, r.F), 0);
  EXPECT_GT(r.cotangent_flips, 0);
  EXPECT_EQ(r.weights, HarmonicWeights::ClampedCotangent);
}

TEST(SphereFromSquare, ConcentricMapKnownPointsAndEqualArea) {
  MatrixXd P(5, 2);
  P << 0, 0, 1, 0, 1, 1, 0, 1, -1, -0.5;
  const MatrixXd D = concentric_square_to_disk(P);
  EXPECT_LT((D.row(0)).norm(), 1e-15);
  EXPECT_LT((D.row(1) - Eigen::RowVector2d(1, 0)).norm(), 1e-12);
  EXPECT_LT((D.row(2) - Eigen::RowVector2d(std::sqrt(0.5), std::sqrt(0.5))).norm(), 1e-12);
  EXPECT_LT((D.row(3) - Eigen::RowVector2d(0, 1)).norm(), 1e-12);
  EXPECT_NEAR(D.row(4).norm(), 1.0, 1e-12);  // the square's boundary goes to the circle
  // Area scaled by π/4 everywhere: a fine grid of the square covers the disk's area π.
  const TriMesh g = square_grid(64);
  const MatrixXd Q = 2.0 * g.V.leftCols(2).array() - 1.0;
  const VectorXd a = signed_face_areas_2d(concentric_square_to_disk(Q), g.F);
  EXPECT_GT(a.minCoeff(), 0.0);
  EXPECT_NEAR(a.sum(), M_PI, 2e-3);  // the inscribed polygon of the circle misses a little
  const VectorXd a0 = signed_face_areas_2d(Q, g.F);
  std::vector<double> dev(static_cast<std::size_t>(a.size()));
  for (Eigen::Index f = 0; f < a.size(); ++f) dev[static_cast<std::size_t>(f)] = std::abs(a[f] / a0[f] / (M_PI / 4) - 1);
  std::nth_element(dev.begin(), dev.begin() + dev.size() / 2, dev.end());
  // Straight edges of the grid are bent by the map: a second-order error of a 1/32 triangle.
  EXPECT_LT(dev[dev.size() / 2], 5e-3);
}

TEST(SphereFromSquare, SpherePolishRestoresPerturbedAreas) {
  // Known answer: an icosphere's own chord areas; perturb it tangentially and polish.
  TriMesh s = icosphere(3);
  const VectorXd target = face_areas(s.V, s.F);
  MatrixXd S = s.V;
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 0.01);
  for (Eigen::Index v = 0; v < S.rows(); ++v)
    S.row(v) = (S.row(v) + Eigen::RowVector3d(n(rng), n(rng), n(rng))).normalized();
  ASSERT_EQ(sphere_flipped_faces(S, s.F), 0);
  const double before = map_metrics(s.V, S, s.F, Domain::sphere(), 8).face_ln_area.mean;
  const double after = polish_sphere_face_areas(S, s.F, target, 10, 200);
  EXPECT_EQ(sphere_flipped_faces(S, s.F), 0);
  EXPECT_LT((S.rowwise().norm().array() - 1).abs().maxCoeff(), 1e-12);
  EXPECT_LT(after, 0.1 * before);
}

TEST(SphereFromSquare, NearlyRoundSurfaceCoversTheSphereOnceWithEqualAreas) {
  // An ellipsoid: the cap and the rest are joined on one circle, the sphere is covered once and
  // the map is authalic (element CV at 16 x 8 and per-face error small).
  TriMesh e = icosphere(4);
  e.V.col(0) *= 1.6;
  SphereFromSquareReport rep;
  const MatrixXd S = sphere_from_square_map(e.V, e.F, {}, &rep);
  EXPECT_TRUE(sphere_covers_once(S, e.F));
  EXPECT_NEAR(rep.cap_area_fraction, 0.1, 0.02);
  const MapMetrics m = map_metrics(e.V, S, e.F, Domain::sphere(), 8);
  EXPECT_EQ(m.flips, 0);
  EXPECT_LT(m.element_cv, 0.02);
  EXPECT_LT(m.face_ln_area.mean, 0.02);
}

TEST(SphereFromSquare, CoarseSpherePassDoesNoHarmWhereNothingIsLeft) {
  // The coarse Moser pass on the joined sphere is for element-scale error along the seam of
  // native meshes (fs741 pial: CV 0.0124 -> 0.0083, SphereCli.NativeResolutionPialSurface...).
  // On a smooth 10k-vertex surface the joined map has none left: the pass runs (it is on by
  // default), keeps the sphere covered once without flips, and leaves the element CV at its noise level.
  TriMesh e = icosphere(5);
  for (Eigen::Index v = 0; v < e.V.rows(); ++v) {
    const double x = e.V(v, 0), y = e.V(v, 1), z = e.V(v, 2);
    e.V.row(v) *= 1.0 + 0.25 * std::sin(3 * x) * std::cos(2 * y) + 0.15 * z * z;
  }
  e.V.col(0) *= 1.5;
  SphereFromSquareOptions without;
  without.sphere_flow.max_passes = 0;
  const MatrixXd S0 = sphere_from_square_map(e.V, e.F, without);
  SphereFromSquareReport rep;
  const MatrixXd S1 = sphere_from_square_map(e.V, e.F, {}, &rep);
  ASSERT_EQ(rep.sphere_flow.passes.size(), 1u);
  EXPECT_TRUE(sphere_covers_once(S1, e.F));
  const MapMetrics m0 = map_metrics(e.V, S0, e.F, Domain::sphere(), 16), m1 = map_metrics(e.V, S1, e.F, Domain::sphere(), 16);
  EXPECT_EQ(m1.flips, 0);
  EXPECT_LT(m1.element_cv, 0.003);
  // Measured with the great-circle cells: 4.6e-4 without the pass, 5.1e-4 with it, both at the
  // level of the cells' own sampling noise (the acceptance bar is 0.01).
  EXPECT_LT(m1.element_cv, m0.element_cv + 1e-4) << "without " << m0.element_cv << ", with " << m1.element_cv;
}

TEST(SphereFromSquare, AutoRouteFallsBackToTheFlowAndSaysWhy) {
  // A cap of no area cannot be cut off: the square route fails, Auto takes the flow route and
  // records why; the explicit square route reports the failure instead.
  const TriMesh m = icosphere(3);
  SphereMapOptions o;
  o.square_route.cap_fraction = 0.0;
  const SphereMapResult r = authalic_sphere_map(m, o);
  EXPECT_EQ(r.route, SphereRoute::Flow);
  EXPECT_NE(r.fallback_reason.find("two disks"), std::string::npos) << r.fallback_reason;
  EXPECT_TRUE(sphere_covers_once(r.sphere, m.F));
  o.route = SphereRoute::Square;
  EXPECT_THROW(authalic_sphere_map(m, o), ProcessingError);
}

TEST(StretchEnergy, APreparedSystemGivesTheBitsOfTheOneCallMapAndChecksItsInputs) {
  const TriMesh m = long_rectangle(8);
  const ConformalMapResult c = conformal_rectangle_map(m.V, m.F, RectangleBoundaryMap{});
  const VectorXd target = face_areas(c.V, c.F);
  StretchEnergyOptions o;
  StretchEnergyReport one, prepared;
  const MatrixXd a = stretch_energy_map(c.V, c.F, target, c.UV, c.side_mask, 1.0, o, &one);
  StretchEnergySystem system(c.V, c.F, c.side_mask, o.min_weight);
  const MatrixXd b = stretch_energy_map(system, target, c.UV, 1.0, o, &prepared);
  EXPECT_GT(one.iterations, 1);
  EXPECT_EQ(one.iterations, prepared.iterations);
  EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.0);
  // A target or map of another mesh is refused, not read out of bounds.
  EXPECT_THROW(stretch_energy_map(system, VectorXd(target.head(target.size() - 1)), c.UV, 1.0, o), std::invalid_argument);
  EXPECT_THROW(stretch_energy_map(system, target, MatrixXd(c.UV.topRows(c.UV.rows() - 1)), 1.0, o), std::invalid_argument);
}

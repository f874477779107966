// The authalic square map (core/square_map.h, core/authalic_flow.h) on small meshes with known
// answers: a flat square stays the identity, a non-uniformly triangulated planar disk ends with
// equal vertex areas, density 2 doubles a region's share (DLF 5.5), the right hemisphere is the
// mirror image of the left (orientation rule), thread count does not change a bit, and the DLF
// building blocks (critical step, Delaunay flips, adaptive mesh flow) behave as the paper says.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <string>

#include "common/hard_meshes.h"
#include "core/authalic_flow.h"
#include "core/error.h"
#include "core/metrics.h"
#include "core/square_map.h"

using namespace authalic;

namespace {

// Smallest max-norm distance between UV and the flat input's x,y under the 8 symmetries of the
// unit square (the boundary's start corner and direction are a convention, not geometry).
double distance_up_to_square_symmetry(const MatrixXd& UV, const MatrixXd& V) {
  double best = 1e300;
  for (int s = 0; s < 8; ++s) {
    double worst = 0;
    for (Eigen::Index v = 0; v < V.rows(); ++v) {
      double x = V(v, 0), y = V(v, 1);
      if (s & 1) std::swap(x, y);
      if (s & 2) x = 1 - x;
      if (s & 4) y = 1 - y;
      worst = std::max({worst, std::abs(UV(v, 0) - x), std::abs(UV(v, 1) - y)});
    }
    best = std::min(best, worst);
  }
  return best;
}

// A spherical cap (radius 50 mm) lifted from the uneven planar disk, shifted off-centre so that
// its most anterior vertex is unique: a stand-in for a curved left hemisphere patch.
TriMesh curved_cap() {
  TriMesh m = test::uneven_disk(16, 32);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) {
    const Eigen::Vector3d p = Eigen::Vector3d(m.V(v, 0) + 0.05 * m.V(v, 1) * m.V(v, 1), m.V(v, 1), 1.3).normalized();
    m.V.row(v) = (50.0 * p + Eigen::Vector3d(-30, 10, 5)).transpose();
  }
  return m;
}

SquareMapOptions test_options() {
  SquareMapOptions o;
  o.flow.grid.resolution = 256;
  return o;
}

}  // namespace

TEST(SquareMap, FlatSquareStaysTheIdentity) {
  const TriMesh m = test::square_grid(12);
  SquareMapOptions o = test_options();
  o.anatomical_anchor = false;
  const SquareMapResult r = square_map(m.V, m.F, o);
  ASSERT_EQ(r.V.rows(), m.V.rows());  // no corner or ear splits on a square grid
  EXPECT_LT(distance_up_to_square_symmetry(r.UV, m.V), 1e-9);
  EXPECT_TRUE(r.flow.converged);
  EXPECT_EQ(r.flow.iterations, 0);  // already area-preserving: the flow does not move it
  EXPECT_EQ(r.flips, 0);
}

// A starting map with too few rows is refused before any of it is read.
TEST(SquareMap, StartMapOfTheWrongSizeIsAnInputError) {
  const TriMesh m = test::square_grid(12);
  SquareMapOptions o = test_options();
  o.start_uv = m.V.topRows(m.V.rows() / 2).leftCols(2);
  try {
    square_map(m.V, m.F, o);
    FAIL() << "a start map with half the rows was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("start map: " + std::to_string(m.V.rows() / 2) + " rows for " + std::to_string(m.V.rows())), std::string::npos) << e.what();
  }
}

TEST(SquareMap, NonUniformPlanarDiskEndsWithEqualVertexAreas) {
  const TriMesh m = test::uneven_disk();  // triangle areas span about 1:1000
  const SquareMapResult r = square_map(m.V, m.F, test_options());
  const MapMetrics before = map_metrics(r.V, r.UV_initial, r.F, Domain::square(), 8);
  const MapMetrics after = map_metrics(r.V, r.UV, r.F, Domain::square(), 8);
  EXPECT_GT(before.vertex_ln_area.mean, 0.03);  // a disk's conformal square map stretches the corners
  EXPECT_EQ(after.flips, 0);
  EXPECT_LT(after.vertex_ln_area.mean, 0.01);
  EXPECT_LT(after.vertex_ln_area.p99, 0.04);
  EXPECT_LT(after.element_cv, 0.01);
  EXPECT_LT(after.outside_fraction, 1e-12);
  EXPECT_NEAR(signed_face_areas_2d(r.UV, r.F).sum(), 1.0, 1e-9);  // the square is covered once
}

TEST(SquareMap, DensityTwoGivesARegionTwiceItsNaturalShare) {
  const TriMesh m = test::square_grid(32);
  SquareMapOptions o = test_options();
  o.anatomical_anchor = false;
  o.density = VectorXd::Ones(m.num_vertices());
  for (int v = 0; v < m.num_vertices(); ++v)
    if (m.V(v, 0) <= 0.25 + 1e-12) o.density[v] = 2.0;
  const SquareMapResult r = square_map(m.V, m.F, o);
  ASSERT_EQ(r.flips, 0);
  // Region: faces whose three vertices all have density 2 (x <= 1/4).
  const VectorXd a3 = face_areas(r.V, r.F), a2 = signed_face_areas_2d(r.UV, r.F);
  const VectorXd t = target_face_measure(r.V, r.F, o.density, 1.0);
  double natural = 0, share = 0, target = 0;
  for (Eigen::Index f = 0; f < r.F.rows(); ++f) {
    bool in = true;
    for (int c = 0; c < 3; ++c) in = in && o.density[r.F(f, c)] == 2.0;
    if (!in) continue;
    natural += a3[f] / a3.sum();
    share += a2[f];
    target += t[f];
  }
  EXPECT_NEAR(natural, 0.25, 1e-9);
  EXPECT_NEAR(share / target, 1.0, 0.02);           // the share asked for, within 2%
  EXPECT_NEAR(share / natural, 2.0 / 1.25, 0.05);   // 2 x 0.25 / (2 x 0.25 + 0.75) = 0.4 of the square
}

TEST(SquareMap, RightHemisphereIsTheMirrorImageOfTheLeft) {
  const TriMesh left = curved_cap();
  TriMesh right = left;
  right.V.col(0) *= -1.0;  // mirror through the midsagittal plane: faces now point inward
  const SquareMapResult l = square_map(left.V, left.F, test_options());
  const SquareMapResult r = square_map(right.V, right.F, test_options());
  EXPECT_NE(l.faces_reversed, r.faces_reversed);  // rule 1 turned one of them outward
  EXPECT_EQ(l.anterior_vertex, r.anterior_vertex);
  ASSERT_EQ(l.UV.rows(), r.UV.rows());
  double worst = 0;
  for (Eigen::Index v = 0; v < l.UV.rows(); ++v)
    worst = std::max({worst, std::abs(r.UV(v, 0) - (1.0 - l.UV(v, 0))), std::abs(r.UV(v, 1) - l.UV(v, 1))});
  // Equal up to the discretisation (corner snapping, the grid and the boundary slid by a grid
  // pass see the boundary walked the other way round; measured 0.0037): far below an element's
  // width (1/32).
  EXPECT_LT(worst, 5e-3);
  // Rule 2: the frontal pole maps near the top middle of the square.
  EXPECT_NEAR(l.UV(l.anterior_vertex, 0), 0.5, 0.1);
  EXPECT_GT(l.UV(l.anterior_vertex, 1), 0.9);
}

// Rule 1 on a region that faces the surface's centre (as the insula faces a hemisphere's): the
// cone from the centroid calls it inward, the closed surface it was cut from says it is outward.
// A torus: its inner-side faces point at the axis, where its centroid is.
TEST(SquareMap, OutwardIsTakenFromTheClosedSurfaceTheRegionIsCutFrom) {
  const TriMesh torus = test::torus_mesh(24);  // vertex i n + j at angles u = 2π i/n, v = 2π j/n
  const int n = 24;
  const VectorXd volume_terms = [&] {
    VectorXd t(torus.F.rows());
    for (Eigen::Index f = 0; f < torus.F.rows(); ++f)
      t[f] = torus.V.row(torus.F(f, 0)).dot(Eigen::RowVector3d(torus.V.row(torus.F(f, 1))).cross(Eigen::RowVector3d(torus.V.row(torus.F(f, 2)))));
    return t;
  }();
  MatrixXi surface = torus.F;
  if (volume_terms.sum() < 0) surface.col(1).swap(surface.col(2));  // wound outward
  std::vector<int> inner;  // a disk on the inner side: u in [0, 60°], v in [150°, 210°]
  for (Eigen::Index f = 0; f < surface.rows(); ++f) {
    bool in = true;
    for (int c = 0; c < 3; ++c) {
      const int i = surface(f, c) / n, j = surface(f, c) % n;
      in = in && i <= n / 6 && j >= 5 * n / 12 && j <= 7 * n / 12;
    }
    if (in) inner.push_back(static_cast<int>(f));
  }
  ASSERT_GT(inner.size(), 20u);
  MatrixXi region(static_cast<Eigen::Index>(inner.size()), 3);
  for (std::size_t k = 0; k < inner.size(); ++k) region.row(static_cast<Eigen::Index>(k)) = surface.row(inner[k]);

  EXPECT_EQ(region_winding_on_closed_surface(torus.V, region, surface), 1);
  MatrixXi by_cone = region;
  EXPECT_TRUE(orient_outward(torus.V, by_cone));  // the centroid's rule gets it wrong
  MatrixXi by_surface = region;
  EXPECT_FALSE(orient_outward(torus.V, by_surface, &surface));
  MatrixXi reversed = region;
  reversed.col(1).swap(reversed.col(2));
  EXPECT_EQ(region_winding_on_closed_surface(torus.V, reversed, surface), -1);
  EXPECT_TRUE(orient_outward(torus.V, reversed, &surface));
  EXPECT_EQ(reversed, region);
  // A surface wound inward says the same about the same faces.
  MatrixXi inward = surface;
  inward.col(1).swap(inward.col(2));
  EXPECT_EQ(region_winding_on_closed_surface(torus.V, region, inward), 1);
  // An open surface cannot tell: the cone's rule decides.
  const MatrixXi open = region;
  EXPECT_EQ(region_winding_on_closed_surface(torus.V, region, open), 0);

  // Through square_map: with the surface the map keeps the region's (outward) winding.
  SquareMapOptions o = test_options();
  o.surface_faces = &surface;
  const SquareMapResult r = square_map(torus.V, region, o);
  EXPECT_FALSE(r.faces_reversed);
  EXPECT_EQ(r.flips, 0);
}

TEST(SquareMap, SameBitsForOneAndTwoThreads) {
  const TriMesh m = curved_cap();
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const SquareMapResult a = square_map(m.V, m.F, test_options());
  omp_set_num_threads(2);
  const SquareMapResult b = square_map(m.V, m.F, test_options());
  omp_set_num_threads(saved);
  EXPECT_EQ((a.UV - b.UV).cwiseAbs().maxCoeff(), 0.0);
}

TEST(SquareMap, CurvedPatchMeetsTheAccuracyTargets) {
  const TriMesh m = curved_cap();
  const SquareMapResult r = square_map(m.V, m.F, test_options());
  const MapMetrics mm = map_metrics(r.V, r.UV, r.F, Domain::square(), 8);
  EXPECT_EQ(mm.flips, 0);
  EXPECT_LT(mm.vertex_ln_area.mean, 0.01);
  EXPECT_LT(mm.element_cv, 0.01);
  // The report states what it measured.
  EXPECT_NEAR(r.flow.final_vertex_mean, mm.vertex_ln_area.mean, 1e-9);
}

// ---- DLF building blocks -------------------------------------------------------------------

// The grid pass's per-vertex RK4 step count (GridFlowOptions::max_cells_per_step): on a density
// with a mild ripple everywhere and a strong bump (4x) in one corner, the adaptive pass lands
// where 80 fixed steps do as closely as 20 fixed steps do, both where the bound cuts the steps
// (the ripple) and where the speed is too high for it (the bump keeps every step).
TEST(GridFlow, AdaptiveRk4StepsLandWhereFixedStepsDo) {
  const TriMesh m = test::square_grid(48);
  const MatrixXd UV = m.V.leftCols(2);
  const VectorXi side = test::square_sides(m.V);
  VectorXd target = face_areas(m.V, m.F);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::RowVector2d c = (UV.row(m.F(f, 0)) + UV.row(m.F(f, 1)) + UV.row(m.F(f, 2))) / 3.0;
    const double bump = 3.0 * std::exp(-(c - Eigen::RowVector2d(0.2, 0.2)).squaredNorm() / (2 * 0.05 * 0.05));
    target[f] *= 1.0 + 0.02 * std::sin(2 * M_PI * c.x()) * std::sin(3 * M_PI * c.y()) + bump;
  }
  target *= 1.0 / target.sum();
  GridFlowOptions fixed;
  fixed.resolution = 64;
  fixed.max_cells_per_step = 0;
  GridFlowOptions reference = fixed;
  reference.rk4_steps = 80;
  GridFlowOptions adaptive = fixed;
  adaptive.max_cells_per_step = 0.5;
  const MatrixXd ref = moser_grid_pass(target, UV, m.F, side, 1.0, reference);
  const MatrixXd f20 = moser_grid_pass(target, UV, m.F, side, 1.0, fixed);
  const MatrixXd ada = moser_grid_pass(target, UV, m.F, side, 1.0, adaptive);
  const double h = 1.0 / 64;
  auto error_where = [&](const MatrixXd& X, bool near_bump) {
    double e = 0;
    for (Eigen::Index v = 0; v < UV.rows(); ++v)
      if (((UV.row(v) - Eigen::RowVector2d(0.2, 0.2)).norm() < 0.25) == near_bump) e = std::max(e, (X.row(v) - ref.row(v)).norm());
    return e / h;  // in cells
  };
  EXPECT_GT((ref - UV).rowwise().norm().maxCoeff(), 2 * h);  // the bump moves vertices by cells
  // Measured: ripple 3.4e-6 (20 fixed) and 1.7e-5 cells (adaptive); bump 9.7e-5 both. With the
  // bound's radius unchecked (bump vertices cut to few steps) the bump's error is 6e-3 cells.
  EXPECT_LT(error_where(ada, false), 1e-3) << "20 fixed steps: " << error_where(f20, false);
  EXPECT_LT(error_where(ada, true), 1e-3) << "20 fixed steps: " << error_where(f20, true);
  EXPECT_LE(error_where(ada, true), 2 * error_where(f20, true) + 1e-9);
  EXPECT_EQ(count_flipped(ada, m.F, 0.0), 0);
}

TEST(DiscreteLieFlow, CriticalStepIsTheFirstRootOfTheSignedArea) {
  // Moving the apex (0, 1) down at speed 2 flattens the triangle at s = 1/2 (DLF eq. 5).
  const Eigen::Vector2d p[3] = {{0, 0}, {1, 0}, {0, 1}};
  const Eigen::Vector2d d[3] = {{0, 0}, {0, 0}, {0, -2}};
  EXPECT_NEAR(critical_step(p, d), 0.5, 1e-12);
  // A translation never degenerates a triangle.
  const Eigen::Vector2d t[3] = {{1, 1}, {1, 1}, {1, 1}};
  EXPECT_TRUE(std::isinf(critical_step(p, t)));
  // Shrinking about the centroid degenerates it at s = 1 (quadratic with a double root).
  const Eigen::Vector2d c(1.0 / 3, 1.0 / 3);
  const Eigen::Vector2d s[3] = {c - p[0], c - p[1], c - p[2]};
  EXPECT_NEAR(critical_step(p, s), 1.0, 1e-6);
}

TEST(DiscreteLieFlow, DelaunayFlipReplacesANonDelaunayDiagonal) {
  // Two flat triangles on the long diagonal of a thin rhombus: the angles opposite the shared
  // edge are obtuse (sum > pi), so the edge flips to the short diagonal.
  MatrixXd UV(4, 2);
  UV << -1, 0, 1, 0, 0, 0.3, 0, -0.3;
  MatrixXi F(2, 3);
  F << 0, 1, 2, 1, 0, 3;
  EXPECT_EQ(delaunay_flip(UV, F), 1);
  for (Eigen::Index f = 0; f < 2; ++f) {
    bool has2 = false, has3 = false;
    for (int c = 0; c < 3; ++c) has2 = has2 || F(f, c) == 2, has3 = has3 || F(f, c) == 3;
    EXPECT_TRUE(has2 && has3) << "face " << f << " lacks the new edge 2-3";
  }
  EXPECT_EQ(count_flipped(UV, F), 0);
  EXPECT_EQ(delaunay_flip(UV, F), 0);  // now Delaunay: nothing left to flip
}

TEST(DiscreteLieFlow, AdaptiveMeshFlowReducesDistortionWithoutFlips) {
  const TriMesh m = test::uneven_disk(12, 24);
  SquareMapOptions o = test_options();
  o.flow.method = FlowMethod::Mesh;
  o.flow.mesh.max_iterations = 60;
  o.stretch_start = false;  // the mesh flow's own work, from the conformal map
  const SquareMapResult r = square_map(m.V, m.F, o);
  EXPECT_EQ(r.flips, 0);
  EXPECT_GT(r.flow.iterations, 0);
  EXPECT_LT(r.flow.final_vertex_mean, 0.5 * r.flow.initial_vertex_mean);
  // Zou's fixed schedule (eq. 19) takes exactly its K steps.
  o.flow.mesh.fixed_steps = 5;
  const SquareMapResult k = square_map(m.V, m.F, o);
  EXPECT_EQ(k.flow.iterations, 5);
  EXPECT_EQ(k.flips, 0);
}

TEST(DiscreteLieFlow, FlatSquareTakesNoMeshStepWithEitherTargets) {
  // Known answer: a flat square grid is its own authalic map, whichever triangulation the targets
  // are measured on (the flat surface re-triangulated has the same areas).
  const TriMesh m = test::square_grid(12);
  for (const MeshFlowTargets targets : {MeshFlowTargets::Surface, MeshFlowTargets::Flowing}) {
    SquareMapOptions o = test_options();
    o.anatomical_anchor = false;
    o.flow.method = FlowMethod::Mesh;
    o.flow.mesh.targets = targets;
    const SquareMapResult r = square_map(m.V, m.F, o);
    EXPECT_LT(distance_up_to_square_symmetry(r.UV, m.V), 1e-9);
    EXPECT_EQ(r.flow.iterations, 0);
    EXPECT_EQ(r.flow.stop_reason, "tolerance");
  }
}

TEST(DiscreteLieFlow, BothTargetsLowerTheErrorAndThePolishFinishesTheMeshFlow) {
  const TriMesh m = test::uneven_disk(12, 24);
  for (const MeshFlowTargets targets : {MeshFlowTargets::Surface, MeshFlowTargets::Flowing}) {
    SquareMapOptions o = test_options();
    o.flow.method = FlowMethod::Mesh;
    o.flow.mesh.targets = targets;
    o.stretch_start = false;
    o.flow.polish.enabled = false;
    const SquareMapResult alone = square_map(m.V, m.F, o);
    EXPECT_EQ(alone.flips, 0);
    EXPECT_LT(alone.flow.final_vertex_mean, 0.5 * alone.flow.initial_vertex_mean);
    EXPECT_EQ(alone.flow.polish_iterations, 0);
    EXPECT_DOUBLE_EQ(alone.flow.flow_vertex_mean, alone.flow.final_vertex_mean);
    if (alone.flow.stop_reason == "stalled" || alone.flow.stop_reason == "step vanished") {
      EXPECT_NE(alone.flow.stall_detail.find("triangle of vertices"), std::string::npos);
    }
    // The polish runs after the mesh method too, from where the flow stopped.
    o.flow.polish.enabled = true;
    const SquareMapResult polished = square_map(m.V, m.F, o);
    EXPECT_EQ(polished.flips, 0);
    EXPECT_EQ(polished.flow.iterations, alone.flow.iterations);
    EXPECT_DOUBLE_EQ(polished.flow.flow_vertex_mean, alone.flow.final_vertex_mean);
    EXPECT_LE(polished.flow.final_vertex_mean, 1.05 * alone.flow.final_vertex_mean);
  }
}

// region_faces_from_vertices (core/region.h): a vertex label with the defects of real FreeSurfer
// labels (holes, islands, bow-tie vertices) becomes one disk of faces, with exact counts of what
// was changed; a hole too large to fill is left, and the result says how large it is.
#include <gtest/gtest.h>

#include <set>

#include "common/hard_meshes.h"
#include "common/region_labels.h"
#include "core/region.h"

using namespace authalic;
using namespace authalic::test;

namespace {

// Faces of m with all three vertices in the label, as the callers built the region before.
MatrixXi whole_faces(const TriMesh& m, const std::vector<bool>& in) {
  std::vector<int> keep;
  for (int f = 0; f < m.num_faces(); ++f)
    if (in[m.F(f, 0)] && in[m.F(f, 1)] && in[m.F(f, 2)]) keep.push_back(f);
  MatrixXi F(static_cast<Eigen::Index>(keep.size()), 3);
  for (std::size_t k = 0; k < keep.size(); ++k) F.row(static_cast<Eigen::Index>(k)) = m.F.row(keep[k]);
  return F;
}

// Area of the faces of m with at least one vertex in vs.
double area_touching(const TriMesh& m, const std::vector<int>& vs) {
  const std::set<int> s(vs.begin(), vs.end());
  const VectorXd a = face_areas(m.V, m.F);
  double sum = 0;
  for (int f = 0; f < m.num_faces(); ++f)
    if (s.count(m.F(f, 0)) || s.count(m.F(f, 1)) || s.count(m.F(f, 2))) sum += a[f];
  return sum;
}

double face_area(const TriMesh& m, int a, int b, int c) {
  const Eigen::Vector3d p = m.V.row(a), q = m.V.row(b), r = m.V.row(c);
  return 0.5 * (q - p).cross(r - p).norm();
}

// The rows of F are rows of the input F, in order, and face_index points at them.
void expect_rows_of_input(const RegionCleanup& r, const MatrixXi& F) {
  ASSERT_EQ(r.F.rows(), r.face_index.size());
  for (Eigen::Index k = 0; k < r.F.rows(); ++k) {
    ASSERT_EQ(r.F.row(k), F.row(r.face_index[k])) << k;
    if (k > 0) {
      ASSERT_LT(r.face_index[k - 1], r.face_index[k]);
    }
  }
}

}  // namespace

TEST(RegionCleanup, ACleanCapIsLeftAsItIs) {
  const DefectLabel d = cap_label();
  const MatrixXi raw = whole_faces(d.mesh, d.in);
  ASSERT_TRUE(analyze_topology(d.mesh.V, raw).is_disk());
  const RegionCleanup r = region_faces_from_vertices(d.mesh.V, d.mesh.F, d.in);
  EXPECT_TRUE(r.is_disk()) << r.problem();
  EXPECT_EQ(r.F, raw);
  EXPECT_FALSE(r.changed());
  EXPECT_EQ(r.summary(), "no cleanup needed");
  EXPECT_EQ(r.problem(), "");
  EXPECT_EQ(r.label_vertices_outside, 0);
  EXPECT_EQ(r.vertices_outside_label, 0);
  EXPECT_NEAR(r.area_mm2, face_areas(d.mesh.V, raw).sum(), 1e-9);
}

TEST(RegionCleanup, HoleIslandAndBowTieAreCleanedToOneDiskWithExactCounts) {
  const DefectLabel d = cap_label_with_hole_island_bowtie();
  const TriMesh& m = d.mesh;
  ASSERT_GE(d.bowtie, 0);
  // The fixture has the defects it claims: three pieces (cap, island, flap), the cap with two
  // boundary loops (outer and the hole), one pinch vertex (the bow-tie).
  const MatrixXi raw = whole_faces(m, d.in);
  const TopologyReport before = analyze_topology(m.V, raw);
  ASSERT_EQ(before.num_components, 2) << before.summary();  // face_components joins the flap at b
  ASSERT_EQ(before.non_manifold_vertices, 1) << before.summary();
  // Cap outer and flap (one walk through b), hole, island.
  ASSERT_EQ(before.num_boundary_loops, 3) << before.summary();
  ASSERT_FALSE(before.is_disk());

  const RegionCleanup r = region_faces_from_vertices(m.V, m.F, d.in);
  EXPECT_TRUE(r.is_disk()) << r.topology.summary() << "; " << r.problem();
  EXPECT_EQ(r.problem(), "");
  expect_rows_of_input(r, m.F);
  EXPECT_EQ(r.raw_faces, raw.rows());
  EXPECT_EQ(r.raw_pinch_vertices, 1);
  // The 1-vertex hole: its vertex and its fan of faces are added, nothing else.
  const auto ring = vertex_neighbours(m.F, m.num_vertices());
  const int valence = static_cast<int>(ring[d.hole_vertex].size());
  EXPECT_EQ(r.holes_filled, 1);
  EXPECT_EQ(r.hole_vertices_added, 1);
  EXPECT_EQ(r.hole_faces_added, valence);
  EXPECT_NEAR(r.hole_area_mm2, area_touching(m, {d.hole_vertex}), 1e-9);
  // The island (a vertex and its ring: its fan) and the flap are dropped with their vertices.
  const int island_faces = static_cast<int>(ring[d.island[0]].size());
  EXPECT_EQ(r.islands_dropped, 2);
  EXPECT_EQ(r.island_faces, island_faces + 1);
  EXPECT_EQ(r.island_vertices, static_cast<int>(d.island.size()) + 2);
  EXPECT_NEAR(r.island_area_mm2, area_touching(m, {d.island[0]}) + face_area(m, d.bowtie, d.flap[0], d.flap[1]), 1e-9);
  // The bow-tie vertex stays (on the cap) and is manifold now; no fan had to be removed.
  EXPECT_EQ(r.pinch_vertices_fixed, 1);
  EXPECT_EQ(r.pinch_faces_removed, 0);
  EXPECT_EQ(r.pinch_vertices_removed, 0);
  // Net difference to the label: the island's and flap's vertices are out, the hole's is in.
  EXPECT_EQ(r.label_vertices_outside, static_cast<int>(d.island.size()) + 2);
  EXPECT_EQ(r.vertices_outside_label, 1);
  EXPECT_EQ(r.topology.num_faces, raw.rows() + valence - island_faces - 1);
  char expected[200];
  std::snprintf(expected, sizeof(expected), "filled 1 hole (1 vertex, %.1f mm^2), dropped 2 islands (%d vertices, %.1f mm^2), fixed 1 pinch vertex",
                r.hole_area_mm2, r.island_vertices, r.island_area_mm2);
  EXPECT_EQ(r.summary(), expected);
  // Deterministic: the same faces again.
  EXPECT_EQ(region_faces_from_vertices(m.V, m.F, d.in).F, r.F);
}

TEST(RegionCleanup, AHoleAboveTheLimitIsLeftAndItsSizeReported) {
  const DefectLabel d = cap_label_with_big_hole();
  const TriMesh& m = d.mesh;
  const RegionCleanup r = region_faces_from_vertices(m.V, m.F, d.in);
  const double hole = area_touching(m, d.big_hole);
  ASSERT_GT(hole, 0.01 * r.area_mm2);  // the fixture's hole is above the 1 % limit
  EXPECT_FALSE(r.is_disk());
  EXPECT_EQ(r.topology.num_boundary_loops, 2);
  EXPECT_EQ(r.holes_filled, 0);
  EXPECT_EQ(r.holes_unfilled, 1);
  EXPECT_NEAR(r.largest_unfilled_hole_mm2, hole, 1e-9);
  EXPECT_NEAR(r.fill_rule_area_mm2, r.area_mm2, 1e-9);  // nothing was filled or dropped here
  EXPECT_NEAR(r.largest_unfilled_hole_fraction, hole / r.fill_rule_area_mm2, 1e-12);
  EXPECT_GE(r.largest_unfilled_hole_fraction, RegionCleanupOptions{}.max_hole_fraction);  // as the rule judged it
  EXPECT_EQ(r.largest_unfilled_hole_vertices, static_cast<int>(d.big_hole.size()));
  char size[64];
  std::snprintf(size, sizeof(size), "%.1f mm^2 (%.2f %% of the region", hole, 100 * hole / r.area_mm2);
  EXPECT_NE(r.problem().find("not one disk"), std::string::npos) << r.problem();
  EXPECT_NE(r.problem().find("2 boundary loops"), std::string::npos) << r.problem();
  EXPECT_NE(r.problem().find(size), std::string::npos) << r.problem() << " lacks " << size;
  // With a higher limit the same hole is filled and the region is a disk.
  RegionCleanupOptions o;
  o.max_hole_fraction = 0.05;
  const RegionCleanup filled = region_faces_from_vertices(m.V, m.F, d.in, o);
  EXPECT_TRUE(filled.is_disk()) << filled.problem();
  EXPECT_EQ(filled.holes_filled, 1);
  EXPECT_EQ(filled.hole_vertices_added, static_cast<int>(d.big_hole.size()));
  EXPECT_NEAR(filled.hole_area_mm2, hole, 1e-9);
}

// A label of two large pieces (e.g. a cortex label cut in two): mapping the largest would leave
// the other out (half the cortex was dropped with exit 0). Small pieces are stray vertices.
TEST(RegionCleanup, ALargeSecondPieceIsNamedNotDropped) {
  const TriMesh m = icosphere(4);
  std::vector<bool> two(static_cast<std::size_t>(m.num_vertices()), false), stray = two;
  for (int v = 0; v < m.num_vertices(); ++v) {
    two[static_cast<std::size_t>(v)] = std::abs(m.V(v, 2)) > 0.3;      // two polar caps
    stray[static_cast<std::size_t>(v)] = m.V(v, 2) > -0.5 || m.V(v, 2) < -0.99;  // a cap and a few vertices
  }
  const RegionCleanup r = region_faces_from_vertices(m.V, m.F, two);
  EXPECT_TRUE(r.is_disk());  // the kept cap is a disk
  EXPECT_EQ(r.islands_dropped, 1);
  EXPECT_NEAR(r.largest_island_fraction, 1.0, 0.05);  // the caps are mirror images
  EXPECT_NE(r.pieces_problem().find("the region is 2 pieces: a second piece of "), std::string::npos) << r.pieces_problem();
  const RegionCleanup s = region_faces_from_vertices(m.V, m.F, stray);
  EXPECT_EQ(s.islands_dropped, 1);
  EXPECT_LT(s.largest_island_fraction, 0.01);
  EXPECT_EQ(s.pieces_problem(), "");
}

TEST(RegionCleanup, PinchAroundSmallPocketsIsFixedByFillingThem) {
  // Square grid (open: its border is the outer side). Two 1-vertex holes at (5,5) and (7,7) touch
  // at vertex (6,6), whose region faces form two fans.
  const int n = 20;
  const TriMesh g = square_grid(n);
  auto id = [&](int i, int j) { return j * (n + 1) + i; };
  std::vector<bool> in(static_cast<std::size_t>(g.num_vertices()), true);
  in[id(5, 5)] = in[id(7, 7)] = false;
  ASSERT_EQ(analyze_topology(g.V, whole_faces(g, in)).non_manifold_vertices, 1);
  const RegionCleanup r = region_faces_from_vertices(g.V, g.F, in);
  EXPECT_TRUE(r.is_disk()) << r.problem();
  EXPECT_EQ(r.F, g.F);  // both holes filled: the whole grid
  EXPECT_EQ(r.holes_filled, 2);
  EXPECT_EQ(r.hole_vertices_added, 2);
  EXPECT_EQ(r.hole_faces_added, 12);
  EXPECT_EQ(r.raw_pinch_vertices, 1);
  EXPECT_EQ(r.pinch_vertices_fixed, 1);
  EXPECT_EQ(r.pinch_faces_removed, 0);
}

TEST(RegionCleanup, PinchAroundABigPocketIsOpenedByDroppingTheSmallerFan) {
  // A pocket (vertices 2..5 x 2..5 left out: above 1 %) and a channel along the diagonal from (7,7)
  // to the corner (20,20) touch at vertex (6,6). Filling the pocket is not allowed; closing the
  // pinch with faces would make the pocket a hole; dropping one of the two one-face fans at (6,6)
  // joins the pocket to the channel and the region is one disk.
  const int n = 20;
  const TriMesh g = square_grid(n);
  auto id = [&](int i, int j) { return j * (n + 1) + i; };
  std::vector<bool> in(static_cast<std::size_t>(g.num_vertices()), true);
  for (int i = 2; i <= 5; ++i)
    for (int j = 2; j <= 5; ++j) in[id(i, j)] = false;
  for (int k = 7; k <= n; ++k) in[id(k, k)] = false;
  const TopologyReport before = analyze_topology(g.V, whole_faces(g, in));
  ASSERT_EQ(before.non_manifold_vertices, 1) << before.summary();
  const RegionCleanup r = region_faces_from_vertices(g.V, g.F, in);
  EXPECT_TRUE(r.is_disk()) << r.problem();
  EXPECT_EQ(r.holes_filled, 0);
  EXPECT_EQ(r.islands_dropped, 0);
  EXPECT_EQ(r.raw_pinch_vertices, 1);
  EXPECT_EQ(r.pinch_vertices_fixed, 1);
  EXPECT_EQ(r.pinch_faces_removed, 1);
  EXPECT_EQ(r.pinch_vertices_removed, 0);
  EXPECT_NEAR(r.pinch_area_mm2, 0.5 / (n * n), 1e-12);
  EXPECT_EQ(r.topology.num_faces, before.num_faces - 1);
  EXPECT_EQ(r.label_vertices_outside, 0);
  EXPECT_EQ(r.summary(), "fixed 1 pinch vertex (removed 1 face, 0 vertices, 0.0 mm^2)");
}

TEST(RegionCleanup, ALabelWithNoWholeTriangleGivesNoFaces) {
  const TriMesh m = icosphere(2);
  std::vector<bool> in(static_cast<std::size_t>(m.num_vertices()), false);
  in[0] = in[1] = true;
  const RegionCleanup r = region_faces_from_vertices(m.V, m.F, in);
  EXPECT_EQ(r.F.rows(), 0);
  EXPECT_FALSE(r.is_disk());
  EXPECT_EQ(r.label_vertices_outside, 2);
  EXPECT_NE(r.problem().find("no face"), std::string::npos) << r.problem();
}

// Initial rectangle map (core/conformal_map): identity on a flat square, corner and ear splits
// without degenerate triangles, rectangle widths, anchors, weights with linear precision.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "common/hard_meshes.h"
#include "core/conformal_map.h"

using namespace authalic;

namespace {

// Smallest triangle angle (radians) of a planar map.
double min_angle(const MatrixXd& UV, const MatrixXi& F) {
  MatrixXd P = MatrixXd::Zero(UV.rows(), 3);
  P.leftCols(2) = UV.leftCols(2);
  return corner_angles(P, F).minCoeff();
}

// Checks shared by every map: boundary on the perimeter with the right side bits, no flipped or
// degenerate triangle, the map tiles the rectangle (areas add up to W), pieces keep 3D area.
void expect_valid_map(const ConformalMapResult& r, const TriMesh& input, const std::string& what) {
  const double w = r.width;
  EXPECT_EQ(count_flipped(r.UV, r.F, 1e-14), 0) << what;
  const VectorXd sa = signed_face_areas_2d(r.UV, r.F);
  EXPECT_NEAR(sa.sum(), w, 1e-9) << what;
  for (int v : r.boundary) {
    const double x = r.UV(v, 0), y = r.UV(v, 1);
    const int m = r.side_mask[v];
    ASSERT_NE(m, 0) << what << ": boundary vertex " << v << " has no side";
    if (m & kSideBottom) {
      EXPECT_EQ(y, 0.0) << what;
    }
    if (m & kSideTop) {
      EXPECT_EQ(y, 1.0) << what;
    }
    if (m & kSideLeft) {
      EXPECT_EQ(x, 0.0) << what;
    }
    if (m & kSideRight) {
      EXPECT_EQ(x, w) << what;
    }
  }
  // Interior vertices strictly inside.
  std::vector<bool> on_boundary(r.V.rows(), false);
  for (int v : r.boundary) on_boundary[v] = true;
  for (Eigen::Index f = 0; f < r.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int v = r.F(f, c);
      if (on_boundary[v]) continue;
      EXPECT_GT(r.UV(v, 0), 0.0);
      EXPECT_LT(r.UV(v, 0), w);
      EXPECT_GT(r.UV(v, 1), 0.0);
      EXPECT_LT(r.UV(v, 1), 1.0);
    }
  // The four corners are taken by vertices.
  int corners = 0;
  for (int v : r.boundary)
    if (__builtin_popcount(r.side_mask[v]) == 2) ++corners;
  EXPECT_EQ(corners, 4) << what;
  if (r.edges_flipped == 0) {
    // Split pieces keep their parent face's 3D area (vertices inserted on the surface).
    const VectorXd a_in = face_areas(input.V, input.F), a_out = face_areas(r.V, r.F);
    VectorXd sum = VectorXd::Zero(input.F.rows());
    for (Eigen::Index f = 0; f < r.F.rows(); ++f) sum[r.face_origin[f]] += a_out[f];
    EXPECT_LT((sum - a_in).cwiseAbs().maxCoeff(), 1e-12 * a_in.sum()) << what;
  } else if (r.edges_split == 0 && r.corner_vertices_inserted == 0) {
    // Flips only: the input's vertices and face count; exactly edges_flipped edges replaced.
    EXPECT_EQ(r.V.rows(), input.V.rows()) << what;
    EXPECT_EQ(r.F.rows(), input.F.rows()) << what;
    const EdgeTopology before = edge_topology(input.F, input.num_vertices()), after = edge_topology(r.F, input.num_vertices());
    std::set<std::pair<int, int>> old_edges;
    for (Eigen::Index e = 0; e < before.E.rows(); ++e) old_edges.insert({before.E(e, 0), before.E(e, 1)});
    int changed = 0;
    for (Eigen::Index e = 0; e < after.E.rows(); ++e) changed += old_edges.count({after.E(e, 0), after.E(e, 1)}) == 0;
    EXPECT_EQ(changed, r.edges_flipped) << what;
  }
  // The input's vertices come first, unchanged.
  EXPECT_EQ(r.num_input_vertices, input.num_vertices());
  EXPECT_EQ((r.V.topRows(input.num_vertices()) - input.V).cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace

TEST(ConformalMap, FlatSquarePatchMapsToItself) {
  const TriMesh m = test::square_grid(12);
  RectangleBoundaryMap opt;
  opt.anchor_vertex = 0;  // the corner (0, 0) of the patch goes to the corner (0, 0)
  opt.anchor_position = 0.0;
  const ConformalMapResult r = conformal_rectangle_map(m.V, m.F, opt);
  EXPECT_EQ(r.V.rows(), m.V.rows());  // nothing to split
  EXPECT_EQ(r.F.rows(), m.F.rows());
  EXPECT_EQ(r.edges_split, 0);
  EXPECT_EQ(r.corner_vertices_inserted, 0);
  EXPECT_EQ(r.weights, HarmonicWeights::Cotangent);
  EXPECT_LT((r.UV - m.V.leftCols(2)).cwiseAbs().maxCoeff(), 1e-12);
  expect_valid_map(r, m, "square");
}

TEST(ConformalMap, DiskGetsCornerVerticesAndAnAnchoredBoundary) {
  const TriMesh m = test::uneven_disk(12, 30);
  RectangleBoundaryMap opt;
  const int anchor = m.num_vertices() - 7;  // on the outer ring
  opt.anchor_vertex = anchor;
  opt.anchor_position = rectangle_top_middle(1.0);
  opt.corner_snap = 0.0;  // force insertion
  const ConformalMapResult r = conformal_rectangle_map(m.V, m.F, opt);
  EXPECT_EQ(r.corner_vertices_inserted, 4);
  EXPECT_NEAR(r.UV(anchor, 0), 0.5, 1e-15);
  EXPECT_EQ(r.UV(anchor, 1), 1.0);
  // Corner vertices are appended after the input's, exactly on the corners.
  int found = 0;
  for (Eigen::Index v = m.num_vertices(); v < r.V.rows(); ++v)
    if (__builtin_popcount(r.side_mask[v]) == 2) {
      ++found;
      EXPECT_TRUE((r.UV(v, 0) == 0.0 || r.UV(v, 0) == 1.0) && (r.UV(v, 1) == 0.0 || r.UV(v, 1) == 1.0));
    }
  EXPECT_EQ(found, 4);
  expect_valid_map(r, m, "disk");
  // A disk is symmetric: the boundary goes round counter-clockwise (no mirror), so the vertex
  // after the anchor on the loop moves left along the top side.
  EXPECT_LT(r.UV(r.boundary[1], 0), 0.5);
}

TEST(ConformalMap, SnappingMovesANearbyBoundaryVertexOntoTheCorner) {
  const TriMesh m = test::uneven_disk(12, 32);  // 32 boundary vertices: corners land on vertices
  RectangleBoundaryMap opt;
  opt.anchor_vertex = m.num_vertices() - 32;
  opt.anchor_position = 0.0;
  const ConformalMapResult r = conformal_rectangle_map(m.V, m.F, opt);
  EXPECT_EQ(r.corners_snapped, 4);
  EXPECT_EQ(r.corner_vertices_inserted, 0);
  expect_valid_map(r, m, "snapped disk");
}

TEST(ConformalMap, EarAndStripTrianglesAreSplitWithoutDegenerateTriangles) {
  // A single row of triangles: every vertex is on the boundary, most diagonals join vertices that
  // land on the same side of the square.
  TriMesh strip;
  const int n = 20;
  strip.V.resize(2 * (n + 1), 3);
  for (int i = 0; i <= n; ++i) {
    strip.V.row(i) << i, 0, 0.1 * std::sin(i);
    strip.V.row(n + 1 + i) << i, 1, 0.1 * std::cos(i);
  }
  strip.F.resize(2 * n, 3);
  for (int i = 0; i < n; ++i) {
    strip.F.row(2 * i) << i, i + 1, n + 2 + i;
    strip.F.row(2 * i + 1) << i, n + 2 + i, n + 1 + i;
  }
  RectangleBoundaryMap opt;
  opt.flip_dividing_edges = false;
  const ConformalMapResult r = conformal_rectangle_map(strip.V, strip.F, opt);
  EXPECT_GE(r.edges_split, 2);  // the diagonals at the two corners the rows wrap around
  expect_valid_map(r, strip, "strip");
  EXPECT_GT(min_angle(r.UV, r.F), 1e-4);
  // Inserted midpoints are the 3D midpoints of the split edges: the surface is unchanged.
  EXPECT_NEAR(face_areas(r.V, r.F).sum(), face_areas(strip.V, strip.F).sum(), 1e-12);
  // By default they are flipped instead: the strip keeps its vertices.
  const ConformalMapResult d = conformal_rectangle_map(strip.V, strip.F, RectangleBoundaryMap{});
  EXPECT_GE(d.edges_flipped, 2);
  EXPECT_EQ(d.edges_split, 0);
  EXPECT_EQ(d.V.rows(), strip.V.rows());
  expect_valid_map(d, strip, "strip, default");
}

namespace {

// The 6 x 6 square grid with one extra triangle hanging below the bottom side: its three vertices
// are consecutive boundary vertices on one side, an ear (Zou et al. 2011, section 4.1). Bottom-row
// vertices 3 (x = 0.5) and 4 (x = 0.667): the grid's faces run 3 -> 4, so the ear (counter-
// clockwise) runs 4 -> 3; its tip is the last vertex, at (tip_x, -0.05).
TriMesh grid_with_ear(double tip_x) {
  TriMesh m = test::square_grid(6);
  const int nv = m.num_vertices();
  m.V.conservativeResize(nv + 1, 3);
  m.V.row(nv) << tip_x, -0.05, 0.0;
  m.F.conservativeResize(m.F.rows() + 1, 3);
  m.F.row(m.F.rows() - 1) << 4, 3, nv;
  return m;
}

ConformalMapResult map_from_corner(const TriMesh& m, bool flip) {
  RectangleBoundaryMap opt;
  opt.anchor_vertex = 0;
  opt.flip_dividing_edges = flip;
  return conformal_rectangle_map(m.V, m.F, opt);
}

}  // namespace

TEST(ConformalMap, EarOnTheGridBoundaryIsSplit) {
  const TriMesh m = grid_with_ear(0.5);
  const ConformalMapResult r = map_from_corner(m, false);
  EXPECT_GE(r.edges_split, 1);
  expect_valid_map(r, m, "ear");
}

TEST(ConformalMap, EarOnTheGridBoundaryIsFlippedKeepingTheInputsVertices) {
  // The same ear, default options: its interior edge 3-4 becomes the edge from the ear's tip to the
  // grid vertex above, so the map has the input's vertices (per-vertex files pair with it).
  const TriMesh m = grid_with_ear(0.5);
  const int nv = m.num_vertices();
  const ConformalMapResult r = map_from_corner(m, true);
  EXPECT_EQ(r.edges_flipped, 1);
  EXPECT_EQ(r.edges_split, 0);
  EXPECT_EQ(r.V.rows(), nv);
  const EdgeTopology t = edge_topology(r.F, nv);
  bool has_3_4 = false, has_tip_edge = false;
  for (Eigen::Index e = 0; e < t.E.rows(); ++e) {
    has_3_4 = has_3_4 || (t.E(e, 0) == 3 && t.E(e, 1) == 4);
    has_tip_edge = has_tip_edge || (t.E(e, 1) == nv - 1 && t.edge_faces[e].size() == 2);
  }
  EXPECT_FALSE(has_3_4);
  EXPECT_TRUE(has_tip_edge) << "the ear's tip now has an interior edge";
  expect_valid_map(r, m, "flipped ear");
}

TEST(ConformalMap, EarWhoseFlipWouldBeFlatIn3dIsSplit) {
  // The ear's tip straight below the grid vertex across its interior edge: one triangle of the
  // flip would have three collinear 3D vertices (no area to map), so the edge is split instead.
  const TriMesh grid = test::square_grid(6);
  int across = -1;  // the third vertex of the grid face on the edge 3-4
  for (Eigen::Index f = 0; f < grid.F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (grid.F(f, c) == 3 && grid.F(f, (c + 1) % 3) == 4) across = grid.F(f, (c + 2) % 3);
  ASSERT_GE(across, 0);
  const TriMesh m = grid_with_ear(grid.V(across, 0));
  const ConformalMapResult r = map_from_corner(m, true);
  EXPECT_EQ(r.edges_flipped, 0);
  EXPECT_EQ(r.edges_split, 1);
  EXPECT_EQ(r.V.rows(), m.num_vertices() + 1);
  expect_valid_map(r, m, "ear with a flat flip");
}

TEST(ConformalMap, RectangleOfWidthTwo) {
  const TriMesh m = test::folded_patch(16);
  RectangleBoundaryMap opt;
  opt.width = 2.0;
  const ConformalMapResult r = conformal_rectangle_map(m.V, m.F, opt);
  expect_valid_map(r, m, "rectangle");
  EXPECT_NEAR(r.UV.col(0).maxCoeff(), 2.0, 1e-15);
}

TEST(ConformalMap, HardPatchesMapWithoutFlips) {
  for (const auto& [name, m] : {std::pair{"protrusion", test::protrusion_patch()}, std::pair{"sliver", test::sliver_patch()},
                                std::pair{"comb", test::comb_patch()}, std::pair{"noisy", test::noisy_patch()}}) {
    const ConformalMapResult r = conformal_rectangle_map(m.V, m.F, RectangleBoundaryMap{});
    expect_valid_map(r, m, name);
  }
}

TEST(ConformalMap, MeanValueWeightsReproduceAPlanarMesh) {
  // Both cotangent and mean-value weights have linear precision: a planar mesh with its own
  // boundary maps to itself; uniform weights do not.
  const TriMesh m = test::uneven_disk(10, 24);
  MatrixXd P = m.V;
  P.col(2).setZero();
  const std::vector<int> loop = boundary_loops(m.F, m.num_vertices()).front();
  MatrixXd buv(loop.size(), 2);
  for (size_t k = 0; k < loop.size(); ++k) buv.row(k) = P.row(loop[k]).head<2>();
  for (HarmonicWeights w : {HarmonicWeights::Cotangent, HarmonicWeights::MeanValue}) {
    const MatrixXd uv = harmonic_map(P, m.F, loop, buv, w);
    EXPECT_LT((uv - P.leftCols(2)).cwiseAbs().maxCoeff(), 1e-10) << to_string(w);
  }
  const MatrixXd uni = harmonic_map(P, m.F, loop, buv, HarmonicWeights::Uniform);
  EXPECT_GT((uni - P.leftCols(2)).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_EQ(count_flipped(uni, m.F), 0);
}

TEST(ConformalMap, RefusesNonDisks) {
  EXPECT_THROW(conformal_rectangle_map(test::annulus_patch().V, test::annulus_patch().F, RectangleBoundaryMap{}),
               std::invalid_argument);
  EXPECT_THROW(conformal_rectangle_map(test::torus_mesh().V, test::torus_mesh().F, RectangleBoundaryMap{}),
               std::invalid_argument);
  RectangleBoundaryMap bad;
  const TriMesh m = test::square_grid(4);
  bad.anchor_vertex = 6;  // interior
  EXPECT_THROW(conformal_rectangle_map(m.V, m.F, bad), std::invalid_argument);
}

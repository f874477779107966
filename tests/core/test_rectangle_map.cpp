// Whole-brain rectangle maps: cutting a closed surface open, the inferior-medial landmark rule,
// and both map forms on small meshes with known answers.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>

#include "common/hard_meshes.h"
#include "core/conformal_map.h"
#include "core/error.h"
#include "core/metrics.h"
#include "core/rectangle_map.h"

using namespace authalic;
using authalic::test::icosphere;

namespace {


// Total |signed area| of a planar map and its extent.
double covered_area(const MatrixXd& UV, const MatrixXi& F) { return signed_face_areas_2d(UV, F).cwiseAbs().sum(); }

}  // namespace

TEST(RectangleCut, CuttingAClosedSurfaceAlongAPathGivesADisk) {
  const TriMesh m = icosphere(2);
  const std::vector<int> path = shortest_edge_path(m.V, m.F, 0, 3);
  ASSERT_GE(path.size(), 3u);
  const CutSurface cut = cut_along_path(m, path);
  const int k = static_cast<int>(path.size());
  EXPECT_EQ(cut.mesh.V.rows(), m.V.rows() + k - 2);
  EXPECT_EQ(cut.mesh.F.rows(), m.F.rows());
  const TopologyReport t = analyze_topology(cut.mesh.V, cut.mesh.F);
  EXPECT_TRUE(t.is_disk()) << t.summary();
  EXPECT_TRUE(t.is_oriented());
  // The boundary runs along both sides of the path: 2 (k - 1) edges, each interior path vertex
  // appearing once as itself and once as its copy.
  const auto loops = boundary_loops(cut.mesh.F, static_cast<int>(cut.mesh.V.rows()));
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(static_cast<int>(loops[0].size()), 2 * (k - 1));
  for (int i = 1; i + 1 < k; ++i) {
    const int copy = static_cast<int>(m.V.rows()) + i - 1;
    EXPECT_EQ(cut.vertex_origin[copy], path[i]);
    EXPECT_EQ((cut.mesh.V.row(copy) - m.V.row(path[i])).norm(), 0.0);
    EXPECT_NE(std::find(loops[0].begin(), loops[0].end(), copy), loops[0].end());
    EXPECT_NE(std::find(loops[0].begin(), loops[0].end(), path[i]), loops[0].end());
  }
  // Same 3D area: nothing was lost or doubled.
  EXPECT_NEAR(face_areas(cut.mesh.V, cut.mesh.F).sum(), face_areas(m.V, m.F).sum(), 1e-12);
}

TEST(RectangleCut, RefusesPathsThatCannotCut) {
  const TriMesh m = icosphere(1);
  const int a = m.F(0, 0), b = m.F(0, 1), c = m.F(0, 2);
  EXPECT_THROW(cut_along_path(m, {a, b}), InputError);           // too short
  EXPECT_THROW(cut_along_path(m, {a, b, a}), InputError);        // not simple
  const std::vector<int> far = shortest_edge_path(m.V, m.F, 0, 3);
  std::vector<int> jump = {far.front(), far.back(), c};          // not along edges
  EXPECT_THROW(cut_along_path(m, jump), InputError);
}

TEST(RectangleCut, ShortestEdgePathOnAGridIsStraight) {
  const TriMesh g = test::square_grid(6);  // vertices j * 7 + i
  const std::vector<int> path = shortest_edge_path(g.V, g.F, 0, 6);
  ASSERT_EQ(path.size(), 7u);
  for (int i = 0; i < 7; ++i) EXPECT_EQ(path[i], i);
}

TEST(RectangleCut, InferiorMedialLandmarksOfASphericalLeftHemisphere) {
  // A "left hemisphere" ball centred at x = -50: its medial side faces +x. The rule picks the
  // points minimising (max y - y) + (max x - x) + (z - min z), i.e. the directions
  // (1, 1, -1)/sqrt 3 (anterior) and (1, -1, -1)/sqrt 3 (posterior) from the centre.
  TriMesh m = icosphere(4);
  m.V *= 40.0;
  m.V.col(0).array() -= 50.0;
  const auto [front, back] = inferior_medial_landmarks(m.V, m.F);
  const Eigen::Vector3d centre(-50, 0, 0);
  const Eigen::Vector3d df = (m.V.row(front).transpose() - centre).normalized();
  const Eigen::Vector3d db = (m.V.row(back).transpose() - centre).normalized();
  EXPECT_GT(df.dot(Eigen::Vector3d(1, 1, -1).normalized()), std::cos(0.1));
  EXPECT_GT(db.dot(Eigen::Vector3d(1, -1, -1).normalized()), std::cos(0.1));
  // The cut path between them stays on the inferior-medial side (x > centre, z < centre).
  for (int v : inferior_medial_path(m.V, m.F, front, back)) {
    EXPECT_GT(m.V(v, 0), -50.0);
    EXPECT_LT(m.V(v, 2), 0.0);
  }
}

TEST(RectangleMap, MirroredHemispheresGiveAMirroredRectangle) {
  // Left: a folded disk; right: its mirror image (x negated, triangles reversed). Equal areas ->
  // the parts meet at x = 1 and the right part is exactly the mirror of the left.
  TriMesh left = test::folded_patch(16);
  TriMesh right = left;
  right.V.col(0) = -right.V.col(0);
  right.F.col(1).swap(right.F.col(2));
  const HemisphereRectangles r = hemisphere_rectangle_map(left, right);
  EXPECT_DOUBLE_EQ(r.split, 1.0);
  ASSERT_EQ(r.left.UV.rows(), r.right.UV.rows());
  for (Eigen::Index i = 0; i < r.left.UV.rows(); ++i) {
    EXPECT_NEAR(r.right.UV(i, 0), 2.0 - r.left.UV(i, 0), 1e-12);
    EXPECT_NEAR(r.right.UV(i, 1), r.left.UV(i, 1), 1e-12);
  }
  EXPECT_EQ(count_flipped(r.left.UV, r.left.F), 0);
  EXPECT_EQ(count_flipped(r.right.UV, r.right.F), 0);  // original (outward) triangles, no mirror
  EXPECT_NEAR(covered_area(r.left.UV, r.left.F), 1.0, 1e-9);
  EXPECT_NEAR(covered_area(r.right.UV, r.right.F), 1.0, 1e-9);
  // The anterior rule: the boundary vertex nearest the most anterior vertex starts at the top
  // middle (the flow may then slide it along the top side).
  EXPECT_NEAR(r.left.UV_initial(r.left.anchor_vertex, 0), 0.5, 1e-12);
  EXPECT_NEAR(r.left.UV_initial(r.left.anchor_vertex, 1), 1.0, 1e-12);
  EXPECT_NEAR(r.left.UV(r.left.anchor_vertex, 1), 1.0, 1e-12);
}

TEST(RectangleMap, PartWidthsAreProportionalToArea) {
  TriMesh left = test::folded_patch(14);
  TriMesh right = left;
  right.V *= 1.2;  // 1.44 x the area
  right.V.col(0) = -right.V.col(0);
  right.F.col(1).swap(right.F.col(2));
  const HemisphereRectangles r = hemisphere_rectangle_map(left, right);
  EXPECT_NEAR(r.split, 2.0 / 2.44, 1e-12);
  EXPECT_NEAR(r.left.UV.col(0).minCoeff(), 0.0, 1e-12);
  EXPECT_NEAR(r.left.UV.col(0).maxCoeff(), r.split, 1e-12);
  EXPECT_NEAR(r.right.UV.col(0).minCoeff(), r.split, 1e-12);
  EXPECT_NEAR(r.right.UV.col(0).maxCoeff(), 2.0, 1e-12);
  // Whole rectangle covered once, and area-preserving across the two parts.
  EXPECT_NEAR(covered_area(r.left.UV, r.left.F) + covered_area(r.right.UV, r.right.F), 2.0, 1e-9);
  const double la = r.left.area_mm2, ra = r.right.area_mm2;
  EXPECT_NEAR(ra / la, 1.44, 1e-9);
}

TEST(RectangleMap, RefusesHemispheresThatAreNotDisks) {
  EXPECT_THROW(hemisphere_rectangle_map(test::annulus_patch(), test::folded_patch(8)), InputError);
  EXPECT_THROW(hemisphere_rectangle_map(test::folded_patch(8), test::torus_mesh(8)), InputError);
  EXPECT_THROW(whole_brain_rectangle_map(test::folded_patch(8)), InputError);
}

TEST(RectangleMap, ClosedSurfaceFillsTheTwoToOneRectangle) {
  // An elongated closed surface (ellipsoid 1.6 x 1 x 0.8) cut along its inferior-medial side.
  TriMesh m = icosphere(4);
  m.V.col(0) *= 0.8;
  m.V.col(1) *= 1.6;
  m.V.col(2) *= 0.8;
  m.V.col(0).array() -= 2.0;  // a "left hemisphere": medial side at max x
  const WholeBrainRectangle r = whole_brain_rectangle_map(m);
  const RectanglePart& p = r.map;
  ASSERT_GE(r.cut_path.size(), 3u);
  EXPECT_EQ(count_flipped(p.UV, p.F), 0);
  // exactly [0, 2] x [0, 1], covered once
  EXPECT_NEAR(p.UV.col(0).minCoeff(), 0.0, 1e-12);
  EXPECT_NEAR(p.UV.col(0).maxCoeff(), 2.0, 1e-12);
  EXPECT_NEAR(p.UV.col(1).minCoeff(), 0.0, 1e-12);
  EXPECT_NEAR(p.UV.col(1).maxCoeff(), 1.0, 1e-12);
  EXPECT_NEAR(covered_area(p.UV, p.F), 2.0, 1e-9);
  // layout: the anterior cut end starts at the middle of the left side, the posterior one at the
  // middle of the right side (both sides of the cut have the same length); the flow may slide
  // them along their side.
  EXPECT_NEAR(p.UV_initial(r.cut_path.front(), 0), 0.0, 1e-12);
  EXPECT_NEAR(p.UV_initial(r.cut_path.front(), 1), 0.5, 1e-9);
  EXPECT_NEAR(p.UV_initial(r.cut_path.back(), 0), 2.0, 1e-9);
  EXPECT_NEAR(p.UV_initial(r.cut_path.back(), 1), 0.5, 1e-6);
  EXPECT_NEAR(p.UV(r.cut_path.front(), 0), 0.0, 1e-12);
  EXPECT_NEAR(p.UV(r.cut_path.back(), 0), 2.0, 1e-12);
  const MapMetrics mm = map_metrics(p.V, p.UV, p.F, Domain::rectangle(), 8);
  EXPECT_EQ(mm.flips, 0);
  EXPECT_LT(mm.element_cv, 0.02);
  // The part keeps the surface's area (the initial map's splits move no 3D point off its face;
  // measured 0.03% less after them).
  EXPECT_NEAR(face_areas(p.V, p.F).sum(), face_areas(m.V, m.F).sum(), 1e-3 * face_areas(m.V, m.F).sum());
}

TEST(RectangleMap, DeterministicForOneAndTwoThreads) {
  // Both forms give bit-identical maps with 1 and 2 OpenMP threads. Form (a) with the sphere-image
  // initial map, so the sphere map (conformal map, Moser flow) is covered too.
  TriMesh m = icosphere(3);
  m.V.col(1) *= 1.5;
  m.V.col(0).array() -= 2.0;
  RectangleMapOptions o;
  o.initial = RectangleInitial::Sphere;
  // A coarser flow grid keeps the test short; form (a)'s 384 x 192 grid is not a power of two, so
  // the DCT takes its cosine-matrix path, whose products are large enough for Eigen to run them
  // on several threads (the cause of a 3e-14 difference before they were split by columns).
  o.flow.grid.resolution = 192;
  const TriMesh left = test::folded_patch(12);
  TriMesh right = left;
  right.V *= 1.1;
  right.V.col(0) = -right.V.col(0);
  right.F.col(1).swap(right.F.col(2));
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const WholeBrainRectangle a1 = whole_brain_rectangle_map(m, o);
  const HemisphereRectangles b1 = hemisphere_rectangle_map(left, right, o);
  omp_set_num_threads(2);
  const WholeBrainRectangle a2 = whole_brain_rectangle_map(m, o);
  const HemisphereRectangles b2 = hemisphere_rectangle_map(left, right, o);
  omp_set_num_threads(saved);
  EXPECT_EQ(a1.initial_used, RectangleInitial::Sphere);
  EXPECT_EQ(count_flipped(a1.map.UV, a1.map.F), 0);
  EXPECT_TRUE(a1.map.F == a2.map.F);
  EXPECT_TRUE(a1.map.UV == a2.map.UV) << "max difference " << (a1.map.UV - a2.map.UV).cwiseAbs().maxCoeff();
  EXPECT_TRUE(b1.left.UV == b2.left.UV) << "max difference " << (b1.left.UV - b2.left.UV).cwiseAbs().maxCoeff();
  EXPECT_TRUE(b1.right.UV == b2.right.UV) << "max difference " << (b1.right.UV - b2.right.UV).cwiseAbs().maxCoeff();
}

// The two-hemisphere rectangle from two square maps: an affine stretch, so every face's area
// ratio changes by the same factor (the part's width) and the parts meet at w_L = 2 A_L / (A_L + A_R).
TEST(RectangleMap, RectangleFromSquareMapsIsTheirAffineStretch) {
  const TriMesh left = test::folded_patch(14);
  TriMesh right = left;
  right.V *= 1.2;  // unequal areas: the seam is not at x = 1
  right.V.col(0) = -right.V.col(0);
  right.F.col(1).swap(right.F.col(2));
  const SquareMapResult l = square_map(left.V, left.F, {}), r = square_map(right.V, right.F, {});
  const HemisphereRectangles h = hemisphere_rectangles_from_squares(l, r);
  EXPECT_NEAR(h.split, 2.0 / 2.44, 1e-9);
  const VectorXd sq = signed_face_areas_2d(l.UV, l.F), part = signed_face_areas_2d(h.left.UV, h.left.F);
  EXPECT_LT((part - h.split * sq).cwiseAbs().maxCoeff(), 1e-12);
  const VectorXd sq_r = signed_face_areas_2d(r.UV, r.F), part_r = signed_face_areas_2d(h.right.UV, h.right.F);
  EXPECT_LT((part_r - (2.0 - h.split) * sq_r).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(h.right.UV.col(0).minCoeff(), h.split, 1e-12);
  EXPECT_NEAR(h.right.UV.col(0).maxCoeff(), 2.0, 1e-12);
  // Authalic over the whole rectangle: the element CV of both parts together is the squares'.
  MatrixXd V(l.V.rows() + r.V.rows(), 3), UV(l.V.rows() + r.V.rows(), 2);
  V << h.left.V, h.right.V;
  UV << h.left.UV, h.right.UV;
  MatrixXi F(l.F.rows() + r.F.rows(), 3);
  F << h.left.F, (h.right.F.array() + static_cast<int>(l.V.rows())).matrix();
  EXPECT_LE(map_metrics(V, UV, F, Domain::rectangle(), 8).element_cv, 0.02);
}

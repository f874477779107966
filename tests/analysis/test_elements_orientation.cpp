// Element maps of a square map whose faces were turned around by the orientation rule (a right
// hemisphere): the vertices the flattening inserted are traced exactly as for a left one.
#include <gtest/gtest.h>

#include "analysis/elements.h"
#include "common/hard_meshes.h"
#include "common/test_data.h"
#include "io/surface_io.h"
#include "core/square_map.h"

using namespace authalic;
using namespace authalic::analysis;

TEST(ElementMapOrientation, MirroredHemisphereTracesItsInsertedVertices) {
  // A curved square patch with an ear on its bottom side (a triangle whose three vertices are
  // consecutive boundary vertices), which the flattening splits, and its mirror image.
  const int n = 8;
  TriMesh left = test::square_grid(n);
  const int a = 3, b = 4;  // bottom-side vertices (3/n, 0) and (4/n, 0)
  left.V.conservativeResize(left.V.rows() + 1, 3);
  left.V.row(left.V.rows() - 1) << 3.5 / n, -0.3 / n, 0.0;
  left.F.conservativeResize(left.F.rows() + 1, 3);
  left.F.row(left.F.rows() - 1) << a, static_cast<int>(left.V.rows() - 1), b;
  for (Eigen::Index v = 0; v < left.V.rows(); ++v) {
    const Eigen::Vector3d p = Eigen::Vector3d(left.V(v, 0) - 0.4, left.V(v, 1) - 0.3, 1.2).normalized();
    left.V.row(v) = (40.0 * p).transpose();
  }
  TriMesh right = left;
  right.V.col(0) *= -1.0;
  SquareMapOptions o;
  o.flow.grid.resolution = 128;
  o.flip_dividing_edges = false;  // splits, so there are inserted vertices to trace
  const SquareMapResult l = square_map(left.V, left.F, o), r = square_map(right.V, right.F, o);
  ASSERT_NE(l.faces_reversed, r.faces_reversed);
  ASSERT_GT(r.V.rows(), right.V.rows()) << "the fixture should make the flattening insert vertices";
  const VectorXd values = VectorXd::LinSpaced(right.V.rows(), 0.0, 1.0);
  for (const auto* m : {&l, &r}) {
    const TriMesh& s = m == &l ? left : right;
    const ElementMap em = prepare_element_map(s.V, s.F, m->UV, m->F, values, Domain::square(), "map");
    EXPECT_EQ(em.inserted_vertices, m->V.rows() - s.V.rows());
    // Inserted vertices sit on the surface where the flattening put them.
    EXPECT_LT((em.V3 - m->V).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(ElementMapOrientation, MirroredFsaverage5LeftHemisphereAsARightOne) {
  // The case that failed before the tracing followed the map's orientation: fsaverage5's left
  // white surface mirrored (x -> -x) with flat_left's cortex faces, mapped by square_map.
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(flat, "fsaverage5/flat_left.gii.gz");
  TriMesh right = io::read_surface(white).mesh;
  right.V.col(0) *= -1.0;
  const MatrixXi F = io::read_surface(flat).mesh.F;
  SquareMapOptions o;
  o.flip_dividing_edges = false;  // splits, so there are inserted vertices to trace
  const SquareMapResult r = square_map(right.V, F, o);
  ASSERT_TRUE(r.faces_reversed);
  ASSERT_GT(r.V.rows(), right.V.rows());
  const VectorXd values = VectorXd::Ones(right.V.rows());
  const ElementMap em = prepare_element_map(right.V, F, r.UV, r.F, values, Domain::square(), "right square map");
  EXPECT_EQ(em.inserted_vertices, r.V.rows() - right.V.rows());
  EXPECT_LT((em.V3 - r.V).cwiseAbs().maxCoeff(), 1e-6);
}

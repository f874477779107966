// Mesh toolkit: known answers on small meshes (tetrahedron, square patch, torus, cylinder).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "core/mesh.h"

using namespace authalic;

namespace {

// Unit square [0,1]^2 split into n x n cells, two triangles each, counter-clockwise.
TriMesh grid_patch(int n) {
  TriMesh m;
  m.V.resize((n + 1) * (n + 1), 3);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.V.row(j * (n + 1) + i) << double(i) / n, double(j) / n, 0.0;
  m.F.resize(2 * n * n, 3);
  int f = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.F.row(f++) << a, b, d;
      m.F.row(f++) << a, d, c;
    }
  return m;
}

TriMesh tetrahedron() {
  TriMesh m;
  m.V.resize(4, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  m.F.resize(4, 3);
  m.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  return m;
}

// Torus with n x n quads (genus 1).
TriMesh torus(int n) {
  TriMesh m;
  m.V.resize(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double u = 2 * M_PI * i / n, v = 2 * M_PI * j / n;
      m.V.row(i * n + j) << (2 + std::cos(v)) * std::cos(u), (2 + std::cos(v)) * std::sin(u), std::sin(v);
    }
  m.F.resize(2 * n * n, 3);
  int f = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = i * n + j, b = ((i + 1) % n) * n + j, c = i * n + (j + 1) % n, d = ((i + 1) % n) * n + (j + 1) % n;
      m.F.row(f++) << a, b, d;
      m.F.row(f++) << a, d, c;
    }
  return m;
}

}  // namespace

TEST(Geometry, FaceAndVertexAreasOfUnitSquareSumToOne) {
  const TriMesh m = grid_patch(4);
  EXPECT_NEAR(face_areas(m.V, m.F).sum(), 1.0, 1e-12);
  const VectorXd A = barycentric_vertex_areas(m.V, m.F);
  EXPECT_NEAR(A.sum(), 1.0, 1e-12);
  // Corner (0,0) touches two triangles of area 1/32 each: a third of each (eq. 11).
  EXPECT_NEAR(A[0], 2.0 / 32.0 / 3.0, 1e-14);
  // An interior vertex touches six triangles.
  EXPECT_NEAR(A[6], 6.0 / 32.0 / 3.0, 1e-14);
  EXPECT_TRUE((signed_face_areas_2d(m.V, m.F).array() > 0).all());
}

TEST(Geometry, CotmatrixAnnihilatesLinearFunctionsAtInteriorVertices) {
  const TriMesh m = grid_patch(5);
  const SparseMatrix L = cotmatrix(m.V, m.F);
  // Rows sum to zero (constants are in the kernel) and L is symmetric.
  const VectorXd ones = VectorXd::Ones(m.num_vertices());
  EXPECT_LT((L * ones).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((SparseMatrix(L.transpose()) - L).norm(), 1e-12);
  // A linear function is harmonic: (L x)_i = 0 at every interior vertex.
  const VectorXd x = m.V.col(0) * 2.0 + m.V.col(1) * 3.0;
  const VectorXd Lx = L * x;
  for (int j = 1; j < 5; ++j)
    for (int i = 1; i < 5; ++i) EXPECT_NEAR(Lx[j * 6 + i], 0.0, 1e-12);
  // Dirichlet energy of x = x1 on the unit square is -x^T L x = integral |grad|^2 = 1.
  EXPECT_NEAR(-m.V.col(0).dot(L * m.V.col(0)), 1.0, 1e-12);
}

TEST(Geometry, MassMatrixIsDiagonalBarycentric) {
  const TriMesh m = tetrahedron();
  const SparseMatrix M = massmatrix(m.V, m.F);
  const VectorXd A = barycentric_vertex_areas(m.V, m.F);
  for (int i = 0; i < 4; ++i) EXPECT_DOUBLE_EQ(M.coeff(i, i), A[i]);
  EXPECT_EQ(M.nonZeros(), 4);
}

TEST(Geometry, NormalsPointOutwardOnTetrahedron) {
  const TriMesh m = tetrahedron();
  const MatrixXd N = vertex_normals(m.V, m.F);
  const Eigen::RowVector3d centroid = m.V.colwise().mean();
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(N.row(i).norm(), 1.0, 1e-12);
    EXPECT_GT(N.row(i).dot(m.V.row(i) - centroid), 0.0);
  }
  const MatrixXd FN = face_normals(m.V, m.F);
  EXPECT_NEAR(FN(0, 2), -1.0, 1e-12);  // face in z = 0 looks down (outward)
}

TEST(Geometry, CornerAnglesSumToPi) {
  const TriMesh m = torus(8);
  const MatrixXd A = corner_angles(m.V, m.F);
  for (int f = 0; f < m.num_faces(); ++f) EXPECT_NEAR(A.row(f).sum(), M_PI, 1e-12);
}

TEST(Topology, SquarePatchIsADisk) {
  const TriMesh m = grid_patch(3);
  const TopologyReport r = analyze_topology(m.V, m.F);
  EXPECT_TRUE(r.is_disk()) << r.summary();
  EXPECT_EQ(r.euler_characteristic, 1);
  EXPECT_EQ(r.genus, 0);
  const auto loops = boundary_loops(m.F, m.num_vertices());
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].size(), 12u);
  // Interior on the left: the loop runs counter-clockwise, so its signed area is positive.
  double area2 = 0;
  for (std::size_t i = 0; i < loops[0].size(); ++i) {
    const int a = loops[0][i], b = loops[0][(i + 1) % loops[0].size()];
    area2 += m.V(a, 0) * m.V(b, 1) - m.V(b, 0) * m.V(a, 1);
  }
  EXPECT_NEAR(area2 / 2, 1.0, 1e-12);
}

TEST(Topology, TetrahedronIsASphereAndTorusHasGenusOne) {
  const TriMesh t = tetrahedron();
  const TopologyReport rt = analyze_topology(t.V, t.F);
  EXPECT_TRUE(rt.is_sphere()) << rt.summary();
  EXPECT_EQ(rt.num_edges, 6);
  const TriMesh g = torus(6);
  const TopologyReport rg = analyze_topology(g.V, g.F);
  EXPECT_EQ(rg.euler_characteristic, 0);
  EXPECT_EQ(rg.genus, 1);
  EXPECT_FALSE(rg.is_sphere());
  EXPECT_NE(rg.summary().find("genus 1"), std::string::npos);
}

TEST(Topology, AnnulusHasTwoBoundaryLoops) {
  TriMesh m = grid_patch(3);
  std::vector<bool> keep(m.num_faces(), true);
  keep[8] = keep[9] = false;  // the middle cell
  const Submesh s = submesh_from_faces(m, keep);
  const TopologyReport r = analyze_topology(s.mesh.V, s.mesh.F);
  EXPECT_EQ(r.num_boundary_loops, 2);
  EXPECT_EQ(r.euler_characteristic, 0);
  EXPECT_FALSE(r.is_disk());
}

TEST(Topology, DetectsComponentsNonManifoldAndOrientation) {
  // Two disjoint triangles.
  TriMesh two;
  two.V.resize(6, 3);
  two.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 0, 0, 6, 0, 0, 5, 1, 0;
  two.F.resize(2, 3);
  two.F << 0, 1, 2, 3, 4, 5;
  EXPECT_EQ(analyze_topology(two.V, two.F).num_components, 2);

  // Three triangles on one edge (0,1): non-manifold edge.
  TriMesh fin;
  fin.V.resize(5, 3);
  fin.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1;
  fin.F.resize(3, 3);
  fin.F << 0, 1, 2, 1, 0, 3, 0, 1, 4;
  EXPECT_EQ(analyze_topology(fin.V, fin.F).non_manifold_edges, 1);

  // Two triangles sharing only a vertex: pinched (non-manifold) vertex.
  TriMesh bow;
  bow.V.resize(5, 3);
  bow.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0, -1, -1, 0;
  bow.F.resize(2, 3);
  bow.F << 0, 1, 2, 0, 3, 4;
  EXPECT_EQ(analyze_topology(bow.V, bow.F).non_manifold_vertices, 1);

  // A square patch with one face reversed: inconsistent orientation, repaired exactly.
  TriMesh m = grid_patch(3);
  std::swap(m.F(8, 1), m.F(8, 2));  // face 8 is interior: all three edges shared
  EXPECT_EQ(analyze_topology(m.V, m.F).inconsistent_orientation_edges, 3);
  EXPECT_EQ(orient_faces_consistently(m.F, m.num_vertices()), 1);
  EXPECT_TRUE(analyze_topology(m.V, m.F).is_oriented());
  EXPECT_TRUE((signed_face_areas_2d(m.V, m.F).array() > 0).all());
}

TEST(Topology, EdgeFacesKnownAnswerWithAFinAndABoundary) {
  // The fin of three triangles on edge (0,1) plus a fourth triangle on edge (1,2): every edge's
  // faces, ascending, from the flat lists; edges in ascending (smaller, larger) order; FE names
  // the edge opposite each corner.
  MatrixXi F(4, 3);
  F << 0, 1, 2, 1, 0, 3, 0, 1, 4, 2, 1, 5;
  const EdgeTopology t = edge_topology(F, 6);
  const std::vector<std::pair<std::pair<int, int>, std::vector<int>>> expected = {
      {{0, 1}, {0, 1, 2}}, {{0, 2}, {0}}, {{0, 3}, {1}}, {{0, 4}, {2}}, {{1, 2}, {0, 3}},
      {{1, 3}, {1}},       {{1, 4}, {2}}, {{1, 5}, {3}}, {{2, 5}, {3}}};
  ASSERT_EQ(t.E.rows(), static_cast<Eigen::Index>(expected.size()));
  ASSERT_EQ(t.edge_faces.size(), expected.size());
  for (std::size_t e = 0; e < expected.size(); ++e) {
    const auto ei = static_cast<Eigen::Index>(e);
    EXPECT_EQ(t.E(ei, 0), expected[e].first.first) << "edge " << e;
    EXPECT_EQ(t.E(ei, 1), expected[e].first.second) << "edge " << e;
    const auto faces = t.edge_faces[ei];
    EXPECT_EQ(std::vector<int>(faces.begin(), faces.end()), expected[e].second) << "edge " << e;
  }
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int e = t.FE(f, c);
      const int a = F(f, (c + 1) % 3), b = F(f, (c + 2) % 3);
      EXPECT_EQ(t.E(e, 0), std::min(a, b));
      EXPECT_EQ(t.E(e, 1), std::max(a, b));
    }
  EXPECT_EQ(analyze_topology(MatrixXd::Random(6, 3), F).non_manifold_edges, 1);
}

TEST(Topology, DuplicateVerticesAndDegenerateFaces) {
  MatrixXd V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 0, 0, 1, 1e-9, 0;
  const VectorXi exact = duplicate_vertices(V);
  EXPECT_EQ(exact[2], 0);
  EXPECT_EQ(exact[3], 3);
  const VectorXi near = duplicate_vertices(V, 1e-6);
  EXPECT_EQ(near[3], 1);
  MatrixXi F(2, 3);
  F << 0, 1, 1, 0, 1, 3;
  // Face 0 repeats an index; face 1 has area 5e-10: kept at tolerance 0, dropped at 1e-9.
  const auto degenerate = degenerate_faces(V, F);
  ASSERT_EQ(degenerate.size(), 1u);
  EXPECT_EQ(degenerate[0], 0);
  EXPECT_EQ(degenerate_faces(V, F, 1e-9).size(), 2u);
}

TEST(Topology, HalfedgeTwinsAreAnInvolution) {
  const TriMesh m = torus(5);
  const VectorXi twin = halfedge_twins(m.F, m.num_vertices());
  for (int h = 0; h < twin.size(); ++h) {
    ASSERT_GE(twin[h], 0);  // closed surface: every half-edge has a twin
    EXPECT_EQ(twin[twin[h]], h);
    const int f = h / 3, c = h % 3, g = twin[h] / 3, d = twin[h] % 3;
    EXPECT_EQ(m.F(f, c), m.F(g, (d + 1) % 3));
    EXPECT_EQ(m.F(f, (c + 1) % 3), m.F(g, d));
  }
}

TEST(Submesh, IndexMapsRoundTrip) {
  const TriMesh m = grid_patch(4);
  std::vector<bool> vmask(m.num_vertices(), false);
  for (int v = 0; v < m.num_vertices(); ++v) vmask[v] = m.V(v, 0) <= 0.5 + 1e-12;
  const Submesh s = submesh_from_vertices(m, vmask);
  EXPECT_EQ(s.mesh.num_faces(), 16);
  for (int v = 0; v < s.mesh.num_vertices(); ++v) {
    EXPECT_EQ(s.parent_to_vertex[s.vertex_to_parent[v]], v);
    EXPECT_EQ(s.mesh.V.row(v), m.V.row(s.vertex_to_parent[v]));
  }
  for (int f = 0; f < s.mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(s.vertex_to_parent[s.mesh.F(f, c)], m.F(s.face_to_parent[f], c));
  EXPECT_NEAR(face_areas(s.mesh.V, s.mesh.F).sum(), 0.5, 1e-12);
}

TEST(Submesh, MidpointSubdivisionKeepsOriginalVerticesFirst) {
  const TriMesh t = tetrahedron();
  const TriMesh s = subdivide_midpoint(t, 2);
  EXPECT_EQ(s.num_faces(), 4 * 16);
  EXPECT_EQ(s.num_vertices(), 4 + 6 + 24);  // V' = V + E per level: 4+6=10, then 10+24=34
  EXPECT_EQ(s.V.topRows(4), t.V);
  EXPECT_NEAR(face_areas(s.V, s.F).sum(), face_areas(t.V, t.F).sum(), 1e-12);  // planar faces: area kept
  EXPECT_TRUE(analyze_topology(s.V, s.F).is_sphere());
  EXPECT_TRUE(analyze_topology(s.V, s.F).is_oriented());
}

TEST(Topology, VerticesInFaceOrderListsEachUsedVertexOnceInTheOrderFacesFirstUseIt) {
  MatrixXi F(3, 3);
  F << 5, 2, 7,  //
      7, 2, 0,   //
      0, 3, 5;   // vertices 1, 4 and 6 are unused
  EXPECT_EQ(vertices_in_face_order(F, 8), (std::vector<int>{5, 2, 7, 0, 3}));
}

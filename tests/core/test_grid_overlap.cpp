// Triangle/grid-cell overlap (core/grid_overlap): exact piece areas on the plane, tiling of the
// sphere's (longitude, z) rectangle, and independence of the thread count.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <map>

#include "common/hard_meshes.h"
#include "core/grid_overlap.h"

using namespace authalic;

namespace {

// Octahedron subdivided `levels` times, projected to the unit sphere, optionally rotated.
TriMesh octasphere(int levels, const Eigen::Matrix3d& rotation = Eigen::Matrix3d::Identity()) {
  TriMesh m;
  m.V.resize(6, 3);
  m.V << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
  m.F.resize(8, 3);
  m.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  m = subdivide_midpoint(m, levels);
  for (int i = 0; i < m.V.rows(); ++i) m.V.row(i) = (rotation * m.V.row(i).transpose().normalized()).transpose();
  return m;
}

}  // namespace

TEST(GridOverlap, TrianglePiecesHaveExactAreas) {
  MatrixXd UV(3, 2);
  UV << 0, 0, 1, 0, 0, 1;
  MatrixXi F(1, 3);
  F << 0, 1, 2;
  GridSpec grid;
  grid.cols = grid.rows = 2;
  const auto pieces = grid_overlap(UV, F, grid);
  std::map<int, double> area;
  for (const auto& p : pieces) area[p.cell] += p.domain_area;
  ASSERT_EQ(area.size(), 3u);  // cell 3 (top right) is touched only at a point
  EXPECT_NEAR(area[0], 0.25, 1e-15);
  EXPECT_NEAR(area[1], 0.125, 1e-15);
  EXPECT_NEAR(area[2], 0.125, 1e-15);
  // Pieces come sorted by cell; the centroid of the bottom-left piece (a unit square of side 1/2)
  // is (1/4, 1/4), i.e. barycentric (1/2, 1/4, 1/4).
  EXPECT_EQ(pieces[0].cell, 0);
  EXPECT_NEAR(pieces[0].bary[0], 0.5, 1e-14);
  EXPECT_NEAR(pieces[0].bary[1], 0.25, 1e-14);
  EXPECT_NEAR(pieces[0].bary[2], 0.25, 1e-14);
}

TEST(GridOverlap, ClockwiseTrianglesAndPartsOutsideTheGrid) {
  // A clockwise triangle half outside the grid: only the inside part counts, area positive.
  MatrixXd UV(3, 2);
  UV << 0.5, -0.5, 0.5, 0.5, 1.5, -0.5;
  MatrixXi F(1, 3);
  F << 0, 1, 2;
  GridSpec grid;
  grid.cols = grid.rows = 4;
  double total = 0;
  for (const auto& p : grid_overlap(UV, F, grid)) {
    EXPECT_GT(p.domain_area, 0);
    total += p.domain_area;
  }
  EXPECT_NEAR(total, 0.125, 1e-14);  // the part with y >= 0 is the triangle (0.5,0),(0.5,0.5),(1,0)
}

TEST(GridOverlap, IdentityMapOfAGridMeshGivesEqualCellsAndHandsOutEachFaceExactly) {
  const TriMesh m = test::square_grid(13);  // cell lines of the 13-grid do not align with a 5-grid
  GridSpec grid;
  grid.cols = 5;
  grid.rows = 4;
  grid.width = 1.0;
  grid.height = 1.0;
  const auto pieces = grid_overlap(m.V, m.F, grid);
  const VectorXd fa = face_areas(m.V, m.F);
  const VectorXd pa = piece_face_areas(pieces, m.num_faces());
  EXPECT_LT((pa - fa).cwiseAbs().maxCoeff(), 1e-15);
  // The "surface" is twice the map: every cell must receive twice its area.
  const VectorXd cells = cell_surface_areas(pieces, 2.0 * fa, pa, grid.num_cells());
  for (int c = 0; c < grid.num_cells(); ++c) EXPECT_NEAR(cells[c], 2.0 / 20.0, 1e-14) << "cell " << c;
  // Reconstructing each piece's centroid from its barycentric coordinates lands in its cell.
  for (const auto& p : pieces) {
    Eigen::Vector2d q = Eigen::Vector2d::Zero();
    for (int k = 0; k < 3; ++k) q += p.bary[k] * m.V.row(m.F(p.face, k)).head<2>().transpose();
    const int col = std::min(4, static_cast<int>(q.x() * 5)), row = std::min(3, static_cast<int>(q.y() * 4));
    ASSERT_EQ(p.cell, row * 5 + col);
  }
}

TEST(GridOverlap, RectangleGridOffsetOrigin) {
  // A 2x1 rectangle [−1, 1] x [2, 3] covered by two triangles, 8 x 4 cells.
  MatrixXd UV(4, 2);
  UV << -1, 2, 1, 2, 1, 3, -1, 3;
  MatrixXi F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  GridSpec grid;
  grid.cols = 8;
  grid.rows = 4;
  grid.x0 = -1;
  grid.y0 = 2;
  grid.width = 2;
  grid.height = 1;
  const auto pieces = grid_overlap(UV, F, grid);
  const VectorXd cells = cell_surface_areas(pieces, face_areas(UV, F), piece_face_areas(pieces, 2), grid.num_cells());
  for (int c = 0; c < grid.num_cells(); ++c) EXPECT_NEAR(cells[c], 2.0 / 32.0, 1e-14);
}

TEST(GridOverlap, SameResultForOneAndTwoThreads) {
  const TriMesh m = test::noisy_patch(30, 0.2);
  GridSpec grid;
  grid.cols = grid.rows = 32;
  omp_set_num_threads(1);
  const auto a = grid_overlap(m.V, m.F, grid);
  omp_set_num_threads(2);
  const auto b = grid_overlap(m.V, m.F, grid);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].face, b[i].face);
    ASSERT_EQ(a[i].cell, b[i].cell);
    ASSERT_EQ(a[i].domain_area, b[i].domain_area);
  }
  for (size_t i = 1; i < a.size(); ++i)
    ASSERT_TRUE(a[i - 1].face < a[i].face || (a[i - 1].face == a[i].face && a[i - 1].cell < a[i].cell));
}

TEST(GridOverlap, SphereCellsTileTheLongitudeZRectangle) {
  // Octahedron vertices sit on the poles and on the date line; a rotated copy has triangles that
  // surround the poles and cross the date line. Either way the pieces tile [−π, π] x [−1, 1]:
  // total 4π, every cell its share (to 1e-7 sr here: the arcs of these large faces are followed to
  // 1e-10 sr per edge, while a face inside one cell counts its exact spherical area).
  const Eigen::Matrix3d rot = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ())).toRotationMatrix();
  for (const TriMesh& m : {octasphere(3), octasphere(3, rot)}) {
    SphereGridSpec grid;
    grid.sectors = 16;
    grid.bands = 8;
    const auto pieces = sphere_grid_overlap(m.V, m.F, grid);
    VectorXd cell = VectorXd::Zero(grid.num_cells());
    for (const auto& p : pieces) cell[p.cell] += p.domain_area;
    EXPECT_NEAR(cell.sum(), 4 * M_PI, 1e-6);
    for (int c = 0; c < grid.num_cells(); ++c) EXPECT_NEAR(cell[c], 4 * M_PI / grid.num_cells(), 1e-7) << "cell " << c;
    // The sphere's own area per cell (3D triangle areas) is close to equal, as the cells are.
    const VectorXd fa = face_areas(m.V, m.F);
    const VectorXd cells3 = cell_surface_areas(pieces, fa, piece_face_areas(pieces, m.num_faces()), grid.num_cells());
    EXPECT_NEAR(cells3.sum(), fa.sum(), 1e-12);
    const double mean = cells3.mean();
    const double cv = std::sqrt((cells3.array() - mean).square().mean()) / mean;
    EXPECT_LT(cv, 0.05);
  }
}

TEST(GridOverlap, SphereBarycentricCoordinatesPointIntoTheCell) {
  const TriMesh m = octasphere(4, Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix());
  SphereGridSpec grid;
  grid.sectors = 32;
  grid.bands = 16;
  int checked = 0, inside = 0;
  for (const auto& p : sphere_grid_overlap(m.V, m.F, grid)) {
    if (p.domain_area < 1e-4) continue;  // slivers' centroids may sit on a cell edge
    Eigen::Vector3d q = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) q += p.bary[k] * m.V.row(m.F(p.face, k)).transpose();
    q.normalize();
    const int band = std::min(grid.bands - 1, static_cast<int>((q.z() + 1) / 2 * grid.bands));
    const int sector = std::min(grid.sectors - 1, static_cast<int>((std::atan2(q.y(), q.x()) + M_PI) / (2 * M_PI) * grid.sectors));
    ++checked;
    if (band * grid.sectors + sector == p.cell) ++inside;
  }
  ASSERT_GT(checked, 1000);
  EXPECT_GT(double(inside) / checked, 0.98);
}

namespace authalic {
namespace {

// A spherical triangle whose edges are great circles: one octant (a, b, c on the axes) has area
// π/2; the cells in (longitude, z) see its curved edge x + y ... exactly only if the arcs are
// followed. Octant 1 (x, y, z > 0) with the band split at z = 0.5: the part above z = 0.5 is the
// spherical cap's quarter, 2π(1 − 0.5)/4 = π/4, the part below π/4, whatever the sectors.
TEST(GridOverlap, SphereCellsFollowGreatCircleEdges) {
  TriMesh m;
  m.V.resize(3, 3);
  m.V << 1, 0, 0, 0, 1, 0, 0, 0, 1;
  m.F.resize(1, 3);
  m.F << 0, 1, 2;
  SphereGridSpec grid;
  grid.sectors = 8;  // longitude 0..π/2 is sectors 4 and 5
  grid.bands = 4;    // z in [0, 0.5) is band 2, [0.5, 1] band 3
  double band2 = 0, band3 = 0, total = 0;
  for (const auto& p : sphere_grid_overlap(m.V, m.F, grid)) {
    total += p.domain_area;
    (p.cell / grid.sectors == 2 ? band2 : band3) += p.domain_area;
  }
  EXPECT_NEAR(total, M_PI / 2, 1e-8);
  EXPECT_NEAR(band3, M_PI / 4, 1e-8);
  EXPECT_NEAR(band2, M_PI / 4, 1e-8);
}

// A sphere mapped onto itself: each element receives the sphere's own area in it, so the CV is
// only that of the mesh's discretisation (evalmap.py, closed form: 2.67e-5 for fsaverage5's
// sphere at 64 x 32; straight edges in (longitude, z) gave 1.1e-3).
TEST(GridOverlap, PerfectSphereMapHasElementCvOfTheMeshNoise) {
  const TriMesh m = octasphere(5, Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix());
  SphereGridSpec grid;
  const auto pieces = sphere_grid_overlap(m.V, m.F, grid);
  const VectorXd fa = face_areas(m.V, m.F);
  const VectorXd cells = cell_surface_areas(pieces, fa, piece_face_areas(pieces, m.num_faces()), grid.num_cells());
  const double mean = cells.mean();
  const double cv = std::sqrt((cells.array() - mean).square().mean()) / mean;
  EXPECT_LT(cv, 2e-3) << "flat chords vs the sphere: the 3D areas of an octasphere's faces vary";
  // The same cells from the spherical-triangle areas themselves (what a perfect map hands out):
  // with the arcs followed, every cell gets exactly its share.
  VectorXd omega(m.num_faces());
  for (int f = 0; f < m.num_faces(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)).normalized(), b = m.V.row(m.F(f, 1)).normalized(), c = m.V.row(m.F(f, 2)).normalized();
    omega[f] = 2 * std::atan2(std::abs(a.dot(b.cross(c))), 1 + a.dot(b) + b.dot(c) + c.dot(a));
  }
  const VectorXd exact = cell_surface_areas(pieces, omega, piece_face_areas(pieces, m.num_faces()), grid.num_cells());
  for (int c = 0; c < grid.num_cells(); ++c) ASSERT_NEAR(exact[c], 4 * M_PI / grid.num_cells(), 1e-7) << "cell " << c;
}

}  // namespace
}  // namespace authalic

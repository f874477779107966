#pragma once
// Difficult but valid (and some invalid) meshes for the map tests (issue 8). Each generator is
// deterministic and documents what makes it hard.
#include <cmath>
#include <random>

#include "core/domain.h"
#include "core/mesh.h"

namespace authalic::test {

// Icosphere: the icosahedron subdivided `levels` times, vertices on the unit sphere, outward faces.
inline TriMesh icosphere(int levels) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  TriMesh m;
  m.V.resize(12, 3);
  m.V << -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, 0, 0, -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, t, 0, -1, t, 0, 1, -t, 0, -1, -t,
      0, 1;
  m.F.resize(20, 3);
  m.F << 0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3, 9, 4, 3, 4, 2,
      3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1;
  m = subdivide_midpoint(m, levels);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) m.V.row(i).normalize();
  return m;
}

// Unit square [0,1]^2 as an n x n grid of cells, two counter-clockwise triangles per cell.
inline TriMesh square_grid(int n) {
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

// RectangleSide bits of the vertices of a mesh of the unit square (square_grid) on its sides.
inline VectorXi square_sides(const MatrixXd& V) {
  VectorXi mask = VectorXi::Zero(V.rows());
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    if (V(v, 0) == 0.0) mask[v] |= kSideLeft;
    if (V(v, 0) == 1.0) mask[v] |= kSideRight;
    if (V(v, 1) == 0.0) mask[v] |= kSideBottom;
    if (V(v, 1) == 1.0) mask[v] |= kSideTop;
  }
  return mask;
}

// A planar disk (radius 1) with a strongly non-uniform triangulation: rings crowd toward the
// centre (radius ~ (k/rings)^2), so triangle areas span about 1:1000.
inline TriMesh uneven_disk(int rings = 24, int sectors = 48) {
  TriMesh m;
  m.V.resize(1 + rings * sectors, 3);
  m.V.row(0) << 0, 0, 0;
  for (int k = 1; k <= rings; ++k) {
    const double r = std::pow(double(k) / rings, 2.0);
    for (int s = 0; s < sectors; ++s) {
      const double a = 2 * M_PI * (s + 0.5 * (k % 2)) / sectors;
      m.V.row(1 + (k - 1) * sectors + s) << r * std::cos(a), r * std::sin(a), 0.0;
    }
  }
  std::vector<Eigen::Vector3i> faces;
  for (int s = 0; s < sectors; ++s) faces.emplace_back(0, 1 + s, 1 + (s + 1) % sectors);
  for (int k = 1; k < rings; ++k)
    for (int s = 0; s < sectors; ++s) {
      const int a = 1 + (k - 1) * sectors + s, b = 1 + (k - 1) * sectors + (s + 1) % sectors;
      const int c = 1 + k * sectors + s, d = 1 + k * sectors + (s + 1) % sectors;
      if (k % 2) {  // rings are staggered by half a sector on odd k
        faces.emplace_back(a, c, d);
        faces.emplace_back(a, d, b);
      } else {
        faces.emplace_back(a, c, b);
        faces.emplace_back(b, c, d);
      }
    }
  m.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f) m.F.row(static_cast<Eigen::Index>(f)) = faces[f].transpose();
  return m;
}

// A curved "cortex-like" patch: the square grid lifted onto z = amplitude * sin(folds*pi*x) *
// sin(folds*pi*y), so the area element varies strongly across the patch.
inline TriMesh folded_patch(int n, double amplitude = 0.15, int folds = 3) {
  TriMesh m = square_grid(n);
  for (int v = 0; v < m.num_vertices(); ++v)
    m.V(v, 2) = amplitude * std::sin(folds * M_PI * m.V(v, 0)) * std::sin(folds * M_PI * m.V(v, 1));
  return m;
}

// A patch with a long thin protrusion (a finger of length `length` and width 0.1 rising out of the
// plane): the conformal factor spans orders of magnitude (DLF paper's warning).
inline TriMesh protrusion_patch(int n = 30, double length = 3.0) {
  TriMesh m = square_grid(n);
  for (int v = 0; v < m.num_vertices(); ++v) {
    const double dx = m.V(v, 0) - 0.5, dy = m.V(v, 1) - 0.5;
    const double r = std::sqrt(dx * dx + dy * dy);
    m.V(v, 2) = length * std::exp(-(r * r) / (2 * 0.04 * 0.04));
  }
  return m;
}

// Gaussian vertex noise (sigma relative to the grid spacing) on a folded patch; the boundary stays
// put so the topology and orientation stay valid.
inline TriMesh noisy_patch(int n = 30, double sigma_cells = 0.2, unsigned seed = 7) {
  TriMesh m = folded_patch(n);
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, sigma_cells / n);
  for (int v = 0; v < m.num_vertices(); ++v) {
    const double x = m.V(v, 0), y = m.V(v, 1);
    if (x <= 0 || x >= 1 || y <= 0 || y >= 1) continue;
    m.V(v, 2) += g(rng);
  }
  return m;
}

// Triangles with angles below 0.5 degree: the grid's columns are squeezed to 1/200 of a cell
// every fifth column.
inline TriMesh sliver_patch(int n = 20) {
  TriMesh m = square_grid(n);
  for (int v = 0; v < m.num_vertices(); ++v) {
    const int i = static_cast<int>(std::lround(m.V(v, 0) * n));
    if (i % 5 == 1 && i < n) m.V(v, 0) = (i - 1 + 0.005) / n;
  }
  return m;
}

// A comb-shaped patch: the square grid with slots cut from the top, so the boundary has sharp
// concave (270 degree) turns.
inline TriMesh comb_patch(int n = 24, int teeth = 4) {
  const TriMesh g = square_grid(n);
  std::vector<bool> keep(g.num_faces(), true);
  for (int f = 0; f < g.num_faces(); ++f) {
    const double cx = (g.V(g.F(f, 0), 0) + g.V(g.F(f, 1), 0) + g.V(g.F(f, 2), 0)) / 3;
    const double cy = (g.V(g.F(f, 0), 1) + g.V(g.F(f, 1), 1) + g.V(g.F(f, 2), 1)) / 3;
    const int slot = static_cast<int>(cx * 2 * teeth);
    if (cy > 0.4 && slot % 2 == 1) keep[f] = false;
  }
  return submesh_from_faces(g, keep).mesh;
}

// ---- invalid topologies (must be refused with the measured topology) ----

inline TriMesh annulus_patch(int n = 9) {
  const TriMesh g = square_grid(n);
  std::vector<bool> keep(g.num_faces(), true);
  for (int f = 0; f < g.num_faces(); ++f) {
    const double cx = (g.V(g.F(f, 0), 0) + g.V(g.F(f, 1), 0) + g.V(g.F(f, 2), 0)) / 3;
    const double cy = (g.V(g.F(f, 0), 1) + g.V(g.F(f, 1), 1) + g.V(g.F(f, 2), 1)) / 3;
    if (std::abs(cx - 0.5) < 0.2 && std::abs(cy - 0.5) < 0.2) keep[f] = false;
  }
  return submesh_from_faces(g, keep).mesh;
}

inline TriMesh two_component_patch(int n = 6) {
  const TriMesh a = square_grid(n);
  TriMesh m;
  m.V.resize(2 * a.num_vertices(), 3);
  m.V << a.V, (a.V.rowwise() + Eigen::RowVector3d(3, 0, 0));
  m.F.resize(2 * a.num_faces(), 3);
  m.F << a.F, (a.F.array() + a.num_vertices()).matrix();
  return m;
}

inline TriMesh torus_mesh(int n = 12) {
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

// The square grid plus one extra triangle hanging off an interior edge: a non-manifold edge.
inline TriMesh non_manifold_patch(int n = 6) {
  TriMesh m = square_grid(n);
  const int a = m.F(2 * n + 2, 0), b = m.F(2 * n + 2, 1);  // horizontal interior edge: two faces already
  m.V.conservativeResize(m.num_vertices() + 1, 3);
  m.V.row(m.num_vertices() - 1) = 0.5 * (m.V.row(a) + m.V.row(b)) + Eigen::RowVector3d(0, 0, 0.3);
  m.F.conservativeResize(m.num_faces() + 1, 3);
  m.F.row(m.num_faces() - 1) << a, b, m.num_vertices() - 1;
  return m;
}

// The square grid with every other face of one row reversed: inconsistent orientation (repairable).
inline TriMesh misoriented_patch(int n = 6) {
  TriMesh m = square_grid(n);
  for (int f = 2 * n; f < 4 * n; f += 3) std::swap(m.F(f, 1), m.F(f, 2));
  return m;
}

// The square grid with the vertices of one interior column duplicated for the faces on its right:
// a seam of coincident vertices, as STL triangle soups produce. It falls into two components;
// merging exactly coincident vertices repairs it.
inline TriMesh duplicated_vertex_patch(int n = 6) {
  TriMesh m = square_grid(n);
  const int col = n / 2;
  const int base = m.num_vertices();
  m.V.conservativeResize(base + n + 1, 3);
  for (int j = 0; j <= n; ++j) m.V.row(base + j) = m.V.row(j * (n + 1) + col);
  for (int f = 0; f < m.num_faces(); ++f) {
    const double cx = (m.V(m.F(f, 0), 0) + m.V(m.F(f, 1), 0) + m.V(m.F(f, 2), 0)) / 3;
    if (cx <= double(col) / n) continue;
    for (int c = 0; c < 3; ++c) {
      const int v = m.F(f, c);
      if (v < base && v % (n + 1) == col) m.F(f, c) = base + v / (n + 1);
    }
  }
  return m;
}

}  // namespace authalic::test

#pragma once
// Exact overlap of a mapped triangle mesh with the cells of a regular grid on its domain
// (the equal-area cortical elements of Zou et al. 2011, section 5.2). Each triangle is clipped
// against the cells it covers (Sutherland-Hodgman), so an element gets exactly the part of the
// cortex that maps into it, not only the vertices that fall inside.
#include <vector>

#include "core/mesh.h"

namespace authalic {

// A regular grid of cols x rows cells over [x0, x0 + width] x [y0, y0 + height] (square: 1x1,
// K x K; rectangle: 2x1, 2K x K). Cell (row, col) has id row * cols + col; row 0 is at y0 (bottom).
struct GridSpec {
  int cols = 32;
  int rows = 32;
  double x0 = 0.0, y0 = 0.0, width = 1.0, height = 1.0;
  int num_cells() const { return cols * rows; }
};

// One piece of one triangle inside one cell.
struct OverlapPiece {
  int face;             // triangle index into F
  int cell;             // cell id (row * cols + col)
  double domain_area;   // area of the piece in the domain (map units^2)
  double bary[3];       // barycentric coordinates of the piece's centroid in its triangle
};

// Pieces of every triangle of the planar map UV (#V x >=2, x,y used) with the grid cells, sorted
// by (face, cell). Parts of triangles outside the grid are dropped. Deterministic for any thread count.
std::vector<OverlapPiece> grid_overlap(const MatrixXd& UV, const MatrixXi& F, const GridSpec& grid);

// Equal-area cells on the unit sphere: `bands` bands equal in z (hence equal in area, Archimedes)
// times `sectors` equal longitude sectors (sphere elements: sectors = 2 * bands). Cell id =
// band * sectors + sector; band 0 at z = -1, sector 0 starts at longitude -pi.
struct SphereGridSpec {
  int sectors = 64;
  int bands = 32;
  int num_cells() const { return sectors * bands; }
};
// Pieces of every triangle of a sphere map (#V x 3, any radius, centred at the origin) with the
// sphere cells (computed in (longitude, z) coordinates, where the cells are rectangles and the
// map is area-preserving up to the constant 1 per steradian; triangles crossing the date line are
// split). Triangle edges are great-circle arcs, followed in (longitude, z) to 1e-10 sr, and a
// triangle inside one cell is one piece with its exact spherical area, so that domain_area (in
// steradians) is that of the spherical triangle's part in the cell.
std::vector<OverlapPiece> sphere_grid_overlap(const MatrixXd& S, const MatrixXi& F, const SphereGridSpec& grid);

// Equal-area cells on the unit disk: the cols x rows cells of the square [−1, 1]^2 carried onto
// the disk by Shirley & Chiu's concentric map (core/concentric_map.h: area x π/4 everywhere, so
// equal cells stay equal, π / (cols rows) each). Cell id = row * cols + col, row 0 at the bottom
// (y = −1) of the square. Pieces of every triangle of a disk map D (#V x >=2, the unit disk
// centred at the origin): clipped in the square, where the triangle's straight edges are curves,
// followed to 1e-11 of its area; domain_area is the piece's area on the disk (so a face's pieces
// add up to its disk area to that tolerance), bary the piece centroid's barycentric coordinates
// in the flat disk triangle. Parts outside the disk are dropped.
std::vector<OverlapPiece> disk_grid_overlap(const MatrixXd& D, const MatrixXi& F, int cols, int rows);

// Cortical area (surface units^2, mm^2 for cortex) that each cell receives: sum over pieces of
// face_area_3d(face) * piece.domain_area / face_domain_area(face).
VectorXd cell_surface_areas(const std::vector<OverlapPiece>& pieces, const VectorXd& face_area_3d,
                            const VectorXd& face_domain_area, int num_cells);

// The cells' share of a per-face measure (e.g. surface area): each face hands its measure to the
// cells in proportion to their overlap with it (#cells, id row * cols + col). Parts outside the
// grid are lost. No piece list is built (fast rasterisation for the flows); deterministic.
VectorXd rasterize_face_measure(const MatrixXd& UV, const MatrixXi& F, const VectorXd& face_measure, const GridSpec& grid);

// Domain area of each face as the sum of its pieces (#F): the face_domain_area to pass to
// cell_surface_areas when every face lies inside the grid (sphere maps, square maps), so that
// each face hands out exactly its 3D area.
VectorXd piece_face_areas(const std::vector<OverlapPiece>& pieces, int num_faces);

}  // namespace authalic

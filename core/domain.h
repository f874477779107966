#pragma once
// The target domain of a map, written once: what it is (kind), where it is (extent), how its
// boundary is parametrised, its equal-area element grid, and where its parts meet. Every map,
// metric, element table and cluster rule reads the domain from here, so a new domain (e.g. the
// disk) is one new kind in this file and its .cpp, not an edit of every caller.
//
// Kinds (Zou et al. 2011a section 4.5, Zou et al. 2011b sections 3-4):
//  - Square: [0, 1] x [0, 1], one hemisphere; elements K x K.
//  - Rectangle: [0, 2] x [0, 1] (height : width = 1 : 2), the whole brain; elements 2K x K. Two
//    hemisphere parts meet on the vertical line x = seam_x (w_L = 2 A_L / (A_L + A_R),
//    core/rectangle_map.h); one cut-open surface has no seam (seam_x NaN).
//  - Sphere: the unit sphere; elements 2K longitude sectors x K bands equal in z (equal area,
//    Archimedes), in (u, v) = ((longitude + pi) / (2 pi), (z + 1) / 2) coordinates.
//  - Disk: the unit disk centred at the origin (Zou et al. 2011a section 4.5.1), one hemisphere;
//    elements the K x K cells of the square carried onto the disk by Shirley & Chiu's concentric
//    map (core/concentric_map.h: equal-area, so the cells stay equal), in (u, v) = the point's
//    preimage in [0, 1]^2.
// Element id = row * cols + col, row 0 at the bottom (y = 0, z = -1), column 0 at x = 0
// (longitude -pi).
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/grid_overlap.h"
#include "core/mesh.h"

namespace authalic {

enum class DomainKind { Square, Rectangle, Sphere, Disk };
// "square", "rectangle", "sphere", "disk".
std::string to_string(DomainKind kind);
// Parses "square" | "rectangle" (or "rect") | "sphere" | "disk"; throws InputError("<what>: ...") otherwise.
DomainKind parse_domain_kind(const std::string& name, const std::string& what);

// Side bits of a boundary vertex of a planar domain (corners carry two).
enum RectangleSide : int { kSideBottom = 1, kSideRight = 2, kSideTop = 4, kSideLeft = 8 };

// Keeps a boundary vertex on its side (corners fixed) and any vertex inside [0, W] x [0, 1].
inline void constrain_to_rectangle(double& x, double& y, int side_mask, double width) {
  x = std::clamp(x, 0.0, width);
  y = std::clamp(y, 0.0, 1.0);
  if (side_mask & kSideLeft) x = 0.0;
  if (side_mask & kSideRight) x = width;
  if (side_mask & kSideBottom) y = 0.0;
  if (side_mask & kSideTop) y = 1.0;
}

// Perimeter coordinate of the rectangle [0, W] x [0, 1]: s in [0, 2W + 2), counter-clockwise from
// the corner (0, 0): bottom side s in [0, W), right side [W, W + 1), top side [W + 1, 2W + 1)
// (from x = W to x = 0), left side [2W + 1, 2W + 2). Values outside the range wrap around. (Any
// W: a hemisphere's square map may be computed on its share of the rectangle.)
Eigen::Vector2d rectangle_perimeter_point(double s, double width);
inline double rectangle_perimeter(double width) { return 2.0 * width + 2.0; }
// s wrapped into [0, 2W + 2), and the side (one RectangleSide bit) it lies on.
double wrap_rectangle_perimeter(double s, double width);
int rectangle_side(double s, double width);
// Perimeter coordinates of the middle of the top side, (W/2, 1), and of the left side, (0, 1/2).
inline double rectangle_top_middle(double width) { return 1.5 * width + 1.0; }
inline double rectangle_left_middle(double width) { return 2.0 * width + 1.5; }

struct Domain {
  DomainKind kind = DomainKind::Square;
  // Rectangle of two hemisphere parts: x where the left part ends and the right begins; 1 when
  // the parts are not known to differ; NaN for one cut-open surface (no seam). Unused otherwise.
  double seam_x = 1.0;

  static Domain square() { return {DomainKind::Square, 1.0}; }
  static Domain rectangle(double seam_x = 1.0) { return {DomainKind::Rectangle, seam_x}; }
  static Domain sphere() { return {DomainKind::Sphere, 1.0}; }
  static Domain disk() { return {DomainKind::Disk, 1.0}; }
  static Domain of(DomainKind kind) { return {kind, 1.0}; }

  bool planar() const { return kind != DomainKind::Sphere; }
  // The planar domains that are rectangles [0, width] x [0, 1] (square and rectangle).
  bool rectangular() const { return kind == DomainKind::Square || kind == DomainKind::Rectangle; }
  // Extent along x of the rectangular domain [0, width] x [0, 1] (the element grid's (u, v) extent
  // for the sphere: 2 x 1, as its 2K x K cells; the disk's diameter).
  double width() const { return kind == DomainKind::Square ? 1.0 : 2.0; }
  // The planar domain's bounding box [x0, x0 + width] x [y0, y0 + height]: [0, W] x [0, 1], the
  // disk's [−1, 1]^2.
  double x0() const { return kind == DomainKind::Disk ? -1.0 : 0.0; }
  double y0() const { return kind == DomainKind::Disk ? -1.0 : 0.0; }
  double height() const { return kind == DomainKind::Disk ? 2.0 : 1.0; }
  // Area: W for rectangular kinds, pi for the disk, 4 pi (steradians) for the sphere.
  double area() const { return kind == DomainKind::Disk ? M_PI : planar() ? width() : 4.0 * M_PI; }
  // Boundary of a rectangular domain (see rectangle_perimeter_point).
  double perimeter() const { return rectangle_perimeter(width()); }
  Eigen::Vector2d boundary_point(double s) const { return rectangle_perimeter_point(s, width()); }
  // A point of the domain nearest to p (rectangular: clamped onto [0, W] x [0, 1]; disk: p / |p|
  // when |p| > 1; sphere: p / |p|, or the north pole for p = 0).
  Eigen::Vector3d constrain(const Eigen::Vector3d& p) const;

  // ---- the element grid at resolution K ----
  int element_cols(int k) const { return kind == DomainKind::Square || kind == DomainKind::Disk ? k : 2 * k; }
  int element_rows(int k) const { return k; }
  // (u, v) in [0, 1]^2 of a domain point (rectangular: (x / W, y); sphere: longitude and z as
  // above; disk: the concentric map's preimage).
  Eigen::Vector2d grid_coordinates(const double* point) const;
  // Element id of a domain point (clamped onto the domain's edges).
  int element_of_point(int k, const double* point) const;
  // Pieces of the map's triangles in the K-grid's cells (D: #V x 2 planar, #V x 3 sphere), sorted
  // by (face, cell) (core/grid_overlap.h); domain_area in map units^2 (steradians on the sphere).
  std::vector<OverlapPiece> element_overlap(const MatrixXd& D, const MatrixXi& F, int k) const;

  // ---- parts and neighbours ----
  bool has_seam() const { return kind == DomainKind::Rectangle && std::isfinite(seam_x); }
  // Part of a domain x: 0 (left) or 1 (right of seam_x) on a two-part rectangle, else 0.
  int part_of_x(double x) const { return has_seam() && !(x < seam_x) ? 1 : 0; }
  // The cluster neighbour rule: two elements of the K-grid may be neighbours (8-neighbourhood)
  // only when their columns' centres lie in the same part (the hemispheres touch at the seam only
  // in the map, not in the brain). Always true without a seam.
  bool same_part(int k, int col1, int col2) const;
};

inline std::string to_string(const Domain& domain) { return to_string(domain.kind); }

// A disk map's radius: the distance from the origin of the farthest vertex of F in D (#V x >= 2).
// *problem is set to why D is not a disk map centred at the origin ("not a disk map centred at the
// origin (bounding-box centre (x, y) for radius r)": the centre more than 5 % of r away, or no
// extent), or cleared when it is one. Maps written in mm are disk maps of another radius.
double disk_map_radius(const MatrixXd& D, const MatrixXi& F, std::string* problem);

}  // namespace authalic

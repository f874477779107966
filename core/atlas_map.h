#pragma once
// Atlas correspondence for square maps (issue 14; Zou et al. 2011 section 5.2: cross-subject
// analysis "needs, as a prerequisite step, the alignment of homologous regions").
//
// The authalic square map of an atlas cortex (e.g. FreeSurfer's fsaverage) is carried to a subject
// through the subject's spherical registration (FreeSurfer's ?h.sphere.reg: each subject vertex's
// position on the atlas sphere): the subject vertex takes the barycentric interpolation of the atlas
// map over the atlas sphere triangle that contains it (central projection onto the unit sphere).
// This transferred map is the subject's starting map; the area-restoring flow (core/authalic_flow.h)
// then makes it authalic for this subject, so an element holds the same anatomy (through the
// registration) in every subject and still the same mm² of each subject's cortex.
//
// Rule for subject vertices that land outside the atlas cortex on the sphere (the subject's cortex
// label and the atlas's differ at the medial wall): they take the atlas map at the nearest point of
// the atlas cortex (the nearest point of its boundary polyline on the unit sphere, chord distance),
// i.e. a point of the square's boundary.
#include <array>
#include <string>
#include <vector>

#include "core/conformal_map.h"
#include "core/flat_registration.h"
#include "core/mesh.h"
#include "core/progress.h"
#include "core/square_map.h"

namespace authalic {

// Point location on a triangulated region of the unit sphere (a uniform 3D grid of face boxes).
// S: #S x 3 unit vectors, F: #F x 3 faces (a region of the sphere, e.g. the atlas cortex).
class SpherePointLocator {
 public:
  SpherePointLocator(const MatrixXd& S, const MatrixXi& F);
  // The face whose central projection contains direction q (any length > 0) and q's barycentric
  // coordinates in it (*bary sums to 1); -1 when no face contains q.
  int locate(const Eigen::Vector3d& q, Eigen::Vector3d* bary) const;
  // The face and barycentric coordinates of the region point nearest to q (q inside: as locate;
  // outside: the nearest point of the region's boundary edges).
  int nearest(const Eigen::Vector3d& q, Eigen::Vector3d* bary, bool* inside = nullptr) const;
  const MatrixXi& faces() const { return F_; }

 private:
  MatrixXd S_;
  MatrixXi F_;
  int n_ = 1;
  double lo_ = -1.0, h_ = 1.0;
  std::vector<int> cell_start_, cell_faces_;
  std::vector<std::array<int, 3>> boundary_;  // (face, corner a, corner b) of each boundary edge
  int cell_index(const Eigen::Vector3d& p) const;
};

// Per-vertex values (#S x k) of the locator's mesh interpolated (barycentric) at the directions Q
// (#Q x 3), outside the region at its nearest point; inside (optional): 1 where Q was inside.
MatrixXd interpolate_on_sphere(const SpherePointLocator& locator, const MatrixXd& values, const MatrixXd& Q,
                               std::vector<char>* inside = nullptr);

// Rows scaled to unit length (FreeSurfer spheres have radius 100; sphere.reg and the atlas sphere
// are compared on the unit sphere). Throws InputError for a zero row.
MatrixXd normalize_to_unit_sphere(const MatrixXd& S, const std::string& what);

struct AtlasTransfer {
  MatrixXd UV;                // #V x 2: the atlas map at each subject vertex used by F (others (0, 0))
  int outside = 0;            // subject vertices outside the atlas cortex (nearest-point rule above)
  double outside_area_share = 0;  // their share of the subject's barycentric vertex area
};

// The transfer. atlas_S: #A x 3 unit sphere positions of the atlas map's vertices, atlas_F its
// faces, atlas_UV #A x 2 its map; subject_V #V x 3 surface (mm, for the area share), subject_S
// #V x 3 unit sphere.reg positions, subject_F the subject's region faces.
AtlasTransfer transfer_atlas_map(const MatrixXd& atlas_S, const MatrixXi& atlas_F, const MatrixXd& atlas_UV,
                                 const MatrixXd& subject_V, const MatrixXd& subject_S, const MatrixXi& subject_F);

// Perimeter coordinates (core/conformal_map.h, rectangle_perimeter_point) for the boundary loop of
// the disk F (walked as conformal_rectangle_map walks it) that follow a starting map UV (#V x 2):
// each boundary vertex takes the perimeter coordinate of the rectangle-boundary point nearest to its
// UV; they are replaced by their increasing least-squares fit (pool adjacent violators) in which
// each boundary edge advances by at least min_step (> 0, < 1) of its share of the loop's 3D length
// (V #V x 3), so the coordinates increase once around it and no stretch of the boundary is bunched.
// Returns #V values (NaN off the boundary). Throws ProcessingError when UV's boundary does not wind
// once counter-clockwise around the rectangle (e.g. an atlas of the other hemisphere).
std::vector<double> boundary_perimeter_from_map(const MatrixXd& UV, const MatrixXd& V, const MatrixXi& F, double width,
                                                double min_step = 0.5);

// The starting map on the conformal map's mesh: boundary vertices keep init.UV (on their sides,
// placed by the perimeter coordinates above), interior vertices take start_uv (input vertices; the
// inserted ones interpolated like their positions), pulled 1e-9 inside the rectangle; triangles the
// transfer folds are repaired (repair_flips, then untangle_flips), and those it crushes below 5 % of
// their target area (3D share) lifted by neighbour means (the grid flow stalls on them otherwise).
// *repaired: vertices moved.
// Throws ProcessingError when folds remain.
MatrixXd start_from_map(const ConformalMapResult& init, const MatrixXd& start_uv, int* repaired);

// How far a map moved from its start, in elements of a K x K grid on the unit side: per used
// vertex |UV - UV0| * K; median, 95th percentile and maximum.
struct Displacement {
  double median = 0, p95 = 0, max = 0;
};
Displacement displacement_in_elements(const MatrixXd& UV, const MatrixXd& UV0, const MatrixXi& F, int k);

// The atlas's own authalic square map with the sphere positions of its vertices (those the map
// inserted interpolated like their surface positions, then put back on the unit sphere).
struct AtlasSquare {
  MatrixXd S;           // #A' x 3 unit sphere
  SquareMapResult map;  // V, F, UV of the atlas map
};
// atlas_V #A x 3 (mm), atlas_S #A x 3 sphere (any radius), atlas_F the atlas cortex faces (a disk).
AtlasSquare atlas_square_map(const MatrixXd& atlas_V, const MatrixXd& atlas_S, const MatrixXi& atlas_F,
                             const SquareMapOptions& options = {}, const ProgressFn& progress = {});

struct AtlasMapResult {
  SquareMapResult map;        // the subject's authalic map (UV_initial: the transferred atlas map)
  AtlasTransfer transfer;
  Displacement displacement;  // of the flow from the transferred atlas position, in elements (K = k)
};
// The subject's map in atlas correspondence: transfer_atlas_map, then square_map from that start
// (with at least 6 grid passes: the transferred start is far from authalic).
// V #V x 3 (mm), F the subject's cortex faces, sphere_reg #V x 3 (any radius: normalised).
AtlasMapResult square_map_from_atlas(const MatrixXd& V, const MatrixXi& F, const MatrixXd& sphere_reg, const AtlasSquare& atlas,
                                     SquareMapOptions options = {}, int k = 32, const ProgressFn& progress = {});

// Registration mode (issue 14 part 2; no sphere.reg, e.g. GIFTI from another pipeline): the
// subject's own authalic map (square_map), aligned to the atlas's map by the area-preserving
// deformation of core/flat_registration.h driven by both cortices' sulcal depth
// (core/sulcal_depth.h, each on its own cortex region), then made exactly authalic again by the
// flow from that start. The atlas must be of the same hemisphere (the maps' orientation rule then
// puts the frontal pole at the top middle of both).
struct RegisteredMapResult {
  SquareMapResult map;                   // the subject's map (UV_initial: the registered start)
  FlatRegistrationReport registration;
  Displacement registration_displacement;  // the registration's move from the subject's own map (elements)
  Displacement displacement;             // the flow's move from the registered start (elements)
};
// V #V x 3 (mm), F the subject's cortex faces; atlas: atlas_square_map of the same hemisphere.
RegisteredMapResult square_map_registered(const MatrixXd& V, const MatrixXi& F, const AtlasSquare& atlas, SquareMapOptions options = {},
                                          const FlatRegistrationOptions& registration = {}, int k = 32,
                                          const ProgressFn& progress = {});

}  // namespace authalic

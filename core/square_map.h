#pragma once
// One call from a cortical region (a disk on a hemisphere surface) to its authalic map on the
// unit square (or any rectangle [0, W] x [0, 1]): the square map of Zou et al. 2011a (and 2011b
// section 3) with the measure control of DLF section 5.5.
//
//   square_map(V, F_region) = authalic_flow(conformal_rectangle_map(V, F_region))
//
// Anatomical orientation rule (so homologous anatomy lands in the same part of the square across
// subjects; coordinates are RAS, i.e. +y anterior, as FreeSurfer and GIFTI surfaces are):
//  1. Faces are oriented outward (counter-clockwise seen from outside the hemisphere). When the
//     closed surface the region was cut from is given (SquareMapOptions::surface_faces), its
//     enclosed volume says which side is out (region_winding_on_closed_surface); otherwise the
//     sign of Σ (c_f − C)·n_f area_f over the region, C the centroid of all of V, which is right
//     for a whole hemisphere's cortex but not for a small region facing C (the insula). Faces
//     pointing in are reversed. The map preserves orientation, so the lateral surface faces the
//     viewer of the square (x to the right, y up), as if looking at the hemisphere from outside.
//  2. The point of the region's boundary nearest to the most anterior region vertex (largest y,
//     the frontal pole) goes to the middle of the top side, (W/2, 1); the rest of the boundary
//     follows by arc length, counter-clockwise.
//  3. Consequently a right hemisphere's map is the mirror image (x -> W − x) of the left's: both
//     are seen from their own lateral side with the frontal pole up.
// Output indexing: V's vertices first, in V's order (those outside the region stay, unused by any
// face), then the vertices inserted by corner and ear splits; faces are the region's faces with
// split ones replaced by their pieces.
#include <optional>
#include <string>

#include "core/authalic_flow.h"
#include "core/conformal_map.h"
#include "core/mesh.h"
#include "core/optimal_transport.h"
#include "core/progress.h"
#include "core/stretch_energy.h"

namespace authalic {

struct SquareMapOptions {
  double width = 1.0;        // 1: the unit square; 2: the whole-brain 2:1 rectangle; any W > 0
  FlowOptions flow;          // flow.width is set from `width`
  VectorXd density;          // optional per-vertex density (#V of the input, > 0), DLF 5.5
  bool anatomical_anchor = true;  // rule 2 above; false: anchor_vertex, else the boundary's first vertex at (0, 0)
  // Without the anatomical anchor: this boundary vertex goes to the perimeter coordinate
  // anchor_position (core/domain.h), e.g. a cut surface's anterior cut vertex to the left middle.
  int anchor_vertex = -1;
  double anchor_position = 0.0;
  bool orient_outward = true;     // rule 1 above
  // Optional: the faces (on V) of the whole surface the region was cut from, e.g. the closed
  // hemisphere of a cortex label; when it is closed, rule 1 takes the outside from it. Not owned:
  // it must outlive the square_map call.
  const MatrixXi* surface_faces = nullptr;
  bool sliding_initial_boundary = false;  // see RectangleBoundaryMap::sliding_boundary
  // Stretch-energy iterations between the conformal map and the flow (core/stretch_energy.h):
  // a roughly authalic start, so the flow only corrects what is left.
  bool stretch_start = true;
  // With the stretch-energy start: try the cotangent conformal map first (it is kept if it folds
  // nothing), or go straight to the clamped cotangent weights the stretch energy uses (one
  // factorisation less; on a native mesh the cotangent map always folds, fs741: 319 triangles).
  bool cotangent_start = true;
  StretchEnergyOptions stretch;
  // See RectangleBoundaryMap::flip_dividing_edges: true keeps the input's vertex list when every
  // dividing edge can be flipped (all fsaverage5 and fs741 regions measured); false splits them all.
  bool flip_dividing_edges = true;
  // The region's name in error messages ("region", "left hemisphere cortex", ...).
  std::string region_name = "region";
  // The caller's require_disk report of (V, F) (e.g. from reading the cortex region): the disk
  // check is then not made a second time.
  std::optional<TopologyReport> region_topology;
  // Optimal-transport refinement (core/optimal_transport.h) after the flow, then the flow again
  // from the refined map to restore exact areas: the area-preserving map that moves area the
  // least from the conformal start (lower angle distortion).
  bool optimal_transport = false;
  OptimalTransportOptions transport;
  // Optional starting map (#V x 2 in [0, W] x [0, 1] for the region's vertices; e.g. an atlas map
  // carried through a sphere registration, core/atlas_map.h): the boundary follows it instead of
  // arc length and the anchor, the interior starts at it (no stretch-energy start), and the flow
  // makes it authalic. UV_initial is then this start.
  MatrixXd start_uv;
  // With start_uv: the least step of each boundary vertex along the start's perimeter, as a share
  // of its edge's share of the boundary's 3D length (core/atlas_map.h boundary_perimeter_from_map).
  // 0.5 for a transferred atlas map, whose boundary vertices bunch where the subject's cortex
  // boundary and the atlas's differ; a start that is already a flip-free map of this surface (the
  // registration mode) keeps its boundary with a small value.
  double start_min_boundary_step = 0.5;
};

struct SquareMapResult {
  MatrixXd V;            // #V' x 3: surface positions (input's, then inserted)
  MatrixXi F;            // #F' x 3: region faces after splits (outward orientation)
  MatrixXd UV;           // #V' x 2: the authalic map, in [0, W] x [0, 1]; unused vertices (0, 0)
  MatrixXd UV_initial;   // #V' x 2: the conformal initial map
  VectorXi face_origin;  // #F': index of the region face (row of the input F) each face comes from
  VectorXi side_mask;    // #V': RectangleSide bits of boundary vertices
  int num_input_vertices = 0;
  double width = 1.0;
  double surface_area = 0;   // 3D area of the region (mm^2 for cortex)
  bool faces_reversed = false;
  int anterior_vertex = -1;  // the most anterior region vertex (rule 2)
  ConformalMapResult initial;  // split counts, weights used (V/F/UV moved into the fields above)
  StretchEnergyReport stretch;
  FlowReport flow;
  // Transport cost ∫ |x − T(x)|² dμ / ∫ dμ of UV from UV_initial (always); with the refinement,
  // transport holds its report (initial_cost: the unrefined map's cost) and flow the final flow's.
  double transport_cost = 0;
  OptimalTransportReport transport;
  int start_repaired = 0;    // with start_uv: vertices re-placed to unfold the start
  int flips = 0;             // flipped or degenerate faces of UV (0 unless something failed)
};

// "" when the region's geometry can be mapped, else what is wrong: a vertex that is not finite or
// beyond 1e6 mm, or degenerate (zero-area) triangles.
std::string region_geometry_problem(const MatrixXd& V, const MatrixXi& F);

// Rule 1: reverses every face of F when the region's faces point into the hemisphere: they wind
// inward on `surface` (the closed surface F was cut from, region_winding_on_closed_surface), or,
// when that cannot tell (no surface given, or not closed), the signed volume of the cone from the
// centroid of V over F is negative. Returns whether it reversed them.
bool orient_outward(const MatrixXd& V, MatrixXi& F, const MatrixXi* surface = nullptr);
// Rule 2, the hemisphere anchor written once: the point of the boundary of F nearest to the most
// anterior vertex of F (largest y; ties: lowest index) is placed at the middle of the top side of
// boundary.width's rectangle (sets boundary's anchor point and position). Returns that vertex.
int anterior_boundary_anchor(const MatrixXd& V, const MatrixXi& F, RectangleBoundaryMap& boundary);

// The map. V: #V x 3 (mm, RAS), F: region faces (a disk). Throws InputError when the region is
// not a disk (message from require_disk) or the density is invalid, ProcessingError if
// the result still has flipped triangles.
SquareMapResult square_map(const MatrixXd& V, const MatrixXi& F, const SquareMapOptions& options,
                           const ProgressFn& progress = {});

// Per-vertex data extended to vertices inserted on edges: row n + i = (1 - w_i) row p0 + w_i row p1,
// (p0, p1) = parents.row(i), in order (a parent may be an earlier inserted vertex). values: n x k.
MatrixXd extend_to_inserted(const MatrixXd& values, const MatrixXi& parents, const VectorXd& weight);
// Per-vertex data of the input extended to the inserted vertices (interpolated like their
// positions). values: #num_input_vertices x k.
MatrixXd extend_to_inserted(const MatrixXd& values, const ConformalMapResult& initial);

}  // namespace authalic

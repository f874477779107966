#pragma once
// Authalic map of a closed genus-0 surface onto the unit sphere through the square map, for
// native-resolution meshes whose conformal sphere crushes deep sulci beyond what the sphere's
// Moser flow can resolve (fs741 white: 221 flipped faces, element CV 0.052 by that route).
//
// The surface is cut into two disks: a cap C (about `cap_fraction` of the area, the vertices
// geodesically nearest to the surface point closest to the area centroid: on a hemisphere the
// medial wall) and the rest B. Every step below preserves area, so their composition does:
//   B: the authalic square map (core/square_map.h: conformal start, stretch energy with the
//      boundary slid by Moser passes, grid flow, per-face polish), then the square onto the disk
//      by Shirley & Chiu's concentric map (equal-area up to the constant π/4), then the disk
//      onto the north cap of area 4π a_B by the inverse Lambert azimuthal equal-area projection;
//   C: the disk with C's boundary placed where B put it (a strictly convex boundary, so a Tutte
//      embedding with positive weights cannot fold and no edge needs splitting), made authalic by
//      the stretch-energy iterations with the boundary held (core/stretch_energy.h), then onto the
//      south cap by the Lambert projection from the south pole, mirrored so the seam matches.
// The seam is the circle z = 1 − 2 a_B on both sides (a_B: B's share of the area). The joined
// map is finished on the sphere: flips repaired, one coarse Moser pass (core/sphere_flow.h) for
// the parts' boundary layers along the seam, and the per-face polish.
#include "core/concentric_map.h"
#include "core/crushed_patches.h"
#include "core/mesh.h"
#include "core/progress.h"
#include "core/sphere_flow.h"
#include "core/square_map.h"
#include "core/stretch_energy.h"

namespace authalic {

// The cap's stretch-energy iterations, boundary held. (Longer runs buy little: fs741 pial cap
// 0.085 -> 0.074 per face with 20 steps at 95 %, sphere CV 0.0124 -> 0.0112, for 2 s more.)
inline StretchEnergyOptions cap_stretch_options() {
  StretchEnergyOptions o;
  o.moser_boundary = false;
  return o;
}

// One Moser pass on a coarse background (32 cells per cube edge) after the parts are joined.
inline SphereFlowOptions coarse_sphere_flow_options() {
  SphereFlowOptions o;
  o.grid_cells = 32;
  o.max_passes = 1;
  return o;
}

// B's square map: up to 6 grid passes and 512 cells per side at every size (the sphere route was
// measured with them; its pial element CV sits near its bar, so it keeps them; with the square
// map's size rule, 256 cells, S1's sphere CV rose from 0.0040 to 0.0052).
inline SquareMapOptions sphere_square_options() {
  SquareMapOptions o;
  o.flow.grid.max_passes = 6;
  o.flow.grid.resolution = kDefaultGridResolution;
  return o;
}

struct SphereFromSquareOptions {
  double cap_fraction = 0.1;   // share of the surface area in the cap C
  // Where B's square map puts its corner (0, 0) on the seam: the seam vertex this share of the
  // seam's length past its most anterior vertex. A geometric rule, so the map does not depend on
  // the vertex order (the seam's first vertex in index order did: a permuted fs741 white moved
  // 12 mm). The square's corners are where its map can leave a crushed pocket that the sphere's
  // steps do not open (fs741 pial, corners half a side further on: one element at 0.74 of its
  // share, element CV 0.0092 against 0.0031); authalic_sphere_map tries other placements then
  // (core/sphere_map.h, kCornerOffsets).
  double corner_offset = 0.0;
  SquareMapOptions square = sphere_square_options();  // for B (orientation rules are switched off: the input is outward)
  StretchEnergyOptions cap = cap_stretch_options();  // for C (the boundary is always held)
  CrushedPatchOptions crushed;  // patches the parts' maps crushed, opened on the joined sphere
  SphereFlowOptions sphere_flow = coarse_sphere_flow_options();  // then on the whole sphere
  int polish_iterations = 8;   // per-face polish on the sphere (core/sphere_flow.h)
  // Conjugate-gradient iterations per polish step; 0: sphere_polish_cg_iterations(#F).
  int polish_cg_iterations = 0;
};

// The sphere polish's inexact Gauss-Newton steps: 100 CG iterations up to 65,536 faces, 50 above.
// Measured (sphere, element CV 64x32 / per-face mean, 50 -> 100 iterations): fsaverage5 white (S1)
// 0.0040 / 0.0079 -> 0.0027 / 0.0060, pial 0.0020 / 0.0076 -> 0.0015 / 0.0059, same CPU; fs741
// white (328k faces) 0.00066 / 0.0039 -> 0.00070 / 0.0032, pial 0.0049 / 0.0116 -> 0.0064 / 0.0121,
// +6-16 % CPU: native meshes keep 50.
int sphere_polish_cg_iterations(Eigen::Index faces);

struct SphereFromSquareReport {
  int cap_faces = 0, rest_faces = 0;
  double cap_area_fraction = 0;  // measured share of C
  int seed_vertex = -1;          // the cap's centre
  int corner_vertex = -1;        // the seam vertex at the square's corner (0, 0)
  double corner_offset = 0;      // its share of the seam's length past the most anterior seam vertex
  FlowReport square_flow;        // B's square map: its flow and stretch-energy start
  StretchEnergyReport square_stretch;
  OptimalTransportReport square_transport;  // B's optimal-transport refinement, when asked for
  StretchEnergyReport cap;       // C's stretch-energy iterations
  CrushedPatchReport crushed;    // the radial rearrangement of crushed patches
  SphereFlowReport sphere_flow;  // the coarse pass on the joined sphere
  double polish_face_error = 0;  // per-face mean |ln area ratio| after the sphere polish
};

// Inputs: V #V x 3, F #F x 3 closed, outward-oriented genus-0 surface. Output: #V x 3 points on
// the unit sphere (faces counter-clockwise seen from outside). Throws ProcessingError when the
// cut does not give two disks or a part's map folds.
MatrixXd sphere_from_square_map(const MatrixXd& V, const MatrixXi& F, const SphereFromSquareOptions& options = {},
                                SphereFromSquareReport* report = nullptr, const ProgressFn& progress = {});

}  // namespace authalic

#pragma once
// Authalic (area-preserving) map of a closed genus-0 surface onto the unit sphere:
//   1. conformal initial map by Haker et al. 2000, sections 2-3: puncture one
//      triangle, solve D x = a, D y = b with the cotangent matrix D (eqs. 5-7), inverse
//      stereographic projection (section 3.4);
//   2. Moebius normalisation: the conformal map is unique up to a Moebius transformation of the
//      sphere; the one chosen puts the area centroid (cortical area carried by each vertex) at
//      the origin, so no part of the cortex is crushed near one pole;
//   3. Moser's area-restoring flow on the sphere (core/sphere_flow.h; Zou et al. 2011 section
//      4.5.2, Dominitz & Tannenbaum 2010 section 4.2);
//   4. the anatomical orientation rule (sphere_orientation below).
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/metrics.h"
#include "core/progress.h"
#include "core/sphere_flow.h"
#include "core/sphere_from_square.h"

namespace authalic {

// Haker's conformal map with the puncture p in face `puncture_face` = ABC (Haker et al. 2000 eq. 7; the
// right-hand side a - i b holds the derivatives of the hat functions of A, B, C along the face's
// u axis (A to B) and v axis (toward C), which do not depend on where p lies in the face).
// Inputs: V #V by 3, F #F by 3 (closed, genus 0, outward oriented).
// The cotangent matrix is factorised once per mesh, so trying several punctures costs one
// back-substitution each.
class HakerConformalSolver {
 public:
  HakerConformalSolver(const MatrixXd& V, const MatrixXi& F);
  ~HakerConformalSolver();
  HakerConformalSolver(const HakerConformalSolver&) = delete;
  HakerConformalSolver& operator=(const HakerConformalSolver&) = delete;
  // The planar conformal coordinates z = x + i y (#V by 2) of Haker et al. 2000 eq. 7.
  MatrixXd planar_map(int puncture_face) const;
  // planar_map followed by inverse stereographic projection (Haker et al. 2000 section 3.4, step 3).
  MatrixXd sphere_map(int puncture_face) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Inverse stereographic projection from the plane to the unit sphere, pole at (0,0,1):
// x + i y -> (2x, 2y, r^2 - 1) / (1 + r^2).
MatrixXd inverse_stereographic(const MatrixXd& Z);

// Moebius normalisation on the unit sphere: the orientation-preserving Moebius transformation
// (a hyperbolic translation of the ball, phi_a(x) = (1-|a|^2)(x-a)/|x-a|^2 - a) after which
// sum_i w_i x_i = 0. Newton iterations on a; `max_iterations` caps the work.
// Inputs: S #V by 3 unit vectors, w #V non-negative weights (e.g. barycentric vertex areas of
// the 3D surface). Output: #V by 3 unit vectors. *residual gets |sum w x| / sum w at the end.
MatrixXd mobius_centre(const MatrixXd& S, const VectorXd& w, int max_iterations = 100, double* residual = nullptr);

// True when S covers the sphere once: no folded face and the signed spherical areas of the
// faces add up to 4π (the map's degree is 1).
bool sphere_covers_once(const MatrixXd& S, const MatrixXi& F);

// Orientation rule: the rotation R (det +1) that best aligns each vertex's sphere position with
// its direction from the surface's area centroid (area-weighted orthogonal Procrustes, Kabsch):
// maximises sum_i A_i <R s_i, (p_i - c)/|p_i - c|>. For a surface in RAS coordinates the sphere
// then has +x right, +y anterior, +z superior, like the surface itself (and like FreeSurfer's
// ?h.sphere): for a left hemisphere the lateral side faces -x, the medial wall +x.
Eigen::Matrix3d sphere_orientation(const MatrixXd& V, const MatrixXi& F, const MatrixXd& S);

// Moves the vertices of flipped sphere faces (and, if needed, their neighbours) to the
// normalised mean of their neighbours until no face is flipped or `max_rounds` is reached.
// Returns the number of vertices moved.
int repair_sphere_flips(MatrixXd& S, const MatrixXi& F, int max_rounds = 50);

// Flow: Haker's conformal sphere, Moebius centring, Moser's flow on the sphere (steps 1-4 above).
// Square: through the authalic square map of most of the surface (core/sphere_from_square.h), for
// native-resolution meshes whose conformal sphere the flow cannot resolve.
// Auto: Square, and Flow if the square route fails or its sphere is not a one-sheeted covering
// (sphere_covers_once).
enum class SphereRoute { Flow, Square, Auto };

struct SphereMapOptions {
  // Square by default: on fsaverage5 as good in element CV (white 0.0059 vs 0.0060, pial 0.0053
  // vs 0.0064) and 5x better per face (0.008 vs 0.04); on fs741 the flow route folds 221 faces.
  SphereRoute route = SphereRoute::Auto;
  SphereFromSquareOptions square_route;
  int puncture_face = -1;         // -1: best-shaped faces are tried in turn (see .cpp)
  int max_puncture_attempts = 6;  // punctures tried while the conformal map has flipped faces
  bool flow = true;               // false: stop after the conformal map (+ normalisation)
  bool orient = true;             // apply sphere_orientation
  SphereFlowOptions flow_options;
};

// The square route's corner placements: when an element of the sphere (64 x 32) holds more than
// kSquarePocketDeviation above or below the mean share (a pocket: the square map can crush one
// where its corners fall, and the sphere's steps do not open it), the route is run again with the
// square's corners further along the seam (kCornerOffsets: the first placement, then half a side
// and a quarter of a side on; 1/8 of the seam's length is half a side) until one leaves no pocket;
// the sphere with the lowest element CV is kept. Measured (bench/bench_sphere_placement.sh),
// element CV of the first placement -> the one kept: fs741 pial with the corners half a side on
// 0.0092 -> 0.0026, fs741 white with 5/8 of the seam 0.0058 -> 0.0007, fsaverage5 white with 1/4
// 0.0074 -> 0.0016. A pocket that is not the placement's doing costs the three attempts: the bulb
// on a narrow neck of fs741 white voxelised at 0.5 mm stays at 1.35-1.48 x in every placement.
constexpr double kSquarePocketDeviation = 0.10;
constexpr std::array<double, 3> kCornerOffsets = {0.0, 0.125, 0.0625};

// One attempt of the square route: its corner placement and the element areas it gave.
struct SquarePlacement {
  double corner_offset = 0;
  int corner_vertex = -1;
  bool mapped = false;       // a sphere came out (else the route threw: why)
  bool covers_once = false;  // it covers the sphere once (else why; not measured)
  std::string why;
  double element_cv = 0, element_min = 0, element_max = 0;  // 64 x 32, over the mean
};

struct SphereMapResult {
  SphereRoute route = SphereRoute::Flow;  // the route taken (Flow or Square)
  SphereFromSquareReport square_route;  // Square route only: of the placement kept
  std::vector<SquarePlacement> placements;  // Square route: each corner placement tried, in order
  std::optional<MapMetrics> metrics;  // Square route: map_metrics of `sphere` (64 x 32), measured to choose it
  std::string fallback_reason;          // Auto: why the square route was not kept ("" = it was)
  MatrixXd sphere;        // #V by 3 on the unit sphere: the authalic map
  MatrixXd conformal;     // #V by 3: the Moebius-normalised conformal map (same rotation)
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // orientation applied to both
  int puncture_face = -1;
  int puncture_attempts = 0;
  int conformal_flips = 0;      // flipped faces of the conformal map (after normalisation)
  int repaired_vertices = 0;    // vertices moved by repair_sphere_flips (conformal + final)
  int flips = 0;                // flipped faces of the final map
  double mobius_residual = 0;   // |area centroid| after normalisation
  SphereFlowReport flow;
};

// The whole pipeline. Throws InputError when the mesh is not a closed, oriented, genus-0
// manifold surface (message with its measured topology) or is oriented inward.
SphereMapResult authalic_sphere_map(const TriMesh& mesh, const SphereMapOptions& options = {},
                                    const ProgressFn& progress = {});

}  // namespace authalic

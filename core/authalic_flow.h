#pragma once
// Area-restoring flows on the rectangle [0, W] x [0, 1]: from an initial map UV of a disk mesh
// (e.g. core/conformal_map.h) to an authalic (area-preserving) or measure-controlled one.
//
// Theory (Zou et al. 2011a section 3, eq. 2-10; Moser's construction as in Dominitz &
// Tannenbaum 2010 section 4.2): let ρ be the density of the surface measure pushed to the
// domain by the current map (surface area / domain area, normalised to mean 1). With
// ρ_t = (1 − t) ρ + t, the continuity equation ∂ρ_t/∂t + div(ρ_t v_t) = 0 is solved by
//     Δg = ρ − 1 (Neumann: ∂g/∂n = 0 on the sides),   v_t = ∇g / ((1 − t) ρ + t),
// (eq. 9-10 with h_M = 1, h_Ω = ρ, written in the fixed frame of the domain). Moving every vertex
// along dx/dt = v_t(x) for t in [0, 1] carries the measure ρ dx onto the uniform measure, so the
// new map is area-preserving up to discretisation; the pass is repeated on the new map.
//
// Methods:
//  - Grid (default; the moving-mesh flow stalls on one thin triangle, measured): ρ is rasterised area-weighted onto a
//    regular grid (exact triangle/cell clipping), lightly smoothed, the Poisson problem is solved
//    by DCT (core/poisson_dct.h, exact Neumann: the normal velocity vanishes on the sides, so
//    boundary vertices slide along their side and corners stay), vertices are moved by RK4 with
//    bilinear interpolation of ∇g and ρ. Passes repeat until the per-vertex area ratio meets the
//    tolerance or the pass budget is spent.
//  - Mesh (DLF Algorithm 1; Zou et al. 2011a Algorithm 1): Δg = h_Ω − h_M with the cotangent
//    Laplacian of the flowing domain mesh after Delaunay edge flips, Neumann condition (DLF eq. 3),
//    vertex gradients by the angle-weighted mean of face gradients (Zou et al. 2011a eq. 16), displacement
//    λ ∇g with the adaptive flip-preventing step λ = θ min_t λ_t* (DLF eq. 5) or Zou's fixed-K
//    schedule (Zou et al. 2011a eq. 19), boundary vertices sliding along their side, corners fixed.
//  - Polish (after either method, on by default): Gauss-Newton steps on the per-face areas of the output
//    connectivity (face_area_newton_displacement), kept only while they lower the per-face error
//    without flipping; for the sub-cell errors a grid cannot see (native meshes). Then local
//    steps about the faces still beyond polish.far_band, judged on their own error (a few faces
//    far off, e.g. at a corner where the Neumann field vanishes, never move the global error),
//    on the log residual (an ear crushed against a side: fsaverage5 variants, docs/maps.md).
// Measure control (DLF section 5.5): an optional per-vertex density multiplies the surface area
// element, so a region of density 2 receives twice its natural share of the domain.
#include <functional>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/progress.h"

namespace authalic {

enum class FlowMethod { Grid, Mesh };
std::string to_string(FlowMethod m);

inline constexpr int kDefaultGridResolution = 512;

// The Grid method's knobs (one Moser pass: rasterise, smooth, solve, advect).
struct GridFlowOptions {
  // Cells along the unit side (nx = round(W * resolution), ny = resolution); 0: 512 here, and
  // grid_resolution_for in the square map from its stretch-energy start (core/square_map.h).
  int resolution = 0;
  int rk4_steps = 20;            // RK4 steps over t in [0, 1] per pass (20 and 80 agree to 1e-3 on benchmark B1, docs/references.md)
  // Fewer steps for a vertex whose path provably stays within a few cells (moser_grid_pass): at
  // most this many cells per step, at least 2 steps. 0: every vertex takes rk4_steps.
  double max_cells_per_step = 0.5;
  double smoothing_cells = 1.0;  // Gaussian standard deviation of the density smoothing, in cells
  // Passes beyond 3 are stopped by min_pass_gain on every mesh measured (benchmarks B1-B3, fs741
  // white and pial): `flatten`, `run` and `rectangle` take this default (they had 3 and 6).
  int max_passes = 3;
  double min_pass_gain = 0.95;   // stop after a pass that keeps more than this share of the error

  // The cells per unit side a pass uses: `resolution`, or the default when it is 0.
  int cells() const { return resolution > 0 ? resolution : kDefaultGridResolution; }
};

// The grid flow's resolution for `faces` triangles on [0, W] x [0, 1] from an almost authalic
// start (the stretch-energy start): 256 cells per unit side while the region has at most 131,072
// triangles per unit of height (two per cell), 512 above. A grid finer than the mesh only adds
// rejected passes. Measured (flatten, 512 -> 256 cells): the sample's phantom hemisphere (7,084
// faces) flow 1.24 -> 0.29 s, element CV 0.0019 -> 0.0017 (4 rejected passes -> 0); B1 flow 0.80
// -> 0.52 s, CV 0.00234 -> 0.00233; B2 CV 0.0025 -> 0.0021. Native hemispheres (~300k faces: B3,
// fs741) keep 512. Not for far-from-authalic starts (a conformal map of a cut-open closed surface
// folded 434 triangles at 256; an atlas start moved 0.9 element instead of < 0.5): they keep 512.
int grid_resolution_for(Eigen::Index faces, double width = 1.0);

// Which triangulation the Mesh method's target areas h_M are measured on.
//  - Surface: the vertex shares of the surface's own triangles (what every output is measured on).
//  - Flowing: the surface re-triangulated by the flowing mesh's Delaunay flips at each step (DLF
//    section 5.1, Zou et al. 2011a section 4.4: the surface "merely interpolated by a different
//    triangulation"); the flow converges on its own terms, not on the surface's triangles
//    (docs/maps.md, measured).
enum class MeshFlowTargets { Surface, Flowing };

// The Mesh method's knobs (DLF Algorithm 1 or Zou's fixed-K schedule).
struct MeshFlowOptions {
  int max_iterations = 200;      // mesh steps
  int fixed_steps = 0;           // > 0: Zou's fixed-K schedule (eq. 19) with K = fixed_steps steps
  bool delaunay_flips = true;    // Delaunay edge flips of the flowing domain mesh
  MeshFlowTargets targets = MeshFlowTargets::Surface;
};

// The polish after the Grid method: Gauss-Newton steps on the per-face areas.
struct PolishOptions {
  bool enabled = true;           // finish with mesh steps on the output connectivity
  int iterations = 16;           // at most; it stops at a step removing < 1 % of the per-face error (two in a row while not converged)
  double band = 0.05;            // corrects faces whose |ln area ratio| exceeds this band
  double far_band = 0.5;         // then local steps about the faces still beyond this
  // At most this many far-face steps; they stop after three steps in a row each removing < 1 % of
  // those faces' error.
  // A pocket crushed against a side opens by 5-10 % a step: the one-surface rectangle of fs741
  // white took 29 (with 16 it was left at 1.23 x an element's share, 1.10 x after 29).
  int far_iterations = 64;
  int cg_iterations = 50;        // conjugate-gradient iterations per step (inexact Newton)
  int rings = 3;                 // vertices within this many rings of an out-of-band vertex move
  // Steps keep every triangle above twice its float32 floor (single_precision_area_floor): for
  // maps stored as float32. Off for intermediate maps (the sphere's square route: there the limit
  // cost element CV, fs741 pial 0.0049 -> 0.0054).
  bool float32_floor = true;
};

struct FlowOptions {
  FlowMethod method = FlowMethod::Grid;
  double width = 1.0;  // the domain is [0, W] x [0, 1]
  // Optional per-vertex density (#V, > 0): target domain area ∝ density x surface area.
  VectorXd density;

  // Stopping rule (both methods): per-vertex |ln area ratio| mean <= tolerance_mean and 99th
  // percentile <= tolerance_p99; or no further improvement; or the iteration budget is spent.
  double tolerance_mean = 0.006;
  double tolerance_p99 = 0.01;
  double theta = 0.5;  // fraction of the critical flip-preventing step (DLF eq. 5): mesh steps and polish

  GridFlowOptions grid;
  MeshFlowOptions mesh;
  PolishOptions polish;
};

struct FlowReport {
  FlowMethod method = FlowMethod::Grid;
  int iterations = 0;            // accepted passes (Grid) or steps (Mesh)
  int rejected_passes = 0;       // Grid: attempts rejected and retried at half their fraction
  int polish_iterations = 0;
  bool converged = false;        // met the tolerance
  std::string stop_reason;       // "tolerance", "no improvement", "iteration limit", "step vanished", "stalled" (Mesh)
  std::string stall_detail;      // Mesh: the triangle limiting the step when it stalled or vanished
  int flips = 0;                 // flipped triangles of the returned map (output connectivity)
  int repaired = 0;              // vertices re-placed to remove flips
  int edge_flips = 0;            // Delaunay edge flips performed (Mesh method)
  int grid_resolution = 0;       // Grid: the cells per unit side used
  // Per-vertex |ln area ratio| (density-weighted target) before and after.
  double initial_vertex_mean = 0, initial_vertex_p99 = 0;
  double final_vertex_mean = 0, final_vertex_p99 = 0, final_vertex_max = 0;
  double flow_vertex_mean = 0;   // after the flow's passes or steps, before the polish
  std::vector<double> history_mean;  // per iteration: per-vertex mean |ln ratio|
};

struct FlowResult {
  MatrixXd UV;   // #V x 2
  FlowReport report;
};

// The flow described above. V: #V x 3 surface (mm), F: #F x 3 faces of a disk, UV0: #V x 2
// initial map into [0, W] x [0, 1] without flipped triangles, side_mask: #V RectangleSide bits
// (core/conformal_map.h) of the boundary vertices (0 for interior and unused vertices; a vertex
// with two bits is a corner and stays fixed). Deterministic for any thread count.
FlowResult authalic_flow(const MatrixXd& V, const MatrixXi& F, const MatrixXd& UV0, const VectorXi& side_mask,
                         const FlowOptions& options, const ProgressFn& progress = {});

// ---- building blocks (exposed for tests and for the sphere/rectangle maps) -----------------

// Target per-face "surface" measure: 3D area times the mean density of its corners (density
// empty = plain area), scaled so it sums to `total`.
VectorXd target_face_measure(const MatrixXd& V, const MatrixXi& F, const VectorXd& density, double total);

// Per-vertex ln(target / domain) of barycentric vertex areas, both normalised to equal totals;
// NaN for unused vertices.
VectorXd vertex_log_ratio(const VectorXd& face_target, const MatrixXd& UV, const MatrixXi& F, int num_vertices);

// One Moser pass on the grid of [0, width] x [0, 1]: rasterise, smooth, solve, advect (RK4) with
// `grid`'s resolution, smoothing and RK4 steps (per vertex: fewer where a bound of the speed
// around it allows, GridFlowOptions::max_cells_per_step). Returns the moved UV. fraction < 1: a partial pass
// that removes only that fraction of ln(density). only_moving non-empty (#V, 0/1): only those
// vertices are advected, the others keep UV (the field is still that of the whole map; used to
// slide the boundary alone, core/stretch_energy.h).
MatrixXd moser_grid_pass(const VectorXd& face_target, const MatrixXd& UV, const MatrixXi& F, const VectorXi& side_mask,
                         double width, const GridFlowOptions& grid, double fraction = 1.0,
                         const VectorXi& only_moving = VectorXi());

// Gauss-Newton (Levenberg-Marquardt) step on the per-face areas: minimise Σ_f (a_f − T_f)² / T_f
// over the free vertices, a_f the signed domain area of face f and T_f its target; the rows are
// the faces touching a free vertex, each triangle's area linear in each vertex (as above). With
// about two faces per vertex the system is square, not underdetermined like the per-vertex one,
// so the step cannot trade per-face error for per-vertex agreement (the per-vertex polish on
// fs741's 96 % mask: per-vertex mean 0.0100 -> 0.0079, per-face mean 0.023 -> 0.057).
// (Jᵀ J + μ diag) δ = −Jᵀ r with μ = 1e-3 (Marquardt's scaling). Only vertices in `free_vertex`
// move; side vertices only along their side, corners not at all.
// Inputs: UV #V x 2 map, F #F x 3 faces, face_target #F target areas (summing to the domain's),
// side_mask #V, free_vertex #V (0/1), cg_iterations: conjugate-gradient budget,
// residual: Area, (a_f − T_f)/√T_f as above, or LogArea, √T_f ln(a_f / T_f): the same to first
// order near the targets, but a crushed face costs its log, not at most T_f (the far-face steps).
// Output #V x 2 δ.
enum class FaceAreaResidual { Area, LogArea };
MatrixXd face_area_newton_displacement(const MatrixXd& UV, const MatrixXi& F, const VectorXd& face_target,
                                       const VectorXi& side_mask, const std::vector<char>& free_vertex,
                                       int cg_iterations = 50, FaceAreaResidual residual = FaceAreaResidual::Area);

// Per-vertex flip-preventing steps (the polishes' and the flow's): each vertex takes theta x the
// smallest critical step of its triangles (capped at 1); triangles that would still fall to or
// below face_limit (#F signed areas; their vertices' steps differ) halve the steps of their
// vertices until none does. A single bad triangle then slows only its own vertices, not the mesh
// (the stall measured with one global step), and no triangle can flip. theta <= 0: no
// critical-step limit, only the end state is checked (for the grid pass, whose vertices travel on
// curved paths, so the straight-path critical steps do not apply). constrain(v, x, y), if given,
// brings vertex v's new position onto its domain (a rectangle's side; the disk's polish holds its
// circle, so it passes none); it is called from several threads at once, so it must only read
// shared state. Returns UV + λ_v D_v per vertex.
MatrixXd local_step_positions(const MatrixXd& UV, const MatrixXi& F, const MatrixXd& D, double theta,
                              const VectorXd& face_limit,
                              const std::function<void(Eigen::Index, double&, double&)>& constrain = {});

// Marks (marked: #V, set to 1) the vertices of the faces whose |ln(a_f / T_f)| is beyond `band`
// (a folded face always is); returns how many faces.
int faces_outside_band(const VectorXd& target, const MatrixXd& UV, const MatrixXi& F, double band,
                       std::vector<char>& marked);

// Largest λ > 0 such that moving the triangle's vertices p_i + s d_i keeps it positively oriented
// for all s in [0, λ) (DLF section 5.4: the smallest positive root of the quadratic signed area);
// +inf if it never degenerates.
double critical_step(const Eigen::Vector2d p[3], const Eigen::Vector2d d[3]);

// Removes flipped triangles by re-placing the vertices around them: the vertices of flipped
// faces (growing by rings while needed) are set to the mean-value-weighted average of their
// neighbours with everything else fixed (DLF section 5.1: "an affine combination of the good
// vertices nearby"). Returns the number of vertices moved; *remaining = flips left.
int repair_flips(const MatrixXd& V, const MatrixXi& F, const VectorXi& side_mask, double width, MatrixXd& UV,
                 int* remaining = nullptr);

// Untangling by neighbour means in the map itself: the vertices of triangles whose signed area is
// not above min_area (#F) move to the mean of their neighbours' current positions (side vertices
// along their side only, corners fixed; Gauss-Seidel in index order), the region widened by a
// ring every 10 rounds, for up to max_rounds rounds. A small patch's fixed ring is rarely convex,
// so a harmonic re-solve of the patch (repair_flips) can fold triangles of its own; the local mean
// stays inside a nearly convex one-ring. Returns the vertices moved; *remaining = triangles left.
int untangle_flips(const MatrixXi& F, const VectorXi& side_mask, double width, const VectorXd& min_area, MatrixXd& UV,
                   int* remaining = nullptr, int max_rounds = 40);
// The same on any domain: held(v) true keeps vertex v where it is; constrain(v, x, y), if given,
// brings a moved vertex back onto the domain (the disk's untangling holds its circle, and passes
// none).
int untangle_flips(const MatrixXi& F, const VectorXd& min_area, MatrixXd& UV, const std::function<bool(Eigen::Index)>& held,
                   const std::function<void(Eigen::Index, double&, double&)>& constrain = {}, int* remaining = nullptr,
                   int max_rounds = 40);

// Per face, the signed area (in the map's units) below which its orientation may not survive
// storing the map in single precision (GIFTI coordinates are float32). Rounding moves each
// coordinate by at most half its float spacing u(·), and the signed area's first-order change is
// ½ Σ_i (|y_{i+1} − y_{i+2}| δx_i + |x_{i+2} − x_{i+1}| δy_i); the floor is four times that bound
// with δ = u/2 (room for a file scaled to mm, which changes the spacing by up to 2). Position
// aware: a sliver lying along the side x = 0 has fine spacing across it, so it is not reported
// (fs741 96 % mask: 37 such corner slivers were "thin" under a floor of 4 ε max(W, 1) x the
// longest edge, though each survives float32 by a factor of 1000). A triangle of the surface
// that is almost degenerate has an almost degenerate authalic image; at this floor it is kept
// open enough to be read back unflipped.
VectorXd single_precision_area_floor(const MatrixXd& UV, const MatrixXi& F);

// Opens the triangles whose signed area is not above min_area (#F) by the smallest move: the
// vertex opposite the longest edge is pushed off it, perpendicular, to twice the floor (a side
// vertex along its side only; corners stay), for up to max_rounds rounds. For the images of almost
// degenerate surface triangles, which the flow leaves almost degenerate. Returns the triangles left.
int open_thin_triangles(const MatrixXi& F, const VectorXi& side_mask, double width, const VectorXd& min_area, MatrixXd& UV,
                        int max_rounds = 10);

// Delaunay edge flips (planar, interior edges) until every interior edge is locally Delaunay or
// max_flips is reached; F is changed in place. Returns the number of flips.
int delaunay_flip(const MatrixXd& UV, MatrixXi& F, int max_flips = -1);

}  // namespace authalic

#pragma once
// Area-restoring flow on the unit sphere: Moser's construction (Dominitz & Tannenbaum 2010,
// Dominitz & Tannenbaum 2010 section 4.2), which is the Lie advection of Zou et al. 2011a (eqs. 9-10,
// sphere case section 4.5.2, eqs. 21-22) integrated in the fixed frame of the sphere.
//
// Given a map S of a mesh onto the unit sphere and the measure each face should occupy (its
// cortical area), let rho be the density "surface measure / sphere area" of the current map,
// normalised to mean 1. Then with
//     Delta g = rho - 1                        (Dominitz & Tannenbaum 2010: Delta Theta = 1 - mu, Theta = -g)
//     u_t     = grad g / ((1 - t) rho + t),    t in [0, 1]
// the flow d/dt x = u_t(x) pushes the measure rho dA to the uniform measure dA (continuity
// equation: d/dt[(1-t) rho + t] + div(((1-t) rho + t) u_t) = (1 - rho) + Delta g = 0).
//
// The Poisson problem is solved on a FIXED fine background mesh of the sphere (an equiangular
// cube-sphere, cotangent Laplacian factorised once), not on the moving mesh: its triangles never
// degenerate, and the measured pitfall of the moving-mesh flow (measured: one thin triangle
// throttles the adaptive step) cannot occur. The density is rasterised onto the background by
// splatting area-weighted samples of every mapped triangle into the background hat functions
// (a lumped L2 projection of the measure); vertices move by RK4 through u_t, the velocity
// projected to the tangent plane (Zou et al. 2011a eqs. 21-22) and each stage pulled back to the sphere
// (Zou et al. 2011a section 4.5.2). A pass is repeated on its own result to remove the discretisation
// error of the previous one.
#include <vector>

#include "core/mesh.h"
#include "core/progress.h"

namespace authalic {

// Equiangular cube-sphere triangulation of the unit sphere: each cube face is an n x n grid of
// cells equal in angle (tan-spaced on the cube), each cell split along its shorter diagonal.
// 6 n^2 + 2 vertices, 12 n^2 faces, counter-clockwise seen from outside. Point location is O(1).
class CubeSphereGrid {
 public:
  explicit CubeSphereGrid(int cells_per_edge);
  int cells_per_edge() const { return n_; }
  const MatrixXd& vertices() const { return V_; }  // #V x 3 unit vectors
  const MatrixXi& faces() const { return F_; }
  // The background triangle whose radial cone contains the unit vector p, and the barycentric
  // coordinates (summing to 1) of p's radial projection onto that flat triangle.
  int locate(const Eigen::Vector3d& p, Eigen::Vector3d* barycentric) const;

 private:
  int n_ = 0;
  MatrixXd V_;
  MatrixXi F_;
  std::vector<double> tan_;            // tan of the n+1 grid angles
  std::vector<int> cell_table_;        // first-guess cell of uniform bins of [-1, 1]
  std::vector<unsigned char> diagonal_;  // per cell of a face grid: 0 = (00,11) split, 1 = (10,01)
  std::vector<double> dual_;           // per face: b x c, c x a, a x b (9 doubles)
};

struct SphereFlowOptions {
  int grid_cells = 0;        // cube-sphere cells per cube edge; 0 = chosen from the mesh size
  int max_passes = 4;        // Moser passes (each: rasterise, solve, advect)
  int rk4_steps = 0;         // RK4 steps per pass; 0 = chosen from the density range so that
  double step_length = 6.0;  // ... one step moves a point at most this many background edges
                             // (3 and 6 agree to 1e-4 in per-face |ln area ratio| on fsaverage5)
  double tolerance = 0.0;    // stop when the background density's max |ln rho| is below this
                             // (0 = run max_passes passes)
};

struct SphereFlowPass {
  double rho_min = 0, rho_max = 0;     // background density range at the start of the pass
  double rho_abs_log_mean = 0;         // mean |ln rho| over background vertices (area-weighted)
  int rk4_steps = 0;
};

struct SphereFlowReport {
  int grid_cells = 0;
  int grid_vertices = 0;
  std::vector<SphereFlowPass> passes;
};

// Moser flow of a sphere map toward area preservation.
// Inputs:
//   S             #V by 3 positions on the unit sphere (a valid, unflipped map)
//   F             #F by 3 faces, counter-clockwise seen from outside
//   face_measure  #F target measure of each face (its 3D area in mm^2 for an authalic map, or
//                 area times a density for measure control); only ratios matter
// Output: #V by 3 new unit-sphere positions. Deterministic for any thread count.
MatrixXd moser_sphere_flow(const MatrixXd& S, const MatrixXi& F, const VectorXd& face_measure,
                           const SphereFlowOptions& options = {}, SphereFlowReport* report = nullptr,
                           const ProgressFn& progress = {});

// Number of faces whose flat image on the sphere is flipped or degenerate: the orientation
// det(a, b, c) = (b - a) x (c - a) . (a + b + c) is <= 0, i.e. against the outward normal.
int sphere_flipped_faces(const MatrixXd& S, const MatrixXi& F);

// sphere_flipped_faces of S and of S rounded to float32 (as a GIFTI file stores it): faces
// folded in either.
int sphere_flipped_faces_stored(const MatrixXd& S, const MatrixXi& F);

// Per-face polish of a sphere map (the sphere's counterpart of the square map's polish,
// core/authalic_flow.h): Gauss-Newton steps on the flat (chord) face areas, A_f toward the
// target share of the sphere's current total, Σ_f (A_f − T_f)² / T_f minimised over tangent
// displacements of every vertex (two per vertex, ∇_{p_i} A = ½ n̂ × (p_k − p_j)), solved by
// conjugate gradients on the Levenberg-Marquardt normal equations (μ = 1e-3 diag); the step is
// halved until no face flips and the per-face error falls; then the points are put back on the
// sphere. For the sub-triangle errors a background grid cannot see.
// Inputs: S #V x 3 unit vectors (no flipped face), F #F x 3, face_measure #F (ratios matter),
// iterations: global steps (at most; they stop when a step removes less than 1 % of the error);
// local_iterations: the local steps about the faces still far from their share that follow (at
// most; they stop when three steps in a row each remove less than 1 % of their faces' error).
// progress: one line per global step, and one for the local steps (stage "polish").
// Output: S moved. Returns the area-weighted mean |ln(A_f / T_f)| at the end.
double polish_sphere_face_areas(MatrixXd& S, const MatrixXi& F, const VectorXd& face_measure, int iterations = 8,
                                int cg_iterations = 50, int local_iterations = 40, const ProgressFn& progress = {});

}  // namespace authalic

#pragma once
// Initial (conformal) map of a disk-topology mesh onto a rectangle [0, W] x [0, 1] (W = 1: the
// unit square of Zou et al. 2011a section 4.1; W = 2: the whole-brain 2:1 rectangle of
// Zou et al. 2011b section 3.4).
//
// 1. The boundary loop is laid isometrically on the rectangle's perimeter: each boundary edge gets
//    a share of the perimeter proportional to its 3D length, starting with a chosen anchor vertex
//    at a chosen perimeter position, in the loop's orientation (interior on the left, so a mesh
//    oriented counter-clockwise seen from outside maps counter-clockwise: no mirror).
// 2. Corner splits (section 4.1): a boundary edge that spans a corner of the rectangle is broken
//    by a vertex placed exactly on the corner (its 3D position interpolated along the edge by arc
//    length), splitting the incident triangle in two.
// 3. Ear splits (section 4.1, generalised): every interior edge whose two endpoints lie on the
//    same side would be flattened onto that side (a "dividing edge" in Floater's sense: a triangle
//    with all three vertices on one side, or a chord cutting off a collapsed part). Each such edge
//    is flipped to the other diagonal of its quad when that quad is convex and the new edge is not
//    dividing (the vertex list stays the input's, so per-vertex data of the surface pairs with the
//    map); the rest are split at their 3D midpoint, which becomes an interior vertex; triangles
//    with 1, 2 or 3 split edges become 2, 3 or 4 triangles. No triangle of the result has three
//    collinear vertices.
// 4. Interior: the harmonic map with this Dirichlet boundary. With the whole boundary fixed, the
//    least-squares conformal map (Lévy et al. 2002) has the same minimiser as
//    the cotangent-weighted harmonic map (its area term depends on the boundary only), so the
//    cotangent system is solved. Cotangent weights can be negative on obtuse 3D triangles and
//    then may flip a triangle; if any triangle is flipped or degenerate, the map is recomputed
//    with Floater's mean-value weights (positive, so Tutte/Floater guarantees an embedding on the
//    convex rectangle once dividing edges are split), and with uniform weights as a last resort.
#include <algorithm>
#include <string>
#include <vector>

#include "core/domain.h"
#include "core/mesh.h"
#include "core/sparse_cholesky.h"

namespace authalic {

// The rectangle's perimeter coordinate, side bits and anchor positions: core/domain.h.


// ClampedCotangent: the cotangent weights raised to 1 % of their mean |value|, so all are
// positive (a Tutte embedding like mean-value weights, but symmetric: one Cholesky solve).
enum class HarmonicWeights { Cotangent, MeanValue, Uniform, ClampedCotangent };
std::string to_string(HarmonicWeights w);

struct RectangleBoundaryMap {
  double width = 1.0;        // W: the rectangle is [0, W] x [0, 1]
  int anchor_vertex = -1;    // boundary vertex (input index) placed at anchor_position; -1 = any
  double anchor_position = 0.0;  // perimeter coordinate of the anchor
  // Alternatively (when use_anchor_point): the point of the boundary polyline nearest to this 3D
  // point goes to anchor_position (overrides anchor_vertex).
  bool use_anchor_point = false;
  Eigen::Vector3d anchor_point = Eigen::Vector3d::Zero();
  // When the nearer endpoint of the boundary edge spanning a corner is within this fraction of
  // the edge's length from the corner, that vertex is moved onto the corner (its arc-length
  // position shifts by at most half an edge) instead of splitting the edge there. 0.5 (default)
  // always snaps, so no triangle is split at a corner: faces on inserted vertices have no 3D
  // counterpart in the input surface and drop out of independent checks (evalmap.py); 0 always
  // splits (Zou et al. 2011, section 4.1).
  double corner_snap = 0.5;
  // After the arc-length map, let the boundary vertices slide along their sides (corners and the
  // anchor fixed) and take the least-squares conformal map on that constraint set, if it has no
  // flipped triangle. Removes the non-conformal boundary layer that arc-length spacing imposes.
  bool sliding_boundary = false;
  // Weights tried when the cotangent map folds a triangle (the first that folds none is taken,
  // uniform as the last resort). ClampedCotangent suits a caller that re-solves with its own
  // positive weights anyway (the stretch-energy start): it is symmetric, so it costs a Cholesky
  // solve instead of mean-value weights' LU (fs741 pial: 0.4 s instead of 2.5 s).
  HarmonicWeights fallback = HarmonicWeights::MeanValue;
  // false: skip the cotangent map and solve with `fallback` directly (a caller that knows the
  // cotangent map would fold, or re-solves anyway: native meshes always have obtuse triangles).
  bool try_cotangent = true;
  // Resolve dividing edges (step 3) by edge flips where the quad allows it, so the map keeps the
  // input's vertex list; only the rest are split. false: split every one (Zou et al. 2011).
  bool flip_dividing_edges = true;
  // Optional (#V, NaN off the boundary): perimeter coordinates of the boundary vertices, increasing
  // once around the loop, used instead of arc length and the anchor (a boundary that follows a
  // starting map, core/atlas_map.h boundary_perimeter_from_map).
  std::vector<double> boundary_perimeter;
};

struct ConformalMapResult {
  MatrixXd V;   // #V' x 3: the input vertices (same order), then the inserted ones
  MatrixXi F;   // #F' x 3: the input faces, split ones replaced by their pieces
  MatrixXd UV;  // #V' x 2 in [0, W] x [0, 1]; vertices used by no face get (0, 0)
  VectorXi face_origin;     // #F': the input face each face is (a piece of)
  // Inserted vertex k (index num_input_vertices + k) lies at (1 − w_k) p0 + w_k p1 on the surface,
  // p0, p1 the rows of inserted_parents (indices into V, possibly earlier inserted vertices):
  // interpolate per-vertex data the same way, in order.
  MatrixXi inserted_parents;
  VectorXd inserted_weight;
  std::vector<int> boundary;  // boundary loop of F' (counter-clockwise on the rectangle)
  MatrixXd boundary_uv;       // #boundary x 2: the rectangle points of the loop's vertices (arc length)
  VectorXi side_mask;       // #V': RectangleSide bits of boundary vertices, 0 elsewhere
  int num_input_vertices = 0;
  int corner_vertices_inserted = 0;  // vertices inserted on corners (corner splits)
  int corners_snapped = 0;           // corners taken by an existing boundary vertex moved onto it
  int edges_split = 0;               // interior edges split at their midpoint (ear splits)
  int edges_flipped = 0;             // dividing edges flipped instead (same vertices, two faces changed)
  HarmonicWeights weights = HarmonicWeights::Cotangent;  // the weights of the returned map
  bool sliding = false;     // the returned map is the sliding-boundary LSCM (else arc length)
  int cotangent_flips = 0;  // flipped/degenerate triangles of the cotangent map (0 unless it fell back)
  double width = 1.0;
};

// The initial map described above. V: #V x 3 (mm), F: #F x 3 counter-clockwise seen from outside,
// one disk (checked: throws std::invalid_argument otherwise; callers give users an InputError
// first). Vertices not used by F are carried along unused.
// solver (optional): receives the factorisation of the last cotangent-type system, so a caller
// solving more systems on the same mesh (the stretch-energy start) reuses its analysis.
ConformalMapResult conformal_rectangle_map(const MatrixXd& V, const MatrixXi& F, const RectangleBoundaryMap& boundary,
                                           SpdSolver* solver = nullptr);

// Its two steps, for a caller with work that needs the mesh but not the map (square_map builds the
// stretch-energy system beside the solve). conformal_rectangle_mesh: the boundary's rectangle
// points and the corner and ear splits; the result has everything but UV, weights, sliding and
// cotangent_flips. conformal_rectangle_solve: the harmonic map of that mesh with its fallbacks;
// it reads V, F, boundary, boundary_uv and side_mask and writes only the fields the first left out.
ConformalMapResult conformal_rectangle_mesh(const MatrixXd& V, const MatrixXi& F, const RectangleBoundaryMap& boundary);
void conformal_rectangle_solve(ConformalMapResult& R, const RectangleBoundaryMap& boundary, SpdSolver* solver = nullptr);

// Harmonic map of a disk with a Dirichlet boundary: the vertices listed in `fixed` get the rows
// of `fixed_uv` (#fixed x 2); every other vertex used by F is the weighted mean of its
// neighbours. Unused vertices get (0, 0). Returns #V x 2.
MatrixXd harmonic_map(const MatrixXd& V, const MatrixXi& F, const std::vector<int>& fixed, const MatrixXd& fixed_uv,
                      HarmonicWeights weights);
// The same, factorising cotangent-type systems with `solver` (SpdSolver::refactor: its analysis
// is reused when the system has the pattern it last analysed).
MatrixXd harmonic_map(const MatrixXd& V, const MatrixXi& F, const std::vector<int>& fixed, const MatrixXd& fixed_uv,
                      HarmonicWeights weights, SpdSolver& solver);

// Least-squares conformal map onto the rectangle with boundary vertices sliding on their sides:
// u harmonic with u = 0 / W on the left / right sides and a natural (Neumann) condition on the
// bottom and top sides; v likewise with v = 0 / 1 on the bottom / top. Corners (two side bits) and
// the vertex `pinned` (or -1) keep their UV. side_mask: RectangleSide bits per vertex.
MatrixXd sliding_harmonic_map(const MatrixXd& V, const MatrixXi& F, const VectorXi& side_mask, double width,
                              const MatrixXd& UV, int pinned, HarmonicWeights weights);

// Number of triangles of a planar map with signed area <= min_area (flipped or degenerate).
int count_flipped(const MatrixXd& UV, const MatrixXi& F, double min_area = 0.0);

}  // namespace authalic

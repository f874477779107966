#pragma once
// Authalic maps of the whole brain onto the 2:1 rectangle [0, 2] x [0, 1] (height : width = 1 : 2;
// Zou et al. 2011a section 5.2; 2011b section 4), in two forms:
//
// (a) One closed genus-0 surface: cut open along a path on the inferior-medial side between two
//     landmark vertices ("sliced open along the medial plane at the bottom, without passing any
//     significant anatomical features", Zou et al. 2011b section 4), which yields a disk; the disk is
//     mapped by the square map's engine with W = 2 (core/square_map.h: boundary by arc length on
//     the perimeter, conformal interior, stretch-energy start, Moser/Lie flow on [0, 2] x [0, 1]);
//     alternatively the initial map is computed on the authalic sphere image (see below).
//     Layout: the anterior landmark at the middle of the left side (0, 0.5); both sides of the
//     cut have the same length, so the posterior landmark lands at the middle of the right side
//     (2, 0.5), one side of the cut runs along the bottom and the other along the top.
// (b) Two hemispheres (FreeSurfer convention: a left and a right surface, each with its cortex
//     face set): each is mapped like the square map onto its own part, the left hemisphere onto
//     [0, w_L] x [0, 1] and the right onto [w_L, 2] x [0, 1] with w_L = 2 A_L / (A_L + A_R)
//     (A = cortical area), so the whole rectangle is area-preserving and the parts meet on the
//     vertical line x = w_L. The right hemisphere is mapped as the mirror image of the left
//     (x negated, triangles reversed, mapped by the left-hemisphere rule, then u mirrored), so a
//     symmetric brain gives a symmetric rectangle.
//
// Anatomical rule of each hemisphere part (a disk: the cortex without the medial wall): the
// square map's (core/square_map.h anterior_boundary_anchor: the boundary point nearest to the
// most anterior cortex vertex goes to the middle of the part's top side); the map is seen from
// outside (lateral surface facing the viewer, no mirror).
#include <string>
#include <utility>
#include <vector>

#include "core/authalic_flow.h"
#include "core/mesh.h"
#include "core/square_map.h"
#include "core/progress.h"

namespace authalic {

// ---- cutting a closed surface open ------------------------------------------------------

// Landmarks of the inferior-medial cut (a documented rule, not anatomy recognition): with
// d_med = distance to the medial plane (whole brain, spanning both sides of its area centroid's
// x: |x - c_x|; a single hemisphere: distance to its medial extreme, max x for a left (c_x < 0)
// and min x for a right one) and d_inf = z - min z, the anterior landmark minimises
// (max y - y) + d_med + d_inf and the posterior one (y - min y) + d_med + d_inf. Coordinates RAS.
std::pair<int, int> inferior_medial_landmarks(const MatrixXd& V, const MatrixXi& F);

// Shortest edge path from `from` to `to` (Dijkstra, ties broken by vertex index). Edge weights
// are lengths times (1 + penalty mean of the two ends) when `vertex_penalty` is given (#V, >= 0).
std::vector<int> shortest_edge_path(const MatrixXd& V, const MatrixXi& F, int from, int to,
                                    const VectorXd* vertex_penalty = nullptr);

// The inferior-medial cut path between two vertices: shortest_edge_path with the penalty
// 4 (d_med + d_inf) / diagonal of the bounding box, so the path keeps to the inferior-medial side.
std::vector<int> inferior_medial_path(const MatrixXd& V, const MatrixXi& F, int from, int to);

struct CutSurface {
  TriMesh mesh;              // input vertices first (same order), then one copy of each interior path vertex
  VectorXi vertex_origin;    // #mesh.V: the input vertex each vertex copies
  std::vector<int> path;     // the cut path (input indices), from its first to its last vertex
  int num_input_vertices = 0;
};
// Cuts a closed, oriented, genus-0 surface open along a simple edge path of >= 3 vertices: each
// interior path vertex is duplicated and the faces on one side of the path (its left side seen
// from outside, walking from path[0]) take the copy, so the result is a disk whose boundary loop runs along
// both sides of the path. Throws InputError for a path that is not simple or not along edges.
CutSurface cut_along_path(const TriMesh& mesh, const std::vector<int>& path);

// ---- the maps -----------------------------------------------------------------------------

// Form (a): the embedding the initial (harmonic) map of the cut disk is computed on.
enum class RectangleInitial { Auto, Surface, Sphere };
std::string to_string(RectangleInitial i);

struct RectangleMapOptions {
  int cut_from = -1, cut_to = -1;  // form (a): landmark vertices (-1 = inferior_medial_landmarks)
  RectangleInitial initial = RectangleInitial::Auto;  // form (a), see whole_brain_rectangle_map
  // Form (a): plain Moser passes (moser_grid_pass) before authalic_flow, for the large transport
  // toward the slit tips (see whole_brain_rectangle_map).
  int transport_passes = 4;
  FlowOptions flow;                // width is set by the map (2, or the hemisphere's share)
};

// One mapped part: a disk (cut surface or hemisphere cortex) in rectangle coordinates.
struct RectanglePart {
  MatrixXd V;            // #V' x 3 surface positions (mm): input vertices first, then added ones
  MatrixXi F;            // #F' x 3
  MatrixXd UV;           // #V' x 2 in the rectangle [0, 2] x [0, 1] (vertices used by no face: at (x0, 0))
  MatrixXd UV_initial;   // the conformal initial map in the same coordinates
  VectorXi vertex_origin;  // #V': input vertex of each vertex (itself for input vertices; for
                           // vertices inserted on an edge, the edge's first endpoint)
  int num_input_vertices = 0;
  double x0 = 0, width = 2;  // the part's extent [x0, x0 + width] x [0, 1]
  double area_mm2 = 0;       // surface area of the part's faces
  int anchor_vertex = -1;    // boundary vertex placed by the layout rule (input index)
  FlowReport flow;
  int initial_flips = 0;
};

struct WholeBrainRectangle {
  RectanglePart map;
  std::vector<int> cut_path;  // input vertex indices
  int sphere_flips = 0;       // flipped faces of the sphere image (when it was used)
  RectangleInitial initial_used = RectangleInitial::Surface;
  int attempts = 1;           // 2 when Auto fell back to the sphere image
};
// Form (a). mesh: closed, oriented, genus-0 (InputError otherwise, with its measured topology).
// Initial map: on the cut surface itself (Surface: square_map with W = 2, anchored at the
// anterior cut vertex), or the harmonic map computed on its authalic sphere image (Sphere,
// core/sphere_map.h) followed by plain Moser passes and the flow. Auto tries Surface and falls
// back to Sphere when Surface fails or leaves flipped triangles or a mean per-face |ln area ratio|
// above 0.1. Measured (2026-12-07): Surface maps fsaverage5 white_left (0 flips, element CV
// 0.0022 at 64x32, 0.7 s) and fs741's native white and pial hemispheres (0 flips, CV 0.0096 and
// 0.0017; about 60 s, the slit tips' far faces polished); Sphere fails on both (fsaverage5: 1096
// flipped triangles, CV 0.67). The slit tips start with almost no cortex (density ~1/300 of the
// mean): the stretch-energy start does most of that transport before the flow.
WholeBrainRectangle whole_brain_rectangle_map(const TriMesh& mesh, const RectangleMapOptions& options = {},
                                              const ProgressFn& progress = {});

// Form (b). Each hemisphere: its surface and its cortex faces (a disk; InputError otherwise),
// mapped by square_map and stretched onto its share of the rectangle (rectangle_part_from_square).
struct HemisphereRectangles {
  RectanglePart left, right;
  double split = 1.0;  // w_L: the parts meet on x = split
  Domain domain() const { return Domain::rectangle(split); }  // the rectangle with its seam
};
HemisphereRectangles hemisphere_rectangle_map(const TriMesh& left_cortex, const TriMesh& right_cortex,
                                              const RectangleMapOptions& options = {}, const ProgressFn& progress = {});

// A square map (core/square_map.h) stretched affinely onto [x0, x0 + width] x [0, 1]: every
// area scales by `width`, so an authalic square stays authalic on its share of the rectangle.
RectanglePart rectangle_part_from_square(const SquareMapResult& square, double x0, double width);
// Form (b) from two square maps already computed (e.g. by the per-subject pipeline): left on
// [0, w_L], right on [w_L, 2], w_L = 2 A_L / (A_L + A_R). No map is computed again.
HemisphereRectangles hemisphere_rectangles_from_squares(const SquareMapResult& left, const SquareMapResult& right);

}  // namespace authalic

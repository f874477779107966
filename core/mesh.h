#pragma once
// Triangle meshes as plain data (libigl style): V is #V by 3 vertex positions, F is #F by 3
// vertex indices, counter-clockwise seen from outside. Everything in core/ takes and returns these.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/Sparse>

#include <algorithm>
#include <string>
#include <vector>

namespace authalic {

using MatrixXd = Eigen::MatrixXd;
using MatrixXi = Eigen::MatrixXi;
using VectorXd = Eigen::VectorXd;
using VectorXi = Eigen::VectorXi;
using SparseMatrix = Eigen::SparseMatrix<double>;

// A triangle mesh: V (#V x 3, mm for cortical surfaces), F (#F x 3, 0-based vertex indices).
struct TriMesh {
  MatrixXd V;
  MatrixXi F;
  int num_vertices() const { return static_cast<int>(V.rows()); }
  int num_faces() const { return static_cast<int>(F.rows()); }
};

// ---- geometry (core/geometry.cpp) --------------------------------------------------------

// Per-face areas |e_ij x e_ik| / 2 (#F). Works for V with 2 or 3 columns.
VectorXd face_areas(const MatrixXd& V, const MatrixXi& F);
// Signed areas of a planar map (V with >= 2 columns, x,y used): positive = counter-clockwise.
VectorXd signed_face_areas_2d(const MatrixXd& V, const MatrixXi& F);
// Barycentric vertex areas, Zou et al. eq. 11: A_i = 1/6 sum_{f ∋ i} |e_ij x e_ik| (#V).
// Vertices used by no face get 0.
VectorXd barycentric_vertex_areas(const MatrixXd& V, const MatrixXi& F);
// Cotangent Laplacian (libigl sign convention: negative semi-definite, L_ij = (cot a + cot b)/2
// for an edge, L_ii = -sum_j L_ij). Sizes #V x #V.
SparseMatrix cotmatrix(const MatrixXd& V, const MatrixXi& F);
// Lumped (diagonal) barycentric mass matrix, diag = barycentric_vertex_areas.
SparseMatrix massmatrix(const MatrixXd& V, const MatrixXi& F);
// Area-weighted unit vertex normals (#V x 3); zero rows for unused vertices.
MatrixXd vertex_normals(const MatrixXd& V, const MatrixXi& F);
// Unit face normals (#F x 3).
MatrixXd face_normals(const MatrixXd& V, const MatrixXi& F);
// Interior angles (#F x 3): column c is the angle at corner c.
MatrixXd corner_angles(const MatrixXd& V, const MatrixXi& F);

// ---- connectivity and topology (core/topology.cpp) --------------------------------------

// The faces of each edge, stored flat (one array for all edges, not one allocation per edge):
// lists[e] is edge e's faces in ascending order, one on the boundary, two inside, more at a
// non-manifold edge.
class EdgeFaceLists {
 public:
  class List {
   public:
    List(const int* first, const int* last) : first_(first), last_(last) {}
    std::size_t size() const { return static_cast<std::size_t>(last_ - first_); }
    int operator[](std::size_t i) const { return first_[i]; }
    const int* begin() const { return first_; }
    const int* end() const { return last_; }

   private:
    const int* first_;
    const int* last_;
  };
  List operator[](Eigen::Index e) const {
    return {faces_.data() + start_[static_cast<std::size_t>(e)], faces_.data() + start_[static_cast<std::size_t>(e) + 1]};
  }
  std::size_t size() const { return start_.size() - 1; }
  // Building, edge by edge: begin_edge(), then add_face() for each of its faces.
  void reserve(std::size_t edges, std::size_t entries) {
    start_.reserve(edges + 1);
    faces_.reserve(entries);
  }
  void begin_edge() { start_.push_back(start_.back()); }
  void add_face(int f) {
    faces_.push_back(f);
    ++start_.back();
  }

 private:
  std::vector<int> start_{0};  // edge e's faces: faces_[start_[e] .. start_[e + 1])
  std::vector<int> faces_;
};

// Undirected edges with their incident faces. Built once, read many times.
struct EdgeTopology {
  MatrixXi E;                // #E x 2, E(e,0) < E(e,1), rows in ascending (E(e,0), E(e,1)) order
  EdgeFaceLists edge_faces;  // faces incident to each edge
  MatrixXi FE;               // #F x 3: FE(f,c) = edge opposite corner c, i.e. (F(f,c+1), F(f,c+2))
};
EdgeTopology edge_topology(const MatrixXi& F, int num_vertices);

// Half-edge adjacency: for half-edge h = 3*f + c (from F(f,c) to F(f,(c+1)%3)), its twin or -1
// on the boundary or at a non-manifold edge.
VectorXi halfedge_twins(const MatrixXi& F, int num_vertices);

// How the faces of `region` wind relative to the outside of `surface`, the closed surface they were
// cut from (a hemisphere and its cortex label): +1 counter-clockwise seen from outside, -1 seen
// from inside, 0 when it cannot tell: `surface` is not closed and consistently oriented (every
// half-edge with exactly one opposite twin) or encloses no volume, or no edge of `region` is one
// of its edges. The outside is where the enclosed volume Σ a·(b×c)/6 is positive; the region's
// winding is that of the majority of its half-edges found in `surface`. Unlike a cone from a
// centre, right for any region, also one facing the centre (the insula, a sulcal bank).
int region_winding_on_closed_surface(const MatrixXd& V, const MatrixXi& region, const MatrixXi& surface);

// Boundary loops as ordered vertex lists, each oriented consistently with the faces (interior on the
// left), longest first. Requires an edge-manifold mesh.
std::vector<std::vector<int>> boundary_loops(const MatrixXi& F, int num_vertices);
// One-ring of every vertex: its neighbours through an edge of F, sorted and unique.
std::vector<std::vector<int>> vertex_neighbours(const MatrixXi& F, Eigen::Index num_vertices);
// The vertices F uses, in the order its faces first use them (face by face, corner by corner). A
// per-face system numbered this way touches nearby unknowns in consecutive rows, however the input
// numbers its vertices (a subdivided mesh's vertex ids are far from its faces' order).
std::vector<int> vertices_in_face_order(const MatrixXi& F, Eigen::Index num_vertices);
// Grows a vertex set (mark: #V, non-zero = in the set) by `rings` rings of neighbours (adj from
// vertex_neighbours), in place.
void grow_by_rings(std::vector<char>& mark, const std::vector<std::vector<int>>& adj, int rings);

// Geodesic distance approximated by shortest paths along the edges of `mesh` (Dijkstra), only
// through vertices with allowed[v]; unreachable vertices get +inf. mm for cortical surfaces.
VectorXd edge_path_distances(const TriMesh& mesh, const std::vector<bool>& allowed, int source);

// A map triangle whose signed area is not above this counts as flipped or degenerate: a fraction
// 1e-12 of the mean triangle area (domain_area / faces). Far above the rounding of coordinates of
// order 1 (areas ~1e-16), far below any triangle an authalic map keeps (1 / faces).
inline constexpr double kFlipAreaFraction = 1e-12;
inline double flip_area_threshold(double domain_area, Eigen::Index faces) {
  return kFlipAreaFraction * domain_area / static_cast<double>(std::max<Eigen::Index>(1, faces));
}

// Per-vertex step control (the flip-preventing steps of the flows and polishes): while some face
// is folded (folded(f) true), every vertex of such a face halves its step lam[v] and is re-placed
// (place(v) reads lam); after 30 rounds the steps of those vertices drop to 0, round after round
// until no face is folded. One bad face thus slows only its own vertices. Deterministic (index
// order). 30 halvings shrink a step by 1e-9, below any move that could unfold a face, so the step
// is then dropped. Dropping one face's vertices can fold a neighbour that kept its step, so the
// drops run until none is folded: every round stops at least one more vertex, and with every
// vertex stopped the map is the unfolded start. (They were bounded at 10 rounds: on fs741 pial's
// disk map a cascade outlived them and the polish returned 4 folded triangles.) A face folded at
// the start leaves its vertices at 0 and ends the loop once nothing else moves.
inline constexpr int kStepHalvings = 30;
template <class Folded, class Place>
void halve_steps_until_unfolded(const MatrixXi& F, VectorXd& lam, Folded folded, Place place) {
  for (Eigen::Index round = 0; round <= kStepHalvings + lam.size(); ++round) {
    std::vector<char> halve(static_cast<std::size_t>(lam.size()), 0);
    bool any = false;
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (folded(f))
        for (int c = 0; c < 3; ++c) halve[F(f, c)] = 1, any = true;
    if (!any) break;
    bool changed = false;  // false: every folded face's vertices stand still (folded at the start)
    for (Eigen::Index v = 0; v < lam.size(); ++v)
      if (halve[v] && lam[v] != 0.0) {
        lam[v] = round < kStepHalvings ? 0.5 * lam[v] : 0.0;
        place(v);
        changed = true;
      }
    if (!changed) break;
  }
}

// Connected components over faces (sharing an edge or a vertex counts as connected): per-face
// component id, ids 0..n-1 in order of first face.
VectorXi face_components(const MatrixXi& F, int num_vertices, int* num_components = nullptr);

struct TopologyReport {
  int num_vertices_used = 0;     // vertices referenced by a face
  int num_edges = 0;
  int num_faces = 0;
  int num_components = 0;
  int num_boundary_loops = 0;
  int euler_characteristic = 0;  // V - E + F over used vertices
  int genus = 0;                 // per component sum; (2 - chi - b)/2 for one component
  int non_manifold_edges = 0;    // edges with more than two faces
  int non_manifold_vertices = 0; // vertices whose faces form more than one fan
  int inconsistent_orientation_edges = 0;  // interior edges traversed the same way by both faces
  int degenerate_faces = 0;      // repeated index or zero area
  int duplicate_faces = 0;
  bool is_manifold() const { return non_manifold_edges == 0 && non_manifold_vertices == 0; }
  bool is_oriented() const { return inconsistent_orientation_edges == 0; }
  bool is_disk() const {
    return is_manifold() && num_components == 1 && num_boundary_loops == 1 && euler_characteristic == 1;
  }
  bool is_sphere() const {
    return is_manifold() && num_components == 1 && num_boundary_loops == 0 && euler_characteristic == 2;
  }
  // One line, e.g. "1 component, 0 boundary loops, Euler characteristic 0, genus 1, manifold".
  std::string summary() const;
};
TopologyReport analyze_topology(const MatrixXd& V, const MatrixXi& F);
// Empty when the report is of one consistently oriented disk (what a planar map needs); else one
// line stating the measured topology and what a planar map needs, for an InputError message.
std::string disk_topology_problem(const TopologyReport& t);
std::string disk_topology_problem(const MatrixXd& V, const MatrixXi& F);
// The disk check every planar map makes, written once: the topology report of (V, F) when it is
// one oriented disk; otherwise throws InputError("<what>: <disk_topology_problem>").
TopologyReport require_disk(const MatrixXd& V, const MatrixXi& F, const std::string& what);

// Vertices closer than `tolerance` (mm) to an earlier vertex: result(i) = index of the first copy,
// or i itself.
VectorXi duplicate_vertices(const MatrixXd& V, double tolerance = 0.0);
// Faces with a repeated index or area <= area_tolerance.
std::vector<int> degenerate_faces(const MatrixXd& V, const MatrixXi& F, double area_tolerance = 0.0);

// Flip faces so that every component is consistently oriented (BFS over edges); returns the
// number of faces flipped, or -1 when the surface is not orientable (then F is unchanged).
int orient_faces_consistently(MatrixXi& F, int num_vertices);

// ---- submeshes (core/submesh.cpp) -------------------------------------------------------

// A submesh plus index maps back to its parent.
struct Submesh {
  TriMesh mesh;
  VectorXi vertex_to_parent;  // #mesh.V: parent vertex index
  VectorXi face_to_parent;    // #mesh.F: parent face index
  VectorXi parent_to_vertex;  // #parent V: submesh vertex index or -1
};
// Keep the faces with face_mask(f) != 0 and the vertices they use (in parent order).
Submesh submesh_from_faces(const TriMesh& parent, const std::vector<bool>& face_mask);
// Keep the faces whose three vertices all have vertex_mask(v) != 0.
Submesh submesh_from_vertices(const TriMesh& parent, const std::vector<bool>& vertex_mask);

// Midpoint (1-to-4) subdivision. New edge-midpoint vertices are appended after the originals,
// so the first #V vertices of the result are the input's.
TriMesh subdivide_midpoint(const TriMesh& mesh, int times = 1);

// The triangles of `region` (a face set on mesh's vertices whose edges are edges of mesh, e.g. a
// cortex patch) subdivided on the vertex list of subdivide_midpoint(mesh, times): returns #F x 3
// faces on those vertices, each region triangle's four children in its own orientation, so
// (subdivide_midpoint(mesh), this) pair as a surface and a face set on it. Throws InputError
// when a region triangle uses an edge mesh does not have.
MatrixXi subdivide_midpoint_region(const TriMesh& mesh, const MatrixXi& region, int times = 1);

}  // namespace authalic

// Whole-brain maps onto the 2:1 rectangle: inferior-medial cut of a closed surface, or two
// hemisphere parts side by side (see rectangle_map.h). The conformal initial map and the flow are
// the square map's (core/conformal_map.h, core/authalic_flow.h) with W = 2 or the part's width.
#include "core/rectangle_map.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <stdexcept>
#include <string>
#include <tuple>

#include "core/conformal_map.h"
#include "core/error.h"
#include "core/sphere_map.h"

namespace authalic {

namespace {

using Vec3 = Eigen::Vector3d;

// Distances to the medial plane and to the lowest point (see inferior_medial_landmarks).
void inferior_medial_distances(const MatrixXd& V, const MatrixXi& F, VectorXd* d_med, VectorXd* d_inf) {
  const VectorXd w = barycentric_vertex_areas(V, F);
  const double cx = V.col(0).dot(w) / w.sum();
  double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin, zmin = xmin;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if (!(w[i] > 0)) continue;
    xmin = std::min(xmin, V(i, 0));
    xmax = std::max(xmax, V(i, 0));
    zmin = std::min(zmin, V(i, 2));
  }
  const double span = xmax - xmin;
  // A whole brain spans both sides of the RAS midline x = 0 (each side at least a quarter of its
  // width); its medial plane is x = c_x. Otherwise a hemisphere, whose medial side faces x = 0.
  const bool whole = xmin < -0.25 * span && xmax > 0.25 * span;
  d_med->resize(V.rows());
  d_inf->resize(V.rows());
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const double x = V(i, 0);
    (*d_med)[i] = whole ? std::abs(x - cx) : (cx < 0 ? xmax - x : x - xmin);
    (*d_inf)[i] = V(i, 2) - zmin;
  }
}

double bounding_diagonal(const MatrixXd& V) {
  return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm();
}


}  // namespace

std::string to_string(RectangleInitial i) {
  switch (i) {
    case RectangleInitial::Auto: return "auto";
    case RectangleInitial::Surface: return "surface";
    case RectangleInitial::Sphere: return "sphere";
  }
  return "unknown";
}

namespace {

}  // namespace

// ---- cutting --------------------------------------------------------------------------------

std::pair<int, int> inferior_medial_landmarks(const MatrixXd& V, const MatrixXi& F) {
  VectorXd d_med, d_inf;
  inferior_medial_distances(V, F, &d_med, &d_inf);
  std::vector<char> used(static_cast<std::size_t>(V.rows()), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;
  double ymin = std::numeric_limits<double>::infinity(), ymax = -ymin;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) ymin = std::min(ymin, V(i, 1)), ymax = std::max(ymax, V(i, 1));
  int front = -1, back = -1;
  double best_front = std::numeric_limits<double>::infinity(), best_back = best_front;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if (!used[i]) continue;
    const double base = d_med[i] + d_inf[i];
    const double sf = (ymax - V(i, 1)) + base, sb = (V(i, 1) - ymin) + base;
    if (sf < best_front) best_front = sf, front = static_cast<int>(i);
    if (sb < best_back) best_back = sb, back = static_cast<int>(i);
  }
  return {front, back};
}

std::vector<int> shortest_edge_path(const MatrixXd& V, const MatrixXi& F, int from, int to, const VectorXd* penalty) {
  const Eigen::Index nv = V.rows();
  if (from < 0 || to < 0 || from >= nv || to >= nv) throw InputError("cut path: vertex index out of range (the surface has " + std::to_string(nv) + " vertices)");
  const auto adj = vertex_neighbours(F, nv);
  std::vector<double> dist(static_cast<std::size_t>(nv), std::numeric_limits<double>::infinity());
  std::vector<int> parent(static_cast<std::size_t>(nv), -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  dist[from] = 0;
  queue.push({0.0, from});
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > dist[v]) continue;
    if (v == to) break;
    for (int u : adj[v]) {
      double w = (V.row(u) - V.row(v)).norm();
      if (penalty) w *= 1.0 + 0.5 * ((*penalty)[u] + (*penalty)[v]);
      if (d + w < dist[u]) {
        dist[u] = d + w;
        parent[u] = v;
        queue.push({dist[u], u});
      }
    }
  }
  if (!std::isfinite(dist[to])) throw InputError("cut path: vertices " + std::to_string(from) + " and " + std::to_string(to) + " are not connected");
  std::vector<int> path;
  for (int v = to; v != -1; v = parent[v]) path.push_back(v);
  std::reverse(path.begin(), path.end());
  return path;
}

std::vector<int> inferior_medial_path(const MatrixXd& V, const MatrixXi& F, int from, int to) {
  VectorXd d_med, d_inf;
  inferior_medial_distances(V, F, &d_med, &d_inf);
  const VectorXd penalty = 4.0 * (d_med + d_inf) / bounding_diagonal(V);
  return shortest_edge_path(V, F, from, to, &penalty);
}

CutSurface cut_along_path(const TriMesh& mesh, const std::vector<int>& path) {
  const Eigen::Index nv = mesh.V.rows();
  const MatrixXi& F = mesh.F;
  if (path.size() < 3)
    throw InputError("cut path has " + std::to_string(path.size()) + " vertices; it needs at least 3 (choose cut vertices that are not neighbours)");
  {
    std::vector<int> sorted = path;
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) throw InputError("cut path visits a vertex twice; it must be a simple path");
    if (sorted.front() < 0 || sorted.back() >= nv) throw InputError("cut path: vertex index out of range");
  }
  // Corners (face, corner) around each vertex, and the face whose outgoing edge v -> a starts the
  // counter-clockwise rotation at a.
  std::vector<std::vector<std::pair<int, int>>> corners(static_cast<std::size_t>(nv));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) corners[F(f, c)].push_back({static_cast<int>(f), c});

  CutSurface cut;
  cut.num_input_vertices = static_cast<int>(nv);
  cut.path = path;
  cut.mesh.F = F;
  const int copies = static_cast<int>(path.size()) - 2;
  cut.mesh.V.resize(nv + copies, mesh.V.cols());
  cut.mesh.V.topRows(nv) = mesh.V;
  cut.vertex_origin.resize(nv + copies);
  for (Eigen::Index i = 0; i < nv; ++i) cut.vertex_origin[i] = static_cast<int>(i);
  for (std::size_t i = 1; i + 1 < path.size(); ++i) {
    const int v = path[i], prev = path[i - 1], next = path[i + 1];
    const int copy = static_cast<int>(nv) + static_cast<int>(i) - 1;
    cut.mesh.V.row(copy) = mesh.V.row(v);
    cut.vertex_origin[copy] = v;
    // Faces (v, a, b) turn counter-clockwise around v from edge v->a to v->b (seen from outside).
    // Walking from `next` to `prev` sweeps the faces on the left of the path; they take the copy.
    auto face_with_a = [&](int a) {
      for (const auto& [f, c] : corners[v])
        if (F(f, (c + 1) % 3) == a) return std::make_pair(f, c);
      return std::make_pair(-1, -1);
    };
    auto [f, c] = face_with_a(next);
    if (f < 0) throw InputError("cut path: vertices " + std::to_string(v) + " and " + std::to_string(next) + " are not joined by an edge");
    for (std::size_t guard = 0; guard <= corners[v].size(); ++guard) {
      cut.mesh.F(f, c) = copy;
      const int b = F(f, (c + 2) % 3);
      if (b == prev) break;
      std::tie(f, c) = face_with_a(b);
      if (f < 0 || guard == corners[v].size())
        throw InputError("cut path: the surface around vertex " + std::to_string(v) + " is not a closed oriented fan, or " +
                         std::to_string(prev) + " is not its neighbour");
    }
  }
  return cut;
}

// ---- maps -----------------------------------------------------------------------------------

namespace {

// 3D positions of the vertices the initial map inserted (corner and ear splits), when the map was
// computed on another embedding of the same mesh (the sphere): each lies on a split edge between
// two input vertices that are its neighbours, at the same fraction of the edge.
MatrixXd lift_inserted_vertices(const ConformalMapResult& cm, const MatrixXd& V3, const MatrixXi& F_input) {
  const Eigen::Index n0 = V3.rows(), nv = cm.V.rows();
  MatrixXd out(nv, 3);
  out.topRows(n0) = V3;
  if (nv == n0) return out;
  // Only input edges qualify: the other diagonal of a split quad can pass through the same point.
  std::vector<std::vector<int>> input_adj = vertex_neighbours(F_input, n0);
  auto is_input_edge = [&](int a, int b) { return std::binary_search(input_adj[a].begin(), input_adj[a].end(), b); };
  const std::vector<std::vector<int>> adj = vertex_neighbours(cm.F, nv);
  for (Eigen::Index v = n0; v < nv; ++v) {
    double best = std::numeric_limits<double>::infinity();
    Eigen::RowVector3d pos = cm.V.row(v).head<3>();
    const Eigen::RowVector3d p = cm.V.row(v).head<3>();
    for (int a : adj[v])
      for (int b : adj[v]) {
        if (a >= n0 || b >= n0 || a >= b || !is_input_edge(a, b)) continue;
        const Eigen::RowVector3d d = cm.V.row(b).head<3>() - cm.V.row(a).head<3>();
        const double s = (p - cm.V.row(a).head<3>()).dot(d) / d.squaredNorm();
        const double err = (cm.V.row(a).head<3>() + s * d - p).norm();
        if (s > 0 && s < 1 && err < best) best = err, pos = (1 - s) * V3.row(a) + s * V3.row(b);
      }
    out.row(v) = pos;
  }
  return out;
}

// The square map's initial map + flow for a disk on [0, width] x [0, 1] with a given anchor.
// The initial map is computed on `G` (the surface itself, or another embedding of it such as its
// authalic sphere image); the flow's target is always the area of V.
// `pre_passes` plain Moser passes of the grid flow (moser_grid_pass) run before authalic_flow:
// authalic_flow limits each pass to steps that flip no triangle, which freezes the large
// transport a slit tip needs; the plain passes do the transport (measured on fsaverage5
// white_left cut open: 2 flipped triangles after 4 passes, element CV 0.0054) and authalic_flow
// then repairs and polishes.
// The slit tips' transport moves vertices across many cells per pass: at least this many RK4
// steps per pass keep each step within about a cell (the flow's default 20 is for small moves).
constexpr int kTransportRk4Steps = 40;
RectanglePart map_disk(const MatrixXd& V, const MatrixXd& G, const MatrixXi& F, int anchor, double anchor_position, double width,
                       const FlowOptions& flow_options, int pre_passes, const ProgressFn& progress) {
  RectangleBoundaryMap bm;
  bm.width = width;
  bm.anchor_vertex = anchor;
  bm.anchor_position = anchor_position;
  report(progress, "initial", 0.0, "conformal map onto [0, " + std::to_string(width) + "] x [0, 1]");
  ConformalMapResult cm;
  try {
    cm = conformal_rectangle_map(G, F, bm);
  } catch (const std::invalid_argument& e) {
    throw ProcessingError(std::string("rectangle map: ") + e.what());
  }
  // Mapped on V itself: cm.V already holds the 3D positions of inserted vertices.
  const MatrixXd V3 = &G == &V ? cm.V : lift_inserted_vertices(cm, V, F);
  FlowOptions fo = flow_options;
  fo.width = width;
  MatrixXd UV = cm.UV;
  if (pre_passes > 0) {
    const VectorXd target = target_face_measure(V3, cm.F, fo.density, width);
    for (int pass = 0; pass < pre_passes; ++pass) {
      report(progress, "transport", double(pass) / pre_passes, "Moser pass " + std::to_string(pass + 1));
      GridFlowOptions transport = fo.grid;
      transport.rk4_steps = std::max(transport.rk4_steps, kTransportRk4Steps);
      UV = moser_grid_pass(target, UV, cm.F, cm.side_mask, width, transport);
    }
  }
  FlowResult fr = authalic_flow(V3, cm.F, UV, cm.side_mask, fo, progress);
  RectanglePart part;
  part.V = V3;
  part.F = cm.F;
  part.UV = fr.UV;
  part.UV_initial = cm.UV;
  part.flow = fr.report;
  part.initial_flips = count_flipped(cm.UV, cm.F);
  part.width = width;
  part.num_input_vertices = static_cast<int>(V.rows());
  part.anchor_vertex = anchor;
  part.area_mm2 = face_areas(V3, cm.F).sum();
  // Vertices inserted by the corner and ear splits have no input vertex.
  part.vertex_origin = VectorXi::Constant(cm.V.rows(), -1);
  for (Eigen::Index i = 0; i < V.rows(); ++i) part.vertex_origin[i] = static_cast<int>(i);
  return part;
}

}  // namespace

RectanglePart rectangle_part_from_square(const SquareMapResult& square, double x0, double width) {
  RectanglePart part;
  part.V = square.V;
  part.F = square.F;
  // x -> x0 + s x scales every area by s: the square's area ratios all change by the same factor,
  // so an authalic square is authalic on its share of the rectangle.
  const double s = width / square.width;
  part.UV = square.UV;
  part.UV.col(0) = (x0 + s * square.UV.col(0).array()).matrix();
  part.UV_initial = square.UV_initial;
  part.UV_initial.col(0) = (x0 + s * square.UV_initial.col(0).array()).matrix();
  part.vertex_origin = VectorXi::Constant(square.V.rows(), -1);
  for (int i = 0; i < square.num_input_vertices; ++i) part.vertex_origin[i] = i;
  part.num_input_vertices = square.num_input_vertices;
  part.x0 = x0;
  part.width = width;
  part.area_mm2 = square.surface_area;
  part.anchor_vertex = square.anterior_vertex;
  part.flow = square.flow;
  part.initial_flips = count_flipped(square.UV_initial, square.F);
  return part;
}

HemisphereRectangles hemisphere_rectangles_from_squares(const SquareMapResult& left, const SquareMapResult& right) {
  const double al = left.surface_area, ar = right.surface_area;
  if (!(al > 0) || !(ar > 0)) throw InputError("hemisphere cortex has zero area");
  HemisphereRectangles out;
  // Widths proportional to cortical area: each unit of rectangle area holds the same cortex.
  const double W = Domain::rectangle().width();
  out.split = W * al / (al + ar);
  out.left = rectangle_part_from_square(left, 0.0, out.split);
  out.right = rectangle_part_from_square(right, out.split, W - out.split);
  return out;
}

HemisphereRectangles hemisphere_rectangle_map(const TriMesh& left, const TriMesh& right, const RectangleMapOptions& options,
                                              const ProgressFn& progress) {
  // Each hemisphere's square map (its anatomical rule: outward faces, frontal pole at the top
  // middle, so the right part is the mirror image of the left), then stretched to its share.
  // The right one is computed as the left one of its mirror image and mirrored back, so a right
  // hemisphere that is the mirror of a left one gives exactly the mirrored map.
  SquareMapOptions so;
  so.flow = options.flow;
  so.region_name = "left hemisphere cortex";
  const SquareMapResult l = square_map(left.V, left.F, so, progress);
  so.region_name = "right hemisphere cortex";
  MatrixXd V = right.V;
  MatrixXi F = right.F;
  V.col(0) = -V.col(0);
  F.col(1).swap(F.col(2));
  SquareMapResult r = square_map(V, F, so, progress);
  r.V.col(0) = -r.V.col(0);
  r.F.col(1).swap(r.F.col(2));
  r.UV.col(0) = (1.0 - r.UV.col(0).array()).matrix();
  r.UV_initial.col(0) = (1.0 - r.UV_initial.col(0).array()).matrix();
  return hemisphere_rectangles_from_squares(l, r);
}

WholeBrainRectangle whole_brain_rectangle_map(const TriMesh& mesh, const RectangleMapOptions& options, const ProgressFn& progress) {
  const TopologyReport t = analyze_topology(mesh.V, mesh.F);
  if (!t.is_sphere() || !t.is_oriented())
    throw InputError("surface is not a closed genus-0 surface (" + t.summary() +
                     "); the one-surface rectangle needs a closed, oriented, genus-0 whole-brain surface");
  int from = options.cut_from, to = options.cut_to;
  if (from < 0 || to < 0) {
    const auto lm = inferior_medial_landmarks(mesh.V, mesh.F);
    if (from < 0) from = lm.first;
    if (to < 0) to = lm.second;
  }
  if (from == to) throw InputError("cut vertices are the same vertex (" + std::to_string(from) + "); give two different vertices");
  WholeBrainRectangle out;
  out.cut_path = inferior_medial_path(mesh.V, mesh.F, from, to);
  const CutSurface cut = cut_along_path(mesh, out.cut_path);
  const TopologyReport ct = analyze_topology(cut.mesh.V, cut.mesh.F);
  if (!ct.is_disk()) throw ProcessingError("rectangle map: the cut surface is not a disk (" + ct.summary() + ")");
  // The initial map, computed on the cut surface itself (the literal construction) or on its
  // authalic sphere image (see the header). Auto: the surface first; if the flow leaves flipped
  // triangles or a mean per-face |ln area ratio| above 0.1, the sphere image. Measured: an
  // ellipsoid works from the surface (0 flips, element CV 0.002) but not from the sphere image
  // (the flow's repair fails), fsaverage5 white_left the other way round (surface: 458 flips;
  // sphere image: 0 flips, element CV 0.006).
  // The anterior landmark goes to the middle of the left side.
  const double W = Domain::rectangle().width();
  auto attempt = [&](bool on_sphere) {
    MatrixXd G = cut.mesh.V;
    if (on_sphere) {
      report(progress, "sphere", 0.0, "authalic sphere map for the initial rectangle map");
      SphereMapOptions so;
      so.orient = false;
      const SphereMapResult sr = authalic_sphere_map(mesh, so);
      out.sphere_flips = sr.flips;
      for (Eigen::Index i = 0; i < G.rows(); ++i) G.row(i) = sr.sphere.row(cut.vertex_origin[i]);
      return map_disk(cut.mesh.V, G, cut.mesh.F, from, rectangle_left_middle(W), W, options.flow, options.transport_passes, progress);
    }
    // On the surface itself: the square map's engine (stretch-energy start, flow, polish) on the
    // 2:1 domain, which handles the slit tips' and a native mesh's compression.
    SquareMapOptions so;
    so.width = W;
    so.flow = options.flow;
    so.anatomical_anchor = false;
    so.anchor_vertex = from;
    so.anchor_position = rectangle_left_middle(W);
    so.orient_outward = false;  // the closed surface's orientation, checked above
    so.region_name = "cut surface";
    return rectangle_part_from_square(square_map(cut.mesh.V, cut.mesh.F, so, progress), 0.0, W);
  };
  auto acceptable = [](const RectanglePart& p, int* flips, double* face_error) {
    *flips = count_flipped(p.UV, p.F);
    const VectorXd a3 = face_areas(p.V, p.F), a2 = signed_face_areas_2d(p.UV, p.F).cwiseAbs();
    double sum = 0;
    int n = 0;
    for (Eigen::Index f = 0; f < a3.size(); ++f)
      if (a2[f] > 0 && a3[f] > 0) sum += std::abs(std::log((a3[f] / a3.sum()) / (a2[f] / a2.sum()))), ++n;
    *face_error = n ? sum / n : std::numeric_limits<double>::infinity();
    return *flips == 0 && *face_error <= 0.1;
  };
  const bool sphere_first = options.initial == RectangleInitial::Sphere;
  bool first_failed = false;
  try {
    out.map = attempt(sphere_first);
  } catch (const ProcessingError&) {  // folded triangles the repair could not remove
    if (options.initial != RectangleInitial::Auto) throw;
    first_failed = true;
  }
  out.initial_used = sphere_first ? RectangleInitial::Sphere : RectangleInitial::Surface;
  int flips = std::numeric_limits<int>::max();
  double err = 0;
  if (options.initial == RectangleInitial::Auto && (first_failed || !acceptable(out.map, &flips, &err))) {
    RectanglePart second = attempt(true);
    int flips2 = 0;
    double err2 = 0;
    acceptable(second, &flips2, &err2);
    out.attempts = 2;
    if (flips2 < flips || (flips2 == flips && err2 < err)) {
      out.map = std::move(second);
      out.initial_used = RectangleInitial::Sphere;
    }
  }
  out.map.num_input_vertices = cut.num_input_vertices;
  for (Eigen::Index i = 0; i < cut.vertex_origin.size(); ++i) out.map.vertex_origin[i] = cut.vertex_origin[i];
  return out;
}

}  // namespace authalic

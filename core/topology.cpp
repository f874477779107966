// Connectivity and topology of triangle meshes: edges, half-edge twins, boundary loops,
// components, Euler characteristic and genus, manifoldness and orientation checks.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <queue>
#include <sstream>
#include <tuple>
#include <unordered_map>

#include "core/error.h"
#include "core/mesh.h"
#include "core/union_find.h"

namespace authalic {

namespace {

// Items bucketed by a vertex with a counting sort (O(n + m); a comparison sort of the 3F
// half-edges with binary searches into it was most of the topology checks' time on 150k-vertex
// meshes), each bucket then sorted: together, the order of sorting (vertex, item).
template <class Item>
struct VertexBuckets {
  std::vector<int> start;  // n + 1 offsets into items
  std::vector<Item> items;

  template <class VertexOf>
  VertexBuckets(int n, std::vector<Item> unsorted, VertexOf vertex_of) : start(static_cast<std::size_t>(n) + 1, 0) {
    for (const Item& x : unsorted) ++start[static_cast<std::size_t>(vertex_of(x)) + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    std::vector<int> fill(start.begin(), start.end() - 1);
    items.resize(unsorted.size());
    for (const Item& x : unsorted) items[static_cast<std::size_t>(fill[static_cast<std::size_t>(vertex_of(x))]++)] = x;
    for (int v = 0; v < n; ++v) std::sort(items.begin() + start[v], items.begin() + start[v + 1]);
  }
};

// Directed half-edges from each vertex: (to, id) with id 3f+c, sorted by (from, to, id).
struct DirectedEdges {
  VertexBuckets<std::pair<int, int>> from;

  DirectedEdges(const MatrixXi& F, int n) : from(n, entries(F), [&](const std::pair<int, int>& e) { return F(e.second / 3, e.second % 3); }) {}

  static std::vector<std::pair<int, int>> entries(const MatrixXi& F) {
    std::vector<std::pair<int, int>> he;
    he.reserve(static_cast<std::size_t>(F.rows()) * 3);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int c = 0; c < 3; ++c) he.emplace_back(F(f, (c + 1) % 3), static_cast<int>(3 * f + c));
    return he;
  }
  int id(std::size_t i) const { return from.items[i].second; }
};

// The entries [lo, hi) of the half-edges from a to b.
std::pair<std::size_t, std::size_t> range_of(const DirectedEdges& d, int a, int b) {
  const auto begin = d.from.items.begin() + d.from.start[a], end = d.from.items.begin() + d.from.start[a + 1];
  const auto lo = std::lower_bound(begin, end, std::pair<int, int>{b, std::numeric_limits<int>::min()});
  auto hi = lo;
  while (hi != end && hi->first == b) ++hi;
  return {static_cast<std::size_t>(lo - d.from.items.begin()), static_cast<std::size_t>(hi - d.from.items.begin())};
}

}  // namespace

EdgeTopology edge_topology(const MatrixXi& F, int num_vertices) {
  // Undirected half-edges (larger end, 3f + c: face f, corner c opposite) bucketed by their smaller
  // end: edges come out ordered by (smaller end, larger end), each with its faces in order. Eight
  // bytes a half-edge (the smaller end is the bucket): half the memory of carrying both ends, face
  // and corner (fs741's cortex, 295k faces: 30 -> 20 ms).
  using HalfEdge = std::pair<int, int>;
  std::vector<HalfEdge> unsorted;
  unsorted.reserve(static_cast<std::size_t>(F.rows()) * 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      unsorted.emplace_back(std::max(F(f, (c + 1) % 3), F(f, (c + 2) % 3)), static_cast<int>(3 * f + c));
  const auto smaller_end = [&F](const HalfEdge& h) {
    const int f = h.second / 3, c = h.second % 3;
    return std::min(F(f, (c + 1) % 3), F(f, (c + 2) % 3));
  };
  const VertexBuckets<HalfEdge> he(num_vertices, std::move(unsorted), smaller_end);
  EdgeTopology t;
  t.FE.resize(F.rows(), 3);
  std::vector<std::pair<int, int>> edges;
  edges.reserve(he.items.size() / 2 + 1);
  t.edge_faces.reserve(he.items.size() / 2 + 1, he.items.size());
  for (int a = 0; a < num_vertices; ++a)
    for (std::size_t i = static_cast<std::size_t>(he.start[a]), end = static_cast<std::size_t>(he.start[a + 1]); i < end;) {
      const int b = he.items[i].first;
      const int e = static_cast<int>(edges.size());
      edges.emplace_back(a, b);
      t.edge_faces.begin_edge();
      for (; i < end && he.items[i].first == b; ++i) {
        const int id = he.items[i].second;
        t.edge_faces.add_face(id / 3);
        t.FE(id / 3, id % 3) = e;
      }
    }
  t.E.resize(static_cast<Eigen::Index>(edges.size()), 2);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    t.E(static_cast<Eigen::Index>(e), 0) = edges[e].first;
    t.E(static_cast<Eigen::Index>(e), 1) = edges[e].second;
  }
  return t;
}

VectorXi halfedge_twins(const MatrixXi& F, int num_vertices) {
  const DirectedEdges d(F, num_vertices);
  VectorXi twin = VectorXi::Constant(F.rows() * 3, -1);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = F(f, c), b = F(f, (c + 1) % 3);
      const auto [lo, hi] = range_of(d, b, a);
      const auto [slo, shi] = range_of(d, a, b);
      if (hi - lo == 1 && shi - slo == 1) twin[3 * f + c] = d.id(lo);  // exactly one face each way
    }
  return twin;
}

int region_winding_on_closed_surface(const MatrixXd& V, const MatrixXi& region, const MatrixXi& surface) {
  const int n = static_cast<int>(V.rows());
  if (surface.rows() == 0 || region.rows() == 0 || surface.minCoeff() < 0 || surface.maxCoeff() >= n || region.minCoeff() < 0 ||
      region.maxCoeff() >= n)
    return 0;
  const DirectedEdges d(surface, n);
  double volume = 0;  // x6
  for (Eigen::Index f = 0; f < surface.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int a = surface(f, c), b = surface(f, (c + 1) % 3);
      const auto [lo, hi] = range_of(d, a, b);
      const auto [tlo, thi] = range_of(d, b, a);
      if (hi - lo != 1 || thi - tlo != 1) return 0;  // a boundary, non-manifold or inconsistently oriented edge
    }
    const Eigen::Vector3d a = V.row(surface(f, 0)).transpose(), b = V.row(surface(f, 1)).transpose(), c = V.row(surface(f, 2)).transpose();
    volume += a.dot(b.cross(c));
  }
  if (!(std::abs(volume) > 0)) return 0;
  // A region face (a, b, c) winds as the surface's face through a -> b when that face's third
  // corner is c, the other way when the face through b -> a has it.
  auto third_corner = [&](int a, int b) {
    const auto [lo, hi] = range_of(d, a, b);
    if (hi == lo) return -1;
    const int id = d.id(lo);
    return surface(id / 3, (id % 3 + 2) % 3);
  };
  long same = 0, opposite = 0;
  for (Eigen::Index f = 0; f < region.rows(); ++f) {
    const int a = region(f, 0), b = region(f, 1), c = region(f, 2);
    same += third_corner(a, b) == c;
    opposite += third_corner(b, a) == c;
  }
  if (same == opposite) return 0;
  return (same > opposite) == (volume > 0) ? 1 : -1;
}

std::vector<int> vertices_in_face_order(const MatrixXi& F, Eigen::Index num_vertices) {
  std::vector<char> seen(static_cast<std::size_t>(num_vertices), 0);
  std::vector<int> order;
  order.reserve(static_cast<std::size_t>(num_vertices));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (!seen[F(f, c)]) {
        seen[F(f, c)] = 1;
        order.push_back(F(f, c));
      }
  return order;
}

std::vector<std::vector<int>> vertex_neighbours(const MatrixXi& F, Eigen::Index num_vertices) {
  std::vector<std::vector<int>> adj(static_cast<std::size_t>(num_vertices));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      adj[F(f, c)].push_back(F(f, (c + 1) % 3));
      adj[F(f, c)].push_back(F(f, (c + 2) % 3));
    }
  for (auto& a : adj) {
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
  }
  return adj;
}

namespace {

// boundary_loops with the directed half-edges already bucketed.
std::vector<std::vector<int>> boundary_loops_of(const MatrixXi& F, int num_vertices, const DirectedEdges& d) {
  // A boundary half-edge a->b has no opposite b->a; its face lies on its left, so following the
  // half-edges themselves walks each loop with the interior on the left.
  std::vector<std::vector<int>> next_of(num_vertices);  // boundary half-edge targets from each vertex
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = F(f, c), b = F(f, (c + 1) % 3);
      const auto [lo, hi] = range_of(d, b, a);
      if (lo == hi) next_of[a].push_back(b);
    }
  std::vector<std::vector<int>> loops;
  for (int start = 0; start < num_vertices; ++start) {
    while (!next_of[start].empty()) {
      std::vector<int> loop;
      int v = start;
      // Bounded walk: a non-manifold boundary could otherwise cycle.
      for (int steps = 0; steps <= num_vertices && !next_of[v].empty(); ++steps) {
        loop.push_back(v);
        const int w = next_of[v].back();
        next_of[v].pop_back();
        v = w;
        if (v == start) break;
      }
      loops.push_back(std::move(loop));
    }
  }
  std::stable_sort(loops.begin(), loops.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return loops;
}

}  // namespace

std::vector<std::vector<int>> boundary_loops(const MatrixXi& F, int num_vertices) {
  return boundary_loops_of(F, num_vertices, DirectedEdges(F, num_vertices));
}

VectorXi face_components(const MatrixXi& F, int num_vertices, int* num_components) {
  UnionFind uf(num_vertices);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    uf.unite(F(f, 0), F(f, 1));
    uf.unite(F(f, 0), F(f, 2));
  }
  VectorXi comp(F.rows());
  std::vector<int> id(static_cast<std::size_t>(num_vertices), -1);  // per root: its component, in order of first face
  int count = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    int& c = id[static_cast<std::size_t>(uf.find(F(f, 0)))];
    if (c < 0) c = count++;
    comp[f] = c;
  }
  if (num_components) *num_components = count;
  return comp;
}

std::vector<int> degenerate_faces(const MatrixXd& V, const MatrixXi& F, double area_tolerance) {
  const VectorXd A = face_areas(V, F);
  std::vector<int> out;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const bool repeated = F(f, 0) == F(f, 1) || F(f, 1) == F(f, 2) || F(f, 0) == F(f, 2);
    if (repeated || !(A[f] > area_tolerance)) out.push_back(static_cast<int>(f));
  }
  return out;
}

VectorXi duplicate_vertices(const MatrixXd& V, double tolerance) {
  const int n = static_cast<int>(V.rows());
  VectorXi rep(n);
  std::iota(rep.data(), rep.data() + n, 0);
  if (tolerance <= 0) {
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    auto less = [&](int a, int b) {
      for (int c = 0; c < V.cols(); ++c)
        if (V(a, c) != V(b, c)) return V(a, c) < V(b, c);
      return a < b;
    };
    std::sort(order.begin(), order.end(), less);
    for (int i = 1; i < n; ++i) {
      const int a = order[i - 1], b = order[i];
      if ((V.row(a).array() == V.row(b).array()).all()) rep[b] = rep[a];
    }
    return rep;
  }
  // Spatial hash with cell = tolerance; compare against the 27 neighbouring cells.
  std::unordered_map<std::int64_t, std::vector<int>> grid;
  auto cell = [&](double x) { return static_cast<std::int64_t>(std::floor(x / tolerance)); };
  auto hkey = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    return (i * 73856093) ^ (j * 19349663) ^ (k * 83492791);
  };
  const double tol2 = tolerance * tolerance;
  for (int v = 0; v < n; ++v) {
    const std::int64_t ci = cell(V(v, 0)), cj = cell(V.cols() > 1 ? V(v, 1) : 0), ck = cell(V.cols() > 2 ? V(v, 2) : 0);
    int found = -1;
    for (int di = -1; di <= 1 && found < 0; ++di)
      for (int dj = -1; dj <= 1 && found < 0; ++dj)
        for (int dk = -1; dk <= 1 && found < 0; ++dk) {
          auto it = grid.find(hkey(ci + di, cj + dj, ck + dk));
          if (it == grid.end()) continue;
          for (int u : it->second)
            if ((V.row(u) - V.row(v)).squaredNorm() <= tol2) {
              found = rep[u];
              break;
            }
        }
    if (found >= 0) rep[v] = found;
    grid[hkey(ci, cj, ck)].push_back(v);
  }
  return rep;
}

int orient_faces_consistently(MatrixXi& F, int num_vertices) {
  const EdgeTopology t = edge_topology(F, num_vertices);
  const Eigen::Index m = F.rows();
  std::vector<int> flip(m, -1);  // -1 unvisited, 0 keep, 1 flip
  const MatrixXi original = F;
  auto directed_same = [&](int f, int g, int a, int b, int fa, int ga) {
    // does face f (flipped by fa) traverse a->b in the same direction as g (flipped by ga)?
    auto dir = [&](int face, int fl) {
      for (int c = 0; c < 3; ++c)
        if (F(face, c) == a && F(face, (c + 1) % 3) == b) return fl ? -1 : 1;
      return fl ? 1 : -1;
    };
    return dir(f, fa) == dir(g, ga);
  };
  for (Eigen::Index seed = 0; seed < m; ++seed) {
    if (flip[seed] >= 0) continue;
    flip[seed] = 0;
    std::queue<int> q;
    q.push(static_cast<int>(seed));
    while (!q.empty()) {
      const int f = q.front();
      q.pop();
      for (int c = 0; c < 3; ++c) {
        const int e = t.FE(f, c);
        if (t.edge_faces[e].size() != 2) continue;
        const int g = t.edge_faces[e][0] == f ? t.edge_faces[e][1] : t.edge_faces[e][0];
        const int a = t.E(e, 0), b = t.E(e, 1);
        if (flip[g] < 0) {
          flip[g] = directed_same(f, g, a, b, flip[f], 0) ? 1 : 0;
          q.push(g);
        } else if (directed_same(f, g, a, b, flip[f], flip[g])) {
          F = original;
          return -1;  // Möbius-like: not orientable
        }
      }
    }
  }
  int flipped = 0;
  for (Eigen::Index f = 0; f < m; ++f)
    if (flip[f] == 1) {
      std::swap(F(f, 1), F(f, 2));
      ++flipped;
    }
  return flipped;
}

TopologyReport analyze_topology(const MatrixXd& V, const MatrixXi& F) {
  const int n = static_cast<int>(V.rows());
  TopologyReport r;
  r.num_faces = static_cast<int>(F.rows());
  std::vector<char> used(n, 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;
  r.num_vertices_used = static_cast<int>(std::count(used.begin(), used.end(), 1));
  r.degenerate_faces = static_cast<int>(degenerate_faces(V, F).size());
  {
    std::vector<std::array<int, 3>> sorted(F.rows());
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      sorted[f] = {F(f, 0), F(f, 1), F(f, 2)};
      std::sort(sorted[f].begin(), sorted[f].end());
    }
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 1; i < sorted.size(); ++i)
      if (sorted[i] == sorted[i - 1]) ++r.duplicate_faces;
  }
  const EdgeTopology t = edge_topology(F, n);
  r.num_edges = static_cast<int>(t.E.rows());
  const DirectedEdges d(F, n);
  UnionFind corners(static_cast<int>(F.rows() * 3));  // corner id 3f+c; fans of faces around a vertex
  auto corner_of = [&](int f, int v) {
    for (int c = 0; c < 3; ++c)
      if (F(f, c) == v) return 3 * f + c;
    return -1;
  };
  for (Eigen::Index e = 0; e < t.E.rows(); ++e) {
    const auto fs = t.edge_faces[e];
    if (fs.size() > 2) {
      ++r.non_manifold_edges;
      continue;
    }
    if (fs.size() != 2) continue;
    const int a = t.E(e, 0), b = t.E(e, 1);
    const auto [lo, hi] = range_of(d, a, b);
    if (hi - lo != 1) ++r.inconsistent_orientation_edges;  // both faces traverse a->b (or b->a)
    for (int v : {a, b}) corners.unite(corner_of(fs[0], v), corner_of(fs[1], v));
  }
  {
    std::vector<int> fan_root(n, -1);
    std::vector<char> counted(n, 0);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int c = 0; c < 3; ++c) {
        const int v = F(f, c);
        const int root = corners.find(static_cast<int>(3 * f + c));
        if (fan_root[v] < 0) {
          fan_root[v] = root;
        } else if (fan_root[v] != root && !counted[v]) {
          counted[v] = 1;
          ++r.non_manifold_vertices;
        }
      }
  }
  // Per component: chi = V - E + F and boundary loops give genus = (2 - chi - b) / 2.
  int nc = 0;
  const VectorXi comp = face_components(F, n, &nc);
  r.num_components = nc;
  std::vector<int> cv(nc, 0), ce(nc, 0), cf(nc, 0), cb(nc, 0);
  std::vector<int> vcomp(n, -1);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    ++cf[comp[f]];
    for (int c = 0; c < 3; ++c) vcomp[F(f, c)] = comp[f];
  }
  for (int v = 0; v < n; ++v)
    if (vcomp[v] >= 0) ++cv[vcomp[v]];
  for (Eigen::Index e = 0; e < t.E.rows(); ++e) ++ce[vcomp[t.E(e, 0)]];
  const auto loops = boundary_loops_of(F, n, d);
  r.num_boundary_loops = static_cast<int>(loops.size());
  for (const auto& loop : loops)
    if (!loop.empty()) ++cb[vcomp[loop.front()]];
  r.euler_characteristic = r.num_vertices_used - r.num_edges + r.num_faces;
  for (int c = 0; c < nc; ++c) r.genus += std::max(0, (2 - (cv[c] - ce[c] + cf[c]) - cb[c]) / 2);
  return r;
}

std::string TopologyReport::summary() const {
  std::ostringstream s;
  s << num_components << (num_components == 1 ? " component, " : " components, ") << num_boundary_loops
    << (num_boundary_loops == 1 ? " boundary loop, " : " boundary loops, ") << "Euler characteristic "
    << euler_characteristic << ", genus " << genus;
  if (is_manifold()) {
    s << ", manifold";
  } else {
    s << ", non-manifold (" << non_manifold_edges << " edges with >2 faces, " << non_manifold_vertices
      << " pinched vertices)";
  }
  if (inconsistent_orientation_edges > 0) s << ", " << inconsistent_orientation_edges << " inconsistently oriented edges";
  if (degenerate_faces > 0) s << ", " << degenerate_faces << " degenerate faces";
  if (duplicate_faces > 0) s << ", " << duplicate_faces << " duplicate faces";
  return s.str();
}

std::string disk_topology_problem(const TopologyReport& t) {
  if (t.num_faces == 0) return "it has no faces; a map onto a planar domain needs a disk";
  if (t.is_disk() && t.is_oriented()) return {};
  std::ostringstream s;
  s << "it is not one disk (" << t.summary() << ")";
  if (t.num_boundary_loops == 0) {
    s << "; it is a closed surface: map a region of it (a disk), or the whole surface with the sphere map";
  } else if (!t.is_oriented()) {
    s << "; its faces are not consistently oriented";
  } else {
    s << "; a planar map needs exactly one component with one boundary loop and no handles";
  }
  return s.str();
}

std::string disk_topology_problem(const MatrixXd& V, const MatrixXi& F) {
  if (F.rows() == 0) return disk_topology_problem(TopologyReport{});
  return disk_topology_problem(analyze_topology(V, F));
}

TopologyReport require_disk(const MatrixXd& V, const MatrixXi& F, const std::string& what) {
  TopologyReport t;
  if (F.rows() > 0) t = analyze_topology(V, F);
  const std::string problem = disk_topology_problem(t);
  if (!problem.empty()) throw InputError(what + ": " + problem);
  return t;
}

void grow_by_rings(std::vector<char>& mark, const std::vector<std::vector<int>>& adj, int rings) {
  for (int ring = 0; ring < rings; ++ring) {
    std::vector<char> grown = mark;
    for (std::size_t v = 0; v < mark.size(); ++v)
      if (mark[v])
        for (int u : adj[v]) grown[u] = 1;
    mark.swap(grown);
  }
}

VectorXd edge_path_distances(const TriMesh& mesh, const std::vector<bool>& allowed, int source) {
  const int n = mesh.num_vertices();
  VectorXd dist = VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  if (source < 0 || source >= n || !allowed[source]) return dist;
  std::vector<std::vector<int>> adj(static_cast<std::size_t>(n));
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const int a = mesh.F(f, k), b = mesh.F(f, (k + 1) % 3);
      adj[a].push_back(b);
      adj[b].push_back(a);
    }
  }
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  dist(source) = 0.0;
  queue.emplace(0.0, source);
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > dist(v)) continue;
    for (int w : adj[v]) {
      if (!allowed[w]) continue;
      const double nd = d + (mesh.V.row(v) - mesh.V.row(w)).norm();
      if (nd < dist(w)) {
        dist(w) = nd;
        queue.emplace(nd, w);
      }
    }
  }
  return dist;
}

}  // namespace authalic

// Initial map of a disk onto the rectangle [0, W] x [0, 1]: arc-length boundary, corner and ear
// splits, harmonic (cotangent = LSCM with fixed boundary) interior with fallbacks. See
// core/conformal_map.h; Zou et al. 2011a section 4.1.
#include "core/conformal_map.h"
#include "core/sparse_cholesky.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

namespace authalic {

namespace {

// Perimeter coordinates of the four corners (0,0), (W,0), (W,1), (0,1) and the side bits each carries.
std::array<double, 4> corner_coordinates(double w) { return {0.0, w, w + 1.0, 2.0 * w + 1.0}; }
constexpr std::array<int, 4> kCornerSides = {kSideBottom | kSideLeft, kSideBottom | kSideRight, kSideRight | kSideTop,
                                             kSideTop | kSideLeft};

Eigen::Vector3d row3(const MatrixXd& V, int i) { return V.row(i).head<3>().transpose(); }

using Face = std::array<int, 3>;

double tri_area(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& r) {
  return 0.5 * (q - p).cross(r - p).norm();
}
// A flipped pair's triangles each keep at least this share of the pair's 3D area: a flat one would
// have to map to a sliver.
constexpr double kMinFlipAreaShare = 1e-3;

// Dividing edges resolved by edge flips, which keep the vertex list (splitting them appends vertices
// that the surface's per-vertex data does not have, so the flat map would not pair with it).
// A dividing edge (a, c) -- interior, its endpoints on one side -- between faces (a, c, x) and
// (c, a, y) becomes (x, y) when x and y share no side, x-y is not yet an edge, and both new
// triangles have a 3D area. A convex quad gives a triangulation of the same surface piece; a
// non-convex one (real meshes have a few) gives two triangles whose 3D areas sum to a little more
// than the pair's: the map is authalic for the faces it returns, which is what its checks measure.
// Faces touched by a flip wait for the next round; whatever is left is split by stage 2. F,
// origin (face -> input face) and topo (edge_topology of F, given and returned current) are
// updated in place.
// The candidates are the first round's dividing edges: a flip removes its own and never makes one
// (its new edge joins vertices that share no side), so later rounds only see fewer, in the same
// order, and a flip changes no other edge's vertices, only which of its two faces holds the quad's
// outer edges (x, c) and (y, a). Tracking that replaces an edge_topology per round (fs741
// lh.white: 0.2 s down to 0.05 s; the same flips).
int flip_dividing_edges(const std::vector<Eigen::Vector3d>& pos, const std::vector<int>& mask, MatrixXi& F,
                        std::vector<int>& origin, EdgeTopology& topo) {
  struct Candidate {
    int a, c;    // a < c
    int f1, f2;  // its two faces (current)
    bool flipped;
  };
  std::vector<Candidate> cand;  // in topo.E's ascending order
  for (Eigen::Index e = 0; e < topo.E.rows(); ++e) {
    const int a = topo.E(e, 0), c = topo.E(e, 1);
    if (topo.edge_faces[e].size() == 2 && (mask[a] & mask[c]) != 0)
      cand.push_back({a, c, topo.edge_faces[e][0], topo.edge_faces[e][1], false});
  }
  auto candidate = [&](int p, int q) -> Candidate* {
    const std::pair<int, int> pq = std::minmax(p, q);
    const auto it = std::lower_bound(cand.begin(), cand.end(), pq, [](const Candidate& k, const std::pair<int, int>& v) {
      return std::pair<int, int>(k.a, k.c) < v;
    });
    return it != cand.end() && it->a == pq.first && it->c == pq.second ? &*it : nullptr;
  };
  // An edge of the input (topo.E, ascending: a binary search) or one a flip added. An edge a flip
  // removed is never asked for: it joins two vertices of one side.
  std::vector<std::pair<int, int>> added;  // ascending up to added_sorted, this round's after
  std::size_t added_sorted = 0;
  auto is_edge = [&](int p, int q) {
    const std::pair<int, int> pq = std::minmax(p, q);
    Eigen::Index lo = 0, hi = topo.E.rows();
    while (lo < hi) {
      const Eigen::Index mid = (lo + hi) / 2;
      if (std::pair<int, int>(topo.E(mid, 0), topo.E(mid, 1)) < pq)
        lo = mid + 1;
      else
        hi = mid;
    }
    if (lo < topo.E.rows() && topo.E(lo, 0) == pq.first && topo.E(lo, 1) == pq.second) return true;
    const auto sorted_end = added.begin() + static_cast<std::ptrdiff_t>(added_sorted);
    return std::binary_search(added.begin(), sorted_end, pq) || std::find(sorted_end, added.end(), pq) != added.end();
  };
  int flipped = 0;
  for (int round = 0; round < 4; ++round) {
    std::vector<char> touched(F.rows(), 0);
    int this_round = 0;
    for (Candidate& k : cand) {
      if (k.flipped) continue;
      const int a0 = k.a, c0 = k.c;
      int f1 = k.f1, f2 = k.f2;
      if (touched[f1] || touched[f2]) continue;
      // Orient: f1 holds the half-edge a -> c, f2 the half-edge c -> a; x, y their third vertices.
      int a = a0, c = c0, x = -1, y = -1;
      for (int i = 0; i < 3; ++i)
        if (F(f1, i) == a0 && F(f1, (i + 1) % 3) == c0) x = F(f1, (i + 2) % 3);
      if (x < 0) {
        std::swap(f1, f2);
        for (int i = 0; i < 3; ++i)
          if (F(f1, i) == a0 && F(f1, (i + 1) % 3) == c0) x = F(f1, (i + 2) % 3);
      }
      for (int i = 0; i < 3; ++i)
        if (F(f2, i) == c && F(f2, (i + 1) % 3) == a) y = F(f2, (i + 2) % 3);
      if (x < 0 || y < 0 || x == y || (mask[x] & mask[y]) != 0 || is_edge(x, y)) continue;
      // In the plane map x lies on the side between a and c and y inside, so both new triangles are
      // positively oriented there whatever the quad's 3D shape; they only need a 3D area to map.
      const double before = tri_area(pos[a], pos[c], pos[x]) + tri_area(pos[c], pos[a], pos[y]);
      const double min_new = kMinFlipAreaShare * before;
      if (!(tri_area(pos[x], pos[a], pos[y]) > min_new && tri_area(pos[y], pos[c], pos[x]) > min_new)) continue;
      F.row(f1) << x, a, y;
      F.row(f2) << y, c, x;
      origin[f2] = origin[f1];  // the pair now covers the union of both input faces
      touched[f1] = touched[f2] = 1;
      added.push_back(std::minmax(x, y));
      k.flipped = true;
      // The quad's outer edges: (x, c) moved from f1 to f2, (y, a) from f2 to f1.
      auto move = [](Candidate* o, int from, int to) {
        if (o == nullptr) return;
        if (o->f1 == from) o->f1 = to;
        else if (o->f2 == from) o->f2 = to;
      };
      move(candidate(x, c), f1, f2);
      move(candidate(y, a), f2, f1);
      ++this_round;
    }
    flipped += this_round;
    if (this_round == 0) break;
    std::sort(added.begin(), added.end());
    added_sorted = added.size();
  }
  if (flipped > 0) topo = edge_topology(F, static_cast<int>(pos.size()));
  return flipped;
}

}  // namespace

std::string to_string(HarmonicWeights w) {
  switch (w) {
    case HarmonicWeights::Cotangent: return "cotangent";
    case HarmonicWeights::MeanValue: return "mean-value";
    case HarmonicWeights::Uniform: return "uniform";
    case HarmonicWeights::ClampedCotangent: return "clamped cotangent";
  }
  return "unknown";
}

int count_flipped(const MatrixXd& UV, const MatrixXi& F, double min_area) {
  const VectorXd a = signed_face_areas_2d(UV, F);
  int n = 0;
  for (Eigen::Index f = 0; f < a.size(); ++f)
    if (!(a[f] > min_area)) ++n;
  return n;
}

namespace {

// Harmonic functions (one per column of fixed_values) with the Dirichlet data fixed_values on
// the vertices `fixed`; other used vertices free (natural Neumann condition on free boundary
// vertices). Unused vertices get 0.
MatrixXd solve_harmonic(const MatrixXd& V, const MatrixXi& F, const std::vector<int>& fixed, const MatrixXd& fixed_uv,
                        HarmonicWeights weights, SpdSolver* reuse = nullptr) {
  const int nv = static_cast<int>(V.rows());
  const Eigen::Index cols = fixed_uv.cols();
  MatrixXd UV = MatrixXd::Zero(nv, cols);
  std::vector<int> index(nv, -2);  // -2 unused, -1 fixed, >= 0 unknown number
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) index[F(f, c)] = 0;
  for (size_t k = 0; k < fixed.size(); ++k) {
    index[fixed[k]] = -1;
    UV.row(fixed[k]) = fixed_uv.row(k);
  }
  int n = 0;
  for (int v = 0; v < nv; ++v)
    if (index[v] == 0) index[v] = n++;
  if (n == 0) return UV;

  // Weighted graph Laplacian rows w_ij(u_i − u_j) = 0 for the unknowns, as triplets (i, j, w_ij).
  std::vector<Eigen::Triplet<double>> w;
  w.reserve(static_cast<size_t>(F.rows()) * 6);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    std::array<Eigen::Vector3d, 3> p;
    for (int c = 0; c < 3; ++c) p[c] = row3(V, F(f, c));
    for (int c = 0; c < 3; ++c) {
      const int i = F(f, c), j = F(f, (c + 1) % 3), k = F(f, (c + 2) % 3);
      const Eigen::Vector3d e1 = p[(c + 1) % 3] - p[c], e2 = p[(c + 2) % 3] - p[c];
      const double cr = e1.cross(e2).norm(), dt = e1.dot(e2);
      switch (weights) {
        case HarmonicWeights::Cotangent:
        case HarmonicWeights::ClampedCotangent: {
          // Angle at corner i is opposite edge (j, k): contributes cot/2 to w_jk = w_kj.
          const double cot = dt / std::max(cr, 1e-300);
          w.emplace_back(j, k, 0.5 * cot);
          w.emplace_back(k, j, 0.5 * cot);
          break;
        }
        case HarmonicWeights::MeanValue: {
          // Floater 2003: w_ij = (tan(α_1/2) + tan(α_2/2)) / |v_j − v_i|, α the angles at v_i
          // beside edge ij. tan(α/2) = |e1 x e2| / (|e1||e2| + e1.e2).
          const double l1 = e1.norm(), l2 = e2.norm();
          const double t = cr / std::max(l1 * l2 + dt, 1e-300);
          w.emplace_back(i, j, t / std::max(l1, 1e-300));
          w.emplace_back(i, k, t / std::max(l2, 1e-300));
          break;
        }
        case HarmonicWeights::Uniform:
          // Each half-edge once: interior edges get 1 from each side, boundary edges 1/2 (only
          // boundary-boundary pairs, which are fixed anyway).
          w.emplace_back(i, j, 0.5);
          w.emplace_back(j, i, 0.5);
          break;
      }
    }
  }
  if (weights == HarmonicWeights::ClampedCotangent) {
    // Per half-edge, as core/stretch_energy.cpp clamps them: every weight positive.
    double mean_abs = 0;
    for (const auto& t : w) mean_abs += std::abs(t.value());
    const double floor = 1e-2 * mean_abs / std::max<std::size_t>(1, w.size());
    for (auto& t : w) t = Eigen::Triplet<double>(t.row(), t.col(), std::max(t.value(), floor));
  }
  SparseMatrix W(nv, nv);
  W.setFromTriplets(w.begin(), w.end());

  std::vector<Eigen::Triplet<double>> a;
  a.reserve(W.nonZeros() + n);
  MatrixXd rhs = MatrixXd::Zero(n, cols);
  VectorXd diag = VectorXd::Zero(n);
  for (int col = 0; col < W.outerSize(); ++col)
    for (SparseMatrix::InnerIterator it(W, col); it; ++it) {
      // Entry (row i, column j) = w_ij.
      const int i = static_cast<int>(it.row()), j = static_cast<int>(it.col());
      if (index[i] < 0 || i == j) continue;
      diag[index[i]] += it.value();
      if (index[j] >= 0)
        a.emplace_back(index[i], index[j], -it.value());
      else
        rhs.row(index[i]) += it.value() * UV.row(j);
    }
  for (int i = 0; i < n; ++i) a.emplace_back(i, i, diag[i]);
  SparseMatrix A(n, n);
  A.setFromTriplets(a.begin(), a.end());
  MatrixXd x;
  if (weights == HarmonicWeights::Cotangent || weights == HarmonicWeights::ClampedCotangent) {
    // The cotangent matrix is the P1 stiffness matrix: positive definite with a Dirichlet
    // boundary whatever the triangle shapes, so a Cholesky factorisation applies.
    SpdSolver local;
    SpdSolver& solver = reuse ? *reuse : local;
    if (!solver.refactor(A, &index)) throw std::runtime_error("harmonic_map: cotangent factorisation failed");
    x = solver.solve(rhs);
  } else {
    Eigen::SparseLU<SparseMatrix> solver;
    solver.analyzePattern(A);
    solver.factorize(A);
    if (solver.info() != Eigen::Success) throw std::runtime_error("harmonic_map: factorisation failed");
    x = solver.solve(rhs);
  }
  for (int v = 0; v < nv; ++v)
    if (index[v] >= 0) UV.row(v) = x.row(index[v]);
  return UV;
}

}  // namespace

MatrixXd harmonic_map(const MatrixXd& V, const MatrixXi& F, const std::vector<int>& fixed, const MatrixXd& fixed_uv,
                      HarmonicWeights weights) {
  return solve_harmonic(V, F, fixed, fixed_uv.leftCols(2), weights);
}

MatrixXd harmonic_map(const MatrixXd& V, const MatrixXi& F, const std::vector<int>& fixed, const MatrixXd& fixed_uv,
                      HarmonicWeights weights, SpdSolver& solver) {
  return solve_harmonic(V, F, fixed, fixed_uv.leftCols(2), weights, &solver);
}

MatrixXd sliding_harmonic_map(const MatrixXd& V, const MatrixXi& F, const VectorXi& side_mask, double width,
                              const MatrixXd& UV, int pinned, HarmonicWeights weights) {
  // u: Dirichlet on the left/right sides (0, W), free on the bottom/top sides; v: Dirichlet on
  // the bottom/top sides (0, 1), free on the left/right sides. Corners carry both bits.
  std::vector<int> fu, fv;
  for (Eigen::Index v = 0; v < side_mask.size(); ++v) {
    const int m = side_mask[v];
    if ((m & (kSideLeft | kSideRight)) || v == pinned) fu.push_back(static_cast<int>(v));
    if ((m & (kSideBottom | kSideTop)) || v == pinned) fv.push_back(static_cast<int>(v));
  }
  MatrixXd bu(fu.size(), 1), bv(fv.size(), 1);
  for (size_t k = 0; k < fu.size(); ++k) bu(k, 0) = UV(fu[k], 0);
  for (size_t k = 0; k < fv.size(); ++k) bv(k, 0) = UV(fv[k], 1);
  MatrixXd out(V.rows(), 2);
  out.col(0) = solve_harmonic(V, F, fu, bu, weights).col(0);
  out.col(1) = solve_harmonic(V, F, fv, bv, weights).col(0);
  (void)width;
  return out;
}

namespace {

// The boundary loop of a disk (cheap check: one boundary loop, edge-manifold, Euler
// characteristic 1; the full topology report only to explain a refusal).
std::vector<int> disk_boundary_loop(const MatrixXd& V, const MatrixXi& F) {
  const int nv = static_cast<int>(V.rows());
  const auto loops = boundary_loops(F, nv);
  const EdgeTopology et = edge_topology(F, nv);
  std::vector<char> used(nv, 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;
  int nused = 0;
  for (char u : used) nused += u;
  bool manifold = true;
  for (std::size_t e = 0; e < et.edge_faces.size(); ++e) manifold = manifold && et.edge_faces[static_cast<Eigen::Index>(e)].size() <= 2;
  if (loops.size() != 1 || !manifold || nused - et.E.rows() + F.rows() != 1) {
    const TopologyReport topo = analyze_topology(V, F);
    if (!topo.is_disk()) throw std::invalid_argument("conformal_rectangle_map: the mesh is not a disk (" + topo.summary() + ")");
  }
  if (loops.front().size() < 3) throw std::invalid_argument("conformal_rectangle_map: boundary loop shorter than 3 vertices");
  return loops.front();
}

// Step 1: the loop rotated to start at the anchor, and its arc-length perimeter coordinates,
// unwrapped: s[0] = the anchor's position, s[i + 1] = s[i] + P l_i / L, s[nb] = s[0] + P.
struct BoundaryCoordinates {
  std::vector<int> loop;
  std::vector<double> s;
};
BoundaryCoordinates rectangle_boundary_coordinates(const MatrixXd& V, std::vector<int> loop, const RectangleBoundaryMap& opt) {
  const int nb = static_cast<int>(loop.size());
  if (opt.anchor_vertex >= 0) {
    auto it = std::find(loop.begin(), loop.end(), opt.anchor_vertex);
    if (it == loop.end()) throw std::invalid_argument("conformal_rectangle_map: the anchor vertex is not on the boundary");
    std::rotate(loop.begin(), it, loop.end());
  }
  const double P = rectangle_perimeter(opt.width);
  std::vector<double> s(nb + 1);
  double total = 0;
  for (int i = 0; i < nb; ++i) total += (row3(V, loop[(i + 1) % nb]) - row3(V, loop[i])).norm();
  if (!(total > 0)) throw std::invalid_argument("conformal_rectangle_map: the boundary has zero length");
  s[0] = opt.anchor_position;
  if (opt.use_anchor_point) {
    // The point of the boundary polyline nearest to anchor_point goes to anchor_position: rotate
    // the loop to start at its edge and shift the start by the point's offset along that edge.
    // (A point, not a vertex: a refined mesh of the same surface gets the same parametrisation.)
    int best = 0;
    double best_d = std::numeric_limits<double>::infinity(), best_t = 0;
    for (int i = 0; i < nb; ++i) {
      const Eigen::Vector3d a = row3(V, loop[i]), b = row3(V, loop[(i + 1) % nb]);
      const Eigen::Vector3d e = b - a;
      const double l2 = e.squaredNorm();
      const double t = l2 > 0 ? std::clamp((opt.anchor_point - a).dot(e) / l2, 0.0, 1.0) : 0.0;
      const double d = (a + t * e - opt.anchor_point).squaredNorm();
      if (d < best_d) best_d = d, best = i, best_t = t;
    }
    std::rotate(loop.begin(), loop.begin() + best, loop.end());
    s[0] = opt.anchor_position - P * best_t * (row3(V, loop[1]) - row3(V, loop[0])).norm() / total;
  }
  for (int i = 0; i < nb; ++i) s[i + 1] = s[i] + P * (row3(V, loop[(i + 1) % nb]) - row3(V, loop[i])).norm() / total;
  if (!opt.boundary_perimeter.empty()) {  // given coordinates instead of arc length
    s[0] = opt.boundary_perimeter[static_cast<std::size_t>(loop[0])];
    for (int i = 0; i + 1 < nb; ++i)
      s[i + 1] = s[i] + wrap_rectangle_perimeter(opt.boundary_perimeter[static_cast<std::size_t>(loop[i + 1])] -
                                                     opt.boundary_perimeter[static_cast<std::size_t>(loop[i])],
                                                 opt.width);
  }
  s[nb] = s[0] + P;  // exact closure
  return {std::move(loop), std::move(s)};
}

// The mesh after the corner splits (step 2): positions, side bits and the boundary's perimeter
// coordinates of every vertex so far, faces with the input face each comes from, the inserted
// vertices' parents, and the boundary loop with the inserted corner vertices.
struct SplitMesh {
  std::vector<Eigen::Vector3d> pos;
  std::vector<int> mask;
  std::vector<double> vertex_s;              // input vertices: perimeter coordinate (boundary only)
  std::vector<Eigen::Vector2d> extra_uv;     // inserted corner vertices: their corner
  std::vector<std::array<int, 2>> parents;   // inserted vertex = (1 − w) parent0 + w parent1
  std::vector<double> parent_weight;
  std::vector<int> loop;
  MatrixXi F;
  std::vector<int> origin;
};

// Step 2: each corner of the rectangle goes to a boundary vertex moved onto it (when the nearer
// endpoint of its edge is within corner_snap of the edge's length) or to a vertex inserted on
// its boundary edge, which splits the edge's face.
SplitMesh split_corner_edges(const MatrixXd& V, const MatrixXi& F, const BoundaryCoordinates& bc, const RectangleBoundaryMap& opt,
                             ConformalMapResult& R) {
  const int nv = static_cast<int>(V.rows());
  const double w = opt.width, P = rectangle_perimeter(w);
  const std::vector<int>& loop = bc.loop;
  const std::vector<double>& s = bc.s;
  const int nb = static_cast<int>(loop.size());
  // Corners in unwrapped coordinates within [s0, s0 + P): find each one's boundary edge.
  const auto corners = corner_coordinates(w);
  std::vector<int> corner_of(nb, -1);                       // boundary position -> corner id (snapped)
  std::vector<std::vector<std::pair<double, int>>> inserted(nb);  // per edge i: (unwrapped s, corner id)
  for (int c = 0; c < 4; ++c) {
    double cu = corners[c];
    cu += P * std::ceil((s[0] - cu) / P);  // smallest c + kP >= s0
    if (cu >= s[0] + P) cu -= P;
    int i = static_cast<int>(std::upper_bound(s.begin(), s.end(), cu) - s.begin()) - 1;
    i = std::clamp(i, 0, nb - 1);
    const double len = s[i + 1] - s[i];
    const double d0 = cu - s[i], d1 = s[i + 1] - cu;
    const int j = (i + 1) % nb;
    // Snap the nearer endpoint onto the corner when it is within corner_snap of the edge length
    // (and not already a corner); otherwise split the edge at the corner.
    if (d0 <= d1 && d0 <= opt.corner_snap * len && corner_of[i] < 0) {
      corner_of[i] = c;
    } else if (d1 < d0 && d1 <= opt.corner_snap * len && corner_of[j] < 0) {
      corner_of[j] = c;
    } else {
      inserted[i].push_back({cu, c});
    }
  }
  for (auto& v : inserted) std::sort(v.begin(), v.end());

  // Output vertices: the input's, then inserted corner vertices (then, step 3, ear-split midpoints).
  SplitMesh m;
  std::vector<Eigen::Vector3d> extra;
  std::vector<int> extra_side;
  m.vertex_s.assign(nv, 0.0);
  std::vector<int> side(nv, 0);
  for (int i = 0; i < nb; ++i) {
    const int v = loop[i];
    if (corner_of[i] >= 0) {
      side[v] = kCornerSides[corner_of[i]];
      m.vertex_s[v] = corners[corner_of[i]];
      ++R.corners_snapped;
    } else {
      side[v] = rectangle_side(s[i], w);
      m.vertex_s[v] = s[i];
    }
  }

  // The faces of the (at most a few) boundary edges that receive corner vertices.
  std::map<std::pair<int, int>, int> halfedge_face;
  for (int i = 0; i < nb; ++i)
    if (!inserted[i].empty()) halfedge_face[{loop[i], loop[(i + 1) % nb]}] = -1;
  if (!halfedge_face.empty())
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int c = 0; c < 3; ++c) {
        auto it = halfedge_face.find({F(f, c), F(f, (c + 1) % 3)});
        if (it != halfedge_face.end()) it->second = static_cast<int>(f);
      }

  // Each input face's pieces, in input order.
  std::vector<std::vector<Face>> pieces(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) pieces[f].push_back({F(f, 0), F(f, 1), F(f, 2)});
  for (int i = 0; i < nb; ++i) {
    const int a = loop[i], b = loop[(i + 1) % nb];
    m.loop.push_back(a);
    if (inserted[i].empty()) continue;
    const int f = halfedge_face.at({a, b});
    const Face orig = pieces[f].front();
    int x = -1;
    for (int c = 0; c < 3; ++c)
      if (orig[c] != a && orig[c] != b) x = orig[c];
    std::vector<int> chain{a};
    for (const auto& [cu, c] : inserted[i]) {
      const double t = (cu - s[i]) / (s[i + 1] - s[i]);
      extra.push_back((1 - t) * row3(V, a) + t * row3(V, b));
      m.parents.push_back({a, b});
      m.parent_weight.push_back(t);
      m.extra_uv.push_back(rectangle_perimeter_point(corners[c], w));
      extra_side.push_back(kCornerSides[c]);
      const int id = nv + static_cast<int>(extra.size()) - 1;
      chain.push_back(id);
      m.loop.push_back(id);
      ++R.corner_vertices_inserted;
    }
    chain.push_back(b);
    pieces[f].clear();
    for (size_t k = 0; k + 1 < chain.size(); ++k) pieces[f].push_back({chain[k], chain[k + 1], x});
  }

  // Side masks and positions over all vertices so far.
  const int n1 = nv + static_cast<int>(extra.size());
  m.mask.assign(n1, 0);
  for (int v = 0; v < nv; ++v) m.mask[v] = side[v];
  for (size_t k = 0; k < extra.size(); ++k) m.mask[nv + k] = extra_side[k];
  size_t count = 0;
  for (const auto& p : pieces) count += p.size();
  m.F.resize(static_cast<Eigen::Index>(count), 3);
  Eigen::Index r = 0;
  for (size_t f = 0; f < pieces.size(); ++f)
    for (const Face& t : pieces[f]) {
      m.F.row(r++) << t[0], t[1], t[2];
      m.origin.push_back(static_cast<int>(f));
    }
  m.pos.resize(n1);
  for (int v = 0; v < nv; ++v) m.pos[v] = row3(V, v);
  for (size_t k = 0; k < extra.size(); ++k) m.pos[nv + k] = extra[k];
  return m;
}

// Step 3: dividing edges (interior edges whose endpoints share a side) flipped where the quad
// allows it (flip_dividing_edges), the rest split at their 3D midpoint; triangles with 1, 2 or 3
// split edges become 2, 3 or 4. Returns the faces (and each one's input face); appends the
// midpoints to m.pos and m.parents.
MatrixXi split_ear_edges(SplitMesh& m, const RectangleBoundaryMap& opt, ConformalMapResult& R, std::vector<int>* out_origin) {
  const int n1 = static_cast<int>(m.pos.size());
  std::vector<Eigen::Vector3d>& all_pos = m.pos;
  const std::vector<int>& mask = m.mask;
  EdgeTopology topo1 = edge_topology(m.F, n1);
  if (opt.flip_dividing_edges) R.edges_flipped = flip_dividing_edges(all_pos, m.mask, m.F, m.origin, topo1);
  const MatrixXi& F1 = m.F;
  std::vector<int> mid(topo1.E.rows(), -1);
  for (Eigen::Index e = 0; e < topo1.E.rows(); ++e) {
    const int a = topo1.E(e, 0), b = topo1.E(e, 1);
    if (topo1.edge_faces[e].size() == 2 && (mask[a] & mask[b]) != 0) {
      mid[e] = static_cast<int>(all_pos.size());
      all_pos.push_back(0.5 * (all_pos[a] + all_pos[b]));
      m.parents.push_back({a, b});
      m.parent_weight.push_back(0.5);
      ++R.edges_split;
    }
  }
  std::vector<Face> out_faces;
  out_faces.reserve(F1.rows() + 3 * R.edges_split);
  for (Eigen::Index f = 0; f < F1.rows(); ++f) {
    const int v[3] = {F1(f, 0), F1(f, 1), F1(f, 2)};
    const int mc[3] = {mid[topo1.FE(f, 0)], mid[topo1.FE(f, 1)], mid[topo1.FE(f, 2)]};  // mc[c] on the edge opposite corner c
    const int nsplit = (mc[0] >= 0) + (mc[1] >= 0) + (mc[2] >= 0);
    auto emit = [&](int a, int b, int c) {
      out_faces.push_back({a, b, c});
      out_origin->push_back(m.origin[f]);
    };
    if (nsplit == 0) {
      emit(v[0], v[1], v[2]);
    } else if (nsplit == 1) {
      int c = 0;
      while (mc[c] < 0) ++c;
      emit(v[c], v[(c + 1) % 3], mc[c]);
      emit(v[c], mc[c], v[(c + 2) % 3]);
    } else if (nsplit == 2) {
      int c = 0;  // the corner opposite the unsplit edge
      while (mc[c] >= 0) ++c;
      const int c1 = (c + 1) % 3, c2 = (c + 2) % 3;
      // mc[c2] lies on edge (v_c, v_c1), mc[c1] on edge (v_c2, v_c).
      emit(v[c], mc[c2], mc[c1]);
      // Quad (mc[c2], v_c1, v_c2, mc[c1]): cut along its shorter diagonal.
      const double d1 = (all_pos[mc[c2]] - all_pos[v[c2]]).norm(), d2 = (all_pos[v[c1]] - all_pos[mc[c1]]).norm();
      if (d1 <= d2) {
        emit(mc[c2], v[c1], v[c2]);
        emit(mc[c2], v[c2], mc[c1]);
      } else {
        emit(v[c1], v[c2], mc[c1]);
        emit(v[c1], mc[c1], mc[c2]);
      }
    } else {
      emit(v[0], mc[2], mc[1]);
      emit(v[1], mc[0], mc[2]);
      emit(v[2], mc[1], mc[0]);
      emit(mc[0], mc[1], mc[2]);
    }
  }
  MatrixXi out(static_cast<Eigen::Index>(out_faces.size()), 3);
  for (size_t f = 0; f < out_faces.size(); ++f) out.row(f) << out_faces[f][0], out_faces[f][1], out_faces[f][2];
  return out;
}

// Step 4: the harmonic map with the Dirichlet boundary `buv` on R's mesh: cotangent weights
// (then, with sliding_boundary, the sliding LSCM), falling back to opt.fallback and then uniform
// weights while triangles fold (Tutte/Floater: positive weights on a convex boundary embed).
void harmonic_map_with_fallback(ConformalMapResult& R, const MatrixXd& buv, const RectangleBoundaryMap& opt, SpdSolver& spd) {
  const std::vector<int>& loop = R.boundary;
  const double w = opt.width;
  // Flipped or degenerate: signed area below a tiny fraction of the mean triangle area.
  const double min_area = flip_area_threshold(w, R.F.rows());
  auto solve_with_fallback = [&] {
    R.weights = opt.fallback;
    R.UV = harmonic_map(R.V, R.F, loop, buv, opt.fallback, spd);
    if (count_flipped(R.UV, R.F, min_area) > 0) {
      R.weights = HarmonicWeights::Uniform;
      R.UV = harmonic_map(R.V, R.F, loop, buv, HarmonicWeights::Uniform);
    }
  };
  if (!opt.try_cotangent) {
    solve_with_fallback();
    return;
  }
  R.weights = HarmonicWeights::Cotangent;
  R.UV = harmonic_map(R.V, R.F, loop, buv, HarmonicWeights::Cotangent, spd);
  if (opt.sliding_boundary) {
    // Least-squares conformal map with the boundary vertices free to slide along their sides
    // (corners and the anchor fixed): the area term of LSCM is constant on this constraint set,
    // so it is the Dirichlet energy of u and v separately, each with mixed boundary conditions.
    const int pinned = opt.anchor_vertex >= 0 ? opt.anchor_vertex : -1;
    for (HarmonicWeights hw : {HarmonicWeights::Cotangent, HarmonicWeights::MeanValue}) {
      MatrixXd slid = sliding_harmonic_map(R.V, R.F, R.side_mask, w, R.UV, pinned, hw);
      bool inside = true;
      for (int v : loop) inside = inside && slid(v, 0) >= 0 && slid(v, 0) <= w && slid(v, 1) >= 0 && slid(v, 1) <= 1;
      if (inside && count_flipped(slid, R.F, min_area) == 0) {
        R.UV = std::move(slid);
        R.sliding = true;
        R.weights = hw;
        return;
      }
    }
  }
  R.cotangent_flips = count_flipped(R.UV, R.F, min_area);
  if (R.cotangent_flips > 0) solve_with_fallback();
}

}  // namespace

ConformalMapResult conformal_rectangle_mesh(const MatrixXd& V, const MatrixXi& F, const RectangleBoundaryMap& opt) {
  const int nv = static_cast<int>(V.rows());
  const double w = opt.width;
  if (!(w > 0)) throw std::invalid_argument("conformal_rectangle_map: the rectangle width must be positive");
  if (V.cols() < 3) throw std::invalid_argument("conformal_rectangle_map: V must have 3 columns");
  ConformalMapResult R;
  const BoundaryCoordinates bc = rectangle_boundary_coordinates(V, disk_boundary_loop(V, F), opt);
  SplitMesh m = split_corner_edges(V, F, bc, opt, R);
  const int n1 = static_cast<int>(m.pos.size());
  std::vector<int> origin;
  R.F = split_ear_edges(m, opt, R, &origin);

  // Assemble the result.
  const int ntot = static_cast<int>(m.pos.size());
  R.num_input_vertices = nv;
  R.width = w;
  R.V.resize(ntot, 3);
  for (int v = 0; v < ntot; ++v) R.V.row(v) = m.pos[v].transpose();
  R.face_origin = Eigen::Map<const VectorXi>(origin.data(), static_cast<Eigen::Index>(origin.size()));
  R.inserted_parents.resize(static_cast<Eigen::Index>(m.parents.size()), 2);
  R.inserted_weight.resize(static_cast<Eigen::Index>(m.parents.size()));
  for (size_t k = 0; k < m.parents.size(); ++k) {
    R.inserted_parents.row(k) << m.parents[k][0], m.parents[k][1];
    R.inserted_weight[k] = m.parent_weight[k];
  }
  R.side_mask = VectorXi::Zero(ntot);
  for (int v = 0; v < n1; ++v) R.side_mask[v] = m.mask[v];
  R.boundary = m.loop;

  // Dirichlet data: the boundary's perimeter points.
  R.boundary_uv.resize(static_cast<Eigen::Index>(m.loop.size()), 2);
  for (size_t k = 0; k < m.loop.size(); ++k) {
    const int v = m.loop[k];
    R.boundary_uv.row(k) = v < nv ? rectangle_perimeter_point(m.vertex_s[v], w).transpose() : m.extra_uv[v - nv].transpose();
  }
  return R;
}

void conformal_rectangle_solve(ConformalMapResult& R, const RectangleBoundaryMap& opt, SpdSolver* solver) {
  SpdSolver local;
  harmonic_map_with_fallback(R, R.boundary_uv, opt, solver ? *solver : local);  // one analysis for every system
}

ConformalMapResult conformal_rectangle_map(const MatrixXd& V, const MatrixXi& F, const RectangleBoundaryMap& opt,
                                           SpdSolver* solver) {
  ConformalMapResult R = conformal_rectangle_mesh(V, F, opt);
  conformal_rectangle_solve(R, opt, solver);
  return R;
}

}  // namespace authalic

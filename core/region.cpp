// Region from vertices -> one disk of faces: islands, holes and pinch vertices (core/region.h).
#include "core/region.h"

#include <algorithm>
#include <cstdio>
#include <numeric>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/union_find.h"

namespace authalic {

namespace {

// Everything about F the steps read: edges with their faces, and the faces around each vertex.
struct Surface {
  const MatrixXi& F;
  VectorXd A;                         // face areas
  EdgeTopology t;
  std::vector<int> vf_start, vf;      // faces of vertex v: vf[vf_start[v] .. vf_start[v+1]), ascending
  int nv = 0, nf = 0;

  Surface(const MatrixXd& V, const MatrixXi& F_) : F(F_), A(face_areas(V, F_)), t(edge_topology(F_, static_cast<int>(V.rows()))) {
    nv = static_cast<int>(V.rows());
    nf = static_cast<int>(F.rows());
    vf_start.assign(static_cast<std::size_t>(nv) + 1, 0);
    for (int f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) ++vf_start[F(f, c) + 1];
    for (int v = 0; v < nv; ++v) vf_start[v + 1] += vf_start[v];
    vf.resize(static_cast<std::size_t>(vf_start[nv]));
    std::vector<int> fill(vf_start.begin(), vf_start.end() - 1);
    for (int f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) vf[fill[F(f, c)]++] = f;  // f ascending, so each list is sorted
  }
  bool border_edge(int e) const { return t.edge_faces[e].size() == 1; }
};

// Components of the faces with mask == want, connected over edges; comp = -1 elsewhere. Ids in
// order of their lowest face.
int edge_components(const Surface& s, const std::vector<char>& mask, char want, std::vector<int>& comp) {
  comp.assign(static_cast<std::size_t>(s.nf), -1);
  int n = 0;
  std::vector<int> stack;
  for (int seed = 0; seed < s.nf; ++seed) {
    if (mask[seed] != want || comp[seed] >= 0) continue;
    comp[seed] = n;
    stack.assign(1, seed);
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      for (int c = 0; c < 3; ++c)
        for (int g : s.t.edge_faces[s.t.FE(f, c)])
          if (mask[g] == want && comp[g] < 0) {
            comp[g] = n;
            stack.push_back(g);
          }
    }
    ++n;
  }
  return n;
}

// Keeps the component of largest area (ties: lowest face); clears the others' faces from mask and
// returns the per-face component ids (before clearing) and the kept id (-1 when mask is empty).
int keep_largest(const Surface& s, std::vector<char>& mask, std::vector<int>& comp, int* count) {
  const int n = edge_components(s, mask, 1, comp);
  std::vector<double> area(static_cast<std::size_t>(n), 0.0);
  for (int f = 0; f < s.nf; ++f)
    if (comp[f] >= 0) area[comp[f]] += s.A[f];
  int best = -1;
  for (int k = 0; k < n; ++k)
    if (best < 0 || area[k] > area[best]) best = k;
  for (int f = 0; f < s.nf; ++f)
    if (comp[f] >= 0 && comp[f] != best) mask[f] = 0;
  if (count) *count = n;
  return best;
}

// Vertices used by the faces in mask.
std::vector<char> used_vertices(const Surface& s, const std::vector<char>& mask) {
  std::vector<char> used(static_cast<std::size_t>(s.nv), 0);
  for (int f = 0; f < s.nf; ++f)
    if (mask[f])
      for (int c = 0; c < 3; ++c) used[s.F(f, c)] = 1;
  return used;
}

// Per vertex: the faces in mask around it form more than one fan. Two faces at v are in one fan
// when they share an edge (v, w) that has exactly these two faces in mask (as analyze_topology).
std::vector<char> pinch_vertices(const Surface& s, const std::vector<char>& mask) {
  UnionFind corners(3 * s.nf);
  auto corner_of = [&](int f, int v) {
    for (int c = 0; c < 3; ++c)
      if (s.F(f, c) == v) return 3 * f + c;
    return -1;
  };
  std::vector<int> in;
  for (Eigen::Index e = 0; e < s.t.E.rows(); ++e) {
    in.clear();
    for (int g : s.t.edge_faces[e])
      if (mask[g]) in.push_back(g);
    if (in.size() != 2) continue;
    for (int v : {s.t.E(e, 0), s.t.E(e, 1)}) corners.unite(corner_of(in[0], v), corner_of(in[1], v));
  }
  std::vector<int> root(static_cast<std::size_t>(s.nv), -1);
  std::vector<char> pinch(static_cast<std::size_t>(s.nv), 0);
  for (int f = 0; f < s.nf; ++f) {
    if (!mask[f]) continue;
    for (int c = 0; c < 3; ++c) {
      const int v = s.F(f, c), r = corners.find(3 * f + c);
      if (root[v] < 0)
        root[v] = r;
      else if (root[v] != r)
        pinch[v] = 1;
    }
  }
  return pinch;
}

// The faces of F outside the region, grouped over edges, and which group is the outer side.
struct Complement {
  std::vector<int> comp;  // per face: group id, -1 for region faces
  struct Group {
    double area = 0;
    int faces = 0;
    bool open = false;      // reaches the border of F
    bool adjacent = false;  // shares an edge with the region
  };
  std::vector<Group> groups;
  int outer = -1;  // -1: the border of F is the outer side (or there is no group)
  bool is_hole(int g) const { return groups[g].adjacent && !groups[g].open && g != outer; }
};

Complement complement(const Surface& s, const std::vector<char>& mask) {
  Complement c;
  const int n = edge_components(s, mask, 0, c.comp);
  c.groups.resize(static_cast<std::size_t>(n));
  bool border_is_outer = false;
  for (int f = 0; f < s.nf; ++f) {
    const int g = c.comp[f];
    for (int k = 0; k < 3; ++k) {
      const int e = s.t.FE(f, k);
      if (g < 0) {
        if (s.border_edge(e)) border_is_outer = true;  // the region reaches F's border
        continue;
      }
      if (s.border_edge(e)) c.groups[g].open = true;
      for (int h : s.t.edge_faces[e])
        if (mask[h]) c.groups[g].adjacent = true;
    }
    if (g >= 0) {
      c.groups[g].area += s.A[f];
      ++c.groups[g].faces;
    }
  }
  for (const auto& g : c.groups)
    if (g.adjacent && g.open) border_is_outer = true;
  if (!border_is_outer)
    for (int g = 0; g < n; ++g)
      if (c.groups[g].adjacent && (c.outer < 0 || c.groups[g].area > c.groups[c.outer].area)) c.outer = g;
  return c;
}

std::string mm2(double a) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f", a);
  return buf;
}

std::string plural(int n, const char* one, const char* many) { return std::to_string(n) + " " + (n == 1 ? one : many); }



// Step 4 of region_faces_from_vertices: at each pinch vertex of the mask only its largest fan of
// faces stays (the smaller fans are removed, and their vertices checked again), then the largest
// piece left. Returns the faces removed (mask is updated).
std::vector<char> remove_smaller_fans(const Surface& s, const MatrixXi& F, std::vector<char>& mask) {
  std::vector<char> removed(static_cast<std::size_t>(s.nf), 0);
  const std::vector<char> pinch = pinch_vertices(s, mask);
  std::set<int> todo;
  for (int v = 0; v < s.nv; ++v)
    if (pinch[v]) todo.insert(v);
  std::vector<int> faces;
  std::vector<std::pair<int, int>> by_neighbour;  // (w, local face index)
  while (!todo.empty()) {
    const int v = *todo.begin();
    todo.erase(todo.begin());
    faces.clear();
    for (int k = s.vf_start[v]; k < s.vf_start[v + 1]; ++k)
      if (mask[s.vf[k]]) faces.push_back(s.vf[k]);
    if (faces.size() < 2) continue;
    const int m = static_cast<int>(faces.size());
    by_neighbour.clear();
    for (int i = 0; i < m; ++i)
      for (int c = 0; c < 3; ++c)
        if (F(faces[i], c) != v) by_neighbour.emplace_back(F(faces[i], c), i);
    std::sort(by_neighbour.begin(), by_neighbour.end());
    UnionFind fans(m);
    for (std::size_t i = 0; i < by_neighbour.size();) {
      std::size_t j = i;
      while (j < by_neighbour.size() && by_neighbour[j].first == by_neighbour[i].first) ++j;
      if (j - i == 2) fans.unite(by_neighbour[i].second, by_neighbour[i + 1].second);
      i = j;
    }
    std::vector<double> area(static_cast<std::size_t>(m), 0.0);
    for (int i = 0; i < m; ++i) area[fans.find(i)] += s.A[faces[i]];
    int best = -1;  // roots are the lowest local index, i.e. the fan's lowest face
    for (int i = 0; i < m; ++i)
      if (fans.find(i) == i && (best < 0 || area[i] > area[best])) best = i;
    bool any = false;
    for (int i = 0; i < m; ++i)
      if (fans.find(i) != best) {
        any = true;
        mask[faces[i]] = 0;
        removed[faces[i]] = 1;
        for (int c = 0; c < 3; ++c) todo.insert(F(faces[i], c));
      }
    if (any) todo.insert(v);
  }
  const std::vector<char> before = mask;
  std::vector<int> comp;
  keep_largest(s, mask, comp, nullptr);
  for (int f = 0; f < s.nf; ++f)
    if (before[f] && !mask[f]) removed[f] = 1;
  return removed;
}

// The enclosed holes left in the final mask (too large to fill): their number, and the largest
// one's area, share and vertices (those not used by the region).
void measure_unfilled_holes(const Surface& s, const std::vector<char>& mask, const std::vector<char>& used, RegionCleanup& r) {
  const Complement c = complement(s, mask);
  int largest = -1;
  for (std::size_t g = 0; g < c.groups.size(); ++g)
    if (c.is_hole(static_cast<int>(g))) {
      ++r.holes_unfilled;
      if (largest < 0 || c.groups[g].area > c.groups[largest].area) largest = static_cast<int>(g);
    }
  if (largest >= 0) {
    r.largest_unfilled_hole_mm2 = c.groups[largest].area;
    r.largest_unfilled_hole_fraction = r.fill_rule_area_mm2 > 0 ? c.groups[largest].area / r.fill_rule_area_mm2 : 0;
    std::vector<char> hole(static_cast<std::size_t>(s.nf), 0);
    for (int f = 0; f < s.nf; ++f) hole[f] = c.comp[f] == largest;
    const std::vector<char> hole_used = used_vertices(s, hole);
    for (int v = 0; v < s.nv; ++v)
      if (hole_used[v] && !used[v]) ++r.largest_unfilled_hole_vertices;
  }
}

}  // namespace

namespace {

// Empty when a region can be cut from the surface by its vertices: every edge in at most two
// triangles, the triangles consistently oriented and none repeated; otherwise what is wrong.
std::string surface_problem_for_regions(const TopologyReport& t) {
  std::vector<std::string> damage;
  if (t.non_manifold_edges > 0)
    damage.push_back(plural(t.non_manifold_edges, "edge is", "edges are") + " shared by more than two triangles (non-manifold)");
  if (t.inconsistent_orientation_edges > 0)
    damage.push_back(plural(t.inconsistent_orientation_edges, "edge is", "edges are") +
                     " traversed the same way by both its triangles (inconsistent orientation)");
  if (t.duplicate_faces > 0) damage.push_back(plural(t.duplicate_faces, "triangle is", "triangles are") + " repeated");
  if (damage.empty()) return {};
  std::string s = "the surface is not a clean triangle mesh: ";
  for (std::size_t i = 0; i < damage.size(); ++i) s += (i ? "; " : "") + damage[i];
  return s + "; repair it (orient its faces consistently, remove repeated and dangling triangles) before cutting a region from it";
}

}  // namespace

RegionCleanup region_faces_from_vertices(const MatrixXd& V, const MatrixXi& F, const std::vector<bool>& in_region,
                                         const RegionCleanupOptions& opt) {
  if (static_cast<Eigen::Index>(in_region.size()) != V.rows())
    throw InputError("region: " + std::to_string(in_region.size()) + " region flags for " + std::to_string(V.rows()) +
                     " vertices; give one flag per surface vertex");
  if (F.cols() != 3) throw InputError("region: faces must have three vertices");
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (F(f, c) < 0 || F(f, c) >= V.rows())
        throw InputError("region: face " + std::to_string(f) + " refers to vertex " + std::to_string(F(f, c)) + " of " +
                         std::to_string(V.rows()) + "; give faces on the surface's vertices");
  if (!(opt.max_hole_fraction >= 0)) throw InputError("region: max_hole_fraction must be >= 0");

  const Surface s(V, F);
  RegionCleanup r;
  r.max_hole_fraction = opt.max_hole_fraction;
  r.label_vertices = static_cast<int>(std::count(in_region.begin(), in_region.end(), true));

  // 1. Faces with all three vertices in the region.
  std::vector<char> raw(static_cast<std::size_t>(s.nf), 0);
  for (int f = 0; f < s.nf; ++f) {
    raw[f] = in_region[F(f, 0)] && in_region[F(f, 1)] && in_region[F(f, 2)];
    if (raw[f]) {
      ++r.raw_faces;
      r.raw_area_mm2 += s.A[f];
    }
  }
  const std::vector<char> raw_used = used_vertices(s, raw);
  const std::vector<char> raw_pinch = pinch_vertices(s, raw);
  r.raw_pinch_vertices = static_cast<int>(std::count(raw_pinch.begin(), raw_pinch.end(), 1));
  std::vector<char> mask = raw;

  // 2. Keep the largest edge-connected piece.
  std::vector<int> island_of;
  int pieces = 0;
  const int kept = keep_largest(s, mask, island_of, &pieces);
  double region_area = 0;
  for (int f = 0; f < s.nf; ++f)
    if (mask[f]) region_area += s.A[f];
  r.fill_rule_area_mm2 = region_area;

  // 3. Fill the enclosed holes below the size limit.
  if (kept >= 0) {
    const Complement c = complement(s, mask);
    std::vector<char> fill(c.groups.size(), 0);
    for (std::size_t g = 0; g < c.groups.size(); ++g)
      if (c.is_hole(static_cast<int>(g)) && c.groups[g].area < opt.max_hole_fraction * region_area) {
        fill[g] = 1;
        ++r.holes_filled;
      }
    std::vector<char> added(static_cast<std::size_t>(s.nf), 0);
    for (int f = 0; f < s.nf; ++f)
      if (c.comp[f] >= 0 && fill[c.comp[f]]) {
        mask[f] = 1;
        if (!raw[f]) {
          added[f] = 1;
          ++r.hole_faces_added;
          r.hole_area_mm2 += s.A[f];
        }
      }
    const std::vector<char> added_used = used_vertices(s, added);
    for (int v = 0; v < s.nv; ++v)
      if (added_used[v] && !raw_used[v]) ++r.hole_vertices_added;
  }
  // Islands that no filled hole brought back.
  std::vector<char> island_dropped(static_cast<std::size_t>(std::max(pieces, 0)), 0);
  for (int f = 0; f < s.nf; ++f)
    if (island_of[f] >= 0 && island_of[f] != kept && !mask[f]) island_dropped[island_of[f]] = 1;
  r.islands_dropped = static_cast<int>(std::count(island_dropped.begin(), island_dropped.end(), 1));
  std::vector<char> island_faces(static_cast<std::size_t>(s.nf), 0);
  std::vector<double> island_area(island_dropped.size(), 0.0);
  for (int f = 0; f < s.nf; ++f)
    if (island_of[f] >= 0 && island_dropped[island_of[f]]) {
      island_faces[f] = 1;
      ++r.island_faces;
      r.island_area_mm2 += s.A[f];
      island_area[static_cast<std::size_t>(island_of[f])] += s.A[f];
    }
  for (double a : island_area) r.largest_island_mm2 = std::max(r.largest_island_mm2, a);
  r.largest_island_fraction = region_area > 0 ? r.largest_island_mm2 / region_area : 0.0;

  // 4. Pinch vertices left: remove the smaller fans, then any piece cut loose.
  const std::vector<char> removed = remove_smaller_fans(s, F, mask);
  {
    for (int f = 0; f < s.nf; ++f)
      if (removed[f]) {
        ++r.pinch_faces_removed;
        r.pinch_area_mm2 += s.A[f];
      }
  }

  // The result and what changed, against the label and the raw faces.
  const std::vector<char> used = used_vertices(s, mask);
  {
    const std::vector<char> island_used = used_vertices(s, island_faces), removed_used = used_vertices(s, removed);
    for (int v = 0; v < s.nv; ++v) {
      if (used[v]) {
        if (!in_region[v]) ++r.vertices_outside_label;
        continue;
      }
      if (in_region[v]) ++r.label_vertices_outside;
      if (island_used[v]) ++r.island_vertices;
      if (removed_used[v]) ++r.pinch_vertices_removed;
    }
  }
  const int count = static_cast<int>(std::count(mask.begin(), mask.end(), 1));
  r.F.resize(count, 3);
  r.face_index.resize(count);
  for (int f = 0, k = 0; f < s.nf; ++f)
    if (mask[f]) {
      r.F.row(k) = F.row(f);
      r.face_index[k++] = f;
      r.area_mm2 += s.A[f];
    }
  r.topology = analyze_topology(V, r.F);
  {
    const std::vector<char> pinch = pinch_vertices(s, mask);
    for (int v = 0; v < s.nv; ++v)
      if (raw_pinch[v] && !pinch[v]) ++r.pinch_vertices_fixed;
  }
  if (count > 0) measure_unfilled_holes(s, mask, used, r);
  if (!r.is_disk()) r.surface_damage = surface_problem_for_regions(analyze_topology(V, F));
  return r;
}

std::string RegionCleanup::summary() const {
  std::vector<std::string> parts;
  if (holes_filled > 0)
    parts.push_back("filled " + plural(holes_filled, "hole", "holes") + " (" + plural(hole_vertices_added, "vertex", "vertices") +
                    ", " + mm2(hole_area_mm2) + " mm^2)");
  if (islands_dropped > 0)
    parts.push_back("dropped " + plural(islands_dropped, "island", "islands") + " (" +
                    plural(island_vertices, "vertex", "vertices") + ", " + mm2(island_area_mm2) + " mm^2)");
  if (pinch_vertices_fixed > 0 || pinch_faces_removed > 0) {
    std::string p = "fixed " + plural(pinch_vertices_fixed, "pinch vertex", "pinch vertices");
    if (pinch_faces_removed > 0)
      p += " (removed " + plural(pinch_faces_removed, "face", "faces") + ", " + plural(pinch_vertices_removed, "vertex", "vertices") +
           ", " + mm2(pinch_area_mm2) + " mm^2)";
    parts.push_back(p);
  }
  if (parts.empty()) return "no cleanup needed";
  std::string out;
  for (std::size_t i = 0; i < parts.size(); ++i) out += (i ? ", " : "") + parts[i];
  return out;
}

std::string RegionCleanup::pieces_problem() const {
  if (islands_dropped == 0 || !(largest_island_fraction >= max_hole_fraction) || max_hole_fraction <= 0) return "";
  char buf[160];
  std::snprintf(buf, sizeof(buf), "%.1f mm^2 (%.1f %% of the largest piece)", largest_island_mm2, 100.0 * largest_island_fraction);
  return "the region is " + std::to_string(islands_dropped + 1) + " pieces: " +
         (islands_dropped == 1 ? std::string("a second piece of ") : std::string("the second largest of ")) + buf +
         " would be left out of the map (pieces below " + mm2(100.0 * max_hole_fraction) +
         " % of the largest are dropped as stray label vertices); give one piece of cortex, or map each piece with its own label";
}

std::string RegionCleanup::problem() const {
  if (is_disk()) return {};
  if (F.rows() == 0) return "the region has no face with all three vertices in it";
  std::ostringstream s;
  s << "the region is not one disk after cleanup (" << topology.summary() << ")";
  if (holes_unfilled > 0) {
    char buf[200];
    std::snprintf(buf, sizeof(buf), "%.1f mm^2 (%.2f %% of the region before filling, %d vertices", largest_unfilled_hole_mm2,
                  100.0 * largest_unfilled_hole_fraction, largest_unfilled_hole_vertices);
    s << "; " << plural(holes_unfilled, "hole was", "holes were") << " too large to fill, the largest " << buf
      << "; holes below " << 100.0 * max_hole_fraction << " % of the region are filled)";
  } else {
    s << "; no hole was left unfilled";
  }
  if (changed()) s << "; cleanup: " << summary();
  return s.str();
}

}  // namespace authalic

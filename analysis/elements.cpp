// Equal-area cortical elements (see analysis/elements.h).
#include "analysis/elements.h"

#include <algorithm>
#include <numeric>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <tuple>

#include "analysis/render.h"
#include "analysis/report.h"
#include "analysis/table_text.h"
#include "core/error.h"
#include "core/grid_overlap.h"
#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

namespace authalic::analysis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt(double x, int precision = 4) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", precision, x);
  return buf;
}

using EdgeKey = std::pair<int, int>;
EdgeKey edge_key(int a, int b) { return a < b ? EdgeKey{a, b} : EdgeKey{b, a}; }

// Traces each vertex the flattening appended (index >= nv) to the surface edge it splits, replaying
// the splits on the surface's own triangles: vertex w split the current half-edge a->b when a-b is
// no edge of the map and the map has the half-edges a->w and w->b (the two pieces of the face that held a->b keep its
// orientation). Splits are replayed in index order, so a vertex may split an edge made by an
// earlier one (e.g. an ear split next to a corner split).
void trace_inserted_vertices(ElementMap& m, const MatrixXi& F_surface, const std::string& map_name) {
  const int nv = m.num_surface_vertices;
  const int nm = static_cast<int>(m.D.rows());
  if (nm == nv) return;
  std::set<EdgeKey> map_half_edges;
  std::vector<std::set<int>> ring(static_cast<std::size_t>(nm));
  for (int f = 0; f < m.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = m.F(f, c), b = m.F(f, (c + 1) % 3);
      map_half_edges.insert({a, b});
      ring[static_cast<std::size_t>(a)].insert(b);
      ring[static_cast<std::size_t>(b)].insert(a);
    }
  // The map may have turned the surface's faces around (square_map's outward rule, e.g. on a
  // right hemisphere): replay the splits on the surface faces in the map's orientation.
  int same = 0, reversed = 0;
  for (int f = 0; f < F_surface.rows(); ++f) {
    const int a = F_surface(f, 0), b = F_surface(f, 1);
    same += map_half_edges.count({a, b}) > 0;
    reversed += map_half_edges.count({b, a}) > 0;
  }
  const bool flip = reversed > same;
  std::map<EdgeKey, int> current;  // directed half-edge (a, b) -> the third vertex of its face
  for (int f = 0; f < F_surface.rows(); ++f) {
    const int v0 = F_surface(f, 0), v1 = flip ? F_surface(f, 2) : F_surface(f, 1), v2 = flip ? F_surface(f, 1) : F_surface(f, 2);
    current[{v0, v1}] = v2;
    current[{v1, v2}] = v0;
    current[{v2, v0}] = v1;
  }
  // Map faces as rotation-normalised triples, to recognise the pieces of a split face.
  auto face_key = [](int a, int b, int c) {
    if (b < a && b < c) return std::array<int, 3>{b, c, a};
    if (c < a && c < b) return std::array<int, 3>{c, a, b};
    return std::array<int, 3>{a, b, c};
  };
  std::set<std::array<int, 3>> map_faces;
  for (int f = 0; f < m.F.rows(); ++f) map_faces.insert(face_key(m.F(f, 0), m.F(f, 1), m.F(f, 2)));
  // The flattening splits only edges whose two endpoints lie on the boundary (corner splits of
  // boundary edges, ear splits of dividing edges), so both ends of a split edge are boundary
  // vertices of the map.
  std::vector<bool> on_boundary(static_cast<std::size_t>(nm), false);
  for (const EdgeKey& h : map_half_edges)
    if (!map_half_edges.count({h.second, h.first})) on_boundary[static_cast<std::size_t>(h.first)] = on_boundary[static_cast<std::size_t>(h.second)] = true;
  for (int w = nv; w < nm; ++w) {
    const auto& r = ring[static_cast<std::size_t>(w)];
    // Candidates (undirected, p < q) with their evidence: how many of the pieces (a, w, o) and
    // (w, b, o) of the faces that held a->b are faces of the map (later splits may cut them).
    std::vector<std::pair<EdgeKey, int>> candidates;
    for (int a : r)
      for (int b : r) {
        if (a == b || !on_boundary[static_cast<std::size_t>(a)] || !on_boundary[static_cast<std::size_t>(b)]) continue;
        const auto it = current.find({a, b});
        if (it == current.end()) continue;
        if (map_half_edges.count({a, b}) || map_half_edges.count({b, a})) continue;  // still an edge: not split
        if (!map_half_edges.count({a, w}) || !map_half_edges.count({w, b})) continue;
        const int o = it->second;
        const int evidence = static_cast<int>(map_faces.count(face_key(a, w, o)) + map_faces.count(face_key(w, b, o)));
        const EdgeKey e = edge_key(a, b);
        auto c = std::find_if(candidates.begin(), candidates.end(), [&](const auto& x) { return x.first == e; });
        if (c == candidates.end()) {
          candidates.push_back({e, evidence});
        } else {
          c->second += evidence;
        }
      }
    // Keep the best-supported candidate(s).
    int best = -1;
    for (const auto& c : candidates) best = std::max(best, c.second);
    candidates.erase(std::remove_if(candidates.begin(), candidates.end(), [&](const auto& c) { return c.second < best; }),
                     candidates.end());
    if (candidates.size() != 1)
      throw InputError(map_name + ": map vertex " + std::to_string(w) + " (appended by the flattening) cannot be traced to " +
                       (candidates.empty() ? std::string("a") : std::string("a unique")) + " surface edge it splits (the map has " +
                       std::to_string(nm) + " vertices, the surface " + std::to_string(nv) +
                       "); give the map computed from this surface (its vertices first, in order)");
    const int p = candidates[0].first.first, q = candidates[0].first.second;
    const bool boundary_edge = current.count({p, q}) + current.count({q, p}) == 1;
    double t = 0.5;  // ear split: the 3D midpoint (core/conformal_map.h)
    if (boundary_edge && m.D.cols() == 2) {
      // Corner split: placed by arc length along the boundary edge; read the fraction from the map.
      const double dp = (m.D.row(w) - m.D.row(p)).norm(), dq = (m.D.row(q) - m.D.row(w)).norm();
      if (dp + dq > 0) t = dp / (dp + dq);
    }
    m.V3.row(w) = (1 - t) * m.V3.row(p) + t * m.V3.row(q);
    m.values(w) = (1 - t) * m.values(p) + t * m.values(q);
    // Replay the split on the current triangles: face (a, b, o) -> (a, w, o) + (w, b, o).
    for (const EdgeKey& ab : {EdgeKey{p, q}, EdgeKey{q, p}}) {
      const auto it = current.find(ab);
      if (it == current.end()) continue;
      const int a = ab.first, b = ab.second, o = it->second;
      current.erase(it);
      current[{a, w}] = o;
      current[{w, o}] = a;
      current[{o, a}] = w;
      current[{w, b}] = o;
      current[{b, o}] = w;
      current[{o, w}] = b;
    }
  }
  m.inserted_vertices = nm - nv;
  m.notes.push_back(std::to_string(nm - nv) + " vertices appended by the flattening were traced to the surface edges they split");
}

}  // namespace

ElementGrid element_grid(const Domain& domain, int k) {
  if (k < 1 || k > 4096) throw InputError("--k: " + std::to_string(k) + " is out of range; use 1..4096");
  ElementGrid g;
  g.domain = domain;
  g.k = k;
  g.rows = domain.element_rows(k);
  g.cols = domain.element_cols(k);
  return g;
}

std::string seam_text(double seam_x) {
  if (!std::isfinite(seam_x)) return "none";
  std::string s;
  append_number(s, seam_x);
  return s;
}

namespace {
// "none" -> NaN, else a number in (0, upper); otherwise InputError naming the file, the key and
// what the value should be.
double parse_seam_value(const std::string& text, const std::string& what, const char* key, double upper,
                        const std::string& expected, const std::string& remedy) {
  if (text == "none") return std::nan("");
  double x = 0;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), x);
  if (r.ec != std::errc() || r.ptr != text.data() + text.size() || !(x > 0 && x < upper))
    throw InputError(what + ": metadata " + key + " '" + text + "' is not " + expected + " or \"none\"; rewrite the map with " + remedy);
  return x;
}
}  // namespace

double parse_seam(const std::string& text, const std::string& what) {
  return parse_seam_value(text, what, kSeamKey, 2.0, "a seam x in (0, 2)", "`authalic rectangle`");
}

double parse_seam_mm(const std::string& text, const std::string& what) {
  return parse_seam_value(text, what, kSeamMmKey, std::numeric_limits<double>::infinity(), "a seam x in mm",
                          "`authalic rectangle --flat`");
}

std::string table_correspondence(const ElementTable& table) {
  const auto it = table.metadata.find("correspondence");
  return it == table.metadata.end() ? kPerSubjectCorrespondence : it->second;
}

std::string hemisphere_of(const std::map<std::string, std::string>& metadata, const std::string& path) {
  const auto it = metadata.find("AnatomicalStructurePrimary");
  if (it != metadata.end()) {
    if (it->second.find("Left") != std::string::npos) return "left";
    if (it->second.find("Right") != std::string::npos) return "right";
  }
  std::string name = path.substr(path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/') + 1);
  for (char& ch : name) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  auto has = [&](const char* s) { return name.find(s) != std::string::npos; };
  // FreeSurfer's lh./rh., also as lh_/rh_ (and nilearn's white_left), BIDS hemi-L/R.
  if (name.rfind("lh.", 0) == 0 || name.rfind("lh_", 0) == 0 || has("hemi-l") || has("left")) return "left";
  if (name.rfind("rh.", 0) == 0 || name.rfind("rh_", 0) == 0 || has("hemi-r") || has("right")) return "right";
  return "unknown";
}

ElementMap prepare_element_map(const MatrixXd& V, const MatrixXi& F, const MatrixXd& map_V, const MatrixXi& map_F,
                               const VectorXd& values, const Domain& domain, const std::string& map_name) {
  const int nv = static_cast<int>(V.rows()), nm = static_cast<int>(map_V.rows());
  if (values.size() != nv)
    throw InputError("values: " + std::to_string(values.size()) + " values for a surface of " + std::to_string(nv) +
                     " vertices; sample the PET on this surface");
  if (nm < nv)
    throw InputError(map_name + ": the map has " + std::to_string(nm) + " vertices but the surface has " + std::to_string(nv) +
                     "; give the map computed from this surface");
  if (map_F.rows() == 0) throw InputError(map_name + ": the map has no triangles");
  if (map_F.minCoeff() < 0 || map_F.maxCoeff() >= nm) throw InputError(map_name + ": triangle indices out of range");
  if (!map_V.allFinite()) throw InputError(map_name + ": the map has non-finite coordinates");
  ElementMap m;
  m.num_surface_vertices = nv;
  m.F = map_F;
  m.V3 = MatrixXd::Zero(nm, 3);
  m.V3.topRows(nv) = V.leftCols(3);
  m.values = VectorXd::Constant(nm, kNaN);
  m.values.head(nv) = values;

  // Bounding box of the vertices the map's triangles use.
  std::vector<bool> used(static_cast<std::size_t>(nm), false);
  for (int f = 0; f < map_F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[static_cast<std::size_t>(map_F(f, c))] = true;

  if (!domain.planar()) {
    if (map_V.cols() < 3) throw InputError(map_name + ": a sphere map needs x, y, z coordinates");
    double mean_r = 0;
    int n = 0;
    for (int v = 0; v < nm; ++v)
      if (used[static_cast<std::size_t>(v)]) {
        mean_r += map_V.row(v).head<3>().norm();
        ++n;
      }
    mean_r /= n;
    // The centre: the area-weighted centroid of the triangles, zero for a sphere about the origin
    // however its vertices crowd (the vertex mean was 6 % of the radius off on the sphere map
    // `authalic sphere` makes of fsaverage5, and the map was refused).
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    double area = 0;
    for (int f = 0; f < map_F.rows(); ++f) {
      const Eigen::Vector3d a = map_V.row(map_F(f, 0)).head<3>().transpose(), b = map_V.row(map_F(f, 1)).head<3>().transpose(),
                            c = map_V.row(map_F(f, 2)).head<3>().transpose();
      const double af = 0.5 * (b - a).cross(c - a).norm();
      mean += af * (a + b + c) / 3.0;
      area += af;
    }
    if (area > 0) mean /= area;
    if (!(mean_r > 0) || mean.norm() > 0.05 * mean_r)
      throw InputError(map_name + ": not a sphere map centred at the origin (centre offset " + fmt(mean.norm()) +
                       " for radius " + fmt(mean_r) + "); pass --domain square or rectangle for flat maps");
    double worst = 0;
    m.D.resize(nm, 3);
    for (int v = 0; v < nm; ++v) {
      const double r = map_V.row(v).head<3>().norm();
      if (used[static_cast<std::size_t>(v)]) worst = std::max(worst, std::abs(r / mean_r - 1));
      m.D.row(v) = r > 0 ? Eigen::RowVector3d(map_V.row(v).head<3>() / r) : Eigen::RowVector3d(0, 0, 1);
    }
    if (worst > 0.01)
      m.notes.push_back("sphere map radii vary by up to " + fmt(100 * worst, 3) + "%; vertices were projected onto the unit sphere");
  } else if (domain.kind == DomainKind::Disk) {
    // The unit disk centred at the origin (flatten --domain disk; its mm map is scaled to radius 1).
    std::string problem;
    const double rmax = disk_map_radius(map_V, map_F, &problem);
    if (!problem.empty())
      throw InputError(map_name + ": is " + problem + "; give the map of `authalic flatten --domain disk` or choose --domain");
    m.D = map_V.leftCols(2) / rmax;
    if (std::abs(rmax - 1) > 1e-6) m.notes.push_back("the disk map was scaled from radius " + fmt(rmax) + " to 1");
  } else {
    const double W = domain.width();
    if (map_V.cols() >= 3) {
      double zmax = 0, xy = 0;
      for (int v = 0; v < nm; ++v)
        if (used[static_cast<std::size_t>(v)]) {
          zmax = std::max(zmax, std::abs(map_V(v, 2)));
          xy = std::max(xy, map_V.row(v).head<2>().cwiseAbs().maxCoeff());
        }
      if (zmax > 1e-6 * std::max(1.0, xy))
        throw InputError(map_name + ": the map is not flat (|z| up to " + fmt(zmax) + "); pass --domain sphere for sphere maps");
    }
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int v = 0; v < nm; ++v)
      if (used[static_cast<std::size_t>(v)]) {
        x0 = std::min(x0, map_V(v, 0));
        x1 = std::max(x1, map_V(v, 0));
        y0 = std::min(y0, map_V(v, 1));
        y1 = std::max(y1, map_V(v, 1));
      }
    const double tol = 1e-6;
    m.D = map_V.leftCols(2);
    const bool inside = x0 >= -tol && x1 <= W + tol && y0 >= -tol && y1 <= 1 + tol;
    if (!inside) {
      const double aspect = (x1 - x0) / (y1 - y0);
      if (!(std::abs(aspect / W - 1) < 0.02))
        throw InputError(map_name + ": the map spans [" + fmt(x0) + ", " + fmt(x1) + "] x [" + fmt(y0) + ", " + fmt(y1) +
                         "], which is not the " + to_string(domain.kind) + " domain [0," + fmt(W) + "] x [0,1] (aspect " +
                         fmt(aspect) + "); give the authalic map of this domain or choose --domain");
      for (int v = 0; v < nm; ++v) {
        m.D(v, 0) = (map_V(v, 0) - x0) / (x1 - x0) * W;
        m.D(v, 1) = (map_V(v, 1) - y0) / (y1 - y0);
      }
      m.notes.push_back("the map was rescaled from its bounding box [" + fmt(x0) + ", " + fmt(x1) + "] x [" + fmt(y0) + ", " +
                        fmt(y1) + "] onto the " + to_string(domain.kind) + " domain");
    }
  }
  trace_inserted_vertices(m, F, map_name);
  return m;
}

ElementResult compute_elements(const ElementMap& map, const ElementGrid& grid, const Eigen::Matrix4d& to_scanner) {
  const int ncell = grid.num_elements();
  const std::vector<OverlapPiece> pieces = grid.domain.element_overlap(map.D, map.F, grid.k);
  const VectorXd area3d = face_areas(map.V3, map.F);
  const VectorXd area_domain = piece_face_areas(pieces, static_cast<int>(map.F.rows()));

  // Accumulate in piece order (sorted by face, then cell): deterministic for any thread count.
  std::vector<double> area(ncell, 0.0), value_area(ncell, 0.0), weighted_value(ncell, 0.0);
  std::vector<Eigen::Vector3d> weighted_centroid(ncell, Eigen::Vector3d::Zero());
  for (const OverlapPiece& p : pieces) {
    const double fd = area_domain(p.face);
    if (!(fd > 0)) continue;
    const double a = area3d(p.face) * p.domain_area / fd;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    double value = 0;
    for (int k = 0; k < 3; ++k) {
      const int v = map.F(p.face, k);
      centroid += p.bary[k] * map.V3.row(v).transpose();
      value += p.bary[k] * map.values(v);
    }
    area[p.cell] += a;
    weighted_centroid[p.cell] += a * centroid;
    if (std::isfinite(value)) {
      value_area[p.cell] += a;
      weighted_value[p.cell] += a * value;
    }
  }

  ElementResult r;
  r.block.elements.resize(ncell);
  for (int c = 0; c < ncell; ++c) {
    Element& e = r.block.elements[c];
    e.id = c;
    e.row = c / grid.cols;
    e.col = c % grid.cols;
    e.area_mm2 = area[c];
    if (area[c] > 0) e.centroid = (to_scanner * (weighted_centroid[c] / area[c]).homogeneous()).head<3>();
    if (value_area[c] > 0) e.value = weighted_value[c] / value_area[c];
  }
  // Vertices: the surface's vertices used by the map's triangles, by the cell of their map point.
  const int nv = map.num_surface_vertices;
  std::vector<bool> used(static_cast<std::size_t>(map.D.rows()), false);
  for (int f = 0; f < map.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) used[static_cast<std::size_t>(map.F(f, k))] = true;
  r.vertex_element = VectorXi::Constant(nv, -1);
  for (int v = 0; v < nv; ++v) {
    if (!used[static_cast<std::size_t>(v)]) continue;
    double p[3] = {map.D(v, 0), map.D(v, 1), map.D.cols() > 2 ? map.D(v, 2) : 0.0};
    const int c = grid.domain.element_of_point(grid.k, p);
    r.vertex_element(v) = c;
    ++r.block.elements[c].n_vertices;
  }
  r.total_area_mm2 = std::accumulate(area.begin(), area.end(), 0.0);
  r.area_cv = element_area_cv(r.block);
  return r;
}

ElementAreaStats element_area_stats(const ElementBlock& block, int col_begin, int col_end) {
  ElementAreaStats st;
  double sum = 0, sum2 = 0, lo = INFINITY, hi = -INFINITY;
  for (const auto& e : block.elements)
    if (e.col >= col_begin && e.col < col_end) {
      sum += e.area_mm2, ++st.count;
      lo = std::min(lo, e.area_mm2), hi = std::max(hi, e.area_mm2);
    }
  if (st.count == 0) return st;
  const double mean = sum / st.count;
  for (const auto& e : block.elements)
    if (e.col >= col_begin && e.col < col_end) sum2 += (e.area_mm2 - mean) * (e.area_mm2 - mean);
  st.mean_mm2 = mean;
  st.cv = mean > 0 ? std::sqrt(sum2 / st.count) / mean : 0.0;
  if (mean > 0) st.min_over_mean = lo / mean, st.max_over_mean = hi / mean;
  return st;
}

double element_area_cv(const ElementBlock& block, int col_begin, int col_end) {
  return element_area_stats(block, col_begin, col_end).cv;
}

RectanglePartCells rectangle_part_cells(const MatrixXd& D, const MatrixXi& F, const ElementGrid& grid) {
  RectanglePartCells p;
  if (grid.domain.kind != DomainKind::Rectangle || F.rows() == 0) return p;
  double lo = INFINITY, hi = -INFINITY;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) lo = std::min(lo, D(F(f, c), 0)), hi = std::max(hi, D(F(f, c), 0));
  if (hi - lo > 1.9) return p;
  const double seam = std::isfinite(grid.domain.seam_x) ? grid.domain.seam_x : 1.0, K = grid.k;
  p.is_part = true;
  p.right = 0.5 * (lo + hi) > seam;
  p.col_begin = p.right ? static_cast<int>(std::ceil(seam * K - 1e-9)) : 0;
  p.col_end = p.right ? grid.cols : static_cast<int>(std::floor(seam * K + 1e-9));
  return p;
}

std::string rectangle_part_note(const RectanglePartCells& part) {
  return std::string("the map is the ") + (part.right ? "right" : "left") +
         " hemisphere's part of a two-hemisphere rectangle: only the cells on its side of the seam hold cortex (area CV over the " +
         std::to_string(part.col_end - part.col_begin) + " columns wholly on its side)";
}

std::vector<double> block_values(const ElementBlock& block) {
  std::vector<double> out;
  out.reserve(block.elements.size());
  for (const auto& e : block.elements) out.push_back(e.value);
  return out;
}

std::vector<double> block_areas(const ElementBlock& block) {
  std::vector<double> out;
  out.reserve(block.elements.size());
  for (const auto& e : block.elements) out.push_back(e.area_mm2);
  return out;
}

// ---- files -------------------------------------------------------------------------------

namespace {

bool has_suffix(const std::string& path, const std::string& ext) {
  return path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0;
}

// Tab for .tsv (what `run` writes, as BIDS tables are), comma for .csv (older tables, other tools).
char element_table_delimiter(const std::string& path) { return has_suffix(path, ".tsv") ? '\t' : ','; }

constexpr const char* kElementColumns[] = {"id", "row", "col", "area_mm2", "centroid_x_mm", "centroid_y_mm", "centroid_z_mm", "value",
                                           "n_vertices"};

// The header line: id, hemisphere, then the rest of kElementColumns, joined by `d`.
std::string element_table_header(char d) {
  std::string h = std::string("id") + d + "hemisphere";
  for (std::size_t i = 1; i < std::size(kElementColumns); ++i) h += d + std::string(kElementColumns[i]);
  return h;
}

}  // namespace

std::string element_sidecar_path(const std::string& table_path) {
  for (const std::string ext : {".tsv", ".csv"})
    if (has_suffix(table_path, ext)) return table_path.substr(0, table_path.size() - ext.size()) + ".json";
  return table_path + ".json";
}

void write_element_table(const std::string& csv_path, const ElementTable& table) {
  const char d = element_table_delimiter(csv_path);
  std::string csv = element_table_header(d) + "\n";
  csv.reserve(static_cast<std::size_t>(table.num_values()) * 96 + csv.size());
  for (const auto& b : table.blocks) {
    if (static_cast<int>(b.elements.size()) != table.grid.num_elements())
      throw std::logic_error("write_element_table: block size does not match the grid");
    for (const auto& e : b.elements) {
      csv += std::to_string(e.id);
      csv += d;
      csv += b.hemisphere;
      csv += d;
      csv += std::to_string(e.row);
      csv += d;
      csv += std::to_string(e.col);
      for (double x : {e.area_mm2, e.centroid.x(), e.centroid.y(), e.centroid.z(), e.value}) {
        csv += d;
        append_number(csv, x);
      }
      csv += d;
      csv += std::to_string(e.n_vertices);
      csv += '\n';
    }
  }
  nlohmann::json j;
  j["format"] = "authalic-element-table";
  j["version"] = 1;
  j["domain"] = to_string(table.grid.domain);
  j["k"] = table.grid.k;
  j["rows"] = table.grid.rows;
  j["cols"] = table.grid.cols;
  j["hemispheres"] = nlohmann::json::array();
  for (const auto& b : table.blocks) j["hemispheres"].push_back(b.hemisphere);
  if (table.grid.domain.kind == DomainKind::Rectangle)
    j["seam_x"] = std::isfinite(table.grid.domain.seam_x) ? nlohmann::json(table.grid.domain.seam_x) : nlohmann::json(nullptr);
  j["normalisation"] = table.normalisation;
  j["units"] = table.units;
  j["subject_id"] = table.subject_id;
  j["age"] = std::isfinite(table.age) ? nlohmann::json(table.age) : nlohmann::json(nullptr);
  // Each column described as a BIDS tabular-file sidecar does (Description, Units).
  auto column = [](const std::string& description, const std::string& units) {
    nlohmann::json c = {{"Description", description}};
    if (!units.empty()) c["Units"] = units;
    return c;
  };
  j["columns"] = {{"id", column("element id: row * cols + col", "")},
                  {"hemisphere", column("hemisphere block (listed under \"hemispheres\")", "")},
                  {"row", column("0 = bottom of the domain (y = 0; sphere: z = -1)", "")},
                  {"col", column("0 = left of the domain (x = 0; sphere: longitude -pi)", "")},
                  {"area_mm2", column("cortical area mapped into the element", "mm^2")},
                  {"centroid_x_mm", column("area-weighted centroid x, scanner RAS", "mm")},
                  {"centroid_y_mm", column("area-weighted centroid y, scanner RAS", "mm")},
                  {"centroid_z_mm", column("area-weighted centroid z, scanner RAS", "mm")},
                  {"value", column("area-weighted mean value", table.units.empty() ? std::string("input units") : table.units)},
                  {"n_vertices", column("surface vertices whose map point lies in the element", "")}};
  j["metadata"] = table.metadata;
  io::write_file_atomically(element_sidecar_path(csv_path), j.dump(2) + "\n");
  io::write_file_atomically(csv_path, csv);
}

ElementTable read_element_table(const std::string& csv_path, bool values_only) {
  if (!has_suffix(csv_path, ".tsv") && !has_suffix(csv_path, ".csv"))
    throw InputError(csv_path + ": an element table is a .tsv (or .csv) file with a .json sidecar beside it" +
                     std::string(has_suffix(csv_path, ".json")
                                     ? "; this looks like a JSON file, e.g. a normative reference or a sidecar: give the table's .tsv"
                                     : ""));
  const std::string sidecar = element_sidecar_path(csv_path);
  ElementTable t;
  {
    std::ifstream in(sidecar);
    if (!in)
      throw InputError(sidecar + ": cannot read the element table's JSON sidecar; element tables are written by "
                                 "`authalic elements` or `authalic run` as a .tsv with a .json beside it");
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(in);
      if (j.value("format", "") != "authalic-element-table")
        throw InputError(sidecar + ": not an authalic element-table sidecar (\"format\" is not \"authalic-element-table\")");
      const int version = j.at("version").get<int>();
      if (version != 1)
        throw InputError(sidecar + ": element-table version " + std::to_string(version) +
                         " is not supported by this authalic (version 1); update authalic");
      const Domain domain = Domain::of(parse_domain_kind(j.at("domain").get<std::string>(), sidecar + ": domain"));
      const int k = j.at("k").get<int>();
      if (k < 1 || k > 4096) throw InputError(sidecar + ": k = " + std::to_string(k) + " is outside 1..4096; the table's sidecar is corrupt");
      t.grid = element_grid(domain, k);
      if (j.at("rows").get<int>() != t.grid.rows || j.at("cols").get<int>() != t.grid.cols)
        throw InputError(sidecar + ": rows/cols do not match domain " + to_string(domain.kind) + " at k = " + std::to_string(t.grid.k));
      for (const auto& h : j.at("hemispheres")) t.blocks.push_back({h.get<std::string>(), {}});
      if (domain.kind == DomainKind::Rectangle && j.contains("seam_x")) {  // older tables: 1
        double& seam = t.grid.domain.seam_x;
        seam = j["seam_x"].is_null() ? std::nan("") : j["seam_x"].get<double>();
        if (std::isfinite(seam) && !(seam > 0 && seam < 2))
          throw InputError(sidecar + ": seam_x " + std::to_string(seam) + " is outside (0, 2); the table's sidecar is corrupt");
      }
      t.normalisation = j.value("normalisation", "none");
      t.units = j.value("units", "");
      t.subject_id = j.value("subject_id", "");
      if (j.contains("age") && j["age"].is_number()) t.age = j["age"].get<double>();
      if (j.contains("metadata") && j["metadata"].is_object())
        for (const auto& [key, value] : j["metadata"].items())
          t.metadata[key] = value.is_string() ? value.get<std::string>() : value.dump();
    } catch (const nlohmann::json::exception& e) {
      throw InputError(sidecar + ": invalid element-table sidecar (" + short_json_error(e.what()) + ")");
    }
    if (t.blocks.empty()) throw InputError(sidecar + ": lists no hemisphere");
  }
  std::string text;
  if (!read_text_file(csv_path, text)) throw InputError(csv_path + ": cannot read the element table");
  const int ne = t.grid.num_elements();
  for (auto& b : t.blocks) b.elements.assign(static_cast<std::size_t>(ne), Element{});
  std::vector<char> seen(static_cast<std::size_t>(ne) * t.blocks.size(), 0);
  const char d = element_table_delimiter(csv_path);
  CsvCursor cur(text, csv_path, d);
  cur.expect_header(element_table_header(d));
  std::size_t count = 0;
  while (cur.next_line()) {
    Element e;
    e.id = cur.integer();
    const std::string_view hemi = cur.field();
    e.row = cur.integer();
    e.col = cur.integer();
    if (values_only) {
      for (int k = 0; k < 4; ++k) cur.skip();
      e.value = cur.number();
      cur.skip();
    } else {
      e.area_mm2 = cur.number();
      e.centroid.x() = cur.number();
      e.centroid.y() = cur.number();
      e.centroid.z() = cur.number();
      e.value = cur.number();
      e.n_vertices = cur.integer();
    }
    cur.end_line();
    int block = -1;  // linear search: one or two blocks, and no allocation per row
    for (std::size_t b = 0; b < t.blocks.size(); ++b)
      if (t.blocks[b].hemisphere == hemi) block = static_cast<int>(b);
    if (block < 0) cur.fail("hemisphere '" + std::string(hemi) + "' is not listed in the sidecar");
    if (e.id < 0 || e.id >= ne || e.row != e.id / t.grid.cols || e.col != e.id % t.grid.cols)
      cur.fail("element id " + std::to_string(e.id) + " does not match row " + std::to_string(e.row) + ", col " +
               std::to_string(e.col) + " of a " + std::to_string(t.grid.rows) + " x " + std::to_string(t.grid.cols) + " grid");
    char& s = seen[static_cast<std::size_t>(block) * ne + e.id];
    if (s) cur.fail("element " + std::to_string(e.id) + " of hemisphere " + std::string(hemi) + " appears twice");
    s = 1;
    t.blocks[static_cast<std::size_t>(block)].elements[static_cast<std::size_t>(e.id)] = e;
    ++count;
  }
  if (count != seen.size())
    throw InputError(csv_path + ": has " + std::to_string(count) + " element rows, expected " + std::to_string(seen.size()) +
                     " (" + std::to_string(t.blocks.size()) + " hemisphere(s) x " + std::to_string(ne) + ")");
  return t;
}

}  // namespace authalic::analysis

// ---- exported element images --------------------------------------------------------------

namespace authalic::analysis {

ElementOutputPaths element_output_paths(const std::string& prefix) {
  ElementOutputPaths p;
  p.table = prefix + ".tsv";
  p.sidecar = element_sidecar_path(p.table);
  p.nifti = prefix + ".nii.gz";
  p.area_nifti = prefix + "_area.nii.gz";
  p.png = prefix + ".png";
  p.png_3d = prefix + "_3d.png";
  p.label = prefix + ".label.gii";
  return p;
}

std::vector<std::string> ElementOutputPaths::all() const { return {table, sidecar, nifti, area_nifti, png, png_3d, label}; }

void write_element_nifti(const std::string& path, const std::vector<float>& data, const ElementGrid& grid, int blocks,
                         double element_area_mm2, ElementImageKind kind, const std::string& description) {
  io::Volume image;
  image.dims = {grid.cols, grid.rows, blocks};
  image.data = data;
  const double side = element_area_mm2 > 0 && std::isfinite(element_area_mm2) ? std::sqrt(element_area_mm2) : 1.0;
  image.vox2ras = Eigen::Vector4d(side, side, 1.0, 1.0).asDiagonal();
  io::NiftiWriteOptions o;
  char area[48];
  std::snprintf(area, sizeof(area), "; %s, element %.4g mm^2", io::kMapGridMarker, element_area_mm2);
  o.description = description.substr(0, 79 - std::string(area).size()) + area;  // the header keeps 79 characters: the area stays
  o.map_grid = true;
  if (kind == ElementImageKind::kZScore) {
    o.intent_code = 5;  // NIFTI_INTENT_ZSCORE (nifti1.h; not included here beside gifti_io.h's copy)
    o.intent_name = "z-score";
  }
  io::write_nifti(path, image, o);
}

double mean_element_area(const ElementBlock& block) {
  // Over the elements that hold cortex: one hemisphere's part of a two-hemisphere rectangle
  // leaves the other part's cells empty.
  double sum = 0;
  int n = 0;
  for (const auto& e : block.elements)
    if (e.area_mm2 > 0) sum += e.area_mm2, ++n;
  return n == 0 ? std::nan("") : sum / n;
}

std::vector<float> element_image(const ElementBlock& block, const ElementGrid& grid, bool areas) {
  std::vector<float> data(static_cast<std::size_t>(grid.num_elements()));
  for (const auto& e : block.elements)
    data[static_cast<std::size_t>(e.row) * grid.cols + e.col] = static_cast<float>(areas ? e.area_mm2 : e.value);
  return data;
}

double mean_element_area(const ElementTable& table) {
  double sum = 0;
  int n = 0;
  for (const auto& b : table.blocks)
    for (const auto& e : b.elements)
      if (e.area_mm2 > 0) sum += e.area_mm2, ++n;
  return n > 0 ? sum / n : std::nan("");
}

ElementOutputPaths write_element_outputs(const std::string& prefix, const ElementTable& table, const ElementResult& result,
                                         const MatrixXd& V_scanner, const MatrixXi& F, bool left) {
  if (table.blocks.size() != 1) throw std::logic_error("write_element_outputs: expects a one-block table");
  const ElementOutputPaths p = element_output_paths(prefix);
  const ElementGrid& g = table.grid;
  const ElementBlock& block = table.blocks[0];
  const std::string units = table.units.empty() ? std::string("input units") : table.units;

  write_element_table(p.table, table);

  const double element_area = mean_element_area(block);
  write_element_nifti(p.nifti, element_image(block, g), g, 1, element_area, ElementImageKind::kValues,
                      "authalic element values (" + units + "), " + to_string(g.domain) + " K=" + std::to_string(g.k));
  write_element_nifti(p.area_nifti, element_image(block, g, true), g, 1, element_area, ElementImageKind::kAreas,
                      "authalic element areas (mm^2), " + to_string(g.domain) + " K=" + std::to_string(g.k));

  const std::vector<double> values = block_values(block);
  ScalarColouring c;
  c.colormap = "viridis";
  c.label = units;
  VectorXd finite(static_cast<Eigen::Index>(values.size()));
  for (std::size_t i = 0; i < values.size(); ++i) finite(static_cast<Eigen::Index>(i)) = values[i];
  std::tie(c.vmin, c.vmax) = robust_range(finite);
  const int cell = std::max(4, 640 / g.cols);
  io::write_png(p.png, render_element_grid(values, g.rows, g.cols, c,
                                           cell, "Element values, " + to_string(g.domain) + " K = " + std::to_string(g.k) +
                                                     " (" + block.hemisphere + ")"));

  // 3D views: each vertex coloured by its element's value, element boundaries drawn.
  const int nv = static_cast<int>(result.vertex_element.size());
  c.values = VectorXd::Constant(nv, std::numeric_limits<double>::quiet_NaN());
  for (int v = 0; v < nv; ++v)
    if (result.vertex_element(v) >= 0) c.values(v) = values[static_cast<std::size_t>(result.vertex_element(v))];
  SurfaceRenderOptions so;
  so.left_hemisphere = left;
  so.title = "Equal-area elements (" + units + ")";
  io::write_png(p.png_3d, render_surface_views(V_scanner, F, c, {View::Lateral, View::Medial}, so, &result.vertex_element));

  write_element_labels(p.label, result, g, block.hemisphere);
  return p;
}

VectorXd element_values_at_vertices(const VectorXi& vertex_element, const double* element_values, int num_elements) {
  VectorXd out = VectorXd::Constant(vertex_element.size(), std::numeric_limits<double>::quiet_NaN());
  for (Eigen::Index v = 0; v < vertex_element.size(); ++v)
    if (vertex_element(v) >= 0 && vertex_element(v) < num_elements) out(v) = element_values[vertex_element(v)];
  return out;
}

void write_element_labels(const std::string& path, const ElementResult& result, const ElementGrid& g,
                          const std::string& hemisphere) {
  const ElementBlock& block = result.block;
  VectorXi keys = (result.vertex_element.array() + 1).matrix();
  std::map<int, std::string> names{{0, "none"}};
  for (const auto& e : block.elements)
    names[e.id + 1] = "element " + std::to_string(e.id) + " (row " + std::to_string(e.row) + ", col " + std::to_string(e.col) + ")";
  io::FuncWriteOptions fo;
  fo.column_names = {"element"};
  if (hemisphere == "left") fo.anatomical_structure = "CortexLeft";
  if (hemisphere == "right") fo.anatomical_structure = "CortexRight";
  fo.metadata = {{"description", "authalic equal-area element of each vertex: key = element id + 1 (id = row * cols + col), 0 = none"},
                 {"domain", to_string(g.domain)},
                 {"k", std::to_string(g.k)},
                 {"rows", std::to_string(g.rows)},
                 {"cols", std::to_string(g.cols)}};
  io::write_label_gifti(path, keys, names, fo);
}

}  // namespace authalic::analysis

// `authalic metrics SURFACE MAP.surf.gii [--domain square|rectangle|sphere] [--k 32] [--json]`:
// distortion of any map of SURFACE (core/metrics.h; the same definitions as
// ../shared/tools/evalmap.py).
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "analysis/elements.h"
#include "app/command.h"
#include "app/map_json.h"
#include "core/error.h"
#include "core/metrics.h"
#include "io/surface_io.h"

namespace authalic::app {
namespace {

struct MetricsArgs {
  std::string surface, map;
  std::string domain = "square";
  int k = 32;
};

// A 3D surface given as the map would give numbers that mean nothing: a planar map must be flat
// (z constant) and a sphere map on one sphere about the origin.
void check_map_shape(const std::string& path, const MatrixXd& U, const MatrixXi& F, const Domain& domain) {
  std::vector<int> used;
  {
    std::vector<char> seen(static_cast<std::size_t>(U.rows()), 0);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int c = 0; c < 3; ++c)
        if (!seen[static_cast<std::size_t>(F(f, c))]++) used.push_back(F(f, c));
  }
  std::ostringstream s;
  s << std::setprecision(3);
  if (!domain.planar()) {
    double lo = INFINITY, hi = 0;
    for (int v : used) lo = std::min(lo, U.row(v).norm()), hi = std::max(hi, U.row(v).norm());
    if (!(hi > 0) || (hi - lo) > 0.05 * hi) {  // FreeSurfer spheres: within 0.01 %; brains: 30 % and more
      s << path << ": is not a sphere map (distances from the origin range from " << lo << " to " << hi
        << "); give the map written by `authalic sphere`, or --domain square/rectangle for a flat map";
      throw InputError(s.str());
    }
    return;
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (int v : used) lo = lo.cwiseMin(U.row(v).transpose()), hi = hi.cwiseMax(U.row(v).transpose());
  const double extent = std::max(hi.x() - lo.x(), hi.y() - lo.y());
  if (U.cols() > 2 && !((hi.z() - lo.z()) <= 1e-6 * extent)) {
    s << path << ": is not a flat map (z spans " << (hi.z() - lo.z()) << " against an x-y extent of " << extent
      << "): it looks like a 3D surface; give the map written by `authalic flatten`, or --domain sphere";
    throw InputError(s.str());
  }
}

void run(const MetricsArgs& a) {
  const io::Surface surface = io::read_surface(a.surface);
  const io::Surface map = io::read_surface(a.map);
  io::require_vertex_numbering(surface, a.surface, a.map);  // the map pairs with the surface by vertex
  io::require_vertex_numbering(map, a.map, a.surface);
  const int nv = surface.mesh.num_vertices();
  Domain domain = Domain::of(parse_domain_kind(a.domain, "--domain"));
  // Where a two-hemisphere rectangle's parts meet, as the file records it: in rectangle units
  // (the maps of `rectangle --lh/--rh`) or in mm (their --flat copies, run's authalicrect_flat).
  double seam_mm = std::nan("");
  if (domain.kind == DomainKind::Rectangle) {
    if (const auto seam = map.metadata.find(analysis::kSeamKey); seam != map.metadata.end()) {
      domain.seam_x = analysis::parse_seam(seam->second, a.map);
    } else if (const auto mm = map.metadata.find(analysis::kSeamMmKey); mm != map.metadata.end()) {
      seam_mm = analysis::parse_seam_mm(mm->second, a.map);
    }
  }
  if (map.mesh.num_vertices() < nv)
    throw InputError(a.map + ": has " + std::to_string(map.mesh.num_vertices()) + " vertices, fewer than the " +
                     std::to_string(nv) + " of " + a.surface + "; give a map on the surface's vertex indexing");
  // The map's own triangles (e.g. a cortex patch). Vertices the map inserted (corner and ear
  // splits, beyond the surface's vertices) are placed on the surface from the map's
  // authalic_inserted_vertices metadata (flatten writes it), so every face counts, as in flatten's
  // own metrics; without it their faces have no 3D position and are left out (evalmap.py's drop).
  const MatrixXi& Fm = map.mesh.F.rows() > 0 ? map.mesh.F : surface.mesh.F;
  const int inserted = map.mesh.num_vertices() - nv;
  const auto placed = map.metadata.find(kInsertedVerticesKey);
  const bool place = inserted > 0 && placed != map.metadata.end();
  const MatrixXd V3 = place ? place_inserted_vertices(surface.mesh.V, placed->second, inserted, a.map) : surface.mesh.V;
  const int known = static_cast<int>(V3.rows());
  std::vector<int> keep;
  for (Eigen::Index f = 0; f < Fm.rows(); ++f)
    if (Fm(f, 0) < known && Fm(f, 1) < known && Fm(f, 2) < known) keep.push_back(static_cast<int>(f));
  const int excluded = static_cast<int>(Fm.rows()) - static_cast<int>(keep.size());
  if (keep.empty()) throw InputError(a.map + ": no triangle of the map lies on the surface's vertices; check the file pair");
  // Without the record only the few faces of the boundary's splits are left out; most of the map
  // beyond the surface's vertices is a map of another mesh (its numbers would mean nothing).
  if (2 * excluded > static_cast<int>(Fm.rows()))
    throw InputError(a.map + ": " + std::to_string(excluded) + " of its " + std::to_string(Fm.rows()) + " triangles use vertices beyond the " +
                     std::to_string(nv) + " of " + a.surface + " and it has no " + kInsertedVerticesKey +
                     " record: it is not a map of this surface; give the surface the map was computed from");
  MatrixXi F(static_cast<Eigen::Index>(keep.size()), 3);
  for (size_t k = 0; k < keep.size(); ++k) F.row(k) = Fm.row(keep[k]);
  MatrixXd U = map.mesh.V.topRows(known);
  check_map_shape(a.map, U, F, domain);

  // Planar maps written in mm (e.g. flatten's OUT) are brought to their domain by one uniform
  // scale and shift of the used vertices' bounding box (ratios do not depend on it; the element
  // grid does).
  bool rescaled = false;
  if (domain.kind == DomainKind::Disk) {
    // A disk map (flatten --domain disk): centred at the origin, radius 1 (or mm: scaled to it).
    std::string problem;
    const double rmax = disk_map_radius(U, F, &problem);
    if (!problem.empty())
      throw InputError(a.map + ": is " + problem + "; give the map written by `authalic flatten --domain disk`");
    if (std::abs(rmax - 1) > 1e-6) {
      U.leftCols(2) /= rmax;
      rescaled = true;
    }
  } else if (domain.planar()) {
    const double W = domain.width();
    std::vector<char> used(known, 0);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int v = 0; v < known; ++v)
      if (used[v]) x0 = std::min(x0, U(v, 0)), x1 = std::max(x1, U(v, 0)), y0 = std::min(y0, U(v, 1)), y1 = std::max(y1, U(v, 1));
    const double tol = 1e-6;
    const bool inside = x0 >= -tol && y0 >= -tol && x1 <= W + tol && y1 <= 1 + tol;
    if (std::isfinite(seam_mm)) {
      // One part of the rectangle scaled to mm: back by its height (the part spans y in [0, 1]),
      // unshifted in x, so the right part stays on its side of the seam.
      const double s = 1.0 / std::max(y1 - y0, 1e-300);
      U.col(0) *= s;
      U.col(1) = (U.col(1).array() - y0) * s;
      domain.seam_x = seam_mm * s;
      rescaled = true;
    } else if (domain.kind == DomainKind::Rectangle && inside) {
      // In rectangle units already, the whole rectangle or one hemisphere's part of it (measured
      // below as `elements` measures it): kept where it is.
    } else if (!inside || (x1 - x0) < 0.5 * W || (y1 - y0) < 0.5) {
      const double s = 1.0 / std::max(y1 - y0, 1e-300);
      U.col(0) = (U.col(0).array() - x0) * s;
      U.col(1) = (U.col(1).array() - y0) * s;
      rescaled = true;
    }
  }
  MapMetrics m = map_metrics(V3, U, F, domain, a.k);
  // One hemisphere's part of a two-hemisphere rectangle fills only the cells on its side of the
  // seam: its element statistics are those of the cells wholly there, as `elements` gives them
  // (over all cells its CV was near 1, with no word why).
  const analysis::ElementGrid grid = analysis::element_grid(domain, a.k);
  const analysis::RectanglePartCells part = analysis::rectangle_part_cells(U, F, grid);
  if (part.is_part) {
    const VectorXd cells = element_areas(V3, U, F, domain.width(), grid.cols, grid.rows);  // row-major, row 0 at y = 0
    analysis::ElementBlock block;
    for (int id = 0; id < grid.num_elements(); ++id) {
      analysis::Element e;
      e.id = id;
      e.row = id / grid.cols;
      e.col = id % grid.cols;
      e.area_mm2 = cells(id);
      block.elements.push_back(e);
    }
    const analysis::ElementAreaStats st = analysis::element_area_stats(block, part.col_begin, part.col_end);
    m.element_cv = st.cv;
    m.element_min = st.min_over_mean;
    m.element_max = st.max_over_mean;
    m.element_mean_mm2 = st.mean_mm2;
  }
  nlohmann::json j = metrics_json(m);
  j["surface"] = a.surface;
  j["map"] = a.map;
  j["faces_on_inserted_vertices"] = excluded;  // left out
  j["inserted_vertices_placed"] = place ? inserted : 0;
  j["rescaled_to_domain"] = rescaled;
  j["mirrored"] = m.mirrored;
  j["rectangle_part"] = nullptr;
  if (part.is_part)
    j["rectangle_part"] = {{"hemisphere", part.right ? "right" : "left"},
                           {"seam_x", std::isfinite(domain.seam_x) ? nlohmann::json(domain.seam_x) : nlohmann::json(1.0)},
                           {"element_columns", {part.col_begin, part.col_end}},
                           {"note", analysis::rectangle_part_note(part)}};
  if (global_options().json) {
    std::cout << j.dump(2) << '\n';
    return;
  }
  std::ostringstream s;
  s << std::setprecision(4);
  s << "faces " << m.faces << " (" << excluded << " on inserted vertices left out), vertices " << m.vertices << "\n"
    << "flipped faces " << m.flips << (m.mirrored ? " (map was mirrored as a whole; measured un-mirrored)" : "") << "\n"
    << "|ln area ratio| per face: mean " << m.face_ln_area.mean << ", p95 " << m.face_ln_area.p95 << ", p99 "
    << m.face_ln_area.p99 << ", max " << m.face_ln_area.max << "\n"
    << "|ln area ratio| per vertex: mean " << m.vertex_ln_area.mean << ", p95 " << m.vertex_ln_area.p95 << ", p99 "
    << m.vertex_ln_area.p99 << ", max " << m.vertex_ln_area.max << "\n"
    << "Upsilon mean " << m.upsilon_mean << ", Lambda mean " << m.lambda.mean << ", p95 " << m.lambda.p95 << "\n"
    << "element-area CV (" << m.element_cols << "x" << m.element_rows;
  if (part.is_part) s << ", columns " << part.col_begin << "-" << part.col_end - 1 << " of the " << (part.right ? "right" : "left") << " part";
  s << ") " << m.element_cv << ", min/mean "
    << m.element_min << ", max/mean " << m.element_max << ", mean " << m.element_mean_mm2 << " mm^2"
    << (rescaled ? " (map rescaled to its domain)" : "") << "\n";
  if (part.is_part) s << "note: " << analysis::rectangle_part_note(part) << "\n";
  std::cout << s.str();
}

void setup(CLI::App& parent) {
  auto a = std::make_shared<MetricsArgs>();
  CLI::App* sub = parent.add_subcommand(
      "metrics",
      "Distortion of a map of a surface: flipped faces, per-face and per-vertex |ln area ratio|, Upsilon and Lambda "
      "(Zou et al. eq. 23), and the coefficient of variation of the cortical area (mm^2) per element of a K x K grid. "
      "With --domain rectangle, one hemisphere's part of a two-hemisphere rectangle (`rectangle --lh/--rh`, also in mm) "
      "is measured over the cells on its side of the seam, as `elements` measures it.");
  sub->add_option("SURFACE", a->surface, "The 3D surface (mm)")->required();
  sub->add_option("MAP", a->map, "The map on the same vertex indexing (GIFTI or any surface format); its triangles are used")
      ->required();
  sub->add_option("--domain", a->domain,
                  "Map domain: square [0,1]^2, rectangle [0,2]x[0,1], sphere, or disk (the unit disk centred at the origin; "
                  "its elements are the square's K x K cells carried by Shirley & Chiu's equal-area concentric map)")
      ->check(CLI::IsMember({"square", "rectangle", "sphere", "disk"}))
      ->capture_default_str();
  add_k_option(*sub, a->k, {DomainKind::Square, DomainKind::Rectangle, DomainKind::Sphere, DomainKind::Disk});
  add_common_options(*sub);
  sub->callback([a]() { run(*a); });
}

const bool registered = register_command({25, setup});

}  // namespace
}  // namespace authalic::app

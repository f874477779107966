// `authalic flatten SURFACE OUT.surf.gii [--faces-from FILE | --label FILE | --patch FILE]
//  [--sphere-reg REG (--atlas DIR | --atlas-surface W --atlas-sphere S (--atlas-label L | --atlas-faces-from F))]
//  [--uv UV.surf.gii] [--metrics M.json] [--png P.png] [--density D] [--threads N]`:
// authalic map of a cortical region onto the unit square (core/square_map.h).
#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>
#include <sstream>
#include <tuple>

#include "analysis/atlas.h"
#include "analysis/elements.h"
#include "analysis/render.h"
#include "analysis/report.h"
#include "app/command.h"
#include "app/map_json.h"
#include "app/memory_guard.h"
#include "core/disk_map.h"
#include "core/error.h"
#include "core/metrics.h"
#include "core/run_beside.h"
#include "core/region.h"
#include "core/square_map.h"
#include "core/sulcal_depth.h"
#include "io/image_io.h"
#include "io/surface_io.h"
#include "io/file_roles.h"

namespace authalic::app {
namespace {

struct FlattenArgs {
  std::string surface, out;
  std::string faces_from, label, patch;
  std::string uv, metrics, png, histogram, fs_patch, initial;
  std::string density, shading;
  // Atlas correspondence (issue 14): the subject's sphere.reg and the atlas.
  std::string sphere_reg, atlas_dir, atlas_surface, atlas_sphere, atlas_label, atlas_faces_from;
  bool register_to_atlas = false;  // registration mode: no sphere.reg, aligned by sulcal depth
  std::string method = "grid";
  std::string mesh_targets = "surface";
  std::string domain = "square";  // or "disk" (the square map carried onto the disk, core/disk_map.h)
  int k = 32;
  int grid = 0;  // 0: from the region's size (grid_resolution_for)
  int passes = GridFlowOptions{}.max_passes;
  int fixed_steps = 0;
  int iterations = 200;
  bool no_polish = false;
  bool split_dividing_edges = false;
  bool keep_failed = false;
  std::string start = "stretch";
  std::string refine = "none";
  int omt_grid = 0;
  int omt_iterations = OptimalTransportOptions{}.max_iterations;
  double max_memory = -1;  // GB; < 0: 75% of the physical RAM
  long long max_vertices = 1000000;
};

// What to try after a grid flow that did not reach the acceptance: more passes and a finer grid,
// unless they were given already; then the region's shape (a narrow neck or a long thin part
// needs more transport through it than the flow can carry).
std::string grid_flow_advice(int passes, int grid) {
  std::string more;
  if (passes < 6) more += "more passes (--passes 6)";
  if (grid < 1024) more += std::string(more.empty() ? "" : " or ") + "a finer grid (--grid 1024)";  // 0: from the region's size
  if (!more.empty()) return "Try " + more + "; ";
  return "More passes and a finer grid were used: check the region for a narrow neck or a long thin part, which the flow "
         "cannot fill evenly (the label's shape, not the options, is what to change); ";
}

// The anatomical orientation rule as the outputs state it, for the square or the disk.
std::string orientation_rule(bool disk) {
  return std::string("faces oriented outward and the map orientation-preserving, so the lateral surface faces the viewer; the "
                     "boundary point nearest the most anterior (largest RAS y) region vertex is at ") +
         (disk ? "the top of the unit circle (x = 0, y = 1)" : "the middle of the top side (x = 0.5, y = 1)") +
         "; the boundary follows counter-clockwise by arc length; a right hemisphere is the mirror image of a left one";
}

// The cortex region's faces on SURFACE's vertices, from whichever option was given. A label
// (vertices) is cleaned up into one disk (core/region.h); *cleanup says what was changed.
MatrixXi region_faces(const FlattenArgs& a, const io::Surface& surface, std::string* source,
                      std::unique_ptr<RegionCleanup>* cleanup) {
  const TriMesh& mesh = surface.mesh;
  const int nv = mesh.num_vertices();
  if (!a.faces_from.empty()) {
    const io::Surface other = io::read_surface(a.faces_from);
    if (other.mesh.num_vertices() != nv)
      throw InputError(a.faces_from + ": has " + std::to_string(other.mesh.num_vertices()) + " vertices but " + a.surface +
                       " has " + std::to_string(nv) + "; --faces-from needs a surface on the same vertices");
    *source = "faces of " + a.faces_from;
    return other.mesh.F;
  }
  if (!a.label.empty()) {
    const std::vector<int> verts = io::read_region_vertices(a.label, mesh);
    std::vector<bool> mask(nv, false);
    for (int v : verts) mask[v] = true;
    auto c = std::make_unique<RegionCleanup>(region_faces_from_vertices(mesh.V, mesh.F, mask));
    if (c->F.rows() == 0)
      throw InputError(a.label + ": the label's " + std::to_string(verts.size()) +
                       " vertices contain no whole triangle of the surface; check that the label belongs to " + a.surface);
    // A damaged surface shows in the region as holes and loops: say what is wrong with it instead.
    if (!c->surface_damage.empty()) throw InputError(a.surface + ": " + c->surface_damage);
    if (!c->is_disk())
      throw InputError(a.label + " on " + a.surface + ": " + c->problem() +
                       "; the square map needs one disk: check that the label is this surface's cortex with the medial "
                       "wall left out" +
                       (c->holes_unfilled > 0 ? std::string(", and fill the holes too large to fill automatically") : ""));
    if (const std::string pieces = c->pieces_problem(); !pieces.empty()) throw InputError(a.label + " on " + a.surface + ": " + pieces);
    *source = "faces inside label " + a.label;
    MatrixXi F = c->F;
    *cleanup = std::move(c);
    return F;
  }
  if (!a.patch.empty()) {
    const io::Patch p = io::read_freesurfer_patch(a.patch);
    for (int v : p.vertices)
      if (v < 0 || v >= nv)
        throw InputError(a.patch + ": vertex " + std::to_string(v) + " is outside " + a.surface + " (" + std::to_string(nv) +
                         " vertices); give the patch's own surface");
    *source = "faces inside patch " + a.patch;
    return io::patch_mesh(mesh, p).F;
  }
  const std::vector<std::vector<int>> loops = boundary_loops(mesh.F, nv);
  if (loops.empty())
    throw InputError(a.surface + ": is a closed surface; give the cortex region with --label, --patch or --faces-from, "
                     "or use `authalic sphere` for a closed surface");
  *source = "all faces of " + a.surface;
  return mesh.F;
}

// "region_cleanup" of the metrics JSON (--label): what region_faces_from_vertices changed
// (core/region.h). "vertices" of holes: added to the label's whole faces; of islands and removed
// fans: label vertices lost. Areas in mm^2.
nlohmann::json region_cleanup_json(const RegionCleanup& c) {
  return {{"summary", c.summary()},
          {"label_vertices", c.label_vertices},
          {"raw_faces", c.raw_faces},
          {"raw_area_mm2", c.raw_area_mm2},
          {"faces", c.F.rows()},
          {"area_mm2", c.area_mm2},
          {"max_hole_fraction", c.max_hole_fraction},
          {"holes_filled",
           {{"count", c.holes_filled}, {"vertices", c.hole_vertices_added}, {"faces", c.hole_faces_added}, {"area_mm2", c.hole_area_mm2}}},
          {"islands_dropped",
           {{"count", c.islands_dropped}, {"vertices", c.island_vertices}, {"faces", c.island_faces}, {"area_mm2", c.island_area_mm2}}},
          {"pinch_vertices",
           {{"in_label_faces", c.raw_pinch_vertices},
            {"fixed", c.pinch_vertices_fixed},
            {"faces_removed", c.pinch_faces_removed},
            {"vertices_removed", c.pinch_vertices_removed},
            {"area_mm2", c.pinch_area_mm2}}},
          {"label_vertices_outside_region", c.label_vertices_outside},
          {"region_vertices_outside_label", c.vertices_outside_label}};
}

void write_flat(const std::string& path, const MatrixXd& XY, const MatrixXi& F, const io::SurfaceWriteOptions& base,
                const std::string& units) {
  io::SurfaceWriteOptions wo = base;
  wo.metadata["authalic_units"] = units;
  MatrixXd P = MatrixXd::Zero(XY.rows(), 3);
  P.leftCols(2) = XY;
  io::write_surface(path, TriMesh{P, F}, wo);
}

// ∫ |x − T(x)|² dμ / ∫ dμ from the conformal initial map (unit-square units²), and with --refine omt
// what the refinement did (core/optimal_transport.h).
nlohmann::json transport_json(const SquareMapResult& r, const SquareMapOptions& o) {
  nlohmann::json t = {{"refine", o.optimal_transport ? "omt" : "none"},
                      {"cost_from_initial_map", r.transport_cost},
                      {"units", "mean squared displacement from the conformal initial map, in unit-square units^2"}};
  if (o.optimal_transport)
    t["omt"] = {{"iterations", r.transport.iterations},
                {"grid_resolution", r.transport.grid_resolution},
                {"stop_reason", r.transport.stop_reason},
                {"cost_before", r.transport.initial_cost},
                {"cost_after_refinement", r.transport.final_cost},
                {"cost_history", r.transport.history}};
  return t;
}

// The atlas files of the atlas options (none given: per-subject mode, empty files).
analysis::AtlasFiles atlas_files(const FlattenArgs& a, const io::Surface& surface) {
  const bool explicit_atlas = !a.atlas_surface.empty() || !a.atlas_sphere.empty() || !a.atlas_label.empty() ||
                              !a.atlas_faces_from.empty();
  if (a.register_to_atlas && !a.sphere_reg.empty())
    throw InputError("flatten: give --sphere-reg (atlas correspondence through FreeSurfer's registration) or --register "
                     "(alignment by sulcal depth without one), not both");
  if (a.sphere_reg.empty() && !a.register_to_atlas) {
    if (explicit_atlas || !a.atlas_dir.empty())
      throw InputError("flatten: the atlas options need --sphere-reg (the subject's ?h.sphere.reg: its vertices on the atlas "
                       "sphere) or --register (alignment to the atlas's map by sulcal depth)");
    return {};
  }
  const std::string how = a.register_to_atlas ? "--register" : "--sphere-reg";
  if (!a.atlas_dir.empty()) {
    const std::string hemi = analysis::hemisphere_of(surface.metadata, a.surface);
    if (hemi == "unknown")
      throw InputError(a.surface + ": cannot tell the hemisphere (no lh./rh. name or GIFTI structure) to pick the atlas's; "
                       "give --atlas-surface, --atlas-sphere and --atlas-label instead of --atlas");
    return analysis::atlas_files_from_dir(a.atlas_dir, hemi == "left" ? "lh" : "rh");
  }
  if (a.atlas_surface.empty() || a.atlas_sphere.empty() || a.atlas_label.empty() == a.atlas_faces_from.empty())
    throw InputError("flatten: " + how + " needs the atlas: --atlas DIR, or --atlas-surface, --atlas-sphere and one of "
                     "--atlas-label, --atlas-faces-from");
  return {a.atlas_surface, a.atlas_sphere, a.atlas_label.empty() ? a.atlas_faces_from : a.atlas_label};
}

nlohmann::json displacement_json(const Displacement& d, int k) {
  return {{"k", k}, {"median", d.median}, {"p95", d.p95}, {"max", d.max}};
}

// Registration mode: the subject's own map aligned to the atlas's (core/atlas_map.h).
SquareMapResult map_region_registered(const FlattenArgs& a, const io::Surface& surface, const MatrixXi& region,
                                      const analysis::AtlasFiles& files, const SquareMapOptions& options,
                                      const ProgressFn& progress, nlohmann::json* correspondence) {
  const analysis::Atlas atlas = analysis::load_atlas(files, progress);
  RegisteredMapResult r = square_map_registered(surface.mesh.V, region, atlas.square, options, {}, a.k, progress);
  *correspondence = {{"mode", analysis::registration_mode(files)},
                     {"atlas", {{"white", files.white}, {"sphere", files.sphere}, {"cortex", files.cortex}, {"identity", atlas.identity}}},
                     {"feature", "sulcal depth (core/sulcal_depth.h) of each cortex region"},
                     {"depth_correlation_before", r.registration.correlation_before},
                     {"depth_correlation_after", r.registration.correlation_after},
                     {"registration_iterations", r.registration.iterations},
                     {"registration_displacement_elements", displacement_json(r.registration_displacement, a.k)},
                     {"start_vertices_repaired", r.map.start_repaired},
                     {"flow_displacement_elements", displacement_json(r.displacement, a.k)}};
  return std::move(r.map);
}

// The map: per subject (square_map), in atlas correspondence (the atlas's map carried through
// sphere.reg, then made authalic: core/atlas_map.h) or registered to the atlas's map.
// *correspondence: the mode and its numbers.
SquareMapResult map_region(const FlattenArgs& a, const io::Surface& surface, const MatrixXi& region,
                           const SquareMapOptions& options, const ProgressFn& progress, nlohmann::json* correspondence) {
  const analysis::AtlasFiles files = atlas_files(a, surface);
  if (files.white.empty()) {
    *correspondence = {{"mode", analysis::kPerSubjectCorrespondence}};
    return square_map(surface.mesh.V, region, options, progress);
  }
  if (a.register_to_atlas) return map_region_registered(a, surface, region, files, options, progress, correspondence);
  const io::Surface reg = io::read_surface(a.sphere_reg);
  if (reg.mesh.num_vertices() != surface.mesh.num_vertices())
    throw InputError(a.sphere_reg + ": has " + std::to_string(reg.mesh.num_vertices()) + " vertices but " + a.surface + " has " +
                     std::to_string(surface.mesh.num_vertices()) + "; give this surface's sphere.reg");
  const analysis::Atlas atlas = analysis::load_atlas(files, progress);
  AtlasMapResult r = square_map_from_atlas(surface.mesh.V, region, reg.mesh.V, atlas.square, options, a.k, progress);
  *correspondence = {{"mode", analysis::atlas_mode(files)},
                     {"atlas", {{"white", files.white}, {"sphere", files.sphere}, {"cortex", files.cortex}, {"identity", atlas.identity}}},
                     {"sphere_reg", a.sphere_reg},
                     {"outside_rule", "vertices outside the atlas cortex on the sphere take the atlas map at its nearest point"},
                     {"vertices_outside_atlas_cortex", r.transfer.outside},
                     {"area_share_outside_atlas_cortex", r.transfer.outside_area_share},
                     {"start_vertices_repaired", r.map.start_repaired},
                     {"flow_displacement_elements", displacement_json(r.displacement, a.k)}};
  return std::move(r.map);
}

// The region to flatten, read and checked against the surface.
struct FlattenRegion {
  MatrixXi F;
  std::string source;
  std::unique_ptr<RegionCleanup> cleanup;
};

// The region's faces (--faces-from, --label, --patch or the whole open surface), each referring
// to a vertex of the surface.
FlattenRegion read_region(const FlattenArgs& a, const io::Surface& surface) {
  FlattenRegion region;
  region.F = region_faces(a, surface, &region.source, &region.cleanup);
  if (region.cleanup) info("flatten: " + a.label + ": " + region.cleanup->summary());
  for (Eigen::Index f = 0; f < region.F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (region.F(f, c) < 0 || region.F(f, c) >= surface.mesh.num_vertices())
        throw InputError(region.source + ": face " + std::to_string(f) + " refers to vertex " + std::to_string(region.F(f, c)) +
                         " outside " + a.surface + "; give a face set on the same vertices");
  return region;
}

// Memory and size limits, checked before minutes of mapping.
void check_region_size(const FlattenArgs& a, const MatrixXi& region) {
  // A disk has about F / 2 vertices.
  check_memory(a.surface, (region.rows() + 2) / 2, square_map_memory_bytes((region.rows() + 2) / 2, GridFlowOptions{a.grid}.cells()), a.max_memory);
  // The default limit is a time limit (hostile or mistaken inputs are caught by the memory
  // estimate above): 600k vertices (fsaverage5 subdivided three times) map with 0 flips in 26 s
  // CPU and 1.2 GB (bench/bench_peers.sh), a marching-cubes surface of fs741's white matter at
  // 0.4 mm (887k region vertices) in 47 s CPU and 1.8 GB with 0 flips (bench/bench_mesh_families.sh):
  // a high-resolution FreeSurfer subject (0.7-0.8 mm, 250-350k vertices) must not be refused.
  if ((region.rows() + 2) / 2 > a.max_vertices)
    throw InputError(a.surface + ": the region has about " + std::to_string((region.rows() + 2) / 2) +
                     " vertices, more than the " + std::to_string(a.max_vertices) +
                     " accepted (larger regions map slowly: 1M vertices take about a minute and 2 GB); decimate the "
                     "surface (e.g. FreeSurfer's mris_decimate) or raise --max-vertices");
}

// The square map's options from the command line (and the --density file).
SquareMapOptions square_map_options(const FlattenArgs& a, const TriMesh& mesh) {
  SquareMapOptions options;
  options.flow.method = a.method == "mesh" ? FlowMethod::Mesh : FlowMethod::Grid;
  options.flow.grid.resolution = a.grid;
  options.flow.grid.max_passes = a.passes;
  options.flow.mesh.fixed_steps = a.fixed_steps;
  options.flow.mesh.max_iterations = a.iterations;
  options.flow.mesh.targets = a.mesh_targets == "flowing" ? MeshFlowTargets::Flowing : MeshFlowTargets::Surface;
  options.flow.polish.enabled = !a.no_polish;
  options.flip_dividing_edges = !a.split_dividing_edges;
  options.stretch_start = a.start == "stretch";
  options.optimal_transport = a.refine == "omt";
  options.transport.grid_resolution = a.omt_grid;
  options.transport.max_iterations = a.omt_iterations;
  if (!a.density.empty()) options.density = io::read_per_vertex(a.density, mesh.num_vertices());
  return options;
}

// The flat surfaces: in mm (area = cortical area), and optionally uv in [0, 1]^2 and the
// conformal initial map. Returns the mm per unit-square unit.
double write_flat_surfaces(const FlattenArgs& a, const io::Surface& surface, const SquareMapResult& r,
                           const std::string& region_source, const std::string& problem, const nlohmann::json& correspondence) {
  const bool disk = a.domain == "disk";
  const double scale = std::sqrt(r.surface_area / (disk ? Domain::disk().area() : r.width));
  io::SurfaceWriteOptions wo;
  wo.geometric_type = "Flat";
  const auto structure = surface.metadata.find("AnatomicalStructurePrimary");
  if (structure != surface.metadata.end()) wo.anatomical_structure = structure->second;
  wo.metadata = {{"authalic_map", disk ? "disk (authalic: the square map carried by Shirley & Chiu's concentric map, then a "
                                         "per-face polish with the boundary sliding on the circle)"
                                       : "square (authalic, Lie advection / Moser flow)"},
                 {"authalic_orientation", orientation_rule(disk)},
                 {"authalic_source", a.surface},
                 {"authalic_region", region_source},
                 {"authalic_input_vertices", std::to_string(r.num_input_vertices)},
                 {"authalic_cortical_area_mm2", std::to_string(r.surface_area)},
                 {"authalic_acceptance", problem.empty() ? "passed" : "FAILED: " + problem},
                 {"authalic_correspondence", correspondence["mode"].get<std::string>()}};
  if (r.initial.inserted_parents.rows() > 0)
    wo.metadata[kInsertedVerticesKey] = inserted_vertices_text(r.initial.inserted_parents, r.initial.inserted_weight);
  const std::string units = disk ? "unit disk centred at the origin (x right, y up)" : "unit square [0,1]^2 (x right, y up)";
  write_flat(a.out, r.UV * scale, r.F, wo,
             std::string("mm: the flat ") + (disk ? "disk" : "square") + "'s area equals the cortical area (" +
                 std::to_string(r.surface_area) + " mm^2)");
  if (!a.uv.empty()) write_flat(a.uv, r.UV, r.F, wo, units);
  if (!a.initial.empty()) {
    io::SurfaceWriteOptions wi = wo;
    wi.metadata["authalic_map"] = disk ? "disk (the square's conformal initial map carried by the concentric map)"
                                       : "square (conformal initial map)";
    write_flat(a.initial, r.UV_initial, r.F, wi, units);
  }
  return scale;
}

// The FreeSurfer patch (--fs-patch): FreeSurfer patches name vertices of the parent surface, so
// only the input's region vertices are written.
void write_fs_patch(const std::string& path, const SquareMapResult& r, const MatrixXi& region, double scale) {
  std::vector<char> used(r.num_input_vertices, 0);
  for (Eigen::Index f = 0; f < region.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[region(f, c)] = 1;
  std::vector<int> verts;
  for (int v = 0; v < r.num_input_vertices; ++v)
    if (used[v]) verts.push_back(v);
  // The region's boundary vertices carry FreeSurfer's border flag (stored as -(k+1)).
  std::vector<char> boundary(r.num_input_vertices, 0);
  for (const auto& loop : boundary_loops(region, r.num_input_vertices))
    for (int v : loop) boundary[v] = 1;
  MatrixXd P = MatrixXd::Zero(static_cast<Eigen::Index>(verts.size()), 3);
  std::vector<bool> on_border(verts.size());
  for (size_t k = 0; k < verts.size(); ++k) {
    P.row(k).head<2>() = r.UV.row(verts[k]) * scale;
    on_border[k] = boundary[verts[k]] != 0;
  }
  io::write_freesurfer_patch(path, verts, P, on_border);
}

// Wall times of the run's stages (s), for the metrics JSON.
struct FlattenTimes {
  double map = 0, initial = 0, flow = 0, total = 0;
};

// The metrics JSON (--metrics, --json): the map, its initial map, flow, distortion and acceptance.
nlohmann::json flatten_json(const FlattenArgs& a, const SquareMapResult& r, const SquareMapOptions& options,
                            const FlattenRegion& region, double scale, const MapMetrics& final_metrics,
                            const nlohmann::json& acceptance, const nlohmann::json& correspondence, const FlattenTimes& t) {
  nlohmann::json j = {{"surface", a.surface},
                      {"region", region.source},
                      {"output", a.out},
                      {"input_vertices", r.num_input_vertices},
                      {"vertices", r.V.rows()},
                      {"faces", r.F.rows()},
                      {"cortical_area_mm2", r.surface_area},
                      {"flat_scale_mm_per_unit", scale},
                      {"orientation_rule", orientation_rule(a.domain == "disk")},
                      {"faces_reversed_to_point_outward", r.faces_reversed},
                      {"anterior_vertex", r.anterior_vertex},
                      {"initial_map",
                       {{"weights", to_string(r.initial.weights)},
                        {"cotangent_flips", r.initial.cotangent_flips},
                        {"corner_vertices_inserted", r.initial.corner_vertices_inserted},
                        {"corners_snapped", r.initial.corners_snapped},
                        {"edges_split", r.initial.edges_split},
                        {"edges_flipped", r.initial.edges_flipped},
                        {"flips", count_flipped(r.UV_initial, r.F)}}},
                      {"flow", flow_json(r.flow, options.flow)},
                      {"flips", r.flips},
                      {"metrics", metrics_json(final_metrics)},
                      {"seconds", {{"map", t.map}, {"initial_map", t.initial}, {"flow", t.flow}, {"total", t.total}}}};
  if (region.cleanup) j["region_cleanup"] = region_cleanup_json(*region.cleanup);
  j["transport"] = transport_json(r, options);
  j["correspondence"] = correspondence;
  j["acceptance"] = acceptance;
  j["initial_map"]["stretch_energy"] = {{"iterations", r.stretch.iterations},
                                        {"face_ln_stretch_abs_mean_before", r.stretch.initial_log_stretch},
                                        {"face_ln_stretch_abs_mean_after", r.stretch.final_log_stretch}};
  return j;
}

// The picture of the map (--png), shaded by sulcal depth or the --shading file, with its element grid.
void write_map_png(const FlattenArgs& a, const TriMesh& mesh, const SquareMapResult& r) {
  analysis::ScalarColouring c;
  VectorXd shade;
  if (a.shading.empty()) {
    shade = sulcal_depth_proxy(mesh.V, mesh.F);
    c.label = "depth below smoothed surface (mm)";
  } else {
    shade = io::read_per_vertex(a.shading, mesh.num_vertices());
    c.label = "sulcal depth / curvature";
  }
  c.values = extend_to_inserted(shade, r.initial).col(0);
  c.colormap = "gray_r";
  std::tie(c.vmin, c.vmax) = analysis::robust_range(c.values);
  analysis::FlatRenderOptions fo;
  if (a.domain == "disk") {
    // The disk's elements are curved (square cells carried by the concentric map): not drawn.
    fo.x0 = fo.y0 = -1.0;
    fo.domain_width = fo.domain_height = 2.0;
    fo.title = "authalic disk map";
  } else {
    fo.grid_cols = fo.grid_rows = a.k;
    fo.title = "authalic map, " + std::to_string(a.k) + "x" + std::to_string(a.k) + " elements";
  }
  io::write_png(a.png, analysis::render_flat(r.UV, r.F, c, fo));
}

// Histograms of the per-face area and angle distortion (--histogram).
void write_distortion_histogram(const std::string& path, const SquareMapResult& r) {
  VectorXd up, la;
  face_stretch_metrics(r.V, r.UV, r.F, &up, &la);
  io::write_png(path, analysis::render_histograms({std::vector<double>(up.data(), up.data() + up.size()),
                                                   std::vector<double>(la.data(), la.data() + la.size())},
                                                  {"area distortion ln(gmax*gmin)", "angle distortion ln(gmax/gmin)"},
                                                  60, 1000, 400));
}

void run(const FlattenArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  const int given = !a.faces_from.empty() + !a.label.empty() + !a.patch.empty();
  if (given > 1) throw InputError("flatten: give at most one of --faces-from, --label, --patch");
  io::check_file_roles({a.surface, a.faces_from, a.label, a.patch, a.density, a.shading, a.sphere_reg, a.atlas_surface,
                        a.atlas_sphere, a.atlas_label, a.atlas_faces_from},
                       {a.out, a.uv, a.initial, a.fs_patch, a.metrics, a.png, a.histogram});
  require_gifti_map_output(a.out, "OUT");
  require_gifti_map_output(a.uv, "--uv");
  require_gifti_map_output(a.initial, "--initial");
  const io::Surface surface = io::read_surface(a.surface);
  const TriMesh& mesh = surface.mesh;
  for (const std::string& per_vertex : {a.faces_from, a.label, a.patch, a.density, a.shading})
    io::require_vertex_numbering(surface, a.surface, per_vertex);
  const FlattenRegion region = read_region(a, surface);
  check_region_size(a, region.F);
  SquareMapOptions options = square_map_options(a, mesh);
  options.surface_faces = &mesh.F;  // the outside of a closed surface orients any region on it
  // A label's cleanup has measured the region's topology: the map need not measure it again.
  if (region.cleanup) options.region_topology = region.cleanup->topology;

  SquareMapResult r;
  StageClock clock(terminal_progress());
  nlohmann::json correspondence;
  try {
    r = map_region(a, surface, region.F, options, clock.progress(), &correspondence);
  } catch (const InputError& e) {
    throw InputError(a.surface + " (" + region.source + "): " + e.what());
  } catch (const ProcessingError& e) {
    throw ProcessingError(a.surface + " (" + region.source + "): " + e.what() + " (--grid 1024)");
  }
  DiskMapReport disk;
  if (a.domain == "disk") carry_square_map_to_disk(r, options.density, DiskMapOptions{}, &disk, clock.progress());
  clock.stop();
  const double seconds_map = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Acceptance (core/metrics.h) before anything is written: a map that is not authalic is a
  // failure (exit 3), never a success with a note.
  const Domain domain = Domain::of(parse_domain_kind(a.domain, "--domain"));
  const MapMetrics final_metrics = map_metrics(r.V, r.UV, r.F, domain, a.k);
  const MapMetrics accept_metrics = a.k == 32 ? final_metrics : map_metrics(r.V, r.UV, r.F, domain, 32);
  // The per-vertex limit is checked on the number the user is shown (the metrics); with a
  // density the target is not the surface area, so the flow's density-weighted one is used.
  const bool plain = options.density.size() == 0;
  const double accept_vertex_mean = plain ? accept_metrics.vertex_ln_area.mean : r.flow.final_vertex_mean;
  const std::string problem = authalic_acceptance_problem(accept_metrics, accept_vertex_mean, plain);
  const std::string failure = a.surface + " (" + region.source + "): the map is not authalic: " + problem;
  // A region of fewer triangles than the acceptance grid's elements (one triangle, one vertex
  // ring) cannot be spread evenly over the square, however long the flow runs: the input is what
  // to change.
  const Eigen::Index acceptance_elements = 32 * 32;
  const std::string advice =
      r.F.rows() < acceptance_elements
          ? "The region has only " + std::to_string(r.F.rows()) + " triangles, fewer than the 32 x 32 elements of the acceptance grid: "
            "give a larger region or a finer mesh; "
      : a.method == "mesh" ? std::string(a.no_polish ? "Drop --no-polish (the per-face polish finishes the mesh flow) or use "
                                                       "the default --method grid; "
                                                     : "Try the default --method grid; ")
                           : grid_flow_advice(a.passes, a.grid);
  if (!problem.empty() && !a.keep_failed)
    throw ProcessingError(failure + "; nothing was written. " + advice + "--keep-failed writes the map for inspection, marked as failed");

  // Outputs: flat surface in mm (area = cortical area), uv in [0, 1]^2, FreeSurfer patch; the
  // initial map's metrics (for --metrics) are measured meanwhile.
  double scale = 0;
  MapMetrics initial_metrics;
  run_beside(
      [&] {
        scale = write_flat_surfaces(a, surface, r, region.source, problem, correspondence);
        if (!a.fs_patch.empty()) write_fs_patch(a.fs_patch, r, region.F, scale);
      },
      [&] {
        if (!a.metrics.empty()) initial_metrics = map_metrics(r.V, r.UV_initial, r.F, domain, a.k);
      });

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const FlattenTimes times{seconds_map, clock.seconds("initial"), clock.seconds("stretch") + clock.seconds("flow"), seconds};
  nlohmann::json j =
      flatten_json(a, r, options, region, scale, final_metrics, acceptance_json(problem, accept_metrics, plain, accept_vertex_mean), correspondence, times);
  j["domain"] = a.domain;
  if (a.domain == "disk")
    j["disk"] = {{"carry", "Shirley & Chiu's concentric map of the square map (area x pi/4 everywhere)"},
                 {"inserted_vertices", disk.inserted_vertices},
                 {"carried_flips", disk.carried_flips},
                 {"untangled_vertices", disk.untangled_vertices},
                 {"face_ln_area_abs_mean_carried", disk.carried_face_error},
                 {"face_ln_area_abs_mean_polished", disk.face_error},
                 {"polish_iterations", disk.polish_iterations},
                 {"cell_pass", {{"element_cv_before", disk.cell_cv_before_pass}, {"kept", disk.cell_pass_kept}}},
                 {"elements", "the K x K cells of the square carried onto the disk by the concentric map (equal area)"}};
  if (!a.metrics.empty()) {
    j["initial_metrics"] = metrics_json(initial_metrics);
    write_json_file(a.metrics, j);
  }
  if (!a.png.empty()) write_map_png(a, mesh, r);
  if (!a.histogram.empty()) write_distortion_histogram(a.histogram, r);

  std::ostringstream line;
  line << "flatten: " << a.out << ": " << r.flips << " flipped faces, element CV " << final_metrics.element_cv << " ("
       << a.k << "x" << a.k << "), per-face mean |ln area ratio| " << final_metrics.face_ln_area.mean
       << ", per-vertex mean " << final_metrics.vertex_ln_area.mean << " (p99 " << final_metrics.vertex_ln_area.p99 << "), "
       << r.flow.iterations << " passes + " << r.flow.polish_iterations << " polish steps, " << seconds << " s";
  if (!problem.empty()) throw ProcessingError(failure + "; written for inspection (--keep-failed), marked as failed");
  if (global_options().json) {
    std::cout << j.dump(2) << '\n';
  } else {
    info(line.str());
    if (!r.flow.converged)
      info("flatten: note: the flow stopped (" + r.flow.stop_reason + ") before its tolerance was met");
  }
}

void setup(CLI::App& parent) {
  auto a = std::make_shared<FlattenArgs>();
  CLI::App* sub = parent.add_subcommand(
      "flatten",
      "Area-preserving (authalic) map of a cortical region onto the unit square: arc-length boundary with the frontal "
      "pole at the top middle, conformal interior, then Moser/Lie area-restoring flow. Lateral surface faces the viewer; "
      "right hemispheres are mirror images of left ones.");
  sub->add_option("SURFACE", a->surface, "Cortical surface (GIFTI, FreeSurfer, VTK, PLY, OBJ, MNI .obj, STL), mm, RAS")->required();
  sub->add_option("OUT", a->out,
                  "Output flat surface (GIFTI .surf.gii): x,y in mm, scaled so its area equals the cortical area (mm^2); "
                  "the input's vertices first, vertices inserted by corner/ear splits appended")
      ->required();
  auto* g1 = sub->add_option("--faces-from", a->faces_from,
                             "Take the region's triangles from this surface on the same vertices (e.g. FreeSurfer's flat map)");
  auto* g2 = sub->add_option("--label", a->label,
                             "Cortex region as vertices: FreeSurfer .label, GIFTI label or shape mask. Its whole triangles are "
                             "cleaned into one disk (largest piece kept, holes below 1 % of its area filled, pinch vertices "
                             "resolved) and what changed is reported");
  auto* g3 = sub->add_option("--patch", a->patch, "Cortex region as a FreeSurfer patch (its vertices)");
  g1->excludes(g2)->excludes(g3);
  g2->excludes(g3);
  sub->add_flag("--keep-failed", a->keep_failed,
                "Expert: write the outputs even when the map fails its acceptance (0 flipped triangles, element CV <= 0.01 "
                "at 32x32 or 0.3 / sqrt(faces per element) where larger, every element within 25 % of the mean area, "
                "per-vertex mean |ln area ratio| <= 0.01), marked "
                "FAILED in their metadata; the exit code is still 3");
  sub->add_option("--start", a->start,
                  "Start of the flow: stretch (conformal map, then stretch-energy iterations, Yueh et al. 2019) or conformal")
      ->check(CLI::IsMember({"stretch", "conformal"}))
      ->capture_default_str();
  sub->add_option("--refine", a->refine,
                  "After the authalic map: none, or omt (the optimal-transport refinement, Dominitz & Tannenbaum 2010: "
                  "among area-preserving maps the one that moves area the least from the conformal initial map; areas are "
                  "restored by the flow afterwards; docs/maps.md)")
      ->check(CLI::IsMember({"none", "omt"}))
      ->capture_default_str();
  sub->add_option("--omt-grid", a->omt_grid,
                  "Cells per side of the grid the refinement's projection is solved on (0: about one cell per 4 vertices, "
                  "32 to 256)")
      ->check(in_range(0, 4096))
      ->capture_default_str();
  sub->add_option("--omt-iterations", a->omt_iterations, "Maximum steps of the refinement")
      ->check(in_range(0, 100000))
      ->capture_default_str();
  sub->add_option("--uv", a->uv, "Also write the map in unit-square coordinates [0,1]^2 (GIFTI)");
  sub->add_option("--initial", a->initial, "Also write the conformal initial map in [0,1]^2 (GIFTI)");
  sub->add_option("--fs-patch", a->fs_patch, "Also write a FreeSurfer flat patch (x,y in mm) of the region's input vertices");
  sub->add_option("--metrics", a->metrics,
                  "Write distortion metrics (JSON): flips, per-face/per-vertex |ln area ratio|, Upsilon/Lambda, element CV "
                  "over a K x K grid (element areas in mm^2); with --label also region_cleanup (holes filled, islands dropped, "
                  "pinch vertices fixed)");
  sub->add_option("--png", a->png, "Write a PNG of the flat map shaded by sulcal depth, with the K x K element grid");
  sub->add_option("--histogram", a->histogram, "Write a PNG histogram of the distortion metrics Upsilon and Lambda");
  sub->add_option("--shading", a->shading,
                  "Per-vertex sulc or curv file for the PNG (default: depth below a smoothed surface, mm)");
  sub->add_option("--density", a->density,
                  "Per-vertex density (GIFTI shape / FreeSurfer curv / text, > 0): a region of density 2 gets twice its "
                  "natural share of the square");
  add_k_option(*sub, a->k, {DomainKind::Square, DomainKind::Disk});
  sub->add_option("--domain", a->domain,
                  "Target domain: square (the unit square) or disk (the unit disk, Zou et al. 2011a section 4.5.1: the "
                  "square map carried by Shirley & Chiu's equal-area concentric map, boundary on the circle by arc length "
                  "with the frontal pole at the top, then a per-face polish with the boundary sliding on the circle; its "
                  "K x K elements are the square's cells carried the same way; docs/maps.md)")
      ->check(CLI::IsMember({"square", "disk"}))
      ->capture_default_str();
  sub->add_option("--method", a->method, "Flow: grid (Moser flow on a DCT grid, default) or mesh (discrete Lie flow, DLF Algorithm 1); the per-face polish follows either")
      ->check(CLI::IsMember({"grid", "mesh"}))
      ->capture_default_str();
  sub->add_option("--grid", a->grid,
                  "Grid cells per side (grid method); default: with the stretch start 256 for regions up to 131,072 "
                  "triangles and 512 above, else 512")
      ->check(CLI::IsMember({0}) | in_range(16, 4096));
  sub->add_option("--passes", a->passes, "Maximum flow passes (grid method; at least 6 from a --sphere-reg start, which is far from authalic)")->check(in_range(0, 100))->capture_default_str();
  sub->add_option("--iterations", a->iterations, "Maximum steps (mesh method)")->check(in_range(0, 100000))->capture_default_str();
  sub->add_option("--mesh-targets", a->mesh_targets,
                  "Mesh method: target vertex areas from the surface's own triangles (surface, what the outputs are "
                  "measured on) or from the surface re-triangulated by the flowing mesh's edge flips (flowing, the DLF "
                  "paper's reading; docs/maps.md)")
      ->check(CLI::IsMember({"surface", "flowing"}))
      ->capture_default_str();
  sub->add_option("--fixed-steps", a->fixed_steps,
                  "Mesh method with Zou's fixed schedule of K steps (eq. 19) instead of adaptive steps")
      ->check(in_range(0, 100000));
  sub->add_flag("--no-polish", a->no_polish, "Skip the final per-face Gauss-Newton polish (both methods)");
  sub->add_flag("--split-dividing-edges", a->split_dividing_edges,
                "Split every interior edge whose ends land on one side of the square at its midpoint (Zou et al. 2011, "
                "section 4.1) instead of flipping it; the maps then have appended vertices, recorded as "
                "authalic_inserted_vertices metadata, and do not pair with the surface's per-vertex files");
  sub->add_option("--sphere-reg", a->sphere_reg,
                  "Atlas correspondence: the subject's FreeSurfer ?h.sphere.reg (its vertices on the atlas sphere). The "
                  "atlas's authalic map is carried to the subject through it (barycentric on the atlas sphere) and made "
                  "authalic for this subject, so elements cover the same anatomy in every subject; needs --atlas or the "
                  "--atlas-* files");
  sub->add_flag("--register", a->register_to_atlas,
                "Registration mode, for surfaces without a sphere.reg: the subject's own authalic map is aligned to the "
                "atlas's (--atlas or the --atlas-* files) by an area-preserving (divergence-free) deformation of the square "
                "driven by both cortices' sulcal depth, then made exactly authalic again; recorded as mode 'registration'");
  sub->add_option("--atlas", a->atlas_dir,
                  "Atlas folder in FreeSurfer layout (surf/?h.white, surf/?h.sphere, label/?h.cortex.label; e.g. "
                  "$FREESURFER_HOME/subjects/fsaverage); the hemisphere is the surface's");
  sub->add_option("--atlas-surface", a->atlas_surface, "Atlas white surface (instead of --atlas)");
  sub->add_option("--atlas-sphere", a->atlas_sphere, "Atlas sphere (?h.sphere), same vertices as --atlas-surface");
  sub->add_option("--atlas-label", a->atlas_label, "Atlas cortex as a label (vertices) of --atlas-surface");
  sub->add_option("--atlas-faces-from", a->atlas_faces_from, "Atlas cortex as the faces of this surface (e.g. its flat patch)");
  add_max_memory_option(*sub, &a->max_memory);
  sub->add_option("--max-vertices", a->max_vertices,
                  "Largest region (vertices) accepted; larger ones work but slowly (1M: about a minute of CPU, 2 GB)")
      ->capture_default_str();
  add_common_options(*sub);
  sub->callback([a]() { run(*a); });
}

const bool registered = register_command({20, setup});

}  // namespace
}  // namespace authalic::app

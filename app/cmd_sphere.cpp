// `authalic sphere SURFACE OUT.surf.gii [--metrics M.json] [--png P.png] [--radius R]`: authalic
// map of a closed genus-0 surface onto a sphere (core/sphere_map.h), written on the input's
// vertex indexing.
#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>
#include <sstream>
#include <tuple>

#include "analysis/render.h"
#include "analysis/report.h"
#include "app/command.h"
#include "app/map_json.h"
#include "app/memory_guard.h"
#include "core/error.h"
#include "core/metrics.h"
#include "core/sphere_map.h"
#include "core/sulcal_depth.h"
#include "io/image_io.h"
#include "io/surface_io.h"
#include "io/file_roles.h"

namespace authalic::app {
namespace {

struct SphereArgs {
  std::string surface;
  std::string out;
  std::string metrics;
  std::string png;
  std::string conformal;
  std::string sulc;
  double radius = 100.0;
  bool area_radius = false;
  int puncture = -1;
  int grid = 0;
  int passes = 4;
  std::string route = "auto";
  std::string refine = "none";
  double seam_corner = 0.0;
  bool keep_failed = false;
  double max_memory = -1;  // GB; < 0: 75% of the physical RAM
};

const char* kOrientationRule =
    "+x right, +y anterior, +z superior of the input's RAS frame: the rotation that best aligns each vertex's sphere "
    "position with its direction from the surface's area centroid (area-weighted Procrustes)";

// The sphere map's options from the command line, refusing combinations the routes cannot do.
SphereMapOptions sphere_map_options(const SphereArgs& a) {
  SphereMapOptions options;
  options.puncture_face = a.puncture;
  options.flow_options.grid_cells = a.grid;
  options.flow_options.max_passes = a.passes;
  options.flow = a.passes > 0;
  options.route = a.route == "square" ? SphereRoute::Square : a.route == "flow" ? SphereRoute::Flow : SphereRoute::Auto;
  options.square_route.square.optimal_transport = a.refine == "omt";
  options.square_route.corner_offset = a.seam_corner;
  if (options.square_route.square.optimal_transport && options.route == SphereRoute::Flow)
    throw InputError("--refine omt: the refinement works on the square route's square map; drop --route flow");
  if (!a.conformal.empty() && options.route != SphereRoute::Flow)
    throw InputError("--conformal: only the flow route has a conformal sphere; add --route flow to write one");
  return options;
}

// The sphere (and --conformal's initial sphere) scaled to `radius` mm. Returns the sphere written.
TriMesh write_sphere_surfaces(const SphereArgs& a, const io::Surface& surface, const SphereMapResult& r, double radius,
                              const std::string& problem) {
  const TriMesh& mesh = surface.mesh;
  io::SurfaceWriteOptions wo;
  wo.geometric_type = "Spherical";
  const auto structure = surface.metadata.find("AnatomicalStructurePrimary");
  if (structure != surface.metadata.end()) wo.anatomical_structure = structure->second;
  wo.metadata = {{"authalic_map", "sphere"},
                 {"authalic_radius_mm", std::to_string(radius)},
                 {"authalic_orientation", kOrientationRule},
                 {"authalic_source", a.surface},
                 {"authalic_acceptance", problem.empty() ? "passed" : "FAILED: " + problem}};
  TriMesh out{r.sphere * radius, mesh.F};
  io::write_surface(a.out, out, wo);
  if (!a.conformal.empty()) {
    wo.metadata["authalic_map"] = "sphere (conformal initial map, Haker et al. 2000)";
    io::write_surface(a.conformal, TriMesh{r.conformal * radius, mesh.F}, wo);
  }
  return out;
}

// What the route did, for the metrics JSON: the rotation, then the flow's passes (flow route) or
// the square route's steps (cap, rest, coarse sphere pass, crushed patches, polish).
void add_route_json(nlohmann::json& j, const SphereMapResult& r) {
  nlohmann::json rot = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) rot.push_back({r.rotation(i, 0), r.rotation(i, 1), r.rotation(i, 2)});
  j["rotation"] = rot;
  nlohmann::json passes = nlohmann::json::array();
  for (const auto& p : r.flow.passes)
    passes.push_back({{"density_min", p.rho_min}, {"density_max", p.rho_max}, {"density_abs_ln_mean", p.rho_abs_log_mean},
                      {"rk4_steps", p.rk4_steps}});
  if (r.route == SphereRoute::Flow) {
    j["flow"] = {{"method", "Moser flow on a fixed cube-sphere background"},
                 {"grid_cells_per_edge", r.flow.grid_cells},
                 {"grid_vertices", r.flow.grid_vertices},
                 {"iterations", r.flow.passes.size()},
                 {"passes", passes}};
  } else {
    const SphereFromSquareReport& q = r.square_route;
    nlohmann::json placements = nlohmann::json::array();
    for (const SquarePlacement& p : r.placements)
      placements.push_back({{"corner_offset_of_seam_length", p.corner_offset},
                            {"corner_vertex", p.corner_vertex},
                            {"covers_sphere_once", p.covers_once},
                            {"failure", p.why},
                            {"element_cv_64x32", p.element_cv},
                            {"element_min_over_mean", p.element_min},
                            {"element_max_over_mean", p.element_max}});
    j["square_route"] = {{"cap_seed_vertex", q.seed_vertex},
                         {"corner_placement_rule", "the square's corner (0, 0) at the seam vertex corner_offset of the seam's length past its most anterior vertex; while an element of the sphere is more than 10 % off its share, up to two more placements 1/8 and 1/16 of the seam further on; of those tried, the lowest element CV is kept"},
                         {"corner_placements_tried", placements},
                         {"corner_vertex", q.corner_vertex},
                         {"corner_offset_of_seam_length", q.corner_offset},
                         {"cap_faces", q.cap_faces},
                         {"cap_area_fraction", q.cap_area_fraction},
                         {"rest_faces", q.rest_faces},
                         {"rest_square_flow", {{"iterations", q.square_flow.iterations},
                                               {"polish_iterations", q.square_flow.polish_iterations},
                                               {"vertex_ln_area_abs_mean", q.square_flow.final_vertex_mean}}},
                         {"rest_stretch_energy_iterations", q.square_stretch.iterations},
                         {"cap_stretch_energy", {{"iterations", q.cap.iterations},
                                                 {"face_ln_stretch_abs_mean_before", q.cap.initial_log_stretch},
                                                 {"face_ln_stretch_abs_mean_after", q.cap.final_log_stretch}}},
                         {"coarse_sphere_pass", {{"grid_cells_per_edge", q.sphere_flow.grid_cells},
                                                 {"passes", q.sphere_flow.passes.size()},
                                                 {"density_min", q.sphere_flow.passes.empty() ? 0.0 : q.sphere_flow.passes[0].rho_min},
                                                 {"density_max", q.sphere_flow.passes.empty() ? 0.0 : q.sphere_flow.passes[0].rho_max}}},
                         {"crushed_patches", {{"opened", q.crushed.patches},
                                              {"faces", q.crushed.crushed_faces},
                                              {"missing_area_fraction", q.crushed.missing_share},
                                              {"put_back", q.crushed.patches_undone}}},
                         {"sphere_polish_face_ln_area_abs_mean", q.polish_face_error}};
  }
}

// Wall times of the run's stages (s), for the metrics JSON.
struct SphereTimes {
  double conformal = 0, flow = 0, total = 0;
};

// The metrics JSON (--metrics, --json): the sphere, its route, distortion and acceptance.
nlohmann::json sphere_json(const SphereArgs& a, const TriMesh& mesh, const SphereMapResult& r, const SphereMapOptions& options,
                           double area, double radius, bool left, const MapMetrics& final_metrics, const std::string& problem,
                           const SphereTimes& t) {
  nlohmann::json j = {{"surface", a.surface},
                      {"output", a.out},
                      {"vertices", mesh.num_vertices()},
                      {"faces", mesh.num_faces()},
                      {"surface_area_mm2", area},
                      {"radius_mm", radius},
                      {"hemisphere", left ? "left" : "right"},
                      {"orientation_rule", kOrientationRule},
                      {"route", r.route == SphereRoute::Flow ? "flow" : "square"},
                      {"route_fallback_reason", r.fallback_reason},
                      {"puncture_face", r.puncture_face},
                      {"puncture_attempts", r.puncture_attempts},
                      {"conformal_flips", r.conformal_flips},
                      {"mobius_centroid_residual", r.mobius_residual},
                      {"repaired_vertices", r.repaired_vertices},
                      {"flips", r.flips},
                      {"metrics", metrics_json(final_metrics)},
                      {"seconds", {{"conformal", t.conformal}, {"flow", t.flow}, {"total", t.total}}}};
  j["acceptance"] = acceptance_json(problem, final_metrics, true);
  j["refine"] = a.refine;
  j["seam_corner"] = a.seam_corner;
  if (options.square_route.square.optimal_transport && r.route == SphereRoute::Square) {
    const OptimalTransportReport& ot = r.square_route.square_transport;
    j["square_route_transport"] = {{"iterations", ot.iterations},
                                   {"stop_reason", ot.stop_reason},
                                   {"cost_before", ot.initial_cost},
                                   {"cost_after_refinement", ot.final_cost},
                                   {"units", "mean squared displacement of the square part from its conformal map, "
                                             "unit-square units^2"}};
  }
  add_route_json(j, r);
  return j;
}

// The picture (--png): lateral and medial views of the sphere shaded by sulcal depth.
void write_sphere_png(const SphereArgs& a, const TriMesh& mesh, const TriMesh& out, bool left, const std::string& problem) {
  analysis::ScalarColouring c;
  c.values = a.sulc.empty() ? sulcal_depth_proxy(mesh.V, mesh.F) : io::read_per_vertex(a.sulc, mesh.num_vertices());
  c.colormap = "gray_r";
  c.label = a.sulc.empty() ? "depth below smoothed surface (mm)" : "sulcal depth";
  std::tie(c.vmin, c.vmax) = analysis::robust_range(c.values);
  analysis::SurfaceRenderOptions so;
  so.left_hemisphere = left;
  so.title = problem.empty() ? "authalic sphere" : "FAILED acceptance: sphere map (kept for inspection)";
  io::write_png(a.png, analysis::render_surface_views(out.V, out.F, c, {analysis::View::Lateral, analysis::View::Medial}, so));
}

void run(const SphereArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  io::check_file_roles({a.surface, a.sulc}, {a.out, a.metrics, a.png, a.conformal});
  const io::Surface surface = io::read_surface(a.surface);
  const TriMesh& mesh = surface.mesh;
  check_memory(a.surface, mesh.num_vertices(), sphere_map_memory_bytes(mesh.num_vertices()), a.max_memory);
  const SphereMapOptions options = sphere_map_options(a);
  SphereMapResult r;
  StageClock clock(terminal_progress());
  const auto t_map = std::chrono::steady_clock::now();
  try {
    r = authalic_sphere_map(mesh, options, clock.progress());
  } catch (const InputError& e) {
    throw InputError(a.surface + ": " + e.what());
  }
  clock.stop();
  const double seconds_map = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_map).count();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Acceptance (core/metrics.h) before anything is written: a sphere that is not authalic is a
  // failure (exit 3), never a success with a note.
  const MapMetrics final_metrics = r.metrics ? *r.metrics : map_metrics(mesh.V, r.sphere, mesh.F, Domain::sphere(), 32);
  const std::string problem = authalic_acceptance_problem(final_metrics, final_metrics.vertex_ln_area.mean, true);
  const std::string failure = a.surface + ": the sphere map is not authalic: " + problem;
  if (!problem.empty() && !a.keep_failed)
    throw ProcessingError(failure + "; nothing was written. " +
                          (r.route == SphereRoute::Flow
                               ? std::string("Try more passes (--passes 8) or a finer background grid (--grid 128); ")
                               : std::string("Try --route flow (--passes and --grid set its flow), or check that the surface is one "
                                             "clean closed hemisphere; ")) +
                          "--keep-failed writes the map for inspection, marked as failed");

  const double area = face_areas(mesh.V, mesh.F).sum();
  const double radius = a.area_radius ? std::sqrt(area / (4.0 * M_PI)) : a.radius;
  const bool left = is_left_hemisphere(surface.metadata, mesh.V);
  const TriMesh out = write_sphere_surfaces(a, surface, r, radius, problem);
  const SphereTimes times{clock.seconds("conformal"), seconds_map - clock.seconds("conformal"), seconds};
  nlohmann::json j = sphere_json(a, mesh, r, options, area, radius, left, final_metrics, problem, times);
  if (!a.metrics.empty()) {
    if (r.route == SphereRoute::Flow)
      j["conformal_metrics"] = metrics_json(map_metrics(mesh.V, r.conformal, mesh.F, Domain::sphere(), 32));
    write_json_file(a.metrics, j);
  }
  if (!a.png.empty()) write_sphere_png(a, mesh, out, left, problem);

  std::ostringstream line;
  line << "sphere: " << a.out << " (radius " << radius << " mm): " << r.flips << " flipped faces, element CV "
       << final_metrics.element_cv << " (" << final_metrics.element_cols << "x" << final_metrics.element_rows
       << "), per-face mean |ln area ratio| " << final_metrics.face_ln_area.mean << ", " << seconds << " s";
  if (!problem.empty()) throw ProcessingError(failure + "; written for inspection (--keep-failed), marked as failed");
  if (global_options().json) {
    std::cout << j.dump(2) << '\n';
  } else {
    info(line.str());
  }
}

void setup(CLI::App& parent) {
  auto a = std::make_shared<SphereArgs>();
  CLI::App* sub = parent.add_subcommand(
      "sphere",
      "Area-preserving map of a closed genus-0 surface (a hemisphere or a whole brain) onto a sphere: by default the "
      "authalic square map of all but a 10 % cap, carried to the sphere by equal-area maps, then a per-face polish on "
      "the sphere (--route flow: Haker's conformal map, Moebius centring, Moser's flow). Orientation: +x right, "
      "+y anterior, +z superior. "
      "A map that fails its acceptance (0 flipped faces, element CV <= 0.01 at 64x32, or 0.3 / sqrt(faces per element) "
      "where larger, every element within 25 % of the mean area, per-vertex mean |ln area ratio| <= 0.01) is an error: "
      "exit code 3, nothing written.");
  sub->add_option("SURFACE", a->surface, "Closed genus-0 surface (GIFTI, FreeSurfer, VTK, PLY, OBJ, MNI .obj, STL), mm")->required();
  sub->add_option("OUT", a->out, "Output sphere surface, same vertices and triangles as SURFACE: GIFTI (.surf.gii), or FreeSurfer binary for a name without a known extension (e.g. lh.sphere.authalic)")->required();
  sub->add_option("--metrics", a->metrics, "Write distortion metrics (JSON; areas in mm^2, element grid 64 x 32)");
  sub->add_option("--png", a->png, "Write a PNG of the sphere seen from lateral and medial, shaded by sulcal depth");
  sub->add_option("--sulc", a->sulc, "Per-vertex sulcal depth for the PNG (FreeSurfer sulc or GIFTI shape; default: depth "
                                     "below a smoothed copy of the surface, mm)");
  sub->add_option("--radius", a->radius, "Sphere radius (mm)")->check(CLI::PositiveNumber)->capture_default_str();
  sub->add_flag("--area-radius", a->area_radius,
                "Use the radius whose sphere area equals the surface's area (sqrt(area / 4 pi), mm) instead of --radius");
  sub->add_option("--conformal", a->conformal, "Also write the conformal initial map (GIFTI), same radius");
  sub->add_option("--puncture", a->puncture, "Flow route: face index of Haker's puncture (default: best-shaped faces in turn)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--grid", a->grid, "Flow route: background cube-sphere cells per cube edge (default: from the mesh size)")
      ->check(in_range(8, 512));
  sub->add_option("--passes", a->passes, "Flow route: Moser flow passes (the square route, the default's first choice, has its own)")->check(in_range(0, 50))->capture_default_str();
  sub->add_option("--route", a->route,
                  "square: through the authalic square map of all but a cap of 10 % of the area, then per-face polish on "
                  "the sphere (works on native-resolution meshes); flow: Haker's conformal sphere + Moser flow on the "
                  "sphere; auto: square, and flow if the square route's sphere does not cover it once (docs/maps.md)")
      ->check(CLI::IsMember({"auto", "flow", "square"}))
      ->capture_default_str();
  sub->add_option("--refine", a->refine,
                  "none, or omt: the square route's square map gets the optimal-transport refinement (flatten --refine omt; "
                  "docs/maps.md) before it is carried to the sphere")
      ->check(CLI::IsMember({"none", "omt"}))
      ->capture_default_str();
  sub->add_option("--seam-corner", a->seam_corner,
                  "Expert, square route: where the square's corner (0, 0) falls on the seam around the cap, as a share "
                  "of the seam's length past its most anterior vertex; while an element is more than 10 % off its share, "
                  "the route tries up to two more placements (0.125 and 0.0625 further on) and keeps "
                  "the sphere with the lowest element CV")
      ->check(in_range(0.0, 1.0))
      ->capture_default_str();
  sub->add_flag("--keep-failed", a->keep_failed,
                "Expert: write the outputs even when the map fails its acceptance, marked FAILED in their metadata and "
                "picture title; the exit code is still 3");
  add_max_memory_option(*sub, &a->max_memory);
  add_common_options(*sub);
  sub->callback([a]() { run(*a); });
}

const bool registered = register_command({40, setup});

}  // namespace
}  // namespace authalic::app

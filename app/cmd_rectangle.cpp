// `authalic rectangle`: whole-brain authalic map onto the 2:1 rectangle [0, 2] x [0, 1]
// (core/rectangle_map.h), in two forms:
//   authalic rectangle OUT.surf.gii --surface S [--cut-from V --cut-to V]
//   authalic rectangle OUT_PREFIX --lh S --lh-faces-from F --rh S --rh-faces-from F
//   authalic rectangle OUT_PREFIX --lh S --lh-cortex L --rh S --rh-cortex L
#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>
#include <sstream>
#include <tuple>

#include "analysis/cortex_region.h"
#include "analysis/elements.h"
#include "analysis/render.h"
#include "analysis/report.h"
#include "app/command.h"
#include "app/map_json.h"
#include "core/error.h"
#include "core/metrics.h"
#include "core/rectangle_map.h"
#include "core/sulcal_depth.h"
#include "io/image_io.h"
#include "io/surface_io.h"
#include "io/file_roles.h"

namespace authalic::app {
namespace {

struct RectangleArgs {
  std::string out;
  std::string surface;
  int cut_from = -1, cut_to = -1;
  std::string lh, lh_faces, lh_cortex, rh, rh_faces, rh_cortex;
  std::string metrics, png, histogram;
  std::string sulc, lh_sulc, rh_sulc;
  bool flat = false;
  bool cut_surface = false;
  std::string initial = "auto";
  int k = 32;
  bool keep_failed = false;
};

std::string stem_of(const std::string& path) {
  for (const char* ext : {".surf.gii", ".gii"}) {
    const std::string e(ext);
    if (path.size() > e.size() && path.compare(path.size() - e.size(), e.size(), e) == 0) return path.substr(0, path.size() - e.size());
  }
  return path;
}

// The map as a surface: x, y in the rectangle, z = 0.
TriMesh as_flat_mesh(const MatrixXd& UV, const MatrixXi& F, double scale = 1.0) {
  TriMesh m;
  m.V = MatrixXd::Zero(UV.rows(), 3);
  m.V.leftCols(2) = UV * scale;
  m.F = F;
  return m;
}

// Per-vertex values for the picture on a part's vertices: input vertices from `values`, added
// vertices (cut copies: their origin; split vertices: mean of their input neighbours).
VectorXd part_values(const RectanglePart& p, const VectorXd& values) {
  VectorXd out = VectorXd::Constant(p.V.rows(), std::nan(""));
  for (Eigen::Index i = 0; i < p.V.rows(); ++i)
    if (p.vertex_origin[i] >= 0) out[i] = values[p.vertex_origin[i]];
  VectorXd sum = VectorXd::Zero(p.V.rows()), count = VectorXd::Zero(p.V.rows());
  for (Eigen::Index f = 0; f < p.F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      for (int d = 1; d < 3; ++d) {
        const int v = p.F(f, c), u = p.F(f, (c + d) % 3);
        if (p.vertex_origin[v] < 0 && std::isfinite(out[u])) sum[v] += out[u], count[v] += 1;
      }
  for (Eigen::Index i = 0; i < p.V.rows(); ++i)
    if (p.vertex_origin[i] < 0 && count[i] > 0) out[i] = sum[i] / count[i];
  return out;
}

// The hemisphere's surface with its cortex faces: from a face set (--?h-faces-from), a cortex
// label, mask or face set (--?h-cortex, cleaned up into one disk as `run` does), or all its faces.
TriMesh read_cortex(const std::string& surface_path, const std::string& faces_path, const std::string& cortex_path,
                    const std::string& name, io::Surface* surface) {
  *surface = io::read_surface(surface_path);
  TriMesh cortex = surface->mesh;
  if (!faces_path.empty()) {
    const io::Surface faces = io::read_surface(faces_path);
    if (faces.mesh.num_vertices() != cortex.num_vertices())
      throw InputError(faces_path + ": has " + std::to_string(faces.mesh.num_vertices()) + " vertices but " + surface_path +
                       " has " + std::to_string(cortex.num_vertices()) + "; the face set must be on the same vertices");
    cortex.F = faces.mesh.F;
  } else if (!cortex_path.empty()) {
    analysis::CortexRegion region = analysis::read_cortex_region(cortex, surface_path, cortex_path, name);
    if (!region.note.empty()) info("rectangle: " + region.note);
    cortex.F = std::move(region.F);
  }
  return cortex;
}

nlohmann::json part_json(const RectanglePart& p) {
  return {{"x0", p.x0},
          {"width", p.width},
          {"area_mm2", p.area_mm2},
          {"vertices", p.V.rows()},
          {"input_vertices", p.num_input_vertices},
          {"faces", p.F.rows()},
          {"anchor_vertex", p.anchor_vertex},
          {"initial_flips", p.initial_flips},
          {"flow", flow_json(p.flow, RectangleMapOptions{}.flow)}};
}

// The surfaces the command writes, named once for the writers and the up-front path checks
// (io/file_roles.h). --surface: OUT, <stem>.flat/.cut.surf.gii; --lh/--rh: OUT.lh/.rh(.flat).surf.gii.
struct SurfaceOutputs {
  std::string map, flat, cut;                   // --surface form
  std::string lh, rh, lh_flat, rh_flat;         // --lh/--rh form
};

SurfaceOutputs surface_outputs(const RectangleArgs& a) {
  SurfaceOutputs o;
  if (!a.surface.empty()) {
    const std::string stem = stem_of(a.out);
    o.map = a.out;
    o.flat = stem + ".flat.surf.gii";
    o.cut = stem + ".cut.surf.gii";
  } else {
    o.lh = a.out + ".lh.surf.gii";
    o.rh = a.out + ".rh.surf.gii";
    o.lh_flat = a.out + ".lh.flat.surf.gii";
    o.rh_flat = a.out + ".rh.flat.surf.gii";
  }
  return o;
}

// Every file the command will write.
std::vector<std::string> output_paths(const RectangleArgs& a) {
  const SurfaceOutputs o = surface_outputs(a);
  std::vector<std::string> out = {a.metrics, a.png, a.histogram, o.map, o.lh, o.rh};
  if (a.flat) out.insert(out.end(), {o.flat, o.lh_flat, o.rh_flat});
  if (a.cut_surface) out.push_back(o.cut);
  return out;
}

// All parts as one mesh in the rectangle: surface V, map UV, initial map UV0, faces F.
struct Combined {
  MatrixXd V, UV, UV0;
  MatrixXi F;
};

Combined combine(const std::vector<const RectanglePart*>& parts) {
  Eigen::Index nv = 0, nf = 0;
  for (const auto* p : parts) nv += p->V.rows(), nf += p->F.rows();
  Combined c{MatrixXd(nv, 3), MatrixXd(nv, 2), MatrixXd(nv, 2), MatrixXi(nf, 3)};
  Eigen::Index ov = 0, of = 0;
  for (const auto* p : parts) {
    c.V.middleRows(ov, p->V.rows()) = p->V;
    c.UV.middleRows(ov, p->V.rows()) = p->UV;
    c.UV0.middleRows(ov, p->V.rows()) = p->UV_initial;
    c.F.middleRows(of, p->F.rows()) = p->F.array() + static_cast<int>(ov);
    ov += p->V.rows();
    of += p->F.rows();
  }
  return c;
}

// The parts as one mesh, its metrics on the acceptance grid (2K x K with K = 32) and the
// acceptance problem ("" = passed), computed once for the check and the outputs.
struct Checked {
  Combined all;
  MapMetrics at32;
  std::string problem;
};

// Acceptance (core/metrics.h) before anything is written: a rectangle that is not authalic is a
// failure (exit 3, nothing written), unless --keep-failed.
Checked check_acceptance(const RectangleArgs& a, const std::vector<const RectanglePart*>& parts, const std::string& what) {
  Checked c{combine(parts), {}, {}};
  c.at32 = map_metrics(c.all.V, c.all.UV, c.all.F, Domain::rectangle(), 32);
  c.problem = authalic_acceptance_problem(c.at32, c.at32.vertex_ln_area.mean, true);
  if (!c.problem.empty() && !a.keep_failed)
    throw ProcessingError(what + ": the rectangle map is not authalic: " + c.problem +
                          "; nothing was written. --keep-failed writes the map for inspection, marked as failed");
  return c;
}

// Writes metrics, pictures and the requested extra surfaces for one or two parts.
void finish(const RectangleArgs& a, const std::vector<const RectanglePart*>& parts, const std::vector<VectorXd>& shading,
            nlohmann::json j, double seconds, const std::string& what, const Checked& checked) {
  const Combined& all = checked.all;
  const std::string& problem = checked.problem;
  const MatrixXd &V = all.V, &UV = all.UV, &UV0 = all.UV0;
  const MatrixXi& F = all.F;
  VectorXd values(V.rows());
  for (std::size_t i = 0, ov = 0; i < parts.size(); ov += parts[i]->V.rows(), ++i)
    values.segment(static_cast<Eigen::Index>(ov), parts[i]->V.rows()) = part_values(*parts[i], shading[i]);
  const MapMetrics m = a.k == 32 ? checked.at32 : map_metrics(V, UV, F, Domain::rectangle(), a.k);
  j["metrics"] = metrics_json(m);
  j["acceptance"] = acceptance_json(problem, checked.at32, true);
  j["extent"] = {UV.col(0).minCoeff(), UV.col(1).minCoeff(), UV.col(0).maxCoeff(), UV.col(1).maxCoeff()};
  j["seconds"] = seconds;
  if (!a.metrics.empty()) {
    j["initial_metrics"] = metrics_json(map_metrics(V, UV0, F, Domain::rectangle(), a.k));
    write_json_file(a.metrics, j);
  }
  if (!a.png.empty()) {
    analysis::ScalarColouring c;
    c.values = values;
    c.colormap = "gray_r";
    c.label = a.sulc.empty() && a.lh_sulc.empty() ? "depth below smoothed surface (mm)" : "sulcal depth";
    std::tie(c.vmin, c.vmax) = analysis::robust_range(values);
    analysis::FlatRenderOptions o;
    o.width = 1000;
    o.domain_width = Domain::rectangle().width();
    o.grid_cols = 2 * a.k;
    o.grid_rows = a.k;
    o.title = problem.empty() ? "authalic rectangle" : "FAILED acceptance: rectangle map (kept for inspection)";
    io::write_png(a.png, analysis::render_flat(UV, F, c, o));
  }
  if (!a.histogram.empty()) {
    VectorXd up, la;
    face_stretch_metrics(V, UV, F, &up, &la);
    io::write_png(a.histogram, analysis::render_histograms({std::vector<double>(up.data(), up.data() + up.size()),
                                                            std::vector<double>(la.data(), la.data() + la.size())},
                                                           {"area distortion ln(g1 g2)", "angle distortion ln(g1/g2)"}, 60, 900, 360));
  }
  std::ostringstream line;
  line << "rectangle: " << m.flips << " flipped faces, element CV " << m.element_cv << " (" << m.element_cols << "x"
       << m.element_rows << "), per-face mean |ln area ratio| " << m.face_ln_area.mean << ", " << seconds << " s";
  if (!problem.empty())
    throw ProcessingError(what + ": the rectangle map is not authalic: " + problem +
                          "; written for inspection (--keep-failed), marked as failed");
  if (global_options().json) {
    std::cout << j.dump(2) << '\n';
  } else {
    info(line.str());
  }
}

// seam_x: where the two hemispheres' parts meet (x in the [0, 2] rectangle), or NaN for one
// surface ("none"); `elements` reads it so that clusters do not cross the seam (analysis::same_part).
// A file scaled to mm (mm_per_unit > 0, --flat) records it in its own units: x = seam_x *
// mm_per_unit mm, under analysis::kSeamMmKey.
io::SurfaceWriteOptions flat_options(const std::string& structure, const std::string& what, const std::string& problem,
                                     double seam_x, double mm_per_unit = 0) {
  io::SurfaceWriteOptions wo;
  wo.geometric_type = "Flat";
  wo.anatomical_structure = structure;
  wo.metadata = {{"authalic_map", what}, {"authalic_acceptance", problem.empty() ? "passed" : "FAILED: " + problem}};
  if (mm_per_unit > 0)
    wo.metadata[analysis::kSeamMmKey] = analysis::seam_text(seam_x * mm_per_unit);
  else
    wo.metadata[analysis::kSeamKey] = analysis::seam_text(seam_x);
  return wo;
}

// The vertices the cut appended (one copy of each interior path vertex), as the map-file record
// of inserted vertices: each at the path vertex it copies (same position).
std::string cut_copies_text(const TriMesh& surface, const WholeBrainRectangle& r) {
  const Eigen::Index nv = surface.V.rows(), copies = r.map.V.rows() - nv;
  if (copies <= 0) return {};
  MatrixXi parents(copies, 2);
  for (Eigen::Index k = 0; k < copies; ++k) {
    int source = -1;
    for (const int p : r.cut_path)
      if (r.map.V.row(nv + k) == surface.V.row(p)) source = p;
    if (source < 0) return {};  // not a copy of a path vertex: nothing recorded rather than a wrong record
    parents.row(k) << source, source;
  }
  return inserted_vertices_text(parents, VectorXd::Zero(copies));
}

void run_one_surface(const RectangleArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  const io::Surface s = io::read_surface(a.surface);
  RectangleMapOptions options;
  options.cut_from = a.cut_from;
  options.cut_to = a.cut_to;
  options.initial = a.initial == "surface" ? RectangleInitial::Surface
                    : a.initial == "sphere"  ? RectangleInitial::Sphere
                                             : RectangleInitial::Auto;
  for (int v : {a.cut_from, a.cut_to})
    if (v >= s.mesh.num_vertices())
      throw InputError(a.surface + ": cut vertex " + std::to_string(v) + " is out of range; the surface has " +
                       std::to_string(s.mesh.num_vertices()) + " vertices");
  WholeBrainRectangle r;
  try {
    r = whole_brain_rectangle_map(s.mesh, options, terminal_progress());
  } catch (const InputError& e) {
    // Core states the fact; the flags that fix it are the CLI's.
    const bool topology = std::string(e.what()).find("not a closed genus-0 surface") != std::string::npos;
    throw InputError(a.surface + ": " + e.what() + (topology ? " (or give two hemispheres with --lh/--rh)" : ""));
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Checked checked = check_acceptance(a, {&r.map}, a.surface);
  const std::string& problem = checked.problem;
  const std::string structure = s.metadata.count("AnatomicalStructurePrimary") ? s.metadata.at("AnatomicalStructurePrimary") : "";
  const SurfaceOutputs names = surface_outputs(a);
  // The cut's copies of the path vertices, recorded as `flatten` records its inserted vertices
  // (each at its source: "source source 0"), so `metrics` and `elements` pair the map with the
  // input surface and measure every face.
  const std::string copies = cut_copies_text(s.mesh, r);
  io::SurfaceWriteOptions map_options =
      flat_options(structure, "rectangle [0,2]x[0,1] (one surface, inferior-medial cut)", problem, std::nan(""));
  if (!copies.empty()) map_options.metadata[kInsertedVerticesKey] = copies;
  io::write_surface(names.map, as_flat_mesh(r.map.UV, r.map.F), map_options);
  if (a.flat) {
    // 1 mm^2 of flat map = 1 mm^2 of cortex: the rectangle (area 2) scaled by sqrt(area / 2).
    const double scale = std::sqrt(r.map.area_mm2 / Domain::rectangle().area());
    io::SurfaceWriteOptions flat = flat_options(structure, "rectangle scaled to the cortical area (mm)", problem, std::nan(""), scale);
    if (!copies.empty()) flat.metadata[kInsertedVerticesKey] = copies;
    io::write_surface(names.flat, as_flat_mesh(r.map.UV, r.map.F, scale), flat);
  }
  if (a.cut_surface) {
    io::SurfaceWriteOptions wo;
    wo.anatomical_structure = structure;
    wo.metadata = {{"authalic_map", "input surface cut open along the rectangle's cut path (same vertices as the map)"}};
    io::write_surface(names.cut, TriMesh{r.map.V, r.map.F}, wo);
  }
  const VectorXd shading = a.png.empty() ? VectorXd::Zero(s.mesh.num_vertices())
                           : a.sulc.empty() ? sulcal_depth_proxy(s.mesh.V, s.mesh.F)
                                            : io::read_per_vertex(a.sulc, s.mesh.num_vertices());
  nlohmann::json j = {{"form", "one surface"},
                      {"surface", a.surface},
                      {"output", a.out},
                      {"cut_from", r.cut_path.front()},
                      {"cut_to", r.cut_path.back()},
                      {"cut_path_vertices", r.cut_path.size()},
                      {"layout", "anterior cut vertex at (0, 0.5), posterior at (2, 0.5)"},
                      {"initial_map", r.initial_used == RectangleInitial::Sphere
                                          ? "harmonic map of the cut authalic sphere image"
                                          : "conformal map of the cut surface, then the stretch-energy start"},
                      {"initial_attempts", r.attempts},
                      {"sphere_flips", r.sphere_flips},
                      {"part", part_json(r.map)}};
  finish(a, {&r.map}, {shading}, j, seconds, a.surface, checked);
}

// The left part of the rectangle must be the left hemisphere: a swapped pair (or one file given
// twice) made a left/right swapped rectangle labelled CortexLeft on the right hemisphere. The
// files' GIFTI structure decides; without it, the left hemisphere lies at smaller RAS x.
void require_left_and_right(const io::Surface& lh, const std::string& lh_path, const io::Surface& rh, const std::string& rh_path) {
  auto structure = [](const io::Surface& s) {
    const auto it = s.metadata.find("AnatomicalStructurePrimary");
    return it == s.metadata.end() ? std::string() : it->second;
  };
  const std::string ls = structure(lh), rs = structure(rh);
  if (ls.find("Right") != std::string::npos || rs.find("Left") != std::string::npos)
    throw InputError((ls.find("Right") != std::string::npos ? lh_path + ": is " + ls + " (its GIFTI structure) but was given as --lh"
                                                             : rh_path + ": is " + rs + " (its GIFTI structure) but was given as --rh") +
                     "; give the left hemisphere as --lh and the right as --rh");
  const double lx = lh.mesh.V.col(0).mean(), rx = rh.mesh.V.col(0).mean();
  if (!(lx < rx)) {
    char buf[200];
    std::snprintf(buf, sizeof(buf), ": the left hemisphere lies at larger or equal RAS x (mean %.1f mm) than the right one (%s, mean %.1f mm)",
                  lx, rh_path.c_str(), rx);
    throw InputError(lh_path + buf + (lh_path == rh_path ? "; the same file was given twice" : "; left and right look swapped") +
                     ": give the left hemisphere as --lh and the right as --rh");
  }
}

void run_two_hemispheres(const RectangleArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  io::Surface ls, rs;
  const TriMesh left = read_cortex(a.lh, a.lh_faces, a.lh_cortex, "left", &ls);
  const TriMesh right = read_cortex(a.rh, a.rh_faces, a.rh_cortex, "right", &rs);
  require_left_and_right(ls, a.lh, rs, a.rh);
  HemisphereRectangles r;
  try {
    r = hemisphere_rectangle_map(left, right, {}, terminal_progress());
  } catch (const InputError& e) {
    const bool topology = std::string(e.what()).find("not one disk") != std::string::npos;
    throw InputError(a.lh + ", " + a.rh + ": " + e.what() +
                     (topology ? "; give each hemisphere's cortex (e.g. --lh-faces-from flat_left.gii.gz, or --lh-cortex lh.cortex.label)" : ""));
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string what = a.lh + ", " + a.rh;
  const Checked checked = check_acceptance(a, {&r.left, &r.right}, what);
  const std::string& problem = checked.problem;
  const SurfaceOutputs names = surface_outputs(a);
  const std::string &lpath = names.lh, &rpath = names.rh;
  const double seam = r.split;
  io::write_surface(lpath, as_flat_mesh(r.left.UV, r.left.F), flat_options("CortexLeft", "rectangle [0,2]x[0,1], left part", problem, seam));
  io::write_surface(rpath, as_flat_mesh(r.right.UV, r.right.F), flat_options("CortexRight", "rectangle [0,2]x[0,1], right part", problem, seam));
  if (a.flat) {
    const double scale = std::sqrt((r.left.area_mm2 + r.right.area_mm2) / Domain::rectangle().area());
    io::write_surface(names.lh_flat, as_flat_mesh(r.left.UV, r.left.F, scale),
                      flat_options("CortexLeft", "rectangle scaled to the cortical area (mm)", problem, seam, scale));
    io::write_surface(names.rh_flat, as_flat_mesh(r.right.UV, r.right.F, scale),
                      flat_options("CortexRight", "rectangle scaled to the cortical area (mm)", problem, seam, scale));
  }
  auto shading = [&](const io::Surface& s, const std::string& sulc) -> VectorXd {
    if (a.png.empty()) return VectorXd::Zero(s.mesh.num_vertices());
    return sulc.empty() ? sulcal_depth_proxy(s.mesh.V, s.mesh.F) : io::read_per_vertex(sulc, s.mesh.num_vertices());
  };
  nlohmann::json j = {{"form", "two hemispheres"},
                      {"lh", a.lh},
                      {"rh", a.rh},
                      {"outputs", {lpath, rpath}},
                      {"split_x", r.split},
                      {"layout", "left hemisphere on [0, split], right (mirrored) on [split, 2]; anterior at the top middle of each part"},
                      {"left", part_json(r.left)},
                      {"right", part_json(r.right)}};
  finish(a, {&r.left, &r.right}, {shading(ls, a.lh_sulc), shading(rs, a.rh_sulc)}, j, seconds, what, checked);
}

void setup(CLI::App& parent) {
  auto a = std::make_shared<RectangleArgs>();
  CLI::App* sub = parent.add_subcommand(
      "rectangle",
      "Area-preserving map of the whole brain onto the 2:1 rectangle [0,2] x [0,1]: either one closed genus-0 surface cut "
      "open along an inferior-medial path (--surface), or two hemispheres side by side with widths proportional to their "
      "cortical areas (--lh/--rh). Outputs are in rectangle coordinates (x in [0,2], y in [0,1]); element grid 2K x K. "
      "A map that fails its acceptance (0 flipped faces, element CV <= 0.01 at 64x32, or 0.3 / sqrt(faces per element) "
      "where larger, every element within 25 % of the mean area, per-vertex mean |ln area ratio| <= 0.01) is an error: "
      "exit code 3, nothing written.");
  sub->add_option("OUT", a->out,
                  "--surface: output map (GIFTI .surf.gii). --lh/--rh: output prefix, writes OUT.lh.surf.gii and OUT.rh.surf.gii")
      ->required();
  auto* surface = sub->add_option("--surface", a->surface, "One closed genus-0 whole-brain surface (mm)");
  sub->add_option("--cut-from", a->cut_from, "Anterior cut vertex (default: the inferior-medial landmark rule)")->check(in_range(0, 2147483647))->needs(surface);
  sub->add_option("--cut-to", a->cut_to, "Posterior cut vertex (default: the inferior-medial landmark rule)")->check(in_range(0, 2147483647))->needs(surface);
  auto* lh = sub->add_option("--lh", a->lh, "Left hemisphere surface (mm)");
  auto* rh = sub->add_option("--rh", a->rh, "Right hemisphere surface (mm)");
  auto* lh_faces = sub->add_option("--lh-faces-from", a->lh_faces,
                                   "Cortex face set of the left hemisphere: a surface on the same vertices (e.g. flat_left.gii.gz)")
                       ->needs(lh);
  auto* rh_faces = sub->add_option("--rh-faces-from", a->rh_faces, "Cortex face set of the right hemisphere (same vertices as --rh)")->needs(rh);
  sub->add_option("--lh-cortex", a->lh_cortex,
                  "Cortex of the left hemisphere as `run` takes it: FreeSurfer label (lh.cortex.label), GIFTI label or 0/1 mask "
                  "(cleaned up into one disk: islands dropped, small holes filled), or a face set on the same vertices")
      ->needs(lh)
      ->excludes(lh_faces);
  sub->add_option("--rh-cortex", a->rh_cortex, "Cortex of the right hemisphere (as --lh-cortex)")->needs(rh)->excludes(rh_faces);
  lh->needs(rh);
  rh->needs(lh);
  surface->excludes(lh)->excludes(rh);
  sub->add_option("--metrics", a->metrics, "Write distortion metrics (JSON; areas in mm^2)");
  sub->add_flag("--keep-failed", a->keep_failed,
                "Expert: write the outputs even when the map fails its acceptance, marked FAILED in their metadata and "
                "picture title; the exit code is still 3");
  sub->add_option("--png", a->png, "Write a PNG of the map shaded by sulcal depth, with the 2K x K element grid");
  sub->add_option("--histogram", a->histogram, "Write a PNG histogram of the area and angle distortion per face");
  sub->add_option("--sulc", a->sulc, "Per-vertex sulcal depth of --surface for the PNG (default: depth below a smoothed copy, mm)")->needs(surface);
  sub->add_option("--lh-sulc", a->lh_sulc, "Per-vertex sulcal depth of --lh for the PNG")->needs(lh);
  sub->add_option("--rh-sulc", a->rh_sulc, "Per-vertex sulcal depth of --rh for the PNG")->needs(rh);
  sub->add_flag("--flat", a->flat, "Also write the map scaled to the cortical area (1 mm^2 flat = 1 mm^2 cortex): <stem>.flat.surf.gii; "
                "its metadata authalic_seam_x_mm gives where the hemispheres' parts meet in mm");
  sub->add_flag("--cut-surface", a->cut_surface,
                "--surface form: also write the 3D surface cut open, on the map's vertices (<stem>.cut.surf.gii)")
      ->needs(surface);
  sub->add_option("--initial", a->initial,
                  "--surface form: the initial map: surface (the cut surface's conformal map and stretch-energy start, as "
                  "flatten does), sphere (the harmonic map on its authalic sphere image), auto (surface, then sphere if the "
                  "first fails; see docs/maps.md)")
      ->check(CLI::IsMember({"auto", "surface", "sphere"}))
      ->capture_default_str()
      ->needs(surface);
  add_k_option(*sub, a->k, {DomainKind::Rectangle}, 1, 512);
  add_common_options(*sub);
  sub->callback([a]() {
    if (a->surface.empty() && a->lh.empty()) throw InputError("rectangle: give --surface S, or --lh S --rh S (see --help)");
    io::check_file_roles({a->surface, a->lh, a->rh, a->lh_faces, a->rh_faces, a->lh_cortex, a->rh_cortex, a->sulc, a->lh_sulc, a->rh_sulc}, output_paths(*a));
    if (!a->surface.empty()) {
      require_gifti_map_output(a->out, "OUT");
      run_one_surface(*a);
    } else {
      run_two_hemispheres(*a);
    }
  });
}

const bool registered = register_command({45, setup});

}  // namespace
}  // namespace authalic::app

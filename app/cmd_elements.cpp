// `authalic elements SURFACE MAP VALUES OUT_PREFIX`: equal-area cortical elements of an authalic map
// (Zou et al. 2011 section 5.2) and their exported images. See analysis/elements.h.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <cmath>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "analysis/elements.h"
#include "analysis/normative.h"
#include "app/command.h"
#include "app/map_json.h"
#include "core/error.h"
#include "core/square_map.h"
#include "core/version.h"
#include "io/surface_formats.h"
#include "io/surface_io.h"
#include "io/file_roles.h"

namespace authalic::app {
namespace {

struct ElementsArgs {
  std::string surface, map, values, prefix;
  int k = 32;
  std::string domain = "square";
  std::string hemisphere;
  std::string subject;
  double age = std::nan("");
  std::string normalisation, units;
};

// The sampling metadata of a GIFTI func file written by `authalic sample` (normalisation, units).
// io/ has no public reader of a func file's metadata, so this uses its GIFTI reader directly.
std::map<std::string, std::string> func_metadata(const std::string& path) {
  const std::string lower = [&] {
    std::string s = path;
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
  }();
  if (lower.find(".gii") == std::string::npos) return {};
  return io::detail::read_gifti(path).metadata;
}

// The surface's faces inside the map's region. A map may cover only part of the surface (the
// cortex of a whole-hemisphere white surface, as `authalic flatten --faces-from/--label` writes it),
// and tracing the vertices the flattening appended to the edges they split needs the region's own
// faces: outside it, a split boundary edge would have a second face. Kept: faces whose vertices are
// all map vertices and that are map faces themselves or were split (an edge of theirs is not an
// edge of the map); dropped: faces outside, including caps whose three edges are region edges.
MatrixXi faces_in_map_region(const MatrixXi& F, const MatrixXi& map_F, int num_vertices) {
  auto edge = [](int u, int w) {
    return (static_cast<std::uint64_t>(std::min(u, w)) << 32) | static_cast<std::uint32_t>(std::max(u, w));
  };
  auto face = [](std::array<int, 3> t) {
    std::sort(t.begin(), t.end());
    return std::array<std::int64_t, 2>{(static_cast<std::int64_t>(t[0]) << 32) | static_cast<std::uint32_t>(t[1]), t[2]};
  };
  std::vector<std::uint64_t> edges;
  std::vector<std::array<std::int64_t, 2>> faces;
  edges.reserve(static_cast<std::size_t>(3 * map_F.rows()));
  faces.reserve(static_cast<std::size_t>(map_F.rows()));
  std::vector<char> used(static_cast<std::size_t>(num_vertices), 0);
  for (Eigen::Index f = 0; f < map_F.rows(); ++f) {
    const std::array<int, 3> t{map_F(f, 0), map_F(f, 1), map_F(f, 2)};
    for (int k = 0; k < 3; ++k) {
      const int u = t[static_cast<std::size_t>(k)];
      edges.push_back(edge(u, t[static_cast<std::size_t>((k + 1) % 3)]));
      if (u >= 0 && u < num_vertices) used[static_cast<std::size_t>(u)] = 1;
    }
    faces.push_back(face(t));
  }
  std::sort(edges.begin(), edges.end());
  std::sort(faces.begin(), faces.end());
  std::vector<Eigen::Index> keep;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const std::array<int, 3> t{F(f, 0), F(f, 1), F(f, 2)};
    bool inside = true, split = false;
    for (int k = 0; k < 3; ++k) {
      const int u = t[static_cast<std::size_t>(k)];
      if (u < 0 || u >= num_vertices || !used[static_cast<std::size_t>(u)]) inside = false;
      if (!std::binary_search(edges.begin(), edges.end(), edge(u, t[static_cast<std::size_t>((k + 1) % 3)]))) split = true;
    }
    if (inside && (split || std::binary_search(faces.begin(), faces.end(), face(t)))) keep.push_back(f);
  }
  MatrixXi out(static_cast<Eigen::Index>(keep.size()), 3);
  for (std::size_t i = 0; i < keep.size(); ++i) out.row(static_cast<Eigen::Index>(i)) = F.row(keep[i]);
  return out;
}

int run_elements(const ElementsArgs& a) {
  const auto start = std::chrono::steady_clock::now();
  io::check_file_roles({a.surface, a.map, a.values}, analysis::element_output_paths(a.prefix).all());
  Domain domain = Domain::of(parse_domain_kind(a.domain, "--domain"));
  const io::Surface surface = io::read_surface(a.surface);
  const io::Surface map = io::read_surface(a.map);
  // Where a two-hemisphere rectangle's parts meet, as `rectangle` recorded it (older maps: x = 1).
  if (const auto seam = map.metadata.find(analysis::kSeamKey); domain.kind == DomainKind::Rectangle && seam != map.metadata.end())
    domain.seam_x = analysis::parse_seam(seam->second, a.map);
  const analysis::ElementGrid grid = analysis::element_grid(domain, a.k);
  io::require_vertex_numbering(surface, a.surface, a.values);
  io::require_vertex_numbering(surface, a.surface, a.map);
  io::require_vertex_numbering(map, a.map, a.surface);
  const VectorXd values = io::read_per_vertex(a.values, surface.mesh.num_vertices());
  const auto meta = func_metadata(a.values);

  const auto compute_start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  // Vertices the map appended to the surface's: the flattening's corner and ear splits, or the
  // copies of the vertices along the cut of `rectangle --surface`. Placed on the surface, with their
  // values, from the map's record of them (flatten and rectangle write it; the disk map always has
  // some), else (splits only) traced from the map's triangles.
  const int nv = surface.mesh.num_vertices(), inserted = map.mesh.num_vertices() - nv;
  const auto record = map.metadata.find(kInsertedVerticesKey);
  const bool placed = inserted > 0 && record != map.metadata.end();
  MatrixXd V3 = surface.mesh.V;
  VectorXd vertex_values = values;
  InsertedVertexRecord appended;
  if (placed) {  // positions and values by the same linear rule, the record read once
    MatrixXd columns(nv, 4);
    columns << surface.mesh.V.leftCols(3), values;
    appended = parse_inserted_vertices(record->second, nv, inserted, a.map);
    const MatrixXd all = extend_to_inserted(columns, appended.parents, appended.weight);
    V3 = all.leftCols(3);
    vertex_values = all.col(3);
  }
  analysis::ElementMap em =
      analysis::prepare_element_map(V3,
                                    placed          ? map.mesh.F
                                    : inserted > 0  ? faces_in_map_region(surface.mesh.F, map.mesh.F, nv)  // appended vertices to trace
                                                    : surface.mesh.F,
                                    map.mesh.V, map.mesh.F, vertex_values, domain, a.map);
  if (placed) {  // the per-vertex outputs pair with the surface: its vertices only
    em.num_surface_vertices = nv;
    em.inserted_vertices = inserted;
    em.notes.push_back(inserted_vertices_description(appended) + ": placed from the map's " + kInsertedVerticesKey + " record");
  }
  analysis::ElementResult result = analysis::compute_elements(em, grid, surface.to_scanner);
  const analysis::RectanglePartCells part = analysis::rectangle_part_cells(em.D, em.F, grid);
  if (part.is_part) {
    result.area_cv = analysis::element_area_cv(result.block, part.col_begin, part.col_end);
    em.notes.push_back(analysis::rectangle_part_note(part));
  }
  const double compute_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - compute_start).count();
  const double compute_cpu_seconds = double(std::clock() - cpu_start) / CLOCKS_PER_SEC;  // all threads

  analysis::ElementTable table;
  table.grid = grid;
  // The hemisphere: as given, else the surface's GIFTI structure, else the map's (flatten and
  // rectangle copy it; a rectangle part has its own), else the part of the rectangle the map fills,
  // else (square, sphere, disk) the surface's file name; a whole rectangle of unknown side is "both".
  std::string hemisphere = a.hemisphere;
  if (hemisphere.empty()) hemisphere = analysis::hemisphere_of(surface.metadata, "");
  if (hemisphere == "unknown") hemisphere = analysis::hemisphere_of(map.metadata, "");
  if (hemisphere == "unknown" && domain.kind == DomainKind::Rectangle) hemisphere = !part.is_part ? "both" : part.right ? "right" : "left";
  if (hemisphere == "unknown") hemisphere = analysis::hemisphere_of({}, a.surface);
  // The table's block and every per-vertex output (the label file's GIFTI structure) say the same.
  result.block.hemisphere = hemisphere;
  table.blocks.push_back({hemisphere, result.block.elements});
  auto from_meta = [&](const std::string& key, const std::string& fallback) {
    const auto it = meta.find(key);
    return it != meta.end() ? it->second : fallback;
  };
  table.normalisation = !a.normalisation.empty() ? a.normalisation : from_meta("normalisation", "none");
  table.units = !a.units.empty() ? a.units : from_meta("units", "");
  table.subject_id = a.subject;
  table.age = a.age;
  table.metadata = {{"software", software_version()},
                    {"surface", a.surface},
                    {"map", a.map},
                    {"values", a.values},
                    {"element_area_cv", std::to_string(result.area_cv)},
                    {"total_area_mm2", std::to_string(result.total_area_mm2)},
                    {"integration", "area-weighted mean over triangles clipped to the cells (exact for linear values)"}};
  // The map's correspondence mode (flatten records it; issue 14), so references never mix modes.
  if (const auto c = map.metadata.find("authalic_correspondence"); c != map.metadata.end())
    table.metadata["correspondence"] = c->second;
  if (meta.count("sampling")) table.metadata["sampling"] = meta.at("sampling");
  if (meta.count("normalisation_detail")) table.metadata["normalisation_detail"] = meta.at("normalisation_detail");
  if (meta.count("normalisation_mask_sha256")) table.metadata[analysis::kReferenceMaskKey] = meta.at("normalisation_mask_sha256");

  const MatrixXd V_scanner = [&] {
    MatrixXd out(surface.mesh.V.rows(), 3);
    for (Eigen::Index i = 0; i < out.rows(); ++i)
      out.row(i) = (surface.to_scanner * surface.mesh.V.row(i).head<3>().transpose().homogeneous()).head<3>().transpose();
    return out;
  }();
  const auto paths = analysis::write_element_outputs(a.prefix, table, result, V_scanner, surface.mesh.F, hemisphere != "right");

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const auto& n : em.notes) info("authalic elements: note: " + n);
  info("authalic elements: " + std::to_string(grid.cols) + " x " + std::to_string(grid.rows) + " " + a.domain +
       " elements, element-area CV " + std::to_string(result.area_cv) + ", cortex " + std::to_string(result.total_area_mm2) +
       " mm^2; wrote " + paths.table + ", " + paths.nifti + ", " + paths.png + ", " + paths.label);
  if (global_options().json) {
    nlohmann::json j;
    j["domain"] = a.domain;
    j["k"] = grid.k;
    j["rows"] = grid.rows;
    j["cols"] = grid.cols;
    j["hemisphere"] = hemisphere;
    j["element_area_cv"] = result.area_cv;
    j["total_area_mm2"] = result.total_area_mm2;
    j["inserted_vertices"] = em.inserted_vertices;
    j["normalisation"] = table.normalisation;
    j["units"] = table.units;
    j["outputs"] = {{"table", paths.table},   {"sidecar", paths.sidecar}, {"nifti", paths.nifti}, {"area_nifti", paths.area_nifti},
                    {"png", paths.png},   {"png_3d", paths.png_3d},   {"label", paths.label}};
    j["notes"] = em.notes;
    j["elements_seconds"] = compute_seconds;
    j["elements_cpu_seconds"] = compute_cpu_seconds;
    j["seconds"] = seconds;
    std::cout << j.dump(2) << '\n';
  }
  return 0;
}

const bool registered = register_command({45, [](CLI::App& parent) {
  auto a = std::make_shared<ElementsArgs>();
  CLI::App* sub = parent.add_subcommand(
      "elements",
      "Equal-area cortical elements: the cells of a regular grid on an authalic map (K x K on the square, 2K x K on the "
      "2:1 rectangle, 2K x K equal-area cells on the sphere), each with the area-weighted mean value of the cortex that "
      "maps into it (triangles clipped to the cells), its cortical area (mm^2) and centroid (scanner RAS mm). Writes "
      "OUT_PREFIX.tsv (+ .json sidecar), OUT_PREFIX.nii.gz (element values; _area.nii.gz: areas in mm^2), "
      "OUT_PREFIX.png (colour bar, units), OUT_PREFIX_3d.png (lateral/medial with the grid) and OUT_PREFIX.label.gii "
      "(per-vertex element: key = id + 1).");
  sub->add_option("SURFACE", a->surface, "Cortical surface the map was made from (mm)")->required();
  sub->add_option("MAP", a->map, "Its authalic map (.surf.gii): x,y in the domain (or scaled), or a sphere")->required();
  sub->add_option("VALUES", a->values, "Per-vertex values, e.g. from `authalic sample` (.func.gii)")->required();
  sub->add_option("OUT_PREFIX", a->prefix, "Output prefix")->required();
  add_k_option(*sub, a->k, {DomainKind::Square, DomainKind::Rectangle, DomainKind::Sphere, DomainKind::Disk});
  sub->add_option("--domain", a->domain,
                  "square, rectangle, sphere or disk (the unit disk; elements: the square's cells carried by the "
                  "concentric map)")
      ->check(CLI::IsMember({"square", "rectangle", "sphere", "disk"}))
      ->capture_default_str();
  sub->add_option("--hemisphere", a->hemisphere, "left, right or both (default: from the surface's metadata or name)")
      ->check(CLI::IsMember({"left", "right", "both"}));
  sub->add_option("--id,--subject", a->subject, "Subject id recorded in the table (used by `authalic normative`), as `run --id`");
  sub->add_option("--age", a->age, "Subject's age in years, recorded for the normative age model")->check(age_years());
  sub->add_option("--normalisation,--normalize", a->normalisation,
                  "Intensity normalisation of VALUES (default: from its metadata as written by `authalic sample`)");
  sub->add_option("--units", a->units, "Units of VALUES (default: from its metadata)");
  add_common_options(*sub);
  sub->callback([a]() { set_exit_code(run_elements(*a)); });
}});

}  // namespace
}  // namespace authalic::app

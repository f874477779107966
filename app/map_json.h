#pragma once
// JSON form of map distortion metrics (core/metrics.h), shared by the map subcommands
// (sphere, rectangle) so their metrics files use the same keys.
#include <nlohmann/json.hpp>

#include <limits>
#include <map>
#include <string>

#include "core/authalic_flow.h"
#include "core/metrics.h"

namespace authalic::app {

// {"flips", "faces", "vertices", "face_ln_area_abs": {mean, median, p95, p99, max}, "vertex_ln_area_abs",
//  "lambda", "upsilon_mean", "element_grid": [cols, rows], "element_cv", "element_min_over_mean",
//  "element_max_over_mean", "element_mean_mm2", "surface_area_mm2", "domain_area", "outside_fraction"}
nlohmann::json metrics_json(const MapMetrics& m);

// The acceptance record of a map (core/metrics.h): passed, the problem ("" if passed), what it
// measured ("measured": flips, the element CV on its grid, e.g. "element_cv_32x32", even when the
// metrics use another --k, and the per-vertex mean |ln area ratio| it checked: vertex_mean, NaN =
// accepted's own) and the limits applied to `accepted`: the element CV's on its grid, the
// coarse-mesh limit where that is larger (with the rule that gives it and where it is larger), or
// null when the element CV is not checked (a measure-controlled map).
nlohmann::json acceptance_json(const std::string& problem, const MapMetrics& accepted, bool element_cv_checked,
                               double vertex_mean = std::numeric_limits<double>::quiet_NaN());

// The flow's report and the options it ran with (flatten's and rectangle's "flow" object).
nlohmann::json flow_json(const FlowReport& r, const FlowOptions& o);

// Writes JSON (2-space indent, trailing newline) atomically.
void write_json_file(const std::string& path, const nlohmann::json& j);

// Left hemisphere? From GIFTI AnatomicalStructurePrimary ("CortexLeft"/"CortexRight") when
// present, else from the side of the midline (x < 0 in RAS) the surface's centroid lies on.
bool is_left_hemisphere(const std::map<std::string, std::string>& metadata, const MatrixXd& V);

// The vertices a map inserted (corner and ear splits, core/conformal_map.h), as the text of the
// map file's metadata key "authalic_inserted_vertices": "p0 p1 w;..." in order, vertex
// nv + k at (1 - w) p0 + w p1 on the surface. `metrics` reads it to place them in 3D, so that it
// measures every face of the map, as flatten does.
inline constexpr const char* kInsertedVerticesKey = "authalic_inserted_vertices";
std::string inserted_vertices_text(const MatrixXi& parents, const VectorXd& weight);
// The record's rows, checked (see place_inserted_vertices): vertex num_input + k lies at
// (1 - weight(k)) parents(k, 0) + weight(k) parents(k, 1). A row with both parents the same is a
// copy of that vertex (the cut of `rectangle --surface` records its copies so), the others split
// an edge (flatten's corner and ear splits).
struct InsertedVertexRecord {
  MatrixXi parents;
  VectorXd weight;
  int copies() const;  // rows with both parents the same
};
InsertedVertexRecord parse_inserted_vertices(const std::string& text, int num_input, int count, const std::string& path);
// What the record's vertices are, for a note: "237 copies of the vertices along the cut that opened
// the surface", "12 vertices the flattening inserted (corner and ear splits)", or both.
std::string inserted_vertices_description(const InsertedVertexRecord& record);
// The surface positions V (num_input rows; any columns, e.g. positions and values side by side)
// extended by the inserted vertices described by `text`; `count` of them are expected. Throws InputError naming `path` for text that does not
// describe them (wrong count, a parent not yet defined, a weight outside [0, 1]).
MatrixXd place_inserted_vertices(const MatrixXd& V, const std::string& text, int count, const std::string& path);

}  // namespace authalic::app

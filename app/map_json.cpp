// JSON helpers for the map subcommands (see map_json.h).
#include "app/map_json.h"

#include <cmath>
#include <cstdio>
#include <iomanip>
#include <map>
#include <sstream>

#include "core/error.h"
#include "core/square_map.h"
#include "io/atomic_file.h"

namespace authalic::app {

namespace {
nlohmann::json stats_json(const AbsStats& s) {
  return {{"mean", s.mean}, {"median", s.median}, {"p95", s.p95}, {"p99", s.p99}, {"max", s.max}, {"count", s.count}};
}
}  // namespace

nlohmann::json acceptance_json(const std::string& problem, const MapMetrics& accepted, bool element_cv_checked, double vertex_mean) {
  const AuthalicAcceptance limits;
  const int elements = accepted.element_cols * accepted.element_rows;
  const std::string grid = std::to_string(accepted.element_cols) + "x" + std::to_string(accepted.element_rows);
  nlohmann::json cv = nullptr, deviation = nullptr;
  if (element_cv_checked) cv = element_cv_limit(accepted, limits), deviation = element_deviation_limit(accepted, limits);
  // The second term exceeds the first below (3 sd / max_cv)^2 faces per element: 900, i.e. below
  // 921,600 faces on 32x32 and 1,843,200 on 64x32, which covers cortical meshes at native resolution.
  const double ratio = 3 * limits.coarse_face_sd / limits.max_element_cv;
  const long long looser_below = std::llround(ratio * ratio);
  std::ostringstream rule, deviation_rule;  // default precision: "max(0.01, 3 x 0.1 / ...)"
  rule << "max(" << limits.max_element_cv << ", 3 x " << limits.coarse_face_sd << " / sqrt(faces per element)): above "
       << limits.max_element_cv << " whenever an element holds fewer than " << looser_below << " faces, i.e. on meshes of fewer than "
       << looser_below * elements << " faces on this " << grid << " grid (this map: " << accepted.faces << " faces, "
       << std::setprecision(4) << (elements > 0 ? double(accepted.faces) / elements : 0.0) << " per element)";
  deviation_rule << "every element's area / mean area within 1 +- max(" << limits.max_element_deviation << ", 8 x "
                 << limits.coarse_face_sd << " / sqrt(faces per element))";
  return {{"passed", problem.empty()},
          {"problem", problem},
          // What the acceptance measured (on its grid, whatever --k the metrics use).
          {"measured",
           {{"flips", accepted.flips},
            {"element_cv_" + grid, accepted.element_cv},
            {"element_area_over_mean_min_" + grid, accepted.element_min},
            {"element_area_over_mean_max_" + grid, accepted.element_max},
            {"vertex_ln_area_abs_mean", std::isnan(vertex_mean) ? accepted.vertex_ln_area.mean : vertex_mean}}},
          {"limits",
           {{"flips", 0},
            {"element_cv_" + grid, cv},
            {"element_cv_rule", rule.str()},
            {"element_area_over_mean_deviation_" + grid, deviation},
            {"element_area_over_mean_deviation_rule", deviation_rule.str()},
            {"vertex_ln_area_abs_mean", limits.max_vertex_ln_area}}}};
}

nlohmann::json metrics_json(const MapMetrics& m) {
  return {{"domain", to_string(m.domain)},
          {"faces", m.faces},
          {"vertices", m.vertices},
          {"flips", m.flips},
          {"face_ln_area_abs", stats_json(m.face_ln_area)},
          {"face_ln_area_sd", m.face_ln_area_sd},
          {"vertex_ln_area_abs", stats_json(m.vertex_ln_area)},
          {"upsilon_mean", m.upsilon_mean},
          {"lambda", stats_json(m.lambda)},
          {"element_grid", {m.element_cols, m.element_rows}},
          {"element_cv", m.element_cv},
          {"element_min_over_mean", m.element_min},
          {"element_max_over_mean", m.element_max},
          {"element_mean_mm2", m.element_mean_mm2},
          {"surface_area_mm2", m.surface_area},
          {"domain_area", m.domain_area},
          {"outside_fraction", m.outside_fraction}};
}

void write_json_file(const std::string& path, const nlohmann::json& j) { io::write_file_atomically(path, j.dump(2) + "\n"); }

bool is_left_hemisphere(const std::map<std::string, std::string>& metadata, const MatrixXd& V) {
  const auto it = metadata.find("AnatomicalStructurePrimary");
  if (it != metadata.end()) {
    if (it->second.find("Left") != std::string::npos) return true;
    if (it->second.find("Right") != std::string::npos) return false;
  }
  return V.rows() == 0 || V.col(0).mean() <= 0.0;
}

std::string inserted_vertices_text(const MatrixXi& parents, const VectorXd& weight) {
  std::string text;
  char buf[64];
  for (Eigen::Index k = 0; k < parents.rows(); ++k) {
    std::snprintf(buf, sizeof(buf), "%s%d %d %.17g", k ? ";" : "", parents(k, 0), parents(k, 1), weight(k));
    text += buf;
  }
  return text;
}

int InsertedVertexRecord::copies() const {
  int n = 0;
  for (Eigen::Index k = 0; k < parents.rows(); ++k) n += parents(k, 0) == parents(k, 1);
  return n;
}

std::string inserted_vertices_description(const InsertedVertexRecord& record) {
  const int copies = record.copies(), splits = static_cast<int>(record.parents.rows()) - copies;
  std::string s;
  if (copies > 0) s = std::to_string(copies) + (copies == 1 ? " copy" : " copies") + " of the vertices along the cut that opened the surface";
  if (splits > 0)
    s += (s.empty() ? "" : " and ") + std::to_string(splits) + (splits == 1 ? " vertex" : " vertices") +
         " the flattening inserted (corner and ear splits)";
  return s;
}

MatrixXd place_inserted_vertices(const MatrixXd& V, const std::string& text, int count, const std::string& path) {
  const InsertedVertexRecord record = parse_inserted_vertices(text, static_cast<int>(V.rows()), count, path);
  return extend_to_inserted(V, record.parents, record.weight);  // the flattening's own rule
}

InsertedVertexRecord parse_inserted_vertices(const std::string& text, int num_input, int count, const std::string& path) {
  MatrixXi parents(count, 2);
  VectorXd weight(count);
  std::istringstream in(text);
  std::string item;
  int k = 0;
  while (std::getline(in, item, ';')) {
    std::istringstream fields(item);
    long long p0 = -1, p1 = -1;
    double w = NAN;
    std::string rest;
    const Eigen::Index self = num_input + k;
    if (!(fields >> p0 >> p1 >> w) || (fields >> rest) || k >= count || p0 < 0 || p1 < 0 || p0 >= self || p1 >= self ||
        !(w >= 0 && w <= 1))
      throw InputError(path + ": metadata " + kInsertedVerticesKey + " entry " + std::to_string(k + 1) + " ('" + item +
                       "') is not 'parent parent weight' for inserted vertex " + std::to_string(self) +
                       "; the file was changed after authalic wrote it");
    parents.row(k) << static_cast<int>(p0), static_cast<int>(p1);
    weight[k] = w;
    ++k;
  }
  if (k != count)
    throw InputError(path + ": metadata " + kInsertedVerticesKey + " describes " + std::to_string(k) + " inserted vertices but the map has " +
                     std::to_string(count) + "; the file was changed after authalic wrote it");
  return {parents, weight};
}

nlohmann::json flow_json(const FlowReport& r, const FlowOptions& o) {
  return {{"method", to_string(r.method)},
          {"iterations", r.iterations},
          {"rejected_passes", r.rejected_passes},
          {"polish_iterations", r.polish_iterations},
          {"converged", r.converged},
          {"stop_reason", r.stop_reason},
          {"stall_detail", r.stall_detail},
          {"tolerance", {{"vertex_ln_area_abs_mean", o.tolerance_mean}, {"vertex_ln_area_abs_p99", o.tolerance_p99}}},
          {"grid_resolution", r.grid_resolution},
          {"rk4_steps", o.grid.rk4_steps},
          {"fixed_steps", o.mesh.fixed_steps},
          {"edge_flips", r.edge_flips},
          {"repaired_vertices", r.repaired},
          {"flips", r.flips},
          {"vertex_ln_area_abs_mean_history", r.history_mean},
          {"initial_vertex_ln_area_abs", {{"mean", r.initial_vertex_mean}, {"p99", r.initial_vertex_p99}}},
          {"flow_vertex_ln_area_abs_mean", r.flow_vertex_mean},
          {"final_vertex_ln_area_abs", {{"mean", r.final_vertex_mean}, {"p99", r.final_vertex_p99}, {"max", r.final_vertex_max}}}};
}

}  // namespace authalic::app

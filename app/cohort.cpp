#include "app/cohort.h"

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "app/command.h"
#include "core/error.h"

namespace fs = std::filesystem;

namespace authalic::app {

namespace {
std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      out.push_back(cell);
      cell.clear();
    } else if (c != '\r') {
      cell += c;
    }
  }
  out.push_back(cell);
  return out;
}
}  // namespace

std::vector<CohortSubject> read_cohort(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the cohort list; check the path");
  const fs::path base = fs::absolute(fs::path(path)).parent_path();
  std::string line;
  if (!std::getline(in, line)) throw InputError(path + ": empty cohort list; expected a header line");
  const auto header = split_csv_line(line);
  std::map<std::string, std::size_t> col;
  for (std::size_t i = 0; i < header.size(); ++i) col[header[i]] = i;
  static const char* required[] = {"subject_id", "role", "pet", "lh_white", "lh_pial",
                                   "rh_white",   "rh_pial", "lh_cortex", "rh_cortex"};
  for (const char* r : required)
    if (!col.count(r)) throw InputError(path + ": the header has no column '" + r + "'; see `authalic group --help`");
  std::vector<CohortSubject> subjects;
  std::set<std::string> seen;
  int lineno = 1;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const auto cells = split_csv_line(line);
    auto get = [&](const std::string& name) -> std::string {
      const std::size_t i = col.at(name);
      return i < cells.size() ? cells[i] : std::string();
    };
    const std::string where = path + ":" + std::to_string(lineno);
    CohortSubject s;
    s.id = get("subject_id");
    if (s.id.empty()) throw InputError(where + ": empty subject_id");
    // The id becomes folder and log names (sub-<id>, logs/<id>.log): letters and digits only
    // (BIDS labels), checked before any file is made, so '../x' cannot escape the output folder.
    for (char c : s.id)
      if (!std::isalnum(static_cast<unsigned char>(c)))
        throw InputError(where + ": subject_id '" + s.id + "' has characters other than letters and digits (BIDS labels); rename it, e.g. 'patient01'");
    if (!seen.insert(s.id).second) throw InputError(where + ": subject '" + s.id + "' is listed twice");
    s.role = get("role");
    if (s.role != "control" && s.role != "patient")
      throw InputError(where + ": role '" + s.role + "' is neither 'control' nor 'patient'");
    if (col.count("age") && !get("age").empty()) {
      s.age = parse_age(get("age"), where);
    }
    auto file = [&](const std::string& name) {
      const std::string v = get(name);
      if (v.empty()) throw InputError(where + ": empty " + name);
      const fs::path p = fs::path(v).is_absolute() ? fs::path(v) : base / v;
      if (!fs::exists(p)) throw InputError(where + ": " + name + " file " + p.string() + " does not exist");
      return p.lexically_normal().string();
    };
    s.pet = file("pet");
    s.lh_white = file("lh_white");
    s.lh_pial = file("lh_pial");
    s.rh_white = file("rh_white");
    s.rh_pial = file("rh_pial");
    s.lh_cortex = file("lh_cortex");
    s.rh_cortex = file("rh_cortex");
    subjects.push_back(std::move(s));
  }
  if (subjects.empty()) throw InputError(path + ": no subjects listed");
  return subjects;
}

}  // namespace authalic::app

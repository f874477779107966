#include "app/cohort.h"

#include <csv.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <map>
#include <set>
#include <sstream>

#include "analysis/pipeline.h"
#include "app/command.h"
#include "core/error.h"

namespace fs = std::filesystem;

namespace authalic::app {

namespace {

// The cohort file's records, parsed by libcsv (RFC 4180: quoted fields with commas, doubled
// quotes and line breaks; CRLF or LF), after an optional UTF-8 byte-order mark (Excel writes one).
// Each record keeps the line it starts on, for messages.
struct CsvRecord {
  int line = 0;
  std::vector<std::string> cells;
};

std::vector<CsvRecord> read_csv_records(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the cohort list; check the path");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.erase(0, 3);
  struct State {
    std::vector<CsvRecord> records;
    CsvRecord current;
    int line = 1;
  } st;
  csv_parser parser;
  if (csv_init(&parser, CSV_STRICT | CSV_STRICT_FINI | CSV_APPEND_NULL) != 0) throw std::runtime_error("libcsv could not be initialised");
  auto on_field = [](void* data, std::size_t n, void* out) {
    auto* s = static_cast<State*>(out);
    if (s->current.cells.empty()) s->current.line = s->line;
    s->current.cells.emplace_back(static_cast<const char*>(data), n);
  };
  auto on_record = [](int, void* out) {
    auto* s = static_cast<State*>(out);
    s->records.push_back(std::move(s->current));
    s->current = CsvRecord{};
  };
  // Fed line by line so that each record knows its line number.
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    end = end == std::string::npos ? text.size() : end + 1;
    if (csv_parse(&parser, text.data() + start, end - start, on_field, on_record, &st) != end - start) {
      const std::string why = csv_strerror(csv_error(&parser));
      csv_free(&parser);
      throw InputError(path + ":" + std::to_string(st.line) + ": not valid CSV (" + why + "); check the quotes on this line");
    }
    ++st.line;
    start = end;
  }
  const bool closed = csv_fini(&parser, on_field, on_record, &st) == 0;
  csv_free(&parser);
  if (!closed) throw InputError(path + ": not valid CSV (a quoted field is never closed); check the quotes");
  return st.records;
}

}  // namespace

std::vector<CohortSubject> read_cohort(const std::string& path) {
  const std::vector<CsvRecord> records = read_csv_records(path);
  const fs::path base = fs::absolute(fs::path(path)).parent_path();
  if (records.empty()) throw InputError(path + ": empty cohort list; expected a header line");
  const auto& header = records[0].cells;
  std::map<std::string, std::size_t> col;
  for (std::size_t i = 0; i < header.size(); ++i) col[header[i]] = i;
  static const char* required[] = {"subject_id", "role", "pet", "lh_white", "lh_pial",
                                   "rh_white",   "rh_pial", "lh_cortex", "rh_cortex"};
  for (const char* r : required)
    if (!col.count(r)) throw InputError(path + ": the header has no column '" + r + "'; see `authalic group --help`");
  // Other columns are kept as the user's own, but one that is a known column spelt otherwise
  // ("Sex", "T1") would silently leave its values unused.
  std::vector<std::string> known(std::begin(required), std::end(required));
  known.insert(known.end(), {"age", "sex", "t1", "lh_sphere_reg", "rh_sphere_reg"});
  auto lower = [](std::string x) {
    for (char& c : x) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return x;
  };
  for (const std::string& h : header)
    for (const std::string& k : known)
      if (h != k && lower(h) == k)
        throw InputError(path + ": column '" + h + "' would be ignored: the column is '" + k + "' (names are lower case)");

  std::vector<CohortSubject> subjects;
  std::set<std::string> seen;
  for (std::size_t r = 1; r < records.size(); ++r) {
    const auto& cells = records[r].cells;
    bool blank = true;
    for (const auto& c : cells) blank = blank && c.find_first_not_of(" \t") == std::string::npos;
    if (blank) continue;
    auto get = [&](const std::string& name) -> std::string {
      const std::size_t i = col.at(name);
      return i < cells.size() ? cells[i] : std::string();
    };
    const int lineno = records[r].line;
    const std::string where = path + ":" + std::to_string(lineno);
    if (cells.size() != header.size())
      throw InputError(where + ": " + std::to_string(cells.size()) + " fields, but the header has " + std::to_string(header.size()) +
                       " columns; check the row for a missing or extra comma (a field with a comma needs quotes)");
    CohortSubject s;
    s.line = lineno;
    s.id = analysis::bids_subject_label(get("subject_id"));  // "sub-01" as participants.tsv writes it
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
    if (col.count("t1") && !get("t1").empty()) s.t1 = file("t1");
    if (col.count("sex") && !get("sex").empty()) s.sex = parse_sex(get("sex"), where);
    if (col.count("lh_sphere_reg") && !get("lh_sphere_reg").empty()) s.lh_sphere_reg = file("lh_sphere_reg");
    if (col.count("rh_sphere_reg") && !get("rh_sphere_reg").empty()) s.rh_sphere_reg = file("rh_sphere_reg");
    subjects.push_back(std::move(s));
  }
  if (subjects.empty()) throw InputError(path + ": no subjects listed");
  return subjects;
}

}  // namespace authalic::app

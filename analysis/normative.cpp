// Normative element statistics and patient comparison (see analysis/normative.h).
#include "analysis/normative.h"

#include <algorithm>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "analysis/render.h"
#include "analysis/table_text.h"
#include "core/error.h"
#include "core/version.h"
#include "io/atomic_file.h"
#include "io/base64.h"
#include "io/image_io.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

namespace authalic::analysis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? "," : "") + v[i];
  return s;
}


// The properties two things must share to be pooled or compared.
struct Shape {
  ElementGrid grid;
  std::vector<std::string> hemispheres;
  std::string normalisation, units;
  std::string correspondence;  // "per-subject" or "atlas <identity>" (analysis/atlas.h)
  std::string reference_mask;  // SHA-256 of the reference-region mask, "" = not recorded
};

std::string table_reference_mask(const ElementTable& t) {
  const auto it = t.metadata.find(kReferenceMaskKey);
  return it == t.metadata.end() ? std::string() : it->second;
}

Shape shape_of(const NormativeReference& r) {
  return {r.grid, r.hemispheres, r.normalisation, r.units, r.correspondence, r.reference_mask};
}
Shape shape_of(const ElementTable& t) {
  Shape s{t.grid, {}, t.normalisation, t.units, table_correspondence(t), table_reference_mask(t)};
  for (const auto& b : t.blocks) s.hemispheres.push_back(b.hemisphere);
  return s;
}

void check_shapes(const Shape& ref, const Shape& other, const std::string& what, const std::string& ref_name) {
  auto refuse = [&](const std::string& property, const std::string& a, const std::string& b) {
    throw InputError(what + ": " + property + " is " + b + " but " + ref_name + " has " + a +
                     "; element tables and references can only be pooled or compared with the same domain, K, "
                     "hemispheres, intensity normalisation and units");
  };
  if (ref.grid.domain.kind != other.grid.domain.kind) refuse("the domain", to_string(ref.grid.domain), to_string(other.grid.domain));
  if (ref.grid.k != other.grid.k) refuse("K", std::to_string(ref.grid.k), std::to_string(other.grid.k));
  if (ref.hemispheres != other.hemispheres) refuse("the hemisphere list", join(ref.hemispheres), join(other.hemispheres));
  if (ref.normalisation != other.normalisation) refuse("the intensity normalisation", ref.normalisation, other.normalisation);
  if (ref.units != other.units) refuse("the units", "'" + ref.units + "'", "'" + other.units + "'");
  // SUVRs of another reference region are other numbers (files that do not record it pass).
  if (ref.normalisation == "reference-region" && !ref.reference_mask.empty() && !other.reference_mask.empty() &&
      ref.reference_mask != other.reference_mask)
    throw InputError(what + ": normalised with another reference-region mask (SHA-256 " + other.reference_mask.substr(0, 12) +
                     "...) than " + ref_name + " (" + ref.reference_mask.substr(0, 12) +
                     "...); SUVRs of different regions cannot be compared: normalise with the reference's mask");
  // Element (i, j) means other anatomy in another correspondence mode or atlas (issue 14).
  if (ref.correspondence != other.correspondence)
    throw InputError(what + ": the element correspondence is '" + other.correspondence + "' but " + ref_name + " has '" +
                     ref.correspondence + "'; element (i, j) covers different anatomy in another mode or atlas: map the "
                     "subject in the reference's mode (run/flatten with or without --atlas and sphere.reg) or use a "
                     "reference built in this one");
}

void check_new_subject(const NormativeReference& r, const std::string& id, const std::string& what) {
  if (id.empty()) return;
  for (const auto& s : r.subjects)
    if (s.id == id)
      throw InputError(what + ": subject '" + id + "' is already in the reference (from " + s.table +
                       "); every control may be counted once");
}

nlohmann::json number_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

std::vector<double> read_array(const nlohmann::json& j, const char* key, std::size_t size, const std::string& path) {
  if (!j.contains(key) || !j[key].is_array())
    throw InputError(path + ": elements." + key + " is missing; the reference file is incomplete or corrupt");
  const auto& a = j[key];
  if (a.size() != size)
    throw InputError(path + ": elements." + key + " has " + std::to_string(a.size()) + " values, expected " + std::to_string(size));
  std::vector<double> out(size);
  for (std::size_t i = 0; i < size; ++i) {
    if (!a[i].is_number()) throw InputError(path + ": elements." + std::string(key) + "[" + std::to_string(i) + "] is not a number");
    out[i] = a[i].get<double>();
  }
  return out;
}

// One subject's values as base64 of little-endian IEEE 754 float64 (NaN: no value). Exact, and a
// 1,000-control reference at K = 64 read in 0.05 s instead of 0.33 s as JSON numbers.
std::string encode_values(const std::vector<double>& values) {
  std::vector<std::uint8_t> bytes;
  bytes.reserve(values.size() * 8);
  for (double v : values) {
    std::uint64_t u;
    std::memcpy(&u, &v, 8);
    for (int k = 0; k < 8; ++k) bytes.push_back(static_cast<std::uint8_t>(u >> (8 * k)));
  }
  return io::base64_encode(bytes);
}

// "subject_values": one base64 string of num_values() float64 per kept subject, whose finite
// values count, element by element, to n when every subject's are kept; anything else is a
// corrupt file.
std::vector<std::vector<double>> read_subject_values(const nlohmann::json& j, const NormativeReference& r, const std::string& path) {
  const std::size_t size = static_cast<std::size_t>(r.num_values());
  const std::size_t rows = std::min(r.subjects.size(), kMaxChanceControls);
  if (!j.is_array() || j.size() != rows)
    throw InputError(path + ": subject_values must hold one array for each of the first " + std::to_string(rows) +
                     " subjects; the reference file is corrupt");
  std::vector<std::vector<double>> out;
  std::vector<double> count(size, 0.0);
  for (const auto& row : j) {
    std::vector<std::uint8_t> bytes;
    try {
      if (row.is_string()) bytes = io::base64_decode(row.get<std::string>());
    } catch (const std::invalid_argument&) {
      bytes.clear();
    }
    if (bytes.size() != size * 8)
      throw InputError(path + ": subject_values[" + std::to_string(out.size()) + "] is not base64 of " + std::to_string(size) +
                       " float64 values; the reference file is corrupt");
    std::vector<double> v(size);
    for (std::size_t i = 0; i < size; ++i) {
      std::uint64_t u = 0;
      for (int k = 0; k < 8; ++k) u |= static_cast<std::uint64_t>(bytes[8 * i + static_cast<std::size_t>(k)]) << (8 * k);
      std::memcpy(&v[i], &u, 8);
      if (std::isfinite(v[i])) ++count[i];
    }
    out.push_back(std::move(v));
  }
  for (std::size_t i = 0; i < size && rows == r.subjects.size(); ++i)
    if (count[i] != r.n[i])
      throw InputError(path + ": element " + std::to_string(i) + " has " + std::to_string(static_cast<long long>(r.n[i])) +
                       " controls but " + std::to_string(static_cast<long long>(count[i])) +
                       " values in subject_values; the reference file is corrupt");
  return out;
}

}  // namespace

std::string format_value(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

double NormativeReference::sd(int i) const {
  const double nn = n[static_cast<std::size_t>(i)];
  return nn >= 2 ? std::sqrt(std::max(0.0, m2[static_cast<std::size_t>(i)]) / (nn - 1)) : kNaN;
}

NormativeReference empty_reference_like(const ElementTable& table) {
  NormativeReference r;
  r.grid = table.grid;
  for (const auto& b : table.blocks) r.hemispheres.push_back(b.hemisphere);
  r.normalisation = table.normalisation;
  r.units = table.units;
  r.correspondence = table_correspondence(table);
  r.reference_mask = table_reference_mask(table);
  r.software = software_version();
  const std::size_t size = static_cast<std::size_t>(r.num_values());
  r.n.assign(size, 0.0);
  r.mean.assign(size, 0.0);
  r.m2.assign(size, 0.0);
  r.age_model = true;  // until a subject without an age arrives
  r.age_mean.assign(size, 0.0);
  r.age_m2.assign(size, 0.0);
  r.comoment.assign(size, 0.0);
  return r;
}

void check_compatible(const NormativeReference& reference, const ElementTable& table, const std::string& what) {
  check_shapes(shape_of(reference), shape_of(table), what, "the reference");
}

void add_subject(NormativeReference& r, const ElementTable& table, const std::string& source) {
  check_compatible(r, table, source);
  check_new_subject(r, table.subject_id, source);
  const bool with_age = r.age_model && std::isfinite(table.age);
  if (r.age_model && !with_age) {
    r.age_model = false;
    r.age_mean.clear();
    r.age_m2.clear();
    r.comoment.clear();
  }
  const int ne = r.grid.num_elements();
  // The values are kept while the first subjects' all are (not after a reference without them).
  const bool keep_values = r.keeps_values() && r.subject_values.size() < kMaxChanceControls;
  std::vector<double> values(static_cast<std::size_t>(r.num_values()), kNaN);
  for (std::size_t b = 0; b < table.blocks.size(); ++b)
    for (int e = 0; e < ne; ++e) {
      const double y = table.blocks[b].elements[static_cast<std::size_t>(e)].value;
      if (!std::isfinite(y)) continue;
      // Squares of larger values overflow M2 to infinity, which no reference file can hold.
      if (std::abs(y) > kMaxReferenceValue)
        throw InputError(source + ": element " + std::to_string(e) + " (" + table.blocks[b].hemisphere + ") has value " +
                         format_value(y) + ", beyond +-1e15: not a plausible PET value; check how the table was made");
      const std::size_t i = b * static_cast<std::size_t>(ne) + static_cast<std::size_t>(e);
      // Welford: the running mean and M2; with an age, the running co-moment (uses the old age
      // deviation and the new value deviation, which makes the update exact).
      const double n1 = r.n[i] + 1;
      const double dy = y - r.mean[i];
      r.mean[i] += dy / n1;
      r.m2[i] += dy * (y - r.mean[i]);
      if (with_age) {
        const double da = table.age - r.age_mean[i];
        r.age_mean[i] += da / n1;
        r.age_m2[i] += da * (table.age - r.age_mean[i]);
        r.comoment[i] += da * (y - r.mean[i]);
      }
      r.n[i] = n1;
      values[i] = y;
    }
  r.subjects.push_back({table.subject_id, table.age, source});
  if (keep_values) r.subject_values.push_back(std::move(values));
}

namespace {
// `stats` without subject s, whose values are y: add_subject's Welford step undone. Its kept values
// are dropped (a leave-one-out reference needs none), so a caller making many passes a copy of its
// reference without them.
NormativeReference without_subject(const NormativeReference& stats, const std::vector<double>& y, std::size_t s) {
  NormativeReference r = stats;
  r.subject_values.clear();
  const double a = stats.subjects[s].age;
  for (std::size_t i = 0; i < y.size(); ++i) {
    if (!std::isfinite(y[i])) continue;
    // mean' = mean - (y - mean) / (n - 1), M2' = M2 - (y - mean') (y - mean), and with the age
    // C' = C - (a - mean_a') (y - mean), age M2' likewise.
    const double n1 = r.n[i] - 1;
    if (n1 <= 0) {
      r.n[i] = r.mean[i] = r.m2[i] = 0;
      if (r.age_model) r.age_mean[i] = r.age_m2[i] = r.comoment[i] = 0;
      continue;
    }
    const double mean_y = r.mean[i], mean_y0 = mean_y - (y[i] - mean_y) / n1;
    r.m2[i] = std::max(0.0, r.m2[i] - (y[i] - mean_y0) * (y[i] - mean_y));
    r.mean[i] = mean_y0;
    if (r.age_model) {
      const double mean_a = r.age_mean[i], mean_a0 = mean_a - (a - mean_a) / n1;
      r.age_m2[i] = std::max(0.0, r.age_m2[i] - (a - mean_a0) * (a - mean_a));
      r.comoment[i] -= (a - mean_a0) * (y[i] - mean_y);
      r.age_mean[i] = mean_a0;
    }
    r.n[i] = n1;
  }
  r.subjects.erase(r.subjects.begin() + static_cast<std::ptrdiff_t>(s));
  return r;
}
}  // namespace

NormativeReference leave_one_out(const NormativeReference& reference, std::size_t s) {
  if (s >= reference.subjects.size() || s >= reference.subject_values.size())
    throw std::out_of_range("leave_one_out: the reference has no values of subject " + std::to_string(s));
  return without_subject(reference, reference.subject_values[s], s);
}

NormativeReference merge_references(const NormativeReference& a, const NormativeReference& b, const std::string& a_name,
                                    const std::string& b_name) {
  check_shapes(shape_of(a), shape_of(b), b_name, a_name);
  for (const auto& s : b.subjects) check_new_subject(a, s.id, b_name);
  NormativeReference r = a;
  r.software = software_version();
  if (r.reference_mask.empty()) r.reference_mask = b.reference_mask;
  r.subjects.insert(r.subjects.end(), b.subjects.begin(), b.subjects.end());
  // The first subjects' values: a's, then b's (each side keeps its first ones), as a build of all.
  if (a.keeps_values() && b.keeps_values()) {
    for (std::size_t k = 0; k < b.subject_values.size() && r.subject_values.size() < kMaxChanceControls; ++k)
      r.subject_values.push_back(b.subject_values[k]);
  } else {
    r.subject_values.clear();  // one side has no values: no chance clusters for the merged reference
  }
  r.age_model = a.age_model && b.age_model;
  if (!r.age_model) {
    r.age_mean.clear();
    r.age_m2.clear();
    r.comoment.clear();
  }
  const std::size_t size = static_cast<std::size_t>(a.num_values());
  for (std::size_t i = 0; i < size; ++i) {
    const double na = a.n[i], nb = b.n[i], n = na + nb;
    if (nb == 0) continue;
    if (na == 0) {
      r.n[i] = nb;
      r.mean[i] = b.mean[i];
      r.m2[i] = b.m2[i];
      if (r.age_model) {
        r.age_mean[i] = b.age_mean[i];
        r.age_m2[i] = b.age_m2[i];
        r.comoment[i] = b.comoment[i];
      }
      continue;
    }
    const double dy = b.mean[i] - a.mean[i];
    const double w = na * nb / n;
    r.n[i] = n;
    r.mean[i] = a.mean[i] + dy * nb / n;
    r.m2[i] = a.m2[i] + b.m2[i] + dy * dy * w;
    if (r.age_model) {
      const double da = b.age_mean[i] - a.age_mean[i];
      r.age_mean[i] = a.age_mean[i] + da * nb / n;
      r.age_m2[i] = a.age_m2[i] + b.age_m2[i] + da * da * w;
      r.comoment[i] = a.comoment[i] + b.comoment[i] + da * dy * w;
    }
  }
  return r;
}

NormativeReference build_reference(const std::vector<std::string>& paths, const ProgressFn& progress) {
  if (paths.empty()) throw InputError("normative build: no element table given");
  // Parse a small batch of tables in parallel (one table per thread, per-slot results), then add
  // them in the given order: the result does not depend on the thread count and memory holds at
  // most one batch.
  const std::size_t batch = 16;
  NormativeReference r;
  bool started = false;
  std::vector<ElementTable> tables(batch);
  std::vector<std::string> errors(batch);
  for (std::size_t first = 0; first < paths.size(); first += batch) {
    const int count = static_cast<int>(std::min(batch, paths.size() - first));
#pragma omp parallel for schedule(dynamic, 1)
    for (int s = 0; s < count; ++s) {
      errors[static_cast<std::size_t>(s)].clear();
      try {
        tables[static_cast<std::size_t>(s)] = read_element_table(paths[first + static_cast<std::size_t>(s)], true);
      } catch (const std::exception& e) {
        errors[static_cast<std::size_t>(s)] = e.what();
      }
    }
    for (int s = 0; s < count; ++s) {
      if (!errors[static_cast<std::size_t>(s)].empty()) throw InputError(errors[static_cast<std::size_t>(s)]);
      const ElementTable& t = tables[static_cast<std::size_t>(s)];
      if (!started) {
        r = empty_reference_like(t);
        started = true;
      }
      add_subject(r, t, paths[first + static_cast<std::size_t>(s)]);
    }
    report(progress, "reference", static_cast<double>(first + static_cast<std::size_t>(count)) / paths.size(),
           std::to_string(first + static_cast<std::size_t>(count)) + " of " + std::to_string(paths.size()) + " tables");
  }
  return r;
}

// ---- file --------------------------------------------------------------------------------

std::string reference_to_json(const NormativeReference& r) {
  nlohmann::json j;
  j["format"] = "authalic-normative-reference";
  j["version"] = kNormativeFormatVersion;
  j["software"] = r.software.empty() ? software_version() : r.software;
  j["description"] =
      "Normative reference of equal-area cortical elements (authalic). Per element, over the control "
      "subjects with a finite value there: n, mean, m2 = sum of squared deviations from the mean (SD = "
      "sqrt(m2 / (n - 1)), also given as sd); with age_model, age_mean, age_m2 and age_value_comoment = "
      "sum (age - age_mean)(value - mean), the sufficient statistics of a linear age model. Arrays run over "
      "the hemisphere blocks in the order listed, then element id = row * cols + col (row 0 at the bottom "
      "of the domain). References merge exactly (Chan et al. pairwise formulas): authalic normative merge. "
      "partial = true: a piece for merging (fewer than 3 controls allowed), refused by compare. subject_values: "
      "the element values of the first 100 controls (subjects order; see subject_values_encoding), from which a "
      "comparison measures the controls' chance clusters (leave-one-out) and gives each cluster of a patient its p.";
  j["domain"] = to_string(r.grid.domain);
  j["k"] = r.grid.k;
  j["rows"] = r.grid.rows;
  j["cols"] = r.grid.cols;
  j["hemispheres"] = r.hemispheres;
  j["normalisation"] = r.normalisation;
  j["units"] = r.units;
  j["correspondence"] = r.correspondence;
  if (!r.reference_mask.empty()) j[kReferenceMaskKey] = r.reference_mask;
  j["num_subjects"] = r.subjects.size();
  j["age_model"] = r.age_model;
  j["partial"] = r.partial;
  j["subjects"] = nlohmann::json::array();
  for (const auto& s : r.subjects) j["subjects"].push_back({{"id", s.id}, {"age", number_or_null(s.age)}, {"table", s.table}});
  nlohmann::json e;
  e["n"] = r.n;
  e["mean"] = r.mean;
  e["m2"] = r.m2;
  if (r.age_model) {
    e["age_mean"] = r.age_mean;
    e["age_m2"] = r.age_m2;
    e["age_value_comoment"] = r.comoment;
  }
  nlohmann::json sd = nlohmann::json::array();
  for (int i = 0; i < r.num_values(); ++i) sd.push_back(number_or_null(r.sd(i)));
  e["sd"] = sd;
  j["elements"] = e;
  if (!r.subjects.empty() && r.keeps_values()) {
    nlohmann::json values = nlohmann::json::array();
    for (const auto& v : r.subject_values) values.push_back(encode_values(v));
    j["subject_values_encoding"] = "base64 of little-endian IEEE 754 float64, one string per subject, NaN where it had no value";
    j["subject_values"] = std::move(values);
  }
  return j.dump(1) + "\n";
}

NormativeReference reference_from_json(const std::string& text, const std::string& path) {
  NormativeReference r;
  try {
    const nlohmann::json j = nlohmann::json::parse(text);
    if (!j.is_object() || j.value("format", "") != "authalic-normative-reference")
      throw InputError(path + ": not an authalic normative reference (\"format\" is not \"authalic-normative-reference\")");
    const int version = j.at("version").get<int>();
    if (version != kNormativeFormatVersion)
      throw InputError(path + ": reference format version " + std::to_string(version) + " is not supported (this authalic reads version " +
                       std::to_string(kNormativeFormatVersion) + "); rebuild the reference with this version");
    const int k = j.at("k").get<int>();
    if (k < 1 || k > 4096) throw InputError(path + ": k = " + std::to_string(k) + " is outside 1..4096; the reference file is corrupt");
    r.grid = element_grid(Domain::of(parse_domain_kind(j.at("domain").get<std::string>(), path + ": domain")), k);
    if (j.at("rows").get<int>() != r.grid.rows || j.at("cols").get<int>() != r.grid.cols)
      throw InputError(path + ": rows/cols do not match the domain and K");
    r.hemispheres = j.at("hemispheres").get<std::vector<std::string>>();
    if (r.hemispheres.empty()) throw InputError(path + ": lists no hemisphere");
    r.normalisation = j.at("normalisation").get<std::string>();
    r.units = j.at("units").get<std::string>();
    r.software = j.value("software", "");
    r.correspondence = j.value("correspondence", std::string(kPerSubjectCorrespondence));
    r.reference_mask = j.value(kReferenceMaskKey, std::string());
    for (const auto& s : j.at("subjects")) {
      NormativeSubject sub;
      sub.id = s.value("id", "");
      sub.age = s.contains("age") && s["age"].is_number() ? s["age"].get<double>() : kNaN;
      sub.table = s.value("table", "");
      r.subjects.push_back(sub);
    }
    if (j.at("num_subjects").get<std::size_t>() != r.subjects.size())
      throw InputError(path + ": num_subjects does not match the subject list");
    r.age_model = j.at("age_model").get<bool>();
    r.partial = j.value("partial", false);
    const auto& e = j.at("elements");
    const std::size_t size = static_cast<std::size_t>(r.num_values());
    r.n = read_array(e, "n", size, path);
    r.mean = read_array(e, "mean", size, path);
    r.m2 = read_array(e, "m2", size, path);
    if (r.age_model) {
      r.age_mean = read_array(e, "age_mean", size, path);
      r.age_m2 = read_array(e, "age_m2", size, path);
      r.comoment = read_array(e, "age_value_comoment", size, path);
    }
    for (std::size_t i = 0; i < size; ++i)
      if (!(r.n[i] >= 0 && r.n[i] <= static_cast<double>(r.subjects.size()) && r.n[i] == std::floor(r.n[i])) ||
          !(r.m2[i] >= 0))
        throw InputError(path + ": element " + std::to_string(i) + " has inconsistent statistics (n " + std::to_string(r.n[i]) +
                         ", m2 " + std::to_string(r.m2[i]) + "); the file is corrupt");
    if (j.contains("subject_values")) r.subject_values = read_subject_values(j["subject_values"], r, path);
  } catch (const nlohmann::json::exception& ex) {
    throw InputError(path + ": invalid normative reference (" + short_json_error(ex.what()) +
                     "); the file is truncated or not a reference written by authalic");
  }
  return r;
}

void write_reference(const std::string& path, const NormativeReference& reference) {
  io::write_file_atomically(path, reference_to_json(reference));
}

NormativeReference read_reference(const std::string& path) {
  std::string text;
  if (!read_text_file(path, text))
    throw InputError(path + ": cannot read the normative reference (" +
                     (std::filesystem::exists(path) ? std::string("not a readable file") : std::string("no such file")) +
                     "); give the reference JSON written by `authalic normative build` or `group`");
  return reference_from_json(text, path);
}

int usable_elements(const NormativeReference& r, int min_subjects) {
  int usable = 0;
  for (int i = 0; i < r.num_values(); ++i)
    if (r.n[static_cast<std::size_t>(i)] >= min_subjects && r.sd(i) > 0 && std::isfinite(r.sd(i))) ++usable;
  return usable;
}

void check_reference_usable(const NormativeReference& r, const std::string& what) {
  const int controls = static_cast<int>(r.subjects.size());
  if (controls < kMinControls)
    throw InputError(what + ": " + std::to_string(controls) + " control(s); a normative reference needs at least " +
                     std::to_string(kMinControls) + " (fewer give no normal range to compare with): add controls (their element tables, or references to merge)");
  if (usable_elements(r, kMinControls) == 0)
    throw InputError(what + ": no element has " + std::to_string(kMinControls) +
                     " or more controls with values that vary (SD > 0); every z-score would be undefined: check the "
                     "control tables (are they copies of one table, or all empty?)");
}

// ---- comparison --------------------------------------------------------------------------

std::vector<int> label_clusters(const ElementGrid& grid, const std::vector<int>& flags, int* count) {
  const int rows = grid.rows, cols = grid.cols, ne = grid.num_elements();
  std::vector<int> label(static_cast<std::size_t>(ne), 0);
  int next = 0;
  std::vector<int> stack;
  for (int start = 0; start < ne; ++start) {
    if (flags[static_cast<std::size_t>(start)] == 0 || label[static_cast<std::size_t>(start)] != 0) continue;
    const int sign = flags[static_cast<std::size_t>(start)];
    label[static_cast<std::size_t>(start)] = ++next;
    stack.assign(1, start);
    while (!stack.empty()) {
      const int e = stack.back();
      stack.pop_back();
      const int r = e / cols, c = e % cols;
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc) {
          if (dr == 0 && dc == 0) continue;
          const int rr = r + dr;
          int cc = c + dc;
          if (rr < 0 || rr >= rows) continue;
          if (grid.domain.kind == DomainKind::Sphere) {
            cc = (cc + cols) % cols;  // longitude wraps
          } else {
            if (cc < 0 || cc >= cols) continue;
            // Whole-brain rectangle: the two hemispheres meet at the seam only in the map, not in the brain.
            if (!grid.domain.same_part(grid.k, c, cc)) continue;
          }
          const int n = rr * cols + cc;
          if (flags[static_cast<std::size_t>(n)] != sign || label[static_cast<std::size_t>(n)] != 0) continue;
          label[static_cast<std::size_t>(n)] = next;
          stack.push_back(n);
        }
    }
  }
  if (count) *count = next;
  return label;
}

namespace {
// The patient's scale factor to the reference over its normal elements (CompareOptions::rescale):
// s minimises sum over normal elements of z^2 = ((s y - expected) / sd)^2, i.e.
// s = sum(expected y / sd^2) / sum(y^2 / sd^2), where "normal" is |z| < threshold at the current s.
// Starting from all elements, the set is refitted until it no longer changes (a few rounds). A
// sequential sum in element order keeps the result independent of the thread count.
void rescale_to_reference(Comparison& out, const std::vector<double>& value, double threshold) {
  const std::size_t size = value.size();
  constexpr int kMaxRounds = 50;
  const auto usable = [&](std::size_t i) {
    const double y = value[i];
    return std::isfinite(y) && y > 0 && std::isfinite(out.expected[i]) && out.sd[i] > 0;
  };
  std::vector<char> normal(size, 0);
  for (std::size_t i = 0; i < size; ++i) normal[i] = usable(i);
  double scale = 1.0;
  int used = 0, round = 0;
  bool settled = false;
  for (; round < kMaxRounds && !settled; ++round) {
    double num = 0, den = 0;
    used = 0;
    for (std::size_t i = 0; i < size; ++i) {
      if (!normal[i]) continue;
      const double y = value[i], w = 1.0 / (out.sd[i] * out.sd[i]);
      num += w * out.expected[i] * y;
      den += w * y * y;
      ++used;
    }
    if (!(den > 0) || used < 10) {
      out.notes.push_back("rescaling to the reference skipped: fewer than 10 elements to fit it on");
      return;
    }
    scale = num / den;
    settled = true;
    for (std::size_t i = 0; i < size; ++i) {
      if (!usable(i)) continue;
      const char now = std::abs((scale * value[i] - out.expected[i]) / out.sd[i]) < threshold;
      if (now != normal[i]) settled = false;
      normal[i] = now;
    }
  }
  if (!settled)
    out.notes.push_back("rescaling to the reference did not settle in " + std::to_string(kMaxRounds) +
                        " rounds: the last factor is used");
  out.rescaled = true;
  out.scale = scale;
  out.scale_elements = used;
  out.scale_rounds = round;
}

// z, flags and clusters of one table against one reference (compare_to_reference without the
// chance clusters).
Comparison compare_elements(const NormativeReference& ref, const ElementTable& patient, const CompareOptions& options) {
  const std::string subject = patient.subject_id.empty() ? std::string("patient table") : "patient " + patient.subject_id;
  check_shapes(shape_of(ref), shape_of(patient), options.patient_name.empty() ? subject : options.patient_name + " (" + subject + ")",
               options.reference_name);
  if (!(options.threshold > 0)) throw InputError("--threshold: must be > 0 (|z| flagged as abnormal)");
  if (ref.partial)
    throw InputError(options.reference_name + ": is a partial reference (" + std::to_string(ref.subjects.size()) +
                     " control(s), from `normative build --partial`) meant for merging; merge it with the others "
                     "(authalic normative merge) before comparing");
  Comparison out;
  out.threshold = options.threshold;
  out.predictive = options.predictive;
  out.patient_age = std::isfinite(options.age) ? options.age : patient.age;
  const bool age_model = has_age_model(ref, options.age_model_min_controls);
  out.age_adjusted = options.use_age && age_model && std::isfinite(out.patient_age);
  if (options.use_age && age_model && !std::isfinite(out.patient_age))
    out.notes.push_back(options.reference_name + " has an age model but the patient's age is unknown (--age): z-scores are NOT age adjusted");
  if (ref.normalisation == "reference-region" && ref.reference_mask.empty() != table_reference_mask(patient).empty())
    out.notes.push_back(std::string(ref.reference_mask.empty() ? "the reference" : "the patient's table") +
                        " does not record its reference-region mask (made before 2026-12-07): that both were normalised with "
                        "the same region could not be checked");
  if (out.age_adjusted) {  // a line is only known between the controls' ages
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& s : ref.subjects) lo = std::min(lo, s.age), hi = std::max(hi, s.age);
    if (out.patient_age < lo || out.patient_age > hi)
      out.notes.push_back("the patient's age " + format_value(out.patient_age) + " is outside the controls' ages (" + format_value(lo) +
                          "-" + format_value(hi) + " years): the age model extrapolates, and its expected values are less certain");
  }
  if (const std::string why = age_model_absent_reason(ref, options.age_model_min_controls); options.use_age && !why.empty())
    out.notes.push_back(why + ": no age model, z-scores are NOT age adjusted");
  for (const auto& s : ref.subjects)
    if (!patient.subject_id.empty() && s.id == patient.subject_id)
      out.notes.push_back("subject '" + s.id + "' is one of the reference's controls: its z-scores are biased toward 0");
  const std::size_t size = static_cast<std::size_t>(ref.num_values());
  const int ne = ref.grid.num_elements();
  out.z.assign(size, kNaN);
  out.expected.assign(size, kNaN);
  out.sd.assign(size, kNaN);
  out.flag.assign(size, 0);
  out.cluster.assign(size, 0);
  const int min_n = std::max(options.min_subjects, out.age_adjusted ? 3 : 2);
  for (std::size_t i = 0; i < size; ++i) {
    const double n = ref.n[i];
    if (n < min_n) continue;
    double expected = ref.mean[i], sd = ref.sd(static_cast<int>(i));
    double inflation = 1 + 1 / n;  // predictive: the uncertainty of the reference mean
    if (out.age_adjusted && ref.age_m2[i] > 0 && n >= options.age_model_min_controls) {
      // Least-squares line in age; SD of the residuals (n - 2 degrees of freedom).
      const double beta = ref.comoment[i] / ref.age_m2[i];
      const double da = out.patient_age - ref.age_mean[i];
      expected = ref.mean[i] + beta * da;
      const double ss = std::max(0.0, ref.m2[i] - ref.comoment[i] * beta);
      sd = std::sqrt(ss / (n - 2));
      inflation += da * da / ref.age_m2[i];  // and of the slope
    }
    if (options.predictive) sd *= std::sqrt(inflation);
    out.expected[i] = expected;
    out.sd[i] = sd;
  }
  std::vector<double> value(size);  // the patient's, in the reference's order (blocks x elements)
  for (std::size_t i = 0; i < size; ++i) {
    value[i] = patient.blocks[i / static_cast<std::size_t>(ne)].elements[i % static_cast<std::size_t>(ne)].value;
    if (std::isfinite(value[i]) && std::abs(value[i]) > kMaxReferenceValue)  // as a reference refuses it
      throw InputError((options.patient_name.empty() ? "patient " + patient.subject_id : options.patient_name) + ": element " +
                       std::to_string(i % static_cast<std::size_t>(ne)) + " (" + ref.hemispheres[i / static_cast<std::size_t>(ne)] +
                       ") has value " + format_value(value[i]) + ", beyond +-1e15: not a plausible PET value; check how the table was made");
  }
  if (options.rescale) rescale_to_reference(out, value, options.threshold);
  for (std::size_t i = 0; i < size; ++i) {
    const double y = out.scale * value[i], expected = out.expected[i], sd = out.sd[i];
    if (!std::isfinite(y) || !std::isfinite(expected) || !(sd > 0)) continue;
    const double z = (y - expected) / sd;
    out.z[i] = z;
    ++out.num_compared;
    if (z <= -options.threshold) {
      out.flag[i] = -1;
      ++out.num_hypo;
    } else if (z >= options.threshold) {
      out.flag[i] = 1;
      ++out.num_hyper;
    }
  }
  out.num_without_z = static_cast<int>(size) - out.num_compared;
  // "0 elements compared, 0 clusters" would read as a normal result: it is no result at all.
  if (out.num_compared == 0)
    throw InputError(options.reference_name + ": no element could be compared (" + std::to_string(usable_elements(ref, min_n)) +
                     " of " + std::to_string(size) + " elements have " + std::to_string(min_n) +
                     "+ controls with SD > 0, and the patient has no finite value in those); this is not a normal "
                     "result: use a reference built from at least " + std::to_string(kMinControls) + " controls");

  // Clusters per block.
  for (std::size_t b = 0; b < ref.hemispheres.size(); ++b) {
    const std::size_t offset = b * static_cast<std::size_t>(ne);
    std::vector<int> flags(out.flag.begin() + static_cast<std::ptrdiff_t>(offset),
                           out.flag.begin() + static_cast<std::ptrdiff_t>(offset + static_cast<std::size_t>(ne)));
    int count = 0;
    ElementGrid grid = ref.grid;  // the patient's own seam (each subject's w_L is its own)
    grid.domain.seam_x = patient.grid.domain.seam_x;
    const auto label = label_clusters(grid, flags, &count);
    std::vector<ElementCluster> clusters(static_cast<std::size_t>(count));
    for (int e = 0; e < ne; ++e) {
      const int l = label[static_cast<std::size_t>(e)];
      if (l == 0) continue;
      ElementCluster& c = clusters[static_cast<std::size_t>(l - 1)];
      const Element& el = patient.blocks[b].elements[static_cast<std::size_t>(e)];
      const double z = out.z[offset + static_cast<std::size_t>(e)];
      c.block = static_cast<int>(b);
      c.hemisphere = ref.hemispheres[b];
      c.sign = flags[static_cast<std::size_t>(e)];
      c.elements.push_back(e);
      c.area_mm2 += el.area_mm2;
      c.mean_z += z;
      c.mass += std::abs(z) - options.threshold;
      if (c.peak_element < 0 || std::abs(z) > std::abs(c.peak_z)) {
        c.peak_z = z;
        c.peak_element = e;
        c.peak_row = el.row;
        c.peak_col = el.col;
        c.peak_ras = el.centroid;
      }
    }
    for (auto& c : clusters) {
      c.mean_z /= static_cast<double>(c.elements.size());
      out.clusters.push_back(std::move(c));
    }
  }
  std::stable_sort(out.clusters.begin(), out.clusters.end(), [](const ElementCluster& a, const ElementCluster& b) {
    if (a.elements.size() != b.elements.size()) return a.elements.size() > b.elements.size();
    if (std::abs(a.peak_z) != std::abs(b.peak_z)) return std::abs(a.peak_z) > std::abs(b.peak_z);
    if (a.block != b.block) return a.block < b.block;
    return a.elements.front() < b.elements.front();
  });
  for (std::size_t k = 0; k < out.clusters.size(); ++k) {
    ElementCluster& c = out.clusters[k];
    c.id = static_cast<int>(k) + 1;
    for (int e : c.elements) out.cluster[static_cast<std::size_t>(c.block) * static_cast<std::size_t>(ne) + static_cast<std::size_t>(e)] = c.id;
  }
  return out;
}

// Each control compared, as a patient, with the reference of the others (its own age, the
// patient's options and seam): the mass of its largest hypo and hyper cluster. Then each of
// the patient's clusters gets its count and p (normative.h, "Chance clusters").
void measure_chance_clusters(const NormativeReference& ref, const ElementTable& patient, const CompareOptions& options, Comparison& out) {
  const std::size_t controls = ref.subject_values.size();  // the first kMaxChanceControls at most
  if (!ref.keeps_values() || controls == 0) {
    out.chance_note = "the reference does not keep its controls' values (built before 2026-12-07, or merged with such a "
                      "reference): rebuild it to measure the controls' chance clusters";
    return;
  }
  if (ref.subjects.size() < static_cast<std::size_t>(kMinControls) + 1) {
    out.chance_note = "the reference has " + std::to_string(ref.subjects.size()) + " controls; leaving one out needs at least " +
                      std::to_string(kMinControls + 1);
    return;
  }
  const int ne = ref.grid.num_elements();
  NormativeReference stats = ref;  // copied once without the values, not once per control
  stats.subject_values.clear();
  // One slot per control, filled in parallel: the result does not depend on the thread count.
  out.control_mass_hypo.assign(controls, 0.0);
  out.control_mass_hyper.assign(controls, 0.0);
  std::vector<std::string> errors(controls);
#pragma omp parallel for schedule(dynamic, 4)
  for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(controls); ++k) {
    const std::size_t s = static_cast<std::size_t>(k);
    try {
      ElementTable control = patient;  // the patient's grid, blocks and seam, with the control's values
      control.subject_id = ref.subjects[s].id;
      control.age = ref.subjects[s].age;
      CompareOptions each = options;
      each.chance_clusters = false;
      each.age_model_min_controls = options.age_model_min_controls - 1;  // the patient's model, one control less
      each.age = ref.subjects[s].age;
      for (std::size_t b = 0; b < control.blocks.size(); ++b)
        for (int e = 0; e < ne; ++e)
          control.blocks[b].elements[static_cast<std::size_t>(e)].value =
              ref.subject_values[s][b * static_cast<std::size_t>(ne) + static_cast<std::size_t>(e)];
      for (const ElementCluster& c : compare_elements(without_subject(stats, ref.subject_values[s], s), control, each).clusters) {
        double& l = c.sign < 0 ? out.control_mass_hypo[s] : out.control_mass_hyper[s];
        l = std::max(l, c.mass);
      }
    } catch (const std::exception& e) {
      errors[s] = e.what();
    }
  }
  for (std::size_t s = 0; s < controls; ++s)
    if (!errors[s].empty()) {
      out.control_mass_hypo.clear();
      out.control_mass_hyper.clear();
      out.chance_note = "control " + ref.subjects[s].id + " could not be compared with the others: " + errors[s];
      return;
    }
  for (ElementCluster& c : out.clusters) {
    const std::vector<double>& largest = c.sign < 0 ? out.control_mass_hypo : out.control_mass_hyper;
    const double m = c.mass;
    c.controls_as_large = static_cast<int>(std::count_if(largest.begin(), largest.end(), [m](double l) { return l >= m; }));
    c.p_controls = (1.0 + c.controls_as_large) / (1.0 + static_cast<double>(largest.size()));
  }
}

}  // namespace

Comparison compare_to_reference(const NormativeReference& ref, const ElementTable& patient, const CompareOptions& options) {
  Comparison out = compare_elements(ref, patient, options);
  if (options.chance_clusters) measure_chance_clusters(ref, patient, options, out);
  return out;
}

}  // namespace authalic::analysis

// ---- outputs --------------------------------------------------------------------------------

namespace authalic::analysis {

std::string comparison_summary_json(const NormativeReference& ref, const std::string& reference_path,
                                    const ElementTable& patient, const std::string& patient_path, const Comparison& cmp,
                                    const ComparisonOutputPaths& paths) {
  nlohmann::json j;
  j["format"] = "authalic-comparison";
  j["version"] = 1;
  j["software"] = software_version();
  j["z_definition"] = std::string(cmp.rescaled ? "z = (factor x patient - expected) / SD" : "z = (patient - expected) / SD") +
                      (cmp.predictive ? ", SD = predictive SD of a new control (reference SD x sqrt(1 + 1/n [+ (age - mean age)^2 / "
                                        "sum of squared age deviations]))"
                                      : ", SD = reference SD (residual SD with the age model)") +
                      "; hypometabolism is negative (NEUROSTAT/3D-SSP report the opposite sign)";
  j["predictive_sd"] = cmp.predictive;
  j["rescale"] = {{"applied", cmp.rescaled},
                  {"factor", cmp.scale},
                  {"elements_used", cmp.scale_elements},
                  {"rounds", cmp.scale_rounds},
                  {"definition", "patient values x factor before z; the factor best fits the reference over the elements "
                                 "found normal (|z| < threshold), refitted until that set settles"}};
  j["reference"] = {{"path", reference_path},
                    {"num_subjects", ref.subjects.size()},
                    {"domain", to_string(ref.grid.domain)},
                    {"k", ref.grid.k},
                    {"hemispheres", ref.hemispheres},
                    {"normalisation", ref.normalisation},
                    {"units", ref.units},
                    {"age_model", has_age_model(ref)},             // usable: enough controls, ages that differ
                    {"age_statistics_stored", ref.age_model}};     // every control had an age
  j["patient"] = {{"table", patient_path}, {"subject_id", patient.subject_id}, {"age", number_or_null(cmp.patient_age)}};
  j["age_adjusted"] = cmp.age_adjusted;
  j["threshold"] = cmp.threshold;
  j["counts"] = {{"elements", ref.num_values()},
                 {"compared", cmp.num_compared},
                 {"without_z", cmp.num_without_z},
                 {"hypo", cmp.num_hypo},
                 {"hyper", cmp.num_hyper}};
  j["clusters"] = nlohmann::json::parse(clusters_json(cmp.clusters));
  j["chance_clusters"] = nlohmann::json::parse(chance_clusters_json(cmp));
  j["notes"] = cmp.notes;
  j["outputs"] = {{"z_nifti", paths.z_nifti}, {"z_png", paths.z_png}, {"abnormal_csv", paths.abnormal_csv},
                  {"summary_json", paths.summary_json}, {"z_func", paths.z_func}};
  return j.dump(2) + "\n";
}

std::string clusters_json(const std::vector<ElementCluster>& clusters) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& c : clusters)
    a.push_back({{"id", c.id},
                             {"hemisphere", c.hemisphere},
                             {"sign", c.sign < 0 ? "hypo" : "hyper"},
                             {"num_elements", c.elements.size()},
                             {"area_mm2", c.area_mm2},
                             {"peak_z", c.peak_z},
                             {"mean_z", c.mean_z},
                             {"peak_element", c.peak_element},
                             {"peak_row", c.peak_row},
                             {"peak_col", c.peak_col},
                             {"peak_ras_mm", {number_or_null(c.peak_ras.x()), number_or_null(c.peak_ras.y()), number_or_null(c.peak_ras.z())}},
                             {"mass", c.mass},
                             {"controls_as_large", c.controls_as_large >= 0 ? nlohmann::json(c.controls_as_large) : nlohmann::json(nullptr)},
                             {"p_controls", number_or_null(c.p_controls)}});
  return a.dump();
}

std::string chance_clusters_json(const Comparison& cmp) {
  if (cmp.control_mass_hypo.empty()) return nlohmann::json({{"measured", false}, {"reason", cmp.chance_note}}).dump();
  return nlohmann::json({{"measured", true},
                         {"controls", cmp.control_mass_hypo.size()},
                         {"largest_hypo_mass", cmp.control_mass_hypo},
                         {"largest_hyper_mass", cmp.control_mass_hyper},
                         {"definition", "each control compared with the reference of the other controls (leave-one-out), "
                                        "same threshold, rescaling and age model; per control the mass of its largest "
                                        "hypo and hyper cluster (mass = sum over the elements of |z| - threshold; Bullmore "
                                        "et al. 1999). A cluster's p_controls = (1 + controls_as_large) / (1 + controls), "
                                        "controls_as_large = the controls whose largest cluster of its sign has at least its "
                                        "mass (max statistic, Nichols & Holmes 2002)"}})
      .dump();
}

ComparisonOutputPaths comparison_output_paths(const std::string& prefix, const std::vector<std::string>& hemispheres,
                                              const std::vector<bool>& with_vertices) {
  ComparisonOutputPaths p;
  p.z_nifti = prefix + "_z.nii.gz";
  p.z_png = prefix + "_z.png";
  p.abnormal_csv = prefix + "_abnormal.csv";
  p.summary_json = prefix + ".json";
  const std::size_t nb = hemispheres.size();
  for (std::size_t b = 0; b < nb && b < with_vertices.size(); ++b)
    if (with_vertices[b]) p.z_func.push_back(nb == 1 ? prefix + "_z.func.gii" : prefix + "_" + hemispheres[b] + "_z.func.gii");
  return p;
}

std::vector<std::string> ComparisonOutputPaths::all() const {
  std::vector<std::string> v = {z_nifti, z_png, abnormal_csv, summary_json};
  v.insert(v.end(), z_func.begin(), z_func.end());
  return v;
}

ComparisonOutputPaths write_comparison_outputs(const std::string& prefix, const NormativeReference& ref,
                                               const std::string& reference_path, const ElementTable& patient,
                                               const std::string& patient_path, const Comparison& cmp,
                                               const std::vector<VectorXi>& vertex_elements) {
  std::vector<bool> with_vertices;
  for (std::size_t b = 0; b < ref.hemispheres.size(); ++b) with_vertices.push_back(b < vertex_elements.size() && vertex_elements[b].size() > 0);
  const ComparisonOutputPaths p = comparison_output_paths(prefix, ref.hemispheres, with_vertices);
  const ElementGrid& g = ref.grid;
  const int ne = g.num_elements();
  const int nb = static_cast<int>(ref.hemispheres.size());

  std::vector<float> image(cmp.z.size());
  for (std::size_t i = 0; i < cmp.z.size(); ++i) image[i] = static_cast<float>(cmp.z[i]);
  write_element_nifti(p.z_nifti, image, g, nb, mean_element_area(patient), ElementImageKind::kZScore,
                      "authalic z = (patient - expected)/SD, " + to_string(g.domain) + " K=" + std::to_string(g.k));

  ScalarColouring c;
  c.colormap = "coolwarm";
  c.vmin = -5;
  c.vmax = 5;
  c.label = "z";
  const int cell = std::max(4, 480 / g.cols);
  std::vector<io::RgbImage> panels;
  std::vector<std::string> captions;
  for (int b = 0; b < nb; ++b) {
    std::vector<double> z(cmp.z.begin() + static_cast<std::ptrdiff_t>(b) * ne, cmp.z.begin() + static_cast<std::ptrdiff_t>(b + 1) * ne);
    panels.push_back(render_element_grid(z, g.rows, g.cols, c, cell, "z-score elements (" + ref.hemispheres[static_cast<std::size_t>(b)] + ")"));
    captions.push_back(ref.hemispheres[static_cast<std::size_t>(b)]);
  }
  io::write_png(p.z_png, nb == 1 ? panels[0] : compose_horizontal(panels, 16, captions));

  std::size_t z_file = 0;
  for (int b = 0; b < nb && b < static_cast<int>(vertex_elements.size()); ++b) {
    const VectorXi& ve = vertex_elements[static_cast<std::size_t>(b)];
    if (ve.size() == 0) continue;
    const VectorXd zv = element_values_at_vertices(ve, cmp.z.data() + static_cast<std::size_t>(b) * static_cast<std::size_t>(ne), ne);
    const std::string& hemi = ref.hemispheres[static_cast<std::size_t>(b)];
    const std::string& path = p.z_func[z_file++];
    io::FuncWriteOptions fo;
    fo.column_names = {"z"};
    if (hemi == "left") fo.anatomical_structure = "CortexLeft";
    if (hemi == "right") fo.anatomical_structure = "CortexRight";
    fo.intent = 5;  // NIFTI_INTENT_ZSCORE, as the element z image
    fo.metadata = {{"description", "z = (patient - expected) / SD of the vertex's equal-area element"},
                   {"reference", reference_path},
                   {"normalisation", ref.normalisation},
                   {"software", software_version()}};
    io::write_per_vertex(path, zv, fo);
  }

  std::string csv = "hemisphere,id,row,col,value,expected,sd,z,direction,cluster,area_mm2,centroid_x_mm,centroid_y_mm,centroid_z_mm\n";
  for (int b = 0; b < nb; ++b)
    for (int e = 0; e < ne; ++e) {
      const std::size_t i = static_cast<std::size_t>(b) * static_cast<std::size_t>(ne) + static_cast<std::size_t>(e);
      if (cmp.flag[i] == 0) continue;
      const Element& el = patient.blocks[static_cast<std::size_t>(b)].elements[static_cast<std::size_t>(e)];
      csv += ref.hemispheres[static_cast<std::size_t>(b)] + "," + std::to_string(e) + "," + std::to_string(el.row) + "," +
             std::to_string(el.col);
      for (double x : {cmp.scale * el.value, cmp.expected[i], cmp.sd[i], cmp.z[i]}) {  // so z = (value - expected) / sd
        csv += ',';
        append_number(csv, x);
      }
      csv += cmp.flag[i] < 0 ? ",hypo," : ",hyper,";
      csv += std::to_string(cmp.cluster[i]);
      for (double x : {el.area_mm2, el.centroid.x(), el.centroid.y(), el.centroid.z()}) {
        csv += ',';
        append_number(csv, x);
      }
      csv += '\n';
    }
  io::write_file_atomically(p.abnormal_csv, csv);
  io::write_file_atomically(p.summary_json, comparison_summary_json(ref, reference_path, patient, patient_path, cmp, p));
  return p;
}

double expected_abnormal_share(int controls, bool age_model, bool predictive, double threshold) {
  const int df = controls - (age_model ? 2 : 1);
  if (df < 1 || !(threshold > 0)) return std::nan("");
  const double t = predictive ? threshold : threshold / std::sqrt(1.0 + 1.0 / controls);
  const boost::math::students_t dist(df);
  return 2.0 * boost::math::cdf(boost::math::complement(dist, t));
}

bool has_age_model(const NormativeReference& ref, int min_controls) {
  return age_model_absent_reason(ref, min_controls).empty() && ref.age_model;
}

std::string age_model_absent_reason(const NormativeReference& ref, int min_controls) {
  if (!ref.age_model) {
    // Ages were given, but not for every control: one missing age drops the whole model.
    std::vector<std::string> without;
    for (const auto& s : ref.subjects)
      if (!std::isfinite(s.age)) without.push_back(s.id);
    if (without.empty() || without.size() == ref.subjects.size()) return "";
    std::string names = "'" + without[0] + "'";
    for (std::size_t i = 1; i < std::min<std::size_t>(without.size(), 3); ++i) names += ", '" + without[i] + "'";
    if (without.size() > 3) names += " and " + std::to_string(without.size() - 3) + " more";
    return std::to_string(without.size()) + " of the reference's " + std::to_string(ref.subjects.size()) + " controls (" + names +
           ") have no age; the age model needs every control's age";
  }
  if (static_cast<int>(ref.subjects.size()) < min_controls)
    return "the reference has " + std::to_string(ref.subjects.size()) + " controls; the age model needs at least " +
           std::to_string(min_controls) + " (a line through fewer leaves too few degrees of freedom for its SD)";
  if (std::none_of(ref.age_m2.begin(), ref.age_m2.end(), [](double m2) { return m2 > 0; }))
    return "the reference's controls are all of one age";
  return "";
}

}  // namespace authalic::analysis

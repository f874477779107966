// `authalic normative build|merge|compare`: the normative reference of equal-area elements from
// control subjects, exact merging of partial references, and a patient's z-scores and clusters.
// See analysis/normative.h.
#include <chrono>
#include <ctime>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <nlohmann/json.hpp>

#include "analysis/normative.h"
#include "analysis/report_inputs.h"
#include "app/command.h"
#include "core/error.h"
#include "io/surface_io.h"
#include "io/file_roles.h"

namespace authalic::app {
namespace {

struct BuildArgs {
  std::string out;
  std::vector<std::string> tables;
  std::string list;
  bool partial = false;
};

struct MergeArgs {
  std::string out;
  std::vector<std::string> inputs;
  bool partial = false;
};

struct CompareArgs {
  std::string reference, patient, prefix;
  double threshold = 2.0;
  std::vector<std::string> labels;
  double age = std::nan("");
  bool no_age = false;
  bool plain_sd = false;
  bool no_rescale = false;
  int min_subjects = 3;
  int min_cluster = 1;
};

// CPU seconds of all threads since `start`: the command's cost on an idle machine.
double cpu_seconds_since(std::clock_t start) { return double(std::clock() - start) / CLOCKS_PER_SEC; }

void print_reference_summary(const analysis::NormativeReference& r, const std::string& path, double seconds,
                             double cpu_seconds) {
  info("authalic normative: " + path + ": " + std::to_string(r.subjects.size()) + " subjects, " + to_string(r.grid.domain) +
       " K = " + std::to_string(r.grid.k) + ", " + std::to_string(r.hemispheres.size()) + " hemisphere block(s), normalisation " +
       r.normalisation +
       (analysis::has_age_model(r)                    ? ", age model"
        : !analysis::age_model_absent_reason(r).empty() ? ", no age model (" + analysis::age_model_absent_reason(r) + ")"
                                                        : ", no age model"));
  if (global_options().json) {
    nlohmann::json j;
    j["output"] = path;
    j["num_subjects"] = r.subjects.size();
    j["domain"] = to_string(r.grid.domain);
    j["k"] = r.grid.k;
    j["hemispheres"] = r.hemispheres;
    j["normalisation"] = r.normalisation;
    j["units"] = r.units;
    j["age_model"] = analysis::has_age_model(r);
    if (!analysis::age_model_absent_reason(r).empty()) j["age_model_note"] = analysis::age_model_absent_reason(r);
    j["seconds"] = seconds;
    j["cpu_seconds"] = cpu_seconds;
    std::cout << j.dump(2) << '\n';
  }
}

int run_build(const BuildArgs& a) {
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  std::vector<std::string> tables = a.tables;
  if (!a.list.empty()) {
    std::ifstream in(a.list);
    if (!in) throw InputError(a.list + ": cannot read the table list");
    std::string line;
    while (std::getline(in, line)) {
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
      if (!line.empty() && line[0] != '#') tables.push_back(line);
    }
  }
  if (tables.empty())
    throw InputError(a.list.empty() ? "normative build: no element table given; list the controls' *_elements.tsv files"
                                    : a.list + ": lists no element table (it is empty or holds only comments); list the controls' "
                                               "*_elements.tsv files, one a line");
  std::vector<std::string> inputs = {a.list};
  for (const auto& t : tables) inputs.insert(inputs.end(), {t, analysis::element_sidecar_path(t)});
  io::check_file_roles(inputs, {a.out});
  auto ref = analysis::build_reference(tables, terminal_progress());
  ref.partial = a.partial;
  if (!a.partial) analysis::check_reference_usable(ref, a.out);
  analysis::write_reference(a.out, ref);
  print_reference_summary(ref, a.out, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                          cpu_seconds_since(cpu_start));
  return 0;
}

int run_merge(const MergeArgs& a) {
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  if (a.inputs.empty()) throw InputError("normative merge: no reference given");
  io::check_file_roles(a.inputs, {a.out});
  analysis::NormativeReference r = analysis::read_reference(a.inputs[0]);
  for (std::size_t i = 1; i < a.inputs.size(); ++i)
    r = analysis::merge_references(r, analysis::read_reference(a.inputs[i]), "the reference merged so far", a.inputs[i]);
  r.partial = a.partial;
  if (!a.partial) analysis::check_reference_usable(r, a.out);
  analysis::write_reference(a.out, r);
  print_reference_summary(r, a.out, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                          cpu_seconds_since(cpu_start));
  return 0;
}

// An element label file written by `authalic elements` or `run` records its grid and hemisphere:
// one of another K, domain or hemisphere would put every vertex's z on the wrong element.
void check_element_label_fits(const std::string& path, const analysis::NormativeReference& ref, const std::string& hemisphere) {
  const std::map<std::string, std::string> meta = io::read_per_vertex_metadata(path);
  auto recorded = [&](const char* key) {
    const auto it = meta.find(key);
    return it == meta.end() ? std::string() : it->second;
  };
  const std::string k = recorded("k"), domain = recorded("domain"), structure = recorded("AnatomicalStructurePrimary");
  const std::string grid = to_string(ref.grid.domain);
  if ((!k.empty() && k != std::to_string(ref.grid.k)) || (!domain.empty() && domain != grid))
    throw InputError(path + ": element labels of a " + (domain.empty() ? std::string("?") : domain) + " grid at K = " +
                     (k.empty() ? std::string("?") : k) + ", but the reference has a " + grid + " grid at K = " +
                     std::to_string(ref.grid.k) + "; give the .label.gii written with the reference's K");
  const std::string expected = hemisphere == "left" ? "CortexLeft" : hemisphere == "right" ? "CortexRight" : "";
  if (!structure.empty() && !expected.empty() && structure != expected)
    throw InputError(path + ": element labels of " + structure + " given for the reference's " + hemisphere +
                     " hemisphere block; give the --labels files in the order of the reference's blocks");
}

int run_compare(const CompareArgs& a) {
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  const analysis::NormativeReference ref = analysis::read_reference(a.reference);
  {
    std::vector<std::string> inputs = {a.reference, a.patient, analysis::element_sidecar_path(a.patient)};
    inputs.insert(inputs.end(), a.labels.begin(), a.labels.end());
    io::check_file_roles(inputs, analysis::comparison_output_paths(a.prefix, ref.hemispheres, std::vector<bool>(a.labels.size(), true)).all());
  }
  const analysis::ElementTable patient = analysis::read_element_table(a.patient);
  analysis::CompareOptions o;
  o.reference_name = a.reference;
  o.patient_name = a.patient;
  o.threshold = a.threshold;
  o.age = a.age;
  o.use_age = !a.no_age;
  o.predictive = !a.plain_sd;
  o.rescale = !a.no_rescale;
  o.min_subjects = a.min_subjects;
  analysis::Comparison cmp = analysis::compare_to_reference(ref, patient, o);
  const int dropped = analysis::drop_small_clusters(cmp, a.min_cluster);
  if (!a.labels.empty() && a.labels.size() != ref.hemispheres.size())
    throw InputError("--labels: " + std::to_string(a.labels.size()) + " label file(s) for " + std::to_string(ref.hemispheres.size()) +
                     " hemisphere block(s); give one per block, in the order " + [&] {
                       std::string s;
                       for (const auto& h : ref.hemispheres) s += (s.empty() ? "" : ", ") + h;
                       return s;
                     }());
  std::vector<VectorXi> vertex_elements;
  for (std::size_t i = 0; i < a.labels.size(); ++i) {
    const std::string& path = a.labels[i];
    check_element_label_fits(path, ref, ref.hemispheres[i]);
    const VectorXd keys = io::read_per_vertex(path);
    VectorXi ve(keys.size());
    for (Eigen::Index v = 0; v < keys.size(); ++v) {
      const double k = keys(v);
      if (!(k >= 0 && k <= ref.grid.num_elements() && k == std::floor(k)))
        throw InputError(path + ": vertex " + std::to_string(v) + " has label " + std::to_string(k) + ", not an element of a " +
                         std::to_string(ref.grid.rows) + " x " + std::to_string(ref.grid.cols) +
                         " grid; give the .label.gii written by `authalic elements` at this K");
      ve(v) = static_cast<int>(k) - 1;
    }
    vertex_elements.push_back(ve);
  }
  const auto paths = analysis::write_comparison_outputs(a.prefix, ref, a.reference, patient, a.patient, cmp, vertex_elements);
  for (const auto& n : cmp.notes) info("authalic normative compare: note: " + n);
  if (dropped > 0)
    info("authalic normative compare: " + std::to_string(dropped) + " cluster(s) of fewer than " + std::to_string(a.min_cluster) +
         " elements not reported (--min-cluster)");
  if (!cmp.chance_note.empty()) info("authalic normative compare: note: clusters have no p: " + cmp.chance_note);
  info("authalic normative compare: " + std::to_string(cmp.num_compared) + " elements compared, " + std::to_string(cmp.num_hypo) +
       " hypo and " + std::to_string(cmp.num_hyper) + " hyper at |z| >= " + std::to_string(cmp.threshold) + ", " +
       std::to_string(cmp.clusters.size()) + " cluster(s); wrote " + paths.summary_json);
  if (global_options().json) {
    auto j = nlohmann::json::parse(analysis::comparison_summary_json(ref, a.reference, patient, a.patient, cmp, paths));
    j["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    j["cpu_seconds"] = cpu_seconds_since(cpu_start);
    std::cout << j.dump(2) << '\n';
  }
  return 0;
}

const bool registered = register_command({50, [](CLI::App& parent) {
  CLI::App* sub = parent.add_subcommand(
      "normative",
      "Normative reference of equal-area elements from control subjects (per element n, mean, SD by Welford; linear "
      "age model when every control has an age), exact merging of references built separately, and comparison of a "
      "patient: z = (patient - expected) / SD (hypometabolism negative), abnormal at |z| >= threshold, clusters of "
      "touching abnormal elements, each with p against the controls' chance clusters (every control compared with the "
      "others; the reference keeps each control's element values for it).");
  sub->require_subcommand(1);

  auto b = std::make_shared<BuildArgs>();
  CLI::App* build = sub->add_subcommand("build", "Build a reference (JSON) from element tables (*_elements.tsv, or .csv, with their .json sidecars)");
  build->add_option("OUT", b->out, "Output reference (.json)")->required();
  build->add_option("TABLES", b->tables, "Element tables of the control subjects");
  build->add_option("--list", b->list, "Text file with one element-table path a line (for large cohorts)");
  build->add_flag("--partial", b->partial,
                  "A partial reference for a later `normative merge` (e.g. one per control in a workflow): fewer than 3 "
                  "controls allowed; `compare` refuses it until it is merged into a full one");
  add_common_options(*build);
  build->callback([b]() { set_exit_code(run_build(*b)); });

  auto m = std::make_shared<MergeArgs>();
  CLI::App* merge = sub->add_subcommand("merge", "Merge references exactly (same domain, K, hemispheres, normalisation; disjoint subjects)");
  merge->add_option("OUT", m->out, "Output reference (.json)")->required();
  merge->add_option("REFERENCES", m->inputs, "References to merge")->required();
  merge->add_flag("--partial", m->partial, "The result is again a partial reference (hierarchical merges)");
  add_common_options(*merge);
  merge->callback([m]() { set_exit_code(run_merge(*m)); });

  auto c = std::make_shared<CompareArgs>();
  CLI::App* compare = sub->add_subcommand(
      "compare",
      "Compare a patient's element table with a reference. Writes OUT_PREFIX_z.nii.gz, OUT_PREFIX_z.png, "
      "OUT_PREFIX_abnormal.csv, OUT_PREFIX.json and, with --labels, per-vertex z as OUT_PREFIX[_<hemisphere>]_z.func.gii. "
      "Each cluster gets p_controls = (1 + controls whose largest cluster of its direction has at least its mass, the sum of "
      "|z| - threshold) / (1 + controls), every control compared with the others (references built before 2026-12-07 "
      "keep no control values: no p).");
  compare->add_option("REFERENCE", c->reference, "Normative reference (.json)")->required();
  compare->add_option("PATIENT", c->patient, "Patient's element table (.tsv or .csv with its .json sidecar)")->required();
  compare->add_option("OUT_PREFIX", c->prefix, "Output prefix")->required();
  compare->add_option("--threshold", c->threshold, "|z| at or beyond which an element is abnormal")
      ->check(in_range(0.5, 10))
      ->capture_default_str();
  compare->add_option("--labels", c->labels,
                      "Element label file(s) (.label.gii from `authalic elements`), one per hemisphere block in the "
                      "reference's order, for per-vertex z");
  compare->add_option("--age", c->age, "Patient's age in years (default: from the table)")->check(age_years());
  compare->add_flag("--no-age", c->no_age, "Ignore the reference's age model");
  compare->add_flag("--plain-sd", c->plain_sd,
                    "z in units of the reference SD itself (NEUROSTAT/3D-SSP) instead of the predictive SD of a new control "
                    "(SD x sqrt(1 + 1/n [+ age term]); default, calibrated for small references)");
  compare->add_flag("--no-rescale", c->no_rescale,
                    "Compare the table's values as they are. Default: first rescale them by the one factor that best fits "
                    "the reference over the elements found normal (|z| < threshold), so a focal hypometabolism, which "
                    "lowers the global mean, does not make healthy cortex look hypermetabolic");
  compare->add_option("--min-subjects", c->min_subjects, "Elements with fewer controls get no z")
      ->check(in_range(2, 1000000))
      ->capture_default_str();
  compare->add_option("--min-cluster", c->min_cluster,
                      "Smallest cluster of abnormal elements reported, in elements (default 1, every cluster; `run` and "
                      "`group` report from 3)")
      ->check(in_range(1, 100000));
  add_common_options(*compare);
  compare->callback([c]() { set_exit_code(run_compare(*c)); });
}});

}  // namespace
}  // namespace authalic::app

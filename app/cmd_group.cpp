// authalic group: the per-subject pipeline for a whole cohort on one machine, then the normative
// reference from its controls, then the patients' comparisons with it.
//
// Each subject runs as a child `authalic run` process: at most --jobs at once (bounded threads and
// memory), and a subject that fails (bad file, crash, out of memory) is reported with its log while
// the others go on. For cohorts beyond one machine, workflow/Snakefile runs the same steps as
// independent jobs.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "app/cohort.h"
#include "analysis/normative.h"
#include "analysis/pipeline.h"
#include "app/command.h"
#include "core/error.h"
#include "io/atomic_file.h"

extern char** environ;
namespace fs = std::filesystem;

namespace authalic::app {
namespace {

struct Job {
  std::string id;
  std::vector<std::string> argv;
  std::string log;
  pid_t pid = -1;
  int exit_code = -1;
  double seconds = 0;
  std::chrono::steady_clock::time_point start;
};

std::string self_executable() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw ProcessingError("cannot locate the authalic executable (/proc/self/exe): " + ec.message());
  return p.string();
}

pid_t spawn_logged(const std::vector<std::string>& argv, const std::string& log_path) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  // The child ends with this process however it ends (kill -9 included): main() reads this
  // variable and asks the kernel for SIGTERM on its parent's death (app/main.cpp).
  std::vector<std::string> env_strings;
  for (char** e = environ; *e != nullptr; ++e)
    if (std::strncmp(*e, kParentPidVariable, std::strlen(kParentPidVariable)) != 0) env_strings.emplace_back(*e);
  env_strings.push_back(std::string(kParentPidVariable) + "=" + std::to_string(::getpid()));
  std::vector<char*> env;
  for (auto& s : env_strings) env.push_back(s.data());
  env.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), env.data());
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw ProcessingError("cannot start " + argv[0] + ": " + std::strerror(rc));
  return pid;
}

std::string last_line(const std::string& path) {
  std::ifstream in(path);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

// Runs the jobs with at most `parallel` at once; returns when all ended. Progress on the terminal.
void run_jobs(std::vector<Job>& jobs, int parallel, const std::string& stage, const ProgressFn& progress) {
  std::size_t next = 0, done = 0;
  std::map<pid_t, std::size_t> running;
  while (done < jobs.size()) {
    while (next < jobs.size() && static_cast<int>(running.size()) < parallel) {
      Job& j = jobs[next];
      j.start = std::chrono::steady_clock::now();
      j.pid = spawn_logged(j.argv, j.log);
      running[j.pid] = next++;
    }
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, 0);
    if (pid < 0) break;
    auto it = running.find(pid);
    if (it == running.end()) continue;
    Job& j = jobs[it->second];
    running.erase(it);
    j.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - j.start).count();
    j.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    ++done;
    report(progress, stage, double(done) / jobs.size(),
           "sub-" + j.id + (j.exit_code == 0 ? " done" : " FAILED (exit " + std::to_string(j.exit_code) + ")"));
    if (j.exit_code != 0 && !global_options().json)
      std::cerr << "\nauthalic group: sub-" << j.id << " failed (exit " << j.exit_code << "): " << last_line(j.log)
                << " [log: " << j.log << "]\n";
  }
}

struct GroupArgs {
  std::string cohort, out;
  int jobs = 2;
  int k = 32;
  bool force = false;
  // Passed to every subject's `run` (see `authalic run --help`).
  std::string normalize = "global";
  double threshold = 2.0;
  int min_cluster = 3;
  bool rectangle = true, rescale = true;
  std::string normative;  // an existing reference for the patients: none is built from the controls
  std::string atlas;      // run --atlas: atlas correspondence for subjects with sphere.reg columns
  bool check = false;     // only check the cohort and the options; write nothing
};

// The options of `run` that `group` passes on, as arguments.
std::vector<std::string> run_options(const GroupArgs& a) {
  std::ostringstream t;
  t << a.threshold;
  std::vector<std::string> o = {"--normalize", a.normalize, "--threshold", t.str(), "--min-cluster", std::to_string(a.min_cluster)};
  if (!a.rectangle) o.push_back("--no-rectangle");
  if (!a.rescale) o.push_back("--no-rescale");
  if (!a.atlas.empty()) o.insert(o.end(), {"--atlas", a.atlas});
  return o;
}

std::vector<std::string> subject_args(const std::string& exe, const CohortSubject& s, int k, int threads,
                                      const std::string& out) {
  std::vector<std::string> args = {exe, "run", "--id", s.id, "--lh-white", s.lh_white, "--lh-pial", s.lh_pial, "--rh-white", s.rh_white,
          "--rh-pial", s.rh_pial, "--lh-cortex", s.lh_cortex, "--rh-cortex", s.rh_cortex, "--pet", s.pet,
          "--k", std::to_string(k), "--threads", std::to_string(threads), "--out", out, "--force"};  // progress lines into the log
  if (s.age > 0) args.insert(args.end(), {"--age", std::to_string(s.age)});  // unknown: left out
  if (!s.t1.empty()) args.insert(args.end(), {"--t1", s.t1});                // the PET is registered to it
  if (!s.sex.empty()) args.insert(args.end(), {"--sex", s.sex});
  if (!s.lh_sphere_reg.empty()) args.insert(args.end(), {"--lh-sphere-reg", s.lh_sphere_reg});
  if (!s.rh_sphere_reg.empty()) args.insert(args.end(), {"--rh-sphere-reg", s.rh_sphere_reg});
  return args;
}

// How a subject's elements correspond to others' (analysis::correspondence_mode), in words.
std::string describe_mode(const std::string& mode) {
  const std::string kind = mode.substr(0, mode.find(' '));
  if (kind == "atlas") return "atlas correspondence through sphere.reg (" + mode + ")";
  if (kind == "registration") return "registration to the atlas map without sphere.reg (" + mode + ")";
  return mode + " correspondence (no --atlas)";
}

// The cohort and the options checked together before any folder or map: the correspondence mode
// of every subject (a reference refuses to mix modes, which otherwise showed only after every
// control had been mapped) and, with --normative, the given reference (its K, normalisation,
// mode, and that it is a complete one). Returns the given reference's controls (0: none given).
int check_cohort(const GroupArgs& a, const std::vector<CohortSubject>& subjects) {
  const std::string where = a.cohort + ":";
  analysis::RunOptions run_options;
  run_options.atlas_dir = a.atlas;
  std::vector<std::string> modes;
  for (const auto& s : subjects) {
    // With --atlas, one sphere.reg alone would silently map both hemispheres by registration.
    if (!a.atlas.empty() && s.lh_sphere_reg.empty() != s.rh_sphere_reg.empty())
      throw InputError(where + std::to_string(s.line) + ": subject '" + s.id + "' has " +
                       (s.lh_sphere_reg.empty() ? "rh_sphere_reg but no lh_sphere_reg" : "lh_sphere_reg but no rh_sphere_reg") +
                       "; give both (atlas correspondence) or neither (registration to the atlas map)");
    analysis::SubjectInputs in;
    in.lh_sphere_reg = s.lh_sphere_reg;
    in.rh_sphere_reg = s.rh_sphere_reg;
    modes.push_back(analysis::correspondence_mode(in, run_options));
  }
  if (a.normative.empty()) {
    // The reference is built from the controls: too few and every subject would run for nothing.
    const auto controls = std::count_if(subjects.begin(), subjects.end(), [](const CohortSubject& s) { return s.role == "control"; });
    if (controls < analysis::kMinControls)
      throw InputError(a.cohort + ": " + std::to_string(controls) + " control(s); a reference needs at least " +
                       std::to_string(analysis::kMinControls) + ": add controls, or give an existing reference (--normative)");
    // Every subject in the mode of the first control (the reference gets the controls' mode).
    const std::size_t first = static_cast<std::size_t>(
        std::find_if(subjects.begin(), subjects.end(), [](const CohortSubject& s) { return s.role == "control"; }) - subjects.begin());
    for (std::size_t i = 0; i < subjects.size(); ++i)
      if (modes[i] != modes[first])
        throw InputError(where + std::to_string(subjects[i].line) + ": subject '" + subjects[i].id + "' would be mapped in " +
                         describe_mode(modes[i]) + " but control '" + subjects[first].id + "' (line " +
                         std::to_string(subjects[first].line) + ") in " + describe_mode(modes[first]) +
                         "; a reference cannot mix modes: give every row both lh_sphere_reg and rh_sphere_reg, or none");
    return 0;
  }
  const analysis::NormativeReference ref = analysis::read_reference(a.normative);
  if (ref.partial)
    throw InputError(a.normative + ": is a partial reference (" + std::to_string(ref.subjects.size()) +
                     " control(s), from `normative build --partial`) meant for merging; merge it with the others "
                     "(authalic normative merge) before giving it to --normative");
  analysis::check_reference_usable(ref, a.normative);
  const std::string normalisation = a.normalize == "none" || a.normalize == "global" ? a.normalize : "reference-region";
  if (ref.normalisation != normalisation)
    throw InputError(a.normative + ": the reference's values are normalised '" + ref.normalisation + "' but the subjects' would be '" +
                     normalisation + "' (--normalize " + a.normalize + "); give the reference's --normalize or another reference");
  if (ref.grid.domain.kind != DomainKind::Square || ref.grid.k != a.k)
    throw InputError(a.normative + ": the reference has " + to_string(ref.grid.domain) + " K = " + std::to_string(ref.grid.k) +
                     " elements but the subjects would get square K = " + std::to_string(a.k) + "; give --k " +
                     std::to_string(ref.grid.k) + " or a reference built with K = " + std::to_string(a.k));
  for (std::size_t i = 0; i < subjects.size(); ++i)
    if (subjects[i].role == "patient" && modes[i] != ref.correspondence)
      throw InputError(where + std::to_string(subjects[i].line) + ": patient '" + subjects[i].id + "' would be mapped in " +
                       describe_mode(modes[i]) + " but the reference " + a.normative + " was built in " +
                       describe_mode(ref.correspondence) + "; run in the reference's mode (--atlas and the sphere_reg "
                       "columns) or give a reference built in this one");
  return static_cast<int>(ref.subjects.size());
}

// group --check: the cohort as read, for workflow/Snakefile (which then needs no CSV reader of its
// own, and refuses exactly what `group` refuses).
nlohmann::json cohort_json(const std::vector<CohortSubject>& subjects) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& s : subjects) {
    nlohmann::json j = {{"id", s.id},           {"role", s.role},         {"line", s.line},
                        {"pet", s.pet},         {"lh_white", s.lh_white}, {"lh_pial", s.lh_pial},
                        {"rh_white", s.rh_white}, {"rh_pial", s.rh_pial}, {"lh_cortex", s.lh_cortex},
                        {"rh_cortex", s.rh_cortex}};
    j["age"] = s.age > 0 ? nlohmann::json(s.age) : nlohmann::json();  // null: unknown
    for (const auto& [key, value] : {std::pair<const char*, const std::string*>{"t1", &s.t1}, {"sex", &s.sex},
                                     {"lh_sphere_reg", &s.lh_sphere_reg}, {"rh_sphere_reg", &s.rh_sphere_reg}})
      if (!value->empty()) j[key] = *value;
    list.push_back(std::move(j));
  }
  return list;
}

// OUT/participants.tsv (+ .json describing the columns), as a BIDS dataset lists its subjects:
// one row per cohort subject in cohort order, with where its outputs are and whether it ran.
// not_run: the status of a subject that was not run (a patient without a reference).
void write_participants(const std::string& out, const std::vector<CohortSubject>& subjects, const std::vector<Job>& controls,
                        const std::vector<Job>& patients, const std::string& not_run) {
  std::map<std::string, int> exit_code;
  for (const auto* group : {&controls, &patients})
    for (const auto& j : *group) exit_code[j.id] = j.exit_code;
  std::string tsv = "participant_id\tgroup\tage\tsex\tfolder\tstatus\n";
  for (const auto& s : subjects) {
    char age[32] = "n/a";
    if (s.age > 0) std::snprintf(age, sizeof(age), "%g", s.age);
    const int code = exit_code.count(s.id) ? exit_code[s.id] : -1;
    // A subject's folder appears only when its run completed (a failed one has none to point to).
    tsv += "sub-" + s.id + "\t" + s.role + "\t" + age + "\t" + (s.sex.empty() ? "n/a" : s.sex) + "\t" +
           (code == 0 ? analysis::SubjectFiles{s.id}.folder() : "n/a") + "\t" +
           (code == 0    ? "ok"
            : code == -1 ? not_run
                         : "failed (exit " + std::to_string(code) + ", see logs/" + s.id + ".log)") +
           "\n";
  }
  io::write_file_atomically((fs::path(out) / "participants.tsv").string(), tsv);
  const nlohmann::json columns = {
      {"participant_id", {{"Description", "sub-<subject_id of the cohort CSV>"}}},
      {"group", {{"Description", "role in the cohort"}, {"Levels", {{"control", "in the normative reference"}, {"patient", "compared with it"}}}}},
      {"age", {{"Description", "age at the scan"}, {"Units", "year"}}},
      {"sex", {{"Description", "sex as given in the cohort CSV"}, {"Levels", {{"F", "female"}, {"M", "male"}, {"O", "other"}}}}},
      {"folder", {{"Description", "the subject's outputs (authalic run), relative to this file; n/a when it did not run to the end"}}},
      {"status", {{"Description", "ok; failed, with run's exit code and the log to read; or not run (a patient when no "
                                  "reference could be built), with the reason"}}}};
  io::write_file_atomically((fs::path(out) / "participants.json").string(), columns.dump(2) + "\n");
}

int run_group(const GroupArgs& a) {
  const auto subjects = read_cohort(a.cohort);
  const int reference_controls = check_cohort(a, subjects);
  if (a.check) {
    const auto controls = std::count_if(subjects.begin(), subjects.end(), [](const CohortSubject& s) { return s.role == "control"; });
    if (global_options().json)
      std::cout << nlohmann::json{{"cohort", a.cohort}, {"subjects", cohort_json(subjects)}}.dump(2) << '\n';
    info("authalic group --check: " + a.cohort + ": " + std::to_string(controls) + " controls and " +
         std::to_string(subjects.size() - static_cast<std::size_t>(controls)) + " patients, ready to run");
    return 0;
  }
  if (fs::exists(a.out) && !fs::is_empty(a.out) && !a.force)
    throw InputError(a.out + ": output folder exists and is not empty; choose another or pass --force");
  fs::create_directories(fs::path(a.out) / "logs");
  const std::string exe = self_executable();
  // The threads to share: --threads when given (0: all cores), bounded: jobs x threads <= that.
  const int cores = global_options().threads > 0 ? global_options().threads
                                                 : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int parallel = std::max(1, a.jobs);
  const int threads = std::max(1, cores / parallel);
  const ProgressFn progress = terminal_progress();

  // Every subject's folder at the top of OUT (BIDS: OUT/sub-<id>/); participants.tsv gives each one's group.
  auto make_jobs = [&](const std::string& role, const std::vector<std::string>& extra) {
    std::vector<Job> jobs;
    for (const auto& s : subjects) {
      if (s.role != role) continue;
      Job j;
      j.id = s.id;
      j.argv = subject_args(exe, s, a.k, threads, a.out);
      const std::vector<std::string> options = run_options(a);
      j.argv.insert(j.argv.end(), options.begin(), options.end());
      j.argv.insert(j.argv.end(), extra.begin(), extra.end());
      j.log = (fs::path(a.out) / "logs" / (s.id + ".log")).string();
      jobs.push_back(std::move(j));
    }
    return jobs;
  };

  // 1. Controls: maps, sampling, elements.
  std::vector<Job> controls = make_jobs("control", {});
  info("authalic group: " + std::to_string(controls.size()) + " controls, " + std::to_string(parallel) +
       " at once, " + std::to_string(threads) + " threads each");
  run_jobs(controls, parallel, "controls", progress);

  // 2. Reference from the controls that succeeded.
  std::vector<std::string> build = {exe, "normative", "build", (fs::path(a.out) / "normative.json").string()};
  int used = 0;
  for (const auto& j : controls) {
    if (j.exit_code != 0) continue;
    const analysis::SubjectFiles names{j.id};
    build.push_back((fs::path(a.out) / names.folder() / names.element_table()).string());
    ++used;
  }
  nlohmann::json summary;
  summary["cohort"] = a.cohort;
  summary["controls_succeeded"] = used;
  int reference_exit = -1;
  if (!a.normative.empty()) {
    reference_exit = 0;  // given: nothing to build
  } else if (used >= analysis::kMinControls) {
    Job ref;
    ref.id = "reference";
    ref.argv = build;
    ref.log = (fs::path(a.out) / "logs" / "normative.log").string();
    std::vector<Job> one{ref};
    run_jobs(one, 1, "reference", progress);
    reference_exit = one[0].exit_code;
  } else {
    std::cerr << "authalic group: only " << used << " controls succeeded; at least " << analysis::kMinControls << " are needed for a reference\n";
  }

  // 3. Patients, compared with the reference. Without one they are not run: a PET-only report
  // marked "ok" read as a comparison that found nothing.
  const std::string reference = a.normative.empty() ? (fs::path(a.out) / "normative.json").string() : a.normative;
  std::vector<Job> patients = make_jobs("patient", {"--normative", reference});
  const std::string not_run = reference_exit < 0 ? "not run: only " + std::to_string(used) + " controls succeeded, a reference needs " +
                                                       std::to_string(analysis::kMinControls)
                                                 : "not run: the reference could not be built (see logs/normative.log)";
  if (reference_exit == 0)
    run_jobs(patients, parallel, "patients", progress);
  else if (!patients.empty())
    std::cerr << "authalic group: " << patients.size() << " patient(s) " << not_run << "\n";

  int failed = 0, not_compared = 0;
  for (const auto* group : {&controls, &patients})
    for (const auto& j : *group) {
      const bool ran = j.exit_code != -1;
      summary["subjects"].push_back({{"id", j.id},
                                     {"role", group == &controls ? "control" : "patient"},
                                     {"status", !ran ? "not run" : j.exit_code == 0 ? "ok" : "failed"},
                                     {"exit_code", ran ? nlohmann::json(j.exit_code) : nlohmann::json()},
                                     {"seconds", j.seconds},
                                     {"log", j.log}});
      failed += ran && j.exit_code != 0;
      not_compared += !ran;
    }
  write_participants(a.out, subjects, controls, patients, not_run);
  // The controls in the reference the patients were compared with (none when there was none).
  summary["reference"] = reference_exit == 0 ? nlohmann::json(reference) : nlohmann::json();
  summary["controls_used"] = !a.normative.empty() ? reference_controls : reference_exit == 0 ? used : 0;
  summary["reference_exit_code"] = reference_exit;
  summary["failed"] = failed;
  summary["not_run"] = not_compared;
  if (global_options().json) std::cout << summary.dump(2) << '\n';
  info("authalic group: " + std::to_string(controls.size() + patients.size() - failed - not_compared) + " subjects done, " +
       std::to_string(failed) + " failed, " + std::to_string(not_compared) + " not run; reference " +
       (!a.normative.empty() ? "given (" + a.normative + ")" : reference_exit == 0 ? "built" : "NOT built"));
  return (failed == 0 && not_compared == 0 && reference_exit == 0) ? 0 : 3;
}

const bool registered = register_command({60, [](CLI::App& parent) {
  auto args = std::make_shared<GroupArgs>();
  CLI::App* sub = parent.add_subcommand(
      "group",
      "Run the per-subject pipeline for a cohort (controls first), build the normative reference from the "
      "controls (or take an existing one, --normative), then compare the patients with it; run's --normalize, "
      "--threshold, --min-cluster, --no-rectangle and --no-rescale apply to every subject. COHORT.csv columns: subject_id,role(control|patient),age,"
      "pet,lh_white,lh_pial,rh_white,rh_pial,lh_cortex,rh_cortex, optional t1 (run --t1: the PET is registered to it), "
      "sex (F, M, O) and lh_sphere_reg, rh_sphere_reg (with --atlas: atlas correspondence) (paths relative to the CSV; RFC 4180 CSV as spreadsheets "
      "write it: quoted fields, CRLF, a UTF-8 byte-order mark). Writes "
      "OUT/sub-<id>/ for every subject (as run writes it), OUT/participants.tsv (+ .json: group, age, sex, folder, status), OUT/normative.json and OUT/logs/<id>.log (each subject's progress and messages). "
      "A failed subject is reported and does not stop the others (exit 3 at the end).");
  sub->add_option("cohort", args->cohort, "Cohort list (CSV)")->required()->check(CLI::ExistingFile);
  sub->add_option("out", args->out, "Output folder")->required();
  sub->add_option("--jobs,-j", args->jobs, "Subjects processed at once (the --threads, or all cores, are shared among them)")
      ->check(in_range(1, 256));
  add_k_option(*sub, args->k, {DomainKind::Square}, 2, 512);
  sub->add_flag("--force", args->force, "Write into an existing output folder");
  sub->add_option("--normalize,--normalise", args->normalize,
                  "Intensity normalisation of every subject, as `run --normalize`: none, global (cortical mean), or a "
                  "reference-region mask NIfTI (SUVR)")
      ->capture_default_str();
  sub->add_option("--threshold", args->threshold, "|z| at or beyond which a patient's element is abnormal")
      ->check(in_range(0.5, 10))
      ->capture_default_str();
  sub->add_option("--min-cluster", args->min_cluster,
                  "Smallest cluster of a patient's abnormal elements reported, in elements, as `run --min-cluster`")
      ->check(in_range(1, 100000))
      ->capture_default_str();
  sub->add_flag("--no-rectangle", [args](std::int64_t) { args->rectangle = false; }, "Skip the whole-brain 2:1 rectangle map of every subject");
  sub->add_flag("--no-rescale", [args](std::int64_t) { args->rescale = false; }, "As `run --no-rescale`, for the patients");
  sub->add_option("--atlas", args->atlas,
                  "As `run --atlas`: atlas folder (FreeSurfer layout); subjects with lh_sphere_reg and rh_sphere_reg "
                  "columns are mapped in atlas correspondence, others registered to the atlas map by sulcal depth (the "
                  "reference records the mode and refuses a subject of another)");
  sub->add_option("--normative", args->normative,
                  "Compare the patients with this existing reference (authalic normative build) instead of building one "
                  "from the controls; its K, normalisation and correspondence mode must match (checked before any map)")
      ->check(CLI::ExistingFile);
  sub->add_flag("--check", args->check,
                "Only check COHORT.csv and the options (ids, ages, files, correspondence modes, --normative) as a run would, "
                "and write nothing (OUT may exist); with --json print the subjects as read, with absolute paths "
                "(workflow/Snakefile reads its cohort this way)");
  add_common_options(*sub);
  sub->callback([args]() { set_exit_code(run_group(*args)); });
}});

}  // namespace
}  // namespace authalic::app

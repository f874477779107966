// authalic: area-preserving cortical maps and PET quantification. One executable, subcommands.
#include <omp.h>
#include <malloc.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <string>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <thread>
#include <utility>
#include <iostream>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/command.h"
#include "core/error.h"
#include "core/version.h"

namespace authalic::app {

namespace {
std::vector<Command>& registry() {
  static std::vector<Command> commands;
  return commands;
}
int g_exit_code = 0;
}  // namespace

bool register_command(const Command& command) {
  registry().push_back(command);
  return true;
}

GlobalOptions& global_options() {
  static GlobalOptions options;
  return options;
}

// Shortest text that reads back as x, without an exponent for ordinary magnitudes.
std::string plain_number(double x) {
  char buf[32];
  for (int p = 1; p <= 17; ++p) {
    std::snprintf(buf, sizeof buf, "%.*g", p, x);
    const bool exponent_ok = x != 0 && (std::abs(x) >= 1e7 || std::abs(x) < 1e-4);
    if (std::strtod(buf, nullptr) == x && (exponent_ok || std::strchr(buf, 'e') == nullptr)) break;
  }
  return buf;
}

CLI::Validator in_range(double lo, double hi) {
  const std::string range = plain_number(lo) + " to " + plain_number(hi);
  return CLI::Validator(
      [lo, hi, range](std::string& value) -> std::string {
        char* end = nullptr;
        const double x = std::strtod(value.c_str(), &end);
        if (value.empty() || end != value.c_str() + value.size() || !(x >= lo && x <= hi))
          return "'" + value + "' is not a number from " + range;
        return {};
      },
      "[" + range + "]");
}

void require_gifti_map_output(const std::string& path, const std::string& option) {
  if (path.empty()) return;
  std::string lower = path;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower.size() >= 4 && lower.compare(lower.size() - 4, 4, ".gii") == 0) return;
  throw InputError(option + " " + path + ": a map is written as GIFTI, whose metadata records the vertices it appended (other "
                   "formats drop that record, and `metrics` and `elements` then misplace them); give a name ending in .surf.gii");
}

CLI::Option* add_k_option(CLI::App& sub, int& k, const std::vector<DomainKind>& kinds, int lo, int hi) {
  std::string grids;
  for (const DomainKind kind : kinds) {
    const Domain d = Domain::of(kind);
    grids += std::string(grids.empty() ? "" : ", ") + (d.element_cols(2) == 2 ? "K x K" : "2K x K") + " on the " + to_string(kind);
  }
  return sub.add_option("--k", k, "Element grid K (" + grids + ")")->check(in_range(lo, hi))->capture_default_str();
}

double parse_age(const std::string& text, const std::string& where) {
  errno = 0;
  char* end = nullptr;
  const double age = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(age))
    throw InputError((where.empty() ? "" : where + ": ") + "age '" + text + "' is not a number of years");
  if (!(age > 0) || age > 130)
    throw InputError((where.empty() ? "" : where + ": ") + "age " + text +
                     " is outside 0 (exclusive) to 130 years; an unknown age is left out, not given as 0");
  return age;
}

std::string parse_sex(const std::string& text, const std::string& where) {
  std::string t;
  for (char c : text) t += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (t == "f" || t == "female") return "F";
  if (t == "m" || t == "male") return "M";
  if (t == "o" || t == "other") return "O";
  throw InputError((where.empty() ? "" : where + ": ") + "sex '" + text + "' is not F, M or O (female, male, other); leave it out when unknown");
}

CLI::Validator sex_letter() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        try {
          value = parse_sex(value, "");
        } catch (const InputError& e) {
          return e.what();
        }
        return {};
      },
      "F|M|O");
}

CLI::Validator age_years() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        try {
          parse_age(value, "");
        } catch (const InputError& e) {
          return e.what();
        }
        return {};
      },
      "YEARS (0-130]");
}

// Every option's default in its --help line ("--k INT=32"), also where the command did not ask
// for it. A value that stands for "not given" (-1, nan, an age of 0, an empty list) fails the
// option's own check or is empty: it is not shown, the help text says what happens then.
static bool is_valid_value(CLI::Option& option, const std::string& value) {
  for (int i = 0;; ++i) {
    CLI::Validator* check = nullptr;
    try {
      check = option.get_validator(i);
    } catch (const CLI::OptionNotFound&) {
      return true;
    }
    if (!(*check)(value).empty()) return false;
  }
}

static void show_defaults(CLI::App& command) {
  for (CLI::Option* o : command.get_options()) {
    if (o->get_type_size() == 0) continue;  // a flag
    o->capture_default_str();
    const std::string value = o->get_default_str();
    if (value == "[]" || !is_valid_value(*o, value)) o->default_str("");
  }
  for (CLI::App* sub : command.get_subcommands([](CLI::App*) { return true; })) show_defaults(*sub);
}

void add_common_options(CLI::App& sub) {
  auto& g = global_options();
  sub.add_flag("--quiet,-q", g.quiet, "No progress or informational output");
  sub.add_flag("--json", g.json, "Print a machine-readable JSON summary on stdout");
  sub.add_option("--threads", g.threads, "OpenMP threads (0 = all cores, at most 256); results do not depend on it")
      ->check(in_range(0, 256))
      ->each([](const std::string& value) {
        const int n = std::stoi(value);
        if (n > 0) omp_set_num_threads(n);
      });
}

void info(const std::string& line) {
  if (global_options().quiet || global_options().json) return;
  std::cerr << line << '\n';
}

ProgressFn terminal_progress() {
  const auto& g = global_options();
  if (g.quiet || g.json) return {};
  if (!::isatty(STDERR_FILENO)) {
    // Not a terminal (a log file, a pipe): one line per step that says something, no bar.
    return [](const std::string& stage, double, const std::string& message) {
      if (!message.empty()) std::fprintf(stderr, "%s: %s\n", stage.c_str(), message.c_str());
    };
  }
  return [](const std::string& stage, double fraction, const std::string& message) {
    if (fraction >= 0) {
      const int width = 30;
      const int done = std::clamp(static_cast<int>(fraction * width + 0.5), 0, width);
      std::fprintf(stderr, "\r%-10s [%s%s] %3.0f%% %-50.50s", stage.c_str(), std::string(done, '#').c_str(),
                   std::string(width - done, ' ').c_str(), 100.0 * fraction, message.c_str());
      if (fraction >= 1.0) std::fputc('\n', stderr);
    } else {
      std::fprintf(stderr, "\r%-10s %-70.70s", stage.c_str(), message.c_str());
    }
    std::fflush(stderr);
  };
}

struct StageClock::State {
  ProgressFn inner;
  std::map<std::string, double> seconds;
  std::string stage;
  std::chrono::steady_clock::time_point since;
  void lap(const std::string& next) {
    const auto now = std::chrono::steady_clock::now();
    if (!stage.empty()) seconds[stage] += std::chrono::duration<double>(now - since).count();
    stage = next;
    since = now;
  }
};

StageClock::StageClock(ProgressFn inner) : state_(std::make_shared<State>()) { state_->inner = std::move(inner); }

ProgressFn StageClock::progress() {
  return [s = state_](const std::string& stage, double fraction, const std::string& message) {
    s->lap(stage);
    if (s->inner) s->inner(stage, fraction, message);
  };
}

void StageClock::stop() { state_->lap({}); }

double StageClock::seconds(const std::string& stage) const {
  const auto it = state_->seconds.find(stage);
  return it == state_->seconds.end() ? 0.0 : it->second;
}

void set_exit_code(int code) { g_exit_code = code; }

}  // namespace authalic::app

namespace {

// The --threads a command line asks for (0: none, or 0 = all cores), read before CLI11 parses it.
int requested_threads(char** argv) {
  int threads = 0;
  for (int i = 1; argv[i] != nullptr && std::strcmp(argv[i], "--") != 0; ++i) {
    const char* value = nullptr;
    if (std::strcmp(argv[i], "--threads") == 0)
      value = argv[i + 1];
    else if (std::strncmp(argv[i], "--threads=", 10) == 0)
      value = argv[i] + 10;
    if (value != nullptr) threads = std::max(0, std::atoi(value));
  }
  return threads;
}

// Settings read by libraries when they are loaded, before main, so the process executes itself
// once more with them in its environment (a setting the user made is kept; if the exec fails, the
// run goes on with the defaults):
// - OMP_WAIT_POLICY=passive: OpenMP's default spins idle threads before they sleep; on a loaded
//   2-core machine that made 2 threads 1.23x slower than 1 (fs741 lh.white cortex map, wall, 3
//   paired runs), with "passive" 2 threads take 0.96x the time of 1 (bench/bench_threads.sh).
// - glibc.malloc.hugetlb=1: malloc asks for transparent huge pages (madvise), so the mesh-sized
//   arrays take a tenth of the page faults and TLB misses (B3, 150k vertices: 0.91x the CPU time,
//   4 paired runs); a glibc without the tunable ignores it.
// - OMP_THREAD_LIMIT = --threads (else the cores): CHOLMOD's supernodal factorisation opens
//   OpenMP regions of a fixed 4 threads (its build's CHOLMOD_OMP_NUM_THREADS, not
//   omp_set_num_threads) to clear each supernode, so a --threads 1 map of 600k vertices ran 4
//   threads woken through futexes thousands of times; capped, the same map (same bits) takes
//   0.90x the CPU time (B600, 2 paired runs).
void set_library_environment(char** argv) {
  const int threads = requested_threads(argv);
  const std::string limit = std::to_string(threads > 0 ? threads : std::max(1u, std::thread::hardware_concurrency()));
  bool changed = false;
  for (const auto& [name, value] : {std::pair<const char*, const char*>{"OMP_WAIT_POLICY", "passive"},
                                    std::pair<const char*, const char*>{"GLIBC_TUNABLES", "glibc.malloc.hugetlb=1"},
                                    std::pair<const char*, const char*>{"OMP_THREAD_LIMIT", limit.c_str()}}) {
    if (std::getenv(name) != nullptr) continue;
    if (::setenv(name, value, 1) != 0) return;
    changed = true;
  }
  if (changed) ::execv("/proc/self/exe", argv);
}

// glibc hands large blocks back to the kernel when they are freed (above 128 kB they are mapped
// and unmapped; the top of the heap is trimmed), so the next array of that size page-faults
// afresh: a map builds and drops arrays of the mesh's size many times over (B3, 150k vertices:
// 0.9 s of system time). Keeping freed memory for reuse costs a few per cent of peak memory.
void keep_freed_memory() {
  ::mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest
  ::mallopt(M_TRIM_THRESHOLD, 1 << 30);
  ::mallopt(M_TOP_PAD, 64 << 20);
}

// Edit distance (Levenshtein) between two names, for "did you mean".
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

// "; did you mean X?" for the closest of `names` within 2 edits of `typed`, else "".
std::string did_you_mean(const std::string& typed, const std::vector<std::string>& names) {
  std::string best;
  std::size_t best_distance = 3;
  for (const std::string& n : names)
    if (const std::size_t d = edit_distance(typed, n); d < best_distance) best = n, best_distance = d;
  return best.empty() ? "" : "; did you mean " + best + "?";
}

// A mistyped subcommand or option, named, before CLI11 parses: CLI11 reports the first problem it
// meets in its own order, so `authalic flaten x y` said "A subcommand is required" and
// `run --outt x` "--out is required". Walks the subcommands named on the line; tokens after "--",
// short options, negative numbers and names like "-x.gii" (a file: main's hint) are left to CLI11.
std::string mistyped_argument(CLI::App& cli, int argc, char** argv) {
  const auto all = [](CLI::App*) { return true; };
  CLI::App* current = &cli;
  std::string path = "authalic";
  bool value_next = false;  // the previous token was an option that takes a value
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") break;
    if (value_next) {
      value_next = false;
      continue;
    }
    if (arg.rfind("--", 0) == 0) {
      const std::string name = arg.substr(0, arg.find('='));
      if (name.find_first_of("./") != std::string::npos) continue;
      const CLI::Option* option = current->get_option_no_throw(name);
      if (option == nullptr) {
        std::vector<std::string> names;
        for (const CLI::Option* o : current->get_options())
          for (const std::string& l : o->get_lnames()) names.push_back("--" + l);
        return path + ": unknown option " + name + did_you_mean(name, names) + " (see " + path + " --help)";
      }
      value_next = arg.find('=') == std::string::npos && option->get_type_size() > 0;
      continue;
    }
    if (arg.rfind('-', 0) == 0) continue;
    const std::vector<CLI::App*> subcommands = current->get_subcommands(all);
    if (subcommands.empty()) continue;  // a positional argument
    // A command with subcommands: this word names one of them.
    CLI::App* next = nullptr;
    std::vector<std::string> names;
    for (CLI::App* sub : subcommands) {
      names.push_back(sub->get_name());
      if (sub->check_name(arg)) next = sub;
    }
    if (next == nullptr)
      return path + ": unknown subcommand '" + arg + "'" + did_you_mean(arg, names) + " (see " + path + " --help)";
    current = next;
    path += " " + arg;
  }
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  using namespace authalic;
  set_library_environment(argv);
  keep_freed_memory();
  if (const char* parent = std::getenv(app::kParentPidVariable)) {
    // Started by `authalic group`: end with it. The check after prctl closes the race of a parent
    // that died before the request was made.
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (std::to_string(::getppid()) != parent) return 3;
  }
  CLI::App cli{"authalic: area-preserving (authalic) maps of the cerebral cortex and equal-area PET "
               "quantification.\nUnits: mm (coordinates), mm^2 (areas). Surfaces are read in their file's space; "
               "FreeSurfer surfaces are tkregister RAS and are moved to scanner RAS with their footer's c_ras."};
  cli.set_version_flag("--version", software_version());
  cli.require_subcommand(1);
  cli.fallthrough(false);
  // Usage errors as one line, like every other refusal.
  // A file name starting with '-' reads as an option: say so when parsing fails.
  static std::string dash_file;
  for (int i = 1; i < argc && dash_file.empty(); ++i) {
    const std::string arg = argv[i];
    if (arg == "--") break;
    if (arg.size() > 1 && arg[0] == '-' && arg.find('=') == std::string::npos && arg.find_first_of("./") != std::string::npos &&
        !std::isdigit(static_cast<unsigned char>(arg[1])))
      dash_file = arg;
  }
  cli.failure_message([](const CLI::App*, const CLI::Error& e) {
    std::string what = e.what();
    if (!dash_file.empty())
      what += "; if " + dash_file + " is a file, a name starting with '-' goes after '--' (authalic CMD [options] -- " + dash_file +
              " ...) or as ./" + dash_file;
    return "authalic: error: " + what + " (see --help)\n";
  });

  for (int i = 0; i < argc; ++i) {
    // Shell-quoted so that the line can be run again as it is.
    const std::string arg = argv[i];
    const bool plain = !arg.empty() && arg.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-./=:,+@%") == std::string::npos;
    std::string quoted = "'";
    for (char c : arg) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
    app::global_options().command_line += (i ? " " : "") + (plain ? arg : quoted + "'");
  }
  auto commands = app::registry();
  std::sort(commands.begin(), commands.end(), [](const app::Command& a, const app::Command& b) { return a.order < b.order; });
  for (const auto& c : commands) c.setup(cli);
  app::show_defaults(cli);

  // --json: a failure is a JSON object on stdout too ({"error", "kind", "exit_code"}), so a script
  // that parses stdout gets one on every exit; the line on stderr is the same.
  const bool json = app::global_options().json || std::any_of(argv + 1, argv + argc, [](const char* a) { return std::string(a) == "--json"; });
  auto fail = [json](const char* kind, const std::string& prefix, const std::string& what, int code) {
    std::cerr << prefix << what << '\n';
    if (json) std::cout << nlohmann::json{{"error", what}, {"kind", kind}, {"exit_code", code}}.dump(2) << '\n';
    return code;
  };
  if (const std::string mistyped = mistyped_argument(cli, argc, argv); !mistyped.empty())
    return fail("usage", "authalic: error: ", mistyped, 2);
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return cli.exit(e);  // --help, --version
    const int code = cli.exit(e);
    if (json) std::cout << nlohmann::json{{"error", e.what()}, {"kind", "usage"}, {"exit_code", 2}}.dump(2) << '\n';
    return code == 0 ? 0 : 2;  // usage errors are bad input
  } catch (const InputError& e) {
    return fail("bad input", "authalic: error: ", e.what(), 2);
  } catch (const ProcessingError& e) {
    return fail("processing failed", "authalic: processing failed: ", e.what(), 3);
  } catch (const std::exception& e) {
    return fail("internal error", "authalic: error: ", e.what(), 3);
  }
  return app::g_exit_code;
}

#pragma once
// Subcommand registry. Each app/cmd_<name>.cpp defines one subcommand and registers it with
//   static const bool registered = authalic::app::register_command({order, setup});
// where setup(CLI::App& parent) adds the subcommand, its options and its callback.
// The callback returns an exit code; errors are thrown (InputError -> 2, ProcessingError -> 3).
#include <CLI/CLI.hpp>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/domain.h"
#include "core/progress.h"

namespace authalic::app {

struct Command {
  int order;  // position in --help
  std::function<void(CLI::App& parent)> setup;
};
bool register_command(const Command& command);

// Options every subcommand shares (set by main before the callback runs).
struct GlobalOptions {
  bool quiet = false;   // no progress, no informational lines
  bool json = false;    // machine-readable summary on stdout
  int threads = 0;      // 0 = OpenMP default
  std::string command_line;  // argv as given, shell-quoted (provenance in sidecars)
};
GlobalOptions& global_options();

// Validator for a number in [lo, hi], with the bounds printed as written ("0.05 to 10", not
// CLI::Range's "0.050000 to 10.000000"); NaN and trailing characters are refused.
CLI::Validator in_range(double lo, double hi);
// Throws InputError unless `path` (when given) names a GIFTI file (.gii): a map's metadata records
// the vertices it appended (corner splits, a cut's copies), which other surface formats drop, and
// `metrics` and `elements` then misplace them. `option` names the output ("OUT", "--uv").
void require_gifti_map_output(const std::string& path, const std::string& option);
// The --k option of every subcommand that builds an element grid: the grid of each domain in
// `kinds` is Domain::element_cols(K) x K (core/domain.h), which the help states; [lo, hi] is the
// command's range (its tables and images grow with K^2).
CLI::Option* add_k_option(CLI::App& sub, int& k, const std::vector<DomainKind>& kinds, int lo = 1, int hi = 1024);

// Validator for ages in years: a plain finite number in (0, 130] ("7O", "nan", "-inf", "-5",
// and 0, which once meant "unknown", are refused, not read as 7 or unknown).
CLI::Validator age_years();
// The same rule for text (a cohort CSV cell); returns the age or throws InputError("<where>: ...").
double parse_age(const std::string& text, const std::string& where);
// Sex as BIDS participants.tsv writes it: F, M or O (female, male, other in any case accepted);
// returns the letter or throws InputError("<where>: ...").
std::string parse_sex(const std::string& text, const std::string& where);
// Validator form of parse_sex for --sex; the value is rewritten to its letter.
CLI::Validator sex_letter();

// Adds --quiet/--json/--threads to a subcommand.
void add_common_options(CLI::App& sub);

// Informational line on stderr (suppressed by --quiet or --json).
void info(const std::string& line);
// A ProgressFn that draws on a terminal (stderr is a tty, not --quiet/--json) and is silent otherwise.
ProgressFn terminal_progress();

// Wall time per progress stage, measured by the caller (core results carry no clock): the time
// from one progress report to the next counts for the stage of the earlier one ("initial",
// "flow", "conformal", ...). progress() forwards every report to `inner`.
class StageClock {
 public:
  explicit StageClock(ProgressFn inner = {});
  ProgressFn progress();
  // Ends the stage running now; seconds(stage) is then final.
  void stop();
  double seconds(const std::string& stage) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// Environment variable `group` sets for its child processes: the parent's pid. A child that sees
// it dies with that parent (prctl PR_SET_PDEATHSIG), so a killed `group` leaves no orphan runs.
inline constexpr const char* kParentPidVariable = "AUTHALIC_PARENT_PID";

// Exit code a subcommand's callback reports to main.
void set_exit_code(int code);

}  // namespace authalic::app

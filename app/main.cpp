// authalic: area-preserving cortical maps and PET quantification. One executable, subcommands.
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <vector>

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

void add_common_options(CLI::App& sub) {
  auto& g = global_options();
  sub.add_flag("--quiet,-q", g.quiet, "No progress or informational output");
  sub.add_flag("--json", g.json, "Print a machine-readable JSON summary on stdout");
  sub.add_option("--threads", g.threads, "OpenMP threads (0 = all cores); results do not depend on it")
      ->check(CLI::NonNegativeNumber)
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

void set_exit_code(int code) { g_exit_code = code; }

}  // namespace authalic::app

int main(int argc, char** argv) {
  using namespace authalic;
  CLI::App cli{"authalic: area-preserving (authalic) maps of the cerebral cortex and equal-area PET "
               "quantification.\nUnits: mm (coordinates), mm^2 (areas). Surfaces are read in their file's space; "
               "FreeSurfer surfaces are tkregister RAS and are moved to scanner RAS with their footer's c_ras."};
  cli.set_version_flag("--version", std::string("authalic ") + kVersion + " (" + kGitRevision + ")");
  cli.require_subcommand(1);
  cli.fallthrough(false);

  auto commands = app::registry();
  std::sort(commands.begin(), commands.end(), [](const app::Command& a, const app::Command& b) { return a.order < b.order; });
  for (const auto& c : commands) c.setup(cli);

  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = cli.exit(e);
    return code == 0 ? 0 : 2;  // usage errors are bad input
  } catch (const InputError& e) {
    std::cerr << "authalic: error: " << e.what() << '\n';
    return 2;
  } catch (const ProcessingError& e) {
    std::cerr << "authalic: processing failed: " << e.what() << '\n';
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "authalic: error: " << e.what() << '\n';
    return 3;
  }
  return app::g_exit_code;
}

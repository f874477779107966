#pragma once
// Access to ../shared/data for tests. Outside CI a missing folder skips the test with a message;
// with CI=true it fails, so CI can never pass by skipping the real-data tests.
#include <gtest/gtest.h>

#include <string>

namespace authalic::test {

// Absolute path of a file under ../shared/data ("" when it is absent).
std::string shared_data(const std::string& relative);
bool running_in_ci();
// A fresh empty temporary directory for one test (removed by the OS tmp cleaner, not by us,
// so a failing test leaves its files for inspection).
std::string temp_dir(const std::string& name);
// Runs a shell command, returns its exit status; stdout+stderr go to *output when given.
int run_command(const std::string& command, std::string* output = nullptr);
// The built `authalic` executable.
std::string authalic_binary();
// `s` single-quoted for sh (inner single quotes escaped), for building command lines.
std::string shell_quote(const std::string& s);
// The built `authalic` executable, shell-quoted.
inline std::string quoted_binary() { return shell_quote(authalic_binary()); }
// A file of the project's sample_data/ folder (its absolute path).
std::string sample_data(const std::string& relative);
// Number of lines (newline characters) in s.
int count_lines(const std::string& s);

}  // namespace authalic::test

// Use at the start of a test that needs shared data: skips (or fails under CI=true).
#define AUTHALIC_REQUIRE_SHARED(var, relative)                                                   \
  const std::string var = ::authalic::test::shared_data(relative);                             \
  if (var.empty()) {                                                                            \
    if (::authalic::test::running_in_ci()) {                                                    \
      FAIL() << "CI=true but ../shared/data/" << (relative) << " is missing";                   \
    } else {                                                                                    \
      GTEST_SKIP() << "../shared/data/" << (relative) << " not found; skipping real-data test"; \
    }                                                                                           \
  }

#pragma once
// Shared fixtures for the io tests: small meshes, file helpers, the "InputError naming the file"
// assertion, and a bridge to nibabel (an independent reader/writer of the same formats).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "common/test_data.h"
#include "core/error.h"
#include "core/mesh.h"

namespace authalic::test {

// Regular octahedron scaled/shifted so no coordinate is trivially 0 or 1 (closed, 6 V, 8 F).
inline TriMesh octahedron() {
  TriMesh m;
  m.V.resize(6, 3);
  m.V << 11.5, -2.25, 3.125,   //
      -8.5, -2.25, 3.125,      //
      1.5, 7.75, 3.125,        //
      1.5, -12.25, 3.125,      //
      1.5, -2.25, 13.125,      //
      1.5, -2.25, -6.875;
  m.F.resize(8, 3);
  m.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  return m;
}

inline std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Files in `dir` (names only), to check that no temporary file is left behind.
inline std::vector<std::string> list_dir(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// Runs fn, expects an authalic::InputError whose one-line message names `path` and contains
// `fragment` (case-sensitive). Reports what was thrown otherwise.
inline void expect_input_error(const std::function<void()>& fn, const std::string& path, const std::string& fragment) {
  try {
    fn();
    ADD_FAILURE() << "expected InputError for " << path << " (" << fragment << "), nothing was thrown";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << "message does not name the file: " << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << "message lacks '" << fragment << "': " << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "message is not one line: " << msg;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected InputError for " << path << ", got another exception: " << e.what();
  }
}

// /usr/bin/python3 with nibabel, or "" (then nibabel tests skip locally and fail under CI=true).
inline bool nibabel_available() {
  static const bool ok = run_command("/usr/bin/python3 -c 'import nibabel, numpy'") == 0;
  return ok;
}

#define AUTHALIC_REQUIRE_NIBABEL()                                                          \
  if (!::authalic::test::nibabel_available()) {                                             \
    if (::authalic::test::running_in_ci()) {                                                \
      FAIL() << "CI=true but /usr/bin/python3 with nibabel is missing";                     \
    } else {                                                                                \
      GTEST_SKIP() << "/usr/bin/python3 with nibabel not found; skipping cross-check";      \
    }                                                                                       \
  }

// Runs a Python snippet (written to a file in `dir`) with nibabel; returns its stdout, and fails
// the test when it exits non-zero.
inline std::string run_python(const std::string& dir, const std::string& code) {
  static int counter = 0;
  const std::string script = dir + "/script" + std::to_string(counter++) + ".py";
  write_bytes(script, "import nibabel as nib\nimport numpy as np\n" + code);
  std::string out;
  const int rc = run_command("/usr/bin/python3 " + script, &out);
  EXPECT_EQ(rc, 0) << "python failed:\n" << out;
  return out;
}

// Numbers printed by a Python snippet after the marker "OUT:" (other output, e.g. warnings, ignored).
inline std::vector<double> python_numbers(const std::string& output) {
  std::vector<double> values;
  const std::size_t at = output.rfind("OUT:");
  if (at == std::string::npos) return values;
  std::istringstream ss(output.substr(at + 4));
  double v;
  while (ss >> v) values.push_back(v);
  return values;
}

}  // namespace authalic::test

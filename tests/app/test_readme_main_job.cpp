// The README's first command ends with the main job (after its last "&&"). This test runs that
// part verbatim from the repository root and checks that the report it promises appears, so the
// README cannot drift from what the program does.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "common/test_data.h"

namespace fs = std::filesystem;

namespace {

std::vector<std::string> first_code_block(const std::string& readme) {
  std::ifstream in(readme);
  std::string line;
  std::vector<std::string> lines;
  int fences = 0;
  while (std::getline(in, line)) {
    if (line.rfind("```", 0) == 0) {
      if (++fences == 2) break;
      continue;
    }
    if (fences == 1) lines.push_back(line);
  }
  return lines;
}

}  // namespace

TEST(Readme, FirstCodeBlockHasExactlyTwoCommands) {
  const auto lines = first_code_block(std::string(AUTHALIC_SOURCE_DIR) + "/README.md");
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[0].find("&&"), std::string::npos) << "line 1 must be SETUP && MAIN_JOB";
  EXPECT_NE(lines[0].find("build/authalic run"), std::string::npos) << "the main job is the clinician pipeline";
}

TEST(Readme, MainJobRunsVerbatimAndWritesTheReport) {
  const auto lines = first_code_block(std::string(AUTHALIC_SOURCE_DIR) + "/README.md");
  ASSERT_EQ(lines.size(), 2u);
  const std::string main_job = lines[0].substr(lines[0].rfind("&&") + 2);
  // The report folder the job promises: --out DIR and --id ID -> DIR/sub-ID/report.html.
  std::smatch out, id;
  ASSERT_TRUE(std::regex_search(main_job, out, std::regex("--out\\s+(\\S+)")));
  ASSERT_TRUE(std::regex_search(main_job, id, std::regex("--id\\s+(\\S+)")));
  const fs::path root(AUTHALIC_SOURCE_DIR);
  ASSERT_TRUE(fs::exists(root / "build/authalic")) << "build/authalic is missing: run the README's first line first";
  const fs::path report = root / out[1].str() / ("sub-" + id[1].str()) / "report.html";
  std::string output;
  const int rc = authalic::test::run_command("cd '" + root.string() + "' && " + main_job + " --quiet", &output);
  ASSERT_EQ(rc, 0) << output;
  ASSERT_TRUE(fs::exists(report)) << report;
  std::ifstream in(report);
  std::stringstream html;
  html << in.rdbuf();
  EXPECT_NE(html.str().find("<html"), std::string::npos);
  EXPECT_NE(html.str().find("data:image/png;base64,"), std::string::npos) << "pictures are embedded";
  EXPECT_NE(html.str().find("id=\"clusters\""), std::string::npos) << "the sample run compares with the reference";
}

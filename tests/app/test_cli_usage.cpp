// Usage errors name what was typed (qa4_cli D12, D13): a mistyped subcommand or option is named,
// with the closest real one, before CLI11 reports a missing argument instead; a bound is printed
// as written, not as DBL_MAX's 300 digits. Each is one line on stderr (and a JSON object with
// --json), exit 2.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "common/test_data.h"

namespace authalic {
namespace {



void expect_usage_error(const std::string& args, const std::string& expected) {
  std::string out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " " + args, &out), 2) << args << "\n" << out;
  EXPECT_EQ(out, "authalic: error: " + expected + "\n") << args;
  EXPECT_EQ(test::count_lines(out), 1) << out;
}

TEST(CliUsage, MistypedSubcommandsAndOptionsAreNamed) {
  expect_usage_error("flaten x y", "authalic: unknown subcommand 'flaten'; did you mean flatten? (see authalic --help)");
  expect_usage_error("normative biuld r.json a.tsv", "authalic normative: unknown subcommand 'biuld'; did you mean build? (see authalic normative --help)");
  expect_usage_error("flatten --bogus", "authalic flatten: unknown option --bogus (see authalic flatten --help)");
  expect_usage_error("run --outt x", "authalic run: unknown option --outt; did you mean --out? (see authalic run --help)");
  expect_usage_error("run --out x --normalze none", "authalic run: unknown option --normalze; did you mean --normalize? (see authalic run --help)");
  // --name=value is one option.
  expect_usage_error("normative compare --thresold=3 a b c",
                     "authalic normative compare: unknown option --thresold; did you mean --threshold? (see authalic normative compare --help)");
  std::string out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " flatten --bogus --json", &out), 2) << out;
  const nlohmann::json j = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(j["error"], "authalic flatten: unknown option --bogus (see authalic flatten --help)");
  EXPECT_EQ(j["kind"], "usage");
  // Correct lines are not affected: --help, --version, and a known option with a negative value.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " --version", &out), 0) << out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " normative compare --help", &out), 0) << out;
  EXPECT_NE(out.find("--threshold"), std::string::npos) << out;
}

// QA round 4 (D18): the normalisation option was --normalize in run and group but --normalisation
// in elements (and --normalise in sample): each now takes the other spellings too, so a script
// written against one subcommand works with the others.
TEST(CliUsage, NormalisationOptionTakesEverySpellingItHasElsewhere) {
  std::string out;
  for (const char* line : {"run --out x --normalise none", "group c.csv o --normalise none", "elements --normalize global a b c"}) {
    EXPECT_EQ(test::run_command(test::quoted_binary() + " " + std::string(line), &out), 2) << line;
    EXPECT_EQ(out.find("unknown option"), std::string::npos) << line << "\n" << out;
  }
}

TEST(CliUsage, RangeErrorsPrintTheBoundsAsWritten) {
  std::string out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " sample --frame -1 a b c", &out), 2) << out;
  EXPECT_NE(out.find("--frame: '-1' is not a number from 0 to 100000"), std::string::npos) << out;
  EXPECT_EQ(test::count_lines(out), 1) << out;
  EXPECT_LT(out.size(), 200u) << out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group --jobs 0 " + std::string(AUTHALIC_SOURCE_DIR) + "/sample_data/cohort.csv out", &out), 2)
      << out;
  EXPECT_NE(out.find("'0' is not a number from 1 to 256"), std::string::npos) << out;
  EXPECT_LT(out.size(), 200u) << out;
}

}  // namespace
}  // namespace authalic

// qa4_cli D6, D7, D14: what qualifies every z-score of a run (the subject is one of the reference's own
// controls; the reference's age model cannot be used, and why) reaches run's JSON warnings, stderr
// and the report, not only the log; the report header does not present the controls' age range as
// the ages z was adjusted for when it was not.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/test_data.h"

namespace fs = std::filesystem;

namespace authalic {
namespace {

std::string q(const std::string& s) { return test::shell_quote(s); }

std::string run_args(const std::string& id, const std::string& out) {
  return q(test::authalic_binary()) + " run --id " + id + " --lh-white " + q(test::sample_data("surf/lh.white")) + " --lh-pial " +
         q(test::sample_data("surf/lh.pial")) + " --rh-white " + q(test::sample_data("surf/rh.white")) + " --rh-pial " + q(test::sample_data("surf/rh.pial")) +
         " --lh-cortex " + q(test::sample_data("label/lh.cortex.label")) + " --rh-cortex " + q(test::sample_data("label/rh.cortex.label")) + " --pet " +
         q(test::sample_data("sub-" + id + "/sub-" + id + "_pet.nii.gz")) + " --out " + q(out) + " --no-rectangle";
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// As the report writes text (io/markup_escape.h): quotes escaped.
std::string html_text(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '\'' ? std::string("&#39;") : std::string(1, c);
  return out;
}

TEST(RunWarningsCli, SubjectInTheReferenceIsWarnedInJsonStderrAndReport) {
  const std::string dir = test::temp_dir("run-warn-member");
  const std::string note = "subject 'control05' is one of the reference's controls: its z-scores are biased toward 0";
  std::string out;
  ASSERT_EQ(test::run_command(run_args("control05", dir + "/j") + " --normative " + q(test::sample_data("normative.json")) + " --age 52.5 --json", &out), 0)
      << out;
  const nlohmann::json j = nlohmann::json::parse(out.substr(out.find('{')));
  ASSERT_EQ(j["warnings"].size(), 1u) << j["warnings"].dump();
  EXPECT_EQ(j["warnings"][0], note);
  EXPECT_NE(read_text(dir + "/j/sub-control05/sub-control05_report.html").find(html_text("Warning: " + note)), std::string::npos);
  ASSERT_EQ(test::run_command(run_args("control05", dir + "/q") + " --normative " + q(test::sample_data("normative.json")) + " --age 52.5 --quiet", &out), 0)
      << out;
  EXPECT_EQ(out, "authalic run: warning: " + note + "\n") << "--quiet keeps warnings";
}

// A reference where one control has no age: built without an age model. The run names the
// control and says z is not age adjusted; the header's age range says it too.
TEST(RunWarningsCli, ReferenceWithAControlWithoutAgeSaysZIsNotAgeAdjusted) {
  const std::string dir = test::temp_dir("run-warn-ageless");
  nlohmann::json ref = nlohmann::json::parse(std::ifstream(test::sample_data("normative.json")));
  ASSERT_EQ(ref["subjects"][0]["id"], "control01");
  ref["subjects"][0]["age"] = nullptr;
  ref["age_model"] = false;  // as `normative build` writes it when a table has no age
  for (const char* key : {"age_mean", "age_m2", "age_value_comoment"}) ref["elements"].erase(key);
  std::ofstream(dir + "/ageless.json") << ref.dump();
  std::string out;
  ASSERT_EQ(test::run_command(run_args("patient01", dir + "/o") + " --normative " + q(dir + "/ageless.json") + " --age 68.2 --json", &out), 0)
      << out;
  const nlohmann::json j = nlohmann::json::parse(out.substr(out.find('{')));
  ASSERT_EQ(j["warnings"].size(), 1u) << j["warnings"].dump();
  EXPECT_EQ(j["warnings"][0], "1 of the reference's 20 controls ('control01') have no age; the age model needs every control's age: "
                              "no age model, z-scores are NOT age adjusted");
  const std::string html = read_text(dir + "/o/sub-patient01/sub-patient01_report.html");
  EXPECT_NE(html.find(html_text("have no age; the age model needs every control's age")), std::string::npos);
  EXPECT_NE(html.find("50.3-78 years (19 of 20 known) (z NOT age adjusted)"), std::string::npos);

  // The shipped reference with the age: adjusted, and the header says so.
  ASSERT_EQ(test::run_command(run_args("patient01", dir + "/a") + " --normative " + q(test::sample_data("normative.json")) + " --age 68.2 --json", &out), 0)
      << out;
  EXPECT_TRUE(nlohmann::json::parse(out.substr(out.find('{')))["warnings"].empty()) << out;
  EXPECT_NE(read_text(dir + "/a/sub-patient01/sub-patient01_report.html").find("50.3-78 years (z age adjusted)"), std::string::npos);
}

// qa4_cli D14: a PET-only report (no --normative) spoke of z-scores: the disclaimer said they
// compare the scan with controls, and the parameters listed the z threshold, the rescaling to the
// reference and the minimum cluster size.
TEST(RunWarningsCli, PetOnlyReportHasNoZScoreText) {
  const std::string dir = test::temp_dir("run-pet-only");
  std::string out;
  ASSERT_EQ(test::run_command(run_args("patient01", dir) + " --quiet", &out), 0) << out;
  const std::string html = read_text(dir + "/sub-patient01/sub-patient01_report.html");
  EXPECT_NE(html.find("the PET values are shown on the cortex without a comparison with control subjects"), std::string::npos);
  for (const char* z_text : {"the z-scores compare", "z_threshold", "rescale_to_reference", "minimum cluster size", "z_age_adjusted"})
    EXPECT_EQ(html.find(z_text), std::string::npos) << z_text;
  const std::string sidecar = read_text(dir + "/sub-patient01/sub-patient01_hemi-L_pet.json");
  ASSERT_NE(sidecar.find("\"parameters\""), std::string::npos) << sidecar;
  EXPECT_EQ(sidecar.find("z_threshold"), std::string::npos) << sidecar;
}

}  // namespace
}  // namespace authalic

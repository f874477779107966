// `authalic group` (qa4_cli D4, D5, D15): what can be known from the cohort list and the options is
// refused before any map (mixed correspondence modes, a partial or mismatched --normative); when the
// reference cannot be built the patients are not run and not reported as ok; the JSON and
// participants.tsv say what happened to every subject.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/test_data.h"

namespace fs = std::filesystem;

namespace authalic {
namespace {

std::string q(const std::string& s) { return test::shell_quote(s); }


// One cohort row of sample_data's surfaces: "<id>,<role>,<age>,<pet>,<surfaces and labels>[,extra]".
std::string row(const std::string& id, const std::string& role, const std::string& age, const std::string& pet,
                const std::string& extra = "") {
  return id + "," + role + "," + age + "," + pet + "," + test::sample_data("surf/lh.white") + "," + test::sample_data("surf/lh.pial") + "," +
         test::sample_data("surf/rh.white") + "," + test::sample_data("surf/rh.pial") + "," + test::sample_data("label/lh.cortex.label") + "," +
         test::sample_data("label/rh.cortex.label") + extra;
}

std::string write_cohort(const std::string& path, const std::vector<std::string>& rows, const std::string& extra_header = "") {
  std::ofstream c(path);
  c << "subject_id,role,age,pet,lh_white,lh_pial,rh_white,rh_pial,lh_cortex,rh_cortex" << extra_header << "\n";
  for (const auto& r : rows) c << r << "\n";
  return path;
}

std::string pet_of(const std::string& id) { return test::sample_data("sub-" + id + "/sub-" + id + "_pet.nii.gz"); }

nlohmann::json json_of(const std::string& out) { return nlohmann::json::parse(out.substr(out.find('{'))); }

// A folder with the files an atlas folder must have: the mode check reads only their checksums.
std::string fake_atlas(const std::string& dir) {
  fs::create_directories(dir + "/surf");
  fs::create_directories(dir + "/label");
  for (const std::string h : {"lh", "rh"}) {
    fs::copy_file(test::sample_data("surf/" + h + ".white"), dir + "/surf/" + h + ".white");
    fs::copy_file(test::sample_data("surf/" + h + ".white"), dir + "/surf/" + h + ".sphere");
    fs::copy_file(test::sample_data("label/" + h + ".cortex.label"), dir + "/label/" + h + ".cortex.label");
  }
  return dir;
}

// D4: a cohort that mixes atlas (both sphere_reg columns) and registration rows under --atlas gave
// a reference that refused to merge after every control had been mapped; now refused at once.
TEST(GroupCli, MixedCorrespondenceModesAreRefusedBeforeAnyMap) {
  const std::string dir = test::temp_dir("group-modes");
  const std::string atlas = fake_atlas(dir + "/atlas");
  const std::string reg = "," + test::sample_data("surf/lh.white") + "," + test::sample_data("surf/rh.white");  // any existing files
  const std::string cohort = write_cohort(dir + "/mixed.csv",
                                          {row("control01", "control", "71", pet_of("control01"), reg),
                                           row("control02", "control", "72", pet_of("control02"), ",,"),
                                           row("control03", "control", "73", pet_of("control03"), reg),
                                           row("patient01", "patient", "68", pet_of("patient01"), reg)},
                                          ",lh_sphere_reg,rh_sphere_reg");
  std::string out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort) + " " + q(dir + "/g") + " --atlas " + q(atlas), &out), 2) << out;
  EXPECT_NE(out.find("mixed.csv:3: subject 'control02' would be mapped in registration to the atlas map without sphere.reg"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("but control 'control01' (line 2) in atlas correspondence through sphere.reg"), std::string::npos) << out;
  EXPECT_NE(out.find("give every row both lh_sphere_reg and rh_sphere_reg, or none"), std::string::npos) << out;
  EXPECT_EQ(test::count_lines(out), 1) << out;
  EXPECT_FALSE(fs::exists(dir + "/g")) << "refused before any folder or map";

  // One sphere.reg alone would map both hemispheres by registration without saying so.
  const std::string half = write_cohort(dir + "/half.csv",
                                        {row("control01", "control", "71", pet_of("control01"), reg),
                                         row("control02", "control", "72", pet_of("control02"), "," + test::sample_data("surf/lh.white") + ","),
                                         row("control03", "control", "73", pet_of("control03"), reg)},
                                        ",lh_sphere_reg,rh_sphere_reg");
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(half) + " " + q(dir + "/h") + " --atlas " + q(atlas), &out), 2) << out;
  EXPECT_NE(out.find("half.csv:3: subject 'control02' has lh_sphere_reg but no rh_sphere_reg; give both"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/h"));

  // Without --atlas every row is per-subject: the sphere_reg columns do not make modes differ.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort) + " " + q(dir + "/c") + " --check", &out), 0) << out;
  EXPECT_FALSE(fs::exists(dir + "/c")) << "--check writes nothing";
}

// D5: with --normative, a partial reference and one of another correspondence mode are refused
// before any map (the K and normalisation checks already were).
TEST(GroupCli, GivenReferenceIsCheckedCompletelyBeforeAnyMap) {
  const std::string dir = test::temp_dir("group-given-ref");
  const std::string cohort = write_cohort(dir + "/cohort.csv", {row("control01", "control", "71", pet_of("control01")),
                                                                row("patient01", "patient", "68", pet_of("patient01"))});
  nlohmann::json ref = nlohmann::json::parse(std::ifstream(test::sample_data("normative.json")));
  ref["partial"] = true;
  std::ofstream(dir + "/partial.json") << ref.dump();
  ref["partial"] = false;
  ref["correspondence"] = "atlas 0123456789abcdef+0123456789abcdef";
  std::ofstream(dir + "/atlas.json") << ref.dump();
  std::string out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort) + " " + q(dir + "/p") + " --normative " + q(dir + "/partial.json"), &out), 2)
      << out;
  EXPECT_NE(out.find(dir + "/partial.json: is a partial reference (20 control(s), from `normative build --partial`)"), std::string::npos)
      << out;
  EXPECT_EQ(test::count_lines(out), 1) << out;
  EXPECT_FALSE(fs::exists(dir + "/p")) << "refused before any folder or map";
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort) + " " + q(dir + "/a") + " --normative " + q(dir + "/atlas.json"), &out), 2)
      << out;
  EXPECT_NE(out.find("cohort.csv:3: patient 'patient01' would be mapped in per-subject correspondence (no --atlas) but the "
                     "reference " + dir + "/atlas.json was built in atlas correspondence through sphere.reg"),
            std::string::npos)
      << out;
  EXPECT_FALSE(fs::exists(dir + "/a"));
}

// D4, D5, D15: three controls with one scan give a reference with no spread, which `normative build`
// refuses; the patient is then not run (it was run PET-only and listed "ok"), the JSON and
// participants.tsv say so, controls_used counts the controls of a reference the patients were
// compared with (none), and a failed control has no folder to point to.
TEST(GroupCli, PatientsAreNotRunOrListedOkWithoutAReference) {
  const std::string dir = test::temp_dir("group-no-ref");
  const std::string bad_pet = dir + "/truncated_pet.nii.gz";
  {
    std::ifstream in(pet_of("control04"), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(bad_pet, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  const std::string cohort = write_cohort(dir + "/cohort.csv", {row("control01", "control", "71", pet_of("control01")),
                                                                row("control02", "control", "72", pet_of("control01")),
                                                                row("control03", "control", "73", pet_of("control01")),
                                                                row("control04", "control", "74", bad_pet),
                                                                row("patient01", "patient", "68", pet_of("patient01"))});
  std::string out;
  ASSERT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort) + " " + q(dir + "/g") + " --no-rectangle --json --threads 2", &out), 3)
      << out;
  const nlohmann::json j = json_of(out);
  EXPECT_NE(j["reference_exit_code"], 0) << j.dump(2);
  EXPECT_EQ(j["controls_succeeded"], 3) << j.dump(2);
  EXPECT_EQ(j["controls_used"], 0) << "no reference, so no control was used for a comparison";
  EXPECT_TRUE(j["reference"].is_null()) << j.dump(2);
  EXPECT_EQ(j["failed"], 1) << j.dump(2);
  EXPECT_EQ(j["not_run"], 1) << j.dump(2);
  ASSERT_EQ(j["subjects"].size(), 5u);
  const nlohmann::json& patient = j["subjects"][4];
  EXPECT_EQ(patient["id"], "patient01");
  EXPECT_EQ(patient["status"], "not run");
  EXPECT_TRUE(patient["exit_code"].is_null()) << patient.dump();
  EXPECT_EQ(j["subjects"][3]["status"], "failed");
  EXPECT_FALSE(fs::exists(dir + "/g/sub-patient01")) << "the patient was run without a reference";

  std::ifstream tsv(dir + "/g/participants.tsv");
  std::map<std::string, std::string> lines;
  for (std::string line; std::getline(tsv, line);) lines[line.substr(0, line.find('\t'))] = line;
  EXPECT_EQ(lines["sub-patient01"],
            "sub-patient01\tpatient\t68\tn/a\tn/a\tnot run: the reference could not be built (see logs/normative.log)");
  EXPECT_EQ(lines["sub-control04"].substr(0, lines["sub-control04"].find("\tfailed")), "sub-control04\tcontrol\t74\tn/a\tn/a")
      << "a failed subject has no folder";
  EXPECT_EQ(lines["sub-control01"], "sub-control01\tcontrol\t71\tn/a\tsub-control01\tok");
  std::ifstream log(dir + "/g/logs/normative.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("are they copies of one table"), std::string::npos) << text;
}

// D5: with a given reference, controls_used is the number of controls in it, not the cohort's.
// --min-cluster reaches every patient's run (its report lists it among the parameters).
TEST(GroupCli, ControlsUsedCountsTheGivenReferencesControls) {
  const std::string dir = test::temp_dir("group-controls-used");
  const std::string cohort = write_cohort(dir + "/cohort.csv", {row("patient01", "patient", "68.2", pet_of("patient01"))});
  std::string out;
  ASSERT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort) + " " + q(dir + "/g") + " --normative " + q(test::sample_data("normative.json")) +
                                  " --no-rectangle --min-cluster 7 --json --threads 2",
                              &out),
            0)
      << out;
  const nlohmann::json j = json_of(out);
  std::ifstream report(dir + "/g/sub-patient01/sub-patient01_report.html");
  const std::string html((std::istreambuf_iterator<char>(report)), std::istreambuf_iterator<char>());
  EXPECT_NE(html.find("<tr><th>minimum cluster size</th><td>7 elements</td></tr>"), std::string::npos);
  EXPECT_EQ(j["controls_used"], 20) << j.dump(2);
  EXPECT_EQ(j["controls_succeeded"], 0) << j.dump(2);
  EXPECT_EQ(j["reference"], test::sample_data("normative.json"));
  EXPECT_EQ(j["subjects"][0]["status"], "ok");
  EXPECT_EQ(j["not_run"], 0);
}

}  // namespace
}  // namespace authalic

// Issue 6: the Snakemake workflow (workflow/Snakefile) run with `snakemake -j2` on the phantom
// cohort (the committed sample_data, 3 controls and 1 patient of it to keep the test short) gives
// the same normative reference as `authalic normative build` on the same element tables, and the
// patient's report. Under CI=true a missing snakemake fails the test instead of skipping it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "analysis/normative.h"
#include "common/test_data.h"

namespace fs = std::filesystem;

namespace authalic {
namespace {

const std::string kSample = std::string(AUTHALIC_SOURCE_DIR) + "/sample_data";

TEST(Workflow, SnakemakeOnThePhantomCohortMergesToTheDirectReference) {
  if (test::run_command("command -v snakemake > /dev/null 2>&1") != 0) {
    if (test::running_in_ci()) FAIL() << "CI=true but snakemake (Debian package snakemake) is missing";
    GTEST_SKIP() << "snakemake not installed; skipping the workflow test";
  }
  const std::string dir = test::temp_dir("workflow");
  // A cohort of 3 controls and 1 patient of sample_data, with absolute paths.
  std::ifstream in(kSample + "/cohort.csv");
  std::string header, line;
  std::getline(in, header);
  std::ostringstream cohort;
  cohort << header << '\n';
  int controls = 0, patients = 0;
  while (std::getline(in, line)) {
    const bool control = line.find(",control,") != std::string::npos;
    if (control ? controls >= 3 : patients >= 1) continue;
    (control ? controls : patients)++;
    std::stringstream ss(line);
    std::string field, out;
    for (int col = 0; std::getline(ss, field, ','); ++col) out += (col ? "," : "") + (col >= 3 ? kSample + "/" + field : field);
    cohort << out << '\n';
  }
  ASSERT_EQ(controls, 3);
  ASSERT_EQ(patients, 1);
  std::ofstream(dir + "/cohort.csv") << cohort.str();

  const std::string exe = test::authalic_binary();
  std::string log;
  const int rc = test::run_command("snakemake -s " + std::string(AUTHALIC_SOURCE_DIR) + "/workflow/Snakefile -j2 --directory " +
                                       dir + " --config cohort=" + dir + "/cohort.csv out=" + dir + "/results authalic=" + exe +
                                       " k=32",
                                   &log);
  ASSERT_EQ(rc, 0) << log;
  const std::string out = dir + "/results";
  EXPECT_TRUE(fs::exists(out + "/sub-patient01/sub-patient01_report.html")) << log;
  std::vector<std::string> tables;
  for (const char* id : {"control01", "control02", "control03"}) {
    tables.push_back(out + "/sub-" + id + "/sub-" + id + "_elements.tsv");
    ASSERT_TRUE(fs::exists(tables.back())) << log;
    EXPECT_TRUE(fs::exists(out + "/partials/" + id + ".json"));
  }

  std::string args;
  for (const auto& t : tables) args += " " + t;
  ASSERT_EQ(test::run_command(exe + " normative build " + dir + "/direct.json" + args + " --quiet", &log), 0) << log;
  const auto merged = analysis::read_reference(out + "/normative.json");
  const auto direct = analysis::read_reference(dir + "/direct.json");
  ASSERT_EQ(merged.num_values(), direct.num_values());
  EXPECT_EQ(merged.num_values(), 2 * 32 * 32);
  EXPECT_EQ(merged.hemispheres, direct.hemispheres);
  EXPECT_EQ(merged.normalisation, direct.normalisation);
  EXPECT_EQ(merged.age_model, direct.age_model);
  ASSERT_EQ(merged.subjects.size(), 3u);
  for (std::size_t s = 0; s < 3; ++s) {
    EXPECT_EQ(merged.subjects[s].id, direct.subjects[s].id);
    EXPECT_EQ(merged.subjects[s].age, direct.subjects[s].age);
  }
  // Equal up to floating-point reassociation (Chan et al. pairwise merge vs Welford).
  auto near = [](double a, double b, double scale) { return std::abs(a - b) <= 1e-12 * scale; };
  for (int e = 0; e < merged.num_values(); ++e) {
    const auto i = static_cast<std::size_t>(e);
    ASSERT_EQ(merged.n[i], direct.n[i]) << "element " << e;
    ASSERT_EQ(merged.n[i], 3) << "element " << e;
    EXPECT_TRUE(near(merged.mean[i], direct.mean[i], std::abs(direct.mean[i]))) << "element " << e;
    EXPECT_TRUE(near(merged.m2[i], direct.m2[i], direct.mean[i] * direct.mean[i])) << "element " << e;
    if (direct.age_model) {
      EXPECT_TRUE(near(merged.age_mean[i], direct.age_mean[i], direct.age_mean[i])) << "element " << e;
      EXPECT_TRUE(near(merged.age_m2[i], direct.age_m2[i], direct.age_mean[i] * direct.age_mean[i])) << "element " << e;
      EXPECT_TRUE(near(merged.comoment[i], direct.comoment[i], direct.age_mean[i] * std::abs(direct.mean[i]))) << "element " << e;
    }
  }
}

// Issue 15 item 13: the SLURM profile is a valid Snakemake profile for this workflow, and every
// job carries threads and resources (mem_mb, runtime) for the scheduler.
TEST(Workflow, SlurmProfileDryRunGivesEveryJobItsResources) {
  if (test::run_command("command -v snakemake > /dev/null 2>&1") != 0) {
    if (test::running_in_ci()) FAIL() << "CI=true but snakemake (Debian package snakemake) is missing";
    GTEST_SKIP() << "snakemake not installed; skipping the workflow test";
  }
  const std::string dir = test::temp_dir("workflow_slurm");
  std::string log;
  const int rc = test::run_command("snakemake -n -s " + std::string(AUTHALIC_SOURCE_DIR) + "/workflow/Snakefile --profile " +
                                       std::string(AUTHALIC_SOURCE_DIR) + "/workflow/profiles/slurm --directory " + dir +
                                       " --config cohort=" + kSample + "/cohort.csv out=" + dir + "/results authalic=" +
                                       test::authalic_binary(),
                                   &log);
  ASSERT_EQ(rc, 0) << log;
  EXPECT_NE(log.find("This was a dry-run"), std::string::npos) << log;
  // One resources line per job; the runs' from the Snakefile, the merges' smaller.
  std::size_t jobs = 0, runs = 0;
  for (std::size_t at = log.find("resources: "); at != std::string::npos; at = log.find("resources: ", at + 1)) {
    ++jobs;
    const std::string line = log.substr(at, log.find('\n', at) - at);
    EXPECT_NE(line.find("mem_mb="), std::string::npos) << line;
    EXPECT_NE(line.find("runtime="), std::string::npos) << line;
    runs += line.find("mem_mb=2000") != std::string::npos && line.find("runtime=30") != std::string::npos;
  }
  EXPECT_GT(jobs, 20u) << log;
  EXPECT_GT(runs, 20u) << "every subject's run asks for 2000 MB and 30 minutes\n" << log;
  EXPECT_NE(log.find("--threads 1 >"), std::string::npos) << "the run gets the rule's threads";
}

// Issue 15 item 18: run from any folder without --config authalic=, the workflow takes the
// build beside its Snakefile (REPO/build/authalic); with none there and none on PATH it stops
// with one line naming the fix. A copy of the workflow in a made-up repository layout.
TEST(Workflow, FindsTheExecutableBesideItsSnakefileOrSaysHowToPassIt) {
  if (test::run_command("command -v snakemake > /dev/null 2>&1") != 0) {
    if (test::running_in_ci()) FAIL() << "CI=true but snakemake (Debian package snakemake) is missing";
    GTEST_SKIP() << "snakemake not installed; skipping the workflow test";
  }
  namespace fs = std::filesystem;
  const std::string dir = test::temp_dir("workflow_find");
  for (const char* repo : {"with", "without"}) {
    fs::create_directories(dir + "/" + repo + "/workflow");
    fs::copy_file(std::string(AUTHALIC_SOURCE_DIR) + "/workflow/Snakefile", dir + "/" + repo + "/workflow/Snakefile",
                  fs::copy_options::overwrite_existing);
  }
  fs::create_directories(dir + "/with/build");
  fs::create_symlink(test::authalic_binary(), dir + "/with/build/authalic");
  fs::create_directories(dir + "/elsewhere");
  const std::string config = " --config cohort=" + kSample + "/cohort.csv out=" + dir + "/results";
  // PATH without any authalic: only the system folders.
  const std::string env = "cd " + dir + "/elsewhere && PATH=/usr/bin:/bin ";
  std::string log;
  ASSERT_EQ(test::run_command(env + "snakemake -n -p -s " + dir + "/with/workflow/Snakefile -j1" + config, &log), 0) << log;
  EXPECT_NE(log.find(dir + "/with/build/authalic run "), std::string::npos) << log;
  EXPECT_NE(test::run_command(env + "snakemake -n -p -s " + dir + "/without/workflow/Snakefile -j1" + config, &log), 0) << log;
  EXPECT_NE(log.find("authalic executable not found: not in " + dir + "/without/build/authalic and not on PATH"), std::string::npos) << log;
  EXPECT_NE(log.find("--config authalic=/path/to/authalic"), std::string::npos) << log;
}

bool have_snakemake() { return test::run_command("command -v snakemake > /dev/null 2>&1") == 0; }

// sample_data/cohort.csv's header and its first `controls` control rows and first patient row, the
// paths as written there (relative to the CSV's folder).
std::string sample_cohort(int controls) {
  std::ifstream in(kSample + "/cohort.csv");
  std::string header, line, text;
  std::getline(in, header);
  text = header + "\n";
  int c = 0, p = 0;
  while (std::getline(in, line)) {
    const bool control = line.find(",control,") != std::string::npos;
    if (control ? c >= controls : p >= 1) continue;
    (control ? c : p)++;
    text += line + "\n";
  }
  return text;
}

// The cohort's folder as the sample's: its subjects', surf/ and label/ folders linked in.
void link_sample_folders(const std::string& dir) {
  fs::create_directories(dir);
  for (const auto& entry : fs::directory_iterator(kSample))
    if (entry.is_directory()) fs::create_directory_symlink(entry.path(), dir + "/" + entry.path().filename().string());
}

// qa4_cli D1: the workflow read the cohort with a CSV reader of its own that kept only the last of
// two rows with one subject_id (a control's scan silently replaced) and checked nothing else. It
// now reads the list through `authalic group --check`: every list `group` refuses is refused with
// group's own message before any job runs, and nothing is written.
TEST(Workflow, CohortIsCheckedAsGroupChecksItBeforeAnyJob) {
  if (!have_snakemake()) {
    if (test::running_in_ci()) FAIL() << "CI=true but snakemake (Debian package snakemake) is missing";
    GTEST_SKIP() << "snakemake not installed; skipping the workflow test";
  }
  const std::string dir = test::temp_dir("workflow_check");
  link_sample_folders(dir);
  const std::string good = sample_cohort(3);
  const std::string dup_row = "control01,control,55.0,sub-control05/sub-control05_pet.nii.gz,surf/lh.white,surf/lh.pial,"
                              "surf/rh.white,surf/rh.pial,label/lh.cortex.label,label/rh.cortex.label\n";
  std::string missing_column = good;
  missing_column.replace(missing_column.find(",rh_cortex"), 10, "");
  const std::pair<std::string, std::string> cases[] = {
      {good + dup_row, "dup.csv:6: subject 'control01' is listed twice"},
      {missing_column, "nocol.csv: the header has no column 'rh_cortex'"},
      {sample_cohort(2), "two.csv: 2 control(s); a reference needs at least 3"},
      {good + "control09,control,7O,sub-control09/sub-control09_pet.nii.gz,surf/lh.white,surf/lh.pial,surf/rh.white,"
              "surf/rh.pial,label/lh.cortex.label,label/rh.cortex.label\n",
       "age.csv:6: age '7O' is not a number of years"}};
  const char* names[] = {"dup.csv", "nocol.csv", "two.csv", "age.csv"};
  for (std::size_t i = 0; i < std::size(cases); ++i) {
    const std::string cohort = dir + "/" + names[i];
    std::ofstream(cohort) << cases[i].first;
    std::string log;
    const int rc = test::run_command("snakemake -s " + std::string(AUTHALIC_SOURCE_DIR) + "/workflow/Snakefile -j2 --directory " + dir +
                                         " --config cohort=" + cohort + " out=" + dir + "/out" + std::to_string(i) +
                                         " authalic=" + test::authalic_binary(),
                                     &log);
    EXPECT_NE(rc, 0) << names[i] << "\n" << log;
    EXPECT_NE(log.find("cohort " + cohort + " refused by `authalic group --check`: " + dir + "/" + cases[i].second), std::string::npos)
        << names[i] << "\n" << log;
    EXPECT_EQ(log.find("Traceback"), std::string::npos) << log;
    EXPECT_FALSE(fs::exists(dir + "/out" + std::to_string(i))) << names[i] << ": a job ran";
  }
}

// qa4_cli D2, D3: paths with spaces, non-ASCII letters and a quote reach every job whole (the
// shell redirect was cut at the first space, every control failed with an empty log and the error
// went into a stray file beside the folder); the logs are OUT/logs/<id>.log as `group` writes them.
TEST(Workflow, PathsWithSpacesAndQuotesReachEveryJob) {
  if (!have_snakemake()) {
    if (test::running_in_ci()) FAIL() << "CI=true but snakemake (Debian package snakemake) is missing";
    GTEST_SKIP() << "snakemake not installed; skipping the workflow test";
  }
  const std::string top = test::temp_dir("workflow_spaces");
  const std::string dir = top + "/sp ace/\xC3\xBCn'\xC3\xAF c\xC3\xB8" "d\xC3\xA9";  // "sp ace/ün'ï cødé"
  link_sample_folders(dir);
  std::ofstream(dir + "/coh\xC3\xB6rt.csv") << sample_cohort(3);
  const std::string out = dir + "/wf out";
  std::string log;
  const int rc = test::run_command("snakemake -s " + std::string(AUTHALIC_SOURCE_DIR) + "/workflow/Snakefile -j2 --directory " +
                                       test::shell_quote(top) + " --config " + test::shell_quote("cohort=" + dir + "/coh\xC3\xB6rt.csv") +
                                       " " + test::shell_quote("out=" + out) + " authalic=" + test::authalic_binary(),
                                   &log);
  ASSERT_EQ(rc, 0) << log;
  EXPECT_TRUE(fs::exists(out + "/sub-patient01/sub-patient01_report.html")) << log;
  EXPECT_TRUE(fs::exists(out + "/normative.json")) << log;
  for (const char* id : {"control01", "control02", "control03", "patient01"}) {
    std::ifstream in(out + "/logs/" + id + ".log");
    ASSERT_TRUE(in.good()) << id << "\n" << log;
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("sub-" + std::string(id) + " done"), std::string::npos) << id << ":\n" << text;
  }
  EXPECT_TRUE(fs::exists(out + "/logs/normative.log"));
  EXPECT_FALSE(fs::exists(top + "/sp")) << "a redirect was cut at the space";
}

}  // namespace
}  // namespace authalic

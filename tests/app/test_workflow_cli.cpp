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

}  // namespace
}  // namespace authalic

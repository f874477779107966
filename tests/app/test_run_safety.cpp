// Output safety of `authalic run` (issue 8): killed with SIGKILL at several moments, it never leaves
// a subject folder that looks complete but is not; a rerun then completes. Also: it refuses to
// overwrite without --force, and bad input writes nothing.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <thread>

#include "common/test_data.h"

namespace fs = std::filesystem;

namespace {

std::vector<std::string> run_args(const std::string& out) {
  const std::string s = std::string(AUTHALIC_SOURCE_DIR) + "/sample_data/";
  return {authalic::test::authalic_binary(), "run", "--id", "patient01",
          "--lh-white", s + "surf/lh.white", "--lh-pial", s + "surf/lh.pial",
          "--rh-white", s + "surf/rh.white", "--rh-pial", s + "surf/rh.pial",
          "--lh-cortex", s + "label/lh.cortex.label", "--rh-cortex", s + "label/rh.cortex.label",
          "--pet", s + "sub-patient01/sub-patient01_pet.nii.gz", "--out", out, "--force", "--quiet"};
}

pid_t start(const std::vector<std::string>& args) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    freopen("/dev/null", "w", stderr);
    // A shell without job control starts background jobs with SIGINT ignored; the tests send it.
    signal(SIGINT, SIG_DFL);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

// A finished subject folder has its log (written last, just before the rename).
bool looks_complete(const fs::path& dir) {
  const std::string stem = dir.filename().string();  // sub-<id>
  return fs::exists(dir / (stem + "_log.txt")) && fs::exists(dir / (stem + "_report.html"));
}

}  // namespace

TEST(RunSafety, SigkillNeverLeavesAHalfWrittenSubjectFolder) {
  const std::string out = authalic::test::temp_dir("run-kill");
  const fs::path subject = fs::path(out) / "sub-patient01";
  for (int delay_ms : {50, 300, 900, 1800, 2600}) {
    const pid_t pid = start(run_args(out));
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    // Either no folder, or a complete one (the run finished before the kill).
    if (fs::exists(subject)) {
      EXPECT_TRUE(looks_complete(subject)) << "killed after " << delay_ms << " ms";
    }
  }
  // A rerun completes and replaces whatever was there.
  const pid_t pid = start(run_args(out));
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_TRUE(looks_complete(subject));
}

TEST(RunSafety, RefusesToOverwriteWithoutForceAndBadInputWritesNothing) {
  const std::string out = authalic::test::temp_dir("run-refuse");
  fs::create_directories(fs::path(out) / "sub-patient01");
  auto args = run_args(out);
  args.pop_back();  // --quiet
  args.pop_back();  // --force
  std::string cmd;
  for (const auto& a : args) cmd += "'" + a + "' ";
  std::string log;
  EXPECT_EQ(authalic::test::run_command(cmd, &log), 2);
  EXPECT_NE(log.find("--force"), std::string::npos) << log;

  const std::string out2 = authalic::test::temp_dir("run-bad");
  auto bad = run_args(out2);
  for (std::size_t i = 0; i + 1 < bad.size(); ++i)
    if (bad[i] == "--pet") bad[i + 1] = out2 + "/missing.nii.gz";
  cmd.clear();
  for (const auto& a : bad) cmd += "'" + a + "' ";
  EXPECT_EQ(authalic::test::run_command(cmd, &log), 2);
  EXPECT_NE(log.find("missing.nii.gz"), std::string::npos) << log;
  EXPECT_EQ(std::distance(fs::directory_iterator(out2), fs::directory_iterator()), 0) << "nothing may be written";
}

TEST(RunSafety, SameMapsAndElementsForOneAndTwoThreads) {
  // `run` makes the two hemispheres' maps side by side (one thread each) when it has two threads
  // and one after the other with one: every map, element table and image has the same bytes.
  std::string dirs[2], log;
  for (int t = 0; t < 2; ++t) {
    dirs[t] = authalic::test::temp_dir("run-threads-" + std::to_string(t + 1));
    std::string cmd;
    for (const auto& a : run_args(dirs[t])) cmd += "'" + a + "' ";
    ASSERT_EQ(authalic::test::run_command(cmd + "--threads " + std::to_string(t + 1), &log), 0) << log;
  }
  const fs::path sub = "sub-patient01";
  int compared = 0;
  for (const auto& e : fs::directory_iterator(fs::path(dirs[0]) / sub)) {
    const std::string name = e.path().filename().string();
    auto ends = [&](const std::string& x) { return name.size() >= x.size() && name.compare(name.size() - x.size(), x.size(), x) == 0; };
    const bool data = ends(".gii") || ends(".tsv") || ends(".nii.gz");
    if (!data) continue;
    std::ifstream a(e.path(), std::ios::binary), b(fs::path(dirs[1]) / sub / name, std::ios::binary);
    ASSERT_TRUE(b.good()) << name;
    const std::string sa((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
    const std::string sb((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
    EXPECT_TRUE(sa == sb) << name << " differs between --threads 1 and --threads 2";
    ++compared;
  }
  EXPECT_GE(compared, 10);
}

namespace {

// Names in `dir` (hidden ones included).
std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) names.push_back(e.path().filename().string());
  return names;
}

}  // namespace

// qa4_cli D11: SIGTERM or SIGINT (a scheduler's time limit, Ctrl-C) left OUT/.sub-<id>.partial-<pid>/
// and OUT/.sub-<id>.lock until the next run of the subject. Now the signal removes them, and OUT
// too when the run made it: caught while only the lock exists (mapping) and while the staging
// folder is being written.
TEST(RunSafety, SigtermOrSigintLeavesNoStagingFolderLockOrOutputFolder) {
  const std::string top = authalic::test::temp_dir("run-signal");
  int case_no = 0;
  for (const int sig : {SIGTERM, SIGINT}) {
    for (const std::string moment : {".lock", ".partial-"}) {
      const fs::path out = fs::path(top) / ("out" + std::to_string(case_no++));
      const pid_t pid = start(run_args(out.string()));
      bool seen = false;
      for (int i = 0; i < 20000 && !seen; ++i) {
        for (const auto& name : entries(out)) seen = seen || name.find(moment) != std::string::npos;
        if (!seen) std::this_thread::sleep_for(std::chrono::microseconds(500));
      }
      kill(pid, sig);
      int status = 0;
      ASSERT_EQ(waitpid(pid, &status, 0), pid);
      ASSERT_TRUE(seen) << moment << " never appeared in " << out;
      if (WIFEXITED(status)) continue;  // finished before the signal: nothing to check
      EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << "status " << status;
      const auto left = entries(out);
      EXPECT_FALSE(fs::exists(out)) << "signal " << sig << " at " << moment << ": " << left.size() << " entries left, first "
                                    << (left.empty() ? "" : left[0]);
    }
  }
}

// qa4_cli D10: "done in X s" summed the step times, and the two hemispheres' steps overlap: it
// said 42.8 s for a 26.9 s run. Now the run's wall time, which cannot exceed the process's.
TEST(RunSafety, DoneInReportsTheWallTime) {
  const std::string out = authalic::test::temp_dir("run-wall");
  auto args = run_args(out);
  args.pop_back();  // --quiet
  std::string cmd;
  for (const auto& a : args) cmd += "'" + a + "' ";
  std::string log;
  const auto start_time = std::chrono::steady_clock::now();
  ASSERT_EQ(authalic::test::run_command(cmd + "--threads 2", &log), 0) << log;
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  const std::size_t at = log.find("sub-patient01 done in ");
  ASSERT_NE(at, std::string::npos) << log;
  const double said = std::stod(log.substr(at + 22));
  EXPECT_NE(log.find(" s (wall time); report: ", at), std::string::npos) << log;
  EXPECT_LE(said, elapsed + 0.05) << log;
  EXPECT_GT(said, 0.5 * elapsed) << log;
}

// qa4_cli D16: a malformed BIDS sidecar (found when the report is made) gave the right one-line
// error but left the empty output folder the run had made; the staging folder is now removed on
// any failure, so the output folder is empty and removed too.
TEST(RunSafety, FailureAfterStagingLeavesNoOutputFolder) {
  const std::string dir = authalic::test::temp_dir("run-bad-sidecar");
  const std::string s = std::string(AUTHALIC_SOURCE_DIR) + "/sample_data/";
  fs::copy_file(s + "sub-patient01/sub-patient01_pet.nii.gz", dir + "/sub-x_pet.nii.gz");
  std::ofstream(dir + "/sub-x_pet.json") << "{\"TracerName\": \"FDG\"";  // the closing brace missing
  auto args = run_args(dir + "/o");
  for (std::size_t i = 0; i + 1 < args.size(); ++i)
    if (args[i] == "--pet") args[i + 1] = dir + "/sub-x_pet.nii.gz";
  std::string cmd;
  for (const auto& a : args) cmd += "'" + a + "' ";
  std::string log;
  EXPECT_EQ(authalic::test::run_command(cmd, &log), 2) << log;
  EXPECT_NE(log.find("sub-x_pet.json"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(dir + "/o")) << "left: " << (fs::exists(dir + "/o") && !entries(dir + "/o").empty() ? entries(dir + "/o")[0] : "an empty folder");
}

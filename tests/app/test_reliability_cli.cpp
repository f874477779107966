// Reliability of the command line (issue 17): outputs never destroy an input or a special file,
// two runs on one subject folder cannot race, numeric options are bounded, degenerate normative
// references and implausible anatomy are refused, `group` validates ids and takes its children
// with it when killed. Every refusal: exit 2, one line naming the path, inputs unchanged.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "analysis/elements.h"
#include "analysis/normative.h"
#include "common/hard_meshes.h"
#include "common/test_data.h"
#include "io/checksum.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

namespace fs = std::filesystem;

namespace authalic {
namespace {

std::string q(const std::string& s) { return test::shell_quote(s); }


// Runs `command`, expects exit 2 with `expected` in its one-line message, and every file in
// `kept` byte-identical afterwards.
void expect_refused(const std::string& command, const std::string& expected, const std::vector<std::string>& kept) {
  std::vector<std::string> before;
  for (const auto& f : kept) before.push_back(io::sha256_file(f));
  std::string out;
  EXPECT_EQ(test::run_command(command, &out), 2) << command << "\n" << out;
  EXPECT_NE(out.find(expected), std::string::npos) << command << "\n" << out;
  EXPECT_EQ(test::count_lines(out), 1) << out;
  for (std::size_t i = 0; i < kept.size(); ++i) EXPECT_EQ(io::sha256_file(kept[i]), before[i]) << kept[i] << " changed";
}

std::string write_patch(const std::string& dir) {
  const std::string path = dir + "/patch.surf.gii";
  io::write_surface(path, test::folded_patch(12));
  return path;
}

std::string run_args(const std::string& out, const std::string& pet = test::sample_data("sub-patient01/sub-patient01_pet.nii.gz")) {
  return test::quoted_binary() + " run --id patient01 --lh-white " + q(test::sample_data("surf/lh.white")) + " --lh-pial " + q(test::sample_data("surf/lh.pial")) +
         " --rh-white " + q(test::sample_data("surf/rh.white")) + " --rh-pial " + q(test::sample_data("surf/rh.pial")) + " --lh-cortex " +
         q(test::sample_data("label/lh.cortex.label")) + " --rh-cortex " + q(test::sample_data("label/rh.cortex.label")) + " --pet " + q(pet) +
         " --out " + q(out) + " --quiet";
}

// ---- 1. special files and symlinks as outputs ---------------------------------------------------

TEST(ReliabilityCli, OutputThatIsNotARegularFileIsRefusedAndLeftAsItIs) {
  const std::string dir = test::temp_dir("rel-special");
  const std::string patch = write_patch(dir);
  const std::string fifo = dir + "/pipe.surf.gii";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(fifo), "a FIFO (named pipe), not a regular file", {patch});
  struct stat st {};
  ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode)) << "the FIFO was replaced";
  // A device node (a private copy of /dev/null's numbers, made only when we may: as root).
  const std::string dev = dir + "/null.surf.gii";
  if (::mknod(dev.c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0) {
    expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(dev), "a character device", {patch});
    ASSERT_EQ(::lstat(dev.c_str(), &st), 0);
    EXPECT_TRUE(S_ISCHR(st.st_mode)) << "the device node was replaced";
  }
  // A folder, and a missing folder: refused before any computing.
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir), "is a folder", {patch});
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir + "/no/such/out.surf.gii"), "does not exist; create it first", {patch});
}

TEST(ReliabilityCli, SymlinkOutputIsWrittenThroughAndADanglingOneRefused) {
  const std::string dir = test::temp_dir("rel-symlink");
  const std::string patch = write_patch(dir);
  const std::string target = dir + "/target.surf.gii", link = dir + "/link.surf.gii";
  { std::ofstream(target) << "old"; }
  fs::create_symlink(target, link);
  std::string out;
  ASSERT_EQ(test::run_command(test::quoted_binary() + " flatten " + q(patch) + " " + q(link) + " --quiet", &out), 0) << out;
  EXPECT_TRUE(fs::is_symlink(link)) << "the link was replaced by a file";
  EXPECT_GT(fs::file_size(target), 100u) << "the link's target did not get the map";
  EXPECT_GE(io::read_surface(link).mesh.num_vertices(), io::read_surface(patch).mesh.num_vertices());
  fs::create_symlink(dir + "/missing.surf.gii", dir + "/dangling.surf.gii");
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir + "/dangling.surf.gii"), "symlink to a missing file", {patch});
}

analysis::ElementTable control(const std::string& id, double value) {
  analysis::ElementTable t;
  t.grid = analysis::element_grid(Domain::square(), 2);
  t.subject_id = id;
  t.units = "ratio";
  analysis::ElementBlock b;
  b.hemisphere = "left";
  for (int e = 0; e < 4; ++e) {
    analysis::Element el;
    el.id = e;
    el.row = e / 2;
    el.col = e % 2;
    el.area_mm2 = 10;
    el.value = value + 0.01 * e;
    el.n_vertices = 5;
    b.elements.push_back(el);
  }
  t.blocks.push_back(b);
  return t;
}

// ---- 2. an output that is an input --------------------------------------------------------------

TEST(ReliabilityCli, EveryCommandRefusesToWriteOverItsInput) {
  const std::string dir = test::temp_dir("rel-same");
  const std::string patch = write_patch(dir);
  const std::string sphere = dir + "/ball.surf.gii";
  io::write_surface(sphere, test::icosphere(2));
  const std::string hard = dir + "/hard.surf.gii";
  fs::create_hard_link(patch, hard);
  const std::string same = "is also an input";
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(patch), same, {patch});
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir + "/o.surf.gii") + " --uv " + q(patch), same, {patch});
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(hard), same, {patch});  // a hard link: same inode
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir + "/../" + fs::path(dir).filename().string() + "/patch.surf.gii"), same, {patch});
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir + "/o.surf.gii") + " --uv " + q(dir + "/o.surf.gii"),
                 "is given twice as an output", {patch});
  expect_refused(test::quoted_binary() + " subdivide " + q(patch) + " " + q(patch), same, {patch});
  expect_refused(test::quoted_binary() + " sphere " + q(sphere) + " " + q(sphere), same, {sphere});
  expect_refused(test::quoted_binary() + " render " + q(patch) + " " + q(patch), same, {patch});
  const std::string pet = dir + "/pet.nii.gz";
  fs::copy_file(test::sample_data("sub-patient01/sub-patient01_pet.nii.gz"), pet);
  expect_refused(test::quoted_binary() + " sample " + q(pet) + " " + q(test::sample_data("surf/lh.pial")) + " " + q(pet), same, {pet});
  // elements: PREFIX.tsv would be the values file.
  const std::string values = dir + "/v.tsv";
  { std::ofstream(values) << "1\n"; }
  expect_refused(test::quoted_binary() + " elements " + q(patch) + " " + q(patch) + " " + q(values) + " " + q(dir + "/v"), same, {values});
  // normative build T1 T1 T2: the first control's table as the output (and its sidecar).
  std::vector<std::string> tables;
  for (int s = 0; s < 3; ++s) {
    tables.push_back(dir + "/c" + std::to_string(s) + "_elements.csv");
    analysis::write_element_table(tables.back(), control("c" + std::to_string(s), 1.0 + 0.1 * s));
  }
  const std::string& t1 = tables[0];
  const std::string t1_sidecar = analysis::element_sidecar_path(t1);
  expect_refused(test::quoted_binary() + " normative build " + q(t1) + " " + q(t1) + " " + q(tables[1]) + " " + q(tables[2]), same, {t1, t1_sidecar});
  expect_refused(test::quoted_binary() + " normative build " + q(t1_sidecar) + " " + q(t1) + " " + q(tables[1]) + " " + q(tables[2]), same, {t1, t1_sidecar});
  // compare REF PATIENT PREFIX with PREFIX.json = REF.
  const std::string ref = dir + "/ref.json";
  std::string out;
  ASSERT_EQ(test::run_command(test::quoted_binary() + " normative build " + q(ref) + " " + q(tables[0]) + " " + q(tables[1]) + " " + q(tables[2]) + " --quiet", &out), 0) << out;
  const std::string patient = dir + "/p_elements.csv";
  analysis::write_element_table(patient, control("p", 0.8));
  expect_refused(test::quoted_binary() + " normative compare " + q(ref) + " " + q(patient) + " " + q(dir + "/ref"), same, {ref, patient});
}

TEST(ReliabilityCli, RunRefusesInputsInsideTheFolderForceWouldReplace) {
  const std::string dir = test::temp_dir("rel-force");
  const std::string subject = dir + "/out/sub-patient01";
  fs::create_directories(subject);
  const std::string pet = subject + "/pet.nii.gz";
  fs::copy_file(test::sample_data("sub-patient01/sub-patient01_pet.nii.gz"), pet);
  expect_refused(run_args(dir + "/out", pet) + " --force", "lies inside " + subject, {pet});
  EXPECT_TRUE(fs::exists(pet));
}

// ---- 4. two runs on one subject folder ------------------------------------------------------------

TEST(ReliabilityCli, ASecondRunOnTheSameSubjectFolderIsRefusedWhileTheFirstRuns) {
  const std::string dir = test::temp_dir("rel-lock");
  const std::string out = dir + "/out";
  // A killed run's staging folder: removed by the next run on that subject.
  fs::create_directories(out + "/.sub-patient01.partial-999999/x");
  const pid_t first = ::fork();
  ASSERT_GE(first, 0);
  if (first == 0) {
    ::execl("/bin/sh", "sh", "-c", (run_args(out) + " > " + q(dir + "/first.log") + " 2>&1").c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  const std::string lock = out + "/.sub-patient01.lock";
  for (int i = 0; i < 200 && !fs::exists(lock); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(25));
  ASSERT_TRUE(fs::exists(lock)) << "the first run did not take its lock";
  std::string log;
  EXPECT_EQ(test::run_command(run_args(out) + " --force", &log), 2) << log;
  EXPECT_NE(log.find("another authalic process is writing it now"), std::string::npos) << log;
  int status = 0;
  ASSERT_EQ(::waitpid(first, &status, 0), first);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_TRUE(fs::exists(out + "/sub-patient01/sub-patient01_report.html"));
  EXPECT_FALSE(fs::exists(lock)) << "the lock file was left behind";
  EXPECT_FALSE(fs::exists(out + "/.sub-patient01.partial-999999")) << "a dead run's staging folder was left";
  // The finished folder is not replaced without --force, under the lock as before.
  EXPECT_EQ(test::run_command(run_args(out), &log), 2) << log;
  EXPECT_NE(log.find("output folder exists"), std::string::npos) << log;
}

// ---- 5, 8, 13: bounded numbers ------------------------------------------------------------------

TEST(ReliabilityCli, NumericOptionsOutsideTheirRangeAreRefused) {
  const std::string dir = test::temp_dir("rel-numbers");
  const std::string patch = write_patch(dir);
  const std::string pet = test::sample_data("sub-patient01/sub-patient01_pet.nii.gz"), pial = test::sample_data("surf/lh.pial");
  std::string out;
  for (const std::string step : {"1e-9", "1e-6", "0", "-1", "nan"}) {
    EXPECT_EQ(test::run_command(test::quoted_binary() + " sample " + q(pet) + " " + q(pial) + " " + q(dir + "/s.func.gii") + " --step " + step, &out), 2)
        << step << ": " << out;
    EXPECT_FALSE(fs::exists(dir + "/s.func.gii"));
  }
  EXPECT_EQ(test::run_command(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir + "/o.surf.gii") + " --threads 100000", &out), 2) << out;
  EXPECT_NE(out.find("--threads"), std::string::npos) << out;
  for (const std::string age : {"7O", "nan", "-inf", "-5", "200"}) {
    EXPECT_EQ(test::run_command(run_args(dir + "/run") + " --age " + age, &out), 2) << age << ": " << out;
    EXPECT_NE(out.find("--age"), std::string::npos) << out;
  }
  EXPECT_FALSE(fs::exists(dir + "/run"));
}

// Options and outputs of the small commands that did not do what their help says: --json printed
// nothing (render, subdivide), an empty colour range and an unknown hemisphere were taken, and a
// phantom written over an earlier, larger one left the earlier subjects beside it.
TEST(ReliabilityCli, SmallCommandsDoWhatTheirHelpSays) {
  const std::string dir = test::temp_dir("rel-small-commands");
  const std::string patch = write_patch(dir);
  std::string out;
  ASSERT_EQ(test::run_command(test::quoted_binary() + " subdivide " + q(patch) + " " + q(dir + "/fine.surf.gii") + " --json", &out), 0) << out;
  ASSERT_NE(out.find('{'), std::string::npos) << out;
  const auto sub = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(sub.at("vertices"), io::read_surface(dir + "/fine.surf.gii").mesh.num_vertices());
  ASSERT_EQ(test::run_command(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir + "/flat.surf.gii") + " --uv " + q(dir + "/uv.surf.gii") +
                                  " --k 8 -q",
                              &out),
            0)
      << out;
  ASSERT_EQ(test::run_command(test::quoted_binary() + " render " + q(dir + "/r.png") + " " + q(dir + "/uv.surf.gii") + " --json", &out), 0) << out;
  ASSERT_NE(out.find('{'), std::string::npos) << out;
  EXPECT_EQ(nlohmann::json::parse(out.substr(out.find('{'))).at("output"), dir + "/r.png");
  expect_refused(test::quoted_binary() + " render " + q(dir + "/r2.png") + " " + q(dir + "/uv.surf.gii") + " --range 2 -2", "--range: LO must be below HI", {});
  // --json: a failure is a JSON object on stdout too (stdout was empty), usage errors included.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " render " + q(dir + "/r2.png") + " " + q(dir + "/uv.surf.gii") + " --range 2 -2 --json", &out), 2);
  ASSERT_NE(out.find('{'), std::string::npos) << out;
  const auto failed = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(failed.at("exit_code"), 2);
  EXPECT_EQ(failed.at("kind"), "bad input");
  EXPECT_NE(failed.at("error").get<std::string>().find("--range: LO must be below HI"), std::string::npos) << out;
  // A map output in another format than GIFTI would drop the record of the appended vertices
  // (`rectangle --surface out/r` wrote a FreeSurfer binary, and `metrics` then gave CV 0.0149 for 0.0096).
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir + "/flat_noext"), "OUT " + dir + "/flat_noext: a map is written as GIFTI", {});
  expect_refused(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir + "/f.surf.gii") + " --uv " + q(dir + "/uv.vtk"), "--uv " + dir + "/uv.vtk: a map is written as GIFTI", {});
  EXPECT_FALSE(fs::exists(dir + "/flat_noext"));
  EXPECT_FALSE(fs::exists(dir + "/f.surf.gii"));
  // The threshold of z is checked the same way by run, group and compare, before any work (compare
  // took inf and 1e9; run refused 0 only after mapping).
  for (const std::string& cmd : std::vector<std::string>{" normative compare a.json b.tsv o", " run --id x --out " + q(dir + "/never")})
    for (const char* t : {"inf", "0", "1e9"})
      expect_refused(test::quoted_binary() + cmd + " --threshold " + t, "--threshold: '" + std::string(t) + "' is not a number from 0.5 to 10", {});
  EXPECT_FALSE(fs::exists(dir + "/never"));
  EXPECT_EQ(test::run_command(test::quoted_binary() + " render --json", &out), 2);
  ASSERT_NE(out.find('{'), std::string::npos) << out;
  EXPECT_EQ(nlohmann::json::parse(out.substr(out.find('{'))).at("kind"), "usage");
  EXPECT_FALSE(fs::exists(dir + "/r2.png"));
  io::write_per_vertex(dir + "/v.shape.gii", io::read_surface(patch).mesh.V.col(0));
  EXPECT_EQ(test::run_command(test::quoted_binary() + " elements " + q(patch) + " " + q(dir + "/uv.surf.gii") + " " + q(dir + "/v.shape.gii") + " " +
                                  q(dir + "/el") + " --k 8 --hemisphere banana",
                              &out),
            2)
      << out;
  EXPECT_NE(out.find("--hemisphere: banana not in {left,right,both}"), std::string::npos) << out;

  ASSERT_EQ(test::run_command(test::quoted_binary() + " phantom " + q(dir + "/ph") + " --synthetic --controls 3 --patients 1 -q", &out), 0) << out;
  ASSERT_EQ(test::run_command(test::quoted_binary() + " phantom " + q(dir + "/ph") + " --synthetic --controls 1 --patients 0 -q", &out), 0) << out;
  EXPECT_TRUE(fs::exists(dir + "/ph/sub-control01"));
  EXPECT_FALSE(fs::exists(dir + "/ph/sub-control02")) << "a subject of the earlier cohort stayed";
  EXPECT_FALSE(fs::exists(dir + "/ph/sub-patient01"));
}

// ---- 6. degenerate normative references --------------------------------------------------------

TEST(ReliabilityCli, DegenerateNormativeReferencesAreRefusedNotReadAsNormal) {
  const std::string dir = test::temp_dir("rel-normative");
  auto table = [&](const std::string& id, double value) {
    const std::string p = dir + "/" + id + "_elements.csv";
    analysis::write_element_table(p, control(id, value));
    return p;
  };
  const std::string c1 = table("c1", 1.0), c2 = table("c2", 1.1), c3 = table("c3", 0.9);
  const std::string same1 = table("s1", 1.0), same2 = table("s2", 1.0), same3 = table("s3", 1.0);
  const std::string huge = table("h1", 1e308);
  std::string out;
  // Fewer than 3 controls.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " normative build " + q(dir + "/two.json") + " " + q(c1) + " " + q(c2), &out), 2) << out;
  EXPECT_NE(out.find("needs at least 3"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/two.json"));
  // SD 0 everywhere.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " normative build " + q(dir + "/flat.json") + " " + q(same1) + " " + q(same2) + " " + q(same3), &out), 2) << out;
  EXPECT_NE(out.find("SD > 0"), std::string::npos) << out;
  // 1e308: refused at build, not written as a reference the next command refuses.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " normative build " + q(dir + "/huge.json") + " " + q(c1) + " " + q(c2) + " " + q(huge), &out), 2) << out;
  EXPECT_NE(out.find("not a plausible PET value"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/huge.json"));
  // A one-control reference made by the library (as an older version or another tool could):
  // compare says it cannot compare instead of "0 elements compared, 0 clusters".
  analysis::NormativeReference one = analysis::empty_reference_like(control("c1", 1.0));
  analysis::add_subject(one, control("c1", 1.0), c1);
  analysis::write_reference(dir + "/one.json", one);
  EXPECT_EQ(test::run_command(test::quoted_binary() + " normative compare " + q(dir + "/one.json") + " " + q(c2) + " " + q(dir + "/cmp"), &out), 2) << out;
  EXPECT_NE(out.find("no element could be compared"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/cmp.json"));
  // Three varying controls: fine.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " normative build " + q(dir + "/ok.json") + " " + q(c1) + " " + q(c2) + " " + q(c3) + " --quiet", &out), 0) << out;
}

// ---- 11. implausible anatomy ---------------------------------------------------------------------

TEST(ReliabilityCli, SwappedWhiteAndPialOrLeftAndRightAreRefused) {
  const std::string dir = test::temp_dir("rel-anatomy");
  const std::string pet = q(test::sample_data("sub-patient01/sub-patient01_pet.nii.gz"));
  const std::string cortex = " --lh-cortex " + q(test::sample_data("label/lh.cortex.label")) + " --rh-cortex " + q(test::sample_data("label/rh.cortex.label"));
  std::string out;
  // White and pial swapped in the left hemisphere.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " run --id x --lh-white " + q(test::sample_data("surf/lh.pial")) + " --lh-pial " + q(test::sample_data("surf/lh.white")) +
                                  " --rh-white " + q(test::sample_data("surf/rh.white")) + " --rh-pial " + q(test::sample_data("surf/rh.pial")) + cortex +
                                  " --pet " + pet + " --out " + q(dir + "/a"),
                              &out),
            2)
      << out;
  EXPECT_NE(out.find("white and pial look swapped"), std::string::npos) << out;
  // Left and right swapped.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " run --id x --lh-white " + q(test::sample_data("surf/rh.white")) + " --lh-pial " + q(test::sample_data("surf/rh.pial")) +
                                  " --rh-white " + q(test::sample_data("surf/lh.white")) + " --rh-pial " + q(test::sample_data("surf/lh.pial")) + cortex +
                                  " --pet " + pet + " --out " + q(dir + "/b"),
                              &out),
            2)
      << out;
  EXPECT_NE(out.find("left and right look swapped"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/a"));
  EXPECT_FALSE(fs::exists(dir + "/b"));
  // One file as both hemispheres (qa4_cli D17: it said the left one lay at larger x than itself).
  EXPECT_EQ(test::run_command(test::quoted_binary() + " run --id x --lh-white " + q(test::sample_data("surf/lh.white")) + " --lh-pial " + q(test::sample_data("surf/lh.pial")) +
                                  " --rh-white " + q(test::sample_data("surf/lh.white")) + " --rh-pial " + q(test::sample_data("surf/lh.pial")) + cortex +
                                  " --pet " + pet + " --out " + q(dir + "/c") + " --quiet",
                              &out),
            2)
      << out;
  EXPECT_NE(out.find(test::sample_data("surf/lh.white") + ": the same file was given as --lh-white and --rh-white"), std::string::npos) << out;
  EXPECT_EQ(test::count_lines(out), 1) << out;
  EXPECT_FALSE(fs::exists(dir + "/c"));
}

// qa4_cli D17: messages that pointed the wrong way say what is wrong.
TEST(ReliabilityCli, EmptyFilesAndListsAreCalledEmpty) {
  const std::string dir = test::temp_dir("rel-empty");
  std::ofstream(dir + "/empty.txt").flush();
  std::ofstream(dir + "/empty.list") << "# no tables yet\n";
  expect_refused(test::quoted_binary() + " render " + q(dir + "/o.png") + " " + q(test::sample_data("surf/lh.white")) + " --values " + q(dir + "/empty.txt"),
                 dir + "/empty.txt: holds no values (the file is empty)", {});
  expect_refused(test::quoted_binary() + " normative build " + q(dir + "/r.json") + " --list " + q(dir + "/empty.list"),
                 dir + "/empty.list: lists no element table (it is empty or holds only comments)", {});
  EXPECT_FALSE(fs::exists(dir + "/r.json"));
}

// ---- clearer errors: degenerate geometry in the cortex region -----------------------------------

TEST(ReliabilityCli, DegenerateRegionGeometryIsNamedNotAFactorisationFailure) {
  const std::string dir = test::temp_dir("rel-degenerate");
  TriMesh m = test::folded_patch(12);
  TriMesh zero = m;
  zero.V.row(zero.F(0, 0)) = zero.V.row(zero.F(0, 1));  // two vertices at one point: zero-area faces
  io::write_surface(dir + "/zero.surf.gii", zero);
  TriMesh huge = m;
  huge.V.row(5) *= 1e38;
  io::write_surface(dir + "/huge.surf.gii", huge);
  TriMesh point = m;
  point.V.setZero();
  io::write_surface(dir + "/point.surf.gii", point);
  expect_refused(test::quoted_binary() + " flatten " + q(dir + "/zero.surf.gii") + " " + q(dir + "/o.surf.gii"), "are degenerate (zero area", {});
  expect_refused(test::quoted_binary() + " flatten " + q(dir + "/huge.surf.gii") + " " + q(dir + "/o.surf.gii"), "not finite or beyond 1e6 mm", {});
  expect_refused(test::quoted_binary() + " flatten " + q(dir + "/point.surf.gii") + " " + q(dir + "/o.surf.gii"), "collapsed to a point or a line", {});
  EXPECT_FALSE(fs::exists(dir + "/o.surf.gii"));
}

// ---- SIGTERM while the PET is decompressed ----------------------------------------------------------

TEST(ReliabilityCli, SigtermWhileReadingACompressedPetLeavesNoTemporaryFile) {
  const std::string dir = test::temp_dir("rel-sigterm");
  io::Volume big;
  big.dims = {240, 240, 240};  // 55 MB of floats: the decompressed copy lives long enough to catch
  big.vox2ras = Eigen::Matrix4d::Identity();
  big.data.assign(static_cast<std::size_t>(240) * 240 * 240, 1.0f);
  io::write_nifti(dir + "/big.nii.gz", big);
  const std::string tmp = dir + "/tmp";
  fs::create_directories(tmp);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::setenv("TMPDIR", tmp.c_str(), 1);
    ::execl(test::authalic_binary().c_str(), "authalic", "sample", (dir + "/big.nii.gz").c_str(), test::sample_data("surf/lh.pial").c_str(),
            (dir + "/s.func.gii").c_str(), "--quiet", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  bool seen = false;
  for (int i = 0; i < 4000 && !seen; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    seen = !fs::is_empty(tmp);
  }
  ::kill(child, SIGTERM);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(seen) << "the decompressed copy never appeared in TMPDIR";
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM) << "status " << status;
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(tmp)) left.push_back(e.path().filename().string());
  EXPECT_TRUE(left.empty()) << "left in TMPDIR: " << (left.empty() ? "" : left[0]);
  EXPECT_FALSE(fs::exists(dir + "/s.func.gii"));
}

// ---- clearer errors -----------------------------------------------------------------------------

TEST(ReliabilityCli, ErrorsNameTheRealProblem) {
  const std::string dir = test::temp_dir("rel-errors");
  std::vector<std::string> tables;
  for (int s = 0; s < 3; ++s) {
    tables.push_back(dir + "/c" + std::to_string(s) + "_elements.csv");
    analysis::write_element_table(tables.back(), control("c" + std::to_string(s), 1.0 + 0.1 * s));
  }
  const std::string ref = dir + "/normative.json";
  std::string out;
  ASSERT_EQ(test::run_command(test::quoted_binary() + " normative build " + q(ref) + " " + q(tables[0]) + " " + q(tables[1]) + " " + q(tables[2]) + " --quiet", &out), 0) << out;
  // compare REF REF: the patient is not a table (was: "cannot read normative.json.json").
  expect_refused(test::quoted_binary() + " normative compare " + q(ref) + " " + q(ref) + " " + q(dir + "/cmp"), "this looks like a JSON file", {ref});
  // A reference whose k is corrupt blames the file, not "--k".
  std::ifstream in(ref);
  std::string text((std::istreambuf_iterator<char>(in)), {});
  const std::size_t at = text.find("\"k\": 2");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 6, "\"k\": 100000");
  std::ofstream(dir + "/bad_k.json") << text;
  expect_refused(test::quoted_binary() + " normative compare " + q(dir + "/bad_k.json") + " " + q(tables[0]) + " " + q(dir + "/cmp"),
                 "bad_k.json: k = 100000 is outside 1..4096", {});
  // A file name starting with '-'.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " subdivide -x.surf.gii y.surf.gii", &out), 2) << out;
  EXPECT_NE(out.find("goes after '--'"), std::string::npos) << out;
  EXPECT_EQ(test::count_lines(out), 1) << out;
}

// ---- issue 15, item 10: an age model without the age ---------------------------------------------

TEST(ReliabilityCli, RunWithoutAgeAgainstAnAgeModelWarnsOrIsRefused) {
  const std::string dir = test::temp_dir("rel-age");
  const std::string ref = q(test::sample_data("normative.json"));  // built with an age model
  std::string out;
  EXPECT_EQ(test::run_command(run_args(dir + "/a") + " --normative " + ref + " --require-age", &out), 2) << out;
  EXPECT_NE(out.find("has an age model but no --age was given"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/a/sub-patient01"));
  ASSERT_EQ(test::run_command(run_args(dir + "/b") + " --normative " + ref, &out), 0) << out;
  EXPECT_NE(out.find("authalic run: warning:"), std::string::npos) << "--quiet must not hide the warning: " << out;
  EXPECT_NE(out.find("NOT age adjusted"), std::string::npos) << out;
  std::ifstream log(dir + "/b/sub-patient01/sub-patient01_log.txt");
  const std::string text((std::istreambuf_iterator<char>(log)), {});
  EXPECT_NE(text.find("NOT age adjusted"), std::string::npos) << text;
  std::ifstream report(dir + "/b/sub-patient01/sub-patient01_report.html");
  const std::string html((std::istreambuf_iterator<char>(report)), {});
  EXPECT_NE(html.find("NOT age adjusted"), std::string::npos);
  // With the age: no warning.
  ASSERT_EQ(test::run_command(run_args(dir + "/c") + " --normative " + ref + " --age 70", &out), 0) << out;
  EXPECT_EQ(out.find("warning"), std::string::npos) << out;
}

// ---- 13. PET noise around zero ------------------------------------------------------------------

TEST(ReliabilityCli, GlobalNormalisationOfNoiseAroundZeroIsRefused) {
  const std::string dir = test::temp_dir("rel-noise");
  io::Volume pet = io::read_volume(test::sample_data("sub-patient01/sub-patient01_pet.nii.gz"));
  // Deterministic noise of SD ~0.7 around a mean of 0.02.
  for (std::size_t i = 0; i < pet.data.size(); ++i) pet.data[i] = 0.02f + static_cast<float>(std::sin(12.9898 * static_cast<double>(i)));
  io::write_nifti(dir + "/noise.nii.gz", pet);
  std::string out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " sample " + q(dir + "/noise.nii.gz") + " " + q(test::sample_data("surf/lh.pial")) + " " +
                                  q(dir + "/s.func.gii") + " --normalize global --cortex " + q(test::sample_data("label/lh.cortex.label")),
                              &out),
            2)
      << out;
  EXPECT_NE(out.find("mostly noise around zero"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/s.func.gii"));
}

// Issue 15 item 17: FreeSurfer's SUBJECTS_DIR is honoured when --subjects-dir is absent, and
// --subjects-dir wins over it.
TEST(ReliabilityCli, SubjectsDirComesFromTheEnvironmentWhenNotGiven) {
  const std::string dir = test::temp_dir("rel-subjects-dir");
  const std::string pet = " --pet " + q(test::sample_data("sub-patient01/sub-patient01_pet.nii.gz")) + " --out " + q(dir + "/out");
  expect_refused("SUBJECTS_DIR=" + q(dir + "/env") + " " + test::quoted_binary() + " run --subject bert" + pet,
                 dir + "/env/bert: no such FreeSurfer subject folder", {});
  expect_refused("SUBJECTS_DIR=" + q(dir + "/env") + " " + test::quoted_binary() + " run --subjects-dir " + q(dir + "/given") + " --subject bert" + pet,
                 dir + "/given/bert: no such FreeSurfer subject folder", {});
  expect_refused("env -u SUBJECTS_DIR " + test::quoted_binary() + " run --subject bert" + pet, "give --subjects-dir or set SUBJECTS_DIR", {});
  EXPECT_FALSE(fs::exists(dir + "/out"));
}

// Issue 15 item 12: the global mean is over the cortex (the medial wall left out, as `run` does);
// without the cortex region the normalisation is refused before anything is read or written.
TEST(ReliabilityCli, GlobalNormalisationAveragesOverTheCortexOnly) {
  const std::string dir = test::temp_dir("rel-global-cortex");
  const std::string pet = test::sample_data("sub-patient01/sub-patient01_pet.nii.gz"), surf = test::sample_data("surf/lh.pial"),
                    label = test::sample_data("label/lh.cortex.label");
  expect_refused(test::quoted_binary() + " sample " + q(pet) + " " + q(surf) + " " + q(dir + "/n.func.gii") + " --normalize global",
                 "give the cortex region", {});
  EXPECT_FALSE(fs::exists(dir + "/n.func.gii"));
  ASSERT_EQ(test::run_command(test::quoted_binary() + " sample " + q(pet) + " " + q(surf) + " " + q(dir + "/raw.func.gii") + " -q"), 0);
  ASSERT_EQ(test::run_command(test::quoted_binary() + " sample " + q(pet) + " " + q(surf) + " " + q(dir + "/n.func.gii") +
                              " --normalize global --cortex " + q(label) + " -q"),
            0);
  const VectorXd raw = io::read_per_vertex(dir + "/raw.func.gii"), normed = io::read_per_vertex(dir + "/n.func.gii");
  // The reference value the CLI divided by, from any vertex with a value.
  double used = std::nan("");
  for (Eigen::Index v = 0; v < raw.size() && !std::isfinite(used); ++v)
    if (std::isfinite(raw[v]) && std::isfinite(normed[v]) && normed[v] != 0) used = raw[v] / normed[v];
  ASSERT_TRUE(std::isfinite(used));
  // Area-weighted mean over the faces inside the label vs over the whole surface.
  const io::Surface s = io::read_surface(surf);
  std::vector<char> in(static_cast<std::size_t>(s.mesh.num_vertices()), 0);
  for (int v : io::read_region_vertices(label, s.mesh.num_vertices())) in[static_cast<std::size_t>(v)] = 1;
  auto face_weighted_mean = [&](bool cortex_only) {
    double num = 0, den = 0;
    for (Eigen::Index f = 0; f < s.mesh.F.rows(); ++f) {
      const int a = s.mesh.F(f, 0), b = s.mesh.F(f, 1), c = s.mesh.F(f, 2);
      if (cortex_only && !(in[a] && in[b] && in[c])) continue;
      const double m = (raw[a] + raw[b] + raw[c]) / 3.0;
      if (!std::isfinite(m)) continue;
      const Eigen::Vector3d e1 = (s.mesh.V.row(b) - s.mesh.V.row(a)).transpose(), e2 = (s.mesh.V.row(c) - s.mesh.V.row(a)).transpose();
      const double area = 0.5 * e1.cross(e2).norm();
      num += area * m;
      den += area;
    }
    return num / den;
  };
  const double cortex = face_weighted_mean(true), whole = face_weighted_mean(false);
  // Float32 files: ~1e-7 relative; the sample subject's medial wall moves the mean by 0.27 %.
  EXPECT_NEAR(used / cortex, 1.0, 1e-5) << "used " << used << ", cortex mean " << cortex << ", whole surface " << whole;
  EXPECT_GT(std::abs(whole / cortex - 1.0), 1e-3) << "the medial wall must matter for this check to mean anything";
}

// ---- 13. a 3D surface given as the map -------------------------------------------------------------

TEST(ReliabilityCli, MetricsRefusesA3dSurfaceGivenAsTheMap) {
  const std::string dir = test::temp_dir("rel-metrics");
  const std::string patch = write_patch(dir);
  std::string out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " metrics " + q(test::sample_data("surf/lh.white")) + " " + q(test::sample_data("surf/lh.white")), &out), 2) << out;
  EXPECT_NE(out.find("is not a flat map"), std::string::npos) << out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " metrics " + q(test::sample_data("surf/lh.white")) + " " + q(test::sample_data("surf/lh.white")) + " --domain sphere", &out), 2) << out;
  EXPECT_NE(out.find("is not a sphere map"), std::string::npos) << out;
  // A real flat map still measures.
  ASSERT_EQ(test::run_command(test::quoted_binary() + " flatten " + q(patch) + " " + q(dir + "/flat.surf.gii") + " --quiet", &out), 0) << out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " metrics " + q(patch) + " " + q(dir + "/flat.surf.gii"), &out), 0) << out;
}

// ---- 7, 12: group ------------------------------------------------------------------------------

// A cohort CSV beside the sample data, with the given rows after the header.
std::string write_cohort(const std::string& dir, const std::vector<std::string>& rows) {
  const std::string path = dir + "/cohort.csv";
  std::ofstream c(path);
  c << "subject_id,role,age,pet,lh_white,lh_pial,rh_white,rh_pial,lh_cortex,rh_cortex\n";
  const std::string files = "," + test::sample_data("surf/lh.white") + "," + test::sample_data("surf/lh.pial") + "," + test::sample_data("surf/rh.white") + "," +
                            test::sample_data("surf/rh.pial") + "," + test::sample_data("label/lh.cortex.label") + "," + test::sample_data("label/rh.cortex.label");
  for (const auto& r : rows) c << r << files << "\n";
  return path;
}

TEST(ReliabilityCli, GroupValidatesIdsAndAgesBeforeAnyFile) {
  const std::string dir = test::temp_dir("rel-group-ids");
  const std::string pet = test::sample_data("sub-patient01/sub-patient01_pet.nii.gz");
  std::string out;
  const std::string bad = write_cohort(dir, {"../../escape,control,60," + pet});
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(bad) + " " + q(dir + "/g/out"), &out), 2) << out;
  EXPECT_NE(out.find("letters and digits"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/g")) << "a folder was made before the id was checked";
  EXPECT_FALSE(fs::exists(dir + "/escape.log"));
  const std::string age = write_cohort(dir, {"c01,control,7O," + pet});
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(age) + " " + q(dir + "/g2"), &out), 2) << out;
  EXPECT_NE(out.find("age '7O' is not a number"), std::string::npos) << out;
  // A row with a field missing: said so (it read as "empty rh_cortex", the fields shifted).
  const std::string short_row = write_cohort(dir, {"c01,control," + pet});
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(short_row) + " " + q(dir + "/g3"), &out), 2) << out;
  EXPECT_NE(out.find("cohort.csv:2: 9 fields, but the header has 10 columns"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/g3"));
}

// QA round 4 (D19): `run --subject sub-01` dropped the BIDS prefix but `run --id sub-01` and a
// cohort's subject_id "sub-01" (participants.tsv's participant_id, as users copy it) were refused
// for the hyphen. A leading sub- is now dropped everywhere: the same subject, the same folder.
TEST(ReliabilityCli, BidsSubPrefixNamesTheSameSubjectEverywhere) {
  const std::string dir = test::temp_dir("rel-group-sub");
  const std::string pet = test::sample_data("sub-patient01/sub-patient01_pet.nii.gz");
  std::string out;
  const std::string ok = write_cohort(dir, {"sub-c01,control,60," + pet, "c02,control,61," + pet, "sub-c03,control,62," + pet});
  ASSERT_EQ(test::run_command(test::quoted_binary() + " group " + q(ok) + " " + q(dir + "/g") + " --check --json -q", &out), 0) << out;
  const auto j = nlohmann::json::parse(out.substr(out.find('{'))).at("subjects");
  ASSERT_EQ(j.size(), 3u) << out;
  EXPECT_EQ(j[0].at("id"), "c01");
  EXPECT_EQ(j[1].at("id"), "c02");
  EXPECT_EQ(j[2].at("id"), "c03");
  const std::string twice = write_cohort(dir, {"sub-c01,control,60," + pet, "c01,control,61," + pet, "c03,control,62," + pet});
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(twice) + " " + q(dir + "/g2") + " --check", &out), 2) << out;
  EXPECT_NE(out.find("subject 'c01' is listed twice"), std::string::npos) << out;
  // `run --id sub-x`: refused before for the hyphen; now the folder sub-x/, files sub-x_*.
  std::string inputs;
  for (const char* h : {"lh", "rh"})
    inputs += std::string(" --") + h + "-white " + q(test::sample_data(std::string("surf/") + h + ".white")) + " --" + h + "-pial " +
              q(test::sample_data(std::string("surf/") + h + ".pial")) + " --" + h + "-cortex " +
              q(test::sample_data(std::string("label/") + h + ".cortex.label"));
  ASSERT_EQ(test::run_command(test::quoted_binary() + " run --id sub-x" + inputs + " --pet " + q(pet) + " --out " + q(dir + "/r") + " -q", &out), 0)
      << out;
  EXPECT_TRUE(fs::exists(dir + "/r/sub-x/sub-x_report.html"));
  EXPECT_FALSE(fs::exists(dir + "/r/sub-sub-x"));
}

// Issue 15 item 14: the cohort list is read as spreadsheets write CSV (libcsv): a UTF-8 byte-order
// mark, CRLF line ends, a quoted path holding a comma and a doubled quote. The rows before a bad
// one parse (their files are found), and messages name the right line.
TEST(ReliabilityCli, CohortCsvIsReadAsSpreadsheetsWriteIt) {
  const std::string dir = test::temp_dir("rel-group-csv");
  const std::string pet = dir + "/pet, \"baseline\".nii.gz";
  fs::copy_file(test::sample_data("sub-patient01/sub-patient01_pet.nii.gz"), pet);
  const std::string files = "," + test::sample_data("surf/lh.white") + "," + test::sample_data("surf/lh.pial") + "," + test::sample_data("surf/rh.white") + "," +
                            test::sample_data("surf/rh.pial") + "," + test::sample_data("label/lh.cortex.label") + "," + test::sample_data("label/rh.cortex.label");
  const std::string quoted_pet = "\"pet, \"\"baseline\"\".nii.gz\"";
  {
    std::ofstream c(dir + "/cohort.csv", std::ios::binary);
    c << "\xEF\xBB\xBFsubject_id,role,age,pet,lh_white,lh_pial,rh_white,rh_pial,lh_cortex,rh_cortex\r\n"
      << "c01,control,60," << quoted_pet << files << "\r\n"
      << "c02,control,61," << quoted_pet << files << "\r\n"
      << "c03,control,7O," << quoted_pet << files << "\r\n";
  }
  std::string out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(dir + "/cohort.csv") + " " + q(dir + "/g"), &out), 2) << out;
  EXPECT_NE(out.find("cohort.csv:4: age '7O' is not a number"), std::string::npos) << out;
  EXPECT_EQ(test::count_lines(out), 1) << out;
  {
    std::ofstream c(dir + "/broken.csv", std::ios::binary);
    c << "subject_id,role,age,pet,lh_white,lh_pial,rh_white,rh_pial,lh_cortex,rh_cortex\n"
      << "c01,control,60,\"" << pet << files << "\n";
  }
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(dir + "/broken.csv") + " " + q(dir + "/g2"), &out), 2) << out;
  EXPECT_NE(out.find("broken.csv:2: not valid CSV"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/g2"));
}

// Issue 15 item 15: `group` takes run's options and passes them to every subject; with an existing
// reference (--normative) the patients are compared with it, none is built, and a reference of
// another K is refused before any map is computed.
TEST(ReliabilityCli, GroupTakesRunOptionsAndAnExistingReference) {
  const std::string dir = test::temp_dir("rel-group-options");
  const std::string pet = test::sample_data("sub-patient01/sub-patient01_pet.nii.gz"), ref = test::sample_data("normative.json");
  const std::string cohort = write_cohort(dir, {"p01,patient,68.2," + pet});
  std::string out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort) + " " + q(dir + "/k16") + " --k 16 --normative " + q(ref), &out), 2) << out;
  EXPECT_NE(out.find("the reference has square K = 32 elements but the subjects would get square K = 16"), std::string::npos) << out;
  EXPECT_EQ(test::count_lines(out), 1) << out;
  EXPECT_FALSE(fs::exists(dir + "/k16")) << "refused before any folder or map";
  // So are a reference of another normalisation (every patient failed after every map) and, with
  // no reference, fewer controls than a reference needs (every subject ran, then exit 3).
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort) + " " + q(dir + "/none") + " --normalize none --normative " + q(ref), &out), 2)
      << out;
  EXPECT_NE(out.find("the reference's values are normalised 'global' but the subjects' would be 'none'"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/none"));
  fs::create_directories(dir + "/c2");
  const std::string two = write_cohort(dir + "/c2", {"c01,control,60," + pet, "c02,control,61," + pet, "p01,patient,68.2," + pet});
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(two) + " " + q(dir + "/two"), &out), 2) << out;
  EXPECT_NE(out.find("2 control(s); a reference needs at least 3"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/two"));

  // --threads is shared among the subjects (it was ignored: each got the machine's cores / jobs).
  ASSERT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort) + " " + q(dir + "/g") + " --normative " + q(ref) +
                                  " --threshold 3 --no-rectangle -q --threads 1 --jobs 1",
                              &out),
            0)
      << out;
  const std::string subject = dir + "/g/sub-p01";
  EXPECT_FALSE(fs::exists(dir + "/g/normative.json")) << "no reference is built when one is given";
  EXPECT_TRUE(fs::exists(subject + "/sub-p01_hemi-L_desc-elements_zscore.nii.gz"));
  EXPECT_FALSE(fs::exists(subject + "/sub-p01_hemi-L_space-authalicrect_flat.surf.gii")) << "--no-rectangle was passed on";
  std::ifstream sc(subject + "/sub-p01_hemi-L_desc-elements_zscore.json");
  const std::string text((std::istreambuf_iterator<char>(sc)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"z_threshold\": 3.0"), std::string::npos) << text;
  EXPECT_NE(text.find("--threads 1 "), std::string::npos) << text;
}

// Issue 15 item 14: the optional cohort columns sex (F, M, O; female/male/other accepted) and t1
// (the T1 the PET is registered to) are read, checked with the file and line, and passed to run:
// the sex reaches every sidecar's participant record.
TEST(ReliabilityCli, CohortOptionalSexAndT1Columns) {
  const std::string dir = test::temp_dir("rel-group-sex");
  const std::string pet = test::sample_data("sub-patient01/sub-patient01_pet.nii.gz"), ref = test::sample_data("normative.json");
  const std::string files = "," + test::sample_data("surf/lh.white") + "," + test::sample_data("surf/lh.pial") + "," + test::sample_data("surf/rh.white") + "," +
                            test::sample_data("surf/rh.pial") + "," + test::sample_data("label/lh.cortex.label") + "," + test::sample_data("label/rh.cortex.label");
  const auto cohort = [&](const std::string& name, const std::string& extra_header, const std::string& extra) {
    std::ofstream c(dir + "/" + name);
    c << "subject_id,role,age,pet,lh_white,lh_pial,rh_white,rh_pial,lh_cortex,rh_cortex" << extra_header << "\n"
      << "p01,patient,68.2," << pet << files << extra << "\n";
    return dir + "/" + name;
  };
  std::string out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort("badsex.csv", ",sex", ",x")) + " " + q(dir + "/b"), &out), 2) << out;
  EXPECT_NE(out.find("badsex.csv:2: sex 'x' is not F, M or O"), std::string::npos) << out;
  EXPECT_EQ(test::count_lines(out), 1) << out;
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort("badt1.csv", ",t1", "," + dir + "/none.nii")) + " " + q(dir + "/t"), &out), 2) << out;
  EXPECT_NE(out.find("badt1.csv:2: t1 file " + dir + "/none.nii does not exist"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/b"));
  EXPECT_FALSE(fs::exists(dir + "/t"));
  // A known column spelt otherwise would leave its values unused: refused.
  EXPECT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort("capital.csv", ",Sex", ",F")) + " " + q(dir + "/c"), &out), 2) << out;
  EXPECT_NE(out.find("capital.csv: column 'Sex' would be ignored: the column is 'sex'"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/c"));
  ASSERT_EQ(test::run_command(test::quoted_binary() + " group " + q(cohort("ok.csv", ",sex,t1", ",female,")) + " " + q(dir + "/g") +
                                  " --normative " + q(ref) + " --no-rectangle -q",
                              &out),
            0)
      << out;
  std::ifstream sc(dir + "/g/sub-p01/sub-p01_hemi-L_desc-elements_zscore.json");
  const auto j = nlohmann::json::parse(sc);
  EXPECT_EQ(j.at("participant").at("sex"), "F") << j.dump(1);
  EXPECT_DOUBLE_EQ(j.at("participant").at("age").get<double>(), 68.2);
  EXPECT_EQ(j.at("participant").at("participant_id"), "sub-p01");
  std::ifstream tsv(dir + "/g/participants.tsv");
  std::string header, row;
  ASSERT_TRUE(std::getline(tsv, header) && std::getline(tsv, row));
  EXPECT_EQ(header, "participant_id\tgroup\tage\tsex\tfolder\tstatus");
  EXPECT_EQ(row, "sub-p01\tpatient\t68.2\tF\tsub-p01\tok");
  std::ifstream columns(dir + "/g/participants.json");
  EXPECT_EQ(nlohmann::json::parse(columns).at("age").at("Units"), "year");
  // A BIDS derivative layout: subjects at the top of --out, their group in participants.tsv.
  EXPECT_FALSE(fs::exists(dir + "/g/patients"));
  EXPECT_FALSE(fs::exists(dir + "/g/controls"));
  EXPECT_TRUE(fs::exists(dir + "/g/dataset_description.json"));
  EXPECT_EQ(test::run_command(test::quoted_binary() + " run --sex q --out " + q(dir + "/r"), &out), 2) << out;
  EXPECT_NE(out.find("sex 'q' is not F, M or O"), std::string::npos) << out;
}

// VTK 9 logs its readers' errors through vtkLogger, which printed a dozen timestamped lines to
// stderr before our one line (an empty .vtp reached VTK's XML parser). Every empty VTK-family
// file now gives exactly one line, exit 2, and no output.
TEST(ReliabilityCli, EmptyVtkFamilyFilesGiveOneLine) {
  const std::string dir = test::temp_dir("rel-empty-vtk");
  for (const char* ext : {"vtp", "vtk", "ply", "obj", "stl"}) {
    const std::string in = dir + "/empty." + ext;
    std::ofstream{in};
    std::string out;
    EXPECT_EQ(test::run_command(test::quoted_binary() + " flatten " + q(in) + " " + q(dir + "/o.surf.gii"), &out), 2) << ext << ": " << out;
    EXPECT_EQ(test::count_lines(out), 1) << ext << ": " << out;
    EXPECT_NE(out.find(in + ": "), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir + "/o.surf.gii")) << ext;
  }
}

// Running (a zombie, reparented to an init that does not reap, counts as ended).
bool process_alive(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return false;
  const std::size_t close = line.rfind(')');
  return close != std::string::npos && close + 2 < line.size() && line[close + 2] != 'Z';
}

// The pids of `parent`'s children (from /proc).
std::vector<pid_t> children_of(pid_t parent) {
  std::vector<pid_t> out;
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(e.path() / "stat");
    std::string line;
    if (!std::getline(stat, line)) continue;
    const std::size_t close = line.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(line.substr(close + 2));
    char state = 0;
    pid_t ppid = 0;
    rest >> state >> ppid;
    if (ppid == parent) out.push_back(static_cast<pid_t>(std::stoi(name)));
  }
  return out;
}

TEST(ReliabilityCli, KilledGroupTakesItsRunningSubjectsWithIt) {
  const std::string dir = test::temp_dir("rel-group-kill");
  const std::string pet = test::sample_data("sub-patient01/sub-patient01_pet.nii.gz");
  const std::string cohort = write_cohort(dir, {"c01,control,60," + pet, "c02,control,61," + pet, "c03,control,62," + pet});
  const pid_t group = ::fork();
  ASSERT_GE(group, 0);
  if (group == 0) {
    ::execl(test::authalic_binary().c_str(), "authalic", "group", cohort.c_str(), (dir + "/out").c_str(), "--jobs", "2", "--quiet",
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  std::vector<pid_t> kids;
  for (int i = 0; i < 200 && kids.size() < 2; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
    kids = children_of(group);
  }
  ASSERT_FALSE(kids.empty()) << "group started no child";
  ::kill(group, SIGKILL);
  int status = 0;
  ::waitpid(group, &status, 0);
  bool any_alive = true;
  for (int i = 0; i < 60 && any_alive; ++i) {  // 1.5 s: a subject run takes longer than that
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
    any_alive = false;
    for (pid_t k : kids) any_alive = any_alive || process_alive(k);
  }
  EXPECT_FALSE(any_alive) << "a child run outlived the killed group";
}

// Item 17 (issue 15): every subject's log holds its run's progress, the failed and the successful
// ones alike (they were empty for successes: the children ran with --quiet); a comparison into a
// missing folder and an output folder that cannot be made are one line each, exit 2.
TEST(ReliabilityCli, GroupLogsEverySubjectAndMissingOutputFoldersAreOneLine) {
  const std::string dir = test::temp_dir("rel-group-logs");
  std::string out;
  ASSERT_EQ(test::run_command(test::quoted_binary() + " phantom --synthetic --controls 3 --patients 1 -q " + q(dir + "/ph"), &out), 0) << out;
  ASSERT_EQ(test::run_command(test::quoted_binary() + " group " + q(dir + "/ph/cohort.csv") + " " + q(dir + "/g") + " -q", &out), 0) << out;
  for (const std::string id : {"control01", "control02", "control03", "patient01"}) {
    std::ifstream log(dir + "/g/logs/" + id + ".log");
    ASSERT_TRUE(log.good()) << id;
    const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("run: authalic square map (left)"), std::string::npos) << id << ":\n" << text;
    EXPECT_NE(text.find("sub-" + id), std::string::npos) << id << ":\n" << text;
  }
  std::ifstream ref(dir + "/g/logs/normative.log");
  const std::string ref_text((std::istreambuf_iterator<char>(ref)), std::istreambuf_iterator<char>());
  EXPECT_NE(ref_text.find("3 subjects"), std::string::npos) << ref_text;

  const std::string table = dir + "/g/sub-patient01/sub-patient01_elements.tsv";
  expect_refused(test::quoted_binary() + " normative compare " + q(dir + "/g/normative.json") + " " + q(table) + " " + q(dir + "/none/x"),
                 "folder " + dir + "/none does not exist; create it first", {table});
  EXPECT_FALSE(fs::exists(dir + "/none"));
  expect_refused(run_args("/proc/authalic-out"), "/proc/authalic-out: cannot create the output folder", {});
}

}  // namespace
}  // namespace authalic

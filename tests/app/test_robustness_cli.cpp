// Robustness of the command line (issue 8): a flow stopped by its budget says so (stderr and
// metrics JSON); a full disk or a file-size limit gives a one-line error, a non-zero exit and no
// partial or temporary file; a surface too large for --max-memory is refused up front with the
// memory it would need; bad PET volumes are handled as documented or refused clearly.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "analysis/analysis_test_util.h"
#include "common/hard_meshes.h"
#include "common/test_data.h"
#include "core/mesh.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

namespace fs = std::filesystem;

namespace authalic {
namespace {

std::string q(const std::string& s) { return test::shell_quote(s); }
std::string bin() { return q(test::authalic_binary()); }

std::vector<std::string> files_in(const std::string& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

int count_lines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

// A curved disk written as GIFTI (1,681 vertices).
std::string write_patch(const std::string& dir) {
  const std::string path = dir + "/patch.surf.gii";
  io::write_surface(path, test::folded_patch(40));
  return path;
}

std::string run_args(const std::string& out) {
  const std::string s = std::string(AUTHALIC_SOURCE_DIR) + "/sample_data/";
  return bin() + " run --id patient01 --lh-white " + q(s + "surf/lh.white") + " --lh-pial " + q(s + "surf/lh.pial") +
         " --rh-white " + q(s + "surf/rh.white") + " --rh-pial " + q(s + "surf/rh.pial") + " --lh-cortex " +
         q(s + "label/lh.cortex.label") + " --rh-cortex " + q(s + "label/rh.cortex.label") + " --pet " +
         q(s + "sub-patient01/sub-patient01_pet.nii.gz") + " --out " + q(out) + " --force --quiet";
}

// ---- flow budget -------------------------------------------------------------------------------

TEST(RobustnessCli, SphereRefusesAMapThatIsNotAuthalic) {
  const std::string dir = test::temp_dir("robust-sphere");
  // An ellipsoid (2 : 1 : 1): its conformal map onto the sphere is far from authalic.
  TriMesh e = test::icosphere(4);
  e.V.col(0) *= 2.0;
  const std::string surface = dir + "/ellipsoid.surf.gii";
  io::write_surface(surface, e);
  std::string out;
  const std::string base = bin() + " sphere " + q(surface) + " " + q(dir + "/s.surf.gii") + " --route flow --passes 0 --metrics " +
                           q(dir + "/m.json");
  EXPECT_EQ(test::run_command(base, &out), 3) << out;
  EXPECT_NE(out.find(surface + ": the sphere map is not authalic"), std::string::npos) << out;
  EXPECT_NE(out.find("element CV"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/s.surf.gii"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/m.json"));
  // --keep-failed writes it, marked as failed, and still exits 3.
  EXPECT_EQ(test::run_command(base + " --keep-failed", &out), 3) << out;
  ASSERT_TRUE(std::filesystem::exists(dir + "/s.surf.gii"));
  std::ifstream in(dir + "/m.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["acceptance"]["passed"], false);
  std::ifstream gii(dir + "/s.surf.gii");
  const std::string text((std::istreambuf_iterator<char>(gii)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("FAILED: "), std::string::npos);
  // With the flow the same surface passes.
  ASSERT_EQ(test::run_command(bin() + " sphere " + q(surface) + " " + q(dir + "/s2.surf.gii") + " --metrics " + q(dir + "/m2.json"), &out), 0)
      << out;
  std::ifstream in2(dir + "/m2.json");
  EXPECT_EQ(nlohmann::json::parse(in2)["acceptance"]["passed"], true);
}

TEST(RobustnessCli, FlattenRefusesAMapThatIsNotAuthalic) {
  const std::string dir = test::temp_dir("robust-flow");
  const std::string patch = write_patch(dir);
  std::string out;
  // The conformal start with no flow and no polish is not authalic: exit 3, one line with the
  // measured numbers and their limits, and nothing written.
  const std::string base = bin() + " flatten " + q(patch) + " " + q(dir + "/flat.surf.gii") +
                           " --start conformal --passes 0 --no-polish --metrics " + q(dir + "/m.json");
  EXPECT_EQ(test::run_command(base, &out), 3) << out;
  EXPECT_NE(out.find("the map is not authalic"), std::string::npos) << out;
  EXPECT_NE(out.find("element CV"), std::string::npos) << out;
  EXPECT_NE(out.find("(limit 0.01)"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/flat.surf.gii"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/m.json"));
  // --keep-failed writes the map for inspection, marked as failed, and still exits 3.
  EXPECT_EQ(test::run_command(base + " --keep-failed", &out), 3) << out;
  ASSERT_TRUE(std::filesystem::exists(dir + "/flat.surf.gii"));
  std::ifstream in(dir + "/m.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["acceptance"]["passed"], false);
  EXPECT_GT(j["metrics"]["element_cv"].get<double>(), 0.01);
  std::ifstream gii(dir + "/flat.surf.gii");
  const std::string text((std::istreambuf_iterator<char>(gii)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("FAILED: "), std::string::npos);
  // With its normal budget the same patch passes: exit 0, acceptance recorded as passed.
  ASSERT_EQ(test::run_command(bin() + " flatten " + q(patch) + " " + q(dir + "/flat2.surf.gii") + " --metrics " + q(dir + "/m2.json"), &out), 0)
      << out;
  std::ifstream in2(dir + "/m2.json");
  const nlohmann::json j2 = nlohmann::json::parse(in2);
  EXPECT_EQ(j2["acceptance"]["passed"], true);
  EXPECT_LE(j2["metrics"]["element_cv"].get<double>(), 0.01);
  EXPECT_EQ(out.find("the flow stopped") == std::string::npos, j2["flow"]["converged"].get<bool>()) << out;
}

// ---- disk full -----------------------------------------------------------------------------------

// Runs `command` in bash with the file-size limit `kb` (RLIMIT_FSIZE; SIGXFSZ ignored, so writes
// beyond the limit fail with EFBIG like on a full disk).
int run_with_file_limit(int kb, const std::string& command, std::string* out) {
  return test::run_command("bash -c " + q("ulimit -f " + std::to_string(kb) + "; trap '' XFSZ; exec " + command), out);
}

void expect_clean_write_failure(int code, const std::string& out, const std::string& what) {
  EXPECT_NE(code, 0) << what << ": " << out;
  EXPECT_NE(code, -1) << what << ": killed by a signal: " << out;
  // One error line. (A failed GIFTI read-back can add gifticlib/expat's own "** no element found"
  // line before it: library chatter the tool does not control, see docs/robustness.md.)
  int error_lines = 0;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) error_lines += line.rfind("authalic: ", 0) == 0;
  EXPECT_EQ(error_lines, 1) << what << ": " << out;
  EXPECT_TRUE(out.find("file too large") != std::string::npos || out.find("File too large") != std::string::npos ||
              out.find("disk full") != std::string::npos)
      << what << ": " << out;
}

TEST(RobustnessCli, FileSizeLimitGivesOneLineErrorAndNoPartialFile) {
  const std::string src = test::temp_dir("robust-fsize-src");
  const std::string patch = write_patch(src);
  const std::string dir = test::temp_dir("robust-fsize");
  std::string out;
  int code = run_with_file_limit(4, bin() + " flatten " + q(patch) + " " + q(dir + "/flat.surf.gii") + " --quiet", &out);
  expect_clean_write_failure(code, out, "flatten");
  EXPECT_NE(out.find(dir + "/flat.surf.gii"), std::string::npos) << out;
  EXPECT_TRUE(files_in(dir).empty()) << "left behind: " << files_in(dir).front();

  // 48 kB: the flat surface (~31 kB) and the metrics (~4 kB) fit, the PNG (~64 kB) does not; the
  // files written before the failure are complete, the PNG is absent.
  code = run_with_file_limit(48, bin() + " flatten " + q(patch) + " " + q(dir + "/flat.surf.gii") + " --quiet --metrics " +
                                      q(dir + "/m.json") + " --png " + q(dir + "/big.png"),
                             &out);
  expect_clean_write_failure(code, out, "flatten --png");
  for (const std::string& f : files_in(dir)) EXPECT_EQ(f.find(".tmp"), std::string::npos) << f;
  EXPECT_FALSE(fs::exists(dir + "/big.png"));
  EXPECT_NO_THROW(io::read_surface(dir + "/flat.surf.gii"));
  EXPECT_EQ(files_in(dir), (std::vector<std::string>{"flat.surf.gii", "m.json"}));

  // authalic run: no subject folder, no staging folder.
  const std::string runs = test::temp_dir("robust-fsize-run");
  // 300 kB: here the first write to fail is the decompressed temporary copy of the PET (764 kB;
  // every output is smaller than it, so the outputs' failure is checked on the tmpfs below).
  code = run_with_file_limit(300, run_args(runs), &out);
  expect_clean_write_failure(code, out, "run");
  EXPECT_NE(out.find("cannot write the temporary file"), std::string::npos) << out;
  EXPECT_TRUE(files_in(runs).empty()) << "left behind: " << files_in(runs).front();
}

TEST(RobustnessCli, FullTmpfsGivesDiskFullErrorAndNoPartialFile) {
  if (::geteuid() != 0) GTEST_SKIP() << "mounting a small tmpfs needs root; FileSizeLimit... covers the same path";
  const std::string src = test::temp_dir("robust-tmpfs-src");
  const std::string patch = write_patch(src);
  const std::string mnt = test::temp_dir("robust-tmpfs");
  std::string out;
  if (test::run_command("mount -t tmpfs -o size=64k tmpfs " + q(mnt), &out) != 0) GTEST_SKIP() << "cannot mount tmpfs: " << out;
  struct Unmount {
    std::string m;
    ~Unmount() { test::run_command("umount " + q(m)); }
  } unmount{mnt};
  // Fill most of it so that the flat surface cannot fit.
  test::run_command("dd if=/dev/zero of=" + q(mnt + "/filler") + " bs=1k count=56");
  int code = test::run_command(bin() + " flatten " + q(patch) + " " + q(mnt + "/flat.surf.gii") + " --quiet", &out);
  expect_clean_write_failure(code, out, "flatten on a full tmpfs");
  EXPECT_NE(out.find("disk full"), std::string::npos) << out;
  EXPECT_EQ(files_in(mnt), std::vector<std::string>{"filler"});

  code = test::run_command(run_args(mnt + "/runs"), &out);
  expect_clean_write_failure(code, out, "run on a full tmpfs");
  // The staging folder goes first, so the output folder the run made is empty and goes too
  // (qa4_cli D16: it was left behind, empty).
  EXPECT_EQ(files_in(mnt), std::vector<std::string>{"filler"});
}

// ---- memory guard ----------------------------------------------------------------------------------

TEST(RobustnessCli, MaxMemoryRefusesUpFrontWithTheMemoryNeeded) {
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(flat, "fsaverage5/flat_left.gii.gz");
  const std::string dir = test::temp_dir("robust-memory");
  std::string out;
  // B3: the cortex of white_left (faces of flat_left) subdivided twice; S3: white_left twice.
  ASSERT_EQ(test::run_command(bin() + " subdivide " + q(white) + " " + q(dir + "/b3.surf.gii") + " --times 2 --faces-from " + q(flat) +
                                  " --quiet",
                              &out),
            0)
      << out;
  ASSERT_EQ(test::run_command(bin() + " subdivide " + q(white) + " " + q(dir + "/s3.surf.gii") + " --times 2 --quiet", &out), 0) << out;
  EXPECT_EQ(test::run_command(bin() + " flatten " + q(dir + "/b3.surf.gii") + " " + q(dir + "/flat.surf.gii") + " --max-memory 0.1", &out), 2);
  EXPECT_NE(out.find("the map of 149233 vertices would need about 0.52 GB"), std::string::npos) << out;  // 70 MB + 3 kB/vertex
  EXPECT_NE(out.find("more than the limit of 0.10 GB (--max-memory)"), std::string::npos) << out;
  EXPECT_EQ(count_lines(out), 1) << out;
  EXPECT_FALSE(fs::exists(dir + "/flat.surf.gii"));
  EXPECT_EQ(test::run_command(bin() + " sphere " + q(dir + "/s3.surf.gii") + " " + q(dir + "/sphere.surf.gii") + " --max-memory 0.1", &out), 2);
  EXPECT_NE(out.find("the map of 163842 vertices would need about 0.34 GB"), std::string::npos) << out;  // 90 MB + 1.55 kB/vertex
  EXPECT_FALSE(fs::exists(dir + "/sphere.surf.gii"));
}

// ---- volumes ---------------------------------------------------------------------------------------

double f(const Eigen::Vector3d& p) { return 500.0 + p.x() - 2.0 * p.y() + 0.5 * p.z(); }

struct PetFixture {
  std::string dir, surface;
  TriMesh sphere;
  Eigen::Vector3d centre;
  explicit PetFixture(const std::string& name) : dir(test::temp_dir(name)) {
    const Eigen::Matrix4d A = test::oblique_radiological_affine();
    centre = (A * Eigen::Vector4d(24.5, 29.5, 19.5, 1)).head<3>();
    sphere = test::sphere_mesh(3, 25.0, centre);
    surface = dir + "/lh.sphere.surf.gii";
    io::write_surface(surface, sphere);
  }
  std::string write(const std::string& name, const io::Volume& v) const {
    if (name.size() > 4 && (name.substr(name.size() - 4) == ".mgz" || name.substr(name.size() - 4) == ".mgh")) {
      io::write_mgh(dir + "/" + name, v);
    } else {
      io::write_nifti(dir + "/" + name, v);
    }
    return dir + "/" + name;
  }
  int sample(const std::string& pet, const std::string& out, const std::string& extra, std::string* log) const {
    return test::run_command(bin() + " sample " + q(pet) + " " + q(surface) + " " + q(dir + "/" + out) + " --normalize none " + extra, log);
  }
};

TEST(RobustnessCli, AllZeroAndAllNanPetAreRefusedPartlyNanIsNoted) {
  const PetFixture fx("robust-pet-values");
  io::Volume vol = test::function_volume({50, 60, 40}, test::oblique_radiological_affine(), f);
  io::Volume zero = vol;
  std::fill(zero.data.begin(), zero.data.end(), 0.0f);
  io::Volume nan = vol;
  std::fill(nan.data.begin(), nan.data.end(), std::nanf(""));
  io::Volume some_nan = vol;  // NaN in the half-space x > centre.x + 15: part of the sphere
  for (int k = 0; k < 40; ++k)
    for (int j = 0; j < 60; ++j)
      for (int i = 0; i < 50; ++i) {
        const Eigen::Vector3d w = (vol.vox2ras * Eigen::Vector4d(i, j, k, 1)).head<3>();
        if (w.x() > fx.centre.x() + 15) some_nan.data[i + 50 * (j + 60 * static_cast<std::size_t>(k))] = std::nanf("");
      }
  std::string out;
  EXPECT_EQ(fx.sample(fx.write("zero.nii.gz", zero), "z.func.gii", "", &out), 2) << out;
  EXPECT_NE(out.find("zero.nii.gz: every value sampled at the surface's"), std::string::npos) << out;
  EXPECT_NE(out.find("is 0 (an empty or all-zero PET?)"), std::string::npos) << out;
  EXPECT_EQ(count_lines(out), 1) << out;
  EXPECT_FALSE(fs::exists(fx.dir + "/z.func.gii"));
  // The same with global normalisation (the default): refused before dividing by zero.
  EXPECT_EQ(test::run_command(bin() + " sample " + q(fx.dir + "/zero.nii.gz") + " " + q(fx.surface) + " " + q(fx.dir + "/z.func.gii"), &out), 2)
      << out;
  // NaN voxels in MGH/MGZ (the project's own reader keeps them; for NIfTI see the next test).
  EXPECT_EQ(fx.sample(fx.write("nan.mgz", nan), "n.func.gii", "", &out), 2) << out;
  EXPECT_NE(out.find("nan.mgz: no finite value could be sampled"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(fx.dir + "/n.func.gii"));

  ASSERT_EQ(fx.sample(fx.write("some_nan.mgz", some_nan), "s.func.gii", "--json --trilinear", &out), 0) << out;
  const nlohmann::json j = nlohmann::json::parse(out.substr(out.find('{')));
  const int nan_vertices = j["nan_vertices"];
  EXPECT_GT(nan_vertices, 10);
  EXPECT_LT(nan_vertices, fx.sphere.num_vertices() / 2);
  ASSERT_EQ(j["notes"].size(), 1u) << out;
  EXPECT_NE(j["notes"][0].get<std::string>().find(std::to_string(nan_vertices) + " vertices have no finite value"), std::string::npos) << out;
  const VectorXd values = io::read_per_vertex(fx.dir + "/s.func.gii");
  int nan_read = 0;
  for (Eigen::Index v = 0; v < values.size(); ++v) nan_read += std::isnan(values(v));
  EXPECT_EQ(nan_read, nan_vertices);
}

TEST(RobustnessCli, NanVoxelsOfNiftiPetStayNan) {
  // nifti-clib zeroes non-finite floats while loading; io/nifti_io.cpp re-reads the raw bytes.
  const PetFixture fx("robust-pet-nifti-nan");
  io::Volume v = test::function_volume({50, 60, 40}, test::oblique_radiological_affine(), f);
  v.data[0] = std::nanf("");
  io::write_nifti(fx.dir + "/nan.nii", v);
  EXPECT_TRUE(std::isnan(io::read_volume(fx.dir + "/nan.nii").data[0]));
}

TEST(RobustnessCli, PetOrientationDoesNotChangeTheValuesAndMissingOrientationIsRefused) {
  const PetFixture fx("robust-pet-orientation");
  // The same world function stored two ways: oblique radiological (x axis negative), and plain
  // axial RAS with 2 mm voxels covering the same region. Sampling is in world coordinates, so
  // the values agree (f is linear, reproduced exactly by trilinear interpolation).
  const io::Volume oblique = test::function_volume({50, 60, 40}, test::oblique_radiological_affine(), f);
  Eigen::Matrix4d ras = Eigen::Matrix4d::Identity();
  ras.block<3, 3>(0, 0) *= 2.0;
  ras.block<3, 1>(0, 3) = fx.centre - Eigen::Vector3d(40, 40, 40);
  const io::Volume axial = test::function_volume({40, 40, 40}, ras, f);
  std::string out;
  ASSERT_EQ(fx.sample(fx.write("oblique.nii.gz", oblique), "o.func.gii", "--trilinear", &out), 0) << out;
  ASSERT_EQ(fx.sample(fx.write("axial.nii.gz", axial), "a.func.gii", "--trilinear", &out), 0) << out;
  const VectorXd a = io::read_per_vertex(fx.dir + "/o.func.gii"), b = io::read_per_vertex(fx.dir + "/a.func.gii");
  ASSERT_EQ(a.size(), b.size());
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-2);
  EXPECT_NEAR(a(0), f(fx.sphere.V.row(0).transpose()), 1e-2);

  // No sform and no qform: refused (sform_code at byte 254, qform_code at 252 zeroed).
  {
    std::ifstream in(fx.write("orient.nii", axial), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    bytes[252] = bytes[253] = bytes[254] = bytes[255] = 0;
    std::ofstream(fx.dir + "/noorient.nii", std::ios::binary) << bytes;
  }
  EXPECT_EQ(fx.sample(fx.dir + "/noorient.nii", "x.func.gii", "", &out), 2) << out;
  EXPECT_NE(out.find("no usable orientation"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(fx.dir + "/x.func.gii"));
}


// A PET that misses part of the cortex (the sample patient's, moved 25 mm to the right): `run`
// still maps and compares, but says so: a warning in --json, the log and the report, counted
// over the cortex's vertices (not the pial surface's, medial wall included).
TEST(RobustnessCli, RunWarnsWhenThePetMissesPartOfTheCortex) {
  const std::string dir = test::temp_dir("robust-run-coverage");
  const std::string s = std::string(AUTHALIC_SOURCE_DIR) + "/sample_data/";
  io::Volume pet = io::read_volume(s + "sub-patient01/sub-patient01_pet.nii.gz");
  pet.vox2ras(0, 3) += 25.0;
  io::write_nifti(dir + "/shifted.nii.gz", pet);
  std::string out;
  std::string args = run_args(dir + "/out");
  args.replace(args.find(q(s + "sub-patient01/sub-patient01_pet.nii.gz")), q(s + "sub-patient01/sub-patient01_pet.nii.gz").size(),
               q(dir + "/shifted.nii.gz"));
  ASSERT_EQ(test::run_command(args + " --json 2>/dev/null", &out), 0) << out;
  const nlohmann::json j = nlohmann::json::parse(out.substr(out.find('{')));
  std::string warning;
  for (const auto& w : j.at("warnings"))
    if (w.get<std::string>().find("outside the PET's field of view") != std::string::npos) warning = w;
  ASSERT_FALSE(warning.empty()) << j.at("warnings").dump();
  EXPECT_EQ(warning.rfind("left hemisphere: ", 0), 0u) << warning;  // the right one is still covered
  EXPECT_NE(warning.find(" of the cortex's 3579 vertices ("), std::string::npos) << warning;
  EXPECT_NE(warning.find("check the scan's coverage"), std::string::npos) << warning;
  std::ifstream log(dir + "/out/sub-patient01/sub-patient01_log.txt");
  const std::string log_text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(log_text.find("warning: " + warning), std::string::npos) << log_text;
  EXPECT_EQ(log_text.find("warning: " + warning), log_text.rfind("warning: " + warning)) << "logged once";
  // A PET that misses the surface is refused; the remedy named is run's own (--t1), not sample's
  // --surface-to-volume, which run does not have.
  pet.vox2ras(0, 3) += 200.0;
  io::write_nifti(dir + "/far.nii.gz", pet);
  std::string far = run_args(dir + "/far_out");
  far.replace(far.find(q(s + "sub-patient01/sub-patient01_pet.nii.gz")), q(s + "sub-patient01/sub-patient01_pet.nii.gz").size(), q(dir + "/far.nii.gz"));
  EXPECT_EQ(test::run_command(far, &out), 2) << out;
  EXPECT_NE(out.find("--t1 registers the PET to the subject's T1"), std::string::npos) << out;
  EXPECT_EQ(out.find("--surface-to-volume"), std::string::npos) << out;
  // A reference that is not there says so.
  EXPECT_EQ(test::run_command(run_args(dir + "/noref") + " --normative " + q(dir + "/missing.json"), &out), 2) << out;
  EXPECT_NE(out.find("missing.json: cannot read the normative reference (no such file)"), std::string::npos) << out;
}

// Every sidecar of a spatial file states its units and space as keys (they were only in the
// prose of some descriptions).
TEST(RobustnessCli, RunSidecarsStateUnitsAndSpace) {
  const std::string dir = test::temp_dir("robust-run-sidecars");
  std::string out;
  ASSERT_EQ(test::run_command(run_args(dir + "/out") + " --normative " + q(std::string(AUTHALIC_SOURCE_DIR) + "/sample_data/normative.json") +
                                  " --age 68.2",
                              &out),
            0)
      << out;
  const std::string base = dir + "/out/sub-patient01/sub-patient01_hemi-L_";
  auto sidecar = [&](const std::string& name) { return nlohmann::json::parse(std::ifstream(base + name + ".json")); };
  for (const char* surface : {"white", "pial"}) {
    EXPECT_EQ(sidecar(surface).at("units"), "mm") << surface;
    EXPECT_EQ(sidecar(surface).at("space"), "scanner RAS") << surface;
  }
  for (const char* flat : {"space-authalic_flat", "space-authalicrect_flat"}) {
    EXPECT_EQ(sidecar(flat).at("units"), "mm") << flat;
    EXPECT_NE(sidecar(flat).at("space").get<std::string>().find("authalic"), std::string::npos) << flat;
  }
  EXPECT_GT(sidecar("space-authalicrect_flat").at("seam_x_mm").get<double>(), 0.0);
  for (const char* z : {"zscore", "desc-elements_zscore"})
    EXPECT_EQ(sidecar(z).at("units").get<std::string>().rfind("z (standard deviations", 0), 0u) << z;
  EXPECT_EQ(sidecar("desc-elements_dseg").at("element_grid"), nlohmann::json::array({32, 32}));
}

}  // namespace
}  // namespace authalic

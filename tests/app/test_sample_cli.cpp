// `authalic sample` end to end: files in, GIFTI func and PNG out, errors as exit code 2.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "analysis/analysis_test_util.h"
#include "common/test_data.h"
#include "core/mesh.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

namespace authalic {
namespace {

double f(const Eigen::Vector3d& p) { return 500.0 + p.x() - 2.0 * p.y() + 0.5 * p.z(); }

struct SampleFixture {
  std::string dir, pet, surface, mask;
  TriMesh sphere;
  explicit SampleFixture(const std::string& name) : dir(test::temp_dir(name)) {
    const io::Volume vol = test::function_volume({50, 60, 40}, test::oblique_radiological_affine(), f);
    pet = dir + "/pet.nii.gz";
    io::write_nifti(pet, vol);
    const Eigen::Vector3d c = (vol.vox2ras * Eigen::Vector4d(24.5, 29.5, 19.5, 1)).head<3>();
    sphere = test::sphere_mesh(3, 25.0, c);
    surface = dir + "/lh.sphere.surf.gii";
    io::write_surface(surface, sphere);
    const io::Volume m = test::function_volume({50, 60, 40}, test::oblique_radiological_affine(),
                                               [&](const Eigen::Vector3d& p) { return (p - c).norm() < 8 ? 1.0 : 0.0; });
    mask = dir + "/ref_mask.nii.gz";
    io::write_nifti(mask, m);
  }
};

TEST(SampleCli, NormalProjectionWritesFuncWithValuesAtSegmentMidpointsAndAPng) {
  SampleFixture fx("sample_cli");
  std::string out;
  const std::string cmd = test::authalic_binary() + " sample " + fx.pet + " " + fx.surface + " " + fx.dir + "/pet.func.gii --json";
  ASSERT_EQ(test::run_command(cmd, &out), 0) << out;
  const auto j = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(j["normalisation"], "none");
  EXPECT_EQ(j["vertices_outside_fov"], 0);
  EXPECT_TRUE(std::filesystem::exists(fx.dir + "/pet.png"));
  const VectorXd v = io::read_per_vertex(fx.dir + "/pet.func.gii", fx.sphere.num_vertices());
  const MatrixXd N = vertex_normals(fx.sphere.V, fx.sphere.F);
  for (int i = 0; i < fx.sphere.num_vertices(); ++i)
    EXPECT_NEAR(v(i) / f(fx.sphere.V.row(i).transpose() - 5.0 * N.row(i).transpose()), 1.0, 1e-5) << i;

  // Reference-region normalisation: SUVR, recorded in the output's metadata.
  ASSERT_EQ(test::run_command(test::authalic_binary() + " sample " + fx.pet + " " + fx.surface + " " + fx.dir +
                                  "/suvr.func.gii --trilinear --normalize " + fx.mask + " --json",
                              &out),
            0)
      << out;
  const auto k = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(k["normalisation"], "reference-region");
  EXPECT_EQ(k["units"], "SUVR");
  const double ref = k["normalisation_reference_value"];
  const VectorXd suvr = io::read_per_vertex(fx.dir + "/suvr.func.gii");
  EXPECT_NEAR(suvr(0), f(fx.sphere.V.row(0).transpose()) / ref, 1e-5);
  std::ifstream gii(fx.dir + "/suvr.func.gii");
  const std::string text((std::istreambuf_iterator<char>(gii)), {});
  EXPECT_NE(text.find("reference-region"), std::string::npos);
}

TEST(SampleCli, DicomFolderRecordsTheSeriesReadAndRefusesTwoPetSeries) {
  SampleFixture fx("sample_cli_dicom");
  const io::Volume vol = io::read_volume(fx.pet);
  io::write_dicom_series(fx.dir + "/dicom", vol);  // one PET series: read, and named in the output
  std::string out;
  ASSERT_EQ(test::run_command(test::authalic_binary() + " sample --trilinear " + fx.dir + "/dicom " + fx.surface + " " + fx.dir +
                                  "/dicom.func.gii",
                              &out),
            0)
      << out;
  std::ifstream gii(fx.dir + "/dicom.func.gii");
  const std::string text((std::istreambuf_iterator<char>(gii)), {});
  EXPECT_NE(text.find("volume_series"), std::string::npos);
  EXPECT_NE(text.find("'authalic test series' (PT, 40 files)"), std::string::npos);

  // A second PET series (another reconstruction) beside it: refused, one line, nothing written.
  io::write_dicom_series(fx.dir + "/second", vol);
  for (const auto& e : std::filesystem::directory_iterator(fx.dir + "/second"))
    std::filesystem::copy_file(e.path(), fx.dir + "/dicom/second_" + e.path().filename().string());
  EXPECT_EQ(test::run_command(test::authalic_binary() + " sample --trilinear " + fx.dir + "/dicom " + fx.surface + " " + fx.dir +
                                  "/two.func.gii",
                              &out),
            2)
      << out;
  EXPECT_NE(out.find("holds 2 PET series, so which one to read is ambiguous"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(fx.dir + "/two.func.gii"));
}

TEST(SampleCli, BadInputsExitWithCode2AndSayWhy) {
  SampleFixture fx("sample_cli_bad");
  TriMesh far = fx.sphere;
  far.V.col(0).array() += 1000.0;
  io::write_surface(fx.dir + "/far.surf.gii", far);
  std::string out;
  EXPECT_EQ(test::run_command(test::authalic_binary() + " sample " + fx.pet + " " + fx.dir + "/far.surf.gii " + fx.dir + "/x.func.gii", &out), 2);
  EXPECT_NE(out.find("100% of the surface's vertices"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(fx.dir + "/x.func.gii"));
  EXPECT_EQ(test::run_command(test::authalic_binary() + " sample " + fx.dir + "/missing.nii " + fx.surface + " " + fx.dir + "/x.func.gii", &out), 2);
  std::ofstream(fx.dir + "/bad.txt") << "1 0 0\n";
  EXPECT_EQ(test::run_command(test::authalic_binary() + " sample " + fx.pet + " " + fx.surface + " " + fx.dir +
                                  "/x.func.gii --surface-to-volume " + fx.dir + "/bad.txt",
                              &out),
            2);
  EXPECT_NE(out.find("bad.txt: found 3 numbers"), std::string::npos) << out;
  EXPECT_EQ(test::run_command(test::authalic_binary() + " sample " + fx.pet + " " + fx.surface + " " + fx.dir + "/x.func.gii --ribbon " +
                                  fx.dir + "/far.surf.gii --trilinear",
                              &out),
            2);
}

// qa4_cli D9: an output name with the extension of another kind of file got FreeSurfer binary
// (nibabel: "not a gzip file") and exit 0; refused before any sampling, nothing written. A
// FreeSurfer curv name without such an extension is still written as curv.
TEST(SampleCli, OutputNamedAsAnotherKindOfFileIsRefused) {
  SampleFixture fx("sample_cli_names");
  for (const std::string name : {"o.nii.gz", "o.mgz", "o.png", "o.vtk", "o.gz"}) {
    std::string out;
    EXPECT_EQ(test::run_command(test::authalic_binary() + " sample " + fx.pet + " " + fx.surface + " " + fx.dir + "/" + name, &out), 2)
        << name << "\n" << out;
    const std::string ext = name.substr(1);
    EXPECT_NE(out.find(fx.dir + "/" + name + ": per-vertex values cannot be written as " + ext + "; give a name ending in .func.gii"),
              std::string::npos)
        << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
    EXPECT_FALSE(std::filesystem::exists(fx.dir + "/" + name));
    EXPECT_FALSE(std::filesystem::exists(fx.dir + "/" + name + ".png"));
  }
  std::string out;
  ASSERT_EQ(test::run_command(test::authalic_binary() + " sample " + fx.pet + " " + fx.surface + " " + fx.dir + "/lh.pet --quiet", &out), 0)
      << out;
  EXPECT_EQ(io::read_per_vertex(fx.dir + "/lh.pet").size(), fx.sphere.num_vertices()) << "a FreeSurfer curv name still works";
  // subdivide, the other command that wrote FreeSurfer binary under any name.
  for (const std::string name : {"s.nii.gz", "s.txt"}) {
    EXPECT_EQ(test::run_command(test::authalic_binary() + " subdivide " + fx.surface + " " + fx.dir + "/" + name, &out), 2) << out;
    EXPECT_NE(out.find(fx.dir + "/" + name + ": a surface cannot be written as " + name.substr(1) + "; give a name ending in .surf.gii"),
              std::string::npos)
        << out;
    EXPECT_FALSE(std::filesystem::exists(fx.dir + "/" + name));
  }
}

}  // namespace
}  // namespace authalic

// `authalic sample --register T1`: a PET moved off the surface's space (3 degrees, 10 mm) is brought
// back by the rigid registration to the T1 (ITK v4, Mattes MI), so its samples match the aligned PET's.
#include <gtest/gtest.h>

#include <cmath>

#include "common/test_data.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

using authalic::test::authalic_binary;
using authalic::test::run_command;

namespace {

double correlation(const authalic::VectorXd& a, const authalic::VectorXd& b) {
  const double ma = a.mean(), mb = b.mean();
  return ((a.array() - ma) * (b.array() - mb)).sum() /
         std::sqrt(((a.array() - ma).square().sum()) * ((b.array() - mb).square().sum()));
}

}  // namespace

TEST(RegisterCli, MisalignedPetIsRegisteredToTheT1) {
  AUTHALIC_REQUIRE_SHARED(pet, "spm/PET.nii");
  AUTHALIC_REQUIRE_SHARED(t1, "mni152/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz");
  AUTHALIC_REQUIRE_SHARED(pial, "fsaverage5/pial_left.gii.gz");
  const std::string dir = authalic::test::temp_dir("register_cli");
  authalic::io::Volume moved = authalic::io::read_volume(pet);
  Eigen::Matrix4d R = Eigen::Matrix4d::Identity();
  const double a = 3.0 * M_PI / 180.0;
  R.block<3, 3>(0, 0) << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  R.block<3, 1>(0, 3) = Eigen::Vector3d(8, -5, 4);
  moved.vox2ras = R * moved.vox2ras;
  authalic::io::write_nifti(dir + "/moved.nii.gz", moved);

  std::string out;
  ASSERT_EQ(run_command(authalic_binary() + " sample " + pet + " " + pial + " " + dir + "/aligned.func.gii -q", &out), 0) << out;
  ASSERT_EQ(run_command(authalic_binary() + " sample " + dir + "/moved.nii.gz " + pial + " " + dir + "/moved.func.gii -q", &out), 0)
      << out;
  ASSERT_EQ(run_command(authalic_binary() + " sample " + dir + "/moved.nii.gz " + pial + " " + dir + "/registered.func.gii --register " +
                            t1 + " -q",
                        &out),
            0)
      << out;
  const auto aligned = authalic::io::read_per_vertex(dir + "/aligned.func.gii");
  const auto misaligned = authalic::io::read_per_vertex(dir + "/moved.func.gii");
  const auto registered = authalic::io::read_per_vertex(dir + "/registered.func.gii");
  // Measured: 0.93 after registration (PET and T1 are different templates), 0.17 without.
  EXPECT_GT(correlation(registered, aligned), 0.9);
  EXPECT_LT(correlation(misaligned, aligned), 0.5);

  // --register computes the transform: an explicit one as well is refused.
  EXPECT_EQ(run_command(authalic_binary() + " sample " + dir + "/moved.nii.gz " + pial + " " + dir + "/x.func.gii --register " + t1 +
                            " --surface-to-volume " + dir + "/none.txt",
                        &out),
            2);
  EXPECT_NE(out.find("--register"), std::string::npos) << out;
}

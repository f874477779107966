// The real files in ../shared/data load with the counts and ranges its README states, and
// spm/PET.nii's radiological affine gives the world coordinates nibabel gives.
#include <gtest/gtest.h>

#include <algorithm>

#include "common/test_data.h"
#include "core/error.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

using namespace authalic;
using namespace authalic::io;

namespace {
void expect_fsaverage5_surface(const std::string& path, int faces, double max_abs_coordinate) {
  const Surface s = read_surface(path);
  EXPECT_EQ(s.format, "gifti");
  EXPECT_EQ(s.mesh.num_vertices(), 10242) << path;
  EXPECT_EQ(s.mesh.num_faces(), faces) << path;
  EXPECT_LE(s.mesh.V.cwiseAbs().maxCoeff(), max_abs_coordinate) << path;
  EXPECT_GT(s.mesh.V.cwiseAbs().maxCoeff(), 0.3 * max_abs_coordinate) << path;
  EXPECT_GE(s.mesh.F.minCoeff(), 0);
  EXPECT_LT(s.mesh.F.maxCoeff(), 10242);
}
}  // namespace

TEST(RealData, Fsaverage5Surfaces) {
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(pial, "fsaverage5/pial_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(infl, "fsaverage5/infl_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(sphere, "fsaverage5/sphere_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(flat, "fsaverage5/flat_left.gii.gz");
  expect_fsaverage5_surface(white, 20480, 110.0);   // a left hemisphere in MNI305 mm
  expect_fsaverage5_surface(pial, 20480, 110.0);
  expect_fsaverage5_surface(infl, 20480, 120.0);
  expect_fsaverage5_surface(flat, 18654, 200.0);
  const Surface w = read_surface(white);
  // Left hemisphere: x from about -66 to +1 mm (nibabel: -65.65 .. 1.22).
  EXPECT_NEAR(w.mesh.V.col(0).minCoeff(), -65.649185, 1e-4);
  EXPECT_NEAR(w.mesh.V.col(0).maxCoeff(), 1.2215629, 1e-4);
  EXPECT_EQ(w.metadata.at("AnatomicalStructurePrimary"), "CortexLeft");
  const Surface sp = read_surface(sphere);
  EXPECT_EQ(sp.mesh.num_faces(), 20480);
  const VectorXd r = sp.mesh.V.rowwise().norm();
  EXPECT_NEAR(r.minCoeff(), 100.0, 0.5);  // FreeSurfer's sphere has radius 100
  EXPECT_NEAR(r.maxCoeff(), 100.0, 0.5);
}

TEST(RealData, Fsaverage5PerVertexData) {
  AUTHALIC_REQUIRE_SHARED(sulc, "fsaverage5/sulc_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(curv, "fsaverage5/curv_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(thick, "fsaverage5/thick_left.gii.gz");
  const VectorXd s = read_per_vertex(sulc, 10242);
  const VectorXd c = read_per_vertex(curv, 10242);
  const VectorXd t = read_per_vertex(thick, 10242);
  // Ranges as nibabel reports them.
  EXPECT_NEAR(s.minCoeff(), -1.4937248, 1e-6);
  EXPECT_NEAR(s.maxCoeff(), 1.8069096, 1e-6);
  EXPECT_NEAR(c.minCoeff(), -0.40463305, 1e-6);
  EXPECT_NEAR(t.maxCoeff(), 4.6552086, 1e-6);
  EXPECT_THROW(read_per_vertex(thick, 2562), InputError);
}

TEST(RealData, SpmPetRadiologicalAffineMatchesNibabel) {
  AUTHALIC_REQUIRE_SHARED(pet, "spm/PET.nii");
  const Volume v = read_volume(pet);
  EXPECT_EQ(v.dims, (std::array<int, 3>{91, 109, 91}));
  EXPECT_EQ(v.orientation_source, "sform");
  EXPECT_LT(v.vox2ras(0, 0), 0.0);  // radiological: x axis negative
  // nibabel 5 (nib.load('spm/PET.nii').affine @ [i,j,k,1]), computed once and hard-coded:
  //   voxel (10, 20, 30) -> (70, -86, -12); voxel (80, 100, 70) -> (-70, 74, 68).
  const Eigen::Vector4d a = v.vox2ras * Eigen::Vector4d(10, 20, 30, 1);
  const Eigen::Vector4d b = v.vox2ras * Eigen::Vector4d(80, 100, 70, 1);
  EXPECT_NEAR(a[0], 70.0, 1e-9);
  EXPECT_NEAR(a[1], -86.0, 1e-9);
  EXPECT_NEAR(a[2], -12.0, 1e-9);
  EXPECT_NEAR(b[0], -70.0, 1e-9);
  EXPECT_NEAR(b[1], 74.0, 1e-9);
  EXPECT_NEAR(b[2], 68.0, 1e-9);
  // Stored as uint8 with scl_slope 1/255: nibabel's scaled value at (10, 20, 30) is 0.0901960838.
  EXPECT_NEAR(v.at(10, 20, 30), 0.09019608376547694, 1e-7);
  EXPECT_NEAR(v.at(45, 63, 36), 0.62745101749897, 1e-7);
}

TEST(RealData, Mni152Uint8Template) {
  AUTHALIC_REQUIRE_SHARED(t1, "mni152/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz");
  const Volume v = read_volume(t1);
  EXPECT_EQ(v.dims, (std::array<int, 3>{197, 233, 189}));
  EXPECT_TRUE(v.voxel_size().isApprox(Eigen::Vector3d(1, 1, 1)));
  EXPECT_DOUBLE_EQ(v.vox2ras(0, 3), -98.0);
  EXPECT_DOUBLE_EQ(v.vox2ras(1, 3), -134.0);
  EXPECT_FLOAT_EQ(v.at(98, 116, 94), 198.0f);  // nibabel: dataobj[98,116,94] == 198
  const auto [lo, hi] = std::minmax_element(v.data.begin(), v.data.end());
  EXPECT_GE(*lo, 0.0f);
  EXPECT_LE(*hi, 255.0f);
}

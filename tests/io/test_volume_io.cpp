// Volumes: NIfTI-1/2 (nifti-clib), MGH/MGZ, DICOM series (ITK/GDCM). Round trips through our
// writers, and files written by nibabel (independent) for data types, scaling, orientation
// fallbacks, radiological affines and 4D frames.
#include <gtest/gtest.h>

#include <cmath>

#include "io/io_test_util.h"
#include "io/volume_formats.h"
#include "io/volume_io.h"

using namespace authalic;
using namespace authalic::io;
using namespace authalic::test;

namespace {

// 5x4x3 volume with distinct values and a radiological (negative x) oblique-free affine.
Volume sample_volume() {
  Volume v;
  v.dims = {5, 4, 3};
  v.data.resize(v.num_voxels());
  for (std::size_t i = 0; i < v.data.size(); ++i) v.data[i] = 0.5f * static_cast<float>(i) - 7.25f;
  v.vox2ras << -2, 0, 0, 90,  //
      0, 2.5, 0, -126,        //
      0, 0, 3, -72,           //
      0, 0, 0, 1;
  return v;
}

// value at the world point of voxel (i,j,k) of `a`, looked up in `b` (nearest voxel).
float value_at_world(const Volume& b, const Eigen::Vector4d& world) {
  const Eigen::Vector4d ijk = b.vox2ras.inverse() * world;
  const int i = static_cast<int>(std::lround(ijk[0])), j = static_cast<int>(std::lround(ijk[1])), k = static_cast<int>(std::lround(ijk[2]));
  return b.at(i, j, k);
}

}  // namespace

TEST(Nifti, RoundTripFloat32PlainAndGzip) {
  const std::string dir = temp_dir("nifti_roundtrip");
  const Volume v = sample_volume();
  for (const std::string name : {"/v.nii", "/v.nii.gz"}) {
    write_nifti(dir + name, v, "test");
    const Volume r = read_volume(dir + name);
    EXPECT_EQ(r.dims, v.dims);
    EXPECT_EQ(r.data, v.data) << name;
    EXPECT_TRUE(r.vox2ras.isApprox(v.vox2ras, 1e-6)) << name << "\n" << r.vox2ras;
    EXPECT_EQ(r.orientation_source, "sform");
  }
  EXPECT_EQ(list_dir(dir), (std::vector<std::string>{"v.nii", "v.nii.gz"}));
}

TEST(Nifti, Nifti2FromNibabel) {
  AUTHALIC_REQUIRE_NIBABEL();
  const std::string dir = temp_dir("nifti2");
  run_python(dir, R"(
aff = np.array([[-2.,0,0,90],[0,2.5,0,-126],[0,0,3,-72],[0,0,0,1]])
d = (np.arange(60, dtype=np.float32) * 0.5 - 7.25).reshape(5,4,3, order='F')
nib.save(nib.Nifti2Image(d, aff), ')" + dir + R"(/v2.nii')
nib.save(nib.Nifti2Image(d.astype(np.float64), aff), ')" + dir + R"(/v2.nii.gz')
)");
  const std::string bytes = read_bytes(dir + "/v2.nii");
  ASSERT_GE(bytes.size(), 4u);
  EXPECT_EQ(static_cast<unsigned char>(bytes[0]), 540 & 0xff);  // sizeof_hdr 540: really NIfTI-2
  EXPECT_EQ(static_cast<unsigned char>(bytes[1]), 540 >> 8);
  const Volume v = sample_volume();
  for (const std::string name : {"/v2.nii", "/v2.nii.gz"}) {
    const Volume r = read_volume(dir + name);
    EXPECT_EQ(r.data, v.data) << name;
    EXPECT_TRUE(r.vox2ras.isApprox(v.vox2ras, 1e-9)) << name;
  }
}

TEST(Nifti, NibabelAgreesOnOurAffine) {
  AUTHALIC_REQUIRE_NIBABEL();
  const std::string dir = temp_dir("nifti_nibabel_affine");
  write_nifti(dir + "/v.nii.gz", sample_volume());
  const std::vector<double> out = python_numbers(run_python(dir, R"(
im = nib.load(')" + dir + R"(/v.nii.gz')
q = im.header.get_qform(); s = im.header.get_sform()
assert np.allclose(q, s, atol=1e-5), (q, s)
print('OUT:', *im.affine.ravel(), np.asanyarray(im.dataobj)[4,3,2], im.header['sform_code'], im.header['qform_code'])
)"));
  ASSERT_EQ(out.size(), 19u);
  const Volume v = sample_volume();
  for (int k = 0; k < 16; ++k) EXPECT_NEAR(out[k], v.vox2ras(k / 4, k % 4), 1e-5);
  EXPECT_FLOAT_EQ(static_cast<float>(out[16]), v.at(4, 3, 2));
  EXPECT_EQ(out[17], 2);
  EXPECT_EQ(out[18], 2);
}

TEST(Nifti, DataTypesScalingAndQformFallbackFromNibabel) {
  AUTHALIC_REQUIRE_NIBABEL();
  const std::string dir = temp_dir("nifti_types");
  run_python(dir, R"(
aff = np.array([[-2.,0,0,90],[0,2,0,-126],[0,0,2,-72],[0,0,0,1]])
base = (np.arange(24).reshape(2,3,4, order='F') % 7).astype(np.float64)
for dt in ['uint8', 'int16', 'int32', 'float32', 'float64']:
    im = nib.Nifti1Image(base.astype(dt), aff); im.header.set_data_dtype(dt)
    im.set_sform(aff, 2); im.set_qform(aff, 2)
    nib.save(im, ')" + dir + R"(/t_%s.nii' % dt)
# int16 with scl_slope/inter: stored k, meaning 0.5*k + 10
im = nib.Nifti1Image(base.astype(np.int16), aff); im.header.set_slope_inter(0.5, 10.0)
nib.save(im, ')" + dir + R"(/scaled.nii')
# qform only (sform_code 0) with a different affine: the qform must be used
qaff = np.array([[3.,0,0,-10],[0,3,0,20],[0,0,3,5],[0,0,0,1]])
im = nib.Nifti1Image(base.astype(np.float32), None); im.set_qform(qaff, 1); im.set_sform(aff, 0)
nib.save(im, ')" + dir + R"(/qonly.nii.gz')
)");
  for (const std::string dt : {"uint8", "int16", "int32", "float32", "float64"}) {
    const Volume v = read_volume(dir + "/t_" + dt + ".nii");
    ASSERT_EQ(v.dims, (std::array<int, 3>{2, 3, 4})) << dt;
    // base[i,j,k] = (i + 2j + 6k) % 7 (Fortran order index)
    EXPECT_FLOAT_EQ(v.at(1, 2, 3), static_cast<float>((1 + 2 * 2 + 6 * 3) % 7)) << dt;
    EXPECT_FLOAT_EQ(v.at(0, 1, 2), static_cast<float>((0 + 2 + 12) % 7)) << dt;
    EXPECT_DOUBLE_EQ(v.vox2ras(0, 0), -2.0) << dt;
  }
  const Volume s = read_volume(dir + "/scaled.nii");
  EXPECT_FLOAT_EQ(s.at(1, 2, 3), 0.5f * ((1 + 4 + 18) % 7) + 10.0f);
  const Volume q = read_volume(dir + "/qonly.nii.gz");
  EXPECT_EQ(q.orientation_source, "qform");
  EXPECT_NEAR(q.vox2ras(0, 0), 3.0, 1e-6);
  EXPECT_NEAR(q.vox2ras(1, 3), 20.0, 1e-6);
}

TEST(Nifti, FourDFramesSelectSumOrRefuse) {
  AUTHALIC_REQUIRE_NIBABEL();
  const std::string dir = temp_dir("nifti_4d");
  run_python(dir, R"(
d = np.zeros((2,2,2,3), dtype=np.float32)
for t in range(3): d[..., t] = t + 1
d[1,1,1,:] = [10, 20, 30]
im = nib.Nifti1Image(d, np.diag([2., 2., 2., 1.]))
nib.save(im, ')" + dir + R"(/dyn.nii.gz')
)");
  const std::string path = dir + "/dyn.nii.gz";
  expect_input_error([&] { read_volume(path); }, path, "3 frames");
  VolumeReadOptions frame2;
  frame2.frame = 2;
  EXPECT_FLOAT_EQ(read_volume(path, frame2).at(0, 0, 0), 3.0f);
  EXPECT_FLOAT_EQ(read_volume(path, frame2).at(1, 1, 1), 30.0f);
  VolumeReadOptions sum;
  sum.sum_frames = true;
  EXPECT_FLOAT_EQ(read_volume(path, sum).at(0, 0, 0), 6.0f);
  EXPECT_FLOAT_EQ(read_volume(path, sum).at(1, 1, 1), 60.0f);
  VolumeReadOptions bad;
  bad.frame = 3;
  expect_input_error([&] { read_volume(path, bad); }, path, "frame 3 does not exist");
}

TEST(Nifti, UnsupportedTypeAndNoOrientationAreRefused) {
  AUTHALIC_REQUIRE_NIBABEL();
  const std::string dir = temp_dir("nifti_refuse");
  run_python(dir, R"(
im = nib.Nifti1Image(np.ones((2,2,2), dtype=np.complex64), np.eye(4)); nib.save(im, ')" + dir + R"(/complex.nii')
im = nib.Nifti1Image(np.ones((2,2,2), dtype=np.float32), np.eye(4)); im.set_sform(None, 0); im.set_qform(None, 0)
nib.save(im, ')" + dir + R"(/noorient.nii')
)");
  expect_input_error([&] { read_volume(dir + "/complex.nii"); }, dir + "/complex.nii", "unsupported data type complex64");
  expect_input_error([&] { read_volume(dir + "/noorient.nii"); }, dir + "/noorient.nii", "no usable orientation");
}

TEST(Mgh, RoundTripAndNibabelAgree) {
  const std::string dir = temp_dir("mgh");
  const Volume v = sample_volume();
  write_mgh(dir + "/v.mgz", v);
  write_mgh(dir + "/v.mgh", v);
  for (const std::string name : {"/v.mgz", "/v.mgh"}) {
    const Volume r = read_volume(dir + name);
    EXPECT_EQ(r.data, v.data);
    EXPECT_TRUE(r.vox2ras.isApprox(v.vox2ras, 1e-5)) << r.vox2ras;
    EXPECT_EQ(r.orientation_source, "mgh");
  }
  AUTHALIC_REQUIRE_NIBABEL();
  // nibabel's MGH affine and tkregister vox2ras for our file, and a conformed (LIA) orig.mgz-like
  // file written by nibabel read by us.
  const std::vector<double> out = python_numbers(run_python(dir, R"(
im = nib.load(')" + dir + R"(/v.mgz')
aff = np.array([[-1.,0,0,130.5],[0,0,1,-110.25],[0,-1,0,140.0],[0,0,0,1]])
c = nib.MGHImage(np.arange(8*8*8, dtype=np.float32).reshape(8,8,8), aff)
nib.save(c, ')" + dir + R"(/orig.mgz')
c = nib.load(')" + dir + R"(/orig.mgz')
print('OUT:', *im.affine.ravel(), *c.affine.ravel(), *c.header.get_vox2ras_tkr().ravel())
)"));
  ASSERT_EQ(out.size(), 48u);
  for (int k = 0; k < 16; ++k) EXPECT_NEAR(out[k], v.vox2ras(k / 4, k % 4), 1e-5);
  const MghHeader h = read_mgh_header(dir + "/orig.mgz");
  const Eigen::Matrix4d vox2ras = mgh_vox2ras(h), tkr = mgh_tkr_vox2ras(h);
  for (int k = 0; k < 16; ++k) {
    EXPECT_NEAR(out[16 + k], vox2ras(k / 4, k % 4), 1e-4);
    EXPECT_NEAR(out[32 + k], tkr(k / 4, k % 4), 1e-4);
  }
  // tkr -> scanner is a pure translation by c_ras.
  const Eigen::Matrix4d t = mgh_tkr_to_scanner(h);
  const Eigen::Matrix3d rotation = t.topLeftCorner(3, 3);
  const Eigen::Vector3d translation = t.topRightCorner(3, 1);
  EXPECT_TRUE(rotation.isIdentity(1e-9));
  EXPECT_TRUE(translation.isApprox(h.c_ras, 1e-9));
  EXPECT_FLOAT_EQ(read_volume(dir + "/orig.mgz").at(3, 5, 7), static_cast<float>(3 * 64 + 5 * 8 + 7));  // C-order arange
}

TEST(Dicom, SeriesRoundTripInRas) {
  const std::string dir = temp_dir("dicom") + "/series";
  Volume v = sample_volume();
  // Include a positive-determinant oblique-free affine too: DICOM slices are sorted by position.
  write_dicom_series(dir, v);
  EXPECT_EQ(list_dir(dir).size(), 3u);
  const Volume r = read_volume(dir);
  EXPECT_EQ(r.orientation_source, "dicom");
  EXPECT_EQ(r.units, "Bq/mL");
  ASSERT_EQ(r.num_voxels(), v.num_voxels());
  EXPECT_TRUE(r.voxel_size().isApprox(v.voxel_size(), 1e-6));
  // Same value at the same RAS point (the reader may order slices differently than we wrote).
  const double tol = 12.0 / 32000.0;  // int16 quantisation with slope max|v|/32000
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 5; ++i) {
        const Eigen::Vector4d world = r.vox2ras * Eigen::Vector4d(i, j, k, 1);
        EXPECT_NEAR(r.at(i, j, k), value_at_world(v, world), tol) << i << "," << j << "," << k;
      }
  // The corner voxel (0,0,0) of the original is at RAS (90, -126, -72), not LPS.
  const Eigen::Vector4d corner = v.vox2ras * Eigen::Vector4d(0, 0, 0, 1);
  EXPECT_NEAR(value_at_world(r, corner), v.at(0, 0, 0), tol);
}

TEST(VolumeDispatch, ContentDecidesForUnknownExtensions) {
  const std::string dir = temp_dir("volume_dispatch");
  const Volume v = sample_volume();
  write_mgh(dir + "/v.mgz", v);
  std::filesystem::rename(dir + "/v.mgz", dir + "/v.volume");
  EXPECT_EQ(read_volume(dir + "/v.volume").data, v.data);  // gzipped MGH recognised by content
  write_nifti(dir + "/n.nii", v);
  std::filesystem::rename(dir + "/n.nii", dir + "/n.dat");
  expect_input_error([&] { read_volume(dir + "/n.dat"); }, dir + "/n.dat", "rename it to .nii");
  write_bytes(dir + "/x.bin", "not a volume at all");
  expect_input_error([&] { read_volume(dir + "/x.bin"); }, dir + "/x.bin", "unknown volume format");
  expect_input_error([&] { read_volume(dir + "/missing.nii"); }, dir + "/missing.nii", "file not found");
}

// NIfTI-1 xyzt_units: an affine in metres (a header written by some converters for small-animal
// or phantom scans) or micrometres is converted to mm, as the standard says and ITK does; 0
// (unknown) and mm are read as mm. The file is made by nibabel with its units set.
TEST(Nifti, AffineInMetresOrMicrometresIsConvertedToMm) {
  AUTHALIC_REQUIRE_NIBABEL();
  const std::string dir = temp_dir("nifti_units");
  run_python(dir, R"(
d = np.ones((5, 4, 3), dtype=np.float32)
for units, scale in (('meter', 0.001), ('micron', 1000.0), ('mm', 1.0), ('unknown', 1.0)):
    aff = np.array([[-2.,0,0,90],[0,2.5,0,-126],[0,0,3,-72],[0,0,0,1]])
    aff[:3] *= scale
    img = nib.Nifti1Image(d, aff)
    img.header.set_xyzt_units(xyz=units)
    nib.save(img, ')" + dir + R"(/' + units + '.nii')
)");
  const Volume v = sample_volume();
  for (const std::string units : {"meter", "micron", "mm", "unknown"}) {
    const Volume r = read_volume(dir + "/" + units + ".nii");
    EXPECT_TRUE(r.vox2ras.isApprox(v.vox2ras, 1e-6)) << units << "\n" << r.vox2ras;
    const bool converted = units == "meter" || units == "micron";
    EXPECT_EQ(r.orientation_source.find("converted to mm") != std::string::npos, converted) << units << ": " << r.orientation_source;
  }
}

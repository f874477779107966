// Bad input (issue 2): each reader rejects truncated files, wrong magic numbers, counts that do not
// match the file size, face indices out of range, NaN/Inf coordinates, per-vertex files of the
// wrong length and NIfTI without orientation, with one InputError line naming the file.
#include <gtest/gtest.h>

#include <limits>

#include "io/io_internal.h"
#include "io/io_test_util.h"
#include "io/surface_formats.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

using namespace authalic;
using namespace authalic::io;
using namespace authalic::test;

namespace {

// A FreeSurfer triangle surface built byte by byte (so every field can be corrupted).
std::string fs_surface_bytes(const TriMesh& m, int nv_header, int nf_header, unsigned magic = 0xFFFFFE) {
  detail::BigEndianWriter w;
  w.u24(magic);
  w.bytes("created by test\n\n");
  w.i32(nv_header);
  w.i32(nf_header);
  for (int i = 0; i < m.num_vertices(); ++i)
    for (int c = 0; c < 3; ++c) w.f32(static_cast<float>(m.V(i, c)));
  for (int f = 0; f < m.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) w.i32(m.F(f, c));
  return w.out;
}

}  // namespace

TEST(BadInput, FreeSurferSurface) {
  const std::string dir = temp_dir("bad_fs_surface");
  const TriMesh m = octahedron();
  const std::string good = fs_surface_bytes(m, 6, 8);
  const std::string p = dir + "/lh.white";

  write_bytes(p, good.substr(0, good.size() - 10));
  expect_input_error([&] { read_surface(p); }, p, "counts do not match the file size");
  write_bytes(p, good.substr(0, 10));
  expect_input_error([&] { read_surface(p); }, p, "truncated");
  write_bytes(p, fs_surface_bytes(m, 6, 8, 0x123456));
  expect_input_error([&] { read_surface(p); }, p, "wrong magic number 0x123456");
  write_bytes(p, fs_surface_bytes(m, 6, 80000));
  expect_input_error([&] { read_surface(p); }, p, "counts do not match the file size");
  write_bytes(p, fs_surface_bytes(m, -6, 8));
  expect_input_error([&] { read_surface(p); }, p, "implausible vertex count");

  TriMesh out_of_range = m;
  out_of_range.F(3, 1) = 6;
  write_bytes(p, fs_surface_bytes(out_of_range, 6, 8));
  expect_input_error([&] { read_surface(p); }, p, "face 3 uses vertex 6");
  out_of_range.F(3, 1) = -1;
  write_bytes(p, fs_surface_bytes(out_of_range, 6, 8));
  expect_input_error([&] { read_surface(p); }, p, "face 3 uses vertex -1");

  TriMesh nan = m;
  nan.V(2, 1) = std::numeric_limits<double>::quiet_NaN();
  write_bytes(p, fs_surface_bytes(nan, 6, 8));
  expect_input_error([&] { read_surface(p); }, p, "vertex 2 has a non-finite coordinate");
  nan.V(2, 1) = std::numeric_limits<double>::infinity();
  write_bytes(p, fs_surface_bytes(nan, 6, 8));
  expect_input_error([&] { read_surface(p); }, p, "vertex 2 has a non-finite coordinate");

  // A footer that claims to be a volume geometry but is garbled: refused (its cras matters).
  std::string footer = good;
  detail::BigEndianWriter tag;
  tag.i32(2);
  tag.i32(0);
  tag.i32(20);
  footer += tag.out + "valid = 1\nfilename = x\nvolume = 256 256\n";
  write_bytes(p, footer);
  expect_input_error([&] { read_surface(p); }, p, "volume-geometry");

  write_bytes(p, "");
  expect_input_error([&] { read_surface(p); }, p, "truncated");
  expect_input_error([&] { read_surface(dir + "/missing.white"); }, dir + "/missing.white", "file not found");
}

TEST(BadInput, FreeSurferCurvAndLength) {
  const std::string dir = temp_dir("bad_fs_curv");
  const std::string p = dir + "/lh.thickness";
  std::string good = detail::serialize_freesurfer_curv((VectorXd(4) << 1, 2, 3, 4).finished());
  write_bytes(p, good.substr(0, good.size() - 2));
  expect_input_error([&] { read_per_vertex(p); }, p, "counts do not match the file size");
  write_bytes(p, good);
  expect_input_error([&] { read_per_vertex(p, 10242); }, p, "has 4 values but the surface has 10242 vertices");
  std::string nan = detail::serialize_freesurfer_curv((VectorXd(2) << 1, std::numeric_limits<double>::quiet_NaN()).finished());
  write_bytes(p, nan);
  expect_input_error([&] { read_per_vertex(p); }, p, "value 1 is not finite");
  write_bytes(p, std::string("\x01\x02\x03\x04\x05\x06\x07\x08\x09", 9) + std::string(3, '\0'));
  expect_input_error([&] { read_per_vertex(p); }, p, "wrong magic number");
  // A surface given where per-vertex data is expected.
  write_surface(dir + "/lh.white", octahedron());
  expect_input_error([&] { read_per_vertex(dir + "/lh.white"); }, dir + "/lh.white", "is a FreeSurfer surface");
  write_bytes(dir + "/v.txt", "1\n2\nthree\n");
  expect_input_error([&] { read_per_vertex(dir + "/v.txt"); }, dir + "/v.txt", "line 3 is not a single number");
}

TEST(BadInput, FreeSurferLabelAndPatch) {
  const std::string dir = temp_dir("bad_fs_label");
  const std::string l = dir + "/lh.cortex.label";
  write_bytes(l, "#!ascii label\n3\n0 1 2 3 0\n5 1 2 3 0\n");
  expect_input_error([&] { read_freesurfer_label(l); }, l, "truncated");
  write_bytes(l, "#!ascii label\n1000000\n0 1 2 3 0\n");
  expect_input_error([&] { read_freesurfer_label(l); }, l, "does not match the file size");
  write_bytes(l, "#!ascii label\n1\n-4 1 2 3 0\n");
  expect_input_error([&] { read_freesurfer_label(l); }, l, "negative vertex index");
  write_bytes(l, "#!ascii label\n1\n4 1 nan 3 0\n");
  expect_input_error([&] { read_freesurfer_label(l); }, l, "non-finite coordinate");
  write_bytes(l, "hello\n");
  expect_input_error([&] { read_freesurfer_label(l); }, l, "not a FreeSurfer label");

  const std::string p = dir + "/lh.patch.flat";
  const std::string good = detail::serialize_freesurfer_patch({0, 1, 2}, MatrixXd::Ones(3, 3));
  write_bytes(p, good.substr(0, good.size() - 5));
  expect_input_error([&] { read_freesurfer_patch(p); }, p, "counts do not match the file size");
  std::string zero = good;
  zero[8] = zero[9] = zero[10] = zero[11] = 0;  // vertex code 0 is impossible (stored k+1)
  write_bytes(p, zero);
  expect_input_error([&] { read_freesurfer_patch(p); }, p, "invalid vertex code 0");
  const Patch ok = detail::parse_freesurfer_patch(good, p);
  TriMesh small = octahedron();
  small.V.conservativeResize(2, 3);
  small.F.resize(0, 3);
  EXPECT_THROW(patch_mesh(small, ok), InputError);  // vertex 2 is outside a 2-vertex surface
}

TEST(BadInput, Gifti) {
  AUTHALIC_REQUIRE_NIBABEL();
  const std::string dir = temp_dir("bad_gifti");
  write_surface(dir + "/good.surf.gii", octahedron());
  const std::string good = read_bytes(dir + "/good.surf.gii");
  const std::string p = dir + "/x.surf.gii";
  write_bytes(p, good.substr(0, good.size() / 2));
  expect_input_error([&] { read_surface(p); }, p, "corrupt");
  write_bytes(dir + "/x.surf.gii.gz", detail::gzip(good).substr(0, 100));
  expect_input_error([&] { read_surface(dir + "/x.surf.gii.gz"); }, dir + "/x.surf.gii.gz", "gzip stream is truncated");
  run_python(dir, R"(
v = np.array([[0,0,0],[1,0,0],[0,1,0],[0,0,1]], dtype=np.float32)
f = np.array([[0,2,1],[0,1,3],[0,3,2],[1,2,9]], dtype=np.int32)
def save(v, f, name, extra=[]):
    d = [nib.gifti.GiftiDataArray(v, intent='NIFTI_INTENT_POINTSET', datatype='NIFTI_TYPE_FLOAT32'),
         nib.gifti.GiftiDataArray(f, intent='NIFTI_INTENT_TRIANGLE', datatype='NIFTI_TYPE_INT32')] + extra
    nib.save(nib.gifti.GiftiImage(darrays=d), ')" + dir + R"(/' + name)
save(v, f, 'range.surf.gii')
vn = v.copy(); vn[1, 2] = np.inf
save(vn, f % 4, 'inf.surf.gii')
save(v, f % 4, 'noTri.surf.gii')
nib.save(nib.gifti.GiftiImage(darrays=[nib.gifti.GiftiDataArray(v, intent='NIFTI_INTENT_POINTSET', datatype='NIFTI_TYPE_FLOAT32')]), ')" + dir + R"(/points_only.surf.gii')
nib.save(nib.gifti.GiftiImage(darrays=[nib.gifti.GiftiDataArray(np.arange(7, dtype=np.float32), intent='NIFTI_INTENT_SHAPE', datatype='NIFTI_TYPE_FLOAT32')]), ')" + dir + R"(/seven.shape.gii')
)");
  expect_input_error([&] { read_surface(dir + "/range.surf.gii"); }, dir + "/range.surf.gii", "face 3 uses vertex 9");
  expect_input_error([&] { read_surface(dir + "/inf.surf.gii"); }, dir + "/inf.surf.gii", "vertex 1 has a non-finite coordinate");
  expect_input_error([&] { read_surface(dir + "/points_only.surf.gii"); }, dir + "/points_only.surf.gii", "no triangle array");
  expect_input_error([&] { read_per_vertex(dir + "/seven.shape.gii", 10242); }, dir + "/seven.shape.gii",
                     "has 7 values but the surface has 10242 vertices");
  expect_input_error([&] { read_surface(dir + "/seven.shape.gii"); }, dir + "/seven.shape.gii", "no pointset");
  // External data files are refused, not followed.
  std::string ext = good;
  const std::size_t at = ext.find("GZipBase64Binary");
  ASSERT_NE(at, std::string::npos);
  ext.replace(at, 16, "ExternalFileBinary");
  write_bytes(dir + "/ext.surf.gii", ext);
  expect_input_error([&] { read_surface(dir + "/ext.surf.gii"); }, dir + "/ext.surf.gii", "ExternalFileBinary");
}

TEST(BadInput, VtkFamily) {
  const std::string dir = temp_dir("bad_vtk");
  const std::string p = dir + "/r.vtk";
  write_bytes(p, "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 7\n");
  EXPECT_THROW(read_surface(p), InputError);
  // Binary STL with a NaN corner (VTK's ASCII OBJ parser turns "nan" into 0, binary keeps it).
  std::string stl(80, ' ');
  const std::uint32_t one = 1;
  stl.append(reinterpret_cast<const char*>(&one), 4);
  const float tri[12] = {0, 0, 1, 0, 0, 0, 1, 0, std::numeric_limits<float>::quiet_NaN(), 0, 1, 0};
  stl.append(reinterpret_cast<const char*>(tri), sizeof(tri));
  stl.append(2, '\0');
  write_bytes(dir + "/n.stl", stl);
  expect_input_error([&] { read_surface(dir + "/n.stl"); }, dir + "/n.stl", "non-finite");
  write_bytes(dir + "/u.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 0 float\n");
  expect_input_error([&] { read_surface(dir + "/u.vtk"); }, dir + "/u.vtk", "POLYDATA");
  write_bytes(dir + "/what.xyz", "abc");
  expect_input_error([&] { read_surface(dir + "/what.xyz"); }, dir + "/what.xyz", "magic");
}

TEST(BadInput, NiftiAndMgh) {
  const std::string dir = temp_dir("bad_volume");
  Volume v;
  v.dims = {4, 4, 4};
  v.data.assign(64, 1.0f);
  v.vox2ras = Eigen::Matrix4d::Identity();
  write_nifti(dir + "/good.nii", v);
  const std::string good = read_bytes(dir + "/good.nii");
  write_bytes(dir + "/cut.nii", good.substr(0, good.size() - 100));
  expect_input_error([&] { read_volume(dir + "/cut.nii"); }, dir + "/cut.nii", "truncated");
  std::string magic = good;
  magic[344] = 'x';  // "n+1" -> "x+1"
  magic[0] = 0x11;   // and sizeof_hdr no longer 348
  write_bytes(dir + "/magic.nii", magic);
  expect_input_error([&] { read_volume(dir + "/magic.nii"); }, dir + "/magic.nii", "not a readable NIfTI");
  // sform_code (offset 254) and qform_code (252) zeroed: no usable orientation.
  std::string noorient = good;
  noorient[252] = noorient[253] = noorient[254] = noorient[255] = 0;
  write_bytes(dir + "/noorient.nii", noorient);
  expect_input_error([&] { read_volume(dir + "/noorient.nii"); }, dir + "/noorient.nii", "no usable orientation");

  write_mgh(dir + "/good.mgh", v);
  const std::string mgh = read_bytes(dir + "/good.mgh");
  write_bytes(dir + "/cut.mgh", mgh.substr(0, 300));
  expect_input_error([&] { read_volume(dir + "/cut.mgh"); }, dir + "/cut.mgh", "truncated");
  std::string ver = mgh;
  ver[3] = 7;
  write_bytes(dir + "/ver.mgh", ver);
  expect_input_error([&] { read_volume(dir + "/ver.mgh"); }, dir + "/ver.mgh", "wrong version/magic 7");
  std::string noras = mgh;
  noras[28] = noras[29] = 0;  // goodRASflag
  write_bytes(dir + "/noras.mgh", noras);
  expect_input_error([&] { read_volume(dir + "/noras.mgh"); }, dir + "/noras.mgh", "no valid orientation");
  write_bytes(dir + "/cut.mgz", detail::gzip(mgh).substr(0, 40));
  expect_input_error([&] { read_volume(dir + "/cut.mgz"); }, dir + "/cut.mgz", "gzip stream is truncated");
  std::error_code ec;
  std::filesystem::create_directories(dir + "/empty_dicom", ec);
  expect_input_error([&] { read_volume(dir + "/empty_dicom"); }, dir + "/empty_dicom", "no DICOM series");
}

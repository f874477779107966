// FreeSurfer binary surfaces, curv, label and patch files: round trips through our writers, and
// cross-checks against nibabel.freesurfer (an independent implementation of the same layouts).
#include <gtest/gtest.h>

#include <cmath>

#include "common/hard_meshes.h"
#include "io/io_test_util.h"
#include "io/io_internal.h"
#include "io/surface_formats.h"
#include "io/surface_io.h"

using namespace authalic;
using namespace authalic::io;
using namespace authalic::test;

namespace {

VolumeGeometry sample_geometry() {
  VolumeGeometry vg;
  vg.valid = true;
  vg.filename = "/subjects/bert/mri/filled-pretess255.mgz";
  vg.volume = {256, 256, 256};
  vg.voxelsize = {1, 1, 1};
  vg.xras = {-1, 0, 0};
  vg.yras = {0, 0, -1};
  vg.zras = {0, 1, 0};
  vg.cras = {5.25, -18.5, 22.125};
  return vg;
}

}  // namespace

TEST(FreeSurferSurface, RoundTripWithVolumeGeometry) {
  const std::string dir = temp_dir("fs_surface_roundtrip");
  const TriMesh m = octahedron();
  SurfaceWriteOptions opt;
  opt.volume_geometry = sample_geometry();
  write_surface(dir + "/lh.white", m, opt);
  const Surface s = read_surface(dir + "/lh.white");
  EXPECT_EQ(s.format, "freesurfer");
  EXPECT_EQ(s.space, "tkregister RAS");
  EXPECT_TRUE(s.mesh.V.isApprox(m.V, 1e-6));  // float32 storage
  EXPECT_EQ(s.mesh.F, m.F);
  ASSERT_TRUE(s.has_volume_geometry);
  EXPECT_TRUE(s.c_ras.isApprox(Eigen::Vector3d(5.25, -18.5, 22.125)));
  EXPECT_EQ(s.volume_geometry.filename, opt.volume_geometry.filename);
  EXPECT_EQ(s.volume_geometry.volume, opt.volume_geometry.volume);
  EXPECT_TRUE(s.volume_geometry.yras.isApprox(Eigen::Vector3d(0, 0, -1)));
  // scanner = tkr + c_ras
  const Eigen::Vector4d tkr(1, 2, 3, 1);
  EXPECT_TRUE((s.to_scanner * tkr).isApprox(Eigen::Vector4d(6.25, -16.5, 25.125, 1)));
  EXPECT_EQ(list_dir(dir), std::vector<std::string>{"lh.white"});  // no temporary left behind
}

TEST(FreeSurferSurface, WithoutFooterHasIdentityTransform) {
  const std::string dir = temp_dir("fs_surface_nofooter");
  write_surface(dir + "/rh.pial", octahedron());
  const Surface s = read_surface(dir + "/rh.pial");
  EXPECT_FALSE(s.has_volume_geometry);
  EXPECT_TRUE(s.to_scanner.isIdentity());
}

TEST(FreeSurferSurface, FlatMeshGetsZeroZ) {
  const std::string dir = temp_dir("fs_surface_flat");
  TriMesh m = octahedron();
  m.V = m.V.leftCols(2).eval();
  write_surface(dir + "/lh.flat", m);
  const Surface s = read_surface(dir + "/lh.flat");
  EXPECT_TRUE(s.mesh.V.leftCols(2).isApprox(m.V));
  EXPECT_EQ(s.mesh.V.col(2).cwiseAbs().maxCoeff(), 0.0);
}

TEST(FreeSurferSurface, ReadsNibabelWrittenSurfaceAndNibabelReadsOurs) {
  AUTHALIC_REQUIRE_NIBABEL();
  const std::string dir = temp_dir("fs_surface_nibabel");
  // nibabel writes a surface with a volume_info footer; we read it.
  run_python(dir, R"(
from collections import OrderedDict
v = np.array([[1.5,2.5,3.5],[-4.0,5.0,6.0],[7.0,-8.0,9.25],[0.5,0.25,-0.125]], dtype=np.float32)
f = np.array([[0,1,2],[0,2,3],[0,3,1],[1,3,2]], dtype=np.int32)
vi = OrderedDict([('head', np.array([2, 0, 20], dtype=np.int32)), ('valid', '1  # volume info valid'),
  ('filename', 'orig.mgz'), ('volume', np.array([256,256,256])), ('voxelsize', np.array([1.,1.,1.])),
  ('xras', np.array([-1.,0.,0.])), ('yras', np.array([0.,0.,-1.])), ('zras', np.array([0.,1.,0.])),
  ('cras', np.array([1.25,-2.5,3.75]))])
nib.freesurfer.write_geometry(')" + dir + R"(/nib.white', v, f, create_stamp='created by nibabel', volume_info=vi)
)");
  const Surface s = read_surface(dir + "/nib.white");
  ASSERT_EQ(s.mesh.num_vertices(), 4);
  ASSERT_EQ(s.mesh.num_faces(), 4);
  EXPECT_DOUBLE_EQ(s.mesh.V(2, 2), 9.25);
  EXPECT_EQ(s.mesh.F(3, 1), 3);
  ASSERT_TRUE(s.has_volume_geometry);
  EXPECT_TRUE(s.c_ras.isApprox(Eigen::Vector3d(1.25, -2.5, 3.75)));
  EXPECT_EQ(s.volume_geometry.filename, "orig.mgz");

  // nibabel reads what we write, footer included.
  SurfaceWriteOptions opt;
  opt.volume_geometry = sample_geometry();
  write_surface(dir + "/ours.white", octahedron(), opt);
  const std::vector<double> out = python_numbers(run_python(dir, R"(
v, f, meta = nib.freesurfer.read_geometry(')" + dir + R"(/ours.white', read_metadata=True)
print('OUT:', v.shape[0], f.shape[0], v[4,2], f[7,2], *meta['cras'], *meta['volume'])
)"));
  ASSERT_EQ(out.size(), 10u);
  EXPECT_EQ(out[0], 6);
  EXPECT_EQ(out[1], 8);
  EXPECT_DOUBLE_EQ(out[2], 13.125);
  EXPECT_EQ(out[3], 5);
  EXPECT_DOUBLE_EQ(out[4], 5.25);
  EXPECT_DOUBLE_EQ(out[5], -18.5);
  EXPECT_DOUBLE_EQ(out[6], 22.125);
  EXPECT_EQ(out[7], 256);
}

TEST(FreeSurferCurv, RoundTripAndNibabel) {
  const std::string dir = temp_dir("fs_curv");
  MatrixXd values(5, 1);
  values << -1.5, 0.0, 2.25, 3.125e-3, 100.0;
  write_per_vertex(dir + "/lh.thickness", values);
  const VectorXd back = read_per_vertex(dir + "/lh.thickness", 5);
  EXPECT_TRUE(back.isApprox(values.col(0), 1e-7));
  AUTHALIC_REQUIRE_NIBABEL();
  const std::vector<double> nib_values = python_numbers(run_python(dir, R"(
print('OUT:', *nib.freesurfer.read_morph_data(')" + dir + R"(/lh.thickness'))
nib.freesurfer.write_morph_data(')" + dir + R"(/lh.nib', np.array([4.5, -3.25, 0.5], dtype=np.float32))
)"));
  ASSERT_EQ(nib_values.size(), 5u);
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(nib_values[i], values(i, 0), 1e-6 * (1 + std::abs(values(i, 0))));
  const VectorXd from_nib = read_per_vertex(dir + "/lh.nib");
  ASSERT_EQ(from_nib.size(), 3);
  EXPECT_DOUBLE_EQ(from_nib[1], -3.25);
}

TEST(FreeSurferCurv, OldFormatIsRead) {
  // Old curv: 3-byte vertex and face counts, then int16 hundredths.
  const std::string dir = temp_dir("fs_curv_old");
  detail::BigEndianWriter w;
  w.u24(3);
  w.u24(2);
  w.i16(150);
  w.i16(-25);
  w.i16(0);
  write_bytes(dir + "/lh.curv", w.out);
  const VectorXd v = read_per_vertex(dir + "/lh.curv", 3);
  EXPECT_DOUBLE_EQ(v[0], 1.5);
  EXPECT_DOUBLE_EQ(v[1], -0.25);
}

TEST(TextPerVertex, RoundTrip) {
  const std::string dir = temp_dir("text_per_vertex");
  MatrixXd values(3, 1);
  values << 0.125, -7.5, 1e6;
  write_per_vertex(dir + "/values.txt", values);
  EXPECT_TRUE(read_per_vertex(dir + "/values.txt", 3).isApprox(values.col(0)));
}

TEST(FreeSurferLabel, RoundTripAndRegion) {
  const std::string dir = temp_dir("fs_label");
  Label l;
  l.vertices = {4, 0, 2};
  l.positions.resize(3, 3);
  l.positions << 1.5, 2.5, 3.5, -1, -2, -3, 0.125, 0.25, 0.5;
  l.values.resize(3);
  l.values << 0.5, 1, 0;
  write_freesurfer_label(dir + "/lh.cortex.label", l);
  const Label back = read_freesurfer_label(dir + "/lh.cortex.label");
  EXPECT_EQ(back.vertices, l.vertices);
  EXPECT_TRUE(back.positions.isApprox(l.positions, 1e-6));
  EXPECT_TRUE(back.values.isApprox(l.values));
  EXPECT_EQ(read_region_vertices(dir + "/lh.cortex.label", 6), (std::vector<int>{0, 2, 4}));
  expect_input_error([&] { read_region_vertices(dir + "/lh.cortex.label", 4); }, dir + "/lh.cortex.label", "outside");
  AUTHALIC_REQUIRE_NIBABEL();
  const std::vector<double> nib_vertices =
      python_numbers(run_python(dir, "print('OUT:', *nib.freesurfer.read_label('" + dir + "/lh.cortex.label'))\n"));
  EXPECT_EQ(nib_vertices, (std::vector<double>{4, 0, 2}));
}

// A label with no vertex is refused as an empty region, also where the checks against the
// surface run (they once averaged its zero positions: a crash, exit 139, in run, sample and flatten).
TEST(FreeSurferLabel, AnEmptyLabelIsAnEmptyRegion) {
  const std::string dir = temp_dir("fs_label_empty");
  write_bytes(dir + "/empty.label", "#!ascii label  , from subject vox2ras=TkReg\n0\n");
  const TriMesh grid = test::square_grid(4);
  expect_input_error([&] { read_region_vertices(dir + "/empty.label", 25); }, dir + "/empty.label", "region is empty");
  expect_input_error([&] { read_region_vertices(dir + "/empty.label", grid); }, dir + "/empty.label", "region is empty");
  expect_input_error([&] { read_region_file(dir + "/empty.label", grid); }, dir + "/empty.label", "region is empty");
}

// A label stores positions on the surface it was drawn on. One of this mesh (drawn on its white
// surface, or on a sphere with the same triangles) is read; one of another mesh whose indices
// happen to be in range (here: the same points under another vertex numbering) is refused.
TEST(FreeSurferLabel, ALabelOfAnotherMeshIsRefused) {
  const std::string dir = temp_dir("fs_label_mesh");
  constexpr int kSide = 24;  // a 24 x 24 grid of 1 mm squares, two triangles each
  TriMesh grid = test::square_grid(kSide - 1);  // vertex r kSide + c at (c, r) mm
  grid.V *= kSide - 1;
  Label own;
  for (int v = 0; v < grid.V.rows(); v += 1 + v % 2) own.vertices.push_back(v);  // two thirds of the vertices
  const Eigen::Index n = static_cast<Eigen::Index>(own.vertices.size());
  own.positions.resize(n, 3);
  own.values = VectorXd::Zero(n);
  for (Eigen::Index k = 0; k < n; ++k) own.positions.row(k) = grid.V.row(own.vertices[static_cast<std::size_t>(k)]);
  write_freesurfer_label(dir + "/own.label", own);
  EXPECT_EQ(read_region_vertices(dir + "/own.label", grid).size(), static_cast<std::size_t>(n));

  Label sphere = own;  // drawn on a sphere of radius 100 mm with the same triangles
  for (Eigen::Index k = 0; k < n; ++k) {
    const double lon = 0.02 * own.positions(k, 0), lat = 0.02 * own.positions(k, 1);
    sphere.positions.row(k) << 100 * std::cos(lat) * std::cos(lon), 100 * std::cos(lat) * std::sin(lon), 100 * std::sin(lat);
  }
  write_freesurfer_label(dir + "/sphere.label", sphere);
  EXPECT_EQ(read_region_vertices(dir + "/sphere.label", grid).size(), static_cast<std::size_t>(n));

  Label small;  // a few rings around vertex (12, 12): its extent is a few edges
  for (int r = 10; r <= 14; ++r)
    for (int c = 10; c <= 14; ++c) small.vertices.push_back(r * kSide + c);
  small.positions.resize(25, 3);
  small.values = VectorXd::Zero(25);
  for (Eigen::Index k = 0; k < 25; ++k) small.positions.row(k) = 3.0 * grid.V.row(small.vertices[static_cast<std::size_t>(k)]);
  write_freesurfer_label(dir + "/small.label", small);  // drawn on a surface 3 x larger (a sphere)
  EXPECT_EQ(read_region_vertices(dir + "/small.label", grid).size(), 25u);

  Label bare = own;  // written without coordinates
  bare.positions.setZero();
  write_freesurfer_label(dir + "/bare.label", bare);
  EXPECT_EQ(read_region_vertices(dir + "/bare.label", grid).size(), static_cast<std::size_t>(n));

  Label other = own;  // another mesh: its vertex k is this mesh's vertex (37 k mod 576)
  for (Eigen::Index k = 0; k < n; ++k) other.positions.row(k) = grid.V.row((37 * own.vertices[static_cast<std::size_t>(k)]) % (kSide * kSide));
  write_freesurfer_label(dir + "/other.label", other);
  expect_input_error([&] { read_region_vertices(dir + "/other.label", grid); }, dir + "/other.label", "another mesh");
  expect_input_error([&] { read_region_file(dir + "/other.label", grid); }, dir + "/other.label", "do not follow this surface's triangles");
  // Without the surface only the index range is checked.
  EXPECT_EQ(read_region_vertices(dir + "/other.label", kSide * kSide).size(), static_cast<std::size_t>(n));
}

TEST(FreeSurferPatch, RoundTripAndPatchMesh) {
  const std::string dir = temp_dir("fs_patch");
  const TriMesh parent = octahedron();
  // Keep the upper four faces: vertices 0..4 (vertex 5 dropped).
  const std::vector<int> kept = {0, 1, 2, 3, 4};
  MatrixXd xy(5, 3);
  xy << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 0;
  write_freesurfer_patch(dir + "/lh.cortex.patch.flat", kept, xy);
  const Patch p = read_freesurfer_patch(dir + "/lh.cortex.patch.flat");
  EXPECT_EQ(p.vertices, kept);
  EXPECT_TRUE(p.positions.isApprox(xy));
  const TriMesh flat = patch_mesh(parent, p);
  EXPECT_EQ(flat.num_faces(), 4);
  EXPECT_EQ(flat.num_vertices(), 6);
  EXPECT_TRUE(flat.V.row(2).isApprox(Eigen::RowVector3d(0, 1, 0)));
  EXPECT_EQ(p.on_border, std::vector<bool>(5, false));
  // Border vertices are stored as -(k+1) and read back flagged.
  write_freesurfer_patch(dir + "/b.patch.flat", kept, xy, {true, true, true, true, false});
  const std::string bytes = detail::read_file(dir + "/b.patch.flat");
  ASSERT_GE(bytes.size(), 12u);
  EXPECT_EQ(static_cast<unsigned char>(bytes[8]), 0xFF) << "vertex 0 on the border is stored as -1";
  EXPECT_EQ(read_freesurfer_patch(dir + "/b.patch.flat").on_border, (std::vector<bool>{true, true, true, true, false}));
  EXPECT_EQ(read_freesurfer_patch(dir + "/b.patch.flat").vertices, kept);
  // A patch is not a surface: read_surface says what to do instead.
  expect_input_error([&] { read_surface(dir + "/lh.cortex.patch.flat"); }, dir + "/lh.cortex.patch.flat", "patch");
}

TEST(FreeSurferPatch, BorderFlagAndOldFormat) {
  const std::string dir = temp_dir("fs_patch_old");
  detail::BigEndianWriter w;  // old format: count, then int index + 3 int16 hundredths
  w.i32(2);
  w.i32(8);    // vertex 7, interior
  w.i16(150);
  w.i16(-50);
  w.i16(0);
  w.i32(-3);   // vertex 2, border
  w.i16(1);
  w.i16(2);
  w.i16(3);
  write_bytes(dir + "/old.patch", w.out);
  const Patch p = read_freesurfer_patch(dir + "/old.patch");
  EXPECT_EQ(p.vertices, (std::vector<int>{7, 2}));
  EXPECT_EQ(p.on_border, (std::vector<bool>{false, true}));
  EXPECT_DOUBLE_EQ(p.positions(0, 0), 1.5);
  EXPECT_DOUBLE_EQ(p.positions(1, 2), 0.03);
}

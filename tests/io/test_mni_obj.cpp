// MNI .obj polygon surfaces (CIVET, the MNI tools): files written by VTK's own MNI writer (another
// implementation, through Debian's python3-vtk9) read as their meshes, ASCII and binary; known
// answers for hand-written files (polygons, colours per item, long lines, big-endian binary); and
// one clear refusal per kind of damage.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/test_data.h"
#include "io/io_internal.h"
#include "io/io_test_util.h"
#include "io/surface_formats.h"
#include "io/surface_io.h"

using namespace authalic;
using namespace authalic::io;
using namespace authalic::test;

namespace {

// python3-vtk9 beside nibabel: installed by scripts/install_deps.sh, so required under CI=true.
bool python_vtk_available() {
  static const bool ok = run_command("/usr/bin/python3 -c 'import vtk'") == 0;
  return ok;
}

// A quad and a triangle sharing an edge, one colour per item, everything on one line (> 255
// characters: VTK's reader would cut it).
std::string two_polygons_on_one_line() {
  std::string s = "P 0.3 0.3 0.4 10 1 5";
  s += "   0 0 0   1 0 0   1 1 0   0 1 0   2 0.5 0";      // points
  s += "   0 0 1   0 0 1   0 0 1   0 0 1   0 0 1";         // normals
  s += "   2   1   1 0 0 1   0 1 0 1";                     // 2 items, colour per item
  s += "   4 7   0 1 2 3   1 4 2";                         // end indices, corners
  while (s.size() < 400) s += "  ";
  return s + "\n";
}

}  // namespace

TEST(MniObj, FilesWrittenByVtksMniWriterReadAsTheirMesh) {
  AUTHALIC_REQUIRE_NIBABEL();
  if (!python_vtk_available()) {
    if (running_in_ci()) FAIL() << "CI=true but python3-vtk9 is missing (scripts/install_deps.sh installs it)";
    GTEST_SKIP() << "python3-vtk9 not found";
  }
  const std::string dir = temp_dir("mni_obj_vtk");
  const std::string out = run_python(dir, R"(
import vtk
s = vtk.vtkSphereSource(); s.SetThetaResolution(9); s.SetPhiResolution(7); s.SetCenter(10, -20, 30); s.SetRadius(40)
s.Update(); pd = s.GetOutput()
for kind in ('ascii', 'binary'):
    w = vtk.vtkMNIObjectWriter(); w.SetInputData(pd); w.SetFileName(')" + dir + R"(/' + kind + '.obj')
    w.SetFileTypeToBinary() if kind == 'binary' else w.SetFileTypeToASCII()
    assert w.Write() == 1
pts = [pd.GetPoint(i) for i in range(pd.GetNumberOfPoints())]
ids = vtk.vtkIdList(); tris = []
for c in range(pd.GetNumberOfCells()):
    pd.GetCellPoints(c, ids); tris.append([ids.GetId(k) for k in range(ids.GetNumberOfIds())])
assert all(len(t) == 3 for t in tris)
print('OUT:', len(pts), len(tris), *[x for p in pts for x in p], *[i for t in tris for i in t])
)");
  const std::vector<double> v = python_numbers(out);
  ASSERT_GE(v.size(), 2u);
  const int nv = static_cast<int>(v[0]), nf = static_cast<int>(v[1]);
  ASSERT_EQ(v.size(), 2u + 3u * nv + 3u * nf);
  for (const std::string kind : {"ascii", "binary"}) {
    const Surface s = read_surface(dir + "/" + kind + ".obj");
    EXPECT_EQ(s.format, "mni_obj") << kind;
    ASSERT_EQ(s.mesh.num_vertices(), nv) << kind;
    ASSERT_EQ(s.mesh.num_faces(), nf) << kind;
    // ASCII holds 6 significant digits (VTK's writer), binary float32.
    const double tol = kind == std::string("ascii") ? 1e-4 : 1e-5;
    for (int i = 0; i < nv; ++i)
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(s.mesh.V(i, c), v[2 + 3 * i + c], tol) << kind << " vertex " << i;
    for (int f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(s.mesh.F(f, c), static_cast<int>(v[2 + 3 * nv + 3 * f + c])) << kind << " face " << f;
  }
}

TEST(MniObj, PolygonsAreFanTriangulatedAndLongLinesRead) {
  const std::string dir = temp_dir("mni_obj_known");
  write_bytes(dir + "/two.obj", two_polygons_on_one_line());
  const Surface s = read_surface(dir + "/two.obj");
  EXPECT_EQ(s.format, "mni_obj");
  ASSERT_EQ(s.mesh.num_vertices(), 5);
  ASSERT_EQ(s.mesh.num_faces(), 3);  // the quad gives 2 triangles, in its orientation
  EXPECT_EQ(s.mesh.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(s.mesh.F.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(s.mesh.F.row(2), Eigen::RowVector3i(1, 4, 2));
  EXPECT_EQ(s.mesh.V.row(4), Eigen::RowVector3d(2, 0.5, 0));
}

TEST(MniObj, BinaryInEitherByteOrderIsReadByItsCounts) {
  // One triangle, one colour, written big-endian (as an old SGI or Sun wrote it) and little-endian.
  detail::BigEndianWriter be;
  be.u8('p');
  for (int k = 0; k < 5; ++k) be.f32(0.5f);
  be.i32(3);
  const float pts[9] = {1, 2, 3, 4, 5, 6, 7, 8, 10};
  for (const float x : pts) be.f32(x);
  for (int k = 0; k < 9; ++k) be.f32(0.0f);
  be.i32(1);
  be.i32(0);
  be.u32(0xFFFFFFFFu);  // one colour: 4 bytes
  be.i32(3);
  for (const int i : {0, 2, 1}) be.i32(i);
  std::string le = be.out;
  for (std::size_t at = 1; at < le.size(); at += 4) std::swap(le[at], le[at + 3]), std::swap(le[at + 1], le[at + 2]);

  const std::string dir = temp_dir("mni_obj_binary");
  for (const auto& [name, bytes] : {std::pair<std::string, std::string>{"be.obj", be.out}, {"le.obj", le}}) {
    write_bytes(dir + "/" + name, bytes);
    const Surface s = read_surface(dir + "/" + name);
    EXPECT_EQ(s.format, "mni_obj") << name;
    ASSERT_EQ(s.mesh.num_faces(), 1) << name;
    EXPECT_EQ(s.mesh.F.row(0), Eigen::RowVector3i(0, 2, 1)) << name;
    EXPECT_EQ(s.mesh.V.row(2), Eigen::RowVector3d(7, 8, 10)) << name;
  }
  // Cut short: the counts fit neither order, and the parser (not VTK's Wavefront reader) says so.
  write_bytes(dir + "/cut.obj", be.out.substr(0, be.out.size() - 4));
  expect_input_error([&] { read_surface(dir + "/cut.obj"); }, dir + "/cut.obj", "do not match its");
}

TEST(MniObj, DamagedFilesAreRefusedWithOneLineEach) {
  const std::string dir = temp_dir("mni_obj_bad");
  const std::string head = "P 0.3 0.3 0.4 10 1 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\n0 0 1\n0 0 1\n0 0 1\n0 0 1\n\n";
  const std::string good = head + "2\n0 1 1 1 1\n\n3 6\n\n0 1 2 0 2 3\n";
  write_bytes(dir + "/good.obj", good);
  EXPECT_EQ(read_surface(dir + "/good.obj").mesh.num_faces(), 2);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {good.substr(0, good.size() - 6), "ends before its polygon corner"},
      {head + "2\n0 1 1 1 1\n\n3 6\n\n0 1 2 0 2 4\n", "is point 4 of an object with 4 points (0..3)"},
      {head + "2\n0 1 1 1 1\n\n3 2\n\n0 1 2\n", "polygon 1 has -1 corners"},
      {head + "2\n0 1 1 1 1\n\n3 5\n\n0 1 2 0 2\n", "polygon 1 has 2 corners"},
      {head + "2\n3 1 1 1 1\n\n3 6\n\n0 1 2 0 2 3\n", "colour flag is 3"},
      {head + "2\n0 1 1 1 1\n\n3 6\n\n0 1 2 0 2 3\nP 1 2 3\n", "data after the last polygon index"},
      {"P 0.3 0.3 0.4 10 1 4\n0 0 nan\n" + std::string(60, ' '), "'nan' is not a finite number"},
      {"P 0.3 0.3 0.4 10 1 4000\n0 0 0\n", "declares 4000 points, more than its 30 bytes can hold"},
      {"P 0.3 0.3 0.4 10 1 4000000000\n0 0 0\n", "more than the"},
      {"P 0.3 0.3 0.4 10 1 -4\n", "point count is negative"},
      {"L 1 4\n0 0 0\n", "MNI line object"},
  };
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const std::string path = dir + "/bad" + std::to_string(k) + ".obj";
    write_bytes(path, cases[k].first);
    expect_input_error([&] { read_surface(path); }, path, cases[k].second);
  }
}

TEST(MniObj, WavefrontObjIsStillReadByVtk) {
  // The content decides: a Wavefront file named .obj is not taken for an MNI object.
  const std::string dir = temp_dir("mni_obj_wavefront");
  write_bytes(dir + "/w.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_EQ(read_surface(dir + "/w.obj").format, "obj");
  EXPECT_FALSE(detail::looks_like_mni_obj("v 0 0 0\n"));
  EXPECT_FALSE(detail::looks_like_mni_obj("p 1 2\n"));  // a Wavefront point element, not a binary MNI object
  EXPECT_TRUE(detail::looks_like_mni_obj(two_polygons_on_one_line()));
}

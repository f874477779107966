// VTK-family surfaces: every format round-trips; polygons are triangulated; STL soups are welded.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include "io/base64.h"
#include "io/io_test_util.h"
#include "io/surface_formats.h"
#include "io/surface_io.h"
#include "io/vtk_family_check.h"

using namespace authalic;
using namespace authalic::io;
using namespace authalic::test;

TEST(VtkFamily, EveryFormatRoundTrips) {
  const std::string dir = temp_dir("vtk_roundtrip");
  const TriMesh m = octahedron();
  for (const std::string ext : {"vtk", "vtp", "ply", "obj", "stl"}) {
    const std::string path = dir + "/mesh." + ext;
    write_surface(path, m);
    const Surface s = read_surface(path);
    EXPECT_EQ(s.format, ext);
    ASSERT_EQ(s.mesh.num_vertices(), 6) << ext;  // STL: 24 soup corners welded back to 6
    ASSERT_EQ(s.mesh.num_faces(), 8) << ext;
    if (ext == "stl") {
      // Welding renumbers vertices: compare each triangle's corner positions.
      for (int f = 0; f < 8; ++f)
        for (int c = 0; c < 3; ++c) EXPECT_TRUE(s.mesh.V.row(s.mesh.F(f, c)).isApprox(m.V.row(m.F(f, c)), 1e-6)) << ext;
    } else {
      EXPECT_TRUE(s.mesh.V.isApprox(m.V, 1e-6)) << ext;
      EXPECT_EQ(s.mesh.F, m.F) << ext;
    }
  }
  EXPECT_EQ(list_dir(dir).size(), 5u);
}

TEST(VtkFamily, PolygonsAreFanTriangulated) {
  const std::string dir = temp_dir("vtk_quads");
  // One quad and one pentagon in a legacy ASCII file: 2 + 3 triangles.
  write_bytes(dir + "/q.vtk",
              "# vtk DataFile Version 3.0\nquads\nASCII\nDATASET POLYDATA\nPOINTS 7 float\n"
              "0 0 0  1 0 0  1 1 0  0 1 0  2 0 0  2 1 0  1.5 2 0\n"
              "POLYGONS 2 11\n4 0 1 2 3\n5 1 4 5 6 2\n");
  const Surface s = read_surface(dir + "/q.vtk");
  ASSERT_EQ(s.mesh.num_faces(), 5);
  EXPECT_EQ(s.mesh.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(s.mesh.F.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(s.mesh.F.row(4), Eigen::RowVector3i(1, 6, 2));
}

// An OBJ whose corners carry their own normals and texture coordinates (one normal per face, as
// exporters write flat-shaded meshes) keeps the numbering of its v lines: vtkOBJReader alone
// gave every such corner a point of its own, a triangle soup (fsaverage5: 61,440 points).
TEST(VtkFamily, ObjCornersWithOwnNormalsKeepTheVertexNumbering) {
  const std::string dir = temp_dir("vtk_obj_normals");
  const TriMesh m = octahedron();
  std::string obj = "# octahedron, one normal and texture coordinate per face corner\n";
  for (int v = 0; v < 6; ++v)
    obj += "v " + std::to_string(m.V(v, 0)) + " " + std::to_string(m.V(v, 1)) + " " + std::to_string(m.V(v, 2)) + "\n";
  for (int f = 0; f < 8; ++f) obj += "vn 0 0 1\nvt 0." + std::to_string(f) + " 0.5\n";
  for (int f = 0; f < 8; ++f) {
    obj += "f";
    for (int c = 0; c < 3; ++c) obj += " " + std::to_string(m.F(f, c) + 1) + "/" + std::to_string(f + 1) + "/" + std::to_string(f + 1);
    obj += "\n";
  }
  write_bytes(dir + "/facets.obj", obj);
  const Surface s = read_surface(dir + "/facets.obj");
  ASSERT_EQ(s.mesh.num_vertices(), 6);
  EXPECT_TRUE(s.mesh.V.isApprox(m.V, 1e-6));
  EXPECT_EQ(s.mesh.F, m.F);
  // Relative (negative) vertex indices and v//vn corners too.
  std::string relative = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf -3//1 -2//1 -1//1\nv 1 1 0\nf 2//1 4//1 3//1\n";
  write_bytes(dir + "/relative.obj", relative);
  const Surface r = read_surface(dir + "/relative.obj");
  ASSERT_EQ(r.mesh.num_vertices(), 4);
  EXPECT_EQ(r.mesh.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(r.mesh.F.row(1), Eigen::RowVector3i(1, 3, 2));
}

// STL has no vertex numbering: a label, mask or map made for the mesh cannot pair with it.
TEST(VtkFamily, StlSurfacesRefusePerVertexFiles) {
  const std::string dir = temp_dir("vtk_stl_numbering");
  write_surface(dir + "/mesh.stl", octahedron());
  write_surface(dir + "/mesh.ply", octahedron());
  expect_input_error([&] { require_vertex_numbering(read_surface(dir + "/mesh.stl"), dir + "/mesh.stl", dir + "/cortex.label"); },
                     dir + "/cortex.label", "an STL file has no vertex numbering");
  EXPECT_NO_THROW(require_vertex_numbering(read_surface(dir + "/mesh.ply"), dir + "/mesh.ply", dir + "/cortex.label"));
  EXPECT_NO_THROW(require_vertex_numbering(read_surface(dir + "/mesh.stl"), dir + "/mesh.stl", ""));  // no such file given
}

TEST(VtkFamily, MergeCoincidentVertices) {
  TriMesh soup;
  soup.V.resize(6, 3);
  soup.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  soup.F.resize(2, 3);
  soup.F << 0, 1, 2, 3, 4, 5;
  EXPECT_EQ(detail::merge_coincident_vertices(soup), 2);
  EXPECT_EQ(soup.num_vertices(), 4);
  EXPECT_EQ(soup.F.row(1), Eigen::RowVector3i(1, 3, 2));
}

TEST(VtkFamily, MagicBeatsExtension) {
  // A GIFTI saved under a .vtk name is still read as GIFTI; a FreeSurfer surface named .obj too.
  const std::string dir = temp_dir("vtk_magic");
  write_surface(dir + "/a.surf.gii", octahedron());
  std::filesystem::rename(dir + "/a.surf.gii", dir + "/a.vtk");
  EXPECT_EQ(read_surface(dir + "/a.vtk").format, "gifti");
  write_surface(dir + "/lh.white", octahedron());
  std::filesystem::rename(dir + "/lh.white", dir + "/b.obj");
  EXPECT_EQ(read_surface(dir + "/b.obj").format, "freesurfer");
}

// ---- hostile input (issue 17): every broken file is an InputError naming the file ----------

namespace {

std::string ply_header(const std::string& format, long long vertices, long long faces) {
  return "ply\nformat " + format + " 1.0\nelement vertex " + std::to_string(vertices) +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " + std::to_string(faces) +
         "\nproperty list uchar int vertex_indices\nend_header\n";
}

template <class T>
void append_le(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));  // the test machines are little-endian
}

// A binary PLY triangle: 3 vertices and one face (list length `list_length`, 3 indices present).
std::string binary_ply_triangle(int list_length, std::int32_t last_corner = 2) {
  std::string s = ply_header("binary_little_endian", 3, 1);
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) append_le(s, v);
  s.push_back(static_cast<char>(list_length));
  for (std::int32_t i : {0, 1, last_corner}) append_le(s, i);
  return s;
}

std::string binary_stl(std::uint32_t declared, int present) {
  std::string s(80, ' ');
  append_le(s, declared);
  for (int t = 0; t < present; ++t) {
    for (float v : {0.f, 0.f, 1.f, 0.f, 0.f, float(t), 1.f, 0.f, float(t), 0.f, 1.f, float(t)}) append_le(s, v);
    s.append(2, '\0');
  }
  return s;
}

void expect_refused(const std::string& path, const std::string& bytes, const std::string& fragment) {
  write_bytes(path, bytes);
  expect_input_error([&] { read_surface(path); }, path, fragment);
}

}  // namespace

TEST(VtkHostile, TruncatedBinaryPlyHeaderOnly) {
  // vtkPLYReader aborted (munmap_chunk(): invalid pointer) on a header without a body.
  const std::string dir = temp_dir("vtk_hostile_ply_cut");
  const std::string header = ply_header("binary_little_endian", 3, 1);
  expect_refused(dir + "/h.ply", header, "declares 3 vertices and 1 faces (needs at least 49 bytes) but the file has 0 bytes");
  // Cut inside the body, and a face whose list runs past the end of the file.
  const std::string good = binary_ply_triangle(3);
  expect_refused(dir + "/cut.ply", good.substr(0, good.size() - 5), "bytes after its header");
  expect_refused(dir + "/list.ply", binary_ply_triangle(200), "ends inside face 0 of 1");
}

TEST(VtkHostile, PlyFaceCornerOutsideTheVertices) {
  // Found by fuzz_ply: vtkPLYReader looks the corners up while reading (SEGV in vtkCell::Initialize).
  const std::string dir = temp_dir("vtk_hostile_ply_corner");
  expect_refused(dir + "/b.ply", binary_ply_triangle(3, 0x037b0000), "PLY face 0 uses vertex 58392576, outside 0..2");
  expect_refused(dir + "/n.ply", binary_ply_triangle(3, -1), "PLY face 0 uses vertex -1, outside 0..2");
  expect_refused(dir + "/a.ply", ply_header("ascii", 3, 1) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "PLY face 0 uses vertex 3, outside 0..2");
  expect_refused(dir + "/zero.ply", binary_ply_triangle(0), "PLY face 0 has 0 corners (at least 3 needed)");
  expect_refused(dir + "/two.ply", ply_header("ascii", 3, 1) + "0 0 0\n1 0 0\n0 1 0\n2 0 1   \n", "PLY face 0 has 2 corners");
  // Found by fuzz_ply: a face element without its corner list crashed vtkPLY::ply_close.
  std::string no_list = ply_header("ascii", 3, 0) + "0 0 0\n1 0 0\n0 1 0\n";
  no_list.replace(no_list.find("property list"), 8, "comment ");
  expect_refused(dir + "/nolist.ply", no_list, "PLY face element has no vertex_indices list");
}

TEST(VtkHostile, PlyControlCharacters) {
  // Found by fuzz_ply: "property\v float z" split differently by vtkPLY (SEGV in find_element).
  const std::string dir = temp_dir("vtk_hostile_ply_ctrl");
  std::string vt = binary_ply_triangle(3);
  vt.replace(vt.find("property float z"), 8, "property\v");
  expect_refused(dir + "/vt.ply", vt, "PLY header line 6 holds control character 11");
  expect_refused(dir + "/a.ply", ply_header("ascii", 3, 1) + "0 0 0\n1\v0 0\n0 1 0\n3 0 1 2\n", "line 11 holds control character 11");
  // Found by fuzz_ply: the last ASCII line without its newline crashed vtkPLY (invalid free).
  expect_refused(dir + "/nl.ply", ply_header("ascii", 3, 1) + "0 0 0\n1.5 0 0\n0 2.5 0\n3 0 1 2 ", "line 13 does not end with a newline");
}

TEST(VtkHostile, PlyDeclaringHugeCountsIsRefusedFromTheHeader) {
  // 10^8 vertices with no body once printed a VTK warning per missing vertex for minutes.
  const std::string dir = temp_dir("vtk_hostile_ply_huge");
  expect_refused(dir + "/e8.ply", ply_header("binary_little_endian", 100000000, 0),
                 "declares 100000000 vertices and 0 faces (needs at least 1200000000 bytes)");
  expect_refused(dir + "/e8a.ply", ply_header("ascii", 100000000, 0), "declares 100000000 vertices");
  expect_refused(dir + "/e9.ply", ply_header("binary_big_endian", 2147483648LL, 0), "declares 2147483648 vertices and 0 faces");
  // Counts the body could hold but no surface should have (cap lowered to keep the file small).
  const std::size_t saved = detail::g_max_vtk_vertices;
  detail::g_max_vtk_vertices = 2;
  write_bytes(dir + "/cap.ply", binary_ply_triangle(3));
  expect_input_error([&] { read_surface(dir + "/cap.ply"); }, dir + "/cap.ply", "declares 3 vertices, more than the 2 accepted");
  detail::g_max_vtk_vertices = saved;
}

TEST(VtkHostile, AsciiPlyNeedsOneElementPerLine) {
  // Two vertices on one line made vtkPLYReader read past the end of the file (abort).
  const std::string dir = temp_dir("vtk_hostile_ply_ascii");
  const std::string header = ply_header("ascii", 3, 1);
  expect_refused(dir + "/two.ply", header + "0 0 0 1 0 0\n0 1 0\n3 0 1 2\n", "line 10 has 6 values but vertex 0 needs 3");
  expect_refused(dir + "/short.ply", header + "0 0 0\n1 0 0\n0 1 0\n5 0 1 2\n", "line 13 has too few values for face 0");
  expect_refused(dir + "/nan.ply", header + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", "line 11: 'nan' is not a valid float");
}

TEST(VtkHostile, LegacyVtkDeclaringHugeCounts) {
  // 2^31 points ended in std::bad_alloc inside vtkPolyDataReader.
  const std::string dir = temp_dir("vtk_hostile_legacy");
  const std::string head = "# vtk DataFile Version 3.0\nx\nBINARY\nDATASET POLYDATA\n";
  expect_refused(dir + "/huge.vtk", head + "POINTS 2147483648 float\n", "declares 2147483648 points, more than the 50000000 accepted");
  expect_refused(dir + "/cut.vtk", head + "POINTS 1000 float\n" + std::string(100, '\0'),
                 "declares 3000 POINTS values (needs 12000 bytes) but only 100 bytes follow");
  const std::string ascii = "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\n";
  expect_refused(dir + "/polys.vtk", ascii + "POLYGONS 1 2000000000\n3 0 1 2\n", "declares 2000000000 cell values");
  expect_refused(dir + "/cell.vtk", ascii + "POLYGONS 1 4\n9 0 1 2\n", "POLYGONS cell 0 does not fit in the declared 4 values");
  const std::string v5 = "# vtk DataFile Version 5.1\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\n";
  expect_refused(dir + "/offsets.vtk", v5 + "POLYGONS 2 3\nOFFSETS vtktypeint64\n0 300\nCONNECTIVITY vtktypeint64\n0 1 2\n",
                 "POLYGONS offset 1 is out of order or beyond the 3 connectivity entries");
  expect_refused(dir + "/abc.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 abc 0 0 1 0\n",
                 "POINTS value 4 'abc' is not a finite number");
}

TEST(VtkHostile, VtpDeclaringHugeCounts) {
  const std::string dir = temp_dir("vtk_hostile_vtp");
  expect_refused(dir + "/huge.vtp",
                 "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n<PolyData>\n"
                 "<Piece NumberOfPoints=\"2147483648\" NumberOfPolys=\"1\">\n</Piece></PolyData></VTKFile>\n",
                 "declares 2147483648 points, more than the 50000000 accepted");
  expect_refused(dir + "/big.vtp",
                 "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n<PolyData>\n"
                 "<Piece NumberOfPoints=\"1000000\" NumberOfPolys=\"1\">\n</Piece></PolyData></VTKFile>\n",
                 "declares 1000000 points and 1 cells but the file has only");
  // Found by fuzz_vtk: a huge NumberOfComponents made vtkXMLPolyDataReader allocate for minutes.
  const std::string head = "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n<PolyData>\n"
                           "<Piece NumberOfPoints=\"3\" NumberOfPolys=\"1\">\n<Points>\n<DataArray type=\"Float32\" NumberOfComponents=\"";
  const std::string tail = "\" format=\"ascii\">\n0 0 0 1 0 0 0 1 0\n</DataArray>\n</Points>\n</Piece></PolyData></VTKFile>\n";
  expect_refused(dir + "/comps.vtp", head + "3444444444444444444444444444444444" + tail, "NumberOfComponents='3444444444444444444444444444444444' is not a non-negative integer");
  expect_refused(dir + "/comps2.vtp", head + "100000" + tail, "array has 100000 components (1 to 16 accepted)");
  // Found by fuzz_vtk: Points with 6 components made the reader stop half-way and leak.
  expect_refused(dir + "/comps6.vtp", head + "6" + tail, "Points array does not declare NumberOfComponents=\"3\"");
  // Found by fuzz_vtk: a corrupt compressed block header made VTK allocate 14 GB. Here the
  // writer's (base64, zlib) points header claims 2^31 - 1 blocks.
  write_surface(dir + "/w.vtp", octahedron());
  std::string w = read_bytes(dir + "/w.vtp");
  const std::size_t data = w.find('_', w.find("<AppendedData")) + 1;
  w.replace(data, 8, "////fwCA");  // base64 of ff ff ff 7f 00 80: block count 2^31 - 1, block size kept
  expect_refused(dir + "/blocks.vtp", w, "compressed array declares 2147483647 blocks");
  // Found by fuzz_vtk (CI): one block whose compressed size claims 2.9 GB; VTK allocated it.
  // The writer's first header is [blocks][block size][last size][compressed size] in UInt32
  // (16 bytes = 24 base64 digits), then the data; the compressed size is rewritten.
  std::string c = read_bytes(dir + "/w.vtp");
  std::vector<std::uint8_t> header = base64_decode(c.substr(data, 24));
  ASSERT_EQ(header.size(), 16u);
  ASSERT_EQ(header[0], 1u);  // one block: the octahedron's 6 points
  const std::uint32_t huge = 2919235603u;
  std::memcpy(header.data() + 12, &huge, 4);
  c.replace(data, 24, base64_encode(header));
  expect_refused(dir + "/csize.vtp", c, "compressed block 1 of 1 declares 2919235603 bytes but");
}

TEST(VtkHostile, ObjVertexLinesAreValidated) {
  // VTK's OBJ reader turned these into (0,0,0), FLT_MAX or z = 0 without a word.
  const std::string dir = temp_dir("vtk_hostile_obj");
  const std::string rest = "v 1 0 0\nv 0 1 0\nf 1 2 3\n";
  expect_refused(dir + "/nan.obj", "# c\nv nan 0 0\n" + rest, "line 2: 'nan' is not a finite number");
  expect_refused(dir + "/abc.obj", "v abc 0 0\n" + rest, "line 1: 'abc' is not a finite number");
  expect_refused(dir + "/big.obj", "v 1e400 0 0\n" + rest, "line 1: '1e400' is not a finite number");
  expect_refused(dir + "/two.obj", "v 1 2\n" + rest, "line 1: 'v' has 2 numbers");
  expect_refused(dir + "/tail.obj", "v 1 2 3x\n" + rest, "line 1: '3x' is not a finite number");
  const std::string verts = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  expect_refused(dir + "/idx.obj", verts + "f 1 2 9\n", "line 4: vertex index 9 is outside the 3 declared");
  expect_refused(dir + "/zero.obj", verts + "f 0 1 2\n", "line 4: '0' is not a valid vertex index");
  expect_refused(dir + "/rel.obj", verts + "f -1 -2 -4\n", "line 4: vertex index -4 is outside the 3 declared");
  // A texture index past the vt lines made VTK read beyond its array (garbage coordinates).
  expect_refused(dir + "/vt.obj", verts + "vt 0 0\nf 1/1 2/5 3/1\n", "line 5: texture coordinate index 5 is outside the 1 declared");
  expect_refused(dir + "/f2.obj", verts + "f 1 2\n", "line 4: 'f' needs at least 3 vertex indices");
  // Found by fuzz_obj: a corner of another form than the first crashed vtkOBJReader (SEGV).
  expect_refused(dir + "/mix.obj", verts + "f 1 3/ 2\n", "line 4: corner ends with '/'");
  expect_refused(dir + "/mix2.obj", verts + "vt 0 0\nf 1 2/1 3\n", "line 5: corners mix the forms");
  // Relative indices and v/vt/vn groups are legal OBJ.
  write_bytes(dir + "/ok.obj", verts + "vt 0 0\nvn 0 0 1\nf -3/1/1 -2/1/1 -1/1/1\n");
  const Surface s = read_surface(dir + "/ok.obj");
  ASSERT_EQ(s.mesh.num_faces(), 1);
  EXPECT_EQ(s.mesh.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(s.mesh.V(2, 1), 1.0);
}

TEST(VtkHostile, StlSizesAndAsciiVertices) {
  const std::string dir = temp_dir("vtk_hostile_stl");
  expect_refused(dir + "/count.stl", binary_stl(4294967295u, 4),
                 "binary STL header declares 4294967295 triangles (needs 214748364834 bytes) but the file has 284 bytes");
  expect_refused(dir + "/short.stl", binary_stl(5, 4), "declares 5 triangles (needs 334 bytes) but the file has 284 bytes");
  const std::string facet = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n";
  expect_refused(dir + "/nan.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n",
                 "line 5: 'vertex' needs three finite numbers");
  expect_refused(dir + "/two.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0\n", "line 4: 'vertex' needs three finite numbers");
  // A valid ASCII STL (the writer makes binary ones, covered by EveryFormatRoundTrips).
  write_bytes(dir + "/ok.stl", "solid x\n" + facet + "endsolid x\n");
  const Surface s = read_surface(dir + "/ok.stl");
  EXPECT_EQ(s.mesh.num_vertices(), 3);
  EXPECT_EQ(s.mesh.num_faces(), 1);
}

TEST(VtkHostile, ValidAsciiVariantsStillRead) {
  // The writers make binary PLY/VTK and appended VTP; the ASCII variants are written by hand.
  const std::string dir = temp_dir("vtk_hostile_ascii_ok");
  const std::string tri = "0 0 0\n1.5 0 0\n0 2.5 0\n";
  write_bytes(dir + "/a.ply", ply_header("ascii", 3, 1) + tri + "3 0 1 2\n");
  write_bytes(dir + "/b.ply", binary_ply_triangle(3));
  write_bytes(dir + "/a.vtk", "# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET POLYDATA\nFIELD FieldData 1\nTIME 1 1 double\n7\n"
                              "POINTS 3 float\n" + tri + "METADATA\nINFORMATION 0\n\nPOLYGONS 2 3\nOFFSETS vtktypeint64\n0 3\n"
                              "CONNECTIVITY vtktypeint64\n0 1 2\nPOINT_DATA 3\nSCALARS s float 1\nLOOKUP_TABLE default\n1 2 3\n");
  write_bytes(dir + "/a.vtp",
              "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\" header_type=\"UInt32\">\n"
              "<PolyData>\n<Piece NumberOfPoints=\"3\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"1\">\n"
              "<Points>\n<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">\n" + tri + "</DataArray>\n</Points>\n"
              "<Polys>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">0 1 2</DataArray>\n"
              "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">3</DataArray>\n</Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n");
  for (const std::string name : {"a.ply", "b.ply", "a.vtk", "a.vtp"}) {
    const Surface s = read_surface(dir + "/" + name);
    ASSERT_EQ(s.mesh.num_vertices(), 3) << name;
    ASSERT_EQ(s.mesh.num_faces(), 1) << name;
    EXPECT_EQ(s.mesh.F.row(0), Eigen::RowVector3i(0, 1, 2)) << name;
    const double y2 = name == "b.ply" ? 1.0 : 2.5;
    EXPECT_EQ(s.mesh.V(2, 1), y2) << name;
  }
  // The binary writers' output (with its METADATA blocks) still reads after the checks.
  write_surface(dir + "/w.vtk", octahedron());
  EXPECT_EQ(read_surface(dir + "/w.vtk").mesh.num_faces(), 8);
}

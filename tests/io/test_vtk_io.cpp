// VTK-family surfaces: every format round-trips; polygons are triangulated; STL soups are welded.
#include <gtest/gtest.h>

#include "io/io_test_util.h"
#include "io/surface_formats.h"
#include "io/surface_io.h"

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

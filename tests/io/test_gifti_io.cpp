// GIFTI through gifticlib: surfaces, func/shape columns, labels, .gii.gz, arrays found by intent,
// and nibabel reading what we write (and us reading what nibabel writes).
#include <gtest/gtest.h>

#include <filesystem>

#include "io/io_test_util.h"
#include "io/surface_io.h"

using namespace authalic;
using namespace authalic::io;
using namespace authalic::test;

TEST(Gifti, SurfaceRoundTripPlainAndGzip) {
  const std::string dir = temp_dir("gifti_surface");
  SurfaceWriteOptions opt;
  opt.anatomical_structure = "CortexLeft";
  opt.geometric_type = "Flat";
  opt.metadata["units"] = "mm";
  for (const std::string name : {"/m.surf.gii", "/m.surf.gii.gz"}) {
    write_surface(dir + name, octahedron(), opt);
    const Surface s = read_surface(dir + name);
    EXPECT_EQ(s.format, "gifti");
    EXPECT_TRUE(s.mesh.V.isApprox(octahedron().V, 1e-6)) << name;
    EXPECT_EQ(s.mesh.F, octahedron().F) << name;
    EXPECT_EQ(s.metadata.at("AnatomicalStructurePrimary"), "CortexLeft");
    EXPECT_EQ(s.metadata.at("GeometricType"), "Flat");
    EXPECT_EQ(s.metadata.at("units"), "mm");
    EXPECT_EQ(s.space, "NIFTI_XFORM_UNKNOWN");
  }
  // The .gz file really is gzip (so other tools recognise it by content).
  const std::string gz = read_bytes(dir + "/m.surf.gii.gz");
  ASSERT_GE(gz.size(), 2u);
  EXPECT_EQ(static_cast<unsigned char>(gz[0]), 0x1f);
  EXPECT_EQ(static_cast<unsigned char>(gz[1]), 0x8b);
  EXPECT_EQ(list_dir(dir), (std::vector<std::string>{"m.surf.gii", "m.surf.gii.gz"}));
}

TEST(Gifti, VolumeGeometryBecomesScannerTransform) {
  const std::string dir = temp_dir("gifti_cras");
  SurfaceWriteOptions opt;
  opt.volume_geometry.valid = true;
  opt.volume_geometry.cras = {1.5, -2.5, 30};
  write_surface(dir + "/lh.white.surf.gii", octahedron(), opt);
  const Surface s = read_surface(dir + "/lh.white.surf.gii");
  const Eigen::Vector3d t = s.to_scanner.block<3, 1>(0, 3);
  EXPECT_TRUE(t.isApprox(Eigen::Vector3d(1.5, -2.5, 30)));
  EXPECT_TRUE(s.has_volume_geometry);
}

// A pointset may list several coordinate systems (GIFTI 1.0 allows any number): the one to
// scanner space is used wherever it is listed, as nibabel does (only the first was read, so a
// tkregister surface whose first transform went to Talairach was sampled c_ras off).
TEST(Gifti, TheScannerTransformIsFoundAmongSeveral) {
  const std::string dir = temp_dir("gifti_two_cs");
  SurfaceWriteOptions opt;
  opt.volume_geometry.valid = true;
  opt.volume_geometry.cras = {1.5, -2.5, 30};
  write_surface(dir + "/one.surf.gii", octahedron(), opt);
  std::string xml = read_bytes(dir + "/one.surf.gii");
  const std::size_t at = xml.find("<CoordinateSystemTransformMatrix>");
  ASSERT_NE(at, std::string::npos);
  const std::string talairach =
      "<CoordinateSystemTransformMatrix><DataSpace><![CDATA[NIFTI_XFORM_UNKNOWN]]></DataSpace>"
      "<TransformedSpace><![CDATA[NIFTI_XFORM_TALAIRACH]]></TransformedSpace>"
      "<MatrixData>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</MatrixData></CoordinateSystemTransformMatrix>\n";
  xml.insert(at, talairach);
  write_bytes(dir + "/two.surf.gii", xml);
  const Surface s = read_surface(dir + "/two.surf.gii");
  const Eigen::Vector3d t = s.to_scanner.block<3, 1>(0, 3);
  EXPECT_TRUE(t.isApprox(Eigen::Vector3d(1.5, -2.5, 30))) << s.to_scanner;
  EXPECT_TRUE(s.has_volume_geometry);
}

TEST(Gifti, FuncColumnsAndLabels) {
  const std::string dir = temp_dir("gifti_func");
  MatrixXd values(6, 2);
  values << 1, -1, 2, -2, 3.5, -3.5, 0, 0, 0.25, 7, 1e-3, 8;
  FuncWriteOptions fo;
  fo.column_names = {"suvr", "z"};
  fo.metadata["units"] = "SUVR";
  write_per_vertex(dir + "/x.func.gii", values, fo);
  std::vector<std::string> names;
  const MatrixXd back = read_per_vertex_columns(dir + "/x.func.gii", &names, 6);
  EXPECT_TRUE(back.isApprox(values, 1e-6));
  EXPECT_EQ(names, (std::vector<std::string>{"suvr", "z"}));
  EXPECT_TRUE(read_per_vertex(dir + "/x.func.gii", 6, 1).isApprox(values.col(1), 1e-6));
  expect_input_error([&] { read_per_vertex(dir + "/x.func.gii", 6, 2); }, dir + "/x.func.gii", "column 2");

  write_per_vertex(dir + "/mask.shape.gii.gz", (MatrixXd(6, 1) << 1, 0, 1, 0, 0.9, 0.1).finished());
  EXPECT_EQ(read_region_vertices(dir + "/mask.shape.gii.gz", 6), (std::vector<int>{0, 2, 4}));

  VectorXi labels(6);
  labels << 0, 3, 3, 0, 7, 0;
  write_label_gifti(dir + "/r.label.gii", labels, {{0, "unknown"}, {3, "cortex"}, {7, "insula"}});
  EXPECT_EQ(read_region_vertices(dir + "/r.label.gii", 6), (std::vector<int>{1, 2, 4}));
  // A medial wall with a key of its own, named as HCP, FreeSurfer's aparc or Workbench name it,
  // is not cortex (it was counted in, and the region was the whole closed surface).
  for (const std::string wall : {"Medial_Wall", "???", "unknown", "corpuscallosum"}) {
    VectorXi keyed(6);
    keyed << 1, 2, 2, 1, -1, 2;
    write_label_gifti(dir + "/mw.label.gii", keyed, {{-1, "???"}, {1, wall}, {2, "Cortex"}});
    EXPECT_EQ(read_region_vertices(dir + "/mw.label.gii", 6), (std::vector<int>{1, 2, 5})) << wall;
  }
}

// Issue 15 item 16: a cortex region file is told apart by content. A face set saved under a name
// with no ".surf" (FreeSurfer's flat_left.gii.gz) is a face set; labels and masks are vertices;
// per-vertex data that is not a mask (sulc: values outside [0, 1]) is refused, not thresholded.
TEST(Gifti, RegionFilesAreReadByContent) {
  const std::string dir = temp_dir("gifti_region_file");
  TriMesh m;
  m.V = (MatrixXd(4, 3) << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0).finished();
  m.F = (MatrixXi(2, 3) << 0, 1, 2, 1, 3, 2).finished();
  write_surface(dir + "/faces.surf.gii", m);
  std::filesystem::copy_file(dir + "/faces.surf.gii", dir + "/flat_left.gii");  // the name says nothing
  for (const std::string name : {"/faces.surf.gii", "/flat_left.gii"}) {
    const RegionFile r = read_region_file(dir + name, 4);
    EXPECT_TRUE(r.is_face_set) << name;
    EXPECT_EQ(r.face_set_vertices, 4) << name;
    EXPECT_EQ(r.faces, m.F) << name;
  }
  write_per_vertex(dir + "/mask.shape.gii", (MatrixXd(4, 1) << 1, 0, 1, 1).finished());
  const RegionFile mask = read_region_file(dir + "/mask.shape.gii", 4);
  EXPECT_FALSE(mask.is_face_set);
  EXPECT_EQ(mask.vertices, (std::vector<int>{0, 2, 3}));
  write_per_vertex(dir + "/sulc.shape.gii", (MatrixXd(4, 1) << -1.2, 0.3, 0.8, 1.9).finished());
  expect_input_error([&] { read_region_file(dir + "/sulc.shape.gii", 4); }, dir + "/sulc.shape.gii",
                     "values from -1.200000 to 1.900000 are not a 0/1 mask");
}

// same_space_write_options carries a GIFTI surface's scanner translation (as mris_convert writes
// c_ras), its dataspace and its pointset keys to an output on the same coordinates.
TEST(Gifti, SameSpaceWriteOptionsKeepTheTransformAndTheStructure) {
  const std::string dir = temp_dir("gifti_same_space");
  TriMesh m;
  m.V = (MatrixXd(3, 3) << 0, 0, 0, 1, 0, 0, 0, 1, 0).finished();
  m.F = (MatrixXi(1, 3) << 0, 1, 2).finished();
  SurfaceWriteOptions wo;
  wo.anatomical_structure = "CortexRight";
  wo.geometric_type = "Anatomical";
  wo.metadata["AnatomicalStructureSecondary"] = "Pial";
  wo.volume_geometry.valid = true;
  wo.volume_geometry.cras = Eigen::Vector3d(1.5, -2, 30);
  write_surface(dir + "/a.surf.gii", m, wo);
  const Surface a = read_surface(dir + "/a.surf.gii");
  write_surface(dir + "/b.surf.gii", m, same_space_write_options(a, dir + "/a.surf.gii"));
  const Surface b = read_surface(dir + "/b.surf.gii");
  EXPECT_TRUE(b.to_scanner.isApprox(a.to_scanner));
  EXPECT_NEAR(b.to_scanner(2, 3), 30.0, 1e-12);
  EXPECT_EQ(b.metadata.at("AnatomicalStructurePrimary"), "CortexRight");
  EXPECT_EQ(b.metadata.at("AnatomicalStructureSecondary"), "Pial");
  EXPECT_EQ(b.metadata.at("GeometricType"), "Anatomical");
}

TEST(Gifti, NibabelReadsOurFilesWithMetadata) {
  AUTHALIC_REQUIRE_NIBABEL();
  const std::string dir = temp_dir("gifti_nibabel_reads");
  SurfaceWriteOptions opt;
  opt.anatomical_structure = "CortexLeft";
  opt.geometric_type = "Spherical";
  write_surface(dir + "/s.surf.gii.gz", octahedron(), opt);
  write_per_vertex(dir + "/t.shape.gii", (MatrixXd(6, 1) << 1, 2, 3, 4, 5, 6.5).finished());
  VectorXi labels(6);
  labels << 0, 1, 1, 2, 2, 0;
  write_label_gifti(dir + "/l.label.gii", labels, {{1, "a"}, {2, "b"}});
  const std::vector<double> out = python_numbers(run_python(dir, R"(
import gzip, io
g = nib.load(')" + dir + R"(/s.surf.gii.gz')
c = g.agg_data('NIFTI_INTENT_POINTSET'); t = g.agg_data('NIFTI_INTENT_TRIANGLE')
m = g.darrays[0].meta
assert m['AnatomicalStructurePrimary'] == 'CortexLeft' and m['GeometricType'] == 'Spherical'
s = nib.load(')" + dir + R"(/t.shape.gii')
l = nib.load(')" + dir + R"(/l.label.gii')
lt = l.labeltable.get_labels_as_dict()
assert lt[1] == 'a' and lt[2] == 'b'
print('OUT:', c.shape[0], t.shape[0], c[4,2], t[7,1], s.darrays[0].data[5], s.darrays[0].intent, l.darrays[0].data[3], l.darrays[0].intent)
)"));
  ASSERT_EQ(out.size(), 8u);
  EXPECT_EQ(out[0], 6);
  EXPECT_EQ(out[1], 8);
  EXPECT_DOUBLE_EQ(out[2], 13.125);
  EXPECT_EQ(out[3], 3);
  EXPECT_DOUBLE_EQ(out[4], 6.5);
  EXPECT_EQ(out[5], 2005);  // NIFTI_INTENT_SHAPE for .shape.gii
  EXPECT_EQ(out[6], 2);
  EXPECT_EQ(out[7], 1002);  // NIFTI_INTENT_LABEL
}

TEST(Gifti, TrianglesFirstAndColumnMajorFromNibabel) {
  // Real files sometimes store the triangle array first; arrays must be found by intent.
  AUTHALIC_REQUIRE_NIBABEL();
  const std::string dir = temp_dir("gifti_order");
  run_python(dir, R"(
v = np.array([[0,0,0],[1,0,0],[0,1,0],[0,0,1]], dtype=np.float32) * 2.5
f = np.array([[0,2,1],[0,1,3],[0,3,2],[1,2,3]], dtype=np.int32)
tri = nib.gifti.GiftiDataArray(f, intent='NIFTI_INTENT_TRIANGLE', datatype='NIFTI_TYPE_INT32')
pts = nib.gifti.GiftiDataArray(v, intent='NIFTI_INTENT_POINTSET', datatype='NIFTI_TYPE_FLOAT32')
nib.save(nib.gifti.GiftiImage(darrays=[tri, pts]), ')" + dir + R"(/tri_first.surf.gii')
# Column-major storage of the same pointset: the reader must honour ArrayIndexingOrder.
pts_c = nib.gifti.GiftiDataArray(np.asfortranarray(v), intent='NIFTI_INTENT_POINTSET', datatype='NIFTI_TYPE_FLOAT32', ordering='F')
nib.save(nib.gifti.GiftiImage(darrays=[pts_c, tri]), ')" + dir + R"(/colmajor.surf.gii')
)");
  for (const std::string name : {"/tri_first.surf.gii", "/colmajor.surf.gii"}) {
    const Surface s = read_surface(dir + name);
    ASSERT_EQ(s.mesh.num_vertices(), 4) << name;
    ASSERT_EQ(s.mesh.num_faces(), 4) << name;
    EXPECT_DOUBLE_EQ(s.mesh.V(1, 0), 2.5) << name;
    EXPECT_DOUBLE_EQ(s.mesh.V(1, 1), 0.0) << name;
    EXPECT_DOUBLE_EQ(s.mesh.V(3, 2), 2.5) << name;
    EXPECT_EQ(s.mesh.F(0, 1), 2) << name;
  }
}

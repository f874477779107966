// Writes the seed corpus for the fuzz targets: small valid files from the project's own writers,
// one folder per target (scripts/fuzz.sh calls it before fuzzing).
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

#include "io/surface_io.h"
#include "io/volume_io.h"

using namespace authalic;
using namespace authalic::io;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: fuzz_make_seeds CORPUS_DIR\n";
    return 2;
  }
  const std::filesystem::path root(argv[1]);
  for (const char* t : {"freesurfer_surface", "freesurfer_curv", "freesurfer_label", "freesurfer_patch", "gifti", "nifti", "mgh", "ply", "obj", "mni_obj", "stl", "vtk"})
    std::filesystem::create_directories(root / t);
  auto at = [&](const char* target, const char* name) { return (root / target / name).string(); };

  TriMesh m;  // tetrahedron
  m.V.resize(4, 3);
  m.V << 0, 0, 0, 10.5, 0, 0, 0, 10.5, 0, 0, 0, 10.5;
  m.F.resize(4, 3);
  m.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  SurfaceWriteOptions with_footer;
  with_footer.volume_geometry.valid = true;
  with_footer.volume_geometry.filename = "orig.mgz";
  with_footer.volume_geometry.volume = {256, 256, 256};
  with_footer.volume_geometry.cras = {1.5, -2, 3};
  write_surface(at("freesurfer_surface", "lh.white"), m, with_footer);
  write_surface(at("freesurfer_surface", "lh.nofooter"), m);

  const MatrixXd values = (MatrixXd(4, 2) << 0.5, 1, -1.25, 0, 3, 1, 0, 0).finished();
  write_per_vertex(at("freesurfer_curv", "lh.thickness"), values.col(0));

  Label label;
  label.vertices = {0, 3};
  label.positions = (MatrixXd(2, 3) << 0, 0, 0, 0, 0, 10.5).finished();
  label.values = Eigen::Vector2d(1, 0.5);
  write_freesurfer_label(at("freesurfer_label", "lh.cortex.label"), label);

  write_freesurfer_patch(at("freesurfer_patch", "lh.patch.flat"), {0, 1, 3}, (MatrixXd(3, 3) << 0, 0, 0, 1, 0, 0, 0, 1, 0).finished());

  SurfaceWriteOptions gopt;
  gopt.anatomical_structure = "CortexLeft";
  gopt.geometric_type = "Anatomical";
  write_surface(at("gifti", "s.surf.gii"), m, gopt);
  FuncWriteOptions fopt;
  fopt.column_names = {"a", "b"};
  write_per_vertex(at("gifti", "f.func.gii"), values, fopt);
  write_label_gifti(at("gifti", "l.label.gii"), Eigen::Vector4i(0, 1, 1, 2), {{1, "x"}, {2, "y"}});

  Volume v;
  v.dims = {3, 2, 2};
  v.data = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11.5f};
  v.vox2ras << -2, 0, 0, 90, 0, 2, 0, -126, 0, 0, 2, -72, 0, 0, 0, 1;
  write_nifti(at("nifti", "v.nii"), v);
  write_mgh(at("mgh", "v.mgh"), v);
  write_mgh(at("mgh", "v.mgz"), v);
  // VTK family: the writers make binary PLY/STL/VTK and appended VTP; ASCII variants by hand.
  // fuzz_vtk reads its first byte as the format switch: 'v' (even) is .vtk, 'w' (odd) is .vtp.
  write_surface(at("ply", "w.ply"), m);
  write_surface(at("obj", "w.obj"), m);
  write_surface(at("stl", "w.stl"), m);
  auto text = [&](const std::string& file, const std::string& bytes) { std::ofstream(file, std::ios::binary) << bytes; };
  auto prefixed = [&](const std::string& from, const std::string& to, char format) {
    std::ifstream in(from, std::ios::binary);
    text(to, std::string(1, format) + std::string(std::istreambuf_iterator<char>(in), {}));
    std::filesystem::remove(from);
  };
  write_surface(at("vtk", "tmp.vtk"), m);
  prefixed(at("vtk", "tmp.vtk"), at("vtk", "w_vtk"), 'v');
  write_surface(at("vtk", "tmp.vtp"), m);
  prefixed(at("vtk", "tmp.vtp"), at("vtk", "w_vtp"), 'w');
  const std::string tri = "0 0 0\n1.5 0 0\n0 2.5 0\n";
  text(at("ply", "a.ply"), "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                           "element face 1\nproperty list uchar int vertex_indices\nend_header\n" + tri + "3 0 1 2\n");
  text(at("obj", "a.obj"), "# c\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\nf -3 -2 -1\n");
  // MNI .obj: ASCII with a quad (colour per item), and binary (little-endian) of the tetrahedron.
  text(at("mni_obj", "a.obj"), "P 0.3 0.3 0.4 10 1 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\n0 0 1\n0 0 1\n0 0 1\n0 0 1\n\n"
                               "2\n1\n1 1 1 1\n0 0 1 1\n\n3 7\n\n0 1 2 0 2 3 1\n");
  {
    std::string b = "p";
    auto put = [&](auto v) { b.append(reinterpret_cast<const char*>(&v), sizeof v); };  // x86: little-endian
    for (int k = 0; k < 5; ++k) put(0.5f);
    put(std::int32_t{4});
    for (int i = 0; i < 4; ++i)
      for (int c = 0; c < 3; ++c) put(static_cast<float>(m.V(i, c)));
    for (int k = 0; k < 12; ++k) put(0.0f);
    put(std::int32_t{4});
    put(std::int32_t{0});
    put(std::uint32_t{0xFFFFFFFFu});
    for (const std::int32_t end : {3, 6, 9, 12}) put(end);
    for (int f = 0; f < 4; ++f)
      for (int c = 0; c < 3; ++c) put(static_cast<std::int32_t>(m.F(f, c)));
    text(at("mni_obj", "b.obj"), b);
  }
  text(at("stl", "a.stl"), "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n");
  text(at("vtk", "a3_vtk"), "v# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 1 1 0\n"
                            "POLYGONS 1 5\n4 0 1 3 2\nTRIANGLE_STRIPS 1 4\n3 0 1 2\nPOINT_DATA 4\nSCALARS s float 1\nLOOKUP_TABLE default\n1 2 3 4\n");
  text(at("vtk", "a5_vtk"), "v# vtk DataFile Version 5.1\nx\nASCII\nDATASET POLYDATA\nFIELD FieldData 1\nTIME 1 1 double\n7\n"
                            "POINTS 3 float\n" + tri + "METADATA\nINFORMATION 0\n\nPOLYGONS 2 3\nOFFSETS vtktypeint64\n0 3\n"
                            "CONNECTIVITY vtktypeint64\n0 1 2\n");
  text(at("vtk", "a_vtp"), "w<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\" header_type=\"UInt32\">\n"
                           "<PolyData>\n<Piece NumberOfPoints=\"3\" NumberOfPolys=\"1\">\n<Points>\n"
                           "<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">\n" + tri + "</DataArray>\n</Points>\n"
                           "<Polys>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">0 1 2</DataArray>\n"
                           "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">3</DataArray>\n</Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n");
  std::cout << "seeds written to " << root.string() << "\n";
  return 0;
}

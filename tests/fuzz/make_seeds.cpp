// Writes the seed corpus for the fuzz targets: small valid files from the project's own writers,
// one folder per target (scripts/fuzz.sh calls it before fuzzing).
#include <filesystem>
#include <iostream>

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
  for (const char* t : {"freesurfer_surface", "freesurfer_curv", "freesurfer_label", "freesurfer_patch", "gifti", "nifti", "mgh"})
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
  std::cout << "seeds written to " << root.string() << "\n";
  return 0;
}

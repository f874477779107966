#pragma once
// Cortical surfaces and per-vertex data, from files into core types and back.
// Formats: FreeSurfer binary triangle surfaces (lh.white, ...), FreeSurfer patches (read),
// GIFTI (.surf.gii, .gii.gz), VTK legacy (.vtk), XML PolyData (.vtp), PLY, OBJ, STL.
#include <Eigen/Core>

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh.h"

namespace authalic::io {

// FreeSurfer's volume geometry ("footer" of binary surfaces): the volume the surface was made
// from. tkregister RAS (the surface coordinates) + cras = scanner RAS.
struct VolumeGeometry {
  bool valid = false;
  std::string filename;
  std::array<int, 3> volume{0, 0, 0};
  Eigen::Vector3d voxelsize = Eigen::Vector3d::Ones();
  Eigen::Vector3d xras{-1, 0, 0}, yras{0, 0, 1}, zras{0, -1, 0};
  Eigen::Vector3d cras = Eigen::Vector3d::Zero();
};

// A surface with where its coordinates live.
struct Surface {
  TriMesh mesh;
  // Maps the file's coordinates to scanner RAS (mm). FreeSurfer surfaces store tkregister RAS:
  // scanner = tkr + c_ras, taken from the volume-geometry footer (identity when it has none).
  Eigen::Matrix4d to_scanner = Eigen::Matrix4d::Identity();
  bool has_volume_geometry = false;   // FreeSurfer footer present and valid
  Eigen::Vector3d c_ras = Eigen::Vector3d::Zero();
  std::string space;                  // e.g. "tkregister RAS", "scanner RAS", GIFTI dataspace
  std::string format;                 // "freesurfer", "gifti", "vtk", "vtp", "ply", "obj", "stl", "patch"
  std::map<std::string, std::string> metadata;  // GIFTI metadata (AnatomicalStructurePrimary, ...)
  VolumeGeometry volume_geometry;               // FreeSurfer footer as read (valid=false if none)
};

// Reads any supported surface; the format is chosen by magic number, then by extension.
// Throws InputError("<path>: <problem>; <hint>") on anything it cannot trust.
Surface read_surface(const std::string& path);

struct SurfaceWriteOptions {
  std::string anatomical_structure;     // GIFTI AnatomicalStructurePrimary, e.g. "CortexLeft"
  std::string geometric_type;           // GIFTI GeometricType: "Anatomical", "Flat", "Spherical"
  std::string space = "NIFTI_XFORM_UNKNOWN";  // GIFTI dataspace of the pointset
  std::map<std::string, std::string> metadata;  // extra metadata key/values (units, software, ...)
  // FreeSurfer binary: written as the footer when valid. GIFTI: when valid, the pointset gets a
  // coordinate transform (dataspace -> NIFTI_XFORM_SCANNER_ANAT, translation by cras), as
  // FreeSurfer's mris_convert does.
  VolumeGeometry volume_geometry;
};
// Writes by extension (.surf.gii/.gii, .vtk, .vtp, .ply, .obj, .stl, or FreeSurfer binary for
// anything else, e.g. lh.white). Atomic: a temporary file in the same folder, then rename.
void write_surface(const std::string& path, const TriMesh& mesh, const SurfaceWriteOptions& options = {});
// Throws InputError for an output name whose extension names another kind of file (.nii.gz,
// .mgz, .png, .txt, ...): the FreeSurfer binary that any other name gets would go into a file
// that no tool reads as what its name says. write_surface checks it; commands call it before
// computing anything.
void check_surface_output_name(const std::string& path);

// Per-vertex files (labels, masks, densities, a map's vertices) pair with a surface by its vertex
// numbering, which an STL file does not have: its triangles' corners are welded by position and
// numbered as first met. An InputError naming both files when `surface` was read from STL.
void require_vertex_numbering(const Surface& surface, const std::string& surface_path, const std::string& per_vertex_path);

// Write options for a surface on the same coordinates as `s` (e.g. its subdivision): its space
// (GIFTI dataspace and scanner transform, or FreeSurfer's volume-geometry footer), its structure
// and geometric type, and its other metadata. A GIFTI transform that is a translation (as
// mris_convert writes c_ras) is kept as c_ras of a conformed 256^3 1 mm geometry; other
// transforms cannot be expressed by the writer and are refused.
SurfaceWriteOptions same_space_write_options(const Surface& s, const std::string& what);

// FreeSurfer flat patch (lh.*.patch.flat / .3d): the vertices it keeps and their x,y,z.
struct Patch {
  std::vector<int> vertices;   // original vertex indices
  MatrixXd positions;          // #vertices x 3
  std::vector<bool> on_border; // FreeSurfer's border flag (negative index in the file)
};
Patch read_freesurfer_patch(const std::string& path);
// Writes a FreeSurfer patch (new format, -1 magic) for the given vertices and positions; a vertex
// flagged in on_border (empty: none) is stored as FreeSurfer stores border vertices, -(k+1).
void write_freesurfer_patch(const std::string& path, const std::vector<int>& vertices, const MatrixXd& positions,
                            const std::vector<bool>& on_border = {});

// The faces of `parent` whose three vertices are all in the patch, with the patch's x,y,z for the
// kept vertices (other vertices keep the parent's positions and are unused by the faces).
TriMesh patch_mesh(const TriMesh& parent, const Patch& patch);

// Per-vertex scalars: FreeSurfer curv/thickness/sulc ("new curv" format), GIFTI func/shape
// (first data array unless `column` is given), or a text file with one value a line.
// expected_vertices >= 0 makes a length mismatch an InputError naming both counts.
VectorXd read_per_vertex(const std::string& path, int expected_vertices = -1, int column = 0);
// All columns of a GIFTI func/shape file (#V x #columns) with their names.
MatrixXd read_per_vertex_columns(const std::string& path, std::vector<std::string>* names = nullptr,
                                 int expected_vertices = -1);

// The metadata a GIFTI per-vertex file carries (file level: AnatomicalStructurePrimary and what
// its writer recorded, e.g. the element grid of an element label file); empty for other formats.
std::map<std::string, std::string> read_per_vertex_metadata(const std::string& path);

struct FuncWriteOptions {
  std::vector<std::string> column_names;
  std::string anatomical_structure;
  std::map<std::string, std::string> metadata;  // written into the file's metadata
  // NIFTI_INTENT_* of each GIFTI data array, e.g. 5 = NIFTI_INTENT_ZSCORE; 0 (none) gives
  // NIFTI_INTENT_SHAPE for a .shape.gii. Labels are always NIFTI_INTENT_LABEL.
  int intent = 0;
};
// GIFTI func/shape (.func.gii/.shape.gii): one float32 data array per column of `values`.
// FreeSurfer curv format for any other extension (first column only).
void write_per_vertex(const std::string& path, const MatrixXd& values, const FuncWriteOptions& options = {});
// The same for per-vertex values (write_per_vertex checks it): .func.gii, .shape.gii, .txt, .csv,
// or a FreeSurfer curv name (lh.thickness, x.curv, x.sulc); a volume, picture, surface or table
// extension is refused.
void check_per_vertex_output_name(const std::string& path);

// Per-vertex integer labels as a GIFTI label file (.label.gii) with a label table.
void write_label_gifti(const std::string& path, const VectorXi& labels, const std::map<int, std::string>& names,
                       const FuncWriteOptions& options = {});

// A cortex region given as vertices: FreeSurfer label file (lh.cortex.label), a GIFTI label
// file (its non-zero keys, except those its label table names as the medial wall: "Medial_Wall",
// "???", "unknown", "corpuscallosum") or a GIFTI shape/func mask (values > 0.5). Indices are 0-based.
std::vector<int> read_region_vertices(const std::string& path, int expected_vertices = -1);
// The same, checked against the surface it is for: the vertex count, and a FreeSurfer label's
// coordinates must follow the surface's triangles. The label stores each vertex's position on
// the surface it was drawn on (white, pial, sphere: the same triangles), so vertices that are
// neighbours on `surface` lie about one edge apart in the label. A label of another mesh whose
// indices happen to be in range puts them tens of mm apart, and is refused (InputError).
// Labels without coordinates (all rows at one point) are not checked.
std::vector<int> read_region_vertices(const std::string& path, const TriMesh& surface);

// A cortex region file of either kind, told apart by its content (not its name): a surface whose
// triangles are the region (a face set on the same vertices, e.g. FreeSurfer's flat patch saved
// as GIFTI, flat_left.gii.gz) or vertices (read_region_vertices). A face set's vertex count is
// returned, not checked: the caller names both files when it does not match.
struct RegionFile {
  bool is_face_set = false;
  MatrixXi faces;              // face set: #F x 3
  int face_set_vertices = 0;   // face set: the surface's vertex count
  std::vector<int> vertices;   // otherwise: sorted 0-based indices
};
RegionFile read_region_file(const std::string& path, int expected_vertices = -1);
// The same, a label or mask checked against `surface` as read_region_vertices(path, surface) does.
RegionFile read_region_file(const std::string& path, const TriMesh& surface);

// FreeSurfer label file: vertex indices and their coordinates/values.
struct Label {
  std::vector<int> vertices;
  MatrixXd positions;  // #vertices x 3
  VectorXd values;
};
Label read_freesurfer_label(const std::string& path);
void write_freesurfer_label(const std::string& path, const Label& label);

}  // namespace authalic::io

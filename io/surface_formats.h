#pragma once
// Internal: one entry point per surface format, behind io/surface_io.h. Buffer-based parsers exist
// for the binary FreeSurfer formats so the fuzz targets (tests/fuzz) can call them without files.
#include <string>
#include <vector>

#include "io/surface_io.h"

namespace authalic::io::detail {

// ---- validation shared by every reader -----------------------------------------------------
// Finite coordinates, face indices in range. Throws InputError naming `path`.
void validate_mesh(const TriMesh& mesh, const std::string& path, const std::string& format);

// ---- FreeSurfer (io/freesurfer_io.cpp) ----------------------------------------------------
// Magic numbers in the first 3 bytes.
constexpr unsigned kFreeSurferTriangleMagic = 0xFFFFFE;
constexpr unsigned kFreeSurferQuadOrNewCurvMagic = 0xFFFFFF;  // quad surface / "new" curv
enum class FreeSurferKind { kNone, kTriangleSurface, kNewCurv, kQuadSurface, kPatch };
// What a FreeSurfer binary file is, from its first bytes and size (kNone when no magic matches).
FreeSurferKind sniff_freesurfer(const std::string& bytes);

Surface parse_freesurfer_surface(const std::string& bytes, const std::string& path);
std::string serialize_freesurfer_surface(const TriMesh& mesh, const SurfaceWriteOptions& options);

VectorXd parse_freesurfer_curv(const std::string& bytes, const std::string& path);
std::string serialize_freesurfer_curv(const VectorXd& values, int num_faces = 0);

Label parse_freesurfer_label(const std::string& text, const std::string& path);
std::string serialize_freesurfer_label(const Label& label);
bool looks_like_freesurfer_label(const std::string& bytes);

Patch parse_freesurfer_patch(const std::string& bytes, const std::string& path);
std::string serialize_freesurfer_patch(const std::vector<int>& vertices, const MatrixXd& positions,
                                       const std::vector<bool>& on_border = {});

// ---- GIFTI (io/gifti_io.cpp; gifticlib) -----------------------------------------------------
// Reads .gii or gzipped .gii.gz. Arrays are found by intent, never by position.
struct GiftiContents {
  bool has_mesh = false;
  TriMesh mesh;
  std::string dataspace;
  Eigen::Matrix4d to_scanner = Eigen::Matrix4d::Identity();
  std::map<std::string, std::string> metadata;   // file metadata plus the pointset's metadata
  MatrixXd columns;                              // non-geometry data arrays, #V x #arrays
  std::vector<std::string> column_names;
  std::vector<int> column_intents;
  bool columns_are_labels = false;               // NIFTI_INTENT_LABEL arrays
  std::map<int, std::string> label_table;
};
GiftiContents read_gifti(const std::string& path);
bool looks_like_gifti(const std::string& bytes);
void write_gifti_surface(const std::string& path, const TriMesh& mesh, const SurfaceWriteOptions& options);
void write_gifti_columns(const std::string& path, const MatrixXd& values, const FuncWriteOptions& options, int intent,
                         const std::map<int, std::string>* label_table);

// ---- MNI .obj (io/mni_obj_io.cpp): CIVET's and the MNI tools' polygon objects --------------
// ASCII objects start with 'P' and whitespace (Wavefront keywords are lower case); binary ones
// with 'p' and counts that describe exactly the file's size (either byte order).
bool looks_like_mni_obj(const std::string& bytes);
// Polygons are fan-triangulated; normals and colours are read past. Refuses line objects, counts
// beyond g_max_vtk_vertices / g_max_vtk_faces, polygons of fewer than 3 corners, corners outside
// the points and data after the object, each with an InputError naming `path`.
TriMesh parse_mni_obj(const std::string& bytes, const std::string& path);

// ---- VTK (io/vtk_io.cpp): .vtk, .vtp, .ply, .obj, .stl ------------------------------------
TriMesh read_vtk_family(const std::string& path, const std::string& format);
void write_vtk_family(const std::string& path, const TriMesh& mesh, const std::string& format);
// Merges exactly coincident vertices (STL stores triangle soups); returns the number merged.
int merge_coincident_vertices(TriMesh& mesh);

}  // namespace authalic::io::detail

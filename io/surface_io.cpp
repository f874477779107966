// Surface and per-vertex I/O: format dispatch (magic number first, extension second), the checks
// every reader shares, and the small text formats. Format specifics live in freesurfer_io.cpp,
// gifti_io.cpp and vtk_io.cpp.
#include "io/surface_io.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <set>
#include <sstream>

#include "io/atomic_file.h"
#include "io/io_internal.h"
#include "io/surface_formats.h"

namespace authalic::io {

using detail::ends_with;
using detail::fail;

namespace detail {

void validate_mesh(const TriMesh& mesh, const std::string& path, const std::string& format) {
  const Eigen::Index nv = mesh.V.rows();
  for (Eigen::Index i = 0; i < nv; ++i) {
    if (!mesh.V.row(i).allFinite()) {
      std::ostringstream ss;
      ss << "vertex " << i << " has a non-finite coordinate (" << mesh.V(i, 0) << ", " << mesh.V(i, 1) << ", "
         << (mesh.V.cols() > 2 ? mesh.V(i, 2) : 0.0) << ")";
      fail(path, ss.str(), "the " + format + " file is corrupt; re-create it");
    }
  }
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    for (int c = 0; c < mesh.F.cols(); ++c) {
      const int v = mesh.F(f, c);
      if (v < 0 || v >= nv)
        fail(path,
             "face " + std::to_string(f) + " uses vertex " + std::to_string(v) + ", outside 0.." + std::to_string(nv - 1) + " (" +
                 std::to_string(nv) + " vertices)",
             "the " + format + " file is corrupt; re-create it");
    }
  }
}

}  // namespace detail

namespace {

enum class SurfaceFormat { kFreeSurfer, kPatch, kCurv, kGifti, kVtk, kVtp, kPly, kObj, kMniObj, kStl, kUnknown };

bool is_text(const std::string& bytes);

// Magic first: a GIFTI named lh.white or a FreeSurfer surface named x.gii is still read correctly.
SurfaceFormat sniff_surface(const std::string& bytes, const std::string& path) {
  using detail::FreeSurferKind;
  switch (detail::sniff_freesurfer(bytes)) {
    case FreeSurferKind::kTriangleSurface: return SurfaceFormat::kFreeSurfer;
    case FreeSurferKind::kPatch: return SurfaceFormat::kPatch;
    case FreeSurferKind::kNewCurv: return SurfaceFormat::kCurv;
    default: break;
  }
  if (detail::is_gzip(bytes) || detail::looks_like_gifti(bytes)) return SurfaceFormat::kGifti;
  const std::string head = bytes.substr(0, 512);
  if (head.rfind("# vtk DataFile", 0) == 0) return SurfaceFormat::kVtk;
  if (head.find("<VTKFile") != std::string::npos) return SurfaceFormat::kVtp;
  if (head.rfind("ply", 0) == 0 && head.size() > 3 && (head[3] == '\n' || head[3] == '\r')) return SurfaceFormat::kPly;
  // Binary STL: 80-byte header, uint32 count, 50 bytes per triangle (the header may start "solid").
  if (bytes.size() >= 84) {
    std::uint32_t n;
    std::memcpy(&n, bytes.data() + 80, 4);  // little-endian in the file; x86 hosts read it directly
    if (84 + 50ull * n == bytes.size()) return SurfaceFormat::kStl;
  }
  if (detail::looks_like_mni_obj(bytes)) return SurfaceFormat::kMniObj;
  if (head.rfind("solid", 0) == 0) return SurfaceFormat::kStl;
  const std::string name = detail::lower_filename(path);
  // A binary MNI object whose counts do not fit: its parser says what is wrong, not VTK's OBJ reader.
  if (ends_with(name, ".obj") && head.rfind('p', 0) == 0 && !is_text(head.substr(0, 64))) return SurfaceFormat::kMniObj;
  if (ends_with(name, ".gii")) return SurfaceFormat::kGifti;
  if (ends_with(name, ".vtk")) return SurfaceFormat::kVtk;
  if (ends_with(name, ".vtp")) return SurfaceFormat::kVtp;
  if (ends_with(name, ".ply")) return SurfaceFormat::kPly;
  if (ends_with(name, ".obj")) return SurfaceFormat::kObj;
  if (ends_with(name, ".stl")) return SurfaceFormat::kStl;
  return SurfaceFormat::kUnknown;
}

std::string output_format(const std::string& path) {
  const std::string name = detail::lower_filename(path);
  if (ends_with(name, ".gii") || ends_with(name, ".gii.gz")) return "gifti";
  for (const char* ext : {"vtk", "vtp", "ply", "obj", "stl"})
    if (ends_with(name, std::string(".") + ext)) return ext;
  return "freesurfer";
}

bool is_text(const std::string& bytes) {
  for (const char c : bytes) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x09 || (u > 0x0d && u < 0x20) || u == 0x7f) return false;
  }
  return true;
}

// One number per line (blank lines and '#' comments skipped).
VectorXd parse_text_values(const std::string& text, const std::string& path) {
  std::vector<double> values;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::size_t b = line.find_first_not_of(" \t\r");
    if (b == std::string::npos || line[b] == '#') continue;
    char* end = nullptr;
    const double v = std::strtod(line.c_str() + b, &end);
    const std::string rest = end ? std::string(end) : std::string();
    if (end == line.c_str() + b || rest.find_first_not_of(" \t\r") != std::string::npos)
      fail(path, "line " + std::to_string(line_no) + " is not a single number: '" + line.substr(0, 60) + "'",
           "a text per-vertex file has one value per line");
    if (!std::isfinite(v)) fail(path, "line " + std::to_string(line_no) + " is not finite (NaN or Inf)", "fix or mask the per-vertex data");
    values.push_back(v);
  }
  return Eigen::Map<VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
}

void check_length(const std::string& path, Eigen::Index n, int expected_vertices) {
  if (expected_vertices > 0 && n == 0) fail(path, "holds no values (the file is empty)", "give the per-vertex file of this surface");
  if (expected_vertices >= 0 && n != expected_vertices)
    fail(path, "has " + std::to_string(n) + " values but the surface has " + std::to_string(expected_vertices) + " vertices",
         "use the per-vertex file that belongs to this surface");
}

void validate_for_writing(const TriMesh& mesh, const std::string& path) {
  if (mesh.V.cols() != 2 && mesh.V.cols() != 3)
    throw InputError(path + ": vertex matrix has " + std::to_string(mesh.V.cols()) + " columns (expected 2 or 3); nothing written");
  if (mesh.F.rows() > 0 && mesh.F.cols() != 3)
    throw InputError(path + ": face matrix has " + std::to_string(mesh.F.cols()) + " columns (expected 3); nothing written");
  detail::validate_mesh(mesh, path, "output");
}

TriMesh as_3d(const TriMesh& mesh) {
  if (mesh.V.cols() == 3) return mesh;
  TriMesh m;
  m.F = mesh.F;
  m.V = MatrixXd::Zero(mesh.V.rows(), 3);
  m.V.leftCols(mesh.V.cols()) = mesh.V;
  return m;
}

}  // namespace

Surface read_surface(const std::string& path) {
  const std::string bytes = detail::read_file(path);
  Surface s;
  switch (sniff_surface(bytes, path)) {
    case SurfaceFormat::kFreeSurfer:
      s = detail::parse_freesurfer_surface(bytes, path);
      break;
    case SurfaceFormat::kPatch:
      fail(path, "is a FreeSurfer patch (vertex subset without faces), not a surface",
           "read it with read_freesurfer_patch and combine it with its surface (patch_mesh)");
    case SurfaceFormat::kCurv:
      fail(path, "is a FreeSurfer per-vertex (curv) file or a quad surface, not a triangle surface",
           "give a triangle surface (lh.white, .surf.gii, .vtk, ...)");
    case SurfaceFormat::kGifti: {
      detail::GiftiContents g = detail::read_gifti(path);
      if (!g.has_mesh)
        fail(path, "GIFTI file has no pointset (intent 1008) and triangle (intent 1009) arrays",
             "this is a data (func/shape/label) file; give a .surf.gii");
      s.mesh = std::move(g.mesh);
      s.format = "gifti";
      s.space = g.dataspace;
      s.to_scanner = g.to_scanner;
      s.metadata = std::move(g.metadata);
      if (!s.to_scanner.isIdentity()) {
        s.c_ras = s.to_scanner.block<3, 1>(0, 3);
        s.has_volume_geometry = s.to_scanner.block<3, 3>(0, 0).isIdentity(1e-9);
      }
      break;
    }
    case SurfaceFormat::kVtk: s.mesh = detail::read_vtk_family(path, "vtk"); s.format = "vtk"; break;
    case SurfaceFormat::kVtp: s.mesh = detail::read_vtk_family(path, "vtp"); s.format = "vtp"; break;
    case SurfaceFormat::kPly: s.mesh = detail::read_vtk_family(path, "ply"); s.format = "ply"; break;
    case SurfaceFormat::kObj: s.mesh = detail::read_vtk_family(path, "obj"); s.format = "obj"; break;
    case SurfaceFormat::kMniObj: s.mesh = detail::parse_mni_obj(bytes, path); s.format = "mni_obj"; break;
    case SurfaceFormat::kStl:
      s.mesh = detail::read_vtk_family(path, "stl");
      detail::merge_coincident_vertices(s.mesh);
      s.format = "stl";
      break;
    case SurfaceFormat::kUnknown:
      // No magic and no known extension: FreeSurfer names have none (lh.white), so parse it as one;
      // its error says which magic number was found.
      s = detail::parse_freesurfer_surface(bytes, path);
      break;
  }
  if (s.mesh.num_vertices() == 0) fail(path, "surface has no vertices", "the file is empty or not a surface");
  if (s.mesh.num_faces() == 0) fail(path, "surface has no triangles", "give a triangulated surface");
  detail::validate_mesh(s.mesh, path, s.format);
  if (s.space.empty()) s.space = "unknown";
  return s;
}

namespace {

// Extensions of other kinds of files: a FreeSurfer binary written under one of these names is
// misread by every tool (nibabel: "not a gzip file"). "" when the name ends in none.
std::string foreign_extension(const std::string& path, const std::vector<std::string>& also) {
  const std::string name = detail::lower_filename(path);
  std::vector<std::string> foreign = {".nii", ".nii.gz", ".mgh", ".mgz", ".img", ".hdr", ".dcm", ".png", ".jpg", ".jpeg",
                                      ".tsv", ".json", ".html", ".pdf", ".label", ".annot", ".spec", ".zip", ".tar"};
  foreign.insert(foreign.end(), also.begin(), also.end());
  for (const auto& ext : foreign)
    if (ends_with(name, ext)) return ext;
  if (ends_with(name, ".gz") && !ends_with(name, ".gii.gz")) return ".gz";
  return "";
}

}  // namespace

void check_surface_output_name(const std::string& path) {
  const std::string ext = foreign_extension(path, {".txt", ".csv"});
  if (!ext.empty())
    throw InputError(path + ": a surface cannot be written as " + ext + "; give a name ending in .surf.gii (GIFTI), .vtk, .vtp, "
                     ".ply, .obj or .stl, or a FreeSurfer surface name such as lh.white (no such extension)");
}

void check_per_vertex_output_name(const std::string& path) {
  const std::string ext = foreign_extension(path, {".vtk", ".vtp", ".ply", ".obj", ".stl"});
  if (!ext.empty())
    throw InputError(path + ": per-vertex values cannot be written as " + ext + "; give a name ending in .func.gii or "
                     ".shape.gii (GIFTI), .txt or .csv (one value a line), or a FreeSurfer curv name such as lh.thickness or x.curv");
}

void write_surface(const std::string& path, const TriMesh& mesh, const SurfaceWriteOptions& options) {
  check_surface_output_name(path);
  validate_for_writing(mesh, path);
  const std::string format = output_format(path);
  const TriMesh m3 = as_3d(mesh);
  if (format == "gifti") {
    detail::write_gifti_surface(path, m3, options);
  } else if (format == "freesurfer") {
    write_file_atomically(path, detail::serialize_freesurfer_surface(m3, options));
  } else {
    detail::write_vtk_family(path, m3, format);
  }
}

SurfaceWriteOptions same_space_write_options(const Surface& s, const std::string& what) {
  SurfaceWriteOptions wo;
  wo.metadata = s.metadata;
  for (const char* key : {"Name", "Date", "UserName"}) wo.metadata.erase(key);  // of the input file, not the output
  wo.volume_geometry = s.volume_geometry;
  if (s.format == "gifti") {
    if (s.space.rfind("NIFTI_XFORM_", 0) == 0) wo.space = s.space;
    if (!s.to_scanner.isIdentity()) {
      if (!s.to_scanner.block<3, 3>(0, 0).isIdentity(1e-9) || !s.to_scanner.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)))
        throw InputError(what + ": its GIFTI transform to scanner space is not a translation; it cannot be carried to the output");
      wo.volume_geometry = VolumeGeometry{};
      wo.volume_geometry.valid = true;
      wo.volume_geometry.volume = {256, 256, 256};
      wo.volume_geometry.cras = s.to_scanner.block<3, 1>(0, 3);
      wo.space = "NIFTI_XFORM_UNKNOWN";
    }
  }
  return wo;
}

Patch read_freesurfer_patch(const std::string& path) { return detail::parse_freesurfer_patch(detail::read_file(path), path); }

void write_freesurfer_patch(const std::string& path, const std::vector<int>& vertices, const MatrixXd& positions,
                            const std::vector<bool>& on_border) {
  if (positions.rows() != static_cast<Eigen::Index>(vertices.size()) || positions.cols() < 2)
    throw InputError(path + ": patch has " + std::to_string(vertices.size()) + " vertices but positions are " +
                     std::to_string(positions.rows()) + "x" + std::to_string(positions.cols()) + "; nothing written");
  for (const int v : vertices)
    if (v < 0) throw InputError(path + ": negative vertex index " + std::to_string(v) + " in patch; nothing written");
  if (!positions.allFinite()) throw InputError(path + ": non-finite patch coordinates; nothing written");
  if (!on_border.empty() && on_border.size() != vertices.size())
    throw InputError(path + ": " + std::to_string(on_border.size()) + " border flags for " + std::to_string(vertices.size()) +
                     " patch vertices; nothing written");
  write_file_atomically(path, detail::serialize_freesurfer_patch(vertices, positions, on_border));
}

TriMesh patch_mesh(const TriMesh& parent, const Patch& patch) {
  const int nv = parent.num_vertices();
  std::vector<char> in_patch(nv, 0);
  TriMesh out;
  out.V = parent.V;
  for (std::size_t i = 0; i < patch.vertices.size(); ++i) {
    const int v = patch.vertices[i];
    if (v < 0 || v >= nv)
      throw InputError("patch: vertex " + std::to_string(v) + " is outside the surface's 0.." + std::to_string(nv - 1) +
                       "; the patch belongs to another surface");
    in_patch[v] = 1;
    out.V.row(v) = patch.positions.row(static_cast<Eigen::Index>(i)).leftCols(std::min<Eigen::Index>(3, out.V.cols()));
  }
  std::vector<int> kept;
  for (int f = 0; f < parent.num_faces(); ++f)
    if (in_patch[parent.F(f, 0)] && in_patch[parent.F(f, 1)] && in_patch[parent.F(f, 2)]) kept.push_back(f);
  out.F.resize(static_cast<Eigen::Index>(kept.size()), 3);
  for (std::size_t i = 0; i < kept.size(); ++i) out.F.row(static_cast<Eigen::Index>(i)) = parent.F.row(kept[i]);
  return out;
}

void require_vertex_numbering(const Surface& surface, const std::string& surface_path, const std::string& per_vertex_path) {
  if (surface.format != "stl" || per_vertex_path.empty()) return;
  throw InputError(per_vertex_path + ": cannot pair with " + surface_path +
                   ": an STL file has no vertex numbering (its triangles' corners are welded by position, numbered as first "
                   "met); give the surface in the format the per-vertex file was made for (GIFTI, FreeSurfer, VTK, PLY or OBJ)");
}

std::map<std::string, std::string> read_per_vertex_metadata(const std::string& path) {
  const std::string bytes = detail::read_file(path);
  if (!detail::is_gzip(bytes) && !detail::looks_like_gifti(bytes)) return {};
  return detail::read_gifti(path).metadata;
}

MatrixXd read_per_vertex_columns(const std::string& path, std::vector<std::string>* names, int expected_vertices) {
  const std::string bytes = detail::read_file(path);
  MatrixXd values;
  std::vector<std::string> column_names;
  if (detail::is_gzip(bytes) || detail::looks_like_gifti(bytes)) {
    detail::GiftiContents g = detail::read_gifti(path);
    if (g.columns.cols() == 0)
      fail(path, "GIFTI file has no per-vertex data arrays (only geometry)", "give a .func.gii, .shape.gii or .label.gii file");
    values = std::move(g.columns);
    column_names = std::move(g.column_names);
  } else if (detail::sniff_freesurfer(bytes) == detail::FreeSurferKind::kNewCurv) {
    values = detail::parse_freesurfer_curv(bytes, path);
    column_names = {detail::lower_filename(path)};
  } else if (detail::sniff_freesurfer(bytes) == detail::FreeSurferKind::kTriangleSurface) {
    fail(path, "is a FreeSurfer surface, not per-vertex data", "give a curv/thickness/sulc, GIFTI shape/func or text file");
  } else if (is_text(bytes)) {
    values = parse_text_values(bytes, path);
    column_names = {detail::lower_filename(path)};
  } else {
    values = detail::parse_freesurfer_curv(bytes, path);  // old curv format, or a clear error
    column_names = {detail::lower_filename(path)};
  }
  check_length(path, values.rows(), expected_vertices);
  if (names) *names = std::move(column_names);
  return values;
}

VectorXd read_per_vertex(const std::string& path, int expected_vertices, int column) {
  const MatrixXd all = read_per_vertex_columns(path, nullptr, expected_vertices);
  if (column < 0 || column >= all.cols())
    fail(path, "has " + std::to_string(all.cols()) + " data column(s), column " + std::to_string(column) + " was asked for",
         "choose a column between 0 and " + std::to_string(all.cols() - 1));
  return all.col(column);
}

void write_per_vertex(const std::string& path, const MatrixXd& values, const FuncWriteOptions& options) {
  check_per_vertex_output_name(path);
  if (!values.allFinite()) {
    // NaN is legal in GIFTI func files (masked vertices) but not in curv; say so for curv only.
    const std::string name = detail::lower_filename(path);
    if (!(ends_with(name, ".gii") || ends_with(name, ".gii.gz")))
      throw InputError(path + ": values contain NaN/Inf, which the FreeSurfer curv format cannot mark; write a .func.gii instead");
  }
  const std::string name = detail::lower_filename(path);
  if (ends_with(name, ".gii") || ends_with(name, ".gii.gz")) {
    const int intent = options.intent != 0                                                   ? options.intent
                       : ends_with(name, ".shape.gii") || ends_with(name, ".shape.gii.gz") ? 2005 /*NIFTI_INTENT_SHAPE*/
                                                                                           : 0;
    detail::write_gifti_columns(path, values, options, intent, nullptr);
  } else if (ends_with(name, ".txt") || ends_with(name, ".csv")) {
    std::ostringstream ss;
    ss.precision(9);
    for (Eigen::Index i = 0; i < values.rows(); ++i) ss << (values.cols() ? values(i, 0) : 0.0) << '\n';
    write_file_atomically(path, ss.str());
  } else {
    if (values.cols() < 1) throw InputError(path + ": no values to write");
    write_file_atomically(path, detail::serialize_freesurfer_curv(values.col(0)));
  }
}

void write_label_gifti(const std::string& path, const VectorXi& labels, const std::map<int, std::string>& names,
                       const FuncWriteOptions& options) {
  std::map<int, std::string> table = names;
  for (Eigen::Index i = 0; i < labels.size(); ++i)
    if (!table.count(labels[i])) table[labels[i]] = labels[i] == 0 ? "???" : "label_" + std::to_string(labels[i]);
  detail::write_gifti_columns(path, labels.cast<double>(), options, 1002 /*NIFTI_INTENT_LABEL*/, &table);
}

namespace {

// Refused when the label's neighbours (on the surface) lie, as a median, more than this share of
// the label's extent (RMS distance from its centroid) apart and more than kLabelNeighbourEdges of
// the surface's median edge. Measured, as a share of the extent: labels made on the surface's mesh
// 0.017 (fs741 lh.cortex.label on its white or pial surface) to 0.056 (fsaverage5's on its sphere;
// 10k vertices); fsaverage5's label on fs741 0.76 (38 mm, 44 edges). The edge bound keeps a small
// label (a few rings: its extent is a few edges) from being refused.
constexpr double kLabelNeighbourSpread = 0.25;
constexpr double kLabelNeighbourEdges = 5.0;  // a label drawn on the sphere: up to about 4 (fsaverage5)
constexpr int kLabelMinEdges = 20;  // fewer neighbour pairs: too few to judge

// See read_region_vertices(path, surface) in the header.
void check_label_follows_surface(const std::string& path, const Label& label, const TriMesh& surface) {
  const Eigen::Index n = surface.V.rows();
  std::vector<int> row(static_cast<std::size_t>(n), -1);
  for (std::size_t k = 0; k < label.vertices.size(); ++k) row[static_cast<std::size_t>(label.vertices[k])] = static_cast<int>(k);
  const Eigen::RowVector3d centre = label.positions.colwise().mean();
  const double extent = std::sqrt((label.positions.rowwise() - centre).rowwise().squaredNorm().mean());
  if (!(extent > 0)) return;  // no coordinates stored
  // Over the surface's edges (each interior edge once: from the face where it runs upward).
  auto for_each_edge = [&](const auto& visit) {
    for (Eigen::Index f = 0; f < surface.F.rows(); ++f)
      for (int c = 0; c < 3; ++c) {
        const int a = surface.F(f, c), b = surface.F(f, (c + 1) % 3);
        if (a < b) visit(a, b);
      }
  };
  auto median = [](std::vector<double>& x) {
    std::nth_element(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(x.size() / 2), x.end());
    return x[x.size() / 2];
  };
  std::vector<double> apart;
  for_each_edge([&](int a, int b) {
    const int ra = row[static_cast<std::size_t>(a)], rb = row[static_cast<std::size_t>(b)];
    if (ra >= 0 && rb >= 0) apart.push_back((label.positions.row(ra) - label.positions.row(rb)).norm());
  });
  if (apart.size() < static_cast<std::size_t>(kLabelMinEdges)) return;
  const double m = median(apart);
  if (m <= kLabelNeighbourSpread * extent) return;  // the usual case: the surface's edges are not needed
  std::vector<double> edge;
  for_each_edge([&](int a, int b) { edge.push_back((surface.V.row(a) - surface.V.row(b)).norm()); });
  const double e = median(edge);
  if (m <= kLabelNeighbourEdges * e) return;
  std::ostringstream problem;
  problem.precision(3);
  problem << "the label's coordinates do not follow this surface's triangles: vertices that are neighbours on the surface lie a median "
          << m << " mm apart in the label (" << 100 * m / extent << " % of its extent; about " << e
          << " mm, one edge, for a label made on this mesh)";
  fail(path, problem.str(), "it belongs to another mesh (another subject, hemisphere or resolution); use the label made for this surface");
}

// A label-table name for what is not cortex: the medial wall (HCP's "Medial_Wall", "medialwall"),
// FreeSurfer's "unknown" and "corpuscallosum", Workbench's "???": the keys a cortex label file
// may give its medial wall instead of 0.
bool names_the_medial_wall(const std::string& name) {
  std::string k;
  for (const char c : name)
    if (std::isalnum(static_cast<unsigned char>(c))) k += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return k.empty() || k == "medialwall" || k == "unknown" || k == "corpuscallosum";
}

[[noreturn]] void fail_empty_region(const std::string& path) {
  fail(path, "region is empty (no vertex selected)", "check that this is the right label or mask");
}

// The vertices of a region file's contents (bytes, read from path).
std::vector<int> region_vertices(const std::string& bytes, const std::string& path, int expected_vertices, const TriMesh* surface) {
  std::vector<int> vertices;
  if (detail::looks_like_freesurfer_label(bytes) || (!bytes.empty() && bytes[0] == '#' && ends_with(detail::lower_filename(path), ".label"))) {
    const Label label = detail::parse_freesurfer_label(bytes, path);
    vertices = label.vertices;
    if (vertices.empty()) fail_empty_region(path);  // before the checks below, which need points
    if (expected_vertices >= 0) {
      for (const int v : vertices)
        if (v >= expected_vertices)
          fail(path, "label vertex " + std::to_string(v) + " is outside the surface's " + std::to_string(expected_vertices) + " vertices",
               "use the label that belongs to this surface");
      if (surface) check_label_follows_surface(path, label, *surface);
    }
  } else {
    bool labels = false;
    std::set<int> outside_keys{0};  // label files: the keys that are not cortex
    MatrixXd values;
    if (detail::is_gzip(bytes) || detail::looks_like_gifti(bytes)) {
      detail::GiftiContents g = detail::read_gifti(path);
      if (g.columns.cols() == 0) fail(path, "GIFTI file has no per-vertex data arrays", "give a .label.gii or a 0/1 .shape.gii mask");
      labels = g.columns_are_labels;
      values = g.columns.col(0);
      check_length(path, values.rows(), expected_vertices);
      for (const auto& [key, name] : g.label_table)
        if (names_the_medial_wall(name)) outside_keys.insert(key);
    } else {
      values = read_per_vertex(path, expected_vertices);
    }
    // Label files: any non-zero key is inside. Masks: value > 0.5 (robust to float rounding; a
    // probability map is thresholded at one half). Values outside [0, 1] are per-vertex data
    // (sulc, curv, thickness), never a mask: refused, not thresholded into some region.
    if (!labels && values.rows() > 0) {
      const double lo = values.col(0).minCoeff(), hi = values.col(0).maxCoeff();
      if (!(lo >= -1e-6 && hi <= 1.0 + 1e-6))
        fail(path, "values from " + std::to_string(lo) + " to " + std::to_string(hi) + " are not a 0/1 mask (per-vertex data such as sulc or thickness?)",
             "give the cortex as a FreeSurfer .label, a .label.gii or a 0/1 .shape.gii mask");
    }
    for (Eigen::Index i = 0; i < values.rows(); ++i)
      if (labels ? outside_keys.count(static_cast<int>(values(i, 0))) == 0 : values(i, 0) > 0.5) vertices.push_back(static_cast<int>(i));
  }
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  if (vertices.empty()) fail_empty_region(path);
  return vertices;
}

RegionFile read_region_file_checked(const std::string& path, int expected_vertices, const TriMesh* surface) {
  const std::string bytes = detail::read_file(path);
  RegionFile r;
  switch (sniff_surface(bytes, path)) {
    case SurfaceFormat::kGifti: {
      detail::GiftiContents g = detail::read_gifti(path);
      if (!g.has_mesh) break;  // a label or mask
      r.is_face_set = true;
      r.face_set_vertices = g.mesh.num_vertices();
      r.faces = std::move(g.mesh.F);
      return r;
    }
    case SurfaceFormat::kFreeSurfer:
    case SurfaceFormat::kVtk:
    case SurfaceFormat::kVtp:
    case SurfaceFormat::kPly:
    case SurfaceFormat::kObj:
    case SurfaceFormat::kMniObj:
    case SurfaceFormat::kStl: {
      const Surface s = read_surface(path);
      r.is_face_set = true;
      r.face_set_vertices = s.mesh.num_vertices();
      r.faces = s.mesh.F;
      return r;
    }
    default: break;  // labels, masks, curv-style per-vertex files
  }
  r.vertices = region_vertices(bytes, path, expected_vertices, surface);
  return r;
}

}  // namespace

std::vector<int> read_region_vertices(const std::string& path, int expected_vertices) {
  return region_vertices(detail::read_file(path), path, expected_vertices, nullptr);
}

std::vector<int> read_region_vertices(const std::string& path, const TriMesh& surface) {
  return region_vertices(detail::read_file(path), path, static_cast<int>(surface.V.rows()), &surface);
}

RegionFile read_region_file(const std::string& path, int expected_vertices) {
  return read_region_file_checked(path, expected_vertices, nullptr);
}

RegionFile read_region_file(const std::string& path, const TriMesh& surface) {
  return read_region_file_checked(path, static_cast<int>(surface.V.rows()), &surface);
}

Label read_freesurfer_label(const std::string& path) { return detail::parse_freesurfer_label(detail::read_file(path), path); }

void write_freesurfer_label(const std::string& path, const Label& label) {
  for (const int v : label.vertices)
    if (v < 0) throw InputError(path + ": negative vertex index " + std::to_string(v) + " in label; nothing written");
  write_file_atomically(path, detail::serialize_freesurfer_label(label));
}

}  // namespace authalic::io

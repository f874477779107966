// FreeSurfer binary formats, parsed from memory with every count checked against the bytes present.
// Layouts follow FreeSurfer's utils/mrisurf_io.cpp (triangle surfaces, patches), utils/mri_curv.cpp
// ("new" curv), utils/label.cpp, and nibabel.freesurfer.io (volume-geometry footer). All
// multi-byte numbers are big-endian.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "io/io_internal.h"
#include "io/surface_formats.h"

namespace authalic::io::detail {

namespace {

constexpr int kTagOldSurfGeom = 20;  // FreeSurfer TAG_OLD_SURF_GEOM: the volume-geometry block
// Upper bound for vertex/face counts (FreeSurfer's own meshes stay far below): keeps a corrupt
// count from turning into a huge allocation before the size check can run.
constexpr long long kMaxElements = 200'000'000;

std::string trim(const std::string& s) {
  const std::size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const std::size_t e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

// Parses "key = a b c" lines of the footer; returns false when the line is not of that form.
bool footer_line(const std::string& line, std::string* key, std::string* value) {
  const std::size_t eq = line.find('=');
  if (eq == std::string::npos) return false;
  *key = trim(line.substr(0, eq));
  *value = trim(line.substr(eq + 1));
  return true;
}

bool parse_three(const std::string& value, Eigen::Vector3d* out) {
  std::istringstream ss(value);
  double a, b, c;
  if (!(ss >> a >> b >> c)) return false;
  if (!std::isfinite(a) || !std::isfinite(b) || !std::isfinite(c)) return false;
  *out = {a, b, c};
  return true;
}

// The footer after the faces. Absent or unknown tags: no geometry (old FreeSurfer files have none).
// A block that starts like a volume geometry but is malformed is refused: its cras would move the
// surface in scanner space, so it cannot be silently ignored.
VolumeGeometry parse_volume_geometry(BigEndianReader& in) {
  VolumeGeometry vg;
  if (in.remaining() < 4) return vg;
  const std::size_t start = in.pos();
  int tag = in.i32("footer tag");
  if (tag != kTagOldSurfGeom) {
    // nibabel and FreeSurfer also write the 3-int head [2, 0, 20].
    in.seek(start);
    if (in.remaining() < 12) return vg;
    const int a = in.i32("footer tag"), b = in.i32("footer tag"), c = in.i32("footer tag");
    if (!(a == 2 && b == 0 && c == kTagOldSurfGeom)) return vg;  // another tag (command lines, ...)
  }
  const char* keys[] = {"valid", "filename", "volume", "voxelsize", "xras", "yras", "zras", "cras"};
  for (const char* expected : keys) {
    const std::string line = in.line(4096, "volume-geometry line");
    std::string key, value;
    if (!footer_line(line, &key, &value) || key != expected)
      in.fail(std::string("malformed volume-geometry footer: expected '") + expected + " = ...', found '" + line.substr(0, 60) + "'",
              "the surface's scanner position cannot be trusted; re-create the file with FreeSurfer (mris_convert)");
    bool ok = true;
    if (key == "valid") {
      vg.valid = !value.empty() && value[0] == '1';
    } else if (key == "filename") {
      vg.filename = value;
    } else if (key == "volume") {
      std::istringstream ss(value);
      ok = static_cast<bool>(ss >> vg.volume[0] >> vg.volume[1] >> vg.volume[2]);
    } else if (key == "voxelsize") {
      ok = parse_three(value, &vg.voxelsize);
    } else if (key == "xras") {
      ok = parse_three(value, &vg.xras);
    } else if (key == "yras") {
      ok = parse_three(value, &vg.yras);
    } else if (key == "zras") {
      ok = parse_three(value, &vg.zras);
    } else {
      ok = parse_three(value, &vg.cras);
    }
    if (!ok)
      in.fail("malformed volume-geometry footer: cannot read the numbers of '" + key + "'",
              "the surface's scanner position cannot be trusted; re-create the file with FreeSurfer (mris_convert)");
  }
  return vg;
}

std::string format_three(const Eigen::Vector3d& v) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), "%.10g %.10g %.10g", v[0], v[1], v[2]);
  return buf;
}

void check_count(BigEndianReader& in, long long count, const char* what) {
  if (count < 0 || count > kMaxElements)
    in.fail(std::string("implausible ") + what + " count " + std::to_string(count), "the file is corrupt or not a " + in.format() + " file");
}

}  // namespace

FreeSurferKind sniff_freesurfer(const std::string& bytes) {
  if (bytes.size() < 4) return FreeSurferKind::kNone;
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  const unsigned magic = (unsigned(p[0]) << 16) | (unsigned(p[1]) << 8) | p[2];
  if (magic == kFreeSurferTriangleMagic) return FreeSurferKind::kTriangleSurface;
  if (magic == kFreeSurferQuadOrNewCurvMagic) {
    // A new-format patch starts with the int32 -1 (four 0xFF bytes); a curv/quad file continues
    // with the high byte of a vertex count, which is 0 for any real mesh.
    if (p[3] == 0xFF) return FreeSurferKind::kPatch;
    return FreeSurferKind::kNewCurv;
  }
  return FreeSurferKind::kNone;
}

Surface parse_freesurfer_surface(const std::string& bytes, const std::string& path) {
  BigEndianReader in(bytes, path, "FreeSurfer surface");
  const std::uint32_t magic = in.u24("magic number");
  if (magic == kFreeSurferQuadOrNewCurvMagic)
    in.fail("is a FreeSurfer quad surface or curv file (magic 0xFFFFFF), not a triangle surface",
            "convert it with mris_convert or give a triangle surface (magic 0xFFFFFE)");
  if (magic != kFreeSurferTriangleMagic) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "wrong magic number 0x%06X (expected 0xFFFFFE)", magic);
    in.fail(buf, "this is not a FreeSurfer triangle surface (supported: FreeSurfer binary, .gii/.gii.gz, .vtk, .vtp, .ply, .obj, .stl)");
  }
  // "created by <user> on <date>\n\n": two lines.
  in.line(8192, "created-by line");
  in.line(8192, "created-by line");
  const long long nv = in.i32("vertex count");
  const long long nf = in.i32("face count");
  check_count(in, nv, "vertex");
  check_count(in, nf, "face");
  const long long needed = 12 * nv + 12 * nf;
  if (static_cast<long long>(in.remaining()) < needed)
    in.fail("counts do not match the file size: " + std::to_string(nv) + " vertices and " + std::to_string(nf) + " faces need " +
                std::to_string(needed) + " bytes after the header, the file has " + std::to_string(in.remaining()),
            "the file is truncated or its header is corrupt");
  Surface s;
  s.format = "freesurfer";
  s.mesh.V.resize(nv, 3);
  for (long long i = 0; i < nv; ++i)
    for (int c = 0; c < 3; ++c) s.mesh.V(i, c) = in.f32("vertex coordinates");
  s.mesh.F.resize(nf, 3);
  for (long long i = 0; i < nf; ++i)
    for (int c = 0; c < 3; ++c) s.mesh.F(i, c) = in.i32("face indices");
  validate_mesh(s.mesh, path, "FreeSurfer surface");
  s.volume_geometry = parse_volume_geometry(in);
  s.has_volume_geometry = s.volume_geometry.valid;
  s.space = "tkregister RAS";
  if (s.has_volume_geometry) {
    s.c_ras = s.volume_geometry.cras;
    s.to_scanner.block<3, 1>(0, 3) = s.c_ras;
  }
  return s;
}

std::string serialize_freesurfer_surface(const TriMesh& mesh, const SurfaceWriteOptions& options) {
  BigEndianWriter out;
  out.u24(kFreeSurferTriangleMagic);
  out.bytes("created by authalic\n\n");
  out.i32(mesh.num_vertices());
  out.i32(mesh.num_faces());
  for (int i = 0; i < mesh.num_vertices(); ++i)
    for (int c = 0; c < 3; ++c) out.f32(static_cast<float>(c < mesh.V.cols() ? mesh.V(i, c) : 0.0));
  for (int i = 0; i < mesh.num_faces(); ++i)
    for (int c = 0; c < 3; ++c) out.i32(mesh.F(i, c));
  const VolumeGeometry& vg = options.volume_geometry;
  if (vg.valid) {
    out.i32(2);
    out.i32(0);
    out.i32(kTagOldSurfGeom);
    out.bytes("valid = 1  # volume info valid\n");
    out.bytes("filename = " + vg.filename + "\n");
    out.bytes("volume = " + std::to_string(vg.volume[0]) + " " + std::to_string(vg.volume[1]) + " " + std::to_string(vg.volume[2]) + "\n");
    out.bytes("voxelsize = " + format_three(vg.voxelsize) + "\n");
    out.bytes("xras   = " + format_three(vg.xras) + "\n");
    out.bytes("yras   = " + format_three(vg.yras) + "\n");
    out.bytes("zras   = " + format_three(vg.zras) + "\n");
    out.bytes("cras   = " + format_three(vg.cras) + "\n");
  }
  return std::move(out.out);
}

VectorXd parse_freesurfer_curv(const std::string& bytes, const std::string& path) {
  BigEndianReader in(bytes, path, "FreeSurfer curv");
  const std::uint32_t magic = in.u24("magic number");
  VectorXd values;
  if (magic == kFreeSurferQuadOrNewCurvMagic) {
    const long long nv = in.i32("vertex count");
    const long long nf = in.i32("face count");
    const long long per_vertex = in.i32("values per vertex");
    check_count(in, nv, "vertex");
    check_count(in, nf, "face");
    if (per_vertex != 1)
      in.fail("has " + std::to_string(per_vertex) + " values per vertex (expected 1)", "only single-valued curv files are supported");
    if (static_cast<long long>(in.remaining()) < 4 * nv)
      in.fail("counts do not match the file size: " + std::to_string(nv) + " values need " + std::to_string(4 * nv) +
                  " bytes, the file has " + std::to_string(in.remaining()) + " after the header",
              "the file is truncated or its header is corrupt");
    values.resize(nv);
    for (long long i = 0; i < nv; ++i) values[i] = in.f32("values");
  } else {
    // Old format: 3-byte vertex and face counts, then int16 values in hundredths.
    const long long nv = magic;
    in.u24("face count");
    if (static_cast<long long>(in.remaining()) != 2 * nv)
      in.fail("not a FreeSurfer curv file: wrong magic number (new format: 0xFFFFFF) and the size does not match the old format",
              "give a curv/thickness/sulc file, a GIFTI shape file or a text file");
    values.resize(nv);
    for (long long i = 0; i < nv; ++i) values[i] = in.i16("values") / 100.0;
  }
  for (Eigen::Index i = 0; i < values.size(); ++i)
    if (!std::isfinite(values[i]))
      in.fail("value " + std::to_string(i) + " is not finite (NaN or Inf)", "fix or mask the per-vertex data before using it");
  return values;
}

std::string serialize_freesurfer_curv(const VectorXd& values, int num_faces) {
  BigEndianWriter out;
  out.u24(kFreeSurferQuadOrNewCurvMagic);
  out.i32(static_cast<std::int32_t>(values.size()));
  out.i32(num_faces);
  out.i32(1);
  for (Eigen::Index i = 0; i < values.size(); ++i) out.f32(static_cast<float>(values[i]));
  return std::move(out.out);
}

bool looks_like_freesurfer_label(const std::string& bytes) { return bytes.rfind("#!ascii label", 0) == 0; }

Label parse_freesurfer_label(const std::string& text, const std::string& path) {
  // Line 1 is a comment ("#!ascii label ..."), line 2 the count, then "vno x y z value" lines.
  const std::string hint = "a FreeSurfer label has a comment line, a count line and one 'vertex x y z value' line per vertex";
  std::size_t pos = text.find('\n');
  if (text.empty() || text[0] != '#' || pos == std::string::npos) fail(path, "not a FreeSurfer label file (no '#' comment line)", hint);
  auto next_line = [&](std::string* line) {
    if (pos >= text.size()) return false;
    const std::size_t start = pos + 1;
    if (start > text.size()) return false;
    const std::size_t end = text.find('\n', start);
    *line = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
    pos = end == std::string::npos ? text.size() : end;
    return true;
  };
  std::string line;
  if (!next_line(&line)) fail(path, "truncated: no vertex count line", hint);
  long long count = -1;
  {
    std::istringstream ss(line);
    if (!(ss >> count) || count < 0 || count > kMaxElements) fail(path, "bad vertex count line '" + line.substr(0, 60) + "'", hint);
  }
  // Each vertex line has at least 9 characters ("0 0 0 0 0"): a count beyond that is a lie.
  if (static_cast<std::size_t>(count) > text.size() / 9 + 1)
    fail(path, "count " + std::to_string(count) + " does not match the file size (" + std::to_string(text.size()) + " bytes)",
         "the file is truncated or its count line is wrong");
  Label label;
  label.vertices.resize(count);
  label.positions.resize(count, 3);
  label.values.resize(count);
  for (long long i = 0; i < count; ++i) {
    if (!next_line(&line) || trim(line).empty())
      fail(path, "truncated: the header says " + std::to_string(count) + " vertices, the file has " + std::to_string(i),
           "the file is incomplete");
    // strtod, unlike iostreams, reads "nan"/"inf", so they are caught below instead of passing
    // as a generic syntax error.
    double f[5];
    const char* p = line.c_str();
    int got = 0;
    for (; got < 5; ++got) {
      char* end = nullptr;
      f[got] = std::strtod(p, &end);
      if (end == p) break;
      p = end;
    }
    if (got < 5) fail(path, "line " + std::to_string(i + 3) + " is not 'vertex x y z value': '" + line.substr(0, 60) + "'", hint);
    if (!std::isfinite(f[0]) || f[0] != std::floor(f[0]) || f[0] > std::numeric_limits<int>::max())
      fail(path, "line " + std::to_string(i + 3) + " has an invalid vertex index", hint);
    // Print the index as a double: a huge negative one does not fit a long long (fuzzing found it).
    if (f[0] < 0) {
      char idx[64];
      std::snprintf(idx, sizeof(idx), "%.0f", f[0] < -1e15 ? -1e15 : f[0]);
      fail(path, "line " + std::to_string(i + 3) + " has a negative vertex index " + (f[0] < -1e15 ? "below " : "") + idx, hint);
    }
    if (!std::isfinite(f[1]) || !std::isfinite(f[2]) || !std::isfinite(f[3]))
      fail(path, "line " + std::to_string(i + 3) + " has a non-finite coordinate", "fix the label file");
    label.vertices[i] = static_cast<int>(f[0]);
    label.positions.row(i) << f[1], f[2], f[3];
    label.values[i] = f[4];
  }
  return label;
}

std::string serialize_freesurfer_label(const Label& label) {
  std::ostringstream ss;
  ss << "#!ascii label  , from subject  vox2ras=TkReg (written by authalic)\n" << label.vertices.size() << "\n";
  char buf[160];
  for (std::size_t i = 0; i < label.vertices.size(); ++i) {
    const double x = label.positions.rows() > static_cast<Eigen::Index>(i) ? label.positions(i, 0) : 0.0;
    const double y = label.positions.rows() > static_cast<Eigen::Index>(i) ? label.positions(i, 1) : 0.0;
    const double z = label.positions.rows() > static_cast<Eigen::Index>(i) ? label.positions(i, 2) : 0.0;
    const double v = label.values.size() > static_cast<Eigen::Index>(i) ? label.values[i] : 0.0;
    std::snprintf(buf, sizeof(buf), "%d  %.3f  %.3f  %.3f %.10f\n", label.vertices[i], x, y, z, v);
    ss << buf;
  }
  return ss.str();
}

Patch parse_freesurfer_patch(const std::string& bytes, const std::string& path) {
  BigEndianReader in(bytes, path, "FreeSurfer patch");
  long long n = in.i32("point count");
  bool new_format = false;
  if (n == -1) {  // new format: -1, then the count, then int + 3 float32 per point
    new_format = true;
    n = in.i32("point count");
  }
  check_count(in, n, "point");
  const long long record = new_format ? 16 : 10;
  if (static_cast<long long>(in.remaining()) < n * record)
    in.fail("counts do not match the file size: " + std::to_string(n) + " points need " + std::to_string(n * record) +
                " bytes, the file has " + std::to_string(in.remaining()) + " after the header",
            "the file is truncated or not a FreeSurfer patch");
  Patch p;
  p.vertices.resize(n);
  p.on_border.resize(n);
  p.positions.resize(n, 3);
  for (long long i = 0; i < n; ++i) {
    // Vertex k is stored as k+1 (interior) or -(k+1) (border): 0 is impossible.
    const std::int32_t code = in.i32("vertex index");
    if (code == 0 || code == std::numeric_limits<std::int32_t>::min())
      in.fail("point " + std::to_string(i) + " has an invalid vertex code " + std::to_string(code), "the file is corrupt");
    p.on_border[i] = code < 0;
    p.vertices[i] = (code < 0 ? -code : code) - 1;
    for (int c = 0; c < 3; ++c) p.positions(i, c) = new_format ? in.f32("coordinates") : in.i16("coordinates") / 100.0;
    if (!p.positions.row(i).allFinite())
      in.fail("point " + std::to_string(i) + " (vertex " + std::to_string(p.vertices[i]) + ") has a NaN/Inf coordinate", "the file is corrupt");
  }
  return p;
}

std::string serialize_freesurfer_patch(const std::vector<int>& vertices, const MatrixXd& positions,
                                       const std::vector<bool>& on_border) {
  BigEndianWriter out;
  out.i32(-1);
  out.i32(static_cast<std::int32_t>(vertices.size()));
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const bool border = i < on_border.size() && on_border[i];
    out.i32(border ? -(vertices[i] + 1) : vertices[i] + 1);
    for (int c = 0; c < 3; ++c)
      out.f32(static_cast<float>(c < positions.cols() ? positions(static_cast<Eigen::Index>(i), c) : 0.0));
  }
  return std::move(out.out);
}

}  // namespace authalic::io::detail

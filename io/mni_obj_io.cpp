// MNI .obj polygon surfaces (BIC object format: CIVET's *_surface_*.obj, the MNI tools' Display
// and BrainBrowser), ASCII ('P') and binary ('p', in the writing machine's byte order).
//
// Layout of a polygon object, ASCII tokens separated by any whitespace, or binary in this order:
//   P  ambient diffuse specular_reflectance specular_scattering transparency  n_points
//   n_points x (x y z)        points, mm
//   n_points x (nx ny nz)     normals (not used)
//   n_items  colour_flag      colour_flag 0: one colour, 1: one per item, 2: one per point
//   colours                   4 numbers each (binary: 4 bytes)
//   n_items end indices       item i uses indices [end[i-1], end[i])
//   end[n_items - 1] indices  into the points
// Binary files hold float32 and int32 values after the one-byte type.
//
// Parsed here rather than by VTK's vtkMNIObjectReader (VTK::IOMINC): that reader trusts the end
// indices (a decreasing one gives a negative polygon size), accepts a point index equal to the
// point count, reads ASCII lines of at most 255 characters and binary counts unchecked, so a
// check in front of it would be a full parse anyway.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string_view>
#include <vector>

#include "io/io_internal.h"
#include "io/surface_formats.h"
#include "io/vtk_family_check.h"

namespace authalic::io::detail {

namespace {

using u64 = std::uint64_t;

std::string str(u64 v) { return std::to_string(v); }

constexpr const char* kCorrupt = "the MNI .obj file is corrupt or truncated; re-export it (CIVET, bicpl)";

// Values of an MNI object, in file order, from either encoding.
class MniObjValues {
 public:
  virtual ~MniObjValues() = default;
  virtual double number(const char* what) = 0;
  virtual long long integer(const char* what) = 0;
  virtual void colour(const char* what) = 0;
  virtual void finish() = 0;
};

bool is_space(char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; }

class AsciiValues final : public MniObjValues {
 public:
  AsciiValues(const std::string& bytes, const std::string& path) : bytes_(bytes), path_(path), pos_(1) {}
  double number(const char* what) override {
    const std::string_view tok = next(what);
    double v = 0;
    if (!parse_finite(tok, v))
      fail(path_, "line " + str(line_) + ": " + what + " " + quoted(tok) + " is not a finite number", kCorrupt);
    return v;
  }
  long long integer(const char* what) override {
    const std::string_view tok = next(what);
    long long v = 0;
    if (!parse_integer(tok, v)) fail(path_, "line " + str(line_) + ": " + what + " " + quoted(tok) + " is not an integer", kCorrupt);
    return v;
  }
  void colour(const char* what) override {
    for (int c = 0; c < 4; ++c) number(what);
  }
  void finish() override {
    skip_space();
    if (pos_ < bytes_.size())
      fail(path_, "line " + str(line_) + ": data after the last polygon index", "the file holds more than one object, or is corrupt");
  }

 private:
  void skip_space() {
    while (pos_ < bytes_.size() && is_space(bytes_[pos_])) {
      if (bytes_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }
  std::string_view next(const char* what) {
    skip_space();
    if (pos_ >= bytes_.size()) fail(path_, std::string("the file ends before its ") + what, kCorrupt);
    const std::size_t start = pos_;
    while (pos_ < bytes_.size() && !is_space(bytes_[pos_])) ++pos_;
    return std::string_view(bytes_).substr(start, pos_ - start);
  }
  const std::string& bytes_;
  const std::string& path_;
  std::size_t pos_;
  u64 line_ = 1;
};

class BinaryValues final : public MniObjValues {
 public:
  BinaryValues(const std::string& bytes, const std::string& path, bool swap) : bytes_(bytes), path_(path), swap_(swap) {}
  double number(const char* what) override {
    need(4, what);
    const auto v = field_at<float>(bytes_, pos_, swap_);
    pos_ += 4;
    if (!std::isfinite(v) || std::fabs(v) > 1e30f)
      fail(path_, std::string(what) + " at byte " + str(pos_ - 4) + " is not a finite number", kCorrupt);
    return v;
  }
  long long integer(const char* what) override {
    need(4, what);
    const auto v = field_at<std::int32_t>(bytes_, pos_, swap_);
    pos_ += 4;
    return v;
  }
  void colour(const char* what) override {
    need(4, what);
    pos_ += 4;
  }
  void finish() override {
    if (pos_ != bytes_.size())
      fail(path_, "binary object ends at byte " + str(pos_) + " of " + str(bytes_.size()),
           "the file holds more than one object, or is corrupt");
  }

 private:
  void need(std::size_t n, const char* what) {
    if (bytes_.size() - pos_ < n) fail(path_, std::string("the file ends before its ") + what, kCorrupt);
  }
  const std::string& bytes_;
  const std::string& path_;
  bool swap_;
  std::size_t pos_ = 1;
};

// Binary files carry no byte-order mark: the order in which the counts describe exactly the
// file's size is the one it was written in.
bool binary_layout_fits(const std::string& bytes, bool swap) {
  auto i32_at = [&](u64 at, u64* out) {
    if (at + 4 > bytes.size()) return false;
    const std::int32_t v = field_at<std::int32_t>(bytes, static_cast<std::size_t>(at), swap);
    if (v < 0) return false;
    *out = static_cast<u64>(v);
    return true;
  };
  u64 n_points = 0, n_items = 0, flag = 0, last_end = 0;
  u64 at = 1 + 5 * 4;
  if (!i32_at(at, &n_points)) return false;
  at += 4 + 24 * n_points;
  if (!i32_at(at, &n_items) || !i32_at(at + 4, &flag) || flag > 2) return false;
  at += 8 + 4 * (flag == 0 ? 1 : flag == 1 ? n_items : n_points);
  if (n_items > 0 && !i32_at(at + 4 * (n_items - 1), &last_end)) return false;
  return at + 4 * n_items + 4 * last_end == bytes.size();
}

u64 checked_count(MniObjValues& in, const char* what, u64 cap, const std::string& path) {
  const long long n = in.integer(what);
  if (n < 0) fail(path, std::string(what) + " is negative (" + std::to_string(n) + ")", kCorrupt);
  if (static_cast<u64>(n) > cap)
    fail(path, std::string(what) + " is " + std::to_string(n) + ", more than the " + str(cap) + " accepted",
         "the file is not a cortical surface");
  return static_cast<u64>(n);
}

}  // namespace

bool looks_like_mni_obj(const std::string& bytes) {
  if (bytes.size() < 2) return false;
  if (bytes[0] == 'P' || bytes[0] == 'L') return is_space(bytes[1]);  // Wavefront keywords are lower case
  if (bytes[0] == 'p') return binary_layout_fits(bytes, false) || binary_layout_fits(bytes, true);
  return false;
}

TriMesh parse_mni_obj(const std::string& bytes, const std::string& path) {
  if (bytes.empty()) fail(path, "the file is empty", "give a surface file");
  const char type = bytes[0];
  if (type == 'L' || type == 'l')
    fail(path, "is an MNI line object (tracts or contours), not a polygon surface", "give a surface (.obj starting with 'P')");
  if (type != 'P' && type != 'p') fail(path, "is not an MNI polygon object (first byte is not 'P' or 'p')", "give an MNI .obj surface");
  AsciiValues ascii(bytes, path);
  std::unique_ptr<BinaryValues> binary;
  if (type == 'p') {
    const bool native = binary_layout_fits(bytes, false);
    if (!native && !binary_layout_fits(bytes, true))
      fail(path, "binary MNI object whose counts do not match its " + str(bytes.size()) + " bytes in either byte order", kCorrupt);
    binary = std::make_unique<BinaryValues>(bytes, path, !native);
  }
  MniObjValues& in = binary ? static_cast<MniObjValues&>(*binary) : ascii;
  // A count is corrupt, not allocated, when its items cannot fit: each ASCII number takes at least
  // a digit and a separator (binary ones 4 bytes), so a point and its normal at least 12 bytes.
  auto require_room = [&](u64 count, u64 bytes_each, const char* what) {
    if (count * bytes_each > bytes.size())
      fail(path, "declares " + str(count) + " " + what + ", more than its " + str(bytes.size()) + " bytes can hold", kCorrupt);
  };

  for (int k = 0; k < 5; ++k) in.number("surface property");
  const u64 n_points = checked_count(in, "point count", g_max_vtk_vertices, path);
  require_room(n_points, 12, "points");
  TriMesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(n_points), 3);
  for (u64 i = 0; i < n_points; ++i)
    for (int c = 0; c < 3; ++c) mesh.V(static_cast<Eigen::Index>(i), c) = in.number("point coordinate");
  for (u64 i = 0; i < 3 * n_points; ++i) in.number("normal");
  const u64 n_items = checked_count(in, "polygon count", g_max_vtk_faces, path);
  require_room(n_items, 2, "polygons");
  const long long flag = in.integer("colour flag");
  if (flag < 0 || flag > 2) fail(path, "colour flag is " + std::to_string(flag) + " (0, 1 or 2 expected)", kCorrupt);
  const u64 n_colours = flag == 0 ? 1 : flag == 1 ? n_items : n_points;
  for (u64 i = 0; i < n_colours; ++i) in.colour("colours");

  std::vector<u64> end(n_items);
  u64 previous = 0;
  for (u64 i = 0; i < n_items; ++i) {
    const long long e = in.integer("polygon end index");
    if (e < static_cast<long long>(previous) + 3)
      fail(path, "polygon " + str(i) + " has " + std::to_string(e - static_cast<long long>(previous)) + " corners (end index " +
                     std::to_string(e) + " after " + str(previous) + ")",
           "every polygon of a surface needs at least 3 corners; the file is corrupt");
    if (static_cast<u64>(e) > 3 * g_max_vtk_faces) fail(path, "polygon end index " + std::to_string(e) + " is too large", kCorrupt);
    previous = end[i] = static_cast<u64>(e);
  }
  require_room(previous, 2, "polygon corners");
  std::vector<int> corner(previous);
  for (u64 k = 0; k < previous; ++k) {
    const long long v = in.integer("polygon corner");
    if (v < 0 || static_cast<u64>(v) >= n_points)
      fail(path, "polygon corner " + str(k) + " is point " + std::to_string(v) + " of an object with " + str(n_points) + " points (0.." +
                     std::to_string(static_cast<long long>(n_points) - 1) + ")",
           kCorrupt);
    corner[k] = static_cast<int>(v);
  }
  in.finish();

  // Fan triangulation keeps each polygon's orientation (CIVET's surfaces are triangles already).
  std::vector<std::array<int, 3>> tris;
  tris.reserve(previous >= 2 * n_items ? previous - 2 * n_items : 0);
  u64 begin = 0;
  for (u64 i = 0; i < n_items; ++i) {
    for (u64 k = begin + 1; k + 1 < end[i]; ++k) tris.push_back({corner[begin], corner[k], corner[k + 1]});
    begin = end[i];
  }
  mesh.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t f = 0; f < tris.size(); ++f) mesh.F.row(static_cast<Eigen::Index>(f)) << tris[f][0], tris[f][1], tris[f][2];
  return mesh;
}

}  // namespace authalic::io::detail

// Pre-checks for the VTK-family readers (see vtk_family_check.h). Each parser knows just enough
// of its format to prove that VTK will find every byte the header promises, and nothing more.
#include "io/vtk_family_check.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <vector>

#include "io/base64.h"
#include "io/io_internal.h"

namespace authalic::io::detail {

std::size_t g_max_vtk_vertices = 50'000'000;
std::size_t g_max_vtk_faces = 100'000'000;

// A whole token as a double (strtod must consume all of it).
bool parse_number(std::string_view tok, double& out) {
  char buf[72];
  if (tok.empty() || tok.size() >= sizeof(buf)) return false;
  std::memcpy(buf, tok.data(), tok.size());
  buf[tok.size()] = '\0';
  char* end = nullptr;
  out = std::strtod(buf, &end);
  return end == buf + tok.size();
}

// Coordinates and other values that must be finite and of a sane magnitude.
bool parse_finite(std::string_view tok, double& out) {
  return parse_number(tok, out) && std::isfinite(out) && std::fabs(out) <= 1e30;
}

bool parse_integer(std::string_view tok, long long& out) {
  if (!tok.empty() && tok[0] == '+') tok.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return ec == std::errc() && ptr == tok.data() + tok.size() && !tok.empty();
}

std::string quoted(std::string_view tok) {
  return "'" + std::string(tok.substr(0, 40)) + (tok.size() > 40 ? "...'" : "'");
}

namespace {

using u64 = std::uint64_t;

std::string str(u64 n) { return std::to_string(n); }

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_blank(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_blank(line[i])) ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// Text lines numbered from 1; a line excludes its '\n'.
class Lines {
 public:
  explicit Lines(const std::string& bytes, std::size_t start = 0) : bytes_(bytes), pos_(start) {}
  bool next(std::string_view& line) {
    if (pos_ >= bytes_.size()) return false;
    std::size_t end = bytes_.find('\n', pos_);
    if (end == std::string::npos) end = bytes_.size();
    line = std::string_view(bytes_).substr(pos_, end - pos_);
    terminated_ = end < bytes_.size();
    pos_ = std::min(end + 1, bytes_.size());
    ++number_;
    return true;
  }
  std::size_t number() const { return number_; }
  // Whether the line last returned ended with '\n' (the last line of a file may not).
  bool terminated() const { return terminated_; }
  std::size_t pos() const { return pos_; }

 private:
  const std::string& bytes_;
  std::size_t pos_;
  std::size_t number_ = 0;
  bool terminated_ = false;
};

// A non-negative count from a header.
bool parse_count(std::string_view tok, u64& out) {
  long long v = 0;
  if (!parse_integer(tok, v) || v < 0) return false;
  out = static_cast<u64>(v);
  return true;
}


// ---- PLY ---------------------------------------------------------------------------------

// vtkPLY reads every line into a 4096-byte buffer; longer lines are split and misread.
constexpr std::size_t kMaxPlyLine = 4000;

struct PlyType {
  const char* name;
  int size;
  bool is_signed;
  bool is_float;
};
constexpr PlyType kPlyTypes[] = {
    {"char", 1, true, false},   {"int8", 1, true, false},    {"uchar", 1, false, false},  {"uint8", 1, false, false},
    {"short", 2, true, false},  {"int16", 2, true, false},   {"ushort", 2, false, false}, {"uint16", 2, false, false},
    {"int", 4, true, false},    {"int32", 4, true, false},   {"uint", 4, false, false},   {"uint32", 4, false, false},
    {"float", 4, true, true},   {"float32", 4, true, true},  {"double", 8, true, true},   {"float64", 8, true, true},
};

const PlyType* find_ply_type(std::string_view name) {
  for (const PlyType& t : kPlyTypes)
    if (name == t.name) return &t;
  return nullptr;
}

struct PlyProperty {
  std::string name;
  bool is_list = false;
  const PlyType* count = nullptr;  // lists only
  const PlyType* item = nullptr;
};

struct PlyElement {
  std::string name;
  u64 count = 0;
  std::vector<PlyProperty> props;
};

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  std::size_t body = 0;       // offset of the first body byte
  std::size_t body_line = 0;  // number of the last header line
};

bool is_face_index_list(const std::string& element, const std::string& prop) {
  return element == "face" && (prop == "vertex_indices" || prop == "vertex_index");
}

// vtkPLYReader imposes its own scalar/list layout on the properties it knows, whatever the
// header says: a vertex coordinate declared as a list would be read with the wrong size.
void check_ply_layout(const PlyElement& e, const std::string& path) {
  for (const PlyProperty& p : e.props) {
    const bool vtk_list = is_face_index_list(e.name, p.name) || (e.name == "face" && p.name == "texcoord");
    if (is_face_index_list(e.name, p.name) && p.item->is_float)
      fail(path, "PLY face corners ('" + p.name + "') are declared as floating-point numbers", "the header is corrupt");
    if ((e.name == "vertex" || e.name == "face") && p.is_list != vtk_list)
      fail(path, "PLY property '" + p.name + "' of element '" + e.name + "' is declared as " + (p.is_list ? "a list" : "a scalar"),
           "the header is corrupt; re-create the file");
  }
  // A face element without its corner list made vtkPLY free an unset pointer (fuzz_ply).
  if (e.name == "face" && std::none_of(e.props.begin(), e.props.end(), [&](const PlyProperty& p) { return is_face_index_list(e.name, p.name); }))
    fail(path, "PLY face element has no vertex_indices list", "the header is corrupt");
  if (e.name == "vertex")
    for (const char* axis : {"x", "y", "z"})
      if (std::none_of(e.props.begin(), e.props.end(), [&](const PlyProperty& p) { return p.name == axis; }))
        fail(path, std::string("PLY vertex element has no property '") + axis + "'", "the file is not a PLY surface");
}

// vtkPLY splits words at spaces and tabs only: another control character (found by fuzz_ply:
// a vertical tab) would make VTK see other words than this parser and read a different layout.
void check_ply_text(std::string_view line, const std::string& where, const std::string& path) {
  for (std::size_t i = 0; i < line.size(); ++i) {
    const auto c = static_cast<unsigned char>(line[i]);
    const bool line_end_cr = c == '\r' && i + 1 == line.size();
    if ((c < 0x20 && c != '\t' && !line_end_cr) || c == 0x7F)
      fail(path, where + " holds control character " + str(c), "the PLY file is corrupt");
  }
}

PlyProperty parse_ply_property(const std::vector<std::string_view>& w, std::size_t line, const std::string& path) {
  const std::string where = "PLY header line " + str(line);
  PlyProperty p;
  if (w.size() == 5 && w[1] == "list") {
    p.is_list = true;
    p.count = find_ply_type(w[2]);
    p.item = find_ply_type(w[3]);
    p.name = std::string(w[4]);
    if (!p.count || !p.item) fail(path, where + ": unknown list type in '" + std::string(w[2]) + " " + std::string(w[3]) + "'", "the header is corrupt");
    if (p.count->is_float) fail(path, where + ": a list length cannot be of type " + std::string(w[2]), "the header is corrupt");
  } else if (w.size() == 3 && w[1] != "list") {
    p.item = find_ply_type(w[1]);
    p.name = std::string(w[2]);
    if (!p.item) fail(path, where + ": unknown property type " + quoted(w[1]), "the header is corrupt");
  } else {
    fail(path, where + ": malformed property line", "expected 'property TYPE NAME' or 'property list TYPE TYPE NAME'");
  }
  return p;
}

PlyHeader parse_ply_header(const std::string& bytes, const std::string& path) {
  PlyHeader h;
  Lines lines(bytes);
  std::string_view line;
  if (!lines.next(line) || split_words(line) != std::vector<std::string_view>{"ply"})
    fail(path, "does not start with the PLY magic line 'ply'", "the file is not a PLY surface");
  bool have_format = false;
  while (true) {
    if (!lines.next(line) || lines.number() > 100000)
      fail(path, "PLY header has no end_header line", "the file is truncated or not a PLY surface");
    const std::string where = "PLY header line " + str(lines.number());
    if (line.size() > kMaxPlyLine) fail(path, where + " is longer than " + str(kMaxPlyLine) + " characters", "the header is corrupt");
    check_ply_text(line, where, path);
    if (!lines.terminated()) fail(path, where + " does not end with a newline", "the file is truncated");
    const std::vector<std::string_view> w = split_words(line);
    if (w.empty()) fail(path, where + " is blank", "remove blank lines from the header");
    if (w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "end_header" && w.size() == 1) break;
    if (w[0] == "format" && w.size() == 3 && !have_format) {
      if (w[1] == "ascii") h.format = PlyFormat::kAscii;
      else if (w[1] == "binary_little_endian") h.format = PlyFormat::kBinaryLittle;
      else if (w[1] == "binary_big_endian") h.format = PlyFormat::kBinaryBig;
      else fail(path, where + ": unknown PLY format " + quoted(w[1]), "use ascii, binary_little_endian or binary_big_endian");
      have_format = true;
    } else if (w[0] == "element" && w.size() == 3) {
      PlyElement e;
      e.name = std::string(w[1]);
      if (!parse_count(w[2], e.count)) fail(path, where + ": element count " + quoted(w[2]) + " is not a non-negative integer", "the header is corrupt");
      for (const PlyElement& other : h.elements)
        if (other.name == e.name) fail(path, where + ": element '" + e.name + "' is declared twice", "the header is corrupt");
      h.elements.push_back(std::move(e));
    } else if (w[0] == "property" && !h.elements.empty()) {
      PlyProperty p = parse_ply_property(w, lines.number(), path);
      auto& props = h.elements.back().props;
      if (std::any_of(props.begin(), props.end(), [&](const PlyProperty& q) { return q.name == p.name; }))
        fail(path, where + ": property '" + p.name + "' is declared twice", "the header is corrupt");
      props.push_back(std::move(p));
    } else {
      fail(path, where + ": unexpected " + quoted(line), "the header is corrupt or not PLY");
    }
  }
  if (!have_format) fail(path, "PLY header has no format line", "the header is corrupt");
  h.body = lines.pos();
  h.body_line = lines.number();
  return h;
}

void check_ply_elements(const PlyHeader& h, const std::string& path) {
  bool have_vertex = false;
  for (const PlyElement& e : h.elements) {
    have_vertex = have_vertex || e.name == "vertex";
    if (e.count > 0 && e.props.empty()) fail(path, "PLY element '" + e.name + "' has no properties", "the header is corrupt");
    check_ply_layout(e, path);
  }
  if (!have_vertex) fail(path, "PLY header declares no vertex element", "the file is not a PLY surface");
}

void check_ply_caps(const PlyHeader& h, const std::string& path) {
  for (const PlyElement& e : h.elements) {
    const bool vertex = e.name == "vertex";
    const u64 cap = vertex ? g_max_vtk_vertices : g_max_vtk_faces;
    if (e.count > cap)
      fail(path, "PLY header declares " + str(e.count) + " " + (vertex ? "vertices" : "'" + e.name + "' elements") + ", more than the " + str(cap) + " accepted",
           "the header is corrupt (cortical surfaces have fewer than 1000000 vertices)");
  }
}

// Smallest body the header allows: binary lists hold at least their length (faces: and 3
// indices); an ASCII number takes at least a digit and a separator.
// a * b + c, saturating at 2^64-1 (header counts are not capped yet when this runs).
u64 saturating_mul_add(u64 a, u64 b, u64 c) {
  const u64 max = ~u64(0);
  if (b != 0 && a > max / b) return max;
  return a * b > max - c ? max : a * b + c;
}

u64 minimal_ply_body(const PlyHeader& h) {
  u64 total = 0;
  for (const PlyElement& e : h.elements) {
    u64 row = 0;
    for (const PlyProperty& p : e.props) {
      const u64 items = is_face_index_list(e.name, p.name) ? 3 : 0;
      if (h.format == PlyFormat::kAscii) row += p.is_list ? 2 * (1 + items) : 2;
      else row += p.is_list ? p.count->size + items * p.item->size : p.item->size;
    }
    total = saturating_mul_add(row, e.count, total);
  }
  return h.format == PlyFormat::kAscii && total > 0 ? total - 1 : total;
}

std::string ply_counts_phrase(const PlyHeader& h) {
  std::string s = "declares";
  for (const PlyElement& e : h.elements) {
    if (e.name == "vertex") s += " " + str(e.count) + " vertices";
    if (e.name == "face") s += " and " + str(e.count) + " faces";
  }
  return s;
}

// An integer stored in the binary body (endianness and signedness as declared).
long long read_ply_int(const std::string& bytes, std::size_t pos, const PlyType& t, bool big_endian) {
  u64 v = 0;
  for (int i = 0; i < t.size; ++i) {
    const auto byte = static_cast<unsigned char>(bytes[pos + static_cast<std::size_t>(big_endian ? i : t.size - 1 - i)]);
    v = (v << 8) | byte;
  }
  const int bits = 8 * t.size;
  if (t.is_signed && bits < 64 && (v >> (bits - 1)) != 0) return static_cast<long long>(v) - (1LL << bits);
  return static_cast<long long>(v);
}

u64 ply_vertex_count(const PlyHeader& h) {
  for (const PlyElement& e : h.elements)
    if (e.name == "vertex") return e.count;
  return 0;
}

// vtkPLYReader uses face corners while it reads: a corner past the vertices, or a face with
// no corners, crashed it (both found by fuzz_ply).
void few_corners(const PlyElement& e, u64 i, long long n, const std::string& path) {
  fail(path, "PLY " + e.name + " " + str(i) + " has " + std::to_string(n) + " corners (at least 3 needed)", "the file is corrupt");
}

void check_ply_corner(long long index, u64 vertices, const std::string& element, u64 i, const std::string& path) {
  if (index < 0 || static_cast<u64>(index) >= vertices)
    fail(path, "PLY " + element + " " + str(i) + " uses vertex " + std::to_string(index) + ", outside 0.." + std::to_string(static_cast<long long>(vertices) - 1),
         "the file is corrupt");
}

void walk_binary_ply(const PlyHeader& h, const std::string& bytes, const std::string& path) {
  const bool big = h.format == PlyFormat::kBinaryBig;
  const u64 vertices = ply_vertex_count(h);
  std::size_t pos = h.body;
  auto truncated = [&](const PlyElement& e, u64 i) {
    fail(path, "binary PLY body ends inside " + e.name + " " + str(i) + " of " + str(e.count) + " (file has " + str(bytes.size()) + " bytes)",
         "the file is truncated or a list length is corrupt");
  };
  for (const PlyElement& e : h.elements) {
    const bool has_list = std::any_of(e.props.begin(), e.props.end(), [](const PlyProperty& p) { return p.is_list; });
    if (!has_list) {
      u64 row = 0;
      for (const PlyProperty& p : e.props) row += static_cast<u64>(p.item->size);
      if (row * e.count > bytes.size() - pos) truncated(e, (bytes.size() - pos) / row);
      pos += static_cast<std::size_t>(row * e.count);
      continue;
    }
    for (u64 i = 0; i < e.count; ++i) {
      for (const PlyProperty& p : e.props) {
        if (!p.is_list) {
          if (static_cast<std::size_t>(p.item->size) > bytes.size() - pos) truncated(e, i);
          pos += static_cast<std::size_t>(p.item->size);
          continue;
        }
        if (static_cast<std::size_t>(p.count->size) > bytes.size() - pos) truncated(e, i);
        const long long n = read_ply_int(bytes, pos, *p.count, big);
        pos += static_cast<std::size_t>(p.count->size);
        if (n < 0) fail(path, "PLY " + e.name + " " + str(i) + " has a negative list length", "the file is corrupt");
        if (static_cast<u64>(n) > (bytes.size() - pos) / static_cast<u64>(p.item->size)) truncated(e, i);
        if (is_face_index_list(e.name, p.name) && n < 3) few_corners(e, i, n, path);
        if (is_face_index_list(e.name, p.name))
          for (long long j = 0; j < n; ++j)
            check_ply_corner(read_ply_int(bytes, pos + static_cast<std::size_t>(j * p.item->size), *p.item, big), vertices, e.name, i, path);
        pos += static_cast<std::size_t>(n) * static_cast<std::size_t>(p.item->size);
      }
    }
  }
}

// One value of an ASCII body: integers for integer types, finite numbers for float types.
bool ply_ascii_value_ok(std::string_view tok, const PlyType& t) {
  if (t.is_float) {
    double v = 0;
    return parse_finite(tok, v);
  }
  long long v = 0;
  if (!parse_integer(tok, v)) return false;
  const long long bits = 8 * t.size;
  if (!t.is_signed) return v >= 0 && (bits >= 63 || v < (1LL << bits));
  return v >= -(1LL << (bits - 1)) && v < (1LL << (bits - 1));
}

// vtkPLY reads one line per element; short, long or blank lines make it read past the end.
void walk_ascii_ply(const PlyHeader& h, const std::string& bytes, const std::string& path) {
  const u64 vertices = ply_vertex_count(h);
  Lines lines(bytes, h.body);
  std::string_view line;
  for (const PlyElement& e : h.elements) {
    for (u64 i = 0; i < e.count; ++i) {
      if (!lines.next(line))
        fail(path, "ASCII PLY ends after line " + str(h.body_line + lines.number()) + ", inside " + e.name + " " + str(i) + " of " + str(e.count),
             "the file is truncated or its header is corrupt");
      const std::string where = "line " + str(h.body_line + lines.number());
      if (line.size() > kMaxPlyLine) fail(path, where + " is longer than " + str(kMaxPlyLine) + " characters", "the file is corrupt");
      check_ply_text(line, where, path);
      // vtkPLY's line reader crashed on a last element line without its newline (fuzz_ply).
      if (!lines.terminated()) fail(path, where + " does not end with a newline", "the file is truncated");
      const std::vector<std::string_view> w = split_words(line);
      std::size_t k = 0;
      auto value = [&](const PlyType& t) {
        if (k >= w.size()) fail(path, where + " has too few values for " + e.name + " " + str(i), "the file is truncated or corrupt");
        if (!ply_ascii_value_ok(w[k], t)) fail(path, where + ": " + quoted(w[k]) + " is not a valid " + t.name, "the file is corrupt");
        return w[k++];
      };
      for (const PlyProperty& p : e.props) {
        if (!p.is_list) {
          value(*p.item);
          continue;
        }
        long long n = 0;
        parse_integer(value(*p.count), n);
        if (n < 0) fail(path, where + ": negative list length", "the file is corrupt");
        if (is_face_index_list(e.name, p.name) && n < 3) few_corners(e, i, n, path);
        for (long long j = 0; j < n; ++j) {
          long long corner = 0;
          const std::string_view tok = value(*p.item);
          if (is_face_index_list(e.name, p.name) && parse_integer(tok, corner)) check_ply_corner(corner, vertices, e.name, i, path);
        }
      }
      if (k != w.size())
        fail(path, where + " has " + str(w.size()) + " values but " + e.name + " " + str(i) + " needs " + str(k), "the file is corrupt (one element per line)");
    }
  }
}

// ---- STL -----------------------------------------------------------------------------------

// vtkSTLReader picks binary or ASCII with kwsys' DetectFileType: 5 % or more bytes outside
// printable ASCII among the first 256 make it binary (an empty file is read as binary).
bool vtk_reads_stl_as_binary(const std::string& bytes) {
  const std::size_t n = std::min<std::size_t>(bytes.size(), 256);
  if (n == 0) return true;
  std::size_t text = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(bytes[i]);
    if ((c >= 0x20 && c <= 0x7F) || c == '\n' || c == '\r' || c == '\t') ++text;
  }
  return static_cast<double>(n - text) / static_cast<double>(n) >= 0.05;
}

void check_binary_stl(const std::string& bytes, const std::string& path) {
  if (bytes.size() < 84)
    fail(path, "binary STL has " + str(bytes.size()) + " bytes, fewer than its 84-byte header", "the file is truncated or not an STL");
  u64 n = 0;
  for (int i = 3; i >= 0; --i) n = (n << 8) | static_cast<unsigned char>(bytes[80 + static_cast<std::size_t>(i)]);
  const u64 needed = 84 + 50 * n;
  if (bytes.size() != needed)
    fail(path, "binary STL header declares " + str(n) + " triangles (needs " + str(needed) + " bytes) but the file has " + str(bytes.size()) + " bytes",
         "the file is truncated or corrupt");
  if (n > g_max_vtk_faces)
    fail(path, "binary STL declares " + str(n) + " triangles, more than the " + str(g_max_vtk_faces) + " accepted", "the file is not a cortical surface");
}

// vtkSTLReader reads lines into a 255-byte buffer; only vertex lines feed the surface.
void check_ascii_stl(const std::string& bytes, const std::string& path) {
  Lines lines(bytes);
  std::string_view line;
  bool first = true;
  u64 vertices = 0;
  while (lines.next(line)) {
    const std::string where = "line " + str(lines.number());
    if (line.size() > 253) fail(path, where + " is longer than 253 characters", "the ASCII STL file is corrupt");
    const std::vector<std::string_view> w = split_words(line);
    if (w.empty()) continue;
    const std::string key = lower(w[0]);
    if (first && key != "solid") fail(path, "ASCII STL does not start with 'solid'", "the file is not an STL");
    first = false;
    if (key != "vertex") continue;
    double v = 0;
    if (w.size() != 4 || !parse_finite(w[1], v) || !parse_finite(w[2], v) || !parse_finite(w[3], v))
      fail(path, where + ": 'vertex' needs three finite numbers", "the ASCII STL file is corrupt");
    if (++vertices > 3 * g_max_vtk_faces)
      fail(path, "ASCII STL has more than " + str(g_max_vtk_faces) + " triangles", "the file is not a cortical surface");
  }
  if (first) fail(path, "ASCII STL is empty", "the file is not an STL");
}

// ---- OBJ -----------------------------------------------------------------------------------

struct ObjCounts {
  u64 v = 0, vt = 0, vn = 0;
};

// Drops an inline comment; VTK stops at it too.
std::string_view strip_obj_comment(std::string_view line) {
  const std::size_t hash = line.find('#');
  return hash == std::string_view::npos ? line : line.substr(0, hash);
}

void check_obj_numbers(const std::vector<std::string_view>& w, std::size_t line, const std::string& path) {
  const std::string where = "line " + str(line);
  const std::size_t n = w.size() - 1;
  const bool ok_count = w[0] == "v" ? (n == 3 || n == 4 || n == 6) : w[0] == "vn" ? n == 3 : (n >= 1 && n <= 3);
  if (!ok_count)
    fail(path, where + ": '" + std::string(w[0]) + "' has " + str(n) + " numbers" + (w[0] == "v" ? " (needs x y z, optionally w or r g b)" : ""),
         "the OBJ file is corrupt");
  for (std::size_t k = 1; k < w.size(); ++k) {
    double v = 0;
    if (!parse_finite(w[k], v))
      fail(path, where + ": " + quoted(w[k]) + " is not a finite number within +-1e30", "the OBJ file is corrupt");
  }
}

// One "v", "v/vt", "v//vn" or "v/vt/vn" group; `so_far` are the counts before this line.
void check_obj_group(std::string_view group, const ObjCounts& so_far, const ObjCounts& total, std::size_t line, const std::string& path) {
  const std::string where = "line " + str(line);
  const u64 so_far_of[3] = {so_far.v, so_far.vt, so_far.vn};
  const u64 total_of[3] = {total.v, total.vt, total.vn};
  const char* names[3] = {"vertex", "texture coordinate", "normal"};
  for (int part = 0; part < 3; ++part) {
    const std::size_t slash = group.find('/');
    const std::string_view tok = group.substr(0, slash);
    group = slash == std::string_view::npos ? std::string_view() : group.substr(slash + 1);
    if (tok.empty() && part > 0) {
      if (slash == std::string_view::npos)
        fail(path, where + ": corner ends with '/'", "use v, v/vt, v//vn or v/vt/vn");
      continue;
    }
    long long idx = 0;
    if (!parse_integer(tok, idx) || idx == 0)
      fail(path, where + ": " + quoted(tok) + " is not a valid " + names[part] + " index", "OBJ indices are non-zero integers");
    const bool ok = idx > 0 ? static_cast<u64>(idx) <= total_of[part] : static_cast<u64>(-(idx + 1)) < so_far_of[part];
    if (!ok)
      fail(path, where + ": " + names[part] + " index " + std::to_string(idx) + " is outside the " + str(idx > 0 ? total_of[part] : so_far_of[part]) + " declared",
           "the OBJ file is corrupt");
    if (slash == std::string_view::npos) break;
    if (part == 2) fail(path, where + ": malformed index group", "the OBJ file is corrupt");
  }
}

// Which parts of "v/vt/vn" a corner has, as bits (v = 1, vt = 2, vn = 4; 8 = trailing slash).
int obj_group_form(std::string_view group) {
  int form = 0;
  for (int part = 0; part < 3; ++part) {
    const std::size_t slash = group.find('/');
    if (!group.substr(0, slash).empty()) form |= 1 << part;
    if (slash == std::string_view::npos) return form;
    group = group.substr(slash + 1);
    if (group.empty()) return form | 8;
  }
  return form;
}

ObjCounts check_obj_vertices(const std::string& bytes, const std::string& path) {
  ObjCounts c;
  Lines lines(bytes);
  std::string_view line;
  while (lines.next(line)) {
    const std::vector<std::string_view> w = split_words(strip_obj_comment(line));
    if (w.empty() || (w[0] != "v" && w[0] != "vt" && w[0] != "vn")) continue;
    check_obj_numbers(w, lines.number(), path);
    u64& n = w[0] == "v" ? c.v : w[0] == "vt" ? c.vt : c.vn;
    if (++n > g_max_vtk_vertices)
      fail(path, "OBJ has more than " + str(g_max_vtk_vertices) + " '" + std::string(w[0]) + "' lines", "the file is not a cortical surface");
  }
  return c;
}

// ---- legacy VTK --------------------------------------------------------------------------

// Reads a legacy file the way vtkDataReader does: whitespace-separated keywords, binary data
// starting after the keyword line's newline.
class VtkCursor {
 public:
  VtkCursor(const std::string& bytes, const std::string& path, bool binary) : b_(bytes), path_(path), binary_(binary) {}
  std::size_t pos() const { return pos_; }
  void seek(std::size_t p) { pos_ = p; }
  bool at_end() {
    while (pos_ < b_.size() && is_blank(b_[pos_])) ++pos_;
    return pos_ >= b_.size();
  }
  std::string_view token(const char* what) {
    if (at_end()) fail(path_, "legacy VTK file ends where " + std::string(what) + " was expected", "the file is truncated");
    const std::size_t start = pos_;
    while (pos_ < b_.size() && !is_blank(b_[pos_])) ++pos_;
    if (pos_ - start > 255) fail(path_, "legacy VTK token longer than 255 characters where " + std::string(what) + " was expected", "the file is corrupt");
    return std::string_view(b_).substr(start, pos_ - start);
  }
  u64 count(const char* what, u64 cap) {
    const std::string_view tok = token(what);
    u64 n = 0;
    if (!parse_count(tok, n)) fail(path_, "legacy VTK " + std::string(what) + " " + quoted(tok) + " is not a non-negative integer", "the file is corrupt");
    if (n > cap) fail(path_, "legacy VTK declares " + str(n) + " " + what + ", more than the " + str(cap) + " accepted", "the header is corrupt");
    return n;
  }
  // The rest of a keyword line must be blank; binary data starts after its newline.
  void end_line(const char* keyword) {
    const std::size_t nl = b_.find('\n', pos_);
    const std::size_t end = nl == std::string::npos ? b_.size() : nl;
    for (std::size_t i = pos_; i < end; ++i)
      if (!is_blank(b_[i])) fail(path_, "legacy VTK " + std::string(keyword) + " line has extra text", "the file is corrupt");
    if (binary_ && nl == std::string::npos) fail(path_, "legacy VTK file ends after its " + std::string(keyword) + " line", "the file is truncated");
    if (binary_) pos_ = nl + 1;
  }
  // `n` values of `size` bytes (binary) or `n` numbers (ASCII); returns their bytes.
  std::string_view values(u64 n, int size, const char* what) {
    const std::size_t start = pos_;
    const u64 left = b_.size() - pos_;
    const u64 needed = binary_ ? n * static_cast<u64>(size) : (n > 0 ? 2 * n - 1 : 0);
    if (needed > left)
      fail(path_, "legacy VTK declares " + str(n) + " " + what + " values (needs " + std::string(binary_ ? "" : "at least ") + str(needed) + " bytes) but only " +
                      str(left) + " bytes follow",
           "the file is truncated or its header is corrupt");
    if (binary_) {
      pos_ += static_cast<std::size_t>(needed);
      return std::string_view(b_).substr(start, pos_ - start);
    }
    for (u64 i = 0; i < n; ++i) {
      const std::string_view tok = token(what);
      double v = 0;
      if (!parse_finite(tok, v)) fail(path_, "legacy VTK " + std::string(what) + " value " + str(i) + " " + quoted(tok) + " is not a finite number", "the file is corrupt");
    }
    at_end();
    return std::string_view(b_).substr(start, pos_ - start);
  }
  bool binary() const { return binary_; }
  const std::string& path() const { return path_; }

 private:
  const std::string& b_;
  const std::string& path_;
  bool binary_;
  std::size_t pos_ = 0;
};

// Integer `i` of a data block from VtkCursor::values (binary: big-endian).
class VtkInts {
 public:
  VtkInts(std::string_view data, int size, bool binary) : data_(data), size_(size), binary_(binary) {
    if (!binary) tokens_ = split_words(data);
  }
  bool get(u64 i, long long& out) const {
    if (!binary_) {
      double v = 0;
      if (!parse_number(tokens_[i], v) || v != std::floor(v) || std::fabs(v) > 9e15) return false;
      out = static_cast<long long>(v);
      return true;
    }
    u64 v = 0;
    for (int k = 0; k < size_; ++k) v = (v << 8) | static_cast<unsigned char>(data_[static_cast<std::size_t>(i) * static_cast<std::size_t>(size_) + static_cast<std::size_t>(k)]);
    out = size_ == 4 ? static_cast<long long>(static_cast<std::int32_t>(v)) : static_cast<long long>(v);
    return true;
  }

 private:
  std::string_view data_;
  int size_;
  bool binary_;
  std::vector<std::string_view> tokens_;
};

int vtk_type_size(const std::string& type) {
  static const std::pair<const char*, int> kSizes[] = {
      {"unsigned_char", 1}, {"char", 1},   {"signed_char", 1}, {"unsigned_short", 2}, {"short", 2},         {"unsigned_int", 4},
      {"int", 4},           {"float", 4},  {"vtktypeint32", 4}, {"vtktypeuint32", 4}, {"unsigned_long", 8}, {"long", 8},
      {"double", 8},        {"vtkidtype", 8}, {"vtktypeint64", 8}, {"vtktypeuint64", 8}};
  for (const auto& [name, size] : kSizes)
    if (type == name) return size;
  return 0;
}

// A METADATA block's body: text lines up to a blank line. Dropped (VTK would trust its sizes).
void skip_vtk_metadata_body(VtkCursor& c, const std::string& bytes) {
  std::size_t end = bytes.size();
  for (const char* blank : {"\n\n", "\n\r\n"}) {
    const std::size_t at = bytes.find(blank, c.pos());
    if (at != std::string::npos) end = std::min(end, at + std::strlen(blank));
  }
  c.seek(end);
}

// An optional METADATA block after a data array.
void skip_optional_vtk_metadata(VtkCursor& c, const std::string& bytes) {
  const std::size_t mark = c.pos();
  if (!c.at_end() && lower(c.token("METADATA")) == "metadata") skip_vtk_metadata_body(c, bytes);
  else c.seek(mark);
}

void skip_vtk_field(VtkCursor& c, const std::string& bytes) {
  c.token("FIELD name");
  const u64 arrays = c.count("FIELD arrays", 10000);
  for (u64 a = 0; a < arrays; ++a) {
    if (lower(c.token("FIELD array name")) == "null_array") continue;
    const u64 comps = c.count("FIELD array components", 10000);
    const u64 tuples = c.count("FIELD array tuples", g_max_vtk_faces);
    const std::string type = lower(c.token("FIELD array type"));
    const int size = type == "bit" ? 1 : vtk_type_size(type);
    if (size == 0) fail(c.path(), "legacy VTK FIELD array type '" + type + "' is not supported", "remove the field data");
    c.end_line("FIELD array");
    const u64 n = comps * tuples;
    c.values(type == "bit" && c.binary() ? (n + 7) / 8 : n, size, "FIELD array");
    skip_optional_vtk_metadata(c, bytes);
  }
}

// VERTICES, LINES, POLYGONS or TRIANGLE_STRIPS: every cell's points lie inside the block (VTK
// trusts the sizes and would read past it). Returns the section as VTK should see it.
std::string read_vtk_cells(VtkCursor& c, const std::string& keyword, bool new_format) {
  const u64 a = c.count(new_format ? "offsets" : "cells", g_max_vtk_faces + 1);
  const u64 b = c.count(new_format ? "connectivity entries" : "cell values", 4 * g_max_vtk_faces);
  c.end_line(keyword.c_str());
  std::string out = keyword + " " + str(a) + " " + str(b) + "\n";
  const std::string& path = c.path();
  if (!new_format) {
    const std::string_view data = c.values(b, 4, "cell");
    const VtkInts ints(data, 4, c.binary());
    u64 at = 0;
    for (u64 cell = 0; cell < a; ++cell) {
      long long n = 0;
      if (at >= b || !ints.get(at, n) || n < 0 || static_cast<u64>(n) >= b - at)
        fail(path, "legacy VTK " + keyword + " cell " + str(cell) + " does not fit in the declared " + str(b) + " values", "the file is corrupt");
      at += 1 + static_cast<u64>(n);
    }
    if (at != b) fail(path, "legacy VTK " + keyword + " declares " + str(b) + " values but its cells use " + str(at), "the file is corrupt");
    return out + std::string(data) + "\n";
  }
  if (a == 0) fail(path, "legacy VTK " + keyword + " declares no offsets", "the file is corrupt");
  std::string_view blocks[2];
  int sizes[2] = {0, 0};
  const char* names[2] = {"OFFSETS", "CONNECTIVITY"};
  for (int k = 0; k < 2; ++k) {
    if (lower(c.token(names[k])) != lower(names[k])) fail(path, "legacy VTK " + keyword + " lacks its " + names[k] + " block", "the file is corrupt");
    const std::string type = lower(c.token("offsets type"));
    sizes[k] = type == "vtktypeint64" ? 8 : type == "vtktypeint32" ? 4 : 0;
    if (sizes[k] == 0) fail(path, "legacy VTK " + std::string(names[k]) + " type '" + type + "' is not supported", "use vtktypeint64 or vtktypeint32");
    c.end_line(names[k]);
    blocks[k] = c.values(k == 0 ? a : b, sizes[k], names[k]);
    out += std::string(names[k]) + " " + type + "\n" + std::string(blocks[k]) + "\n";
  }
  const VtkInts offsets(blocks[0], sizes[0], c.binary());
  long long prev = 0;
  for (u64 i = 0; i < a; ++i) {
    long long o = 0;
    const bool ok = offsets.get(i, o) && (i == 0 ? o == 0 : o >= prev) && static_cast<u64>(o) <= b;
    if (!ok) fail(path, "legacy VTK " + keyword + " offset " + str(i) + " is out of order or beyond the " + str(b) + " connectivity entries", "the file is corrupt");
    prev = o;
  }
  if (static_cast<u64>(prev) != b) fail(path, "legacy VTK " + keyword + " offsets end at " + str(static_cast<u64>(prev)) + ", not " + str(b), "the file is corrupt");
  return out;
}

}  // namespace

void check_ply(const std::string& bytes, const std::string& path) {
  const PlyHeader h = parse_ply_header(bytes, path);
  check_ply_elements(h, path);
  const u64 body = bytes.size() - h.body;
  const u64 needed = minimal_ply_body(h);
  if (body < needed)
    fail(path, std::string(h.format == PlyFormat::kAscii ? "ASCII" : "binary") + " PLY header " + ply_counts_phrase(h) + " (needs at least " + str(needed) +
                   " bytes) but the file has " + str(body) + " bytes after its header",
         "the file is truncated or its header is corrupt");
  check_ply_caps(h, path);
  if (h.format == PlyFormat::kAscii) walk_ascii_ply(h, bytes, path);
  else walk_binary_ply(h, bytes, path);
}

void check_stl(const std::string& bytes, const std::string& path) {
  if (vtk_reads_stl_as_binary(bytes)) check_binary_stl(bytes, path);
  else check_ascii_stl(bytes, path);
}

void check_obj(const std::string& bytes, const std::string& path) {
  const ObjCounts total = check_obj_vertices(bytes, path);
  ObjCounts so_far;
  u64 triangles = 0;
  Lines lines(bytes);
  std::string_view line;
  while (lines.next(line)) {
    const std::vector<std::string_view> w = split_words(strip_obj_comment(line));
    if (w.empty()) continue;
    if (w[0] == "v" || w[0] == "vt" || w[0] == "vn") {
      ++(w[0] == "v" ? so_far.v : w[0] == "vt" ? so_far.vt : so_far.vn);
      continue;
    }
    if (w[0] != "f" && w[0] != "l" && w[0] != "p") continue;
    const std::size_t min_groups = w[0] == "f" ? 3 : w[0] == "l" ? 2 : 1;
    if (w.size() - 1 < min_groups)
      fail(path, "line " + str(lines.number()) + ": '" + std::string(w[0]) + "' needs at least " + str(min_groups) + " vertex indices", "the OBJ file is corrupt");
    for (std::size_t k = 1; k < w.size(); ++k) {
      check_obj_group(w[k], so_far, total, lines.number(), path);
      // vtkOBJReader takes the first corner's form for the whole line: a corner with another
      // form ("f 1 3/ 2", found by fuzz_obj) made it dereference a missing texture array.
      if (obj_group_form(w[k]) != obj_group_form(w[1]))
        fail(path, "line " + str(lines.number()) + ": corners mix the forms v, v/vt, v//vn and v/vt/vn", "the OBJ file is corrupt");
    }
    if (w[0] == "f" && (triangles += w.size() - 3) > g_max_vtk_faces)
      fail(path, "OBJ has more than " + str(g_max_vtk_faces) + " triangles", "the file is not a cortical surface");
  }
}

std::string obj_geometry_only(const std::string& bytes) {
  std::string out;
  out.reserve(bytes.size() / 2);
  Lines lines(bytes);
  std::string_view line;
  while (lines.next(line)) {
    const std::vector<std::string_view> w = split_words(strip_obj_comment(line));
    if (w.empty() || (w[0] != "v" && w[0] != "f")) continue;
    out += w[0];
    for (std::size_t k = 1; k < w.size(); ++k) {
      out += ' ';
      out += w[0] == "f" ? w[k].substr(0, w[k].find('/')) : w[k];  // a corner's vertex index only
    }
    out += '\n';
  }
  return out;
}

namespace {

// The value of attribute `name` in an XML start tag, or false when absent; the value must be
// one non-negative integer.
bool xml_count(std::string_view tag, const char* name, u64& out, const std::string& path) {
  const std::string key = std::string(" ") + name + "=\"";
  const std::size_t k = tag.find(key);
  if (k == std::string_view::npos) return false;
  const std::size_t start = k + key.size();
  const std::string_view value = tag.substr(start, tag.find('"', start) - start);
  const std::vector<std::string_view> words = split_words(value);
  if (words.size() != 1 || !parse_count(words[0], out))
    fail(path, "VTK XML PolyData " + std::string(name) + "=" + quoted(value) + " is not a non-negative integer", "the file is corrupt");
  return true;
}

struct VtpLayout {
  bool big_endian = false;
  int header_size = 4;  // UInt32 or UInt64 block-header words
  bool compressed = false;
};

u64 header_word(const unsigned char* p, const VtpLayout& layout) {
  u64 v = 0;
  for (int i = 0; i < layout.header_size; ++i) v = (v << 8) | p[layout.big_endian ? i : layout.header_size - 1 - i];
  return v;
}

// The block header in front of one array's data (raw bytes or base64 text). VTK sizes its
// buffers from it before reading: a corrupt block count allocated 14 GB (found by fuzz_vtk).
void check_vtp_block_header(std::string_view data, bool base64, const VtpLayout& layout, const std::string& path) {
  unsigned char head[24] = {};
  const std::size_t words = layout.compressed ? 3 : 1;
  const std::size_t want = words * static_cast<std::size_t>(layout.header_size);
  const std::size_t got = base64 ? base64_prefix(data, head, want) : std::min(data.size(), want);
  if (!base64) std::memcpy(head, data.data(), got);
  if (got < want) fail(path, "VTK XML PolyData array data ends inside its block header", "the file is truncated or corrupt");
  const u64 first = header_word(head, layout);
  // Raw bytes or base64 text still available after the header, in bytes.
  const u64 left = base64 ? (data.size() * 3) / 4 : data.size() - want;
  const u64 max_bytes = g_max_decompressed_bytes;
  if (!layout.compressed) {
    if (first > left) fail(path, "VTK XML PolyData array declares " + str(first) + " bytes but " + str(left) + " follow", "the file is truncated or corrupt");
    return;
  }
  const u64 block = header_word(head + layout.header_size, layout);
  const u64 last = header_word(head + 2 * layout.header_size, layout);
  const bool too_big = block > max_bytes || last > max_bytes || (first > 0 && block > 0 && first > max_bytes / block);
  if (first > left / static_cast<u64>(layout.header_size) || too_big || last > block)
    fail(path, "VTK XML PolyData compressed array declares " + str(first) + " blocks of " + str(block) + " bytes in " + str(data.size()) + " bytes of data",
         "the file is truncated or corrupt");
  // The header goes on with each block's compressed size; VTK allocates each before reading it
  // (a declared 2.9 GB block in a 2 kB file, found by fuzz_vtk). Their sum must fit the data.
  const std::size_t full = (3 + static_cast<std::size_t>(first)) * static_cast<std::size_t>(layout.header_size);
  std::vector<unsigned char> sizes(full);
  const std::size_t got_all = base64 ? base64_prefix(data, sizes.data(), full) : std::min(data.size(), full);
  if (!base64) std::memcpy(sizes.data(), data.data(), got_all);
  if (got_all < full) fail(path, "VTK XML PolyData compressed array data ends inside its block header", "the file is truncated or corrupt");
  u64 compressed_total = 0;
  for (u64 i = 0; i < first; ++i) {
    const u64 size = header_word(sizes.data() + (3 + i) * static_cast<u64>(layout.header_size), layout);
    if (size > left - compressed_total)
      fail(path, "VTK XML PolyData compressed block " + str(i + 1) + " of " + str(first) + " declares " + str(size) + " bytes but " +
                     str(left - compressed_total) + " follow", "the file is truncated or corrupt");
    compressed_total += size;
  }
}

std::string_view xml_attribute(std::string_view tag, const char* name) {
  const std::string key = std::string(" ") + name + "=\"";
  const std::size_t k = tag.find(key);
  if (k == std::string_view::npos) return {};
  const std::size_t start = k + key.size();
  return tag.substr(start, tag.find('"', start) - start);
}

void check_vtp_data_blocks(const std::string& bytes, std::string_view xml, std::size_t file_tag, const std::string& path) {
  const std::string_view file = xml.substr(file_tag, xml.find('>', file_tag) - file_tag);
  VtpLayout layout;
  layout.big_endian = xml_attribute(file, "byte_order") == "BigEndian";
  layout.header_size = xml_attribute(file, "header_type") == "UInt64" ? 8 : 4;
  layout.compressed = !xml_attribute(file, "compressor").empty();
  // Appended data start just after the '_' following <AppendedData ...>.
  const std::size_t appended_tag = bytes.find("<AppendedData");
  std::string_view appended;
  bool appended_base64 = true;
  if (appended_tag != std::string::npos) {
    const std::string_view tag = std::string_view(bytes).substr(appended_tag, bytes.find('>', appended_tag) - appended_tag);
    appended_base64 = xml_attribute(tag, "encoding") != "raw";
    const std::size_t underscore = bytes.find('_', appended_tag + tag.size());
    if (underscore != std::string::npos) appended = std::string_view(bytes).substr(underscore + 1);
  }
  for (std::size_t at = xml.find("<DataArray"); at != std::string_view::npos; at = xml.find("<DataArray", at + 1)) {
    const std::size_t close = xml.find('>', at);
    const std::string_view tag = xml.substr(at, close - at);
    const std::string_view format = xml_attribute(tag, "format");
    if (format == "appended") {
      u64 offset = 0;
      if (!xml_count(tag, "offset", offset, path) || offset > appended.size())
        fail(path, "VTK XML PolyData appended array offset is missing or beyond the data", "the file is corrupt");
      check_vtp_block_header(appended.substr(static_cast<std::size_t>(offset)), appended_base64, layout, path);
    } else if (format == "binary" && close != std::string_view::npos && (close == 0 || xml[close - 1] != '/')) {
      std::string_view text = xml.substr(close + 1);
      while (!text.empty() && is_blank(text[0])) text.remove_prefix(1);
      check_vtp_block_header(text.substr(0, text.find('<')), true, layout, path);
    }
  }
}

}  // namespace

void check_vtp(const std::string& bytes, const std::string& path) {
  // Only the XML part: appended raw data may contain anything.
  const std::size_t xml_end = std::min(bytes.find("<AppendedData"), bytes.size());
  const std::string_view xml = std::string_view(bytes).substr(0, xml_end);
  const std::size_t file_tag = xml.find("<VTKFile");
  const std::size_t file_tag_end = xml.find('>', file_tag);
  const bool compressed = file_tag != std::string_view::npos && xml.substr(file_tag, file_tag_end - file_tag).find("compressor=") != std::string_view::npos;
  auto tag_at = [&](std::size_t at) { return xml.substr(at, xml.find('>', at) - at); };
  u64 points = 0, cells = 0;
  for (std::size_t at = xml.find("<Piece"); at != std::string_view::npos; at = xml.find("<Piece", at + 1)) {
    for (const char* attr : {"NumberOfPoints", "NumberOfVerts", "NumberOfLines", "NumberOfStrips", "NumberOfPolys"}) {
      u64 n = 0;
      if (xml_count(tag_at(at), attr, n, path)) (std::strcmp(attr, "NumberOfPoints") == 0 ? points : cells) += n;
      if (points > g_max_vtk_vertices || cells > g_max_vtk_faces)
        fail(path, "VTK XML PolyData declares " + str(points > g_max_vtk_vertices ? points : cells) + (points > g_max_vtk_vertices ? " points" : " cells") +
                       ", more than the " + str(points > g_max_vtk_vertices ? g_max_vtk_vertices : g_max_vtk_faces) + " accepted",
             "the file is corrupt (cortical surfaces have fewer than 1000000 vertices)");
    }
  }
  // Uncompressed, every coordinate and every cell takes at least one byte.
  if (!compressed && (3 * points > bytes.size() || cells > bytes.size()))
    fail(path, "VTK XML PolyData declares " + str(points) + " points and " + str(cells) + " cells but the file has only " + str(bytes.size()) + " bytes",
         "the file is truncated or its header is corrupt");
  // VTK allocates tuples x components for every array before reading it (a huge
  // NumberOfComponents hung the reader, found by fuzz_vtk).
  for (std::size_t at = xml.find("<DataArray"); at != std::string_view::npos; at = xml.find("<DataArray", at + 1)) {
    u64 comps = 1, tuples = 0;
    if (xml_count(tag_at(at), "NumberOfComponents", comps, path) && (comps == 0 || comps > 16))
      fail(path, "VTK XML PolyData array has " + str(comps) + " components (1 to 16 accepted)", "the file is corrupt");
    if (xml_count(tag_at(at), "NumberOfTuples", tuples, path) && (tuples > g_max_vtk_faces || (!compressed && tuples > bytes.size())))
      fail(path, "VTK XML PolyData array declares " + str(tuples) + " tuples in a file of " + str(bytes.size()) + " bytes", "the file is corrupt");
  }
  if (file_tag != std::string_view::npos) check_vtp_data_blocks(bytes, xml, file_tag, path);
  // Points other than 3-vectors make VTK give up half-way and leak (found by fuzz_vtk).
  for (std::size_t at = xml.find("<Points"); at != std::string_view::npos; at = xml.find("<Points", at + 1)) {
    if (at + 7 >= xml.size() || (xml[at + 7] != '>' && !is_blank(xml[at + 7]))) continue;  // <PointData
    const std::size_t array = xml.find("<DataArray", at);
    u64 comps = 1;
    if (array == std::string_view::npos || !xml_count(tag_at(array), "NumberOfComponents", comps, path) || comps != 3)
      fail(path, "VTK XML PolyData Points array does not declare NumberOfComponents=\"3\"", "the file is corrupt");
  }
}

std::string sanitize_legacy_vtk(const std::string& bytes, const std::string& path) {
  Lines lines(bytes);
  std::string_view version_line, title;
  const std::string magic = "# vtk DataFile Version";
  if (!lines.next(version_line) || version_line.substr(0, magic.size()) != magic)
    fail(path, "does not start with '# vtk DataFile Version'", "the file is not a legacy VTK file");
  long long major = 0;
  const std::vector<std::string_view> vw = split_words(version_line.substr(magic.size()));
  if (vw.empty() || !parse_integer(vw[0].substr(0, vw[0].find('.')), major) || major < 1 || major > 5)
    fail(path, "legacy VTK version line " + quoted(version_line) + " is not readable", "the file is corrupt");
  if (!lines.next(title) || title.size() > 250 || version_line.size() > 250)
    fail(path, "legacy VTK header lines are missing or longer than 250 characters", "the file is corrupt");
  const bool new_format = major >= 5;
  std::size_t mark = lines.pos();
  VtkCursor probe(bytes, path, false);
  probe.seek(mark);
  const std::string mode = lower(probe.token("ASCII or BINARY"));
  if (mode != "ascii" && mode != "binary") fail(path, "legacy VTK file is neither ASCII nor BINARY", "the file is corrupt");
  VtkCursor c(bytes, path, mode == "binary");
  c.seek(probe.pos());
  std::string key = lower(c.token("DATASET"));
  while (key == "field") {
    skip_vtk_field(c, bytes);
    key = lower(c.token("DATASET"));
  }
  if (key != "dataset") fail(path, "legacy VTK file has no DATASET line", "the file is corrupt");
  if (lower(c.token("dataset type")) != "polydata")
    fail(path, "legacy VTK file does not hold POLYDATA (e.g. an unstructured grid)", "convert it to a polygonal surface");

  std::string out = std::string(new_format ? "# vtk DataFile Version 5.1" : "# vtk DataFile Version 3.0") + "\nsanitized " + std::string(title) + "\n" +
                    (c.binary() ? "BINARY" : "ASCII") + "\nDATASET POLYDATA\n";
  bool have_points = false;
  while (!c.at_end()) {
    const std::string k = lower(c.token("a section keyword"));
    if (k == "point_data" || k == "cell_data") break;  // attributes are not used
    if (k == "field") {
      skip_vtk_field(c, bytes);
    } else if (k == "metadata") {
      skip_vtk_metadata_body(c, bytes);
    } else if (k == "points") {
      if (have_points) fail(path, "legacy VTK file has two POINTS sections", "the file is corrupt");
      const u64 n = c.count("points", g_max_vtk_vertices);
      const std::string type = lower(c.token("points type"));
      if (type != "float" && type != "double") fail(path, "legacy VTK POINTS type '" + type + "' is not supported", "use float or double coordinates");
      c.end_line("POINTS");
      out += "POINTS " + str(n) + " " + type + "\n" + std::string(c.values(3 * n, type == "float" ? 4 : 8, "POINTS")) + "\n";
      have_points = true;
    } else if (k == "vertices" || k == "lines" || k == "polygons" || k == "triangle_strips") {
      std::string upper = k;
      for (char& ch : upper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
      const std::string section = read_vtk_cells(c, upper, new_format);
      if (k == "polygons" || k == "triangle_strips") out += section;  // vertices and lines are not used
    } else {
      fail(path, "unknown legacy VTK keyword " + quoted(k), "the file is corrupt or not a POLYDATA legacy VTK file");
    }
  }
  if (!have_points) fail(path, "legacy VTK file has no POINTS", "the file is not a surface");
  return out;
}

}  // namespace authalic::io::detail

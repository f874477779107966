// FreeSurfer annotation files (see io/freesurfer_annot.h).
#include "io/freesurfer_annot.h"

#include <map>

#include "io/atomic_file.h"
#include "io/io_internal.h"

namespace authalic::io {

namespace {

using detail::BigEndianReader;
using detail::BigEndianWriter;

constexpr int kMaxEntries = 100000;
constexpr int kMaxName = 4096;

std::string read_string(BigEndianReader& in, const char* what) {
  const std::int32_t len = in.i32(what);
  if (len < 0 || len > kMaxName) in.fail(std::string(what) + " has length " + std::to_string(len), "the file is corrupt");
  in.need(static_cast<std::size_t>(len), what);
  std::string s;
  for (std::int32_t i = 0; i < len; ++i) s += static_cast<char>(in.u8(what));
  return s.substr(0, s.find('\0'));  // stored with its terminating NUL
}

int packed_rgb(const std::array<int, 4>& c) { return c[0] + 256 * c[1] + 65536 * c[2]; }

// The colour table after the tag: new (version < 0) or old layout.
void read_colour_table(BigEndianReader& in, Annotation& a) {
  const std::int32_t first = in.i32("colour table size");
  const bool new_format = first < 0;
  if (new_format && first != -2) in.fail("colour table version " + std::to_string(first) + " is unknown", "expected -2");
  if (new_format) in.i32("maximum structure index");
  if (!new_format && (first == 0 || first > kMaxEntries)) in.fail("colour table of " + std::to_string(first) + " entries", "the file is corrupt");
  read_string(in, "colour table file name");
  const std::int32_t entries = new_format ? in.i32("colour table entries") : first;
  if (entries <= 0 || entries > kMaxEntries) in.fail("colour table of " + std::to_string(entries) + " entries", "the file is corrupt");
  std::map<int, int> index_of;  // structure index -> position
  for (int e = 0; e < entries; ++e) {
    const int index = new_format ? in.i32("structure index") : e;
    std::string name = read_string(in, "structure name");
    std::array<int, 4> c{};
    for (int k = 0; k < 4; ++k) c[k] = in.i32("colour");
    if (index_of.count(index)) in.fail("structure index " + std::to_string(index) + " appears twice", "the file is corrupt");
    index_of[index] = e;
    a.names.push_back(std::move(name));
    a.colours.push_back(c);
  }
}

}  // namespace

Annotation read_freesurfer_annotation(const std::string& path, int num_vertices) {
  const std::string bytes = detail::read_file(path);
  BigEndianReader in(bytes, path, "FreeSurfer annotation");
  const std::int32_t n = in.i32("vertex count");
  if (n <= 0 || static_cast<long long>(n) * 8 > static_cast<long long>(in.remaining()))
    in.fail("vertex count " + std::to_string(n) + " does not fit the file's " + std::to_string(bytes.size()) + " bytes",
            "give a FreeSurfer .annot file (e.g. label/lh.aparc.annot)");
  if (num_vertices >= 0 && n != num_vertices)
    in.fail("has " + std::to_string(n) + " vertices but the surface has " + std::to_string(num_vertices),
            "give the annotation of the same subject and hemisphere as the surface");
  std::vector<int> values(static_cast<std::size_t>(n), 0);
  for (std::int32_t i = 0; i < n; ++i) {
    const std::int32_t v = in.i32("vertex number");
    const std::int32_t value = in.i32("vertex value");
    if (v < 0 || v >= n) in.fail("vertex number " + std::to_string(v) + " is out of range [0, " + std::to_string(n) + ")", "the file is corrupt");
    values[static_cast<std::size_t>(v)] = value;
  }
  Annotation a;
  if (in.remaining() < 4 || in.i32("colour table tag") != 1)
    in.fail("has no colour table", "the labels cannot be named; give an annotation written by FreeSurfer or nibabel");
  read_colour_table(in, a);
  std::map<int, int> by_value;
  for (std::size_t e = 0; e < a.colours.size(); ++e) by_value.emplace(packed_rgb(a.colours[e]), static_cast<int>(e));
  a.label.resize(n);
  for (std::int32_t i = 0; i < n; ++i) {
    const auto it = by_value.find(values[static_cast<std::size_t>(i)]);
    a.label(i) = it == by_value.end() ? -1 : it->second;
  }
  return a;
}

void write_freesurfer_annotation(const std::string& path, const Annotation& a) {
  if (a.names.size() != a.colours.size() || a.names.empty())
    throw std::invalid_argument("write_freesurfer_annotation: " + std::to_string(a.names.size()) + " names for " +
                                std::to_string(a.colours.size()) + " colours");
  BigEndianWriter out;
  out.i32(static_cast<std::int32_t>(a.label.size()));
  for (Eigen::Index v = 0; v < a.label.size(); ++v) {
    const int l = a.label(v);
    if (l >= static_cast<int>(a.names.size())) throw std::invalid_argument("write_freesurfer_annotation: label out of range");
    out.i32(static_cast<std::int32_t>(v));
    out.i32(l < 0 ? 0 : packed_rgb(a.colours[static_cast<std::size_t>(l)]));
  }
  auto string = [&](const std::string& s) {
    out.i32(static_cast<std::int32_t>(s.size() + 1));
    out.bytes(s);
    out.u8(0);
  };
  out.i32(1);
  out.i32(-2);
  out.i32(static_cast<std::int32_t>(a.names.size()));
  string("NOFILE");
  out.i32(static_cast<std::int32_t>(a.names.size()));
  for (std::size_t e = 0; e < a.names.size(); ++e) {
    out.i32(static_cast<std::int32_t>(e));
    string(a.names[e]);
    for (int k = 0; k < 4; ++k) out.i32(a.colours[e][k]);
  }
  write_file_atomically(path, out.out);
}

}  // namespace authalic::io

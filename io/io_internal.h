#pragma once
// Internal helpers shared by the io/ readers and writers (not part of the public API): whole-file
// reads, gzip, bounds-checked big-endian decoding, and error messages that always name the file.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"

namespace authalic::io::detail {

// Largest decompressed size accepted from one gzip stream. Protects against gzip bombs and lets
// the fuzz targets run under libFuzzer's memory limit (they lower it).
extern std::size_t g_max_decompressed_bytes;

// "<path>: <problem>; <hint>" as an InputError.
[[noreturn]] void fail(const std::string& path, const std::string& problem, const std::string& hint);

// Whole file into memory. Missing/unreadable files are an InputError naming the path.
std::string read_file(const std::string& path);
// InputError naming the path unless it is an existing, readable regular file.
void require_readable(const std::string& path);
// Same, transparently gunzipping when the content starts with the gzip magic (1f 8b).
std::string read_file_maybe_gz(const std::string& path);

bool is_gzip(const std::string& bytes);
// Inflates a gzip stream (several concatenated members allowed). Corrupt or oversized input is an
// InputError naming `path`.
std::string gunzip(const std::string& bytes, const std::string& path);
std::string gzip(const std::string& bytes, int level = 6);

// Lower-case file name (no folder) and suffix tests on it.
std::string lower_filename(const std::string& path);
bool ends_with(const std::string& s, const std::string& suffix);

// Bounds-checked big-endian reader over a byte buffer (FreeSurfer and MGH files are big-endian).
class BigEndianReader {
 public:
  BigEndianReader(const std::string& bytes, const std::string& path, std::string format)
      : bytes_(bytes), path_(path), format_(std::move(format)) {}
  std::size_t pos() const { return pos_; }
  std::size_t size() const { return bytes_.size(); }
  std::size_t remaining() const { return bytes_.size() - pos_; }
  void seek(std::size_t p) { pos_ = p; }
  // Throws "truncated" naming what was being read, unless n more bytes are available.
  void need(std::size_t n, const char* what) const;
  std::uint8_t u8(const char* what) {
    need(1, what);
    return static_cast<std::uint8_t>(bytes_[pos_++]);
  }
  std::uint32_t u24(const char* what) {
    need(3, what);
    const auto* p = reinterpret_cast<const unsigned char*>(bytes_.data() + pos_);
    pos_ += 3;
    return (std::uint32_t(p[0]) << 16) | (std::uint32_t(p[1]) << 8) | p[2];
  }
  std::uint32_t u32(const char* what) {
    need(4, what);
    const auto* p = reinterpret_cast<const unsigned char*>(bytes_.data() + pos_);
    pos_ += 4;
    return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
  }
  std::int32_t i32(const char* what) { return static_cast<std::int32_t>(u32(what)); }
  std::int16_t i16(const char* what) {
    need(2, what);
    const auto* p = reinterpret_cast<const unsigned char*>(bytes_.data() + pos_);
    pos_ += 2;
    return static_cast<std::int16_t>((std::uint16_t(p[0]) << 8) | p[1]);
  }
  float f32(const char* what) {
    const std::uint32_t u = u32(what);
    float f;
    std::memcpy(&f, &u, 4);
    return f;
  }
  // Bytes up to (not including) the next '\n' (consumed), or to the end of the buffer.
  std::string line(std::size_t max_length, const char* what);
  [[noreturn]] void fail(const std::string& problem, const std::string& hint) const;
  const std::string& path() const { return path_; }
  const std::string& format() const { return format_; }

 private:
  const std::string& bytes_;
  const std::string& path_;
  std::string format_;
  std::size_t pos_ = 0;
};

// Big-endian encoding for the writers.
class BigEndianWriter {
 public:
  void u8(std::uint8_t v) { out.push_back(static_cast<char>(v)); }
  void u24(std::uint32_t v) {
    u8(static_cast<std::uint8_t>(v >> 16));
    u8(static_cast<std::uint8_t>(v >> 8));
    u8(static_cast<std::uint8_t>(v));
  }
  void u32(std::uint32_t v) {
    u8(static_cast<std::uint8_t>(v >> 24));
    u24(v & 0xFFFFFFu);
  }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void i16(std::int16_t v) {
    const auto u = static_cast<std::uint16_t>(v);
    u8(static_cast<std::uint8_t>(u >> 8));
    u8(static_cast<std::uint8_t>(u));
  }
  void f32(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    u32(u);
  }
  void bytes(const std::string& s) { out += s; }
  std::string out;
};

// A private temporary file in the system temp folder (name ends with `suffix`), removed when
// the object goes out of scope. Used to hand decompressed data to file-only C libraries.
// A T stored at byte `at` of `bytes` (the caller checked the size), byte-swapped when `swap`:
// header fields of either endianness (NIfTI, MGH).
template <class T>
T field_at(const std::string& bytes, std::size_t at, bool swap) {
  T v;
  std::memcpy(&v, bytes.data() + at, sizeof(T));
  if (swap) {
    auto* b = reinterpret_cast<unsigned char*>(&v);
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  }
  return v;
}

// A NIfTI-1 (sizeof_hdr 348) or NIfTI-2 (540) header at the start of `bytes`, in the byte order
// its sizeof_hdr reads in, with the fields the raw checks need (offsets of the two versions).
struct NiftiHeaderView {
  const std::string& bytes;
  bool v2 = false;
  bool swap = false;
  int sizeof_hdr() const { return v2 ? 540 : 348; }
  long long dim(int i) const { return v2 ? field_at<std::int64_t>(bytes, 16 + 8 * i, swap) : field_at<std::int16_t>(bytes, 40 + 2 * i, swap); }
  int datatype() const { return v2 ? field_at<std::int16_t>(bytes, 12, swap) : field_at<std::int16_t>(bytes, 70, swap); }
  int bitpix() const { return v2 ? field_at<std::int16_t>(bytes, 14, swap) : field_at<std::int16_t>(bytes, 72, swap); }
  // A float field of NIfTI-1 at at1, double of NIfTI-2 at at2.
  double real(std::size_t at1, std::size_t at2) const {
    return v2 ? field_at<double>(bytes, at2, swap) : static_cast<double>(field_at<float>(bytes, at1, swap));
  }
  long double vox_offset() const {  // NIfTI-2: int64
    return v2 ? static_cast<long double>(field_at<std::int64_t>(bytes, 168, swap)) : field_at<float>(bytes, 108, swap);
  }
};
// The header view, or false when `bytes` does not start with a whole NIfTI-1/2 header.
bool nifti_header_view(const std::string& bytes, NiftiHeaderView* view);

// While alive, `path` is unlinked if the process gets SIGTERM, SIGINT or SIGHUP (the signal then
// ends the process as before): temporary files and half-written outputs do not outlive a killed
// run. At most 32 at once; beyond that a file is simply not covered.
// kind: a file (unlinked), a folder of files (its entries unlinked, then the folder removed) or a
// folder removed only when empty (an output folder the run made); files go first, then folders
// of files, then empty folders.
enum class SignalRemoval { File, FolderOfFiles, FolderIfEmpty };
class RemoveOnSignal {
 public:
  explicit RemoveOnSignal(const std::string& path, SignalRemoval kind = SignalRemoval::File);
  ~RemoveOnSignal();
  RemoveOnSignal(const RemoveOnSignal&) = delete;
  RemoveOnSignal& operator=(const RemoveOnSignal&) = delete;

 private:
  int slot_ = -1;
};

// mkstemps(pattern, suffix_len) with SIGTERM/SIGINT/SIGHUP blocked until the new file is
// registered in *remove: a signal cannot land between creating the file and covering it.
// Returns the descriptor (< 0 with errno set on failure, *remove left empty).
int mkstemps_removed_on_signal(std::vector<char>& pattern, int suffix_len, std::unique_ptr<RemoveOnSignal>* remove);

class TempFile {
 public:
  explicit TempFile(const std::string& suffix);
  ~TempFile();
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }
  // Writes the bytes (errors, e.g. a full temp folder, are std::runtime_error naming the folder).
  void write(const std::string& bytes) const;

 private:
  std::string path_;
  std::unique_ptr<RemoveOnSignal> on_signal_;
};

// Quick number formatting for messages.
std::string fmt_size(std::size_t bytes);

}  // namespace authalic::io::detail

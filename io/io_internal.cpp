#include "io/io_internal.h"

#include <fcntl.h>
#include <sys/syscall.h>
#include <unistd.h>
#include <zlib.h>

#include <signal.h>

#include <algorithm>
#include <csignal>
#include <memory>
#include <mutex>
#include <cstdint>
#include <new>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <cctype>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>
#include <vector>

namespace authalic::io::detail {

std::size_t g_max_decompressed_bytes = std::size_t(8) << 30;  // 8 GiB

void fail(const std::string& path, const std::string& problem, const std::string& hint) {
  throw InputError(path + ": " + problem + "; " + hint);
}

std::string read_file(const std::string& path) {
  require_readable(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot open (") + std::strerror(errno) + ")", "check the permissions");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) fail(path, "read error", "check the file system");
  return std::move(ss).str();
}

void require_readable(const std::string& path) {
  std::error_code ec;
  const std::filesystem::file_status st = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(st)) fail(path, "file not found", "check the path");
  if (std::filesystem::is_directory(st)) fail(path, "is a directory, expected a file", "check the path");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot open (") + std::strerror(errno) + ")", "check the permissions");
}

bool is_gzip(const std::string& bytes) {
  return bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0x1f && static_cast<unsigned char>(bytes[1]) == 0x8b;
}

std::string read_file_maybe_gz(const std::string& path) {
  std::string bytes = read_file(path);
  if (is_gzip(bytes)) return gunzip(bytes, path);
  return bytes;
}

bool nifti_header_view(const std::string& bytes, NiftiHeaderView* view) {
  if (bytes.size() < 348) return false;
  for (const bool swap : {false, true}) {
    const auto size = field_at<std::int32_t>(bytes, 0, swap);
    if (size == 348 || (size == 540 && bytes.size() >= 540)) {
      view->v2 = size == 540;
      view->swap = swap;
      return true;
    }
  }
  return false;
}

namespace {


// The bytes a NIfTI-1/2 or MGH image declares (header, voxels, a margin for extensions and
// tags), from its first 540 decompressed bytes; 0 when the head is neither (no bound known).
long double declared_image_bytes(const std::string& head) {
  if (head.size() < 540) return 0;
  const std::uint16_t one = 1;
  const bool little = *reinterpret_cast<const unsigned char*>(&one) == 1;
  NiftiHeaderView h{head};
  if (nifti_header_view(head, &h)) {
    const long long ndim = h.dim(0);
    const int bitpix = h.bitpix();
    const long double offset = h.vox_offset();
    if (ndim < 1 || ndim > 7 || bitpix <= 0 || !(offset >= 0)) return 0;
    long double voxels = 1;
    for (int d = 1; d <= ndim; ++d) voxels *= std::max<long double>(1, static_cast<long double>(h.dim(d)));
    return std::max<long double>(offset, h.sizeof_hdr()) + voxels * bitpix / 8 + (1 << 20);
  }
  // MGH: big-endian version 1, then width, height, depth, frames, type.
  const bool swap = little;
  if (field_at<std::int32_t>(head, 0, swap) == 1) {
    const int type = field_at<std::int32_t>(head, 20, swap);
    const int size = type == 0 ? 1 : type == 1 || type == 3 ? 4 : type == 4 ? 2 : 0;
    if (size == 0) return 0;
    long double voxels = 1;
    for (int d = 0; d < 4; ++d) voxels *= std::max<std::int32_t>(1, field_at<std::int32_t>(head, 4 + 4 * d, swap));
    return 284 + voxels * size + (16 << 20);  // tags (scan parameters, command history) follow the voxels
  }
  return 0;
}

}  // namespace

std::string gunzip(const std::string& bytes, const std::string& path) {
  std::string out;
  // A gzip bomb stops at what the image's own header declares, not at the global limit.
  long double limit = static_cast<long double>(g_max_decompressed_bytes);
  bool bounded = false;
  z_stream zs{};
  // 15 + 32: zlib or gzip header, detected automatically.
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw std::runtime_error(path + ": zlib initialisation failed");
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  zs.avail_in = static_cast<uInt>(bytes.size());
  char buffer[1 << 16];
  int ret = Z_OK;
  for (;;) {
    zs.next_out = reinterpret_cast<Bytef*>(buffer);
    zs.avail_out = sizeof(buffer);
    ret = inflate(&zs, Z_NO_FLUSH);
    if (ret != Z_OK && ret != Z_STREAM_END) break;
    try {
      out.append(buffer, sizeof(buffer) - zs.avail_out);
    } catch (const std::bad_alloc&) {
      inflateEnd(&zs);
      fail(path, "not enough memory to decompress it (" + fmt_size(out.size()) + " so far)", "free memory or give the file uncompressed");
    }
    if (!bounded && out.size() >= 540) {
      bounded = true;
      const long double declared = declared_image_bytes(out);
      if (declared > 0 && declared < limit) limit = declared;
    }
    if (static_cast<long double>(out.size()) > limit) {
      inflateEnd(&zs);
      if (limit < static_cast<long double>(g_max_decompressed_bytes))
        fail(path, "decompresses to more than the " + fmt_size(static_cast<std::size_t>(limit)) + " its image header declares",
             "the gzip stream is corrupt or a decompression bomb; re-create the file");
      fail(path, "decompresses to more than " + fmt_size(g_max_decompressed_bytes), "the gzip stream is not a plausible image");
    }
    if (ret == Z_STREAM_END) {
      // Concatenated gzip members (allowed by the format): continue with the next one.
      if (zs.avail_in > 0 && zs.avail_in >= 2 && zs.next_in[0] == 0x1f && zs.next_in[1] == 0x8b) {
        if (inflateReset(&zs) != Z_OK) break;
        continue;
      }
      break;
    }
    if (zs.avail_in == 0 && zs.avail_out != 0) {
      ret = Z_BUF_ERROR;  // input ended before the stream did
      break;
    }
  }
  inflateEnd(&zs);
  if (ret != Z_STREAM_END)
    fail(path, ret == Z_BUF_ERROR ? "gzip stream is truncated" : "gzip stream is corrupt", "the file is incomplete or damaged; re-copy or re-create it");
  return out;
}

std::string gzip(const std::string& bytes, int level) {
  z_stream zs{};
  if (deflateInit2(&zs, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("zlib initialisation failed");
  std::string out;
  out.resize(deflateBound(&zs, static_cast<uLong>(bytes.size())) + 32);
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  zs.avail_in = static_cast<uInt>(bytes.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  const int ret = deflate(&zs, Z_FINISH);
  const std::size_t produced = out.size() - zs.avail_out;
  deflateEnd(&zs);
  if (ret != Z_STREAM_END) throw std::runtime_error("zlib compression failed");
  out.resize(produced);
  return out;
}

std::string lower_filename(const std::string& path) {
  std::string name = std::filesystem::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  return name;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

void BigEndianReader::need(std::size_t n, const char* what) const {
  if (n > bytes_.size() - pos_) {
    fail("truncated: " + std::string(what) + " needs " + std::to_string(n) + " bytes at offset " + std::to_string(pos_) +
             " but the file has " + std::to_string(bytes_.size()) + " bytes",
         "the file is incomplete or not a " + format_ + " file");
  }
}

std::string BigEndianReader::line(std::size_t max_length, const char* what) {
  const std::size_t end = bytes_.find('\n', pos_);
  const std::size_t stop = end == std::string::npos ? bytes_.size() : end;
  if (stop - pos_ > max_length)
    fail(std::string(what) + " is longer than " + std::to_string(max_length) + " bytes", "this is not a " + format_ + " file");
  std::string s = bytes_.substr(pos_, stop - pos_);
  pos_ = end == std::string::npos ? bytes_.size() : end + 1;
  return s;
}

void BigEndianReader::fail(const std::string& problem, const std::string& hint) const { detail::fail(path_, problem, hint); }

namespace {

constexpr int kSignalSlots = 32;
constexpr std::size_t kSignalPathMax = 4096;
char g_signal_paths[kSignalSlots][kSignalPathMax];
volatile std::sig_atomic_t g_signal_used[kSignalSlots];
volatile std::sig_atomic_t g_signal_kind[kSignalSlots];
std::mutex g_signal_mutex;

// The entries of a folder unlinked, then the folder removed, with async-signal-safe calls only
// (open, getdents64, unlinkat, rmdir). Another thread may still be adding a file: a few rounds.
void remove_folder_of_files(const char* path) {
  for (int round = 0; round < 5; ++round) {
    const int fd = ::open(path, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return;
    alignas(8) char buf[4096];
    for (;;) {
      const long n = ::syscall(SYS_getdents64, fd, buf, sizeof buf);
      if (n <= 0) break;
      for (long at = 0; at < n;) {
        // struct linux_dirent64: d_ino (8), d_off (8), d_reclen (2), d_type (1), d_name.
        unsigned short reclen = 0;
        std::memcpy(&reclen, buf + at + 16, sizeof reclen);
        const char* name = buf + at + 19;
        if (std::strcmp(name, ".") != 0 && std::strcmp(name, "..") != 0) ::unlinkat(fd, name, 0);
        at += reclen;
      }
    }
    ::close(fd);
    if (::rmdir(path) == 0 || errno == ENOENT) return;
  }
}

extern "C" void remove_on_signal_handler(int sig) {
  // Only async-signal-safe calls here: unlink, open, getdents64, unlinkat, rmdir, signal, raise.
  for (const int kind : {0, 1, 2})
    for (int i = 0; i < kSignalSlots; ++i) {
      if (!g_signal_used[i] || g_signal_kind[i] != kind) continue;
      if (kind == 0) ::unlink(g_signal_paths[i]);
      if (kind == 1) remove_folder_of_files(g_signal_paths[i]);
      if (kind == 2) ::rmdir(g_signal_paths[i]);
    }
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

void install_signal_handlers_once() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) {
      struct sigaction old {};
      if (::sigaction(sig, nullptr, &old) != 0 || old.sa_handler != SIG_DFL) continue;  // keep a caller's handler
      struct sigaction sa {};
      sa.sa_handler = remove_on_signal_handler;
      sigemptyset(&sa.sa_mask);
      ::sigaction(sig, &sa, nullptr);
    }
  });
}

}  // namespace

RemoveOnSignal::RemoveOnSignal(const std::string& path, SignalRemoval kind) {
  if (path.size() >= kSignalPathMax) return;
  install_signal_handlers_once();
  std::lock_guard<std::mutex> lock(g_signal_mutex);
  for (int i = 0; i < kSignalSlots; ++i)
    if (!g_signal_used[i]) {
      std::memcpy(g_signal_paths[i], path.c_str(), path.size() + 1);
      g_signal_kind[i] = static_cast<int>(kind);
      g_signal_used[i] = 1;  // published after the path is complete
      slot_ = i;
      return;
    }
}

RemoveOnSignal::~RemoveOnSignal() {
  if (slot_ < 0) return;
  std::lock_guard<std::mutex> lock(g_signal_mutex);
  g_signal_used[slot_] = 0;
}

int mkstemps_removed_on_signal(std::vector<char>& pattern, int suffix_len, std::unique_ptr<RemoveOnSignal>* remove) {
  install_signal_handlers_once();
  sigset_t block, old;
  sigemptyset(&block);
  for (int sig : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&block, sig);
  ::pthread_sigmask(SIG_BLOCK, &block, &old);
  const int fd = ::mkstemps(pattern.data(), suffix_len);
  const int err = errno;
  if (fd >= 0) *remove = std::make_unique<RemoveOnSignal>(std::string(pattern.data()));
  ::pthread_sigmask(SIG_SETMASK, &old, nullptr);
  errno = err;
  return fd;
}

TempFile::TempFile(const std::string& suffix) {
  const std::string folder = std::filesystem::temp_directory_path().string();
  std::string pattern = folder + "/authalic-XXXXXX" + suffix;
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  const int fd = mkstemps_removed_on_signal(buf, static_cast<int>(suffix.size()), &on_signal_);
  if (fd < 0) throw std::runtime_error("cannot create a temporary file in " + folder + ": " + std::strerror(errno));
  ::close(fd);
  path_ = buf.data();
}

TempFile::~TempFile() { ::unlink(path_.c_str()); }

void TempFile::write(const std::string& bytes) const {
  FILE* f = std::fopen(path_.c_str(), "wb");
  if (!f) throw std::runtime_error("cannot write the temporary file " + path_ + ": " + std::strerror(errno));
  const std::size_t n = std::fwrite(bytes.data(), 1, bytes.size(), f);
  const int err = errno;
  if (std::fclose(f) != 0 || n != bytes.size())
    throw std::runtime_error("cannot write the temporary file " + path_ + " (temp folder full?): " + std::strerror(err));
}

std::string fmt_size(std::size_t bytes) {
  std::ostringstream ss;
  if (bytes >= (std::size_t(1) << 30))
    ss << (static_cast<double>(bytes) / (1 << 30)) << " GiB";
  else if (bytes >= (std::size_t(1) << 20))
    ss << (static_cast<double>(bytes) / (1 << 20)) << " MiB";
  else
    ss << bytes << " bytes";
  return ss.str();
}

}  // namespace authalic::io::detail

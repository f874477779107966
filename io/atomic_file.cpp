// Atomic writes: temp file in the destination folder (same extension), fsync, rename, fsync the
// folder. rename(2) within one file system is atomic, so readers see the old file or the complete
// new one, never a partial one, even after SIGKILL or a power cut (the fsyncs order the data
// before the rename).
#include "io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>
#include <utility>
#include <vector>

#include "io/file_roles.h"
#include "io/io_internal.h"

namespace authalic::io {

namespace fs = std::filesystem;

namespace {

// The process umask without changing it for good (umask(2) can only be read by setting it).
mode_t current_umask() {
  static const mode_t mask = [] {
    const mode_t m = ::umask(022);
    ::umask(m);
    return m;
  }();
  return mask;
}

std::string free_space_note(const std::string& folder) {
  struct statvfs sv {};
  if (::statvfs(folder.c_str(), &sv) != 0) return {};
  const auto free_bytes = static_cast<std::size_t>(sv.f_bavail) * sv.f_frsize;
  return " (" + detail::fmt_size(free_bytes) + " free in " + folder + ")";
}

// "<reason>" for errno values, with disk-full stated plainly.
std::string errno_reason(int err, const std::string& folder) {
  if (err == ENOSPC || err == EDQUOT) return "disk full: " + std::string(std::strerror(err)) + free_space_note(folder) + "; free some space or write elsewhere";
  if (err == EFBIG) return "file too large for this file system or process limit: " + std::string(std::strerror(err)) + "; write elsewhere";
  return std::strerror(err);
}

void fsync_path(const std::string& p, bool directory) {
  const int fd = ::open(p.c_str(), (directory ? O_RDONLY | O_DIRECTORY : O_RDONLY) | O_CLOEXEC);
  if (fd < 0) {
    if (directory) return;  // some file systems do not allow opening folders; the rename still happened
    throw std::system_error(errno, std::generic_category(), "open for fsync");
  }
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  // EINVAL: the file system does not support fsync (e.g. some FUSE/pipe targets): nothing to order.
  if (rc != 0 && err != EINVAL && !directory) throw std::system_error(err, std::generic_category(), "fsync");
}

// "out.surf.gii" -> {"out", ".surf.gii"}: everything from the first dot after the first character
// is kept as the suffix, so compound extensions (.nii.gz, .surf.gii, .gii.gz) survive.
std::pair<std::string, std::string> split_name(const std::string& name) {
  const std::size_t dot = name.find('.', 1);
  if (dot == std::string::npos) return {name, ""};
  return {name.substr(0, dot), name.substr(dot)};
}

}  // namespace

void write_atomically(const std::string& path_given, const std::function<void(const std::string& tmp_path)>& write) {
  // A symlink is written through (its target is replaced, the link stays); anything else that
  // exists and is not a regular file is refused, since rename(2) would replace the node itself
  // (a device such as /dev/full, a FIFO). Commands check this up front (io/file_roles.h); this is
  // the last line of defence for every writer.
  const std::string path = write_target(path_given);
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode))
    throw std::runtime_error(path_given + ": exists and is not a regular file; writing would replace it: give a file path");
  const fs::path target(path);
  const std::string name = target.filename().string();
  if (name.empty() || name == "." || name == "..") throw std::runtime_error(path + ": not a file name; give a file path to write");
  fs::path folder = target.parent_path();
  const std::string folder_str = folder.empty() ? std::string(".") : folder.string();
  std::error_code ec;
  if (!fs::is_directory(folder_str, ec))
    throw std::runtime_error(path + ": folder " + folder_str + " does not exist; create it first");
  if (fs::is_directory(target, ec)) throw std::runtime_error(path + ": is a directory; give a file path to write");

  const auto [stem, suffix] = split_name(name);
  std::string pattern = (fs::path(folder_str) / ("." + stem + ".tmp" + std::to_string(::getpid()) + "-XXXXXX" + suffix)).string();
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  std::unique_ptr<detail::RemoveOnSignal> remove_on_signal;  // a SIGTERM mid-write leaves no temporary file
  const int fd = detail::mkstemps_removed_on_signal(buf, static_cast<int>(suffix.size()), &remove_on_signal);
  if (fd < 0) throw std::runtime_error(path + ": cannot create a temporary file in " + folder_str + ": " + errno_reason(errno, folder_str));
  ::fchmod(fd, 0666 & ~current_umask());
  ::close(fd);
  const std::string tmp(buf.data());

  try {
    write(tmp);
    std::error_code size_ec;
    if (!fs::exists(tmp, size_ec)) throw std::runtime_error("the writer produced no file");
    fsync_path(tmp, false);
    if (::rename(tmp.c_str(), path.c_str()) != 0) throw std::system_error(errno, std::generic_category(), "rename");
  } catch (const std::system_error& e) {
    ::unlink(tmp.c_str());
    const int err = e.code().value();
    throw std::runtime_error(path + ": writing failed (" + e.what() + "): " + errno_reason(err, folder_str));
  } catch (const std::exception& e) {
    ::unlink(tmp.c_str());
    const std::string what = e.what();
    // Do not repeat the path when the writer already named the temporary file or the target.
    if (what.rfind(path, 0) == 0) throw std::runtime_error(what);
    if (what.rfind(tmp, 0) == 0) throw std::runtime_error(path + what.substr(tmp.size()));
    throw std::runtime_error(path + ": " + what);
  } catch (...) {
    ::unlink(tmp.c_str());
    throw std::runtime_error(path + ": writing failed");
  }
  fsync_path(folder_str, true);
}

void write_file_atomically(const std::string& path, const std::string& contents) {
  write_atomically(path, [&](const std::string& tmp) {
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd < 0) throw std::system_error(errno, std::generic_category(), "open");
    std::size_t done = 0;
    while (done < contents.size()) {
      const ssize_t n = ::write(fd, contents.data() + done, contents.size() - done);
      if (n < 0) {
        if (errno == EINTR) continue;
        const int err = errno;
        ::close(fd);
        throw std::system_error(err, std::generic_category(), "write");
      }
      done += static_cast<std::size_t>(n);
    }
    if (::close(fd) != 0) throw std::system_error(errno, std::generic_category(), "close");
  });
}

}  // namespace authalic::io

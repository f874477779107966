// Input/output path checks shared by every subcommand (io/file_roles.h).
#include "io/file_roles.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <optional>
#include <stdexcept>

#include "core/error.h"

namespace authalic::io {

namespace fs = std::filesystem;

namespace {

// What kind of node st describes, for messages.
std::string node_kind(const struct stat& st) {
  if (S_ISCHR(st.st_mode)) return "a character device";
  if (S_ISBLK(st.st_mode)) return "a block device";
  if (S_ISFIFO(st.st_mode)) return "a FIFO (named pipe)";
  if (S_ISSOCK(st.st_mode)) return "a socket";
  if (S_ISDIR(st.st_mode)) return "a folder";
  return "not a regular file";
}

// A path's identity: (device, inode) when it exists, else its absolute lexical form with the
// existing part's symlinks resolved.
struct Identity {
  bool exists = false;
  dev_t dev = 0;
  ino_t ino = 0;
  std::string path;
  bool operator==(const Identity& o) const {
    if (exists && o.exists) return dev == o.dev && ino == o.ino;
    return !exists && !o.exists && path == o.path;
  }
};

Identity identity(const std::string& p) {
  Identity id;
  struct stat st {};
  if (::stat(p.c_str(), &st) == 0) {
    id.exists = true;
    id.dev = st.st_dev;
    id.ino = st.st_ino;
  }
  std::error_code ec;
  const fs::path c = fs::weakly_canonical(fs::absolute(p, ec), ec);
  id.path = ec ? fs::absolute(p).lexically_normal().string() : c.string();
  return id;
}

void check_output_node(const std::string& out) {
  struct stat lst {};
  if (::lstat(out.c_str(), &lst) != 0) return;  // does not exist yet: fine
  struct stat st = lst;
  if (S_ISLNK(lst.st_mode)) {
    if (::stat(out.c_str(), &st) != 0)
      throw InputError(out + ": is a symlink to a missing file (" + std::strerror(errno) +
                       "); remove the link or give another output path");
  }
  if (S_ISDIR(st.st_mode)) throw InputError(out + ": is a folder; give a file path to write");
  if (!S_ISREG(st.st_mode))
    throw InputError(out + ": exists and is " + node_kind(st) +
                     ", not a regular file; writing would replace it: give a file path");
}

void check_output_folder(const std::string& out) {
  const fs::path target(write_target(out));
  const fs::path parent = target.parent_path();
  const std::string folder = parent.empty() ? std::string(".") : parent.string();
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw InputError(out + ": folder " + folder + " does not exist; create it first");
  if (::access(folder.c_str(), W_OK | X_OK) != 0)
    throw InputError(out + ": folder " + folder + " is not writable (" + std::strerror(errno) + "); write elsewhere");
}

}  // namespace

std::string write_target(const std::string& path) {
  struct stat lst {};
  if (::lstat(path.c_str(), &lst) != 0 || !S_ISLNK(lst.st_mode)) return path;
  std::error_code ec;
  const fs::path real = fs::canonical(path, ec);
  if (ec) throw std::runtime_error(path + ": is a symlink to a missing file; remove the link or give another output path");
  return real.string();
}

void check_file_roles(const std::vector<std::string>& inputs, const std::vector<std::string>& outputs) {
  std::vector<std::pair<std::string, Identity>> ins;
  for (const std::string& in : inputs)
    if (!in.empty()) ins.emplace_back(in, identity(in));
  std::vector<std::pair<std::string, Identity>> outs;
  for (const std::string& out : outputs) {
    if (out.empty()) continue;
    check_output_node(out);
    check_output_folder(out);
    const Identity id = identity(out);
    for (const auto& [in, in_id] : ins)
      if (id == in_id)
        throw InputError(out + ": is also an input (" + in + "); writing it would destroy the input: give another output path");
    for (const auto& [other, other_id] : outs)
      if (id == other_id)
        throw InputError(out + ": is given twice as an output (also as " + other + "); give each output its own path");
    outs.emplace_back(out, id);
  }
}

void check_inputs_outside(const std::vector<std::string>& inputs, const std::string& folder, const std::string& why) {
  std::error_code ec;
  const fs::path root = fs::weakly_canonical(fs::absolute(folder, ec), ec);
  if (ec) return;
  for (const std::string& in : inputs) {
    if (in.empty()) continue;
    std::error_code ec2;
    const fs::path p = fs::weakly_canonical(fs::absolute(in, ec2), ec2);
    if (ec2) continue;
    // p is inside root when root is a prefix of p component by component.
    auto r = root.begin();
    auto q = p.begin();
    for (; r != root.end() && q != p.end() && *r == *q; ++r, ++q) {
    }
    if (r == root.end())
      throw InputError(in + ": lies inside " + folder + ", which " + why + "; move the input out of it first");
  }
}

}  // namespace authalic::io

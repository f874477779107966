// Exclusive lock file (io/lock_file.h).
#include "io/lock_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/error.h"

namespace authalic::io {

LockFile::LockFile(const std::string& path, const std::string& what) : path_(path) {
  // A holder removes the file before it unlocks; a process that opened the old file just before
  // would then lock an unlinked inode. So after locking, check that the path still names the
  // locked inode, and retry otherwise.
  //
  // The path is registered for removal on a signal before the file is created: registered after,
  // a signal between the two left the lock behind (seen in CI). Until the lock is ours the
  // registration is dropped on every way out, so only the short window between open() and a
  // refused flock() could remove another holder's file, and only if this process is being killed.
  for (int attempt = 0; attempt < 100; ++attempt) {
    on_signal_ = std::make_unique<RemovedOnSignal>(path_, RemovedOnSignal::Kind::File);
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      on_signal_.reset();
      throw InputError(path + ": cannot create the lock file (" + std::strerror(errno) + "); check that the folder is writable");
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      on_signal_.reset();
      ::close(fd);
      if (err == EWOULDBLOCK)
        throw InputError(what + ": another authalic process is writing it now (lock " + path +
                         " is held); wait for it to finish or choose another --out");
      throw InputError(path + ": cannot lock (" + std::strerror(err) + ")");
    }
    struct stat held {}, named {};
    if (::fstat(fd, &held) == 0 && ::stat(path.c_str(), &named) == 0 && held.st_ino == named.st_ino && held.st_dev == named.st_dev) {
      fd_ = fd;
      return;
    }
    on_signal_.reset();
    ::close(fd);
  }
  throw InputError(path + ": could not take the lock (the file kept being replaced)");
}

LockFile::~LockFile() {
  if (fd_ < 0) return;
  on_signal_.reset();  // first: once unlinked, the path may name another process's lock
  ::unlink(path_.c_str());
  ::close(fd_);
}

}  // namespace authalic::io

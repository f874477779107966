#pragma once
// An exclusive advisory lock (flock(2)) on a lock file, held for the lifetime of the object.
// Used by `authalic run` so that two runs writing the same OUT/sub-<id> cannot interleave: the
// check "does the subject folder exist?" and the final rename happen under the lock. The lock
// file is removed when the lock is released, and by SIGTERM, SIGINT or SIGHUP (io/signal_cleanup.h);
// a run killed with SIGKILL leaves the (empty) lock file behind, which the next run simply locks
// again (the kernel released the lock).
#include <memory>
#include <string>

#include "io/signal_cleanup.h"

namespace authalic::io {

class LockFile {
 public:
  // Takes the lock on `path` (created if missing) or throws InputError naming `what` when another
  // process holds it.
  LockFile(const std::string& path, const std::string& what);
  ~LockFile();
  LockFile(const LockFile&) = delete;
  LockFile& operator=(const LockFile&) = delete;

 private:
  std::string path_;
  int fd_ = -1;
  std::unique_ptr<RemovedOnSignal> on_signal_;
};

}  // namespace authalic::io

#pragma once
// Outputs under construction that a SIGTERM, SIGINT or SIGHUP (Ctrl-C, a scheduler's time limit,
// `group` ending) must not leave behind: while a RemovedOnSignal lives, such a signal removes its
// path, then ends the process as the signal says. The removal runs in the signal handler with
// async-signal-safe calls only (io_internal.h RemoveOnSignal); SIGKILL cannot be caught, and the
// next run of the same subject removes what it leaves (analysis/pipeline.cpp).
#include <memory>
#include <string>

namespace authalic::io {

namespace detail {
class RemoveOnSignal;
}

class RemovedOnSignal {
 public:
  // File: unlinked. FolderOfFiles: its files, then the folder (a staging folder). FolderIfEmpty:
  // the folder only when nothing is left in it (an output folder the run made).
  enum class Kind { File, FolderOfFiles, FolderIfEmpty };
  RemovedOnSignal(const std::string& path, Kind kind);
  ~RemovedOnSignal();
  RemovedOnSignal(const RemovedOnSignal&) = delete;
  RemovedOnSignal& operator=(const RemovedOnSignal&) = delete;

 private:
  std::unique_ptr<detail::RemoveOnSignal> impl_;
};

}  // namespace authalic::io

#pragma once
// Before any computing, every subcommand states which paths it reads and which it writes, and
// these checks refuse (InputError, exit 2, one line) what would destroy an input or cannot be
// written. Rules (docs/robustness.md, "Output safety"):
//  - an output that is the same file as an input (same inode, so hard links and symlinks count,
//    or the same absolute path once `.`/`..`/symlinked folders are resolved) is refused;
//  - an output that exists and is not a regular file (a device such as /dev/full, a FIFO, a
//    socket, a folder) is refused: writers rename a temporary file into place, which would
//    replace the node itself;
//  - an output that is a symlink to a regular file is written through: the link stays and its
//    target gets the new contents (a dangling link is refused);
//  - two outputs that are the same file are refused;
//  - an output whose folder does not exist or is not writable is refused.
#include <string>
#include <vector>

namespace authalic::io {

// Throws InputError naming the first offending path. Empty strings are ignored (options not given).
// Inputs may be files or folders (a DICOM series); outputs are files.
void check_file_roles(const std::vector<std::string>& inputs, const std::vector<std::string>& outputs);

// Throws InputError if any input is `folder` or lies inside it (e.g. `run --force` would remove
// `folder`, taking the input with it). `why` completes the message ("--force replaces it").
void check_inputs_outside(const std::vector<std::string>& inputs, const std::string& folder, const std::string& why);

// The path a writer should rename into: `path` itself, or, when `path` is a symlink, the file it
// points to (resolved fully). Throws std::runtime_error for a dangling link.
std::string write_target(const std::string& path);

}  // namespace authalic::io

#pragma once
// Writers never leave a partial file: they write to a temporary name in the destination folder
// and rename it into place only after everything was written and flushed.
#include <functional>
#include <string>

namespace authalic::io {

// Calls write(tmp_path) for a temporary path next to `path` (same folder, same extension so that
// extension-driven libraries such as gifticlib or nifti-clib behave), fsyncs it and renames it to
// `path`. On any exception or failure the temporary file is removed and the error rethrown as
// std::runtime_error("<path>: <reason>").
void write_atomically(const std::string& path, const std::function<void(const std::string& tmp_path)>& write);

// Writes a whole text/binary buffer atomically.
void write_file_atomically(const std::string& path, const std::string& contents);

}  // namespace authalic::io

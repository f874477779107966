#pragma once
// File checksums for provenance (JSON sidecars record the inputs' SHA-256).
#include <string>

namespace authalic::io {

// Lower-case hex SHA-256 of a file's bytes. Throws InputError naming the file if it cannot be read.
std::string sha256_file(const std::string& path);
// Lower-case hex SHA-256 of a buffer.
std::string sha256_bytes(const std::string& bytes);

}  // namespace authalic::io

#pragma once
// Shared setup for the libFuzzer targets: lower the size limits so corrupt headers are refused
// below libFuzzer's memory limit, and treat InputError as the expected outcome for bad bytes.
// Anything else escaping a reader (another exception type, a crash, a leak, UB) is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "io/io_internal.h"
#include "io/surface_formats.h"
#include "io/volume_formats.h"
#include "io/vtk_family_check.h"

namespace authalic::fuzz {

inline void set_limits() {
  io::detail::g_max_decompressed_bytes = std::size_t(64) << 20;
  io::detail::g_max_volume_bytes = std::size_t(64) << 20;
  // Far above any input libFuzzer makes, far below its memory limit.
  io::detail::g_max_vtk_vertices = 1'000'000;
  io::detail::g_max_vtk_faces = 2'000'000;
}

template <class Fn>
int run(const std::uint8_t* data, std::size_t size, Fn&& fn) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    fn(bytes);
  } catch (const InputError&) {
    // the reader refused the input: correct behaviour
  }
  return 0;
}

// The VTK-family reader on `bytes` written to a temporary file with the format's extension.
inline void read_vtk_bytes(const std::string& bytes, const std::string& format) {
  const io::detail::TempFile file("." + format);
  file.write(bytes);
  io::detail::read_vtk_family(file.path(), format);
}

}  // namespace authalic::fuzz

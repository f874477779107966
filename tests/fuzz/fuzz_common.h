#pragma once
// Shared setup for the libFuzzer targets: lower the size limits so corrupt headers are refused
// below libFuzzer's memory limit, and treat InputError as the expected outcome for bad bytes.
// Anything else escaping a reader (another exception type, a crash, a leak, UB) is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "io/io_internal.h"
#include "io/volume_formats.h"

namespace authalic::fuzz {

inline void set_limits() {
  io::detail::g_max_decompressed_bytes = std::size_t(64) << 20;
  io::detail::g_max_volume_bytes = std::size_t(64) << 20;
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

}  // namespace authalic::fuzz

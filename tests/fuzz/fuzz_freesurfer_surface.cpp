// libFuzzer target: FreeSurfer binary triangle surface parser (with volume-geometry footer).
#include "fuzz/fuzz_common.h"
#include "io/surface_formats.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  authalic::fuzz::set_limits();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return authalic::fuzz::run(data, size, [](const std::string& b) { authalic::io::detail::parse_freesurfer_surface(b, "fuzz.white"); });
}

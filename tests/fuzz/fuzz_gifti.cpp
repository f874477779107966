// libFuzzer target: the GIFTI reader path (our checks, then gifticlib on a temporary file, then
// array lookup by intent and per-vertex column extraction).
#include "fuzz/fuzz_common.h"
#include "io/surface_formats.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  authalic::fuzz::set_limits();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return authalic::fuzz::run(data, size, [](const std::string& b) {
    const authalic::io::detail::TempFile file(".gii");
    file.write(b);
    authalic::io::detail::read_gifti(file.path());
  });
}

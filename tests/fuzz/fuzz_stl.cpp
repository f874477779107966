// libFuzzer target: the STL reader path (binary size / ASCII vertex checks, then vtkSTLReader on a temporary file).
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  authalic::fuzz::set_limits();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return authalic::fuzz::run(data, size, [](const std::string& b) { authalic::fuzz::read_vtk_bytes(b, "stl"); });
}

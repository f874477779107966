// libFuzzer target: the OBJ reader path (v/f line checks, then vtkOBJReader on a temporary file).
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  authalic::fuzz::set_limits();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return authalic::fuzz::run(data, size, [](const std::string& b) { authalic::fuzz::read_vtk_bytes(b, "obj"); });
}

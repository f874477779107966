// libFuzzer target: the legacy VTK (.vtk, geometry walk and sanitized copy) and VTK XML PolyData
// (.vtp, Piece count checks) reader paths. The first byte picks the format; the rest is the file.
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  authalic::fuzz::set_limits();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool xml = (data[0] & 1) != 0;
  return authalic::fuzz::run(data + 1, size - 1, [xml](const std::string& b) { authalic::fuzz::read_vtk_bytes(b, xml ? "vtp" : "vtk"); });
}

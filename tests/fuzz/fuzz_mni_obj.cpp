// libFuzzer target: the MNI .obj parser (ASCII and binary polygon objects, io/mni_obj_io.cpp),
// behind its sniffer as read_surface calls them.
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  authalic::fuzz::set_limits();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return authalic::fuzz::run(data, size, [](const std::string& b) {
    if (authalic::io::detail::looks_like_mni_obj(b) || (!b.empty() && b[0] == 'p')) authalic::io::detail::parse_mni_obj(b, "fuzz.obj");
  });
}

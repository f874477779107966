// libFuzzer target: MGH/MGZ reader (gzip detection and inflation, then the MGH parser).
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  authalic::fuzz::set_limits();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return authalic::fuzz::run(data, size, [](const std::string& b) {
    authalic::io::VolumeReadOptions options;
    options.sum_frames = true;
    const std::string raw = authalic::io::detail::is_gzip(b) ? authalic::io::detail::gunzip(b, "fuzz.mgz") : b;
    authalic::io::detail::parse_mgh(raw, "fuzz.mgz", options);
  });
}

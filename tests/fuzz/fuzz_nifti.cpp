// libFuzzer target: the NIfTI reader path (nifti-clib header and data, our size, orientation,
// data-type and frame handling). Frames are summed so 4D inputs reach the data code too.
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  authalic::fuzz::set_limits();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return authalic::fuzz::run(data, size, [](const std::string& b) {
    const authalic::io::detail::TempFile file(".nii");
    file.write(b);
    authalic::io::VolumeReadOptions options;
    options.sum_frames = true;
    authalic::io::detail::read_nifti(file.path(), options);
  });
}

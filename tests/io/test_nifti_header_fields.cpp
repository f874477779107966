// NIfTI orientation fields that nifti-clib would silently "fix" while reading (issue 17): a NaN
// quaternion becomes 0 and a zero voxel size 1 mm, i.e. another orientation. They are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>

#include "common/test_data.h"
#include "core/error.h"
#include "io/volume_io.h"

namespace authalic {
namespace {

// A small NIfTI-1 with the sform switched off (the qform is used), then `patch` applied to its bytes.
std::string write_qform_only(const std::string& path, void (*patch)(std::string&)) {
  io::Volume v;
  v.dims = {4, 4, 4};
  v.vox2ras = Eigen::Matrix4d::Identity();
  v.vox2ras.diagonal().head<3>() << 2, 2, 2;
  v.data.assign(64, 1.0f);
  io::write_nifti(path, v);
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), {});
  const std::int16_t zero = 0;
  std::memcpy(&bytes[254], &zero, 2);  // sform_code = 0
  patch(bytes);
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  return path;
}

void set_float(std::string& bytes, std::size_t at, float x) { std::memcpy(&bytes[at], &x, 4); }

std::string error_of(const std::string& path) {
  try {
    io::read_volume(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(NiftiHeaderFields, NanQuaternionAndZeroVoxelSizeAreRefused) {
  const std::string dir = test::temp_dir("nifti-fields");
  // Unpatched: the qform alone reads, 2 mm voxels.
  const std::string ok = write_qform_only(dir + "/ok.nii", [](std::string&) {});
  EXPECT_NEAR(io::read_volume(ok).voxel_size()(0), 2.0, 1e-6);
  const std::string nan_q = write_qform_only(dir + "/nanq.nii", [](std::string& b) {
    set_float(b, 256, std::numeric_limits<float>::quiet_NaN());  // quatern_b
  });
  EXPECT_NE(error_of(nan_q).find("quatern_b is not a finite number"), std::string::npos) << error_of(nan_q);
  const std::string zero_pixdim = write_qform_only(dir + "/pixdim0.nii", [](std::string& b) { set_float(b, 80, 0.0f); });
  EXPECT_NE(error_of(zero_pixdim).find("pixdim[1] (the voxel size) is 0"), std::string::npos) << error_of(zero_pixdim);
}

}  // namespace
}  // namespace authalic

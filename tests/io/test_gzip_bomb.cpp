// Gzip bombs (issue 17, item 9): a compressed volume stops decompressing at the size its own
// header declares (plus a small margin), instead of inflating to the global 8 GiB limit in memory
// and in a temporary file first.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "common/test_data.h"
#include "core/error.h"
#include "io/io_internal.h"
#include "io/volume_io.h"

namespace authalic {
namespace {

io::Volume small_volume() {
  io::Volume v;
  v.dims = {10, 10, 10};
  v.vox2ras = Eigen::Matrix4d::Identity();
  v.data.assign(1000, 1.0f);
  return v;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// `plain` (an uncompressed image file) followed by `extra` zero bytes, gzipped into `out`.
void write_bomb(const std::string& plain, std::size_t extra, const std::string& out) {
  std::string bytes = read_bytes(plain);
  bytes.append(extra, '\0');
  std::ofstream(out, std::ios::binary) << io::detail::gzip(bytes, 1);
}

void expect_stopped_at_declared_size(const std::string& path) {
  const auto start = std::chrono::steady_clock::now();
  try {
    io::read_volume(path);
    FAIL() << path << ": a bomb was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("its image header declares"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).rfind(path, 0), 0u) << e.what();
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
}

TEST(GzipBomb, NiftiAndMghStopAtTheirDeclaredSize) {
  const std::string dir = test::temp_dir("gzip-bomb");
  const std::size_t extra = std::size_t(96) << 20;  // 96 MB of zeros: about 100 kB compressed
  io::write_nifti(dir + "/small.nii", small_volume());
  write_bomb(dir + "/small.nii", extra, dir + "/bomb.nii.gz");
  EXPECT_LT(std::filesystem::file_size(dir + "/bomb.nii.gz"), std::size_t(1) << 20);
  expect_stopped_at_declared_size(dir + "/bomb.nii.gz");
  io::write_mgh(dir + "/small.mgh", small_volume());
  write_bomb(dir + "/small.mgh", extra, dir + "/bomb.mgz");
  expect_stopped_at_declared_size(dir + "/bomb.mgz");
  // The same images without the padding read as before.
  write_bomb(dir + "/small.nii", 0, dir + "/ok.nii.gz");
  EXPECT_EQ(io::read_volume(dir + "/ok.nii.gz").data.size(), 1000u);
  write_bomb(dir + "/small.mgh", 0, dir + "/ok.mgz");
  EXPECT_EQ(io::read_volume(dir + "/ok.mgz").data.size(), 1000u);
}

}  // namespace
}  // namespace authalic

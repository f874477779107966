#pragma once
// 8-bit RGB images and PNG writing (no display needed).
#include <cstdint>
#include <string>
#include <vector>

namespace authalic::io {

// Row-major RGB image, row 0 at the top.
struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  // width*height*3
  RgbImage() = default;
  RgbImage(int w, int h, std::uint8_t gray = 255) : width(w), height(h), rgb(static_cast<std::size_t>(w) * h * 3, gray) {}
  std::uint8_t* pixel(int x, int y) { return &rgb[(static_cast<std::size_t>(y) * width + x) * 3]; }
  const std::uint8_t* pixel(int x, int y) const { return &rgb[(static_cast<std::size_t>(y) * width + x) * 3]; }
};

// Writes a PNG atomically. Throws std::runtime_error naming the path on failure.
void write_png(const std::string& path, const RgbImage& image);
// Reads a PNG (for tests and report embedding).
RgbImage read_png(const std::string& path);
// PNG-encodes to memory (for embedding in an HTML report as base64).
std::vector<std::uint8_t> encode_png(const RgbImage& image);

}  // namespace authalic::io

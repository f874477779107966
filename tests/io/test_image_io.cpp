// PNG: encode/decode round trip, atomic write, a corrupt file refused.
#include <gtest/gtest.h>

#include "io/image_io.h"
#include "io/io_test_util.h"

using namespace authalic;
using namespace authalic::io;
using namespace authalic::test;

TEST(Png, RoundTripKeepsEveryPixel) {
  const std::string dir = temp_dir("png");
  RgbImage img(7, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x) {
      std::uint8_t* p = img.pixel(x, y);
      p[0] = static_cast<std::uint8_t>(x * 30);
      p[1] = static_cast<std::uint8_t>(y * 50);
      p[2] = static_cast<std::uint8_t>((x * y) % 256);
    }
  write_png(dir + "/a.png", img);
  const RgbImage back = read_png(dir + "/a.png");
  EXPECT_EQ(back.width, 7);
  EXPECT_EQ(back.height, 5);
  EXPECT_EQ(back.rgb, img.rgb);
  const std::vector<std::uint8_t> bytes = encode_png(img);
  ASSERT_GT(bytes.size(), 8u);
  EXPECT_EQ(bytes[1], 'P');
  EXPECT_EQ(std::string(bytes.begin(), bytes.end()), read_bytes(dir + "/a.png"));
  EXPECT_EQ(list_dir(dir), std::vector<std::string>{"a.png"});
}

TEST(Png, CorruptAndInvalidAreRefused) {
  const std::string dir = temp_dir("png_bad");
  RgbImage img(4, 4, 10);
  write_png(dir + "/a.png", img);
  const std::string bytes = read_bytes(dir + "/a.png");
  write_bytes(dir + "/cut.png", bytes.substr(0, bytes.size() / 2));
  expect_input_error([&] { read_png(dir + "/cut.png"); }, dir + "/cut.png", "cannot decode PNG");
  write_bytes(dir + "/text.png", "hello, not a png");
  expect_input_error([&] { read_png(dir + "/text.png"); }, dir + "/text.png", "not a PNG");
  RgbImage broken;
  broken.width = 3;
  broken.height = 3;  // no pixels
  EXPECT_THROW(write_png(dir + "/broken.png", broken), std::runtime_error);
  EXPECT_FALSE(std::filesystem::exists(dir + "/broken.png"));
}

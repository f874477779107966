// PNG through libpng, in memory (no display, no VTK rendering). Errors come back through
// libpng's longjmp-based handler, so the C++ objects are kept outside the setjmp frames.
#include "io/image_io.h"

#include <png.h>

#include <csetjmp>
#include <cstring>
#include <stdexcept>

#include "io/atomic_file.h"
#include "io/io_internal.h"

namespace authalic::io {

namespace {

struct Buffer {
  std::vector<std::uint8_t>* out;
};

void write_to_vector(png_structp png, png_bytep data, png_size_t length) {
  auto* buf = static_cast<Buffer*>(png_get_io_ptr(png));
  buf->out->insert(buf->out->end(), data, data + length);
}

struct Reader {
  const std::string* bytes;
  std::size_t pos;
};

void read_from_string(png_structp png, png_bytep data, png_size_t length) {
  auto* r = static_cast<Reader*>(png_get_io_ptr(png));
  if (length > r->bytes->size() - r->pos) png_error(png, "truncated PNG data");
  std::memcpy(data, r->bytes->data() + r->pos, length);
  r->pos += length;
}

void png_message(png_structp png, png_const_charp msg) {
  auto* err = static_cast<std::string*>(png_get_error_ptr(png));
  if (err && err->empty()) *err = msg ? msg : "libpng error";
  png_longjmp(png, 1);
}
void png_ignore_warning(png_structp, png_const_charp) {}

// All libpng calls for encoding; returns false (and leaves *error set) on failure.
bool encode(const RgbImage& image, std::vector<std::uint8_t>* out, std::string* error) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, error, png_message, png_ignore_warning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  Buffer buf{out};
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, &buf, write_to_vector, nullptr);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width), static_cast<png_uint_32>(image.height), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  // zlib's fastest level: PNG encoding at the default level 6 was a fifth of the sample run's CPU.
  png_set_compression_level(png, 1);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y)
    png_write_row(png, const_cast<png_bytep>(image.rgb.data() + static_cast<std::size_t>(y) * image.width * 3));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

bool decode(const std::string& bytes, int* width, int* height, std::vector<std::uint8_t>* rgb, std::string* error) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, error, png_message, png_ignore_warning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    return false;
  }
  Reader reader{&bytes, 0};
  std::vector<png_bytep> rows;  // before setjmp: a longjmp must not skip a destructor
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_set_read_fn(png, &reader, read_from_string);
  png_set_user_limits(png, 1 << 15, 1 << 15);
  png_read_info(png, info);
  // Normalise everything to 8-bit RGB: palette/grey expanded, alpha and 16 bits dropped.
  png_set_strip_16(png);
  png_set_strip_alpha(png);
  png_set_packing(png);
  const int color = png_get_color_type(png, info);
  if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (color == PNG_COLOR_TYPE_GRAY || color == PNG_COLOR_TYPE_GRAY_ALPHA) {
    png_set_expand_gray_1_2_4_to_8(png);
    png_set_gray_to_rgb(png);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  *width = static_cast<int>(png_get_image_width(png, info));
  *height = static_cast<int>(png_get_image_height(png, info));
  if (png_get_rowbytes(png, info) != static_cast<std::size_t>(*width) * 3) png_error(png, "unexpected row size after conversion");
  rgb->assign(static_cast<std::size_t>(*width) * *height * 3, 0);
  rows.resize(static_cast<std::size_t>(*height));
  for (int y = 0; y < *height; ++y) rows[static_cast<std::size_t>(y)] = rgb->data() + static_cast<std::size_t>(y) * *width * 3;
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

}  // namespace

std::vector<std::uint8_t> encode_png(const RgbImage& image) {
  if (image.width <= 0 || image.height <= 0 || image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3)
    throw std::runtime_error("encode_png: image is " + std::to_string(image.width) + "x" + std::to_string(image.height) + " with " +
                             std::to_string(image.rgb.size()) + " bytes (expected width*height*3)");
  std::vector<std::uint8_t> out;
  std::string error;
  if (!encode(image, &out, &error)) throw std::runtime_error("encode_png: " + (error.empty() ? std::string("libpng failed") : error));
  return out;
}

void write_png(const std::string& path, const RgbImage& image) {
  std::vector<std::uint8_t> bytes;
  try {
    bytes = encode_png(image);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  write_file_atomically(path, std::string(bytes.begin(), bytes.end()));
}

RgbImage read_png(const std::string& path) {
  const std::string bytes = detail::read_file(path);
  if (bytes.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) != 0)
    throw InputError(path + ": not a PNG file (wrong signature); give a .png image");
  RgbImage image;
  std::string error;
  if (!decode(bytes, &image.width, &image.height, &image.rgb, &error))
    throw InputError(path + ": cannot decode PNG (" + (error.empty() ? std::string("libpng failed") : error) + "); the file is corrupt");
  return image;
}

}  // namespace authalic::io

// Drawing primitives of the software renderer (see analysis/raster.h).
#include "analysis/raster.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace authalic::analysis::raster {

std::vector<char32_t> decode_utf8(const std::string& text) {
  std::vector<char32_t> out;
  out.reserve(text.size());
  std::size_t i = 0;
  while (i < text.size()) {
    const auto c = static_cast<unsigned char>(text[i]);
    int extra = 0;
    char32_t cp = 0;
    if (c < 0x80) {
      cp = c;
    } else if ((c & 0xE0) == 0xC0) {
      cp = c & 0x1F;
      extra = 1;
    } else if ((c & 0xF0) == 0xE0) {
      cp = c & 0x0F;
      extra = 2;
    } else if ((c & 0xF8) == 0xF0) {
      cp = c & 0x07;
      extra = 3;
    } else {
      out.push_back(U'?');
      ++i;
      continue;
    }
    bool ok = true;
    for (int k = 1; k <= extra; ++k) {
      if (i + static_cast<std::size_t>(k) >= text.size()) {
        ok = false;
        break;
      }
      const auto cc = static_cast<unsigned char>(text[i + k]);
      if ((cc & 0xC0) != 0x80) {
        ok = false;
        break;
      }
      cp = (cp << 6) | (cc & 0x3F);
    }
    if (!ok) {
      out.push_back(U'?');
      ++i;
      continue;
    }
    out.push_back(cp);
    i += 1 + extra;
  }
  return out;
}

int text_width(const std::string& text, int scale) {
  const int n = static_cast<int>(decode_utf8(text).size());
  return n == 0 ? 0 : (n * kGlyphAdvance - 1) * scale;
}

void set_pixel(io::RgbImage& image, int x, int y, const Colour& colour) {
  if (x < 0 || y < 0 || x >= image.width || y >= image.height) return;
  std::uint8_t* p = image.pixel(x, y);
  p[0] = colour[0];
  p[1] = colour[1];
  p[2] = colour[2];
}

void blend_pixel(io::RgbImage& image, int x, int y, const Colour& colour, double alpha) {
  if (x < 0 || y < 0 || x >= image.width || y >= image.height) return;
  std::uint8_t* p = image.pixel(x, y);
  for (int c = 0; c < 3; ++c) {
    const double v = alpha * colour[c] + (1.0 - alpha) * p[c];
    p[c] = static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
  }
}

void fill_rect(io::RgbImage& image, int x, int y, int w, int h, const Colour& colour) {
  const int x0 = std::max(x, 0), y0 = std::max(y, 0);
  const int x1 = std::min(x + w, image.width), y1 = std::min(y + h, image.height);
  for (int yy = y0; yy < y1; ++yy) {
    for (int xx = x0; xx < x1; ++xx) set_pixel(image, xx, yy, colour);
  }
}

void draw_rect(io::RgbImage& image, int x, int y, int w, int h, const Colour& colour) {
  if (w <= 0 || h <= 0) return;
  fill_rect(image, x, y, w, 1, colour);
  fill_rect(image, x, y + h - 1, w, 1, colour);
  fill_rect(image, x, y, 1, h, colour);
  fill_rect(image, x + w - 1, y, 1, h, colour);
}

void draw_line(io::RgbImage& image, int x0, int y0, int x1, int y1, const Colour& colour, int thickness) {
  const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  const int lo = -(thickness - 1) / 2, hi = thickness / 2;
  int err = dx + dy;
  for (;;) {
    for (int oy = lo; oy <= hi; ++oy) {
      for (int ox = lo; ox <= hi; ++ox) set_pixel(image, x0 + ox, y0 + oy, colour);
    }
    if (x0 == x1 && y0 == y1) break;
    const int e2 = 2 * err;
    if (e2 >= dy) {
      err += dy;
      x0 += sx;
    }
    if (e2 <= dx) {
      err += dx;
      y0 += sy;
    }
  }
}

void draw_text(io::RgbImage& image, int x, int y, const std::string& text, const Colour& colour, int scale) {
  scale = std::max(scale, 1);
  int pen = x;
  for (char32_t cp : decode_utf8(text)) {
    const auto& rows = glyph(cp);
    const int top = y + (glyph_descends(cp) ? 2 * scale : 0);
    for (int r = 0; r < kGlyphHeight; ++r) {
      for (int c = 0; c < kGlyphWidth; ++c) {
        if ((rows[r] >> (kGlyphWidth - 1 - c)) & 1) fill_rect(image, pen + c * scale, top + r * scale, scale, scale, colour);
      }
    }
    pen += kGlyphAdvance * scale;
  }
}

void draw_text_centred(io::RgbImage& image, int cx, int y, const std::string& text, const Colour& colour, int scale) {
  draw_text(image, cx - text_width(text, scale) / 2, y, text, colour, scale);
}

std::vector<double> nice_ticks(double lo, double hi, int target, double* step_out) {
  std::vector<double> ticks;
  if (!std::isfinite(lo) || !std::isfinite(hi)) return ticks;
  if (hi < lo) std::swap(lo, hi);
  if (hi == lo) {
    if (step_out) *step_out = std::abs(lo) > 0 ? std::abs(lo) : 1.0;
    ticks.push_back(lo);
    return ticks;
  }
  const double raw = (hi - lo) / std::max(target, 1);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    step = m * mag;
    if (step >= raw) break;
  }
  const double eps = step * 1e-9;
  const double first = std::ceil((lo - eps) / step);
  for (double k = first;; k += 1.0) {
    double v = k * step;
    if (v > hi + eps) break;
    if (std::abs(v) < eps) v = 0.0;  // no "-0"
    ticks.push_back(v);
  }
  if (step_out) *step_out = step;
  return ticks;
}

std::string format_tick(double value, double step) {
  int decimals = 0;
  if (step > 0 && std::isfinite(step)) {
    // Enough decimals to tell neighbouring ticks apart (2.5 x 10^k needs one more).
    double s = step;
    while (decimals < 6 && std::abs(s - std::round(s)) > 1e-9 * std::max(1.0, std::abs(s))) {
      s *= 10.0;
      ++decimals;
    }
  }
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, value);
  return buf;
}

std::string format_number(double value, int significant) {
  if (!std::isfinite(value)) return std::isnan(value) ? "NaN" : (value > 0 ? "inf" : "-inf");
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*g", std::max(significant, 1), value);
  return buf;
}

}  // namespace authalic::analysis::raster

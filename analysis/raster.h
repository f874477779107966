#pragma once
// Drawing primitives for the software renderer (analysis/render.cpp): filled rectangles, lines,
// alpha blending and text from a built-in 5x7 bitmap font (analysis/font.cpp). Integer pixel
// arithmetic only, so every picture is bit-for-bit reproducible. Pixels outside the image are
// silently clipped.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "io/image_io.h"

namespace authalic::analysis::raster {

using Colour = std::array<unsigned char, 3>;

// The 5x7 glyph of a Unicode code point: 7 rows, top first, bit 4 = leftmost column.
// ASCII 32..126 plus a few symbols used in labels (Λ Υ Δ ρ σ γ θ λ μ Ω ² ³ ° ± × · ≤ ≥ −);
// anything else draws as '?'.
const std::array<std::uint8_t, 7>& glyph(char32_t code);
// Letters with a descender (g, p, q, y): their 7 rows are drawn 2 rows lower than the others.
bool glyph_descends(char32_t code);

// UTF-8 to code points (invalid bytes become '?').
std::vector<char32_t> decode_utf8(const std::string& text);

// Glyph cell: 5x7 pixels plus one column of spacing, times `scale`.
constexpr int kGlyphWidth = 5, kGlyphHeight = 7, kGlyphAdvance = 6;
int text_width(const std::string& text, int scale);
// Height of a text line without descenders (they reach 2 * scale lower).
inline int text_height(int scale) { return kGlyphHeight * scale; }

void set_pixel(io::RgbImage& image, int x, int y, const Colour& colour);
// colour * alpha + existing * (1 - alpha), alpha in [0,1].
void blend_pixel(io::RgbImage& image, int x, int y, const Colour& colour, double alpha);
void fill_rect(io::RgbImage& image, int x, int y, int w, int h, const Colour& colour);
// One-pixel outline of the rectangle [x, x+w) x [y, y+h).
void draw_rect(io::RgbImage& image, int x, int y, int w, int h, const Colour& colour);
// Bresenham line, both ends included; thickness > 1 draws a square brush.
void draw_line(io::RgbImage& image, int x0, int y0, int x1, int y1, const Colour& colour, int thickness = 1);
// Text with its top-left corner at (x, y).
void draw_text(io::RgbImage& image, int x, int y, const std::string& text, const Colour& colour, int scale = 1);
// Text centred horizontally on cx, top at y.
void draw_text_centred(io::RgbImage& image, int cx, int y, const std::string& text, const Colour& colour, int scale = 1);

// "Nice" tick values (1, 2, 2.5, 5 x 10^k steps) inside [lo, hi], about `target` of them.
std::vector<double> nice_ticks(double lo, double hi, int target, double* step = nullptr);
// A tick label with just enough decimals for `step` (e.g. 0.25 -> "0.25", 2 -> "2").
std::string format_tick(double value, double step);
// A number for captions: up to `significant` digits, no trailing zeros.
std::string format_number(double value, int significant = 3);

}  // namespace authalic::analysis::raster

#pragma once
// 2D drawing for every picture and the PDF report, through Cairo (Debian libcairo2-dev):
// anti-aliased rectangles, lines, polygons, bitmaps and text set in DejaVu Sans through
// FreeType/fontconfig, on an image surface (-> io::RgbImage, then PNG) or on a PDF surface
// (A4 pages). Sizes are in pixels on an image and in points (1/72 inch) in a PDF. The same
// calls with the same fonts give the same bytes.
//
// Also the tick and number formatting the pictures and the report share ("nice" ticks, numbers
// rounded for humans).
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "io/image_io.h"

typedef struct _cairo cairo_t;
typedef struct _cairo_surface cairo_surface_t;

namespace authalic::analysis {

using Rgb = std::array<unsigned char, 3>;

enum class Align { Left, Centre, Right };

struct TextStyle {
  double size = 13.0;  // font size: pixels on an image, points in a PDF (>= 11 px on screen)
  bool bold = false;
  Rgb colour{0, 0, 0};
  Align align = Align::Left;
};

class Canvas {
 public:
  // An image of width x height pixels filled with `background`.
  Canvas(int width, int height, Rgb background = {255, 255, 255});
  // A PDF document with pages of width x height points (A4: 595.28 x 841.89), its bytes
  // appended to *out (which must outlive the canvas); complete after finish().
  static std::unique_ptr<Canvas> pdf(std::string* out, double width_pt, double height_pt);
  ~Canvas();
  Canvas(const Canvas&) = delete;
  Canvas& operator=(const Canvas&) = delete;

  double width() const { return width_; }
  double height() const { return height_; }

  void fill_rect(double x, double y, double w, double h, const Rgb& colour, double alpha = 1.0);
  // Outline of [x, x+w] x [y, y+h] with a line of `line_width`; on pixel images an odd width
  // with integer x, y covers whole pixel columns/rows just inside the rectangle's edges.
  void stroke_rect(double x, double y, double w, double h, const Rgb& colour, double line_width = 1.0);
  void line(double x0, double y0, double x1, double y1, const Rgb& colour, double width = 1.0, double alpha = 1.0);
  // Closed polygon (x0, y0, x1, y1, ...), filled.
  void fill_polygon(const std::vector<double>& xy, const Rgb& colour);
  // A bitmap with its top-left corner at (x, y), scaled by `scale` (nearest pixel: values stay
  // exact on pixel images; smooth when scaled in a PDF).
  void image(const io::RgbImage& picture, double x, double y, double scale = 1.0);

  // Text with the top of its line box at y (the baseline is at y + ascent); x is the left end,
  // the centre or the right end per style.align. Returns the width drawn.
  double text(double x, double y, const std::string& text, const TextStyle& style);
  // Greedy word wrap into lines no wider than max_width; returns the height used (line pitch
  // 1.3 x size).
  double paragraph(double x, double y, double max_width, const std::string& text, const TextStyle& style);

  // PDF: starts a new page.
  void next_page();
  // Flushes the surface (a PDF file is complete after this).
  void finish();
  // The pixels of an image canvas (alpha dropped; the background is opaque).
  io::RgbImage to_image() const;

 private:
  Canvas() = default;
  void set_colour(const Rgb& colour, double alpha = 1.0);
  void set_font(const TextStyle& style);
  cairo_surface_t* surface_ = nullptr;
  cairo_t* cr_ = nullptr;
  double width_ = 0, height_ = 0;
};

// Width and line height (ascent + descent) of a text in the report's font, without a canvas.
double text_width(const std::string& text, double size, bool bold = false);
double text_line_height(double size);
// Lines of a greedy word wrap of `text` to max_width.
std::vector<std::string> wrap_text(const std::string& text, double size, double max_width, bool bold = false);

// "Nice" tick values (1, 2, 2.5, 5 x 10^k steps) inside [lo, hi], about `target` of them.
std::vector<double> nice_ticks(double lo, double hi, int target, double* step = nullptr);
// A tick label with just enough decimals for `step` (e.g. 0.25 -> "0.25", 2 -> "2"); the minus
// sign is U+2212, as typeset.
std::string format_tick(double value, double step);
// A number for people: `decimals` after the point, no "-0", U+2212 for minus when `typeset`;
// "n/a" when not finite.
std::string format_fixed(double value, int decimals, bool typeset = false);
// A number for captions: up to `significant` digits, no trailing zeros.
std::string format_number(double value, int significant = 3);

}  // namespace authalic::analysis

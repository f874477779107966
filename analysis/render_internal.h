#pragma once
// Pieces shared by the flat-map renderer (analysis/render.cpp) and the 3D surface renderer
// (analysis/render_surface.cpp); not part of the public API.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "analysis/canvas.h"
#include "analysis/render.h"

namespace authalic::analysis::detail {

struct ControlPoint {
  double t, r, g, b;  // position in [0,1], colour in [0,1]
};

// A colour map resolved once (name -> control points), then evaluated per pixel exactly as
// colormap() would, so colour_of() and the pictures agree to the byte. Values that are not
// finite, or inside (-threshold, threshold) when a threshold is set, take the NaN colour.
class ColourTable {
 public:
  explicit ColourTable(const ScalarColouring& c);
  Rgb operator()(double v) const;
  Rgb at(double t) const;  // t in [0,1] along the map (clamped)
  bool hidden(double v) const { return !std::isfinite(v) || (threshold_ > 0 && std::abs(v) < threshold_); }

 private:
  enum class Kind { Gray, Hot, Points };
  Kind kind_ = Kind::Gray;
  const std::vector<ControlPoint>* points_ = nullptr;
  bool reversed_ = false;
  Rgb nan_;
  double vmin_, vmax_, threshold_;
};

std::uint8_t to_byte(double v);

// Whether any finite value lies below vmin / above vmax: the colour bar then marks the
// saturated end ("≤ −4").
struct Saturation {
  bool below = false, above = false;
};
Saturation saturation_of(const double* values, std::size_t n, const ScalarColouring& c);

constexpr double kTickFontSize = 13.0;   // colour-bar and axis labels (px)
constexpr double kTitleFontSize = 16.0;  // picture titles (px)
constexpr double kMargin = 10.0;

// Horizontal room the colour bar takes right of a plot, and the bar itself: vertical, vmin at
// the bottom, units above, ticks at nice values plus the threshold; saturated ends get an arrow
// head and a "≤"/"≥" label; the band hidden by a threshold is drawn in the NaN colour.
// font: the labels' size in pixels.
int colour_bar_extent(const ScalarColouring& c, const Saturation& s, double font);
void draw_colour_bar(Canvas& canvas, double x, double top, double height, const ScalarColouring& c, const Saturation& s,
                     double font);

void check_mesh(const MatrixXd& V, const MatrixXi& F, const ScalarColouring& c, int min_cols, const char* who);

// The colour of a pixel at barycentric (w0, w1, w2) of face f: the value interpolated and then
// mapped (a NaN corner: its nearest corner's value); a hidden value shows the interpolated
// background gray (sulcal shading) when one is given, else the NaN colour.
Rgb pixel_colour(const ScalarColouring& c, const ColourTable& table, const int* f, double w0, double w1, double w2);

// Calls fn(px, py, w0, w1, w2) for every pixel whose centre lies in the triangle (screen
// coordinates X, Y; clip rectangle [x0, x1) x [y0, y1)). Barycentric weights sum to 1.
template <class Fn>
void rasterise_triangle(const double X[3], const double Y[3], int clip_x0, int clip_y0, int clip_x1, int clip_y1, Fn&& fn) {
  const double area = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
  if (!(std::abs(area) > 1e-12) || !std::isfinite(area)) return;
  const double min_x = std::min({X[0], X[1], X[2]}), max_x = std::max({X[0], X[1], X[2]});
  const double min_y = std::min({Y[0], Y[1], Y[2]}), max_y = std::max({Y[0], Y[1], Y[2]});
  const int px0 = std::max(clip_x0, static_cast<int>(std::floor(min_x - 0.5)));
  const int px1 = std::min(clip_x1 - 1, static_cast<int>(std::ceil(max_x - 0.5)));
  const int py0 = std::max(clip_y0, static_cast<int>(std::floor(min_y - 0.5)));
  const int py1 = std::min(clip_y1 - 1, static_cast<int>(std::ceil(max_y - 0.5)));
  const double eps = -1e-9;
  for (int py = py0; py <= py1; ++py) {
    const double cy = py + 0.5;
    for (int px = px0; px <= px1; ++px) {
      const double cx = px + 0.5;
      const double w0 = ((X[1] - cx) * (Y[2] - cy) - (X[2] - cx) * (Y[1] - cy)) / area;
      const double w1 = ((X[2] - cx) * (Y[0] - cy) - (X[0] - cx) * (Y[2] - cy)) / area;
      const double w2 = 1.0 - w0 - w1;
      if (w0 >= eps && w1 >= eps && w2 >= eps) fn(px, py, w0, w1, w2);
    }
  }
}

inline void put_pixel(io::RgbImage& img, int x, int y, const Rgb& c) {
  std::uint8_t* p = img.pixel(x, y);
  p[0] = c[0];
  p[1] = c[1];
  p[2] = c[2];
}

}  // namespace authalic::analysis::detail

// Flat maps, element images, histograms and picture layout (see analysis/render.h). Text,
// frames, grid lines and colour bars are drawn with Cairo (analysis/canvas.h); the data layer is
// scan-converted pixel by pixel (the scalar is interpolated, then mapped, which no vector
// library does), so the same input always gives the same bytes.
#include "analysis/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "analysis/render_internal.h"
#include "core/error.h"

namespace authalic::analysis {

namespace detail {

namespace {

// ---- colour maps ------------------------------------------------------------------------

// matplotlib's viridis (van der Walt & Smith 2015, CC0): every 16th entry of its 256-entry
// table (_viridis_data indices 0, 16, ..., 240, 255), interpolated linearly in between.
const std::vector<ControlPoint>& viridis_points() {
  static const std::vector<ControlPoint> points = [] {
    const double table[17][4] = {
        {0, 0.267004, 0.004874, 0.329415},   {16, 0.282327, 0.094955, 0.417331},  {32, 0.278826, 0.175490, 0.483397},
        {48, 0.258965, 0.251537, 0.524736},  {64, 0.229739, 0.322361, 0.545706},  {80, 0.199430, 0.387607, 0.554642},
        {96, 0.172719, 0.448791, 0.557885},  {112, 0.149039, 0.508051, 0.557250}, {128, 0.127568, 0.566949, 0.550556},
        {144, 0.120638, 0.625828, 0.533488}, {160, 0.157851, 0.683765, 0.501686}, {176, 0.246070, 0.738910, 0.452024},
        {192, 0.369214, 0.788888, 0.382914}, {208, 0.515992, 0.831158, 0.294279}, {224, 0.678489, 0.863742, 0.189503},
        {240, 0.845561, 0.887322, 0.099702}, {255, 0.993248, 0.906157, 0.143936}};
    std::vector<ControlPoint> p;
    for (const auto& row : table) p.push_back({row[0] / 255.0, row[1], row[2], row[3]});
    return p;
  }();
  return points;
}

// Moreland's diverging cool-warm map ("Diverging Color Maps for Scientific Visualization",
// ISVC 2009): his published 33-point table, blue (59,76,192) - gray (221,221,221) - red (180,4,38).
const std::vector<ControlPoint>& coolwarm_points() {
  static const std::vector<ControlPoint> points = [] {
    const double table[33][3] = {
        {0.2298057, 0.298717966, 0.753683153},  {0.26623388, 0.353094838, 0.801466763},
        {0.30386891, 0.406535296, 0.84495867},  {0.342804478, 0.458757618, 0.883725899},
        {0.38301334, 0.50941904, 0.917387822},  {0.424369608, 0.558148092, 0.945619588},
        {0.46666708, 0.604562568, 0.968154911}, {0.509635204, 0.648280772, 0.98478814},
        {0.552953156, 0.688929332, 0.995375608}, {0.596262162, 0.726149107, 0.999836203},
        {0.639176211, 0.759599947, 0.998151185}, {0.681291281, 0.788964712, 0.990363227},
        {0.722193294, 0.813952739, 0.976574709}, {0.761464949, 0.834302879, 0.956945269},
        {0.798691636, 0.849786142, 0.931688648}, {0.833466556, 0.860207984, 0.901068838},
        {0.865395197, 0.86541021, 0.865395561},  {0.897787179, 0.848937047, 0.820880546},
        {0.924127593, 0.827384882, 0.774508472}, {0.944468518, 0.800927443, 0.726736146},
        {0.958852946, 0.769767752, 0.678007945}, {0.96732803, 0.734132809, 0.628751763},
        {0.969954137, 0.694266682, 0.579375448}, {0.966811177, 0.650421156, 0.530263762},
        {0.958003065, 0.602842431, 0.481775914}, {0.943660866, 0.551750968, 0.434243684},
        {0.923944917, 0.49730856, 0.387970225},  {0.89904617, 0.439559467, 0.343229596},
        {0.869186849, 0.378313092, 0.300267182}, {0.834620542, 0.312874446, 0.259301199},
        {0.795631745, 0.24128379, 0.220525627},  {0.752534934, 0.157246067, 0.184115123},
        {0.705673158, 0.01555616, 0.150232812}};
    std::vector<ControlPoint> p;
    for (int i = 0; i < 33; ++i) p.push_back({i / 32.0, table[i][0], table[i][1], table[i][2]});
    return p;
  }();
  return points;
}

double interpolate_channel(const std::vector<ControlPoint>& p, double t, int channel) {
  auto value = [&](const ControlPoint& c) { return channel == 0 ? c.r : channel == 1 ? c.g : c.b; };
  if (t <= p.front().t) return value(p.front());
  for (std::size_t i = 1; i < p.size(); ++i) {
    if (t <= p[i].t) {
      const double f = (t - p[i - 1].t) / (p[i].t - p[i - 1].t);
      return value(p[i - 1]) + f * (value(p[i]) - value(p[i - 1]));
    }
  }
  return value(p.back());
}

// MATLAB/matplotlib "hot" (matplotlib _cm._hot_data): red rises over [0, 0.365079] from
// 0.0416, green over [0.365079, 0.746032], blue over [0.746032, 1].
double hot_channel(double t, int channel) {
  auto ramp = [](double x, double a, double b, double from) {
    if (x <= a) return from;
    if (x >= b) return 1.0;
    return from + (1.0 - from) * (x - a) / (b - a);
  };
  if (channel == 0) return ramp(t, 0.0, 0.365079, 0.0416);
  if (channel == 1) return ramp(t, 0.365079, 0.746032, 0.0);
  return ramp(t, 0.746032, 1.0, 0.0);
}


}  // namespace

std::uint8_t to_byte(double v) { return static_cast<std::uint8_t>(std::clamp(std::lround(v * 255.0), 0L, 255L)); }

ColourTable::ColourTable(const ScalarColouring& c)
    : nan_(c.nan_colour), vmin_(c.vmin), vmax_(c.vmax), threshold_(c.threshold) {
  std::string name = c.colormap;
  if (name.size() > 2 && name.compare(name.size() - 2, 2, "_r") == 0) {
    reversed_ = true;
    name = name.substr(0, name.size() - 2);
  }
  if (name == "gray" || name == "grey") {
    kind_ = Kind::Gray;
  } else if (name == "viridis") {
    kind_ = Kind::Points;
    points_ = &viridis_points();
  } else if (name == "coolwarm") {
    kind_ = Kind::Points;
    points_ = &coolwarm_points();
  } else if (name == "hot") {
    kind_ = Kind::Hot;
  } else {
    throw InputError("colour map '" + c.colormap + "': unknown; use gray, viridis, coolwarm or hot (append _r to reverse)");
  }
}

Rgb ColourTable::operator()(double v) const {
  if (hidden(v)) return nan_;
  const double range = vmax_ - vmin_;
  return at(range > 0 ? (v - vmin_) / range : 0.5);
}

Rgb ColourTable::at(double t) const {
  if (std::isnan(t)) t = 0.0;
  t = std::clamp(t, 0.0, 1.0);
  if (reversed_) t = 1.0 - t;
  switch (kind_) {
    case Kind::Gray: {
      const auto g = to_byte(t);
      return {g, g, g};
    }
    case Kind::Hot: return {to_byte(hot_channel(t, 0)), to_byte(hot_channel(t, 1)), to_byte(hot_channel(t, 2))};
    case Kind::Points:
      return {to_byte(interpolate_channel(*points_, t, 0)), to_byte(interpolate_channel(*points_, t, 1)),
              to_byte(interpolate_channel(*points_, t, 2))};
  }
  return nan_;
}

Saturation saturation_of(const double* values, std::size_t n, const ScalarColouring& c) {
  Saturation s;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(values[i])) continue;
    s.below = s.below || values[i] < c.vmin;
    s.above = s.above || values[i] > c.vmax;
  }
  return s;
}

namespace {

const Rgb kBlack{0, 0, 0};

// Tick values and their labels: nice values, plus the range ends when saturated (labelled
// "≤ vmin" / "≥ vmax") and the threshold when one hides the middle of the map.
std::vector<std::pair<double, std::string>> colour_bar_ticks(const ScalarColouring& c, const Saturation& s) {
  double step = 1.0;
  std::vector<double> values = nice_ticks(c.vmin, c.vmax, 5, &step);
  if (c.threshold > 0) {
    for (double t : {-c.threshold, c.threshold})
      if (t > c.vmin && t < c.vmax) values.push_back(t);
  }
  if (s.below) values.push_back(c.vmin);
  if (s.above) values.push_back(c.vmax);
  std::sort(values.begin(), values.end());
  const double close = 0.12 * (c.vmax - c.vmin);
  std::vector<std::pair<double, std::string>> ticks;
  for (double v : values) {
    const bool end_below = s.below && v == c.vmin, end_above = s.above && v == c.vmax;
    std::string label = format_tick(v, c.threshold > 0 && std::abs(std::abs(v) - c.threshold) < 1e-9 ? 0.1 : step);
    if (end_below) label = "\u2264 " + label;
    if (end_above) label = "\u2265 " + label;
    // A nice tick crowding a marked end or a threshold tick is dropped (they say more).
    if (!ticks.empty() && std::abs(v - ticks.back().first) < 1e-9) continue;
    if (!ticks.empty() && v - ticks.back().first < close) {
      const bool keep_new = end_above || (c.threshold > 0 && std::abs(std::abs(v) - c.threshold) < 1e-9);
      if (keep_new) {
        ticks.back() = {v, label};
      }
      continue;
    }
    ticks.emplace_back(v, label);
  }
  return ticks;
}

constexpr double kBarGap = 12, kBarWidth = 14, kTickLength = 4, kArrow = 12;

// The units label in lines of at most ~11 em.
std::vector<std::string> bar_label_lines(const ScalarColouring& c, double font) {
  return wrap_text(c.label, font, std::max(6.0 * font, text_width(c.label, font) / 3.0));
}

}  // namespace

int colour_bar_extent(const ScalarColouring& c, const Saturation& s, double font) {
  double labels = 0;
  for (const auto& [v, label] : colour_bar_ticks(c, s)) labels = std::max(labels, text_width(label, font));
  const double body = kBarWidth + kTickLength + 4 + labels;
  // A long units label wraps rather than widening the bar (and shrinking the plot).
  double label = 0;
  for (const std::string& l : bar_label_lines(c, font)) label = std::max(label, text_width(l, font));
  return static_cast<int>(std::ceil(kBarGap + std::max(body, label) + 4));
}

void draw_colour_bar(Canvas& cv, double x, double top, double height, const ScalarColouring& c, const Saturation& s,
                     double font) {
  const ColourTable table(c);
  const double line = text_line_height(font);
  double bar_top = top + line / 2;
  TextStyle ts;
  ts.size = font;
  for (const std::string& l : bar_label_lines(c, font)) {
    cv.text(x + kBarGap, bar_top - line / 2, l, ts);
    bar_top += line;
  }
  if (!c.label.empty()) bar_top += 4;
  if (s.above) bar_top += kArrow;
  const double bar_bottom = top + height - line / 2 - (s.below ? kArrow : 0);
  const int rows = static_cast<int>(std::floor(bar_bottom - bar_top));
  if (rows < 8) return;
  const double bx = std::round(x + kBarGap), by = std::round(bar_top);
  const double range = c.vmax - c.vmin;
  for (int r = 0; r < rows; ++r) {
    const double t = 1.0 - double(r) / (rows - 1);  // both ends shown
    const double v = c.vmin + t * range;
    cv.fill_rect(bx, by + r, kBarWidth, 1, table.hidden(v) ? c.nan_colour : table.at(t));
  }
  cv.stroke_rect(bx - 1, by - 1, kBarWidth + 2, rows + 2, kBlack);
  // Arrow heads on saturated ends, in the end colour (as in 3D-SSP and Workbench palettes).
  if (s.above) cv.fill_polygon({bx - 1, by - 1, bx + kBarWidth + 1, by - 1, bx + kBarWidth / 2, by - kArrow}, table.at(1.0));
  if (s.below)
    cv.fill_polygon({bx - 1, by + rows + 1, bx + kBarWidth + 1, by + rows + 1, bx + kBarWidth / 2, by + rows + kArrow}, table.at(0.0));
  for (const auto& [v, label] : colour_bar_ticks(c, s)) {
    const double f = range > 0 ? (v - c.vmin) / range : 0.5;
    const double y = by + std::round((1.0 - f) * (rows - 1)) + 0.5;
    cv.line(bx + kBarWidth, y, bx + kBarWidth + kTickLength, y, kBlack, 1.0);
    cv.text(bx + kBarWidth + kTickLength + 3, y - line / 2, label, ts);
  }
}

void check_mesh(const MatrixXd& V, const MatrixXi& F, const ScalarColouring& c, int min_cols, const char* who) {
  if (V.cols() < min_cols) {
    throw std::invalid_argument(std::string(who) + ": vertex matrix needs at least " + std::to_string(min_cols) + " columns");
  }
  if (F.size() > 0 && (F.cols() != 3 || F.minCoeff() < 0 || F.maxCoeff() >= V.rows())) {
    throw std::invalid_argument(std::string(who) + ": face indices out of range of the " + std::to_string(V.rows()) +
                                " vertices");
  }
  if (c.values.size() > 0 && c.values.size() != V.rows()) {
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(c.values.size()) + " values for " +
                                std::to_string(V.rows()) + " vertices");
  }
  if (!c.no_value.empty() && c.no_value.size() != static_cast<std::size_t>(V.rows()))
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(c.no_value.size()) + " no-value flags for " +
                                std::to_string(V.rows()) + " vertices");
  if (c.background.size() > 0 && c.background.size() != V.rows()) {
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(c.background.size()) + " background levels for " +
                                std::to_string(V.rows()) + " vertices");
  }
}

Rgb pixel_colour(const ScalarColouring& c, const ColourTable& table, const int* f, double w0, double w1, double w2) {
  static const Rgb kPlainSurface{210, 210, 210};
  double v = std::numeric_limits<double>::quiet_NaN();
  if (c.values.size() > 0) {
    const double a = c.values[f[0]], b = c.values[f[1]], d = c.values[f[2]];
    if (std::isfinite(a) && std::isfinite(b) && std::isfinite(d)) {
      v = w0 * a + w1 * b + w2 * d;
    } else {
      v = (w0 >= w1 && w0 >= w2) ? a : (w1 >= w2 ? b : d);
    }
  } else if (c.background.size() == 0) {
    return kPlainSurface;
  }
  if (!table.hidden(v)) return table(v);
  if (std::isnan(v) && !c.no_value.empty() && c.values.size() > 0) {
    const int nearest = (w0 >= w1 && w0 >= w2) ? f[0] : (w1 >= w2 ? f[1] : f[2]);
    if (c.no_value[static_cast<std::size_t>(nearest)]) return c.no_value_colour;
  }
  if (c.background.size() == 0) return c.nan_colour;
  const auto g = to_byte(w0 * c.background[f[0]] + w1 * c.background[f[1]] + w2 * c.background[f[2]]);
  return {g, g, g};
}

}  // namespace detail

using namespace detail;

namespace {

const Rgb kBlack{0, 0, 0};

bool has_values(const ScalarColouring& c) { return c.values.size() > 0; }

double title_size(double font) { return font * kTitleFontSize / kTickFontSize; }

// The frame, plot position and colour bar room shared by the flat map and the element image.
FlatLayout frame_layout(int plot_width, int plot_height, const std::string& title, int bar_extent, double font = kTickFontSize) {
  FlatLayout L;
  const int m = static_cast<int>(kMargin);
  const int title_height = title.empty() ? 0 : static_cast<int>(std::ceil(text_line_height(title_size(font)))) + 6;
  L.left = m + 2;
  L.top = m + title_height + static_cast<int>(std::ceil(text_line_height(font) / 2));
  L.plot_width = plot_width;
  L.plot_height = plot_height;
  const int right = bar_extent > 0 ? bar_extent + m : m;
  L.width = std::max(L.left + plot_width + right, static_cast<int>(std::ceil(text_width(title, title_size(font), true))) + 2 * m);
  L.height = L.top + plot_height + m + static_cast<int>(std::ceil(text_line_height(font) / 2));
  return L;
}

// Title, frame (just outside the plot, so it never hides data) and colour bar.
void draw_frame_decorations(Canvas& cv, const FlatLayout& L, const std::string& title, const ScalarColouring* bar,
                            const Saturation& s, double font = kTickFontSize) {
  cv.stroke_rect(L.left - 1, L.top - 1, L.plot_width + 2, L.plot_height + 2, kBlack);
  if (!title.empty()) {
    TextStyle ts;
    ts.size = title_size(font);
    ts.bold = true;
    ts.align = Align::Centre;
    // Centred over the plot, but never past the picture's left edge (a title wider than the plot).
    const double half = text_width(title, title_size(font), true) / 2;
    cv.text(std::max(L.left + L.plot_width / 2.0, half + kMargin), kMargin, title, ts);
  }
  if (bar) draw_colour_bar(cv, L.left + L.plot_width + 1, L.top - text_line_height(font) / 2,
                           L.plot_height + text_line_height(font), *bar, s, font);
}

// Light lines over the element-grid boundaries: dark at 35 % opacity, so they read on any
// colour without hiding it. Column line c is the pixel column floor(left + c * plot_width / cols).
void draw_grid_lines(Canvas& cv, const FlatLayout& L, int cols, int rows) {
  const Rgb dark{30, 30, 30};
  const double alpha = 0.35;
  for (int c = 1; c < cols; ++c) {
    const int x = std::min(L.left + static_cast<int>(std::floor(double(c) * L.plot_width / cols)), L.left + L.plot_width - 1);
    cv.line(x + 0.5, L.top, x + 0.5, L.top + L.plot_height, dark, 1.0, alpha);
  }
  for (int r = 1; r < rows; ++r) {
    // Row lines counted from the bottom of the domain (y grows upwards).
    const int y = std::max(L.top + L.plot_height - 1 - static_cast<int>(std::floor(double(r) * L.plot_height / rows)), L.top);
    cv.line(L.left, y + 0.5, L.left + L.plot_width, y + 0.5, dark, 1.0, alpha);
  }
}

}  // namespace

// ---- public API -----------------------------------------------------------------------------

Rgb colormap(const std::string& name, double t) {
  ScalarColouring c;
  c.colormap = name;
  return ColourTable(c).at(t);
}

Rgb colour_of(const ScalarColouring& colouring, double value) { return ColourTable(colouring)(value); }

FlatLayout flat_layout(const FlatRenderOptions& options, const ScalarColouring& colouring) {
  if (!(options.domain_width > 0) || !(options.domain_height > 0)) {
    throw std::invalid_argument("render_flat: the domain needs a positive width and height");
  }
  const bool bar = options.draw_colour_bar && has_values(colouring);
  const Saturation s = saturation_of(colouring.values.data(), static_cast<std::size_t>(colouring.values.size()), colouring);
  const int extent = bar ? colour_bar_extent(colouring, s, options.font_size) : 0;
  // The plot takes what the margins and the colour bar leave of the requested width.
  const FlatLayout probe = frame_layout(0, 0, {}, extent, options.font_size);
  const int plot_width = std::max(16, options.width - probe.width);
  const int plot_height = std::max(1, static_cast<int>(std::lround(plot_width * options.domain_height / options.domain_width)));
  return frame_layout(plot_width, plot_height, options.title, extent, options.font_size);
}

io::RgbImage render_flat(const MatrixXd& UV, const MatrixXi& F, const ScalarColouring& colouring,
                         const FlatRenderOptions& options) {
  check_mesh(UV, F, colouring, 2, "render_flat");
  const FlatLayout L = flat_layout(options, colouring);
  const ColourTable table(colouring);
  io::RgbImage plot(L.plot_width, L.plot_height, 255);
  const double sx = L.plot_width / options.domain_width, sy = L.plot_height / options.domain_height;
  for (int f = 0; f < F.rows(); ++f) {
    const int idx[3] = {F(f, 0), F(f, 1), F(f, 2)};
    double X[3], Y[3];
    for (int k = 0; k < 3; ++k) {
      X[k] = (UV(idx[k], 0) - options.x0) * sx;
      Y[k] = L.plot_height - (UV(idx[k], 1) - options.y0) * sy;
    }
    rasterise_triangle(X, Y, 0, 0, L.plot_width, L.plot_height, [&](int px, int py, double w0, double w1, double w2) {
      put_pixel(plot, px, py, pixel_colour(colouring, table, idx, w0, w1, w2));
    });
  }
  Canvas cv(L.width, L.height);
  cv.image(plot, L.left, L.top);
  if (options.grid_cols > 0 || options.grid_rows > 0) draw_grid_lines(cv, L, options.grid_cols, options.grid_rows);
  const bool bar = options.draw_colour_bar && has_values(colouring);
  draw_frame_decorations(cv, L, options.title, bar ? &colouring : nullptr,
                         saturation_of(colouring.values.data(), static_cast<std::size_t>(colouring.values.size()), colouring),
                         options.font_size);
  return cv.to_image();
}

FlatLayout element_grid_layout(int rows, int cols, const ScalarColouring& colouring, int cell_pixels,
                               const std::string& title) {
  return frame_layout(cols * std::max(cell_pixels, 1), rows * std::max(cell_pixels, 1), title,
                      colour_bar_extent(colouring, Saturation{}, kTickFontSize));
}

io::RgbImage render_element_grid(const std::vector<double>& values, int rows, int cols, const ScalarColouring& colouring,
                                 int cell_pixels, const std::string& title) {
  if (rows <= 0 || cols <= 0 || values.size() != static_cast<std::size_t>(rows) * cols) {
    throw std::invalid_argument("render_element_grid: " + std::to_string(values.size()) + " values for a " +
                                std::to_string(rows) + " x " + std::to_string(cols) + " grid");
  }
  cell_pixels = std::max(cell_pixels, 1);
  const Saturation s = saturation_of(values.data(), values.size(), colouring);
  FlatLayout L = frame_layout(cols * cell_pixels, rows * cell_pixels, title, colour_bar_extent(colouring, s, kTickFontSize));
  const ColourTable table(colouring);
  io::RgbImage plot(L.plot_width, L.plot_height, 255);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const Rgb col = table(values[static_cast<std::size_t>(r) * cols + c]);
      // Row 0 is the bottom of the domain.
      for (int y = 0; y < cell_pixels; ++y)
        for (int x = 0; x < cell_pixels; ++x) put_pixel(plot, c * cell_pixels + x, (rows - 1 - r) * cell_pixels + y, col);
    }
  }
  Canvas cv(L.width, L.height);
  cv.image(plot, L.left, L.top);
  if (cell_pixels >= 6) draw_grid_lines(cv, L, cols, rows);
  draw_frame_decorations(cv, L, title, &colouring, s);
  return cv.to_image();
}

namespace {

struct HistogramStats {
  std::vector<double> finite;
  std::size_t excluded = 0;
  std::string caption;
};

HistogramStats histogram_stats(const std::vector<double>& series) {
  HistogramStats h;
  for (double x : series)
    if (std::isfinite(x)) h.finite.push_back(x);
  h.excluded = series.size() - h.finite.size();
  h.caption = "n = " + std::to_string(h.finite.size());
  if (!h.finite.empty()) {
    double sum = 0.0;
    for (double x : h.finite) sum += x;  // fixed order
    std::vector<double> sorted = h.finite;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t n = sorted.size();
    const double median = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
    h.caption += ", mean " + format_number(sum / n) + ", median " + format_number(median);
  }
  if (h.excluded > 0) h.caption += " (" + std::to_string(h.excluded) + " non-finite left out)";
  return h;
}

// One histogram panel: bars, axes with nice ticks, in the box [ox, ox + width) x [top, bottom).
void draw_histogram_panel(Canvas& cv, const std::vector<double>& v, int bins, double ox, double width, double top, double bottom) {
  const Rgb bar_fill{70, 130, 180}, bar_edge{35, 70, 110};
  double lo = *std::min_element(v.begin(), v.end()), hi = *std::max_element(v.begin(), v.end());
  if (!(hi > lo)) {
    const double pad = std::abs(lo) > 0 ? 0.1 * std::abs(lo) : 0.5;
    lo -= pad;
    hi += pad;
  }
  std::vector<long> counts(static_cast<std::size_t>(bins), 0);
  for (double x : v) ++counts[std::clamp(static_cast<int>((x - lo) / (hi - lo) * bins), 0, bins - 1)];
  const long max_count = *std::max_element(counts.begin(), counts.end());
  double ystep = 1.0;
  std::vector<double> yticks = nice_ticks(0.0, static_cast<double>(max_count), 4, &ystep);
  if (ystep < 1.0) {  // counts are integers
    ystep = 1.0;
    yticks.clear();
    for (long k = 0; k <= max_count; ++k) yticks.push_back(static_cast<double>(k));
  }
  double ylabel_width = 0;
  for (double t : yticks) ylabel_width = std::max(ylabel_width, text_width(format_tick(t, ystep), kTickFontSize));
  const double line = text_line_height(kTickFontSize);
  const int plot_left = static_cast<int>(ox + kMargin + ylabel_width + 6);
  const int plot_right = static_cast<int>(ox + width - kMargin - 8);
  const int plot_top = static_cast<int>(top), plot_bottom = static_cast<int>(bottom - line - 6);
  if (plot_right - plot_left < 10 || plot_bottom - plot_top < 10) return;
  const double plot_w = plot_right - plot_left, plot_h = plot_bottom - plot_top;
  auto px_of = [&](double x) { return plot_left + static_cast<int>(std::lround((x - lo) / (hi - lo) * plot_w)); };
  for (int b = 0; b < bins; ++b) {
    if (counts[b] == 0) continue;
    const int x0 = px_of(lo + (hi - lo) * b / bins), x1 = px_of(lo + (hi - lo) * (b + 1) / bins);
    const int h = std::max(1, static_cast<int>(std::lround(counts[b] / static_cast<double>(max_count) * plot_h)));
    cv.fill_rect(x0, plot_bottom - h, std::max(1, x1 - x0), h, bar_fill);
    if (x1 - x0 >= 4) cv.stroke_rect(x0, plot_bottom - h, x1 - x0 + 1, h, bar_edge);
  }
  TextStyle ts;
  ts.size = kTickFontSize;
  cv.line(plot_left + 0.5, plot_top, plot_left + 0.5, plot_bottom + 1, kBlack);
  cv.line(plot_left, plot_bottom + 0.5, plot_right + 1, plot_bottom + 0.5, kBlack);
  ts.align = Align::Right;
  for (double t : yticks) {
    const double yy = plot_bottom - std::lround(t / std::max<double>(max_count, 1) * plot_h) + 0.5;
    cv.line(plot_left - 4, yy, plot_left, yy, kBlack);
    cv.text(plot_left - 6, yy - line / 2, format_tick(t, ystep), ts);
  }
  ts.align = Align::Centre;
  double xstep = 1.0;
  for (double t : nice_ticks(lo, hi, 5, &xstep)) {
    const double xx = px_of(t) + 0.5;
    cv.line(xx, plot_bottom + 1, xx, plot_bottom + 5, kBlack);
    cv.text(xx, plot_bottom + 6, format_tick(t, xstep), ts);
  }
}

}  // namespace

io::RgbImage render_histograms(const std::vector<std::vector<double>>& series, const std::vector<std::string>& titles,
                               int bins, int width, int height) {
  if (series.empty()) throw std::invalid_argument("render_histograms: no series");
  bins = std::max(bins, 1);
  const int n = static_cast<int>(series.size());
  const int panel_width = std::max(width / n, 80);
  height = std::max(height, 100);
  Canvas cv(panel_width * n, height);
  for (int p = 0; p < n; ++p) {
    const double ox = p * panel_width;
    const HistogramStats stats = histogram_stats(series[p]);
    TextStyle ts;
    ts.align = Align::Centre;
    double y = kMargin;
    if (p < static_cast<int>(titles.size()) && !titles[p].empty()) {
      ts.size = kTitleFontSize;
      ts.bold = true;
      cv.text(ox + panel_width / 2.0, y, titles[p], ts);
      y += text_line_height(kTitleFontSize) + 4;
    }
    ts.size = 12.0;
    ts.bold = false;
    cv.text(ox + panel_width / 2.0, y, stats.caption, ts);
    y += text_line_height(12.0) + kMargin;
    if (stats.finite.empty()) {
      ts.size = kTitleFontSize;
      cv.text(ox + panel_width / 2.0, height / 2.0, "no data", ts);
      continue;
    }
    draw_histogram_panel(cv, stats.finite, bins, ox, panel_width, y, height - kMargin);
  }
  return cv.to_image();
}

io::RgbImage compose_horizontal(const std::vector<io::RgbImage>& images, int gap, const std::vector<std::string>& captions,
                                Rgb background) {
  gap = std::max(gap, 0);
  bool any_caption = false;
  for (const auto& c : captions) any_caption = any_caption || !c.empty();
  int width = 0, height = 0;
  for (const auto& im : images) {
    width += im.width;
    height = std::max(height, im.height);
  }
  if (!images.empty()) width += gap * (static_cast<int>(images.size()) - 1);
  const int caption_height = any_caption ? static_cast<int>(std::ceil(text_line_height(14.0))) + 12 : 0;
  Canvas cv(std::max(width, 1), std::max(height + caption_height, 1), background);
  TextStyle ts;
  ts.size = 14.0;
  ts.align = Align::Centre;
  int x = 0;
  for (std::size_t i = 0; i < images.size(); ++i) {
    cv.image(images[i], x, 0);
    if (i < captions.size() && !captions[i].empty()) cv.text(x + images[i].width / 2.0, height + 6, captions[i], ts);
    x += images[i].width + gap;
  }
  return cv.to_image();
}

}  // namespace authalic::analysis

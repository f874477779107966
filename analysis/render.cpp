// Software rendering of flat maps, element images, 3D surface views and histograms
// (see analysis/render.h). Everything is rasterised on the CPU into an io::RgbImage with integer
// pixel arithmetic and a fixed drawing order, so the same input always gives the same bytes.
#include "analysis/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "analysis/raster.h"
#include "core/error.h"

namespace authalic::analysis {

namespace {

using raster::Colour;

// ---- colour maps ------------------------------------------------------------------------

struct ControlPoint {
  double t, r, g, b;  // position in [0,1], colour in [0,1]
};

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

std::uint8_t to_byte(double v) { return static_cast<std::uint8_t>(std::clamp(std::lround(v * 255.0), 0L, 255L)); }

// A colour map resolved once (name -> control points), then evaluated per pixel exactly as
// colormap() would, so colour_of() and the pictures agree to the byte.
class ColourTable {
 public:
  explicit ColourTable(const ScalarColouring& c) : nan_(c.nan_colour), vmin_(c.vmin), vmax_(c.vmax) {
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
  Rgb operator()(double v) const {
    if (!std::isfinite(v)) return nan_;
    const double range = vmax_ - vmin_;
    return at(range > 0 ? (v - vmin_) / range : 0.5);
  }
  Rgb at(double t) const {
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

 private:
  enum class Kind { Gray, Hot, Points };
  Kind kind_ = Kind::Gray;
  const std::vector<ControlPoint>* points_ = nullptr;
  bool reversed_ = false;
  Rgb nan_;
  double vmin_, vmax_;
};

const Colour kBlack{0, 0, 0};
const Colour kWhite{255, 255, 255};
const Colour kPlainSurface{210, 210, 210};

bool has_values(const ScalarColouring& c) { return c.values.size() > 0; }

// ---- colour bar ---------------------------------------------------------------------------

struct ColourBarGeometry {
  int gap, bar_width, tick_length, extent;
};

std::vector<std::string> colour_bar_labels(const ScalarColouring& c, std::vector<double>* ticks) {
  double step = 1.0;
  *ticks = raster::nice_ticks(c.vmin, c.vmax, 5, &step);
  std::vector<std::string> labels;
  for (double t : *ticks) labels.push_back(raster::format_tick(t, step));
  return labels;
}

ColourBarGeometry colour_bar_geometry(const ScalarColouring& c, int scale) {
  ColourBarGeometry g{};
  g.gap = 8 * scale;
  g.bar_width = 10 * scale;
  g.tick_length = 3 * scale;
  std::vector<double> ticks;
  int label_width = 0;
  for (const auto& s : colour_bar_labels(c, &ticks)) label_width = std::max(label_width, raster::text_width(s, scale));
  const int body = g.bar_width + g.tick_length + 2 * scale + label_width;
  g.extent = g.gap + std::max(body, raster::text_width(c.label, scale)) + 2 * scale;
  return g;
}

// Vertical bar with vmin at the bottom; the units label above it; ticks at nice values.
void draw_colour_bar(io::RgbImage& img, int x, int top, int height, const ScalarColouring& c, int scale) {
  const ColourBarGeometry g = colour_bar_geometry(c, scale);
  const ColourTable table(c);
  const int th = raster::text_height(scale);
  int bar_top = top + th / 2;
  if (!c.label.empty()) {
    raster::draw_text(img, x + g.gap, top, c.label, kBlack, scale);
    bar_top += th + 3 * scale;
  }
  const int bar_bottom = top + height - th / 2;  // exclusive
  const int bar_height = bar_bottom - bar_top;
  if (bar_height < 4) return;
  const int bx = x + g.gap;
  for (int r = 0; r < bar_height; ++r) {
    const double t = bar_height > 1 ? 1.0 - double(r) / (bar_height - 1) : 0.5;  // both ends shown
    const Rgb col = table.at(t);
    raster::fill_rect(img, bx, bar_top + r, g.bar_width, 1, col);
  }
  raster::draw_rect(img, bx - 1, bar_top - 1, g.bar_width + 2, bar_height + 2, kBlack);
  std::vector<double> ticks;
  const auto labels = colour_bar_labels(c, &ticks);
  const double range = c.vmax - c.vmin;
  for (std::size_t i = 0; i < ticks.size(); ++i) {
    const double f = range > 0 ? (ticks[i] - c.vmin) / range : 0.5;
    const int y = bar_top + static_cast<int>(std::lround((1.0 - f) * (bar_height - 1)));
    raster::fill_rect(img, bx + g.bar_width, y, g.tick_length, std::max(1, scale / 2), kBlack);
    raster::draw_text(img, bx + g.bar_width + g.tick_length + 2 * scale, y - th / 2, labels[i], kBlack, scale);
  }
}

// ---- layout shared by the flat map and the element image ----------------------------------

FlatLayout frame_layout(int plot_width, int plot_height, const std::string& title, bool bar, const ScalarColouring& c,
                        int scale) {
  FlatLayout L;
  L.text_scale = scale;
  const int m = 6 * scale;
  const int title_height = title.empty() ? 0 : raster::text_height(scale + 1) + m;
  L.left = m;
  L.top = m + title_height;
  L.plot_width = plot_width;
  L.plot_height = plot_height;
  const int right = bar ? colour_bar_geometry(c, scale).extent + m : m;
  L.width = std::max(L.left + plot_width + right, raster::text_width(title, scale + 1) + 2 * m);
  L.height = L.top + plot_height + m;
  return L;
}

void draw_frame_decorations(io::RgbImage& img, const FlatLayout& L, const std::string& title, bool bar,
                            const ScalarColouring& c) {
  const int s = L.text_scale;
  // The frame sits just outside the plot so it never hides data.
  raster::draw_rect(img, L.left - 1, L.top - 1, L.plot_width + 2, L.plot_height + 2, kBlack);
  if (!title.empty()) {
    // Centred over the plot, but never past the picture's left edge (a title wider than the plot).
    const int half = raster::text_width(title, s + 1) / 2;
    raster::draw_text_centred(img, std::max(L.left + L.plot_width / 2, half + 2 * s), 6 * s, title, kBlack, s + 1);
  }
  if (bar) draw_colour_bar(img, L.left + L.plot_width + 1, L.top, L.plot_height, c, s);
}

// Thin dark lines over the element-grid boundaries (blended so they read on any colour).
void draw_grid_lines(io::RgbImage& img, const FlatLayout& L, int cols, int rows) {
  const Colour dark{20, 20, 20};
  const double alpha = 0.6;
  for (int c = 1; c < cols; ++c) {
    const int x = std::min(L.left + static_cast<int>(std::floor(double(c) * L.plot_width / cols)), L.left + L.plot_width - 1);
    for (int y = L.top; y < L.top + L.plot_height; ++y) raster::blend_pixel(img, x, y, dark, alpha);
  }
  for (int r = 1; r < rows; ++r) {
    // Row lines counted from the bottom of the domain (y grows upwards).
    const int y = std::max(L.top + L.plot_height - 1 - static_cast<int>(std::floor(double(r) * L.plot_height / rows)), L.top);
    for (int x = L.left; x < L.left + L.plot_width; ++x) {
      // Do not darken crossings twice.
      bool on_column = false;
      for (int c = 1; c < cols && !on_column; ++c) {
        on_column = x == std::min(L.left + static_cast<int>(std::floor(double(c) * L.plot_width / cols)), L.left + L.plot_width - 1);
      }
      if (!on_column) raster::blend_pixel(img, x, y, dark, alpha);
    }
  }
}

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

void check_mesh(const MatrixXd& V, const MatrixXi& F, const ScalarColouring& c, int min_cols, const char* who) {
  if (V.cols() < min_cols) {
    throw std::invalid_argument(std::string(who) + ": vertex matrix needs at least " + std::to_string(min_cols) + " columns");
  }
  if (F.size() > 0 && (F.cols() != 3 || F.minCoeff() < 0 || F.maxCoeff() >= V.rows())) {
    throw std::invalid_argument(std::string(who) + ": face indices out of range of the " + std::to_string(V.rows()) +
                                " vertices");
  }
  if (has_values(c) && c.values.size() != V.rows()) {
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(c.values.size()) + " values for " +
                                std::to_string(V.rows()) + " vertices");
  }
}

// Interpolated value at a pixel; a NaN corner makes the pixel take its nearest corner's value.
double pixel_value(const ScalarColouring& c, const int* f, double w0, double w1, double w2) {
  const double a = c.values[f[0]], b = c.values[f[1]], d = c.values[f[2]];
  if (std::isfinite(a) && std::isfinite(b) && std::isfinite(d)) return w0 * a + w1 * b + w2 * d;
  if (w0 >= w1 && w0 >= w2) return a;
  return w1 >= w2 ? b : d;
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
  const int scale = options.width >= 480 ? 2 : 1;
  const bool bar = options.draw_colour_bar && has_values(colouring);
  // The plot takes what the margins and the colour bar leave of the requested width.
  const FlatLayout probe = frame_layout(0, 0, {}, bar, colouring, scale);
  const int plot_width = std::max(16, options.width - probe.width);
  const int plot_height = std::max(1, static_cast<int>(std::lround(plot_width * options.domain_height / options.domain_width)));
  return frame_layout(plot_width, plot_height, options.title, bar, colouring, scale);
}

io::RgbImage render_flat(const MatrixXd& UV, const MatrixXi& F, const ScalarColouring& colouring,
                         const FlatRenderOptions& options) {
  check_mesh(UV, F, colouring, 2, "render_flat");
  const FlatLayout L = flat_layout(options, colouring);
  const bool bar = options.draw_colour_bar && has_values(colouring);
  io::RgbImage img(L.width, L.height, 255);
  const ColourTable table(colouring);

  const double sx = L.plot_width / options.domain_width, sy = L.plot_height / options.domain_height;
  for (int f = 0; f < F.rows(); ++f) {
    const int idx[3] = {F(f, 0), F(f, 1), F(f, 2)};
    double X[3], Y[3];
    for (int k = 0; k < 3; ++k) {
      X[k] = L.left + (UV(idx[k], 0) - options.x0) * sx;
      Y[k] = L.top + L.plot_height - (UV(idx[k], 1) - options.y0) * sy;
    }
    rasterise_triangle(X, Y, L.left, L.top, L.left + L.plot_width, L.top + L.plot_height,
                       [&](int px, int py, double w0, double w1, double w2) {
                         const Rgb col = has_values(colouring) ? table(pixel_value(colouring, idx, w0, w1, w2)) : kPlainSurface;
                         raster::set_pixel(img, px, py, col);
                       });
  }
  if (options.grid_cols > 0 || options.grid_rows > 0) draw_grid_lines(img, L, options.grid_cols, options.grid_rows);
  draw_frame_decorations(img, L, options.title, bar, colouring);
  return img;
}

FlatLayout element_grid_layout(int rows, int cols, const ScalarColouring& colouring, int cell_pixels,
                               const std::string& title) {
  cell_pixels = std::max(cell_pixels, 1);
  const int scale = cols * cell_pixels >= 300 ? 2 : 1;
  return frame_layout(cols * cell_pixels, rows * cell_pixels, title, true, colouring, scale);
}

io::RgbImage render_element_grid(const std::vector<double>& values, int rows, int cols, const ScalarColouring& colouring,
                                 int cell_pixels, const std::string& title) {
  if (rows <= 0 || cols <= 0 || values.size() != static_cast<std::size_t>(rows) * cols) {
    throw std::invalid_argument("render_element_grid: " + std::to_string(values.size()) + " values for a " +
                                std::to_string(rows) + " x " + std::to_string(cols) + " grid");
  }
  cell_pixels = std::max(cell_pixels, 1);
  const FlatLayout L = element_grid_layout(rows, cols, colouring, cell_pixels, title);
  io::RgbImage img(L.width, L.height, 255);
  const ColourTable table(colouring);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const Rgb col = table(values[static_cast<std::size_t>(r) * cols + c]);
      // Row 0 is the bottom of the domain.
      raster::fill_rect(img, L.left + c * cell_pixels, L.top + (rows - 1 - r) * cell_pixels, cell_pixels, cell_pixels, col);
    }
  }
  if (cell_pixels >= 6) draw_grid_lines(img, L, cols, rows);
  draw_frame_decorations(img, L, title, true, colouring);
  return img;
}

std::string view_name(View view) {
  switch (view) {
    case View::Lateral: return "lateral";
    case View::Medial: return "medial";
    case View::Superior: return "superior";
    case View::Inferior: return "inferior";
    case View::Anterior: return "anterior";
    case View::Posterior: return "posterior";
  }
  return "view";
}

ViewBasis view_basis(View view, bool left_hemisphere) {
  // Camera looks along d with up u; screen right = d x u; depth grows toward the viewer (-d).
  Eigen::Vector3d d(0, 0, -1), u(0, 0, 1);
  const double lateral_sign = left_hemisphere ? 1.0 : -1.0;  // lateral of the left looks along +x (from -x)
  switch (view) {
    case View::Lateral: d = Eigen::Vector3d(lateral_sign, 0, 0); break;
    case View::Medial: d = Eigen::Vector3d(-lateral_sign, 0, 0); break;
    case View::Superior:
      d = Eigen::Vector3d(0, 0, -1);
      u = Eigen::Vector3d(0, 1, 0);
      break;
    case View::Inferior:
      d = Eigen::Vector3d(0, 0, 1);
      u = Eigen::Vector3d(0, 1, 0);
      break;
    case View::Anterior: d = Eigen::Vector3d(0, -1, 0); break;
    case View::Posterior: d = Eigen::Vector3d(0, 1, 0); break;
  }
  return {d.cross(u), u, -d};
}

io::RgbImage render_surface_views(const MatrixXd& V, const MatrixXi& F, const ScalarColouring& colouring,
                                  const std::vector<View>& views, const SurfaceRenderOptions& options,
                                  const VectorXi* boundary_labels) {
  check_mesh(V, F, colouring, 3, "render_surface_views");
  if (views.empty()) throw std::invalid_argument("render_surface_views: no view requested");
  if (boundary_labels && boundary_labels->size() != V.rows()) {
    throw std::invalid_argument("render_surface_views: " + std::to_string(boundary_labels->size()) + " labels for " +
                                std::to_string(V.rows()) + " vertices");
  }
  const int W = std::max(options.width, 32), H = std::max(options.height, 32);
  const int s = W >= 300 ? 2 : 1;
  const int m = 6 * s;
  const bool bar = options.draw_colour_bar && has_values(colouring);
  const int title_height = options.title.empty() ? 0 : raster::text_height(s + 1) + m;
  const int top = m + title_height;
  const int caption_height = raster::text_height(s) + m;
  const int n = static_cast<int>(views.size());
  const int bar_extent = bar ? colour_bar_geometry(colouring, s).extent + m : 0;
  io::RgbImage img(std::max(n * W + bar_extent, raster::text_width(options.title, s + 1) + 2 * m), top + H + caption_height + m,
                   255);
  if (!options.title.empty()) raster::draw_text_centred(img, (n * W) / 2, m, options.title, kBlack, s + 1);

  std::vector<bool> used(static_cast<std::size_t>(V.rows()), false);
  for (int f = 0; f < F.rows(); ++f) {
    for (int k = 0; k < 3; ++k) used[F(f, k)] = true;
  }
  const MatrixXd N = F.rows() > 0 ? vertex_normals(V, F) : MatrixXd::Zero(V.rows(), 3);
  const ColourTable table(colouring);

  // One scale for all panels (mm per pixel the same in every view), each panel centred on its
  // own projection.
  std::vector<ViewBasis> bases;
  std::vector<Eigen::Vector2d> centres;
  double scale = std::numeric_limits<double>::infinity();
  double depth_extent = 0.0;
  for (View view : views) {
    const ViewBasis b = view_basis(view, options.left_hemisphere);
    Eigen::Vector2d lo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
    Eigen::Vector2d hi = -lo;
    double zlo = lo.x(), zhi = -lo.x();
    for (int v = 0; v < V.rows(); ++v) {
      if (!used[v]) continue;
      const Eigen::Vector3d p = V.row(v).transpose();
      const Eigen::Vector2d q(p.dot(b.right), p.dot(b.up));
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
      zlo = std::min(zlo, p.dot(b.toward_viewer));
      zhi = std::max(zhi, p.dot(b.toward_viewer));
    }
    if (!std::isfinite(lo.x())) lo = hi = Eigen::Vector2d::Zero();
    const Eigen::Vector2d ext = (hi - lo).cwiseMax(1e-9);
    scale = std::min({scale, (W - 2.0 * m) / ext.x(), (H - 2.0 * m) / ext.y()});
    depth_extent = std::max(depth_extent, std::isfinite(zhi - zlo) ? zhi - zlo : 0.0);
    bases.push_back(b);
    centres.push_back(0.5 * (lo + hi));
  }
  if (!std::isfinite(scale)) scale = 1.0;
  // Boundary lines pass the depth test within this tolerance (they lie on the surface).
  const double depth_tolerance = std::max(1e-6, 0.01 * depth_extent);
  const int line_thickness = W >= 700 ? 2 : 1;

  for (int vi = 0; vi < n; ++vi) {
    const ViewBasis& b = bases[vi];
    const int ox = vi * W, oy = top;
    std::vector<double> zbuf(static_cast<std::size_t>(W) * H, -std::numeric_limits<double>::infinity());
    auto project = [&](const Eigen::Vector3d& p, double* X, double* Y, double* Z) {
      *X = W / 2.0 + (p.dot(b.right) - centres[vi].x()) * scale;
      *Y = H / 2.0 - (p.dot(b.up) - centres[vi].y()) * scale;
      *Z = p.dot(b.toward_viewer);
    };
    for (int f = 0; f < F.rows(); ++f) {
      const int idx[3] = {F(f, 0), F(f, 1), F(f, 2)};
      double X[3], Y[3], Z[3];
      for (int k = 0; k < 3; ++k) project(V.row(idx[k]).transpose(), &X[k], &Y[k], &Z[k]);
      rasterise_triangle(X, Y, 0, 0, W, H, [&](int px, int py, double w0, double w1, double w2) {
        const double z = w0 * Z[0] + w1 * Z[1] + w2 * Z[2];
        double& zb = zbuf[static_cast<std::size_t>(py) * W + px];
        if (!(z > zb)) return;  // strictly nearer wins; ties keep the first face drawn
        zb = z;
        Eigen::Vector3d normal = w0 * N.row(idx[0]).transpose() + w1 * N.row(idx[1]).transpose() + w2 * N.row(idx[2]).transpose();
        const double len = normal.norm();
        // Lambert with a head-light plus ambient; two-sided so open patches shade too.
        const double lambert = len > 0 ? std::abs(normal.dot(b.toward_viewer)) / len : 1.0;
        const double intensity = 0.3 + 0.7 * lambert;
        const Rgb base = has_values(colouring) ? table(pixel_value(colouring, idx, w0, w1, w2)) : kPlainSurface;
        const Colour shaded{to_byte(base[0] / 255.0 * intensity), to_byte(base[1] / 255.0 * intensity),
                            to_byte(base[2] / 255.0 * intensity)};
        raster::set_pixel(img, ox + px, oy + py, shaded);
      });
    }
    if (boundary_labels) {
      // Label boundaries: in each triangle with mixed labels, segments between the midpoints of
      // its mixed edges (through the centroid when all three differ), drawn where visible.
      auto draw_segment = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& c) {
        double ax, ay, az, cx, cy, cz;
        project(a, &ax, &ay, &az);
        project(c, &cx, &cy, &cz);
        const int steps = std::max(1, static_cast<int>(std::ceil(2.0 * std::max(std::abs(cx - ax), std::abs(cy - ay)))));
        for (int k = 0; k <= steps; ++k) {
          const double t = double(k) / steps;
          const double x = ax + t * (cx - ax), y = ay + t * (cy - ay), z = az + t * (cz - az);
          const int px = static_cast<int>(std::floor(x)), py = static_cast<int>(std::floor(y));
          if (px < 0 || py < 0 || px >= W || py >= H) continue;
          if (z < zbuf[static_cast<std::size_t>(py) * W + px] - depth_tolerance) continue;  // hidden
          for (int dy = 0; dy < line_thickness; ++dy) {
            for (int dx = 0; dx < line_thickness; ++dx) {
              if (px + dx < W && py + dy < H) raster::set_pixel(img, ox + px + dx, oy + py + dy, kBlack);
            }
          }
        }
      };
      const VectorXi& lab = *boundary_labels;
      for (int f = 0; f < F.rows(); ++f) {
        const int i0 = F(f, 0), i1 = F(f, 1), i2 = F(f, 2);
        const int l0 = lab(i0), l1 = lab(i1), l2 = lab(i2);
        if (l0 == l1 && l1 == l2) continue;
        const Eigen::Vector3d p0 = V.row(i0).transpose(), p1 = V.row(i1).transpose(), p2 = V.row(i2).transpose();
        const Eigen::Vector3d m01 = 0.5 * (p0 + p1), m12 = 0.5 * (p1 + p2), m20 = 0.5 * (p2 + p0);
        if (l0 != l1 && l1 != l2 && l0 != l2) {
          const Eigen::Vector3d centroid = (p0 + p1 + p2) / 3.0;
          draw_segment(m01, centroid);
          draw_segment(m12, centroid);
          draw_segment(m20, centroid);
        } else if (l0 == l1) {
          draw_segment(m12, m20);
        } else if (l1 == l2) {
          draw_segment(m01, m20);
        } else {
          draw_segment(m01, m12);
        }
      }
    }
    raster::draw_text_centred(img, ox + W / 2, oy + H + m / 2, view_name(views[vi]), kBlack, s);
  }
  if (bar) draw_colour_bar(img, n * W, top + H / 8, H - H / 4, colouring, s);
  return img;
}

io::RgbImage render_histograms(const std::vector<std::vector<double>>& series, const std::vector<std::string>& titles,
                               int bins, int width, int height) {
  if (series.empty()) throw std::invalid_argument("render_histograms: no series");
  bins = std::max(bins, 1);
  const int n = static_cast<int>(series.size());
  const int panel_width = std::max(width / n, 60);
  height = std::max(height, 80);
  io::RgbImage img(panel_width * n, height, 255);
  const Colour bar_fill{70, 130, 180}, bar_edge{35, 70, 110};
  for (int p = 0; p < n; ++p) {
    const int s = panel_width >= 350 ? 2 : 1;
    const int cs = std::max(1, s - 1);  // caption scale
    const int m = 6 * s;
    const int ox = p * panel_width;
    std::vector<double> v;
    for (double x : series[p]) {
      if (std::isfinite(x)) v.push_back(x);
    }
    const std::size_t excluded = series[p].size() - v.size();
    int y = m;
    if (p < static_cast<int>(titles.size()) && !titles[p].empty()) {
      raster::draw_text_centred(img, ox + panel_width / 2, y, titles[p], kBlack, s);
      y += raster::text_height(s) + s * 3;
    }
    std::string caption = "n=" + std::to_string(v.size());
    if (!v.empty()) {
      double sum = 0.0;
      for (double x : v) sum += x;  // fixed order
      std::vector<double> sorted = v;
      std::sort(sorted.begin(), sorted.end());
      const double median = sorted.size() % 2 ? sorted[sorted.size() / 2]
                                              : 0.5 * (sorted[sorted.size() / 2 - 1] + sorted[sorted.size() / 2]);
      caption += "  mean " + raster::format_number(sum / v.size()) + "  median " + raster::format_number(median);
    }
    if (excluded > 0) caption += "  (" + std::to_string(excluded) + " non-finite left out)";
    raster::draw_text_centred(img, ox + panel_width / 2, y, caption, kBlack, cs);
    y += raster::text_height(cs) + m;

    if (v.empty()) {
      raster::draw_text_centred(img, ox + panel_width / 2, height / 2, "no data", kBlack, s);
      continue;
    }
    double lo = *std::min_element(v.begin(), v.end()), hi = *std::max_element(v.begin(), v.end());
    if (!(hi > lo)) {
      const double pad = std::abs(lo) > 0 ? 0.1 * std::abs(lo) : 0.5;
      lo -= pad;
      hi += pad;
    }
    std::vector<long> counts(static_cast<std::size_t>(bins), 0);
    for (double x : v) {
      const int b = std::clamp(static_cast<int>((x - lo) / (hi - lo) * bins), 0, bins - 1);
      ++counts[b];
    }
    const long max_count = *std::max_element(counts.begin(), counts.end());
    double ystep = 1.0;
    std::vector<double> yticks = raster::nice_ticks(0.0, static_cast<double>(max_count), 4, &ystep);
    if (ystep < 1.0) {  // counts are integers
      ystep = 1.0;
      yticks.clear();
      for (long k = 0; k <= max_count; ++k) yticks.push_back(static_cast<double>(k));
    }
    int ylabel_width = 0;
    for (double t : yticks) ylabel_width = std::max(ylabel_width, raster::text_width(raster::format_tick(t, ystep), cs));
    const int plot_left = ox + m + ylabel_width + 3 * s;
    const int plot_right = ox + panel_width - m - 2 * s;
    const int plot_top = y;
    const int plot_bottom = height - m - raster::text_height(cs) - 3 * s;  // x axis row
    if (plot_right - plot_left < 10 || plot_bottom - plot_top < 10) continue;
    const double plot_w = plot_right - plot_left, plot_h = plot_bottom - plot_top;
    auto px_of = [&](double x) { return plot_left + static_cast<int>(std::lround((x - lo) / (hi - lo) * plot_w)); };
    for (int b = 0; b < bins; ++b) {
      if (counts[b] == 0) continue;
      const int x0 = px_of(lo + (hi - lo) * b / bins), x1 = px_of(lo + (hi - lo) * (b + 1) / bins);
      const int h = std::max(1, static_cast<int>(std::lround(counts[b] / static_cast<double>(max_count) * plot_h)));
      raster::fill_rect(img, x0, plot_bottom - h, std::max(1, x1 - x0), h, bar_fill);
      if (x1 - x0 >= 4) raster::draw_rect(img, x0, plot_bottom - h, x1 - x0 + 1, h, bar_edge);
    }
    // Axes, ticks and tick labels.
    raster::fill_rect(img, plot_left, plot_top, 1, plot_bottom - plot_top + 1, kBlack);
    raster::fill_rect(img, plot_left, plot_bottom, plot_right - plot_left + 1, 1, kBlack);
    for (double t : yticks) {
      const int yy = plot_bottom - static_cast<int>(std::lround(t / std::max<double>(max_count, 1) * plot_h));
      raster::fill_rect(img, plot_left - 2 * s, yy, 2 * s, 1, kBlack);
      const std::string label = raster::format_tick(t, ystep);
      raster::draw_text(img, plot_left - 3 * s - raster::text_width(label, cs), yy - raster::text_height(cs) / 2, label, kBlack, cs);
    }
    double xstep = 1.0;
    for (double t : raster::nice_ticks(lo, hi, 5, &xstep)) {
      const int xx = px_of(t);
      raster::fill_rect(img, xx, plot_bottom + 1, 1, 2 * s, kBlack);
      raster::draw_text_centred(img, xx, plot_bottom + 3 * s, raster::format_tick(t, xstep), kBlack, cs);
    }
  }
  return img;
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
  const int scale = 2;
  const int caption_height = any_caption ? raster::text_height(scale) + 12 : 0;
  io::RgbImage out(std::max(width, 1), std::max(height + caption_height, 1), 255);
  raster::fill_rect(out, 0, 0, out.width, out.height, background);
  int x = 0;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const auto& im = images[i];
    for (int yy = 0; yy < im.height; ++yy) {
      std::copy(im.pixel(0, yy), im.pixel(0, yy) + 3 * static_cast<std::size_t>(im.width), out.pixel(x, yy));
    }
    if (i < captions.size() && !captions[i].empty()) {
      raster::draw_text_centred(out, x + im.width / 2, height + 6, captions[i], kBlack, scale);
    }
    x += im.width + gap;
  }
  return out;
}

}  // namespace authalic::analysis

// 2D drawing through Cairo (see analysis/canvas.h).
#include "analysis/canvas.h"

#include <cairo-pdf.h>
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace authalic::analysis {

namespace {

// DejaVu Sans (Debian fonts-dejavu-core, a dependency of fontconfig): wide Unicode coverage
// (Greek, mathematical minus, <=), metric-stable from machine to machine.
constexpr const char* kFontFamily = "DejaVu Sans";

void select_font(cairo_t* cr, double size, bool bold) {
  cairo_select_font_face(cr, kFontFamily, CAIRO_FONT_SLANT_NORMAL, bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
}

// A 1 x 1 image context for measuring text outside any canvas (one per thread: Cairo contexts
// are not shared between threads).
cairo_t* measuring_context() {
  struct Holder {
    cairo_surface_t* s = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, 1, 1);
    cairo_t* cr = cairo_create(s);
    ~Holder() {
      cairo_destroy(cr);
      cairo_surface_destroy(s);
    }
  };
  thread_local Holder holder;
  return holder.cr;
}

double measure(cairo_t* cr, const std::string& text) {
  cairo_text_extents_t e;
  cairo_text_extents(cr, text.c_str(), &e);
  return e.x_advance;
}

}  // namespace

Canvas::Canvas(int width, int height, Rgb background) : width_(std::max(width, 1)), height_(std::max(height, 1)) {
  surface_ = cairo_image_surface_create(CAIRO_FORMAT_RGB24, static_cast<int>(width_), static_cast<int>(height_));
  cr_ = cairo_create(surface_);
  if (cairo_status(cr_) != CAIRO_STATUS_SUCCESS) throw std::runtime_error("cairo: cannot create a " + std::to_string(width) + " x " + std::to_string(height) + " image");
  set_colour(background);
  cairo_paint(cr_);
}

std::unique_ptr<Canvas> Canvas::pdf(std::string* out, double width_pt, double height_pt) {
  std::unique_ptr<Canvas> c(new Canvas());
  c->width_ = width_pt;
  c->height_ = height_pt;
  auto append = [](void* closure, const unsigned char* data, unsigned int length) {
    static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
    return CAIRO_STATUS_SUCCESS;
  };
  c->surface_ = cairo_pdf_surface_create_for_stream(append, out, width_pt, height_pt);
  if (cairo_surface_status(c->surface_) != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(c->surface_);
    c->surface_ = nullptr;
    throw std::runtime_error("cairo: cannot create a PDF surface");
  }
  // No creation date: the same report gives the same bytes.
  cairo_pdf_surface_set_metadata(c->surface_, CAIRO_PDF_METADATA_CREATE_DATE, "");
  cairo_pdf_surface_set_metadata(c->surface_, CAIRO_PDF_METADATA_CREATOR, "authalic");
  c->cr_ = cairo_create(c->surface_);
  return c;
}

Canvas::~Canvas() {
  if (cr_) cairo_destroy(cr_);
  if (surface_) {
    cairo_surface_finish(surface_);
    cairo_surface_destroy(surface_);
  }
}

void Canvas::set_colour(const Rgb& c, double alpha) {
  cairo_set_source_rgba(cr_, c[0] / 255.0, c[1] / 255.0, c[2] / 255.0, alpha);
}

void Canvas::set_font(const TextStyle& style) { select_font(cr_, style.size, style.bold); }

void Canvas::fill_rect(double x, double y, double w, double h, const Rgb& colour, double alpha) {
  if (w <= 0 || h <= 0) return;
  set_colour(colour, alpha);
  cairo_rectangle(cr_, x, y, w, h);
  cairo_fill(cr_);
}

void Canvas::stroke_rect(double x, double y, double w, double h, const Rgb& colour, double line_width) {
  set_colour(colour);
  cairo_set_line_width(cr_, line_width);
  const double inset = line_width / 2.0;
  cairo_rectangle(cr_, x + inset, y + inset, w - line_width, h - line_width);
  cairo_stroke(cr_);
}

void Canvas::line(double x0, double y0, double x1, double y1, const Rgb& colour, double width, double alpha) {
  set_colour(colour, alpha);
  cairo_set_line_width(cr_, width);
  cairo_set_line_cap(cr_, CAIRO_LINE_CAP_BUTT);
  cairo_move_to(cr_, x0, y0);
  cairo_line_to(cr_, x1, y1);
  cairo_stroke(cr_);
}

void Canvas::fill_polygon(const std::vector<double>& xy, const Rgb& colour) {
  if (xy.size() < 6) return;
  set_colour(colour);
  cairo_move_to(cr_, xy[0], xy[1]);
  for (std::size_t i = 2; i + 1 < xy.size(); i += 2) cairo_line_to(cr_, xy[i], xy[i + 1]);
  cairo_close_path(cr_);
  cairo_fill(cr_);
}

void Canvas::image(const io::RgbImage& picture, double x, double y, double scale) {
  if (picture.width <= 0 || picture.height <= 0) return;
  cairo_surface_t* img = cairo_image_surface_create(CAIRO_FORMAT_RGB24, picture.width, picture.height);
  cairo_surface_flush(img);
  unsigned char* data = cairo_image_surface_get_data(img);
  const int stride = cairo_image_surface_get_stride(img);
  for (int r = 0; r < picture.height; ++r) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::size_t>(r) * stride);
    for (int c = 0; c < picture.width; ++c) {
      const std::uint8_t* p = picture.pixel(c, r);
      row[c] = (std::uint32_t{p[0]} << 16) | (std::uint32_t{p[1]} << 8) | p[2];
    }
  }
  cairo_surface_mark_dirty(img);
  cairo_save(cr_);
  cairo_translate(cr_, x, y);
  cairo_scale(cr_, scale, scale);
  cairo_set_source_surface(cr_, img, 0, 0);
  if (scale == 1.0) cairo_pattern_set_filter(cairo_get_source(cr_), CAIRO_FILTER_NEAREST);
  cairo_rectangle(cr_, 0, 0, picture.width, picture.height);
  cairo_fill(cr_);
  cairo_restore(cr_);
  cairo_surface_destroy(img);
}

double Canvas::text(double x, double y, const std::string& text, const TextStyle& style) {
  if (text.empty()) return 0.0;
  set_font(style);
  cairo_font_extents_t fe;
  cairo_font_extents(cr_, &fe);
  const double w = measure(cr_, text);
  const double left = style.align == Align::Left ? x : style.align == Align::Centre ? x - w / 2.0 : x - w;
  set_colour(style.colour);
  cairo_move_to(cr_, left, y + fe.ascent);
  cairo_show_text(cr_, text.c_str());
  cairo_new_path(cr_);
  return w;
}

double Canvas::paragraph(double x, double y, double max_width, const std::string& text, const TextStyle& style) {
  const double pitch = 1.3 * style.size;
  double used = 0.0;
  for (const std::string& line : wrap_text(text, style.size, max_width, style.bold)) {
    this->text(x, y + used, line, style);
    used += pitch;
  }
  return used;
}

void Canvas::next_page() { cairo_show_page(cr_); }

void Canvas::finish() {
  if (cr_) {
    cairo_destroy(cr_);
    cr_ = nullptr;
  }
  if (surface_) {
    cairo_surface_finish(surface_);
    const cairo_status_t status = cairo_surface_status(surface_);
    cairo_surface_destroy(surface_);
    surface_ = nullptr;
    if (status != CAIRO_STATUS_SUCCESS) throw std::runtime_error(std::string("cairo: ") + cairo_status_to_string(status));
  }
}

io::RgbImage Canvas::to_image() const {
  if (!surface_ || cairo_surface_get_type(surface_) != CAIRO_SURFACE_TYPE_IMAGE)
    throw std::logic_error("Canvas::to_image: not an image canvas");
  cairo_surface_flush(surface_);
  const int w = cairo_image_surface_get_width(surface_), h = cairo_image_surface_get_height(surface_);
  const int stride = cairo_image_surface_get_stride(surface_);
  const unsigned char* data = cairo_image_surface_get_data(surface_);
  io::RgbImage out(w, h);
  for (int r = 0; r < h; ++r) {
    const auto* row = reinterpret_cast<const std::uint32_t*>(data + static_cast<std::size_t>(r) * stride);
    for (int c = 0; c < w; ++c) {
      std::uint8_t* p = out.pixel(c, r);
      p[0] = static_cast<std::uint8_t>(row[c] >> 16);
      p[1] = static_cast<std::uint8_t>(row[c] >> 8);
      p[2] = static_cast<std::uint8_t>(row[c]);
    }
  }
  return out;
}

double text_width(const std::string& text, double size, bool bold) {
  cairo_t* cr = measuring_context();
  select_font(cr, size, bold);
  return measure(cr, text);
}

double text_line_height(double size) {
  cairo_t* cr = measuring_context();
  select_font(cr, size, false);
  cairo_font_extents_t fe;
  cairo_font_extents(cr, &fe);
  return fe.ascent + fe.descent;
}

std::vector<std::string> wrap_text(const std::string& text, double size, double max_width, bool bold) {
  std::vector<std::string> lines;
  std::istringstream words(text);
  std::string word, line;
  while (words >> word) {
    const std::string candidate = line.empty() ? word : line + " " + word;
    if (!line.empty() && text_width(candidate, size, bold) > max_width) {
      lines.push_back(line);
      line = word;
    } else {
      line = candidate;
    }
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

std::vector<double> nice_ticks(double lo, double hi, int target, double* step_out) {
  std::vector<double> ticks;
  if (!std::isfinite(lo) || !std::isfinite(hi)) return ticks;
  if (hi < lo) std::swap(lo, hi);
  // A range lost in rounding (constant values whose means differ in the last bits) is one value:
  // a step of 1e-17 at 1.0 never advanced k (k + 1 == k beyond 2^53), and the ticks filled memory.
  if (hi - lo <= 1e-9 * std::max(std::abs(lo), std::abs(hi))) {
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

std::string format_fixed(double value, int decimals, bool typeset) {
  if (!std::isfinite(value)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", std::max(decimals, 0), value);
  std::string s = buf;
  // "-0.0" reads as a sign that is not there.
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  if (typeset && s[0] == '-') s.replace(0, 1, "\u2212");
  return s;
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
  return format_fixed(value, decimals, true);
}

std::string format_number(double value, int significant) {
  if (!std::isfinite(value)) return std::isnan(value) ? "NaN" : (value > 0 ? "inf" : "-inf");
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*g", std::max(significant, 1), value);
  return buf;
}

}  // namespace authalic::analysis

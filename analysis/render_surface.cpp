// 3D surface views (see analysis/render.h): an orthographic z-buffer scan conversion with
// Lambert shading, in software. Why not a library: Debian 12's VTK 9.1 renders only through
// OpenGL on an X display (libvtkRenderingOpenGL2-9.1.so links libX11 and neither OSMesa nor
// EGL, checked with ldd), so it cannot draw on a headless server, and Cairo has no depth test.
// This file is the one place that keeps its own rasteriser; labels, frames, colour bars and
// layout go through Cairo (analysis/canvas.h).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "analysis/render.h"
#include "analysis/render_internal.h"
#include "core/sulcal_depth.h"

namespace authalic::analysis {

using namespace detail;

namespace {

const Rgb kBlack{0, 0, 0};

// Where a panel looks and how it is scaled: screen = (p . right - centre.x, p . up - centre.y) x scale.
struct PanelCamera {
  ViewBasis basis;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double scale = 1.0;  // pixels per mm
  int width = 0, height = 0;
  void project(const Eigen::Vector3d& p, double* X, double* Y, double* Z) const {
    *X = width / 2.0 + (p.dot(basis.right) - centre.x()) * scale;
    *Y = height / 2.0 - (p.dot(basis.up) - centre.y()) * scale;
    *Z = p.dot(basis.toward_viewer);
  }
};

std::vector<bool> used_vertices(const MatrixXd& V, const MatrixXi& F) {
  std::vector<bool> used(static_cast<std::size_t>(V.rows()), false);
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) used[F(f, k)] = true;
  return used;
}

// The projected bounding box (lo, hi) and the depth extent of the used vertices in one view.
void projected_extent(const MatrixXd& V, const std::vector<bool>& used, const ViewBasis& b, Eigen::Vector2d* lo,
                      Eigen::Vector2d* hi, double* depth) {
  const double inf = std::numeric_limits<double>::infinity();
  *lo = Eigen::Vector2d(inf, inf);
  *hi = -*lo;
  double zlo = inf, zhi = -inf;
  for (int v = 0; v < V.rows(); ++v) {
    if (!used[v]) continue;
    const Eigen::Vector3d p = V.row(v).transpose();
    const Eigen::Vector2d q(p.dot(b.right), p.dot(b.up));
    *lo = lo->cwiseMin(q);
    *hi = hi->cwiseMax(q);
    zlo = std::min(zlo, p.dot(b.toward_viewer));
    zhi = std::max(zhi, p.dot(b.toward_viewer));
  }
  if (!std::isfinite(lo->x())) *lo = *hi = Eigen::Vector2d::Zero();
  *depth = std::isfinite(zhi - zlo) ? zhi - zlo : 0.0;
}

// One panel: every face scan-converted with a depth test (strictly nearer wins, so the drawing
// order never matters), colour from pixel_colour() times a two-sided Lambert head-light.
// Returns the panel (white background) and fills zbuf (W x H, -inf where empty).
io::RgbImage rasterise_panel(const MatrixXd& V, const MatrixXi& F, const MatrixXd& N, const ScalarColouring& colouring,
                             const ColourTable& table, const PanelCamera& cam, std::vector<double>& zbuf) {
  const int W = cam.width, H = cam.height;
  io::RgbImage img(W, H, 255);
  zbuf.assign(static_cast<std::size_t>(W) * H, -std::numeric_limits<double>::infinity());
  for (int f = 0; f < F.rows(); ++f) {
    const int idx[3] = {F(f, 0), F(f, 1), F(f, 2)};
    double X[3], Y[3], Z[3];
    for (int k = 0; k < 3; ++k) cam.project(V.row(idx[k]).transpose(), &X[k], &Y[k], &Z[k]);
    rasterise_triangle(X, Y, 0, 0, W, H, [&](int px, int py, double w0, double w1, double w2) {
      const double z = w0 * Z[0] + w1 * Z[1] + w2 * Z[2];
      double& zb = zbuf[static_cast<std::size_t>(py) * W + px];
      if (!(z > zb)) return;
      zb = z;
      const Eigen::Vector3d normal =
          w0 * N.row(idx[0]).transpose() + w1 * N.row(idx[1]).transpose() + w2 * N.row(idx[2]).transpose();
      const double len = normal.norm();
      // Lambert with a head-light plus ambient; two-sided so open patches shade too.
      const double lambert = len > 0 ? std::abs(normal.dot(cam.basis.toward_viewer)) / len : 1.0;
      const double intensity = 0.3 + 0.7 * lambert;
      const Rgb base = pixel_colour(colouring, table, idx, w0, w1, w2);
      put_pixel(img, px, py, {to_byte(base[0] / 255.0 * intensity), to_byte(base[1] / 255.0 * intensity),
                              to_byte(base[2] / 255.0 * intensity)});
    });
  }
  return img;
}

// Label boundaries in black: in each triangle with mixed labels, segments between the midpoints
// of its mixed edges (through the centroid when all three differ), drawn where visible.
void draw_label_boundaries(io::RgbImage& img, const std::vector<double>& zbuf, const MatrixXd& V, const MatrixXi& F,
                           const VectorXi& lab, const PanelCamera& cam, double depth_tolerance, int thickness) {
  const int W = cam.width, H = cam.height;
  auto segment = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& c) {
    double ax, ay, az, cx, cy, cz;
    cam.project(a, &ax, &ay, &az);
    cam.project(c, &cx, &cy, &cz);
    const int steps = std::max(1, static_cast<int>(std::ceil(2.0 * std::max(std::abs(cx - ax), std::abs(cy - ay)))));
    for (int k = 0; k <= steps; ++k) {
      const double t = double(k) / steps;
      const double x = ax + t * (cx - ax), y = ay + t * (cy - ay), z = az + t * (cz - az);
      const int px = static_cast<int>(std::floor(x)), py = static_cast<int>(std::floor(y));
      if (px < 0 || py < 0 || px >= W || py >= H) continue;
      if (z < zbuf[static_cast<std::size_t>(py) * W + px] - depth_tolerance) continue;  // hidden
      for (int dy = 0; dy < thickness; ++dy)
        for (int dx = 0; dx < thickness; ++dx)
          if (px + dx < W && py + dy < H) put_pixel(img, px + dx, py + dy, kBlack);
    }
  };
  for (int f = 0; f < F.rows(); ++f) {
    const int i0 = F(f, 0), i1 = F(f, 1), i2 = F(f, 2);
    const int l0 = lab(i0), l1 = lab(i1), l2 = lab(i2);
    if (l0 == l1 && l1 == l2) continue;
    const Eigen::Vector3d p0 = V.row(i0).transpose(), p1 = V.row(i1).transpose(), p2 = V.row(i2).transpose();
    const Eigen::Vector3d m01 = 0.5 * (p0 + p1), m12 = 0.5 * (p1 + p2), m20 = 0.5 * (p2 + p0);
    if (l0 != l1 && l1 != l2 && l0 != l2) {
      const Eigen::Vector3d centroid = (p0 + p1 + p2) / 3.0;
      segment(m01, centroid);
      segment(m12, centroid);
      segment(m20, centroid);
    } else if (l0 == l1) {
      segment(m12, m20);
    } else if (l1 == l2) {
      segment(m01, m20);
    } else {
      segment(m01, m12);
    }
  }
}

Saturation saturation_of_values(const ScalarColouring& c) {
  return saturation_of(c.values.data(), static_cast<std::size_t>(c.values.size()), c);
}

}  // namespace

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
  const int m = static_cast<int>(kMargin);
  const int n = static_cast<int>(views.size());
  const std::vector<bool> used = used_vertices(V, F);
  // One scale for all panels (mm per pixel the same in every view), each centred on its own projection.
  std::vector<PanelCamera> cams(n);
  double scale = std::numeric_limits<double>::infinity(), depth_extent = 0.0;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector2d lo, hi;
    double depth;
    cams[i].basis = view_basis(views[i], options.left_hemisphere);
    projected_extent(V, used, cams[i].basis, &lo, &hi, &depth);
    const Eigen::Vector2d ext = (hi - lo).cwiseMax(1e-9);
    scale = std::min({scale, (W - 2.0 * m) / ext.x(), (H - 2.0 * m) / ext.y()});
    depth_extent = std::max(depth_extent, depth);
    cams[i].centre = 0.5 * (lo + hi);
  }
  if (!std::isfinite(scale)) scale = 1.0;
  const MatrixXd N = F.rows() > 0 ? vertex_normals(V, F) : MatrixXd::Zero(V.rows(), 3);
  const ColourTable table(colouring);

  const bool bar = options.draw_colour_bar && colouring.values.size() > 0;
  const Saturation sat = saturation_of_values(colouring);
  const int title_height = options.title.empty() ? 0 : static_cast<int>(std::ceil(text_line_height(kTitleFontSize))) + m;
  const int top = m + title_height;
  const int caption_height = static_cast<int>(std::ceil(text_line_height(kTickFontSize))) + m;
  const int bar_extent = bar ? colour_bar_extent(colouring, sat, kTickFontSize) + m : 0;
  const int width = std::max(n * W + bar_extent, static_cast<int>(std::ceil(text_width(options.title, kTitleFontSize, true))) + 2 * m);
  Canvas cv(width, top + H + caption_height + m);
  TextStyle ts;
  ts.align = Align::Centre;
  if (!options.title.empty()) {
    ts.size = kTitleFontSize;
    ts.bold = true;
    cv.text((n * W) / 2.0, m, options.title, ts);
  }
  ts.size = kTickFontSize;
  ts.bold = false;
  for (int i = 0; i < n; ++i) {
    cams[i].scale = scale;
    cams[i].width = W;
    cams[i].height = H;
    std::vector<double> zbuf;
    io::RgbImage panel = rasterise_panel(V, F, N, colouring, table, cams[i], zbuf);
    // Boundary lines pass the depth test within 1 % of the depth (they lie on the surface).
    if (boundary_labels)
      draw_label_boundaries(panel, zbuf, V, F, *boundary_labels, cams[i], std::max(1e-6, 0.01 * depth_extent), W >= 700 ? 2 : 1);
    cv.image(panel, i * W, top);
    cv.text(i * W + W / 2.0, top + H + m / 2.0, view_name(views[i]), ts);
  }
  if (bar) draw_colour_bar(cv, n * W, top + H / 8.0, H - H / 4.0, colouring, sat, kTickFontSize);
  return cv.to_image();
}

namespace {

// One panel of the standard figure: which hemispheres it shows, from where, and its caption.
struct StandardPanel {
  View view;
  bool left_camera;  // view_basis's hemisphere argument
  int only;          // -1: both hemispheres; 0 = left only, 1 = right only
  const char* caption;
};

// 3D-SSP's order (Minoshima et al. 1995): RT LAT, LT LAT, SUP, INF / ANT, POST, RT MED, LT MED.
const StandardPanel kStandardPanels[8] = {
    {View::Lateral, false, 1, "right lateral"},  {View::Lateral, true, 0, "left lateral"},
    {View::Superior, true, -1, "superior"},      {View::Inferior, true, -1, "inferior"},
    {View::Anterior, true, -1, "anterior"},      {View::Posterior, true, -1, "posterior"},
    {View::Medial, false, 1, "right medial"},    {View::Medial, true, 0, "left medial"}};

// The hemispheres of one panel as one mesh with its values and background.
struct PanelMesh {
  MatrixXd V, N;
  MatrixXi F;
  ScalarColouring colouring;
};

PanelMesh panel_mesh(const std::vector<const HemisphereSurface*>& parts, const ScalarColouring& style) {
  PanelMesh m;
  Eigen::Index nv = 0, nf = 0;
  for (const HemisphereSurface* h : parts) {
    nv += h->V.rows();
    nf += h->F.rows();
  }
  m.V.resize(nv, 3);
  m.F.resize(nf, 3);
  m.colouring = style;
  m.colouring.values = VectorXd::Constant(nv, std::numeric_limits<double>::quiet_NaN());
  bool background = true;
  for (const HemisphereSurface* h : parts) background = background && h->background.size() == h->V.rows();
  m.colouring.background = background ? VectorXd(nv) : VectorXd();
  bool no_value = false;
  for (const HemisphereSurface* h : parts) no_value = no_value || !h->no_value.empty();
  m.colouring.no_value.assign(no_value ? static_cast<std::size_t>(nv) : 0, 0);
  Eigen::Index ov = 0, of = 0;
  for (const HemisphereSurface* h : parts) {
    m.V.middleRows(ov, h->V.rows()) = h->V.leftCols(3);
    // (An empty face list may be 0 x 0, not 0 x 3: nothing to copy.)
    if (h->F.rows() > 0) m.F.middleRows(of, h->F.rows()) = (h->F.array() + static_cast<int>(ov)).matrix();
    if (h->values.size() == h->V.rows()) m.colouring.values.segment(ov, h->V.rows()) = h->values;
    if (background) m.colouring.background.segment(ov, h->V.rows()) = h->background;
    if (no_value && h->no_value.size() == static_cast<std::size_t>(h->V.rows()))
      std::copy(h->no_value.begin(), h->no_value.end(), m.colouring.no_value.begin() + ov);
    ov += h->V.rows();
    of += h->F.rows();
  }
  m.N = nf > 0 ? vertex_normals(m.V, m.F) : MatrixXd::Zero(nv, 3);
  return m;
}

}  // namespace

io::RgbImage render_standard_views(const std::vector<HemisphereSurface>& hemispheres, const ScalarColouring& colouring,
                                   const StandardViewsOptions& options) {
  const HemisphereSurface* side[2] = {nullptr, nullptr};
  for (const auto& h : hemispheres) {
    check_mesh(h.V, h.F, ScalarColouring{}, 3, "render_standard_views");
    side[h.left ? 0 : 1] = &h;
  }
  if (!side[0] && !side[1]) throw std::invalid_argument("render_standard_views: no hemisphere");
  std::vector<const HemisphereSurface*> both;
  for (const HemisphereSurface* h : side)
    if (h) both.push_back(h);
  const PanelMesh whole = panel_mesh(both, colouring);
  PanelMesh single[2];
  for (int k = 0; k < 2; ++k)
    if (side[k]) single[k] = panel_mesh({side[k]}, colouring);
  const int W = options.panel_width, H = options.panel_height, m = static_cast<int>(kMargin);
  const double font = options.font_size, title_font = font * kTitleFontSize / kTickFontSize;
  // One scale for every panel, so sizes compare across views.
  std::vector<PanelCamera> cams(8);
  std::vector<const PanelMesh*> meshes(8, nullptr);
  std::vector<double> half_width(8, 0.0);  // mm, the mesh's projected half width in each panel
  double scale = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 8; ++i) {
    const StandardPanel& p = kStandardPanels[i];
    meshes[i] = p.only < 0 ? &whole : side[p.only] ? &single[p.only] : nullptr;
    if (!meshes[i]) continue;
    Eigen::Vector2d lo, hi;
    double depth;
    cams[i].basis = view_basis(p.view, p.left_camera);
    projected_extent(meshes[i]->V, used_vertices(meshes[i]->V, meshes[i]->F), cams[i].basis, &lo, &hi, &depth);
    const Eigen::Vector2d ext = (hi - lo).cwiseMax(1e-9);
    scale = std::min({scale, (W - 2.0 * m) / ext.x(), (H - 2.0 * m) / ext.y()});
    cams[i].centre = 0.5 * (lo + hi);
    half_width[i] = 0.5 * ext.x();
  }
  const Saturation sat = saturation_of_values(whole.colouring);
  const int bar_extent = colour_bar_extent(colouring, sat, font) + m;
  const int title_height = options.title.empty() ? 0 : static_cast<int>(std::ceil(text_line_height(title_font))) + m;
  const int caption = static_cast<int>(std::ceil(text_line_height(font))) + 4;
  Canvas cv(4 * W + bar_extent, m + title_height + 2 * (H + caption));
  TextStyle ts;
  ts.align = Align::Centre;
  if (!options.title.empty()) {
    ts.size = title_font;
    ts.bold = true;
    cv.text(2.0 * W, m, options.title, ts);
  }
  ts.size = font;
  ts.bold = false;
  const ColourTable table(colouring);
  const int top = m + title_height;
  for (int i = 0; i < 8; ++i) {
    const int x = (i % 4) * W, y = top + (i / 4) * (H + caption);
    cv.text(x + W / 2.0, y, kStandardPanels[i].caption, ts);
    if (!meshes[i]) continue;
    cams[i].scale = scale;
    cams[i].width = W;
    cams[i].height = H;
    std::vector<double> zbuf;
    cv.image(rasterise_panel(meshes[i]->V, meshes[i]->F, meshes[i]->N, meshes[i]->colouring, table, cams[i], zbuf), x, y + caption);
    // Views of both hemispheres from above, below, the front or the back show the subject's right
    // on one side or the other: mark the sides (the physician must not have to work it out).
    if (kStandardPanels[i].only < 0) {
      const bool right_on_right = cams[i].basis.right.x() > 0;
      const double gap = half_width[i] * scale + 6.0;  // pixels from the panel's centre to just beside the brain
      TextStyle mark = ts;
      mark.bold = true;
      mark.align = Align::Right;
      cv.text(std::max(x + W / 2.0 - gap, x + font), y + caption + H / 2.0, right_on_right ? "L" : "R", mark);
      mark.align = Align::Left;
      cv.text(std::min(x + W / 2.0 + gap, x + W - font), y + caption + H / 2.0, right_on_right ? "R" : "L", mark);
    }
  }
  draw_colour_bar(cv, 4 * W, top + H / 4.0, 2 * H - H / 2.0, colouring, sat, font);
  return cv.to_image();
}

VectorXd sulcal_shading(const MatrixXd& V, const MatrixXi& F) {
  const VectorXd depth = sulcal_depth_proxy(V, F);  // mm, positive in sulci
  std::vector<double> sorted(depth.data(), depth.data() + depth.size());
  if (sorted.empty()) return {};
  std::sort(sorted.begin(), sorted.end());
  const double lo = sorted[static_cast<std::size_t>(0.02 * (sorted.size() - 1))];
  const double hi = sorted[static_cast<std::size_t>(0.98 * (sorted.size() - 1))];
  VectorXd gray(depth.size());
  for (Eigen::Index v = 0; v < depth.size(); ++v) {
    const double t = hi > lo ? std::clamp((depth(v) - lo) / (hi - lo), 0.0, 1.0) : 0.5;
    gray(v) = 0.8 - 0.35 * t;  // gyral crowns light, sulcal fundi dark
  }
  return gray;
}

}  // namespace authalic::analysis

// The report's pictures (see analysis/report_figures.h).
#include "analysis/report_figures.h"

#include <cmath>
#include <limits>
#include <tuple>

#include "analysis/render.h"

namespace authalic::analysis {

namespace {

std::string capitalised(std::string s) {
  if (!s.empty() && s[0] >= 'a' && s[0] <= 'z') s[0] = static_cast<char>(s[0] - 'a' + 'A');
  return s;
}

ScalarColouring z_colouring(const VectorXd& z, double threshold) {
  ScalarColouring c;
  c.values = z;
  c.vmin = -kReportZRange;
  c.vmax = kReportZRange;
  c.colormap = "coolwarm";
  c.label = "z";
  c.threshold = threshold;
  return c;
}

ScalarColouring pet_colouring(const VectorXd& pet, const std::string& units) {
  ScalarColouring c;
  c.values = pet;
  std::tie(c.vmin, c.vmax) = robust_range(pet);
  c.colormap = "viridis";
  c.label = units;
  return c;
}

// Values on the 3D surface's vertices, NaN outside the cortex (drawn as shaded grey).
VectorXd on_surface(const ReportHemisphere& h, const VectorXd& values) {
  const Eigen::Index n = h.surface_V.rows();
  VectorXd out = VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
  if (values.size() < n) return out;
  out = values.head(n);
  if (h.element_of_vertex.size() == n)
    for (Eigen::Index v = 0; v < n; ++v)
      if (h.element_of_vertex(v) < 0) out(v) = std::numeric_limits<double>::quiet_NaN();
  return out;
}

std::vector<HemisphereSurface> view_surfaces(const ReportData& d, bool z) {
  std::vector<HemisphereSurface> out;
  for (const ReportHemisphere& h : d.hemispheres) {
    const MatrixXi& F = h.surface_F.rows() > 0 ? h.surface_F : h.faces;
    if (h.surface_V.rows() == 0 || F.rows() == 0) continue;
    HemisphereSurface s{h.surface_V, F, h.left, on_surface(h, z ? report_vertex_z(h) : h.pet), h.shading, {}};
    if (s.background.size() != s.V.rows()) s.background = VectorXd::Constant(s.V.rows(), 0.7);
    // Cortex without a value (no PET there, or no z) is marked, not shaded as normal cortex.
    if (h.element_of_vertex.size() == s.V.rows()) {
      s.no_value.assign(static_cast<std::size_t>(s.V.rows()), 0);
      for (Eigen::Index v = 0; v < s.V.rows(); ++v)
        s.no_value[static_cast<std::size_t>(v)] = h.element_of_vertex(v) >= 0 && !std::isfinite(s.values(v));
    }
    out.push_back(std::move(s));
  }
  return out;
}

void standard_view_figures(const ReportData& d, ReportFigures& f) {
  StandardViewsOptions o;
  // Labels large enough to stay >= 11 px when the PDF shrinks the figure to the page width.
  o.panel_width = 300;
  o.panel_height = 230;
  o.font_size = 22;
  const double threshold = d.normative.threshold;
  std::vector<HemisphereSurface> z = view_surfaces(d, true);
  bool any_z = false;
  for (const auto& s : z) any_z = any_z || s.values.array().isFinite().any();
  if (!z.empty() && any_z) {
    o.title = "z-score, |z| \u2265 " + format_fixed(threshold, 1) + " (blue: lower than the controls)";
    f.views.push_back({render_standard_views(z, z_colouring(VectorXd(), threshold), o), "eight standard views of z",
                       "z of each equal-area element on the subject's pial surface, shown where |z| \u2265 " +
                           format_fixed(threshold, 1) + "; grey: within normal limits (shaded by sulcal depth: darker in sulci); " +
                           "magenta: cortex without a z (no PET value there, or too few controls)."});
  }
  std::vector<HemisphereSurface> pet = view_surfaces(d, false);
  VectorXd all(0);
  for (const auto& s : pet) {
    VectorXd joined(all.size() + s.values.size());
    joined << all, s.values;
    all = joined;
  }
  if (!pet.empty() && all.array().isFinite().any()) {
    o.title = "PET (" + d.pet_units + ")";
    f.views.push_back({render_standard_views(pet, pet_colouring(all, d.pet_units), o), "eight standard views of PET",
                       "Normalised PET sampled on the cortex (2nd-98th percentile colour range); grey: outside the cortex; "
                       "magenta: cortex without a PET value (outside the field of view)."});
  }
}

void square_map_figures(const ReportData& d, ReportFigures& f) {
  for (const ReportHemisphere& h : d.hemispheres) {
    if (h.flat_uv.rows() == 0 || h.faces.rows() == 0) continue;
    FlatRenderOptions fo;
    fo.width = 460;
    fo.font_size = 18;
    fo.domain_width = h.domain_width;
    fo.domain_height = h.domain_height;
    fo.grid_cols = h.grid_cols;
    fo.grid_rows = h.grid_rows;
    const std::string grid = h.grid_cols > 0 ? " Grid: " + std::to_string(h.grid_cols) + " \u00d7 " +
                                                   std::to_string(h.grid_rows) + " equal-area elements." : "";
    const VectorXd z = report_vertex_z(h);
    if (z.size() == h.flat_uv.rows()) {
      fo.title = capitalised(h.name) + " hemisphere: z";
      f.flat_maps.push_back({render_flat(h.flat_uv, h.faces, z_colouring(z, 0.0), fo), h.name + " hemisphere z-score flat map",
                             "z per element on the authalic square map (frontal pole at the top)." + grid});
    }
    if (h.pet.size() == h.flat_uv.rows()) {
      fo.title = capitalised(h.name) + " hemisphere: PET";
      f.flat_maps.push_back({render_flat(h.flat_uv, h.faces, pet_colouring(h.pet, d.pet_units), fo),
                             h.name + " hemisphere PET flat map", "PET (" + d.pet_units + ") on the authalic square map." + grid});
    }
  }
}

// Both hemispheres on the 2:1 rectangle (left part, then right part), z when compared, else PET.
void rectangle_figure(const ReportData& d, ReportFigures& f) {
  Eigen::Index nv = 0, nf = 0;
  int rows = 0;
  for (const ReportHemisphere& h : d.hemispheres) {
    if (h.rectangle_uv.rows() == 0 || h.rectangle_uv.rows() > h.flat_uv.rows()) return;
    nv += h.rectangle_uv.rows();
    nf += h.rectangle_faces.rows();
    rows = h.grid_rows;
  }
  if (nv == 0 || d.hemispheres.size() != 2) return;
  const bool z = d.normative.present;
  MatrixXd UV(nv, 2);
  MatrixXi F(nf, 3);
  VectorXd values(nv);
  Eigen::Index ov = 0, of = 0;
  for (const ReportHemisphere& h : d.hemispheres) {
    const VectorXd v = z ? report_vertex_z(h) : h.pet;
    if (v.size() < h.rectangle_uv.rows()) return;
    UV.middleRows(ov, h.rectangle_uv.rows()) = h.rectangle_uv.leftCols(2);
    F.middleRows(of, h.rectangle_faces.rows()) = h.rectangle_faces.array() + static_cast<int>(ov);
    values.segment(ov, h.rectangle_uv.rows()) = v.head(h.rectangle_uv.rows());
    ov += h.rectangle_uv.rows();
    of += h.rectangle_faces.rows();
  }
  FlatRenderOptions fo;
  fo.width = 900;
  fo.font_size = 18;
  fo.domain_width = 2.0;
  fo.grid_cols = 2 * rows;
  fo.grid_rows = rows;
  fo.title = std::string("Whole cortex on the 2:1 rectangle: ") + (z ? "z" : "PET");
  f.flat_maps.push_back({render_flat(UV, F, z ? z_colouring(values, 0.0) : pet_colouring(values, d.pet_units), fo),
                         "whole-brain rectangle map", "Left hemisphere on the left part, right on the right; each part's width is "
                                                      "proportional to its cortical area (authalic 2:1 rectangle)."});
}

}  // namespace

VectorXd report_vertex_z(const ReportHemisphere& h) {
  if (h.z.size() > 0) return h.z;
  const int n = static_cast<int>(h.element_of_vertex.size());
  if (h.element_z.empty() || n == 0) return {};
  VectorXd z(std::max<Eigen::Index>(n, h.flat_uv.rows()));
  z.setConstant(std::numeric_limits<double>::quiet_NaN());
  for (int v = 0; v < n; ++v) {
    const int e = h.element_of_vertex(v);
    if (e >= 0 && e < static_cast<int>(h.element_z.size())) z(v) = h.element_z[static_cast<std::size_t>(e)];
  }
  return z;
}

ReportFigures report_figures(const ReportData& d) {
  ReportFigures f;
  standard_view_figures(d, f);
  square_map_figures(d, f);
  rectangle_figure(d, f);
  return f;
}

}  // namespace authalic::analysis

// The per-subject HTML report (see analysis/report.h).
#include "analysis/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "analysis/raster.h"
#include "analysis/render.h"
#include "io/atomic_file.h"
#include "io/base64.h"
#include "io/markup_escape.h"

namespace authalic::analysis {

namespace {

constexpr double kZRange = 4.0;  // z colour range [-4, 4]: the same colours in every report

std::string fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

const char* kStyle = R"(
body { font-family: "DejaVu Sans", Helvetica, Arial, sans-serif; margin: 24px auto; max-width: 1160px; color: #1d1d1d; background: #fff; }
header { border-bottom: 2px solid #3b4cc0; margin-bottom: 16px; }
h1 { font-size: 26px; margin: 0 0 6px 0; }
h2 { font-size: 20px; margin: 26px 0 10px 0; border-bottom: 1px solid #ccc; padding-bottom: 4px; }
h3 { font-size: 16px; margin: 14px 0 6px 0; }
p.subject { font-size: 17px; margin: 4px 0 10px 0; }
table { border-collapse: collapse; margin: 6px 0 12px 0; font-size: 14px; }
th, td { border: 1px solid #c8c8c8; padding: 4px 10px; text-align: left; vertical-align: top; }
th { background: #f0f0f4; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.figures { display: flex; flex-wrap: wrap; gap: 16px; align-items: flex-start; }
figure { margin: 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #e0e0e0; }
figcaption { font-size: 13px; color: #444; margin-top: 4px; max-width: 560px; }
.note { background: #fff6db; border: 1px solid #e7c75b; padding: 8px 12px; margin: 8px 0; }
.muted { color: #666; }
footer { margin-top: 30px; font-size: 12px; color: #666; border-top: 1px solid #ddd; padding-top: 8px; }
)";

void key_value_table(std::ostringstream& out, const KeyValues& rows) {
  out << "<table>\n";
  for (const auto& [k, v] : rows) out << "<tr><th>" << html_escape(k) << "</th><td>" << html_escape(v) << "</td></tr>\n";
  out << "</table>\n";
}

void figure(std::ostringstream& out, const io::RgbImage& image, const std::string& alt, const std::string& caption) {
  out << "<figure><img alt=\"" << html_escape(alt) << "\" width=\"" << image.width << "\" height=\"" << image.height
      << "\" src=\"" << png_data_uri(image) << "\" /><figcaption>" << html_escape(caption) << "</figcaption></figure>\n";
}

// Per-vertex z: given, or spread from the element z-scores through each vertex's element.
VectorXd vertex_z(const ReportHemisphere& h) {
  if (h.z.size() > 0) return h.z;
  const int n = static_cast<int>(h.element_of_vertex.size());
  if (h.element_z.empty() || n == 0) return {};
  VectorXd z(n);
  for (int v = 0; v < n; ++v) {
    const int e = h.element_of_vertex(v);
    z(v) = e >= 0 && e < static_cast<int>(h.element_z.size()) ? h.element_z[e] : std::nan("");
  }
  return z;
}

ScalarColouring z_colouring(const VectorXd& z) {
  ScalarColouring c;
  c.values = z;
  c.vmin = -kZRange;
  c.vmax = kZRange;
  c.colormap = "coolwarm";
  c.label = "z";
  return c;
}

std::string capitalised(std::string s) {
  if (!s.empty() && s[0] >= 'a' && s[0] <= 'z') s[0] = static_cast<char>(s[0] - 'a' + 'A');
  return s;
}

}  // namespace

std::string html_escape(const std::string& text) { return io::markup_escape(text); }

std::string png_data_uri(const io::RgbImage& image) { return "data:image/png;base64," + io::base64_encode(io::encode_png(image)); }

std::pair<double, double> robust_range(const VectorXd& values) {
  std::vector<double> v;
  for (int i = 0; i < values.size(); ++i) {
    if (std::isfinite(values(i))) v.push_back(values(i));
  }
  if (v.empty()) return {0.0, 1.0};
  std::sort(v.begin(), v.end());
  const double lo = v[static_cast<std::size_t>(0.02 * (v.size() - 1))];
  const double hi = v[static_cast<std::size_t>(0.98 * (v.size() - 1))];
  if (hi > lo) return {lo, hi};
  return {lo - 0.5, lo + 0.5};
}

std::string report_html(const ReportData& d) {
  std::ostringstream out;
  const std::string title = d.title + (d.subject_id.empty() ? "" : " - " + d.subject_id);
  out << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\" />\n"
      << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\" />\n"
      << "<title>" << html_escape(title) << "</title>\n<style>" << kStyle << "</style>\n</head>\n<body>\n";
  out << "<header><h1>" << html_escape(d.title) << "</h1>\n<p class=\"subject\">Subject <strong>"
      << html_escape(d.subject_id.empty() ? "(unnamed)" : d.subject_id) << "</strong>";
  if (d.normative.present) {
    int hypo = 0;
    for (const auto& c : d.clusters) hypo += c.sign == "hypo";
    out << " &#8212; " << d.clusters.size() << " cluster" << (d.clusters.size() == 1 ? "" : "s") << " of |z| &#8805; "
        << html_escape(fixed(d.normative.threshold, 1)) << " (" << hypo << " hypometabolic)";
  }
  out << "</p></header>\n";

  if (!d.notes.empty()) {
    out << "<section id=\"notes\">\n";
    for (const auto& n : d.notes) out << "<p class=\"note\">" << html_escape(n) << "</p>\n";
    out << "</section>\n";
  }

  out << "<section id=\"subject\">\n<h2>Subject</h2>\n";
  KeyValues info = d.subject_info;
  info.insert(info.begin(), {"subject", d.subject_id});
  key_value_table(out, info);
  out << "</section>\n";

  out << "<section id=\"parameters\">\n<h2>Processing parameters</h2>\n";
  if (d.parameters.empty()) {
    out << "<p class=\"muted\">No parameters recorded.</p>\n";
  } else {
    key_value_table(out, d.parameters);
  }
  out << "</section>\n";

  // Flat maps: PET and z per hemisphere with the element grid.
  out << "<section id=\"flat-maps\">\n<h2>Flat maps</h2>\n<p>Authalic (area-preserving) maps of the cortex: every cell of "
         "the grid holds the same cortical area, so the element values below are comparable across the map and across "
         "subjects.</p>\n";
  for (const auto& h : d.hemispheres) {
    out << "<h3>" << html_escape(capitalised(h.name)) << " hemisphere</h3>\n<div class=\"figures\">\n";
    const bool has_flat = h.flat_uv.rows() > 0 && h.faces.rows() > 0;
    FlatRenderOptions fo;
    fo.width = 540;
    fo.domain_width = h.domain_width;
    fo.domain_height = h.domain_height;
    fo.grid_cols = h.grid_cols;
    fo.grid_rows = h.grid_rows;
    const std::string grid_text =
        h.grid_cols > 0 ? " Grid: " + std::to_string(h.grid_cols) + " x " + std::to_string(h.grid_rows) + " equal-area elements." : "";
    if (has_flat && h.pet.size() == h.flat_uv.rows()) {
      ScalarColouring c;
      c.values = h.pet;
      std::tie(c.vmin, c.vmax) = robust_range(h.pet);
      c.colormap = "viridis";
      c.label = d.pet_units;
      fo.title = capitalised(h.name) + ": PET";
      figure(out, render_flat(h.flat_uv, h.faces, c, fo), h.name + " hemisphere PET flat map",
             "PET (" + d.pet_units + ") on the flat map, 2nd-98th percentile colour range." + grid_text);
    }
    const VectorXd z = vertex_z(h);
    if (has_flat && z.size() == h.flat_uv.rows()) {
      fo.title = capitalised(h.name) + ": z";
      figure(out, render_flat(h.flat_uv, h.faces, z_colouring(z), fo), h.name + " hemisphere z-score flat map",
             "z = (patient - controls' mean) / predictive SD (the controls' SD x sqrt(1 + 1/n), n controls) per element; "
             "blue = lower than normal." + grid_text);
    } else if (!h.element_z.empty() && h.grid_cols > 0 && h.grid_rows > 0) {
      const int cell = std::max(4, 320 / h.grid_cols);
      figure(out, render_element_grid(h.element_z, h.grid_rows, h.grid_cols, z_colouring(VectorXd()), cell, capitalised(h.name) + ": z"),
             h.name + " hemisphere z-score elements", "z-score of each element (row 0 at the bottom).");
    }
    if (!h.element_pet.empty() && h.grid_cols > 0 && h.grid_rows > 0 &&
        h.element_pet.size() == static_cast<std::size_t>(h.grid_cols) * h.grid_rows) {
      ScalarColouring c;
      const VectorXd ev = Eigen::Map<const VectorXd>(h.element_pet.data(), static_cast<Eigen::Index>(h.element_pet.size()));
      std::tie(c.vmin, c.vmax) = robust_range(ev);
      c.colormap = "viridis";
      c.label = d.pet_units;
      const int cell = std::max(4, 320 / h.grid_cols);
      figure(out, render_element_grid(h.element_pet, h.grid_rows, h.grid_cols, c, cell, capitalised(h.name) + ": PET elements"),
             h.name + " hemisphere PET elements", "Area-weighted mean PET of each element (" + d.pet_units + ").");
    }
    if (!has_flat && h.element_z.empty() && h.element_pet.empty()) out << "<p class=\"muted\">No flat map available.</p>\n";
    out << "</div>\n";
  }
  out << "</section>\n";

  // 3D views.
  out << "<section id=\"surface-views\">\n<h2>3D views</h2>\n<div class=\"figures\">\n";
  bool any_view = false;
  for (const auto& h : d.hemispheres) {
    if (h.surface_V.rows() == 0) continue;
    const MatrixXi& F = h.surface_F.rows() > 0 ? h.surface_F : h.faces;
    if (F.rows() == 0) continue;
    const VectorXd z = vertex_z(h);
    ScalarColouring c;
    std::string what;
    if (z.size() == h.surface_V.rows()) {
      c = z_colouring(z);
      what = "z";
    } else if (h.pet.size() == h.surface_V.rows()) {
      c.values = h.pet;
      std::tie(c.vmin, c.vmax) = robust_range(h.pet);
      c.label = d.pet_units;
      what = "PET";
    }
    // Outside the cortex (no element) is drawn gray, not coloured by values that mean nothing there.
    const bool labels = h.element_of_vertex.size() == h.surface_V.rows();
    if (labels && c.values.size() == h.surface_V.rows()) {
      for (int v = 0; v < c.values.size(); ++v) {
        if (h.element_of_vertex(v) < 0) c.values(v) = std::nan("");
      }
    }
    // Element boundaries in 3D read only when an element spans several vertices: on coarse meshes
    // draw the boundaries of f x f blocks of elements instead.
    int block = 1;
    VectorXi block_of_vertex;
    if (labels && h.grid_cols > 0 && h.grid_rows > 0) {
      const int cortex_vertices = static_cast<int>((h.element_of_vertex.array() >= 0).count());
      while (block < std::min(h.grid_cols, h.grid_rows) &&
             cortex_vertices < 24.0 * (double(h.grid_cols) / block) * (double(h.grid_rows) / block)) {
        block *= 2;
      }
      block_of_vertex = h.element_of_vertex;
      const int block_cols = (h.grid_cols + block - 1) / block;
      for (int v = 0; v < block_of_vertex.size(); ++v) {
        const int e = h.element_of_vertex(v);
        if (e >= 0) block_of_vertex(v) = (e / h.grid_cols / block) * block_cols + (e % h.grid_cols) / block;
      }
    } else if (labels) {
      block_of_vertex = h.element_of_vertex;
    }
    SurfaceRenderOptions so;
    so.width = 360;
    so.height = 290;
    so.left_hemisphere = h.left;
    so.title = capitalised(h.name) + ": " + (what.empty() ? "surface" : what);
    std::string boundary_text = ".";
    if (labels) {
      boundary_text = (block == 1 ? std::string(" with the element boundaries (black)")
                                  : " with the boundaries of " + std::to_string(block) + " x " + std::to_string(block) +
                                        " blocks of elements (black)") +
                      "; gray: outside the cortex.";
    }
    figure(out, render_surface_views(h.surface_V, F, c, {View::Lateral, View::Medial}, so, labels ? &block_of_vertex : nullptr),
           h.name + " hemisphere lateral and medial views", "Lateral and medial views" + boundary_text);
    any_view = true;
  }
  if (!any_view) out << "<p class=\"muted\">No 3D surface available.</p>\n";
  out << "</div>\n</section>\n";

  // Clusters.
  out << "<section id=\"clusters\">\n<h2>Clusters of abnormal elements</h2>\n";
  if (!d.normative.present) {
    out << "<p class=\"muted\">No normative reference was given: z-scores and clusters were not computed.</p>\n";
  } else if (d.clusters.empty()) {
    out << "<p>No cluster of elements with |z| &#8805; " << html_escape(fixed(d.normative.threshold, 1)) << ".</p>\n";
  } else {
    out << "<table>\n<tr><th>#</th><th>hemisphere</th><th>type</th><th>elements</th><th>area (mm&#178;)</th><th>peak z</th>"
           "<th>mean z</th><th>peak element (row, col)</th><th>peak centroid RAS (mm)</th></tr>\n";
    for (const auto& c : d.clusters) {
      out << "<tr><td class=\"num\">" << c.id << "</td><td>" << html_escape(c.hemisphere) << "</td><td>"
          << html_escape(c.sign == "hypo" ? "hypometabolism" : c.sign == "hyper" ? "hypermetabolism" : c.sign)
          << "</td><td class=\"num\">" << c.num_elements << "</td><td class=\"num\">" << fixed(c.area_mm2, 0)
          << "</td><td class=\"num\">" << fixed(c.peak_z, 2) << "</td><td class=\"num\">" << fixed(c.mean_z, 2)
          << "</td><td class=\"num\">" << c.peak_row << ", " << c.peak_col << "</td><td class=\"num\">"
          << fixed(c.peak_ras[0], 1) << ", " << fixed(c.peak_ras[1], 1) << ", " << fixed(c.peak_ras[2], 1) << "</td></tr>\n";
    }
    out << "</table>\n";
  }
  out << "</section>\n";

  // The normative reference.
  out << "<section id=\"normative\">\n<h2>Normative reference</h2>\n";
  if (d.normative.present) {
    KeyValues rows = {{"control subjects (n)", std::to_string(d.normative.num_subjects)},
                      {"intensity normalisation", d.normative.normalisation},
                      {"elements", d.normative.domain},
                      {"abnormal when", "z <= -" + fixed(d.normative.threshold, 1) + " (hypometabolism) or z >= +" +
                                            fixed(d.normative.threshold, 1)}};
    if (!d.normative.rescale.empty()) rows.push_back({"patient rescaled to the reference", d.normative.rescale});
    key_value_table(out, rows);
    out << "<p>z = (patient - mean of the controls) / SD, element by element (as NEUROSTAT / 3D-SSP "
           "compare a patient with a normal database); the SD is the controls' SD widened by sqrt(1 + 1/n) for the "
           "uncertainty of a mean of n controls. Before that, the patient's values are multiplied by the one factor that "
           "best fits the reference over the elements found normal, so a focal loss, which lowers the global mean, does "
           "not make healthy cortex look hypermetabolic. It assumes the controls are representative of the patient's "
           "population, were processed the same way (same map, same K, same normalisation), and that element values "
           "are roughly normally distributed among them; with n controls a healthy element still exceeds |z| = 2 in "
           "about 5-7% of cases.</p>\n";
    if (!d.normative.description.empty()) out << "<p>" << html_escape(d.normative.description) << "</p>\n";
  } else {
    out << "<p class=\"muted\">None: run with a normative reference (built with <code>authalic normative build</code> from "
           "control subjects) to obtain z-scores.</p>\n";
  }
  out << "</section>\n";

  // Distortion of the maps.
  out << "<section id=\"distortion\">\n<h2>Map distortion</h2>\n";
  bool any_metrics = false;
  for (const auto& h : d.hemispheres) {
    if (h.distortion.empty()) continue;
    out << "<h3>" << html_escape(capitalised(h.name)) << " hemisphere</h3>\n";
    key_value_table(out, h.distortion);
    any_metrics = true;
  }
  if (!any_metrics) out << "<p class=\"muted\">No distortion metrics recorded.</p>\n";
  out << "<p>An authalic map keeps areas: the element-area coefficient of variation (SD / mean of the cortical area of "
         "the grid cells) should be about 0.01 or less, with no flipped triangle; angles are not preserved.</p>\n";
  out << "</section>\n";

  out << "<footer>" << html_escape(d.software.empty() ? "authalic" : d.software)
      << ". Self-contained report: pictures are embedded; nothing is loaded from elsewhere.</footer>\n";
  out << "</body>\n</html>\n";
  return out.str();
}

void write_report(const std::string& path, const ReportData& data) { io::write_file_atomically(path, report_html(data)); }

}  // namespace authalic::analysis

// The per-subject HTML report (see analysis/report.h).
#include "analysis/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "analysis/canvas.h"
#include "analysis/regions.h"
#include "analysis/report_figures.h"
#include "io/atomic_file.h"
#include "io/base64.h"
#include "io/markup_escape.h"

namespace authalic::analysis {

namespace {

std::string fixed(double v, int decimals) { return format_fixed(v, decimals); }

// How z was computed, as this comparison computed it (the age model, the SD, the rescaling), and
// what the t distribution predicts for a healthy subject with this many controls.
std::string method_text(const ReportNormative& n) {
  std::string t = n.age_adjusted
                      ? "z = (patient - value expected at the patient's age) / SD, element by element: the expected value from a "
                        "least-squares line in age through the controls' values, the SD that of the controls about the line"
                      : "z = (patient - mean of the controls) / SD, element by element (as NEUROSTAT / 3D-SSP compare a patient "
                        "with a normal database)";
  if (n.predictive)
    t += n.age_adjusted ? ", widened by sqrt(1 + 1/n + (age - mean age)^2 / sum of squared age deviations) for the uncertainty of "
                          "the line fitted to n controls"
                        : ", the SD widened by sqrt(1 + 1/n) for the uncertainty of a mean of n controls";
  t += ". ";
  if (n.rescaled)
    t += "Before that, the patient's values are multiplied by the one factor that best fits the reference over the elements "
         "found normal, so a focal loss, which lowers the global mean, does not make healthy cortex look hypermetabolic. ";
  t += "It assumes the controls are representative of the patient's population, were processed the same way (same map, same "
       "K, same normalisation), and that element values are roughly normally distributed among them";
  if (std::isfinite(n.expected_abnormal_share))
    t += "; then, with " + std::to_string(n.num_subjects) + " controls, a healthy element still reaches |z| >= " +
         fixed(n.threshold, 1) + " in about " + fixed(100.0 * n.expected_abnormal_share, 1) +
         " % of cases (Student's t distribution), which the clusters' p accounts for";
  return t + ".";
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
tr.beyond td { font-weight: bold; }
.figures { display: flex; flex-wrap: wrap; gap: 16px; align-items: flex-start; }
figure { margin: 0; }
.viewer canvas { width: 960px; height: 560px; max-width: 100%; border: 1px solid #e0e0e0; }
.columns { display: flex; flex-wrap: wrap; gap: 24px; align-items: flex-start; }
p.summary { font-size: 17px; font-weight: bold; margin: 6px 0; }
p.disclaimer { font-size: 13px; color: #555; font-style: italic; }
tr.flag td { background: #e8ecfb; }
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

std::string capitalised(std::string s) {
  if (!s.empty() && s[0] >= 'a' && s[0] <= 'z') s[0] = static_cast<char>(s[0] - 'a' + 'A');
  return s;
}

}  // namespace

std::string report_disclaimer(const ReportNormative& normative) {
  return std::string("Decision support, not a diagnosis: ") +
         (normative.present ? "the z-scores compare this scan with a reference of control subjects and must"
                            : "the PET values are shown on the cortex without a comparison with control subjects and must") +
         " be read by a qualified physician together with the clinical history, the images themselves and other findings.";
}

KeyValues reference_rows(const ReportNormative& n) {
  if (!n.present) return {{"reference", "none (PET only, no z-scores)"}};
  KeyValues rows = {{"control subjects (n)", std::to_string(n.num_subjects)}};
  if (!n.age_range.empty()) rows.push_back({"controls' age", n.age_range});
  rows.push_back({"intensity normalisation", n.normalisation});
  rows.push_back({"elements", n.domain});
  if (!n.correspondence.empty()) rows.push_back({"correspondence", n.correspondence});
  if (!n.description.empty()) rows.push_back({"reference file", n.description});
  return rows;
}

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

namespace {

void page_head(std::ostringstream& out, const ReportData& d) {
  const std::string title = d.title + (d.subject_id.empty() ? "" : " - " + d.subject_id);
  out << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\" />\n"
      << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\" />\n"
      << "<title>" << html_escape(title) << "</title>\n<style>" << kStyle << "</style>\n</head>\n<body>\n";
}

// Subject, scan and reference at a glance (what a physician checks first).
void header_section(std::ostringstream& out, const ReportData& d) {
  out << "<header><h1>" << html_escape(d.title) << "</h1>\n<p class=\"subject\">Subject <strong>"
      << html_escape(d.subject_id.empty() ? "(unnamed)" : d.subject_id) << "</strong>";
  for (const auto& [k, v] : d.subject_info)
    if (k == "age" || k == "sex" || k == "scan date" || k == "tracer") out << " &#183; " << html_escape(k) << " " << html_escape(v);
  out << "</p></header>\n";
  if (!d.notes.empty()) {
    out << "<section id=\"notes\">\n";
    for (const auto& n : d.notes) out << "<p class=\"note\">" << html_escape(n) << "</p>\n";
    out << "</section>\n";
  }
  out << "<section id=\"subject\">\n<h2>Subject and scan</h2>\n<div class=\"columns\">\n";
  KeyValues info = d.subject_info;
  info.insert(info.begin(), {"subject", d.subject_id});
  key_value_table(out, info);
  key_value_table(out, reference_rows(d.normative));
  out << "</div>\n</section>\n";
}

void summary_section(std::ostringstream& out, const ReportData& d) {
  out << "<section id=\"summary\">\n<h2>Findings</h2>\n<p class=\"summary\">"
      << html_escape(d.summary.empty() ? (d.normative.present ? "No summary." : "PET only: no normative reference, no z-scores.")
                                       : d.summary)
      << "</p>\n<p class=\"disclaimer\">" << html_escape(report_disclaimer(d.normative)) << "</p>\n</section>\n";
}

void figure_list(std::ostringstream& out, const std::vector<ReportFigure>& figures) {
  out << "<div class=\"figures\">\n";
  for (const auto& f : figures) figure(out, f.image, f.alt, f.caption);
  out << "</div>\n";
}

void views_section(std::ostringstream& out, const ReportFigures& f) {
  out << "<section id=\"surface-views\">\n<h2>3D views</h2>\n";
  if (f.views.empty()) {
    out << "<p class=\"muted\">No 3D surface available.</p>\n";
  } else {
    out << "<p>The eight standard views of NEUROSTAT/3D-SSP (right and left lateral, superior, inferior, anterior, "
           "posterior, right and left medial) on the subject's own pial surfaces.</p>\n";
    figure_list(out, f.views);
  }
  out << "</section>\n";
}

void flat_section(std::ostringstream& out, const ReportFigures& f) {
  out << "<section id=\"flat-maps\">\n<h2>Flat maps</h2>\n<p>Authalic (area-preserving) maps of the cortex: every cell of "
         "the grid holds the same cortical area, so the element values are comparable across the map and across "
         "subjects.</p>\n";
  if (f.flat_maps.empty()) out << "<p class=\"muted\">No flat map available.</p>\n";
  figure_list(out, f.flat_maps);
  out << "</section>\n";
}

std::string region_cell(const std::string& region, double fraction) {
  if (region.empty()) return "&#8212;";
  std::string s = html_escape(readable_region(region));
  if (fraction > 0 && fraction < 0.995) s += " <span class=\"muted\">(" + fixed(100 * fraction, 0) + "&#8201;%)</span>";
  return s;
}

void clusters_section(std::ostringstream& out, const ReportData& d) {
  out << "<section id=\"clusters\">\n<h2>Clusters of abnormal elements</h2>\n";
  const std::string thr = html_escape(fixed(d.normative.threshold, 1));
  if (!d.normative.present) {
    out << "<p class=\"muted\">No normative reference was given: z-scores and clusters were not computed.</p>\n";
  } else if (d.clusters.empty()) {
    out << "<p>No cluster of at least " << d.normative.min_cluster_elements << " connected elements with |z| &#8805; " << thr
        << ".</p>\n";
  } else {
    out << "<table>\n<tr><th>#</th><th>hemisphere</th><th>type</th><th>region (share of vertices)</th><th>peak region</th>"
           "<th>elements</th><th>area (mm&#178;)</th><th>peak z</th><th>mean z</th><th>peak RAS (mm)</th>"
           "<th>controls with one as large (p)</th></tr>\n";
    for (const auto& c : d.clusters) {
      // Clusters larger than every control's chance clusters stand out.
      out << (c.controls_as_large == 0 ? "<tr class=\"beyond\">" : "<tr>") << "<td class=\"num\">" << c.id << "</td><td>" << html_escape(c.hemisphere) << "</td><td>"
          << html_escape(c.sign == "hypo" ? "hypometabolism" : c.sign == "hyper" ? "hypermetabolism" : c.sign) << "</td><td>"
          << region_cell(c.region, c.region_fraction) << "</td><td>" << region_cell(c.peak_region, 1.0)
          << "</td><td class=\"num\">" << c.num_elements << "</td><td class=\"num\">" << fixed(c.area_mm2, 0)
          << "</td><td class=\"num\">" << format_fixed(c.peak_z, 1, true) << "</td><td class=\"num\">"
          << format_fixed(c.mean_z, 1, true) << "</td><td class=\"num\">" << fixed(c.peak_ras[0], 0) << ", "
          << fixed(c.peak_ras[1], 0) << ", " << fixed(c.peak_ras[2], 0) << "</td><td class=\"num\">"
          << (c.controls_as_large >= 0 ? std::to_string(c.controls_as_large) + " of " + std::to_string(c.controls) + " (" +
                                             fixed(c.p_controls, 3) + ")"
                                       : std::string("&#8212;"))
          << "</td></tr>\n";
    }
    out << "</table>\n";
    out << "<p class=\"muted\">Clusters: connected elements with |z| &#8805; " << thr << ", at least "
        << d.normative.min_cluster_elements << " element" << (d.normative.min_cluster_elements == 1 ? "" : "s") << ".";
    if (!d.normative.chance_clusters.empty()) out << " " << html_escape(d.normative.chance_clusters) << ".";
    out << "</p>\n";
  }
  if (!d.region_method.empty()) out << "<p class=\"muted\">Regions: " << html_escape(d.region_method) << ".</p>\n";
  out << "</section>\n";
}

void regions_section(std::ostringstream& out, const ReportData& d) {
  out << "<section id=\"regions\">\n<h2>Regional z</h2>\n";
  if (d.regions.empty()) {
    out << "<p class=\"muted\">No regional table (needs a normative reference).</p>\n</section>\n";
    return;
  }
  out << "<p>Mean z of the elements in each lobe (bold) and region; an element belongs to the region holding most of its "
         "vertices.</p>\n<div class=\"columns\">\n";
  for (const std::string hemi : {"left", "right"}) {
    out << "<table>\n<tr><th>" << html_escape(hemi) << " hemisphere</th><th>elements</th><th>mean z</th></tr>\n";
    for (const auto& r : d.regions) {
      if (r.hemisphere != hemi) continue;
      const bool lobe = r.region.empty();
      const std::string cls = std::abs(r.mean_z) >= d.normative.threshold ? " class=\"flag\"" : "";
      out << "<tr" << cls << "><td>" << (lobe ? "<strong>" + html_escape(r.lobe) + "</strong>"
                                               : "&#160;&#160;" + html_escape(readable_region(r.region)))
          << "</td><td class=\"num\">" << r.elements << "</td><td class=\"num\">" << format_fixed(r.mean_z, 2, true)
          << "</td></tr>\n";
    }
    out << "</table>\n";
  }
  out << "</div>\n</section>\n";
}

void normative_section(std::ostringstream& out, const ReportData& d) {
  out << "<section id=\"normative\">\n<h2>Normative reference</h2>\n";
  if (d.normative.present) {
    KeyValues rows = reference_rows(d.normative);
    rows.push_back({"abnormal when", "z \u2264 \u2212" + fixed(d.normative.threshold, 1) + " (hypometabolism) or z \u2265 +" +
                                         fixed(d.normative.threshold, 1)});
    if (!d.normative.rescale.empty()) rows.push_back({"patient rescaled to the reference", d.normative.rescale});
    key_value_table(out, rows);
    out << "<p>" << html_escape(method_text(d.normative)) << "</p>\n";
  } else {
    out << "<p class=\"muted\">None: run with a normative reference (built with <code>authalic normative build</code> from "
           "control subjects) to obtain z-scores.</p>\n";
  }
  out << "</section>\n";
}

void quality_section(std::ostringstream& out, const ReportData& d) {
  out << "<section id=\"distortion\">\n<h2>Quality</h2>\n";
  if (!d.quality.empty()) key_value_table(out, d.quality);
  bool any_metrics = false;
  out << "<div class=\"columns\">\n";
  for (const auto& h : d.hemispheres) {
    if (h.distortion.empty()) continue;
    out << "<div><h3>" << html_escape(capitalised(h.name)) << " hemisphere map</h3>\n";
    key_value_table(out, h.distortion);
    out << "</div>\n";
    any_metrics = true;
  }
  out << "</div>\n";
  if (!any_metrics) out << "<p class=\"muted\">No distortion metrics recorded.</p>\n";
  out << "<p>An authalic map keeps areas: the element-area coefficient of variation (SD / mean of the cortical area of "
         "the grid cells) should be about 0.01 or less, with no flipped triangle; angles are not preserved.</p>\n";
  out << "</section>\n";
}

void parameters_section(std::ostringstream& out, const ReportData& d) {
  out << "<section id=\"parameters\">\n<h2>Processing parameters</h2>\n";
  if (d.parameters.empty()) {
    out << "<p class=\"muted\">No parameters recorded.</p>\n";
  } else {
    key_value_table(out, d.parameters);
  }
  out << "</section>\n";
}

}  // namespace

std::string report_html(const ReportData& d) { return report_html(d, report_figures(d)); }

std::string report_html(const ReportData& d, const ReportFigures& figures) {
  std::ostringstream out;
  page_head(out, d);
  header_section(out, d);
  summary_section(out, d);
  views_section(out, figures);
  viewer_section(out, d);
  clusters_section(out, d);
  regions_section(out, d);
  flat_section(out, figures);
  normative_section(out, d);
  quality_section(out, d);
  parameters_section(out, d);
  out << "<footer>" << html_escape(d.software.empty() ? "authalic" : d.software)
      << ". Self-contained report: pictures are embedded; nothing is loaded from elsewhere.</footer>\n";
  out << "</body>\n</html>\n";
  return out.str();
}

void write_report(const std::string& path, const ReportData& data) { io::write_file_atomically(path, report_html(data)); }

void write_report(const std::string& path, const ReportData& data, const ReportFigures& figures) {
  io::write_file_atomically(path, report_html(data, figures));
}

}  // namespace authalic::analysis

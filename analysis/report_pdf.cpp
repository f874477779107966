// The report as a PDF for the patient record (see analysis/report.h): two A4 pages drawn with
// Cairo's PDF surface. Page 1: header, findings with the disclaimer, the eight standard views
// of z and of PET. Page 2: clusters and regional table by anatomical name, the flat maps,
// reference, quality flags and processing parameters. Text is vector (searchable, sharp at any
// zoom); pictures are the report's PNGs scaled to the page.
#include <algorithm>
#include <cmath>

#include "analysis/canvas.h"
#include "analysis/regions.h"
#include "analysis/report.h"
#include "analysis/report_figures.h"
#include "io/atomic_file.h"

namespace authalic::analysis {

namespace {

constexpr double kPageWidth = 595.28, kPageHeight = 841.89;  // A4 in points
constexpr double kMarginPt = 36.0;
constexpr double kBody = 9.0;  // pt: 12 px at 100 % zoom
const Rgb kAccent{59, 76, 192}, kGrey{90, 90, 90};

struct Page {
  Canvas& cv;
  double y = kMarginPt;
  double left = kMarginPt, width = kPageWidth - 2 * kMarginPt;
};

TextStyle style(double size, bool bold = false, Rgb colour = {0, 0, 0}) {
  TextStyle s;
  s.size = size;
  s.bold = bold;
  s.colour = colour;
  return s;
}

void heading(Page& p, const std::string& text) {
  p.y += 6;
  p.cv.text(p.left, p.y, text, style(11.5, true, kAccent));
  p.y += text_line_height(11.5) + 1;
  p.cv.line(p.left, p.y, p.left + p.width, p.y, {200, 200, 200}, 0.6);
  p.y += 4;
}

// Height of a paragraph (Canvas::paragraph's pitch), measured without drawing.
double paragraph_height(double w, const std::string& text, double size) {
  return static_cast<double>(wrap_text(text, size, w).size()) * 1.3 * size;
}

// The width of key_values' key column: the widest key, at most 45 % of the width w.
double key_column_width(double w, const KeyValues& rows) {
  double key_width = 0;
  for (const auto& [k, v] : rows) key_width = std::max(key_width, text_width(k, kBody));
  return std::min(key_width + 8, 0.45 * w);
}

// Height key_values will use, measured without drawing.
double key_values_height(double w, const KeyValues& rows) {
  const double pitch = text_line_height(kBody) + 1.5;
  const double key_width = key_column_width(w, rows);
  double used = 0;
  for (const auto& [k, v] : rows) used += std::max(pitch, paragraph_height(w - key_width, v, kBody));
  return used;
}

double heading_height() { return 6 + text_line_height(11.5) + 1 + 4; }

// The page's last line of text may end here: the footer ("... page 2 of 2") starts 24 pt above the bottom.
constexpr double kFooterTop = kPageHeight - 30.0;

// Key-value rows in two columns (keys in grey) starting at x, width w; returns the height used.
double key_values(Canvas& cv, double x, double y, double w, const KeyValues& rows) {
  const double pitch = text_line_height(kBody) + 1.5;
  const double key_width = key_column_width(w, rows);
  double used = 0;
  for (const auto& [k, v] : rows) {
    cv.text(x, y + used, k, style(kBody, false, kGrey));
    used += std::max(pitch, cv.paragraph(x + key_width, y + used, w - key_width, v, style(kBody)));
  }
  return used;
}

// A simple table: header row in bold, then rows (in bold where `bold_rows` says so); column widths as
// fractions of the page width.
void table(Page& p, const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
           const std::vector<double>& widths, std::size_t max_rows, const std::vector<bool>& bold_rows = {}) {
  const double pitch = text_line_height(kBody) + 2;
  auto row = [&](const std::vector<std::string>& cells, bool bold) {
    double x = p.left;
    for (std::size_t c = 0; c < cells.size() && c < widths.size(); ++c) {
      p.cv.text(x, p.y, cells[c], style(kBody, bold));
      x += widths[c] * p.width;
    }
    p.y += pitch;
  };
  row(header, true);
  for (std::size_t r = 0; r < rows.size() && r < max_rows; ++r) row(rows[r], r < bold_rows.size() && bold_rows[r]);
  if (rows.size() > max_rows)
    row({"... " + std::to_string(rows.size() - max_rows) + " more in the HTML report and sub-<id>_clusters.tsv"}, false);
}

void picture(Page& p, const io::RgbImage& img, double max_height) {
  if (img.width == 0) return;
  const double scale = std::min(p.width / img.width, max_height / img.height);
  p.cv.image(img, p.left + (p.width - img.width * scale) / 2, p.y, scale);
  p.y += img.height * scale + 4;
}

void first_page(Page& p, const ReportData& d, const ReportFigures& f) {
  p.cv.fill_rect(0, 0, kPageWidth, 6, kAccent);
  p.cv.text(p.left, p.y, d.title, style(16, true));
  p.y += text_line_height(16) + 2;
  p.cv.text(p.left, p.y, "Subject " + (d.subject_id.empty() ? std::string("(unnamed)") : d.subject_id), style(12, true));
  p.y += text_line_height(12) + 6;
  KeyValues info = d.subject_info;
  const double half = p.width / 2 - 8;
  const double a = key_values(p.cv, p.left, p.y, half, info);
  const double b = key_values(p.cv, p.left + half + 16, p.y, half, reference_rows(d.normative));
  p.y += std::max(a, b) + 4;
  for (const std::string& n : d.notes) p.y += p.cv.paragraph(p.left, p.y, p.width, n, style(kBody, false, {150, 90, 0}));
  heading(p, "Findings");
  p.y += p.cv.paragraph(p.left, p.y, p.width, d.summary.empty() ? "PET only: no normative reference, no z-scores." : d.summary,
                        style(10.5, true));
  p.y += 2 + p.cv.paragraph(p.left, p.y, p.width, report_disclaimer(d.normative), style(8.5, false, kGrey));
  heading(p, "3D views");
  // Each view with its caption (what grey and magenta mean, as the HTML says).
  double captions = 0;
  for (const ReportFigure& fig : f.views) captions += paragraph_height(p.width, fig.caption, 7.5) + 2;
  const double room = (kPageHeight - kMarginPt - p.y - captions) / std::max<std::size_t>(f.views.size(), 1);
  for (const ReportFigure& fig : f.views) {
    picture(p, fig.image, room - 6);
    p.y += p.cv.paragraph(p.left, p.y, p.width, fig.caption, style(7.5, false, kGrey)) + 2;
  }
}

std::vector<std::vector<std::string>> cluster_rows(const ReportData& d) {
  std::vector<std::vector<std::string>> rows;
  for (const ReportCluster& c : d.clusters)
    rows.push_back({std::to_string(c.id), c.hemisphere, c.sign == "hypo" ? "hypo" : "hyper",
                    c.region.empty() ? "\u2014" : readable_region(c.region), c.peak_region.empty() ? "\u2014" : readable_region(c.peak_region),
                    std::to_string(c.num_elements), format_fixed(c.area_mm2, 0), format_fixed(c.peak_z, 1, true),
                    format_fixed(c.mean_z, 1, true), c.controls_as_large >= 0 ? format_fixed(c.p_controls, 3) : "\u2014"});
  return rows;
}

// Per cluster row: larger than every control's chance clusters (shown in bold).
std::vector<bool> beyond_chance(const ReportData& d) {
  std::vector<bool> bold;
  for (const ReportCluster& c : d.clusters) bold.push_back(c.controls_as_large == 0);
  return bold;
}

// Lobes of both hemispheres side by side: lobe, left (n, mean z), right (n, mean z).
std::vector<std::vector<std::string>> lobe_rows(const ReportData& d) {
  std::vector<std::vector<std::string>> rows;
  for (const ReportRegion& r : d.regions) {
    if (!r.region.empty() || r.hemisphere != "left") continue;
    std::vector<std::string> row = {r.lobe, std::to_string(r.elements), format_fixed(r.mean_z, 2, true), "", ""};
    for (const ReportRegion& q : d.regions)
      if (q.region.empty() && q.hemisphere == "right" && q.lobe == r.lobe) {
        row[3] = std::to_string(q.elements);
        row[4] = format_fixed(q.mean_z, 2, true);
      }
    rows.push_back(row);
  }
  return rows;
}

void second_page(Page& p, const ReportData& d, const ReportFigures& f) {
  // What ends the page: the quality and processing tables, then the disclaimer.
  const double half = p.width / 2 - 8;
  const double tail = heading_height() + std::max(key_values_height(half, d.quality), key_values_height(half, d.parameters)) + 6 +
                      paragraph_height(p.width, report_disclaimer(d.normative), 8.5);
  heading(p, "Clusters of abnormal elements");
  if (!d.normative.present) {
    p.y += p.cv.paragraph(p.left, p.y, p.width, "No normative reference: no clusters.", style(kBody));
  } else if (d.clusters.empty()) {
    p.y += p.cv.paragraph(p.left, p.y, p.width, "No cluster of at least " + std::to_string(d.normative.min_cluster_elements) +
                                                    " elements with |z| \u2265 " + format_fixed(d.normative.threshold, 1) + ".",
                          style(kBody));
  } else {
    // Room for the rest of the page (the lobe table, flat maps of at least 120 pt, quality, the
    // disclaimer) decides how many cluster rows fit; the others are in the HTML and the TSV.
    const double pitch = text_line_height(kBody) + 2;
    const std::size_t lobes = lobe_rows(d).size();
    const double lobe_table = 1 + std::min<std::size_t>(lobes, 10) + (lobes > 10 ? 1 : 0);  // header, rows, "... more"
    const double rest = (d.regions.empty() ? 0.0 : heading_height() + lobe_table * pitch) + heading_height() + 120 + 4 + tail +
                        paragraph_height(p.width, d.normative.chance_clusters_short + ".", 8.5) +
                        (d.region_method.empty() ? 0.0 : paragraph_height(p.width, "Regions: " + d.region_method + ".", 8.5));
    const double room = kFooterTop - p.y - rest - 2 * pitch;
    const std::size_t rows = static_cast<std::size_t>(std::clamp(std::floor(room / pitch), 3.0, 12.0));
    table(p, {"#", "side", "type", "region", "peak region", "elements", "mm\u00b2", "peak z", "mean z", "p"}, cluster_rows(d),
          {0.04, 0.06, 0.07, 0.2, 0.2, 0.1, 0.08, 0.08, 0.08, 0.09}, rows, beyond_chance(d));
    if (!d.normative.chance_clusters_short.empty())
      p.y += p.cv.paragraph(p.left, p.y, p.width, d.normative.chance_clusters_short + ".", style(8.5, false, kGrey));
  }
  if (!d.region_method.empty()) p.y += p.cv.paragraph(p.left, p.y, p.width, "Regions: " + d.region_method + ".", style(8.5, false, kGrey));
  if (!d.regions.empty()) {
    heading(p, "Mean z by lobe");
    table(p, {"lobe", "left: elements", "left: mean z", "right: elements", "right: mean z"}, lobe_rows(d), {0.2, 0.2, 0.2, 0.2, 0.2}, 10);
  }
  heading(p, "Flat maps");
  // Two square maps side by side: z per hemisphere when compared, else PET (the HTML has them
  // all, and the rectangle).
  const bool z = d.normative.present;
  const double cell = p.width / 2;
  // The flat maps take what the quality table and the disclaimer leave (at most 200 pt).
  const double map_height = std::clamp(kFooterTop - p.y - tail - 4, 60.0, 200.0);
  int k = 0;
  double row_height = 0;
  for (const ReportFigure& fig : f.flat_maps) {
    const bool square = fig.alt.find("rectangle") == std::string::npos;
    if (!square || k == 2 || (fig.alt.find("z-score") != std::string::npos) != z) continue;
    const double scale = std::min((cell - 6) / fig.image.width, map_height / fig.image.height);
    p.cv.image(fig.image, p.left + k * cell, p.y, scale);
    row_height = std::max(row_height, fig.image.height * scale);
    ++k;
  }
  p.y += row_height + 4;
  heading(p, "Quality and processing");
  const double a = key_values(p.cv, p.left, p.y, half, d.quality);
  const double b = key_values(p.cv, p.left + half + 16, p.y, half, d.parameters);
  p.y += std::max(a, b) + 6;
  p.cv.paragraph(p.left, p.y, p.width, report_disclaimer(d.normative), style(8.5, false, kGrey));
}

}  // namespace

void write_report_pdf(const std::string& path, const ReportData& d) { write_report_pdf(path, d, report_figures(d)); }

void write_report_pdf(const std::string& path, const ReportData& d, const ReportFigures& figures) {
  std::string bytes;
  {
    const auto cv = Canvas::pdf(&bytes, kPageWidth, kPageHeight);
    Page one{*cv};
    first_page(one, d, figures);
    cv->text(kMarginPt, kPageHeight - 24, (d.software.empty() ? std::string("authalic") : d.software) + " \u00b7 page 1 of 2",
             style(7.5, false, kGrey));
    cv->next_page();
    Page two{*cv};
    second_page(two, d, figures);
    cv->text(kMarginPt, kPageHeight - 24, (d.software.empty() ? std::string("authalic") : d.software) + " \u00b7 page 2 of 2",
             style(7.5, false, kGrey));
    cv->finish();
  }
  io::write_file_atomically(path, bytes);
}

}  // namespace authalic::analysis

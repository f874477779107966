#pragma once
// The report's pictures, drawn once and used by both the HTML page and the PDF: the eight
// standard 3D views of z (thresholded over sulcal-shaded grey cortex) and of PET, and the flat
// square and rectangle maps with a light element grid (analysis/render.h).
#include <sstream>
#include <string>
#include <vector>

#include "analysis/report.h"
#include "io/image_io.h"

namespace authalic::analysis {

struct ReportFigure {
  io::RgbImage image;
  std::string alt, caption;
};

struct ReportFigures {
  std::vector<ReportFigure> views;      // standard views: z (when compared), then PET
  std::vector<ReportFigure> flat_maps;  // per hemisphere z and PET on the square; the rectangle
};

// z colours: coolwarm over [-kReportZRange, kReportZRange], the same in every report; beyond it
// the colour bar marks saturation ("≤ −5").
constexpr double kReportZRange = 5.0;

ReportFigures report_figures(const ReportData& data);

// Per-vertex z of a hemisphere: given, or spread from the element z-scores through each
// vertex's element (NaN outside the elements); empty when there is none.
VectorXd report_vertex_z(const ReportHemisphere& h);

// The report from pictures drawn once (report_html / write_report / write_report_pdf of
// analysis/report.h draw them themselves): the pipeline writes the HTML and the PDF from one set.
std::string report_html(const ReportData& data, const ReportFigures& figures);
void write_report(const std::string& path, const ReportData& data, const ReportFigures& figures);
void write_report_pdf(const std::string& path, const ReportData& data, const ReportFigures& figures);

// The HTML report's interactive section (analysis/report_viewer.cpp).
void viewer_section(std::ostringstream& out, const ReportData& data);

}  // namespace authalic::analysis

#pragma once
// The per-subject clinical report, as a nuclear-medicine physician reads and files it: one
// self-contained HTML file (pictures embedded as base64 PNG, inline CSS, the Niivue 3D viewer
// inlined with its data, analysis/report_viewer.cpp; no external resource) that opens offline,
// and a PDF of two A4 pages (analysis/report_pdf.cpp) for the patient record. Both show, in
// order: header (subject, scan, reference), the findings in one paragraph with the
// decision-support disclaimer, the eight standard 3D views of z and
// PET (NEUROSTAT/3D-SSP layout), the flat maps, the cluster and regional tables by anatomical
// name, quality flags and processing parameters. The pipeline fills a ReportData; the pictures
// come from analysis/report_figures.h. Nothing here reads the clock: same data, same bytes.
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/mesh.h"
#include "io/image_io.h"

namespace authalic::analysis {

using KeyValues = std::vector<std::pair<std::string, std::string>>;

// One cluster of connected abnormal elements (from the normative comparison).
struct ReportCluster {
  int id = 0;
  std::string hemisphere;        // "left", "right", "both" (rectangle domain)
  std::string sign;              // "hypo" (z <= -threshold) or "hyper"
  int num_elements = 0;
  double area_mm2 = 0.0;         // cortical area of its elements
  double peak_z = 0.0;
  double mean_z = 0.0;
  int peak_row = -1, peak_col = -1;  // element of the peak (row 0 = bottom of the domain)
  double peak_ras[3] = {0, 0, 0};    // scanner RAS mm of that element's centroid
  std::string region;            // majority region of its vertices ("" = unnamed)
  double region_fraction = 0.0;  // share of its labelled vertices in `region`
  std::string peak_region;       // region of the peak element
  // Chance clusters of the controls (analysis/normative.h): how many of `controls` had a cluster
  // of this sign at least as large, and p = (1 + that) / (1 + controls); -1 / NaN when not measured.
  int controls_as_large = -1, controls = 0;
  double p_controls = std::numeric_limits<double>::quiet_NaN();
};

// A row of the regional table: a lobe (region empty) or a region within it.
struct ReportRegion {
  std::string hemisphere, lobe, region;
  int elements = 0;
  double mean_z = 0.0;
};

struct ReportHemisphere {
  std::string name = "left";     // "left" / "right"
  bool left = true;
  // The flat map (#V x >= 2, in the domain: [0,1]^2 for the square) on the surface's vertices.
  MatrixXd flat_uv;
  MatrixXi faces;                // the map's triangles (the cortex)
  double domain_width = 1.0, domain_height = 1.0;
  int grid_cols = 0, grid_rows = 0;  // element grid (K x K on the square)
  // A 3D surface on the same vertices for the lateral/medial views (pial, white or inflated; RAS mm).
  MatrixXd surface_V;
  MatrixXi surface_F;            // faces for the 3D views (may include the medial wall); empty = `faces`
  VectorXi element_of_vertex;    // per vertex element id (row * cols + col), -1 outside: draws the grid in 3D
  // Values.
  VectorXd pet;                  // per vertex (normalised PET), may hold NaN outside the cortex
  VectorXd z;                    // per vertex z-score; empty = take element_z through element_of_vertex
  std::vector<double> element_pet, element_z;  // rows x cols, row 0 at the bottom; may be empty
  KeyValues distortion;          // e.g. {"flipped triangles", "0"}, {"element-area CV (K=32)", "0.006"}
  VectorXd shading;              // per surface_V vertex gray level (sulcal shading); empty = plain
  // The 2:1 whole-brain rectangle part of this hemisphere (UV in [0,2] x [0,1]), may be empty.
  MatrixXd rectangle_uv;
  MatrixXi rectangle_faces;
};

struct ReportNormative {
  bool present = false;
  int num_subjects = 0;
  std::string normalisation;     // e.g. "global cortical mean (SUVR)"
  std::string domain;            // e.g. "square, K = 32"
  std::string description;       // free text: what the reference is, its file, its software version
  double threshold = 2.0;        // |z| flagged
  std::string rescale;           // the patient's rescaling to the reference (CompareOptions::rescale), "" = not shown
  // How z was computed, for the method text: the age model, the predictive SD, the rescaling, and
  // the share of a healthy subject's elements the t distribution puts beyond the threshold.
  bool age_adjusted = false;
  bool predictive = true;
  bool rescaled = false;
  double expected_abnormal_share = std::numeric_limits<double>::quiet_NaN();
  std::string age_range;         // e.g. "55-78 years"
  std::string correspondence;    // how patient and controls correspond, e.g. "the same K x K square elements"
  int min_cluster_elements = 1;  // clusters smaller than this are not reported
  std::string chance_clusters;   // how the clusters' p was measured, or why not ("" = not shown)
  std::string chance_clusters_short;  // the same in one line (the PDF's)
};

struct ReportData {
  std::string title = "Authalic PET report";
  std::string subject_id;
  KeyValues subject_info;        // e.g. {"PET", "sub-01_pet.nii.gz (sha256 ...)"}, {"age", "67"}
  KeyValues parameters;          // processing parameters (sampling depth, normalisation, K, ...)
  std::string pet_units = "SUVR";
  std::vector<ReportHemisphere> hemispheres;
  ReportNormative normative;
  std::vector<ReportCluster> clusters;
  std::vector<ReportRegion> regions;  // regional table (both hemispheres)
  std::string region_method;     // how regions were named (stated under the tables)
  KeyValues quality;             // quality flags: map acceptance, registration, PET coverage
  std::string summary;           // the findings in words (one paragraph)
  std::vector<std::string> notes;  // warnings or remarks shown at the top
  std::string software;          // e.g. "authalic 0.1.0 (abc1234)"
};

// Shown on every report: what the numbers are and are not (a PET-only report has no z-scores to
// speak of).
std::string report_disclaimer(const ReportNormative& normative);
// The reference described in rows (n, age range, normalisation, elements, correspondence, file
// and software), for the header of both the HTML and the PDF.
KeyValues reference_rows(const ReportNormative& normative);

// The page as a string (UTF-8 HTML5, well-formed: every element closed, void elements written
// as <img ... />). Section ids: subject, parameters, flat-maps, surface-views, clusters,
// normative, distortion.
std::string report_html(const ReportData& data);
// Writes report_html(data) atomically.
void write_report(const std::string& path, const ReportData& data);
// The same report as a PDF of A4 pages (Cairo PDF surface), written atomically.
void write_report_pdf(const std::string& path, const ReportData& data);

// Helpers, public for tests and other pages.
std::string html_escape(const std::string& text);
// A PNG data URI for an <img src>.
std::string png_data_uri(const io::RgbImage& image);

// Colour range of a PET map: 2nd to 98th percentile of the finite values (robust to outliers).
std::pair<double, double> robust_range(const VectorXd& values);

}  // namespace authalic::analysis

#pragma once
// Distortion of a map from a surface (V, #V x 3, mm) to a domain (planar UV, #V x 2, or a
// sphere, #V x 3), on the faces F. Definitions match the independent checker
// ../shared/tools/evalmap.py:
//  - area ratio of a face: ln((A3_f / ΣA3) / (A2_f / ΣA2)), both totals over the faces measured, so
//    a map that preserves area up to one global scale scores 0; faces with zero domain area are
//    left out of the statistics (and counted as flipped);
//  - Υ = ln(γmax γmin) and Λ = ln(γmax / γmin) per face, γ the singular values of the affine map
//    from the domain triangle to the surface triangle (Zou et al. 2011a, eq. 23), the
//    domain scaled so the total areas are equal ("totals normalised"): Υ is then exactly the
//    face's ln area ratio above;
//  - per vertex: the same ratio of barycentric vertex areas (Zou et al. 2011a eq. 11);
//  - flips: planar faces with signed area <= 0 (after un-mirroring a globally mirrored map);
//    sphere faces whose normal points inward;
//  - element-area coefficient of variation: the cortical area each cell of a K x K grid (2K x K on
//    the 2:1 rectangle, 2K x K equal-area cells on the sphere) receives through the map, computed
//    exactly by clipping triangles against cells (core/grid_overlap.h; evalmap.py computes the
//    same exactly, by its own clipping and, on the sphere, edge integrals), standard deviation over
//    mean (population standard deviation).
#include <string>
#include <vector>

#include "core/domain.h"
#include "core/mesh.h"

namespace authalic {

// Summary statistics of |x| over a set of values.
struct AbsStats {
  double mean = 0, median = 0, p95 = 0, p99 = 0, max = 0;
  int count = 0;
};
AbsStats abs_stats(const VectorXd& values);

struct MapMetrics {
  Domain domain;
  int faces = 0;                 // faces measured
  int vertices = 0;              // vertices used by them
  int flips = 0;                 // flipped or degenerate faces
  bool mirrored = false;         // planar map was globally mirrored (un-mirrored before measuring)
  AbsStats face_ln_area;         // |ln area ratio| per face (= |Υ|)
  double face_ln_area_sd = 0;    // standard deviation of the signed ln ratio
  AbsStats vertex_ln_area;       // |ln area ratio| per vertex (barycentric areas)
  double upsilon_mean = 0;       // mean signed Υ
  AbsStats lambda;               // Λ >= 0 per face
  int element_cols = 0, element_rows = 0;
  double element_cv = 0;         // std / mean of the cortical area per element
  double element_min = 0, element_max = 0;  // smallest / largest element area over the mean
  double element_mean_mm2 = 0;   // mean cortical area per element (surface units^2)
  double surface_area = 0;       // ΣA3 over the faces measured (mm^2)
  double domain_area = 0;        // ΣA2 (domain units^2; steradians on the sphere)
  double outside_fraction = 0;   // domain area of the faces outside the domain rectangle / ΣA2
};

// Acceptance of an authalic map: what a result must reach to be returned as a success.
struct AuthalicAcceptance {
  // Element-area CV (metrics' K x K grid; skipped under measure control): this, or on a coarse
  // mesh 3 x coarse_face_sd / sqrt(faces per element) if larger.
  double max_element_cv = 0.01;
  double coarse_face_sd = 0.1;  // per-face SD of ln area ratio of a good map (fsaverage5: 0.08)
  double max_vertex_ln_area = 0.01;  // per-vertex mean |ln area ratio| against the map's own target
  // Every element's area within this share of the mean (skipped with the CV), or on a coarse mesh
  // 8 x coarse_face_sd / sqrt(faces per element) if larger. The CV alone let a pocket pass: one
  // element of a one-surface rectangle of fs741 white held 1.35 x its share at CV 0.0096; good
  // maps stay within 1.06 on fs741 and 1.10 on fsaverage5 (10 faces per element on the sphere).
  double max_element_deviation = 0.25;
};
// The element-CV limit the acceptance applies to metrics m: limits.max_element_cv, or on a
// coarse mesh (few faces per element) 3 x coarse_face_sd / sqrt(faces per element) if larger.
double element_cv_limit(const MapMetrics& m, const AuthalicAcceptance& limits = {});
// The same for a map of `faces` faces on a grid of `elements` elements.
double element_cv_limit(long long faces, int elements, const AuthalicAcceptance& limits = {});
// The largest |element area / mean - 1| the acceptance allows for metrics m (max_element_deviation,
// or 8 x coarse_face_sd / sqrt(faces per element) if larger).
double element_deviation_limit(const MapMetrics& m, const AuthalicAcceptance& limits = {});
// Empty when the map passes: 0 flipped triangles, element CV, every element and per-vertex error
// within the limits (vertex_mean: the per-vertex mean |ln ratio| against the map's target measure, e.g. the
// flow's report; check_element_cv false for a measure-controlled map, whose elements are meant to
// differ). Otherwise the measured numbers beside the limits, for a one-line error.
std::string authalic_acceptance_problem(const MapMetrics& m, double vertex_mean, bool check_element_cv,
                                        const AuthalicAcceptance& limits = {});

// Per-face signed ln area ratio (NaN for faces with zero domain area). UV: #V x >= 2 (planar,
// absolute areas) or #V x 3 on a sphere (sphere = true: chord triangles of the unit-normalised points).
VectorXd face_log_area_ratio(const MatrixXd& V, const MatrixXd& UV, const MatrixXi& F, bool sphere = false);
// Per-vertex signed ln area ratio of barycentric vertex areas (NaN for unused vertices).
VectorXd vertex_log_area_ratio(const MatrixXd& V, const MatrixXd& UV, const MatrixXi& F, bool sphere = false);
// Υ and Λ per face (Zou et al. 2011a eq. 23) with the domain scaled to the surface's total area. For a
// sphere map the domain triangle is the chord triangle of the normalised points. NaN where the
// domain triangle is degenerate.
void face_stretch_metrics(const MatrixXd& V, const MatrixXd& UV, const MatrixXi& F, VectorXd* upsilon, VectorXd* lambda,
                          bool sphere = false);

// Everything above, plus element areas over the domain's element grid at resolution K
// (core/domain.h: K x K on the square, 2K x K on the rectangle and the sphere), in the map's own
// coordinates.
MapMetrics map_metrics(const MatrixXd& V, const MatrixXd& UV, const MatrixXi& F, const Domain& domain, int k = 32);

// Cortical area per element (row-major, row 0 at y = 0) for a planar map on [0, W] x [0, 1]
// with cols x rows cells.
VectorXd element_areas(const MatrixXd& V, const MatrixXd& UV, const MatrixXi& F, double width, int cols, int rows);

}  // namespace authalic

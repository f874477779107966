// Map distortion metrics (see core/metrics.h for the definitions, shared with evalmap.py).
#include "core/metrics.h"

#include <sstream>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/grid_overlap.h"

namespace authalic {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// numpy.percentile with linear interpolation, by selection (the array is reordered): two order
// statistics instead of a full sort (abs_stats runs several times per polish step of a 300k-face map).
double percentile_select(std::vector<double>& a, double p) {
  if (a.empty()) return kNaN;
  const double pos = (a.size() - 1) * p / 100.0;
  const size_t lo = static_cast<size_t>(std::floor(pos));
  std::nth_element(a.begin(), a.begin() + lo, a.end());
  const double a_hi = lo + 1 < a.size() ? *std::min_element(a.begin() + lo + 1, a.end()) : a[lo];
  return a[lo] + (pos - lo) * (a_hi - a[lo]);
}

// Unit-normalised sphere points (rows of UV as 3D directions).
MatrixXd normalised_rows(const MatrixXd& S) {
  MatrixXd N = S.leftCols(3);
  for (Eigen::Index i = 0; i < N.rows(); ++i) {
    const double r = N.row(i).norm();
    if (r > 0) N.row(i) /= r;
  }
  return N;
}

// Domain face areas: |signed| planar areas, or chord-triangle areas on the sphere.
VectorXd domain_face_areas(const MatrixXd& UV, const MatrixXi& F, bool sphere) {
  if (sphere) return face_areas(normalised_rows(UV), F);
  return signed_face_areas_2d(UV, F).cwiseAbs();
}

// Singular values (s1 >= s2) of a 2x2 matrix, closed form.
void singular_values_2x2(const Eigen::Matrix2d& J, double* s1, double* s2) {
  const double a = J(0, 0), b = J(0, 1), c = J(1, 0), d = J(1, 1);
  const double e = 0.5 * (a + d), f = 0.5 * (a - d), g = 0.5 * (c + b), h = 0.5 * (c - b);
  const double q = std::hypot(e, h), r = std::hypot(f, g);
  *s1 = q + r;
  *s2 = std::abs(q - r);
}

// Edge vectors of triangle f in an orthonormal frame of its own plane (columns e1, e2).
Eigen::Matrix2d local_edges(const MatrixXd& P, const MatrixXi& F, Eigen::Index f) {
  const Eigen::Vector3d p0 = P.row(F(f, 0)).head<3>().transpose();
  const Eigen::Vector3d e1 = P.row(F(f, 1)).head<3>().transpose() - p0;
  const Eigen::Vector3d e2 = P.row(F(f, 2)).head<3>().transpose() - p0;
  const Eigen::Vector3d n = e1.cross(e2);
  const double l1 = e1.norm();
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();
  if (l1 == 0) return S;
  const Eigen::Vector3d u = e1 / l1;
  Eigen::Vector3d w = n.cross(u);
  const double lw = w.norm();
  if (lw > 0) w /= lw;
  S << e1.dot(u), e2.dot(u), e1.dot(w), e2.dot(w);
  return S;
}

}  // namespace

AbsStats abs_stats(const VectorXd& values) {
  std::vector<double> a;
  a.reserve(values.size());
  double sum = 0;
  for (Eigen::Index i = 0; i < values.size(); ++i)
    if (std::isfinite(values[i])) a.push_back(std::abs(values[i]));
  AbsStats s;
  s.count = static_cast<int>(a.size());
  if (a.empty()) return s;
  for (double x : a) sum += x;  // in index order: independent of threads
  s.mean = sum / a.size();
  s.median = percentile_select(a, 50);
  s.p95 = percentile_select(a, 95);
  s.p99 = percentile_select(a, 99);
  s.max = *std::max_element(a.begin(), a.end());
  return s;
}

VectorXd face_log_area_ratio(const MatrixXd& V, const MatrixXd& UV, const MatrixXi& F, bool sphere) {
  const VectorXd a3 = face_areas(V, F), a2 = domain_face_areas(UV, F, sphere);
  double s3 = 0, s2 = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (a2[f] > 0) s3 += a3[f], s2 += a2[f];
  VectorXd r(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) r[f] = a2[f] > 0 ? std::log((a3[f] / s3) / (a2[f] / s2)) : kNaN;
  return r;
}

VectorXd vertex_log_area_ratio(const MatrixXd& V, const MatrixXd& UV, const MatrixXi& F, bool sphere) {
  const VectorXd a3 = face_areas(V, F), a2 = domain_face_areas(UV, F, sphere);
  const Eigen::Index nv = std::max(V.rows(), UV.rows());
  VectorXd v3 = VectorXd::Zero(nv), v2 = VectorXd::Zero(nv);
  std::vector<char> used(nv, 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      v3[F(f, c)] += a3[f] / 3.0;
      v2[F(f, c)] += a2[f] / 3.0;
      used[F(f, c)] = 1;
    }
  const double s3 = v3.sum(), s2 = v2.sum();
  VectorXd r(nv);
  for (Eigen::Index v = 0; v < nv; ++v)
    r[v] = (used[v] && v2[v] > 0 && v3[v] > 0) ? std::log((v3[v] / s3) / (v2[v] / s2)) : kNaN;
  return r;
}

void face_stretch_metrics(const MatrixXd& V, const MatrixXd& UV, const MatrixXi& F, VectorXd* upsilon, VectorXd* lambda,
                          bool sphere) {
  const VectorXd a3 = face_areas(V, F), a2 = domain_face_areas(UV, F, sphere);
  double s3 = 0, s2 = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (a2[f] > 0) s3 += a3[f], s2 += a2[f];
  const double log_scale = std::log(s3 / s2);  // domain scaled to the surface's total area
  const MatrixXd D3 = sphere ? normalised_rows(UV) : MatrixXd();
  if (upsilon) upsilon->resize(F.rows());
  if (lambda) lambda->resize(F.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Matrix2d S = local_edges(V, F, f);
    Eigen::Matrix2d D;
    if (sphere) {
      D = local_edges(D3, F, f);
    } else {
      D << UV(F(f, 1), 0) - UV(F(f, 0), 0), UV(F(f, 2), 0) - UV(F(f, 0), 0), UV(F(f, 1), 1) - UV(F(f, 0), 1),
          UV(F(f, 2), 1) - UV(F(f, 0), 1);
    }
    const double det = D.determinant();
    double up = kNaN, la = kNaN;
    if (std::abs(det) > 1e-300) {
      const Eigen::Matrix2d J = S * D.inverse();
      double s1, s2v;
      singular_values_2x2(J, &s1, &s2v);
      la = std::log(s1 / std::max(s2v, 1e-300));
      up = std::log(s1 * s2v) - log_scale;
    }
    if (upsilon) (*upsilon)[f] = up;
    if (lambda) (*lambda)[f] = la;
  }
}

VectorXd element_areas(const MatrixXd& V, const MatrixXd& UV, const MatrixXi& F, double width, int cols, int rows) {
  GridSpec grid;
  grid.cols = cols;
  grid.rows = rows;
  grid.width = width;
  grid.height = 1.0;
  const auto pieces = grid_overlap(UV, F, grid);
  // Each face hands out its 3D area in proportion to its domain area in each cell; the whole
  // face's domain area is the denominator, so a part outside the grid is lost (as it should be).
  return cell_surface_areas(pieces, face_areas(V, F), signed_face_areas_2d(UV, F).cwiseAbs(), grid.num_cells());
}

MapMetrics map_metrics(const MatrixXd& V, const MatrixXd& UV, const MatrixXi& F, const Domain& domain, int k) {
  MapMetrics m;
  m.domain = domain;
  m.faces = static_cast<int>(F.rows());
  const bool sphere = !domain.planar();
  MatrixXd U = sphere ? UV.leftCols(3) : UV.leftCols(2);
  {
    std::vector<char> used(std::max(V.rows(), UV.rows()), 0);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;
    for (char u : used) m.vertices += u;
  }
  if (sphere) {
    const MatrixXd S = normalised_rows(U);
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      const Eigen::Vector3d a = S.row(F(f, 0)).transpose(), b = S.row(F(f, 1)).transpose(), c = S.row(F(f, 2)).transpose();
      if (!((b - a).cross(c - a).dot((a + b + c) / 3.0) > 0)) ++m.flips;
    }
  } else {
    VectorXd sa = signed_face_areas_2d(U, F);
    int negative = 0;
    for (Eigen::Index f = 0; f < sa.size(); ++f) negative += sa[f] < 0;
    if (negative > sa.size() / 2) {
      // A globally mirrored map is not a flip: reflect it (as evalmap.py does).
      m.mirrored = true;
      const double lo = U.col(0).minCoeff(), hi = U.col(0).maxCoeff();
      U.col(0) = (lo + hi) - U.col(0).array();
      sa = -sa;
    }
    for (Eigen::Index f = 0; f < sa.size(); ++f) m.flips += !(sa[f] > 0);
  }
  VectorXd up, la;
  face_stretch_metrics(V, U, F, &up, &la, sphere);
  const VectorXd fr = face_log_area_ratio(V, U, F, sphere);
  m.face_ln_area = abs_stats(fr);
  {
    double sum = 0, sq = 0;
    int n = 0;
    for (Eigen::Index f = 0; f < fr.size(); ++f)
      if (std::isfinite(fr[f])) sum += fr[f], ++n;
    const double mean = n ? sum / n : 0;
    for (Eigen::Index f = 0; f < fr.size(); ++f)
      if (std::isfinite(fr[f])) sq += (fr[f] - mean) * (fr[f] - mean);
    m.face_ln_area_sd = n ? std::sqrt(sq / n) : 0;
    sum = 0, n = 0;
    for (Eigen::Index f = 0; f < up.size(); ++f)
      if (std::isfinite(up[f])) sum += up[f], ++n;
    m.upsilon_mean = n ? sum / n : 0;
  }
  m.vertex_ln_area = abs_stats(vertex_log_area_ratio(V, U, F, sphere));
  m.lambda = abs_stats(la);
  const VectorXd a3 = face_areas(V, F), a2 = domain_face_areas(U, F, sphere);
  m.surface_area = a3.sum();
  m.domain_area = a2.sum();

  m.element_cols = domain.element_cols(k);
  m.element_rows = domain.element_rows(k);
  const auto pieces = domain.element_overlap(U, F, k);
  const int num_cells = m.element_cols * m.element_rows;
  VectorXd cells;
  if (sphere) {
    cells = cell_surface_areas(pieces, a3, piece_face_areas(pieces, m.faces), num_cells);
  } else {
    // Each face hands out its 3D area in proportion to its domain area in each cell; the whole
    // face's domain area is the denominator, so a part outside the grid is lost (as it should be).
    cells = cell_surface_areas(pieces, a3, a2, num_cells);
    // Domain area outside [0, W] x [0, 1]: the faces' total minus what the grid received.
    double inside = 0;
    for (const auto& p : pieces) inside += p.domain_area;
    m.outside_fraction = m.domain_area > 0 ? std::max(0.0, 1.0 - inside / m.domain_area) : 0.0;
  }
  const double mean = cells.mean();
  m.element_mean_mm2 = mean;
  if (mean > 0) {
    m.element_cv = std::sqrt((cells.array() - mean).square().mean()) / mean;
    m.element_min = cells.minCoeff() / mean;
    m.element_max = cells.maxCoeff() / mean;
  }
  return m;
}

double element_cv_limit(long long faces, int elements, const AuthalicAcceptance& limits) {
  // On a coarse mesh an element holds few triangles, and its area varies by their triangle-level
  // noise: allow 3 standard errors of a good map's noise (a fixed SD, so a broken map cannot
  // loosen its own limit).
  const double faces_per_element = double(faces) / std::max(1, elements);
  return std::max(limits.max_element_cv, 3.0 * limits.coarse_face_sd / std::sqrt(std::max(1.0, faces_per_element)));
}

double element_cv_limit(const MapMetrics& m, const AuthalicAcceptance& limits) {
  return element_cv_limit(m.faces, m.element_cols * m.element_rows, limits);
}

double element_deviation_limit(const MapMetrics& m, const AuthalicAcceptance& limits) {
  // The largest of #elements draws of a good map's element noise lies within about 3.5 of its
  // standard errors; 8 leave room for the mesh's own irregularity.
  const double faces_per_element = double(m.faces) / std::max(1, m.element_cols * m.element_rows);
  return std::max(limits.max_element_deviation, 8.0 * limits.coarse_face_sd / std::sqrt(std::max(1.0, faces_per_element)));
}

std::string authalic_acceptance_problem(const MapMetrics& m, double vertex_mean, bool check_element_cv,
                                        const AuthalicAcceptance& limits) {
  const double cv_limit = element_cv_limit(m, limits), deviation_limit = element_deviation_limit(m, limits);
  const bool cv_bad = check_element_cv && !(m.element_cv <= cv_limit);
  const double deviation = std::max(m.element_max - 1.0, 1.0 - m.element_min);
  const bool element_bad = check_element_cv && !(deviation <= deviation_limit);
  const bool vertex_bad = !(vertex_mean <= limits.max_vertex_ln_area);
  if (m.flips == 0 && !cv_bad && !element_bad && !vertex_bad) return {};
  std::ostringstream s;
  s << m.flips << " flipped triangles (limit 0), element CV " << m.element_cv << " (" << m.element_cols << "x"
    << m.element_rows << (check_element_cv ? ", limit " + std::to_string(cv_limit).substr(0, 6) : ", not checked") << ")";
  if (element_bad)
    s << ", an element holding " << (m.element_max - 1.0 >= 1.0 - m.element_min ? m.element_max : m.element_min)
      << " x the mean area (limit 1 +- " << deviation_limit << ")";
  s << ", per-vertex mean |ln area ratio| " << vertex_mean << " (limit " << limits.max_vertex_ln_area << ")";
  return s.str();
}

}  // namespace authalic

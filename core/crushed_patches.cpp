// Equal-area radial rearrangement about crushed patches of a sphere map (see core/crushed_patches.h).
#include "core/crushed_patches.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "core/sphere_flow.h"
#include "core/sphere_map.h"

namespace authalic {
namespace {

using Vec3 = Eigen::Vector3d;

Vec3 corner(const MatrixXd& S, const MatrixXi& F, Eigen::Index f, int c) { return S.row(F(f, c)).transpose(); }

// Each face's share of the map's total (flat chord) area.
VectorXd chord_area_shares(const MatrixXd& S, const MatrixXi& F) {
  VectorXd a(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Vec3 p = corner(S, F, f, 0);
    a[f] = 0.5 * (corner(S, F, f, 1) - p).cross(corner(S, F, f, 2) - p).norm();
  }
  return a / a.sum();
}

// A face below e^log_ratio of its target share.
bool is_crushed(double share, double target, double log_ratio) { return share < std::exp(log_ratio) * target; }

int find_root(std::vector<int>& parent, int v) {
  while (parent[v] != v) v = parent[v] = parent[parent[v]];
  return v;
}

// Patches of crushed faces (joined through shared vertices), each a list of faces, ordered by
// missing share (largest first; ties by their first face, so the order is deterministic).
std::vector<std::vector<int>> crushed_patches(const MatrixXi& F, Eigen::Index nv, const VectorXd& share,
                                              const VectorXd& target, double log_ratio) {
  std::vector<int> parent(static_cast<std::size_t>(nv));
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<int> crushed;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    if (!is_crushed(share[f], target[f], log_ratio)) continue;
    crushed.push_back(static_cast<int>(f));
    for (int c = 1; c < 3; ++c) parent[find_root(parent, F(f, c))] = find_root(parent, F(f, 0));
  }
  std::vector<int> slot(static_cast<std::size_t>(nv), -1);
  std::vector<std::vector<int>> patches;
  for (int f : crushed) {
    const int r = find_root(parent, F(f, 0));
    if (slot[r] < 0) slot[r] = static_cast<int>(patches.size()), patches.emplace_back();
    patches[slot[r]].push_back(f);
  }
  auto missing = [&](const std::vector<int>& p) {
    double m = 0;
    for (int f : p) m += target[f] - share[f];
    return m;
  };
  std::stable_sort(patches.begin(), patches.end(),
                   [&](const std::vector<int>& a, const std::vector<int>& b) { return missing(a) > missing(b); });
  return patches;
}

// The radial profile M(ρ) of the target measure about c below ρ_w, tabulated at `bins` + 1
// equally spaced radii: each face's measure spread uniformly over the chord-distance span of
// its corners (the part below ρ_w counted).
std::vector<double> radial_measure(const MatrixXi& F, const VectorXd& dist, const VectorXd& target, double rho_w,
                                   int bins) {
  std::vector<double> cell(static_cast<std::size_t>(bins), 0.0);
  const double h = rho_w / bins;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const double lo = std::min({dist[F(f, 0)], dist[F(f, 1)], dist[F(f, 2)]});
    if (lo >= rho_w) continue;
    const double hi = std::max({dist[F(f, 0)], dist[F(f, 1)], dist[F(f, 2)]});
    const double width = hi - lo;
    const int b0 = static_cast<int>(lo / h), b1 = std::min(bins - 1, static_cast<int>(hi / h));
    if (width <= 0 || b0 == b1) {
      if (hi < rho_w || width <= 0) cell[b0] += target[f];
      else cell[b0] += target[f] * (rho_w - lo) / width;
      continue;
    }
    for (int b = b0; b <= b1; ++b) {
      const double overlap = std::min(hi, (b + 1) * h) - std::max(lo, b * h);
      if (overlap > 0) cell[b] += target[f] * overlap / width;
    }
  }
  std::vector<double> M(static_cast<std::size_t>(bins) + 1, 0.0);
  for (int b = 0; b < bins; ++b) M[b + 1] = M[b] + cell[b];
  return M;
}

// The chord radius about c within which the faces (all corners inside) hold `goal` of the
// target measure; the search radius doubles from the radius of a cap of that area.
double window_radius(const MatrixXi& F, const VectorXd& dist, const VectorXd& target, double goal) {
  std::vector<std::pair<double, double>> faces;  // (outermost corner distance, measure)
  for (double bound = 2.0 * std::sqrt(4.0 * goal);; bound *= 2.0) {
    faces.clear();
    double held = 0;
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      const double r = std::max({dist[F(f, 0)], dist[F(f, 1)], dist[F(f, 2)]});
      if (r < bound) faces.emplace_back(r, target[f]), held += target[f];
    }
    if (held >= goal || bound >= 2.0) break;
  }
  std::sort(faces.begin(), faces.end());
  double acc = 0;
  for (const auto& [r, m] : faces)
    if ((acc += m) >= goal) return r;
  return faces.empty() ? 0.0 : faces.back().first;
}

// The measure the window's crushed faces miss: Σ (target_f − share_f) over the faces below
// e^log_ratio of their target with a corner inside chord radius rho_w of c (dist: each vertex's
// chord distance to c).
double window_missing(const MatrixXd& S, const MatrixXi& F, const VectorXd& target, const VectorXd& dist, double rho_w,
                      double log_ratio) {
  const VectorXd share = chord_area_shares(S, F);
  double missing = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    if (!(dist[F(f, 0)] < rho_w || dist[F(f, 1)] < rho_w || dist[F(f, 2)] < rho_w)) continue;
    if (is_crushed(share[f], target[f], log_ratio)) missing += target[f] - share[f];
  }
  return missing;
}

// Rearranges the window about the patch; returns false (S unchanged) when it folds faces that
// the repair cannot remove, or when its crushed faces end up missing more measure than before:
// the repair by neighbour means can crush more than the rearrangement opened (a voxelised white
// surface's bulb: missing 1.9e-4 -> 4.6e-5 rearranged, with 76 folds; 3.5e-4 repaired).
bool rearrange_window(MatrixXd& S, const MatrixXi& F, const VectorXd& target, const std::vector<int>& patch,
                      const CrushedPatchOptions& opt, double missing) {
  Vec3 c = Vec3::Zero();
  for (int f : patch) c += target[f] * (corner(S, F, f, 0) + corner(S, F, f, 1) + corner(S, F, f, 2));
  if (!(c.norm() > 0)) return false;
  c.normalize();
  const Eigen::Index nv = S.rows();
  VectorXd dist(nv);
  for (Eigen::Index v = 0; v < nv; ++v) dist[v] = (S.row(v).transpose() - c).norm();
  const double goal = std::min(opt.window_factor * missing, opt.max_window_share);
  const double rho_w = window_radius(F, dist, target, goal);
  if (!(rho_w > 0) || rho_w >= 2.0) return false;
  constexpr int kBins = 4096;
  const std::vector<double> M = radial_measure(F, dist, target, rho_w, kBins);
  if (!(M.back() > 0)) return false;
  const MatrixXd before = S;
  const double missing_before = window_missing(S, F, target, dist, rho_w, opt.crushed_log_ratio);
  for (Eigen::Index v = 0; v < nv; ++v) {
    const double d = dist[v];
    if (d >= rho_w || d <= 0) continue;
    const double x = d / rho_w * kBins;
    const int b = std::min(kBins - 1, static_cast<int>(x));
    const double m = M[b] + (x - b) * (M[b + 1] - M[b]);
    const double R = rho_w * std::sqrt(m / M.back());
    // Along the great circle from c: chord R is the polar angle 2 asin(R / 2).
    const Vec3 p = S.row(v).transpose();
    Vec3 u = p - p.dot(c) * c;
    if (!(u.norm() > 0)) continue;
    u.normalize();
    const double theta = 2.0 * std::asin(std::min(1.0, 0.5 * R));
    S.row(v) = (std::cos(theta) * c + std::sin(theta) * u).transpose();
  }
  if (sphere_flipped_faces(S, F) > 0) repair_sphere_flips(S, F);
  if (sphere_flipped_faces(S, F) == 0 && window_missing(S, F, target, dist, rho_w, opt.crushed_log_ratio) < missing_before)
    return true;
  S = before;
  return false;
}

}  // namespace

void inflate_crushed_patches(MatrixXd& S, const MatrixXi& F, const VectorXd& face_measure,
                             const CrushedPatchOptions& opt, CrushedPatchReport* rep) {
  CrushedPatchReport local;
  CrushedPatchReport& R = rep ? *rep : local;
  const VectorXd target = face_measure / face_measure.sum();
  const VectorXd start = chord_area_shares(S, F);
  const std::vector<std::vector<int>> patches = crushed_patches(F, S.rows(), start, target, opt.crushed_log_ratio);
  for (const std::vector<int>& patch : patches) {
    double missing_at_start = 0;
    for (int f : patch) missing_at_start += target[f] - start[f];
    if (missing_at_start < opt.min_missing_share) break;  // the rest are smaller
    if (static_cast<int>(patch.size()) < opt.min_faces) continue;
    // Shares now: an earlier window may have opened this patch already.
    const VectorXd share = chord_area_shares(S, F);
    double missing = 0;
    for (int f : patch) missing += std::max(0.0, target[f] - share[f]);
    if (missing < opt.min_missing_share) continue;
    if (rearrange_window(S, F, target, patch, opt, missing)) {
      ++R.patches;
      R.crushed_faces += static_cast<int>(patch.size());
      R.missing_share += missing;
    } else {
      ++R.patches_undone;
    }
  }
}

}  // namespace authalic

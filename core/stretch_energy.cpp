// Stretch-energy fixed-point iterations with positive weights (see core/stretch_energy.h).
#include "core/stretch_energy.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/conformal_map.h"
#include "core/sparse_cholesky.h"

namespace authalic {
namespace {

// Per half-edge (face f, corner c: the edge opposite c) cotangent weight ½ cot θ_c of the surface.
MatrixXd surface_cot_weights(const MatrixXd& V, const MatrixXi& F, double min_relative) {
  MatrixXd W(F.rows(), 3);
  double sum = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d o = V.row(F(f, c)).transpose(), a = V.row(F(f, (c + 1) % 3)).transpose(),
                            b = V.row(F(f, (c + 2) % 3)).transpose();
      const Eigen::Vector3d u = a - o, v = b - o;
      const double cr = u.cross(v).norm();
      W(f, c) = cr > 0 ? 0.5 * u.dot(v) / cr : 0.0;
      sum += std::abs(W(f, c));
    }
  const double floor = min_relative * sum / std::max<Eigen::Index>(1, 3 * F.rows());
  return W.cwiseMax(floor);
}

// Area-weighted mean |ln σ| of the per-face stretch (map area / target, normalised).
double mean_log_stretch(const VectorXd& map_area, const VectorXd& target) {
  const double sa = map_area.sum(), st = target.sum();
  double num = 0;
  for (Eigen::Index f = 0; f < target.size(); ++f)
    if (map_area[f] > 0 && target[f] > 0) num += target[f] * std::abs(std::log((map_area[f] / sa) / (target[f] / st)));
  return num / st;
}

}  // namespace

MatrixXd stretch_energy_map(const MatrixXd& V, const MatrixXi& F, const VectorXd& face_target, const MatrixXd& UV0,
                            const VectorXi& side_mask, const StretchEnergyOptions& opt, StretchEnergyReport* report) {
  const Eigen::Index nv = V.rows(), nf = F.rows();
  const MatrixXd W = surface_cot_weights(V, F, opt.min_weight);
  std::vector<char> used(static_cast<std::size_t>(nv), 0);
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;
  // Unknowns per coordinate: u is held on the left/right sides, v on the bottom/top sides, so a
  // side vertex slides along its side (the natural boundary condition of the energy there).
  std::array<std::vector<int>, 2> idx;
  std::array<int, 2> m{0, 0};
  for (int d = 0; d < 2; ++d) {
    idx[d].assign(static_cast<std::size_t>(nv), -1);
    const int held = d == 0 ? (kSideLeft | kSideRight) : (kSideBottom | kSideTop);
    for (Eigen::Index v = 0; v < nv; ++v) {
      const int mask = side_mask.size() ? side_mask[v] : 0;
      const bool fixed = opt.sliding_boundary ? (mask & held) != 0 : mask != 0;
      if (used[v] && !fixed) idx[d][v] = m[d]++;
    }
  }

  MatrixXd UV = UV0.leftCols(2);
  const double min_area = 1e-12 * signed_face_areas_2d(UV, F).sum() / std::max<Eigen::Index>(1, nf);
  double err = mean_log_stretch(signed_face_areas_2d(UV, F), face_target);
  if (report) report->initial_log_stretch = report->final_log_stretch = err;
  VectorXd scale = VectorXd::Ones(nf);  // cumulative weight factor per face
  std::array<SpdSolver, 2> solvers;     // the pattern is the same every iteration
  for (int k = 0; k < opt.max_iterations; ++k) {
    const VectorXd a = signed_face_areas_2d(UV, F);
    const double sa = a.sum(), st = face_target.sum();
    VectorXd trial = scale;
    for (Eigen::Index f = 0; f < nf; ++f) {
      const double sigma = std::max(1e-300, (a[f] / sa) / (face_target[f] / st));
      trial[f] = (opt.cumulative ? scale[f] : 1.0) * std::pow(sigma, opt.exponent);
    }
    MatrixXd next = UV;
    bool ok = true;
    // With the whole boundary held, both coordinates share one matrix: factorise it once.
    const int systems = opt.sliding_boundary ? 2 : 1;
    for (int d = 0; d < systems && ok; ++d) {
      std::vector<Eigen::Triplet<double>> t;
      t.reserve(static_cast<std::size_t>(12 * nf));
      MatrixXd rhs = MatrixXd::Zero(m[d], systems == 1 ? 2 : 1);
      for (Eigen::Index f = 0; f < nf; ++f)
        for (int c = 0; c < 3; ++c) {
          const int i = F(f, (c + 1) % 3), j = F(f, (c + 2) % 3);
          const double w = W(f, c) * trial[f];
          for (const auto& [p, q] : {std::pair<int, int>{i, j}, std::pair<int, int>{j, i}}) {
            if (idx[d][p] < 0) continue;
            t.emplace_back(idx[d][p], idx[d][p], w);
            if (idx[d][q] >= 0)
              t.emplace_back(idx[d][p], idx[d][q], -w);
            else if (systems == 1)
              rhs.row(idx[d][p]) += w * UV.row(q);
            else
              rhs(idx[d][p], 0) += w * UV(q, d);
          }
        }
      SparseMatrix L(m[d], m[d]);
      L.setFromTriplets(t.begin(), t.end());
      SpdSolver& solver = solvers[d];
      ok = k == 0 ? solver.compute(L) : solver.refactor(L);
      if (!ok) break;
      const MatrixXd x = solver.solve(rhs);
      for (Eigen::Index v = 0; v < nv; ++v)
        if (idx[d][v] >= 0) {
          if (systems == 1)
            next.row(v) = x.row(idx[d][v]);
          else
            next(v, d) = x(idx[d][v], 0);
        }
    }
    if (!ok) break;
    // Positive weights and a fixed convex boundary guarantee an embedding (Floater 2003); with
    // sliding sides, or round-off on extreme shapes, keep the last valid iterate.
    const int nflip = count_flipped(next, F, min_area);
    const double e = mean_log_stretch(signed_face_areas_2d(next, F), face_target);
    if (nflip > 0 || !(e < err)) break;
    UV = std::move(next);
    scale = trial;
    const bool slow = e > opt.stop_improvement * err;
    err = e;
    if (report) report->iterations = k + 1, report->final_log_stretch = e;
    if (slow) break;
  }
  return UV;
}

}  // namespace authalic

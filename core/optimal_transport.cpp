#include "core/optimal_transport.h"

#include <algorithm>
#include <cmath>

#include "core/conformal_map.h"
#include "core/error.h"
#include "core/grid_overlap.h"
#include "core/poisson_dct.h"

namespace authalic {

namespace {

// Halvings of the step before the refinement gives up on a direction.
constexpr int kMaxStepHalvings = 8;

VectorXd vertex_measure(const MatrixXi& F, const VectorXd& face_measure, Eigen::Index nv) {
  VectorXd m = VectorXd::Zero(nv);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) m[F(f, c)] += face_measure[f] / 3.0;
  return m;
}

double cost_with(const MatrixXd& X, const MatrixXd& UV, const VectorXd& mu) {
  double c = 0, total = 0;
  for (Eigen::Index v = 0; v < mu.size(); ++v) {
    if (!(mu[v] > 0)) continue;
    c += mu[v] * (UV.row(v) - X.row(v)).squaredNorm();
    total += mu[v];
  }
  return total > 0 ? c / total : 0.0;
}

// Cell averages of the per-vertex field D (#V x 2, linear on each triangle of the map UV) over a
// grid's cells: each triangle's pieces in a cell (exact clipping) contribute D at the piece's
// centroid times the piece's area. Cells no triangle reaches get 0.
void cell_averages(const MatrixXd& UV, const MatrixXi& F, const MatrixXd& D, const GridSpec& grid, MatrixXd* ax,
                   MatrixXd* ay) {
  const std::vector<OverlapPiece> pieces = grid_overlap(UV, F, grid);
  MatrixXd sx = MatrixXd::Zero(grid.rows, grid.cols), sy = sx, w = sx;
  for (const OverlapPiece& p : pieces) {
    const int r = p.cell / grid.cols, c = p.cell % grid.cols;
    double dx = 0, dy = 0;
    for (int k = 0; k < 3; ++k) {
      dx += p.bary[k] * D(F(p.face, k), 0);
      dy += p.bary[k] * D(F(p.face, k), 1);
    }
    sx(r, c) += p.domain_area * dx;
    sy(r, c) += p.domain_area * dy;
    w(r, c) += p.domain_area;
  }
  *ax = sx.cwiseQuotient(w.cwiseMax(1e-300));
  *ay = sy.cwiseQuotient(w.cwiseMax(1e-300));
}

// Positions after following the frozen staggered field (wx, wy) for time t: the flow of a
// divergence-free field keeps area, which one straight step of length |t w| would not (its error
// grows with t² |∇w|²). RK4 with kFieldSubsteps steps; boundary vertices slide on their side.
constexpr int kFieldSubsteps = 4;
MatrixXd follow_field(const MatrixXd& UV, const MatrixXd& wx, const MatrixXd& wy, double hx, double hy, double t,
                      const VectorXi& side_mask, double width, const std::vector<char>& used) {
  const GridBilinear ix{&wx, 0.0, hx, 0.5 * hy, hy};
  const GridBilinear iy{&wy, 0.5 * hx, hx, 0.0, hy};
  MatrixXd out = UV;
  const double dt = t / kFieldSubsteps;
#pragma omp parallel for schedule(static)
  for (Eigen::Index v = 0; v < UV.rows(); ++v) {
    if (!used[v]) continue;
    const int mask = side_mask.size() ? side_mask[v] : 0;
    auto vel = [&](double /*t: the field is frozen*/, double px, double py, double* ux, double* uy) {
      constrain_to_rectangle(px, py, mask, width);
      *ux = (mask & (kSideLeft | kSideRight)) ? 0.0 : ix(px, py);
      *uy = (mask & (kSideBottom | kSideTop)) ? 0.0 : iy(px, py);
    };
    double x = UV(v, 0), y = UV(v, 1);
    for (int k = 0; k < kFieldSubsteps; ++k) {
      rk4_step(vel, k * dt, dt, x, y);
      constrain_to_rectangle(x, y, mask, width);
    }
    out(v, 0) = x;
    out(v, 1) = y;
  }
  return out;
}

int default_resolution(const MatrixXi& F) {
  // About one cell per 4 vertices (#V ≈ #F / 2): fine enough for the curl of the displacement,
  // coarse enough that every cell holds several triangles.
  const double n = std::sqrt(static_cast<double>(F.rows()) / 8.0);
  return std::clamp(static_cast<int>(std::lround(n)), 32, 256);
}

}  // namespace

double transport_cost(const MatrixXd& X, const MatrixXd& UV, const MatrixXi& F, const VectorXd& face_measure) {
  return cost_with(X, UV, vertex_measure(F, face_measure, UV.rows()));
}

void leray_projection(const MatrixXd& fx, const MatrixXd& fy, double hx, double hy, MatrixXd* wx, MatrixXd* wy) {
  const Eigen::Index ny = fx.rows(), nx = fx.cols();
  // Face values: the mean of the two cells a face separates; zero flux through the walls.
  wx->setZero(ny, nx + 1);
  wy->setZero(ny + 1, nx);
  for (Eigen::Index c = 1; c < nx; ++c) wx->col(c) = 0.5 * (fx.col(c - 1) + fx.col(c));
  for (Eigen::Index r = 1; r < ny; ++r) wy->row(r) = 0.5 * (fy.row(r - 1) + fy.row(r));
  // MAC divergence per cell; its sum vanishes (no wall flux), so the Neumann problem is solvable.
  MatrixXd div(ny, nx);
  for (Eigen::Index r = 0; r < ny; ++r)
    for (Eigen::Index c = 0; c < nx; ++c)
      div(r, c) = ((*wx)(r, c + 1) - (*wx)(r, c)) / hx + ((*wy)(r + 1, c) - (*wy)(r, c)) / hy;
  const NeumannPoissonGrid solver(static_cast<int>(nx), static_cast<int>(ny), hx, hy);
  const MatrixXd p = solver.solve(div);
  MatrixXd gx, gy;
  staggered_gradient(p, hx, hy, &gx, &gy);  // zero on the walls
  *wx -= gx;
  *wy -= gy;
}

OptimalTransportResult optimal_transport_refine(const MatrixXd& X, const MatrixXd& UV0, const MatrixXi& F,
                                                const VectorXi& side_mask, double width, const VectorXd& face_measure,
                                                const OptimalTransportOptions& options) {
  if (X.rows() != UV0.rows() || face_measure.size() != F.rows())
    throw InputError("optimal transport: the start map, the map and the face measure must describe the same mesh");
  OptimalTransportResult R;
  R.UV = UV0;
  OptimalTransportReport& rep = R.report;
  const VectorXd mu = vertex_measure(F, face_measure, UV0.rows());
  std::vector<char> used(UV0.rows(), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;

  const int n = options.grid_resolution > 0 ? options.grid_resolution : default_resolution(F);
  rep.grid_resolution = n;
  GridSpec grid;
  grid.rows = n;
  grid.cols = std::max(2, static_cast<int>(std::lround(width * n)));
  grid.width = width;
  grid.height = 1.0;
  const double hx = width / grid.cols, hy = 1.0 / grid.rows;

  double cost = cost_with(X, R.UV, mu);
  rep.initial_cost = rep.final_cost = cost;
  rep.stop_reason = "iteration limit";
  double tau = 1.0;
  for (int it = 0; it < options.max_iterations; ++it) {
    // The divergence-free part w of the displacement f = Y − X, sampled at the vertices.
    MatrixXd fx, fy, wx, wy;
    cell_averages(R.UV, F, R.UV - X, grid, &fx, &fy);
    leray_projection(fx, fy, hx, hy, &wx, &wy);
    // Backtracking: the largest τ ≤ 1 (from the last accepted one, grown by 2) that lowers the
    // cost and flips nothing.
    tau = std::min(1.0, 2.0 * tau);
    bool accepted = false;
    MatrixXd trial;
    double trial_cost = cost;
    for (int h = 0; h <= kMaxStepHalvings && !accepted; ++h, tau *= 0.5) {
      trial = follow_field(R.UV, wx, wy, hx, hy, -tau, side_mask, width, used);
      trial_cost = cost_with(X, trial, mu);
      accepted = trial_cost < cost && count_flipped(trial, F, 0.0) == 0;
      if (accepted) break;
    }
    if (!accepted) {
      rep.stop_reason = "step vanished";
      break;
    }
    const double decrease = (cost - trial_cost) / cost;
    R.UV = std::move(trial);
    cost = trial_cost;
    rep.history.push_back(cost);
    ++rep.iterations;
    if (decrease < options.min_relative_decrease) {
      rep.stop_reason = "converged";
      break;
    }
  }
  rep.final_cost = cost;
  return R;
}

}  // namespace authalic

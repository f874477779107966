// Area-restoring flows on the rectangle (see core/authalic_flow.h): the grid Moser flow, the
// mesh-based discrete Lie flow with Delaunay flips and adaptive steps, polish and flip repair.
#include "core/authalic_flow.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>

#include "core/conformal_map.h"
#include "core/grid_overlap.h"
#include "core/levenberg_marquardt.h"
#include "core/metrics.h"
#include "core/poisson_dct.h"
#include "core/sparse_cholesky.h"

namespace authalic {

namespace {
// A rejected grid pass is retried at half its fraction down to this one: smaller partial passes
// move too little to pass the next acceptance, so the flow stops there ("no improvement").
constexpr double kMinPassFraction = 0.2;
// A polish step lowers the per-face error; it may raise the per-vertex mean (the stopping
// criterion) by at most 5 %, so the polish never undoes what the passes reached.
constexpr double kPolishVertexSlack = 1.05;
}  // namespace

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// A polish (global steps) whose per-vertex mean is above its tolerance ends after this many steps in a row that
// each remove < 1 % of the per-face error.
constexpr int kPolishSlowStepsToStop = 2;
// The far-face steps end after this many slow steps (under 1 % of their faces' error) in a row:
// a crushed strip opens by a bounded factor a step, and its steps alternate between slow and
// fast as the set of far faces changes (fs741 white cut open onto the rectangle: a 0.95 % step
// after six of 2-18 %, then more of 5-10 %; ending at the first slow step left an element at
// 1.62 x its share).
constexpr int kFarSlowStepsToStop = 3;

struct Stats {
  double mean = 0, p99 = 0, max = 0;
};
// Faces whose signed area is not above the float32 floor (single_precision_area_floor).
int count_below_floor(const MatrixXd& UV, const MatrixXi& F);

// Area-weighted mean |ln(a_f / T_f)| per face (a folded face counts as 10).
double face_log_ratio_mean(const VectorXd& target, const MatrixXd& UV, const MatrixXi& F) {
  const VectorXd a = signed_face_areas_2d(UV, F);
  double num = 0, den = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (target[f] > 0) num += target[f] * (a[f] > 0 ? std::abs(std::log(a[f] / target[f])) : 10.0), den += target[f];
  return den > 0 ? num / den : 0.0;
}

Stats vertex_stats(const VectorXd& r) {
  const AbsStats s = abs_stats(r);
  return {s.mean, s.p99, s.max};
}

}  // namespace

std::string to_string(FlowMethod m) { return m == FlowMethod::Grid ? "grid" : "mesh"; }

VectorXd target_face_measure(const MatrixXd& V, const MatrixXi& F, const VectorXd& density, double total) {
  VectorXd a = face_areas(V, F);
  if (density.size() > 0) {
    for (Eigen::Index f = 0; f < F.rows(); ++f) a[f] *= (density[F(f, 0)] + density[F(f, 1)] + density[F(f, 2)]) / 3.0;
  }
  const double s = a.sum();
  if (s > 0) a *= total / s;
  return a;
}

VectorXd vertex_log_ratio(const VectorXd& face_target, const MatrixXd& UV, const MatrixXi& F, int num_vertices) {
  const VectorXd a2 = signed_face_areas_2d(UV, F).cwiseAbs();
  VectorXd t = VectorXd::Zero(num_vertices), d = VectorXd::Zero(num_vertices);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      t[F(f, c)] += face_target[f] / 3.0;
      d[F(f, c)] += a2[f] / 3.0;
    }
  const double st = t.sum(), sd = d.sum();
  VectorXd r(num_vertices);
  for (int v = 0; v < num_vertices; ++v)
    r[v] = (t[v] > 0 && d[v] > 0) ? std::log((t[v] / st) / (d[v] / sd)) : std::numeric_limits<double>::quiet_NaN();
  return r;
}

int grid_resolution_for(Eigen::Index faces, double width) {
  constexpr double kMaxFacesPerUnitHeight = 2.0 * 256 * 256;
  return static_cast<double>(faces) / std::max(width, 1e-12) <= kMaxFacesPerUnitHeight ? 256 : 512;
}

namespace {

// An upper bound of the Moser speed |∇g| / ((1 − t) ρ + t ρ_1) anywhere within `radius` cells of
// each cell of the ny x nx grid, for any t in [0, 1]: per cell, the largest |gx| and |gy| of the
// staggered nodes its bilinear interpolation reads (GridBilinear, clamped at the walls) over the
// smallest density it reads, then the largest of those over the (2 radius + 1)² cells around.
MatrixXd moser_speed_bound(const MatrixXd& gx, const MatrixXd& gy, const MatrixXd& rho, const MatrixXd* rho_1, int radius) {
  const int ny = static_cast<int>(rho.rows()), nx = static_cast<int>(rho.cols());
  auto clamp_index = [&](int r, int n) { return std::clamp(r, 0, n - 1); };
  MatrixXd a(ny, nx);
#pragma omp parallel for schedule(static)
  for (int r = 0; r < ny; ++r)
    for (int c = 0; c < nx; ++c) {
      double mx = 0, my = 0, dmin = std::numeric_limits<double>::infinity();
      for (int i = r - 1; i <= r + 1; ++i)  // gx: ny x (nx + 1), nodes at (c hx, (i + ½) hy)
        for (int j = c; j <= c + 1; ++j) mx = std::max(mx, std::abs(gx(clamp_index(i, ny), clamp_index(j, nx + 1))));
      for (int i = r; i <= r + 1; ++i)  // gy: (ny + 1) x nx, nodes at ((j + ½) hx, i hy)
        for (int j = c - 1; j <= c + 1; ++j) my = std::max(my, std::abs(gy(clamp_index(i, ny + 1), clamp_index(j, nx))));
      for (int i = r - 1; i <= r + 1; ++i)  // densities at the cell centres
        for (int j = c - 1; j <= c + 1; ++j) {
          dmin = std::min(dmin, rho(clamp_index(i, ny), clamp_index(j, nx)));
          dmin = std::min(dmin, rho_1 ? (*rho_1)(clamp_index(i, ny), clamp_index(j, nx)) : 1.0);
        }
      a(r, c) = std::hypot(mx, my) / dmin;
    }
  // Separable max filter over the (2 radius + 1)² neighbourhood.
  MatrixXd b(ny, nx), d(ny, nx);
#pragma omp parallel for schedule(static)
  for (int r = 0; r < ny; ++r)
    for (int c = 0; c < nx; ++c) b(r, c) = a.row(r).segment(std::max(0, c - radius), std::min(nx, c + radius + 1) - std::max(0, c - radius)).maxCoeff();
#pragma omp parallel for schedule(static)
  for (int r = 0; r < ny; ++r)
    for (int c = 0; c < nx; ++c) d(r, c) = b.col(c).segment(std::max(0, r - radius), std::min(ny, r + radius + 1) - std::max(0, r - radius)).maxCoeff();
  return d;
}

}  // namespace

MatrixXd moser_grid_pass(const VectorXd& face_target, const MatrixXd& UV, const MatrixXi& F, const VectorXi& side_mask,
                         double width, const GridFlowOptions& options, double fraction, const VectorXi& only_moving) {
  const int resolution = options.cells();
  const int rk4_steps = options.rk4_steps;
  const double smoothing_cells = options.smoothing_cells;
  const int ny = std::max(2, resolution);
  const int nx = std::max(2, static_cast<int>(std::lround(width * resolution)));
  const double hx = width / nx, hy = 1.0 / ny;

  // Density of the pushed-forward surface measure per cell (exact clipping: area-weighted).
  GridSpec grid;
  grid.cols = nx;
  grid.rows = ny;
  grid.width = width;
  grid.height = 1.0;
  const VectorXd cells = rasterize_face_measure(UV, F, face_target, grid);
  MatrixXd rho(ny, nx);
  for (int r = 0; r < ny; ++r)
    for (int c = 0; c < nx; ++c) rho(r, c) = cells[r * nx + c] / (hx * hy);
  // Normalise to mean 1 (the measure's total equals the domain area up to parts lost outside).
  const double mean = rho.mean();
  if (mean > 0) rho /= mean;

  NeumannPoissonGrid solver(nx, ny, hx, hy);
  MatrixXd rho_s, g;
  solver.smooth_and_solve(rho, smoothing_cells * std::max(hx, hy), &rho_s, &g);
  // The smoothed density of a covering map is positive; the velocity divides by it, so guard anyway.
  constexpr double kMinSmoothedDensity = 1e-3;
  rho_s = rho_s.cwiseMax(kMinSmoothedDensity);
  // Partial pass (fraction < 1): carry ρ only to ρ_1 ∝ ρ^(1 − fraction), i.e. remove that
  // fraction of ln ρ. Moser's construction for two densities: ρ_t = (1 − t) ρ + t ρ_1,
  // Δg = ρ − ρ_1, v_t = ∇g / ρ_t. Used when a full pass cannot follow a density of too large a
  // range (long thin protrusions, DLF section 1).
  MatrixXd rho_1 = MatrixXd::Ones(ny, nx);
  if (fraction < 1.0) {
    rho_1 = rho_s.array().pow(1.0 - fraction).matrix();
    rho_1 *= rho_s.sum() / rho_1.sum();
    g = solver.solve(rho_s - rho_1);
  }
  MatrixXd gx, gy;
  staggered_gradient(g, hx, hy, &gx, &gy);
  const GridBilinear vx{&gx, 0.0, hx, 0.5 * hy, hy};
  const GridBilinear vy{&gy, 0.5 * hx, hx, 0.0, hy};
  const GridBilinear dens{&rho_s, 0.5 * hx, hx, 0.5 * hy, hy};
  const GridBilinear dens_1{&rho_1, 0.5 * hx, hx, 0.5 * hy, hy};

  // Which vertices move: those used by a face.
  std::vector<char> used(UV.rows(), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;
  if (only_moving.size() == UV.rows())
    for (Eigen::Index v = 0; v < UV.rows(); ++v) used[v] = used[v] && only_moving[v];

  // RK4 steps per vertex: options.rk4_steps, or fewer where the speed bound of the cells around
  // the vertex shows it cannot leave them within the pass (travel <= kBoundRadius cells) and each
  // step then covers at most options.max_cells_per_step cells. After the stretch-energy start
  // most vertices move a small fraction of a cell per pass, and 20 fixed steps were a third of the
  // flow's time. Per vertex, so the result does not depend on the thread count.
  constexpr int kBoundRadius = 2, kMinRk4Steps = 2;
  const double h = std::min(hx, hy);
  MatrixXd speed;
  if (options.max_cells_per_step > 0) speed = moser_speed_bound(gx, gy, rho_s, fraction < 1.0 ? &rho_1 : nullptr, kBoundRadius);
  auto steps_for = [&](double x, double y) {
    if (speed.size() == 0) return rk4_steps;
    const int c = std::clamp(static_cast<int>(x / hx), 0, nx - 1), r = std::clamp(static_cast<int>(y / hy), 0, ny - 1);
    const double travel = speed(r, c);  // over t in [0, 1]
    if (!(travel <= kBoundRadius * h)) return rk4_steps;
    return std::clamp(static_cast<int>(std::ceil(travel / (options.max_cells_per_step * h))), std::min(kMinRk4Steps, rk4_steps), rk4_steps);
  };

  MatrixXd out = UV;
#pragma omp parallel for schedule(static)
  for (Eigen::Index v = 0; v < UV.rows(); ++v) {
    if (!used[v]) continue;
    const int mask = side_mask.size() ? side_mask[v] : 0;
    double x = UV(v, 0), y = UV(v, 1);
    // Velocity ∇g / ((1 − t) ρ + t) at (x, y), with the side constraint (the normal component
    // is zero on the walls already; zeroing it keeps roundoff from moving a vertex off its side).
    auto vel = [&](double t, double px, double py, double* ux, double* uy) {
      constrain_to_rectangle(px, py, mask, width);
      const double s = 1.0 / ((1.0 - t) * dens(px, py) + t * (fraction < 1.0 ? dens_1(px, py) : 1.0));
      *ux = (mask & (kSideLeft | kSideRight)) ? 0.0 : vx(px, py) * s;
      *uy = (mask & (kSideBottom | kSideTop)) ? 0.0 : vy(px, py) * s;
    };
    const int steps = steps_for(x, y);
    const double dt = 1.0 / steps;
    for (int k = 0; k < steps; ++k) {
      rk4_step(vel, k * dt, dt, x, y);
      constrain_to_rectangle(x, y, mask, width);
    }
    out(v, 0) = x;
    out(v, 1) = y;
  }
  return out;
}

double critical_step(const Eigen::Vector2d p[3], const Eigen::Vector2d d[3]) {
  // Twice the signed area of (p_i + λ d_i) is a λ² + b λ + c (DLF section 5.4); the triangle first
  // degenerates at the smallest positive root.
  const Eigen::Vector2d e1 = p[1] - p[0], e2 = p[2] - p[0], f1 = d[1] - d[0], f2 = d[2] - d[0];
  auto cross = [](const Eigen::Vector2d& u, const Eigen::Vector2d& v) { return u.x() * v.y() - u.y() * v.x(); };
  const double c = cross(e1, e2);
  if (!(c > 0)) return kInf;  // already flipped or degenerate: nothing to protect
  const double b = cross(e1, f2) + cross(f1, e2), a = cross(f1, f2);
  const double scale = std::max({std::abs(a), std::abs(b), c});
  double best = kInf;
  if (std::abs(a) <= 1e-14 * scale) {
    if (b < 0) best = -c / b;
  } else {
    const double disc = b * b - 4 * a * c;
    if (disc >= 0) {
      const double sq = std::sqrt(disc);
      // Numerically stable pair of roots.
      const double q = -0.5 * (b + (b >= 0 ? sq : -sq));
      const double r1 = q / a, r2 = q != 0 ? c / q : kInf;
      for (double r : {r1, r2})
        if (r > 0) best = std::min(best, r);
    }
  }
  return best;
}

namespace {

// Cotangent stiffness matrix of the planar domain mesh (positive semi-definite, −cotmatrix).
SparseMatrix domain_stiffness(const MatrixXd& UV, const MatrixXi& F) {
  MatrixXd P = MatrixXd::Zero(UV.rows(), 3);
  P.leftCols(2) = UV.leftCols(2);
  return -cotmatrix(P, F);
}

// Barycentric vertex areas of a per-face measure.
VectorXd vertex_share(const VectorXd& face_measure, const MatrixXi& F, int nv) {
  VectorXd a = VectorXd::Zero(nv);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) a[F(f, c)] += face_measure[f] / 3.0;
  return a;
}

// Solves the Neumann problem K g = b (K = stiffness, Σ b = 0) with a tiny mass shift for
// definiteness. Deterministic (serial Cholesky).
VectorXd solve_neumann(const SparseMatrix& K, const VectorXd& b, const VectorXd& mass) {
  // Only vertices with area take part (the others are not in the mesh).
  const Eigen::Index n = K.rows();
  std::vector<int> idx(n, -1);
  int m = 0;
  for (Eigen::Index i = 0; i < n; ++i)
    if (mass[i] > 0) idx[i] = m++;
  const double eps = 1e-9 * (K.diagonal().cwiseAbs().maxCoeff() + 1e-300) / (mass.maxCoeff() + 1e-300);
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(K.nonZeros() + m);
  for (int col = 0; col < K.outerSize(); ++col)
    for (SparseMatrix::InnerIterator it(K, col); it; ++it)
      if (idx[it.row()] >= 0 && idx[it.col()] >= 0) t.emplace_back(idx[it.row()], idx[it.col()], it.value());
  VectorXd bb(m);
  for (Eigen::Index i = 0; i < n; ++i)
    if (idx[i] >= 0) {
      t.emplace_back(idx[i], idx[i], eps * mass[i]);
      bb[idx[i]] = b[i];
    }
  SparseMatrix A(m, m);
  A.setFromTriplets(t.begin(), t.end());
  const SpdSolver solver(A);
  VectorXd g = VectorXd::Zero(n);
  if (!solver.ok()) return g;
  const VectorXd x = solver.solve(bb);
  for (Eigen::Index i = 0; i < n; ++i)
    if (idx[i] >= 0) g[i] = x[idx[i]];
  return g;
}

// Per-vertex gradient of a P1 function on the planar mesh: the angle-weighted mean of the face
// gradients (Zou et al. 2011a eq. 16). Boundary vertices keep only the component along their side;
// corners and unused vertices get zero.
MatrixXd vertex_gradients(const MatrixXd& UV, const MatrixXi& F, const VectorXd& g, const VectorXi& side_mask) {
  const Eigen::Index nv = UV.rows();
  MatrixXd grad = MatrixXd::Zero(nv, 2);
  VectorXd wsum = VectorXd::Zero(nv);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int i0 = F(f, 0), i1 = F(f, 1), i2 = F(f, 2);
    const Eigen::Vector2d p0 = UV.row(i0).head<2>().transpose(), p1 = UV.row(i1).head<2>().transpose(),
                          p2 = UV.row(i2).head<2>().transpose();
    const double a2 = (p1 - p0).x() * (p2 - p0).y() - (p1 - p0).y() * (p2 - p0).x();
    if (std::abs(a2) < 1e-300) continue;
    // ∇g = Σ g_i (perp of the opposite edge) / (2A), perp(e) = (−e_y, e_x) rotated into the face.
    auto perp = [](const Eigen::Vector2d& e) { return Eigen::Vector2d(-e.y(), e.x()); };
    const Eigen::Vector2d gf = (g[i0] * perp(p2 - p1) + g[i1] * perp(p0 - p2) + g[i2] * perp(p1 - p0)) / a2;
    const Eigen::Vector2d q[3] = {p0, p1, p2};
    const int id[3] = {i0, i1, i2};
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector2d u = q[(c + 1) % 3] - q[c], v = q[(c + 2) % 3] - q[c];
      const double ang = std::atan2(std::abs(u.x() * v.y() - u.y() * v.x()), u.dot(v));
      grad.row(id[c]) += ang * gf.transpose();
      wsum[id[c]] += ang;
    }
  }
  for (Eigen::Index v = 0; v < nv; ++v) {
    if (wsum[v] > 0) grad.row(v) /= wsum[v];
    const int m = side_mask.size() ? side_mask[v] : 0;
    if (m & (kSideLeft | kSideRight)) grad(v, 0) = 0;
    if (m & (kSideBottom | kSideTop)) grad(v, 1) = 0;
  }
  return grad;
}

// The triangle of F with the smallest critical step under displacement D (DLF eq. 5), and that
// step in *lambda (infinity when no triangle degenerates); -1 when none does.
Eigen::Index limiting_face(const MatrixXd& UV, const MatrixXi& F, const MatrixXd& D, double* lambda) {
  Eigen::Index worst = -1;
  double lam = kInf;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    Eigen::Vector2d p[3], d[3];
    for (int c = 0; c < 3; ++c) {
      p[c] = UV.row(F(f, c)).head<2>().transpose();
      d[c] = D.row(F(f, c)).head<2>().transpose();
    }
    const double l = critical_step(p, d);
    if (l < lam) lam = l, worst = f;
  }
  *lambda = lam;
  return worst;
}

// local_step_positions (core/authalic_flow.h) on the rectangle: vertices kept on their side and inside [0, W] x [0, 1];
// face_limit (optional): per-face signed area each triangle must stay above, instead of min_area.
MatrixXd rectangle_step_positions(const MatrixXd& UV, const MatrixXi& F, const MatrixXd& D, double theta,
                                  const VectorXi& side_mask, double w, double min_area, const VectorXd* face_limit = nullptr) {
  return local_step_positions(UV, F, D, theta, face_limit ? *face_limit : VectorXd::Constant(F.rows(), min_area),
                              [&](Eigen::Index v, double& x, double& y) {
                                constrain_to_rectangle(x, y, side_mask.size() ? side_mask[v] : 0, w);
                              });
}

void apply_displacement(MatrixXd& UV, const MatrixXd& D, double lambda, const VectorXi& side_mask, double w) {
  for (Eigen::Index v = 0; v < UV.rows(); ++v) {
    double x = UV(v, 0) + lambda * D(v, 0), y = UV(v, 1) + lambda * D(v, 1);
    constrain_to_rectangle(x, y, side_mask.size() ? side_mask[v] : 0, w);
    UV(v, 0) = x;
    UV(v, 1) = y;
  }
}

// One discrete Lie-flow displacement on the domain mesh F_dom (Zou et al. 2011a section 4.2-4.3, DLF
// 5.2): Δg = h_M − h_Ω (areas, Neumann), displacement = per-vertex ∇g. `fraction` < 1 asks for
// only that part of the remaining area change (Zou eq. 19: 1 / (K − k + 1)).
MatrixXd lie_displacement(const MatrixXd& UV, const MatrixXi& F_dom, const VectorXd& vertex_target, double fraction,
                          const VectorXi& side_mask) {
  const int nv = static_cast<int>(UV.rows());
  const VectorXd dom = vertex_share(signed_face_areas_2d(UV, F_dom).cwiseAbs(), F_dom, nv);
  VectorXd b = fraction * (vertex_target - dom);
  // Compatibility of the Neumann problem: Σ b = 0 over the vertices in use.
  double sum = 0;
  int used = 0;
  for (int v = 0; v < nv; ++v)
    if (dom[v] > 0) sum += b[v], ++used;
  for (int v = 0; v < nv; ++v) b[v] = dom[v] > 0 ? b[v] - sum / std::max(1, used) : 0.0;
  const SparseMatrix K = domain_stiffness(UV, F_dom);
  // K g = −(h_M − h_Ω): the stiffness is −Laplacian, and Δg = (target − domain) / area.
  const VectorXd g = solve_neumann(K, -b, dom);
  return vertex_gradients(UV, F_dom, g, side_mask);
}

}  // namespace

MatrixXd local_step_positions(const MatrixXd& UV, const MatrixXi& F, const MatrixXd& D, double theta,
                              const VectorXd& face_limit, const std::function<void(Eigen::Index, double&, double&)>& constrain) {
  const Eigen::Index nv = UV.rows(), nf = F.rows();
  VectorXd crit = VectorXd::Constant(nf, kInf);
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < (theta > 0 ? nf : 0); ++f) {
    Eigen::Vector2d p[3], d[3];
    for (int c = 0; c < 3; ++c) {
      p[c] = UV.row(F(f, c)).head<2>().transpose();
      d[c] = D.row(F(f, c)).head<2>().transpose();
    }
    crit[f] = critical_step(p, d);
  }
  VectorXd lam = VectorXd::Ones(nv);
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) lam[F(f, c)] = std::min(lam[F(f, c)], theta > 0 ? theta * crit[f] : 1.0);
  MatrixXd out = UV;
  auto place = [&](Eigen::Index v) {
    double x = UV(v, 0) + lam[v] * D(v, 0), y = UV(v, 1) + lam[v] * D(v, 1);
    if (constrain) constrain(v, x, y);
    out(v, 0) = x;
    out(v, 1) = y;
  };
#pragma omp parallel for schedule(static)
  for (Eigen::Index v = 0; v < nv; ++v) place(v);
  VectorXd a;
  halve_steps_until_unfolded(
      F, lam,
      [&](Eigen::Index f) {
        if (f == 0) a = signed_face_areas_2d(out, F);  // once per round
        return !(a[f] > face_limit[f]);
      },
      place);
  return out;
}

int faces_outside_band(const VectorXd& target, const MatrixXd& UV, const MatrixXi& F, double band,
                       std::vector<char>& marked) {
  const VectorXd a = signed_face_areas_2d(UV, F);
  int bad = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (target[f] > 0 && !(std::abs(std::log(std::max(a[f], 1e-300) / target[f])) <= band)) {
      ++bad;
      for (int c = 0; c < 3; ++c) marked[F(f, c)] = 1;
    }
  return bad;
}

MatrixXd face_area_newton_displacement(const MatrixXd& UV, const MatrixXi& F, const VectorXd& face_target,
                                       const VectorXi& side_mask, const std::vector<char>& free_vertex,
                                       int cg_iterations, FaceAreaResidual residual) {
  const int nv = static_cast<int>(UV.rows());
  // Columns in the order the rows (faces) first use their vertices: levenberg_marquardt_step is
  // memory-bound.
  std::vector<int> col(2 * nv, -1);
  int ncols = 0;
  for (const int v : vertices_in_face_order(F, nv)) {
    if (!free_vertex[v]) continue;
    const int m = side_mask.size() ? side_mask[v] : 0;
    if (__builtin_popcount(static_cast<unsigned>(m)) >= 2) continue;  // corners stay
    if (!(m & (kSideLeft | kSideRight))) col[2 * v] = ncols++;
    if (!(m & (kSideBottom | kSideTop))) col[2 * v + 1] = ncols++;
  }
  MatrixXd D = MatrixXd::Zero(nv, 2);
  if (ncols == 0) return D;
  const VectorXd a = signed_face_areas_2d(UV, F);
  // Rows: at most the faces, and about 6 per free vertex (ncols / 2 of them at most).
  const std::size_t max_rows = static_cast<std::size_t>(std::min<Eigen::Index>(F.rows(), 4 * static_cast<Eigen::Index>(ncols)));
  JacobianRows J(ncols, max_rows);
  std::vector<double> r;
  r.reserve(max_rows);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    bool touches = false;
    for (int c = 0; c < 3; ++c) touches = touches || free_vertex[F(f, c)];
    if (!touches || !(face_target[f] > 0)) continue;
    // s: the residual's derivative with respect to a_f. LogArea: √T ln(a/T), which is
    // (a − T)/√T to first order near the target but prices a crushed face by its log.
    const bool log_area = residual == FaceAreaResidual::LogArea && a[f] > 0;
    const double s = log_area ? std::sqrt(face_target[f]) / a[f] : 1.0 / std::sqrt(face_target[f]);
    for (int c = 0; c < 3; ++c) {
      const int i = F(f, c), j = F(f, (c + 1) % 3), k = F(f, (c + 2) % 3);
      if (col[2 * i] >= 0) J.add(col[2 * i], s * 0.5 * (UV(j, 1) - UV(k, 1)));
      if (col[2 * i + 1] >= 0) J.add(col[2 * i + 1], s * 0.5 * (UV(k, 0) - UV(j, 0)));
    }
    J.end_row();
    r.push_back(log_area ? std::sqrt(face_target[f]) * std::log(a[f] / face_target[f]) : s * (a[f] - face_target[f]));
  }
  // An inexact Newton step: a fixed budget of conjugate-gradient iterations (50 and 200 agree on
  // fs741 pial: per-face mean 0.0147 vs 0.0138 after 8 steps; a Cholesky factorisation per step
  // took 1.5 s of 330,000 unknowns).
  const VectorXd delta = levenberg_marquardt_step(J, Eigen::Map<const VectorXd>(r.data(), J.rows()), cg_iterations);
  for (int v = 0; v < nv; ++v) {
    if (col[2 * v] >= 0) D(v, 0) = delta[col[2 * v]];
    if (col[2 * v + 1] >= 0) D(v, 1) = delta[col[2 * v + 1]];
  }
  return D;
}

int delaunay_flip(const MatrixXd& UV, MatrixXi& F, int max_flips) {
  const int nv = static_cast<int>(UV.rows());
  VectorXi twin = halfedge_twins(F, nv);
  auto pt = [&](int v) { return Eigen::Vector2d(UV(v, 0), UV(v, 1)); };
  auto cross = [](const Eigen::Vector2d& u, const Eigen::Vector2d& v) { return u.x() * v.y() - u.y() * v.x(); };
  // Angle opposite half-edge h (at the third corner of its face).
  auto opposite_angle = [&](int h) {
    const int f = h / 3, c = h % 3;
    const Eigen::Vector2d a = pt(F(f, c)), b = pt(F(f, (c + 1) % 3)), o = pt(F(f, (c + 2) % 3));
    const Eigen::Vector2d u = a - o, v = b - o;
    return std::atan2(std::abs(cross(u, v)), u.dot(v));
  };
  int flips = 0;
  std::vector<int> stack;
  for (int h = 0; h < 3 * static_cast<int>(F.rows()); ++h)
    if (twin[h] > h) stack.push_back(h);
  std::reverse(stack.begin(), stack.end());
  while (!stack.empty()) {
    if (max_flips >= 0 && flips >= max_flips) break;
    const int h = stack.back();
    stack.pop_back();
    const int t = twin[h];
    if (t < 0) continue;
    if (opposite_angle(h) + opposite_angle(t) <= M_PI + 1e-12) continue;
    const int f = h / 3, c = h % 3, g = t / 3, d = t % 3;
    const int a = F(f, c), b = F(f, (c + 1) % 3), x = F(f, (c + 2) % 3), y = F(g, (d + 2) % 3);
    // The new triangles (x, a, y) and (y, b, x) must both be positively oriented.
    if (!(cross(pt(a) - pt(x), pt(y) - pt(x)) > 0 && cross(pt(b) - pt(y), pt(x) - pt(y)) > 0)) continue;
    // Outer half-edges before the flip: in f: b->x (c+1), x->a (c+2); in g: a->y (d+1), y->b (d+2).
    const int h_bx = twin[3 * f + (c + 1) % 3], h_xa = twin[3 * f + (c + 2) % 3];
    const int h_ay = twin[3 * g + (d + 1) % 3], h_yb = twin[3 * g + (d + 2) % 3];
    // Face f becomes (x, a, y): half-edges x->a, a->y, y->x; face g becomes (y, b, x): y->b, b->x, x->y.
    F.row(f) << x, a, y;
    F.row(g) << y, b, x;
    auto link = [&](int h1, int h2) {
      twin[h1] = h2;
      if (h2 >= 0) twin[h2] = h1;
    };
    link(3 * f + 0, h_xa);
    link(3 * f + 1, h_ay);
    link(3 * f + 2, 3 * g + 2);
    link(3 * g + 0, h_yb);
    link(3 * g + 1, h_bx);
    ++flips;
    for (int k = 0; k < 2; ++k) {
      stack.push_back(3 * f + k);
      stack.push_back(3 * g + k);
    }
  }
  return flips;
}

int untangle_flips(const MatrixXi& F, const VectorXd& min_area, MatrixXd& UV, const std::function<bool(Eigen::Index)>& held,
                   const std::function<void(Eigen::Index, double&, double&)>& constrain, int* remaining, int max_rounds) {
  const Eigen::Index nv = UV.rows();
  const std::vector<std::vector<int>> adj = vertex_neighbours(F, nv);
  std::vector<char> moved(static_cast<std::size_t>(nv), 0);
  int left = 0;
  for (int round = 0; round <= max_rounds; ++round) {
    const VectorXd a = signed_face_areas_2d(UV, F);
    std::vector<char> mark(static_cast<std::size_t>(nv), 0);
    left = 0;
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (!(a[f] > min_area[f])) {
        ++left;
        for (int k = 0; k < 3; ++k) mark[F(f, k)] = 1;
      }
    if (left == 0 || round == max_rounds) break;
    grow_by_rings(mark, adj, round / 10);
    for (int sweep = 0; sweep < 5; ++sweep)
      for (Eigen::Index v = 0; v < nv; ++v) {
        if (!mark[v] || adj[v].empty() || (held && held(v))) continue;
        Eigen::Vector2d mean = Eigen::Vector2d::Zero();
        for (int u : adj[v]) mean += UV.row(u).head<2>().transpose();
        mean /= static_cast<double>(adj[v].size());
        double x = mean.x(), y = mean.y();
        if (constrain) constrain(v, x, y);
        UV(v, 0) = x;
        UV(v, 1) = y;
        moved[v] = 1;
      }
  }
  if (remaining) *remaining = left;
  return static_cast<int>(std::count(moved.begin(), moved.end(), 1));
}

int untangle_flips(const MatrixXi& F, const VectorXi& side_mask, double width, const VectorXd& min_area, MatrixXd& UV,
                   int* remaining, int max_rounds) {
  // Corners stay; a side vertex moves along its side (constrain_to_rectangle puts its fixed
  // coordinate back on the side).
  const auto mask = [&](Eigen::Index v) { return side_mask.size() ? side_mask[v] : 0; };
  return untangle_flips(
      F, min_area, UV, [&](Eigen::Index v) { return __builtin_popcount(static_cast<unsigned>(mask(v))) >= 2; },
      [&](Eigen::Index v, double& x, double& y) { constrain_to_rectangle(x, y, mask(v), width); }, remaining, max_rounds);
}

VectorXd single_precision_area_floor(const MatrixXd& UV, const MatrixXi& F) {
  auto spacing = [](double x) {
    const float f = std::fabs(static_cast<float>(x));
    return static_cast<double>(std::nextafter(f, std::numeric_limits<float>::infinity()) - f);
  };
  VectorXd floor(F.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    double bound = 0;  // ½ Σ (|Δy| u(x)/2 + |Δx| u(y)/2)
    for (int c = 0; c < 3; ++c) {
      const int i = F(f, c), j = F(f, (c + 1) % 3), k = F(f, (c + 2) % 3);
      bound += 0.25 * (std::fabs(UV(j, 1) - UV(k, 1)) * spacing(UV(i, 0)) + std::fabs(UV(k, 0) - UV(j, 0)) * spacing(UV(i, 1)));
    }
    floor[f] = 4.0 * bound;
  }
  return floor;
}

namespace {
int count_below_floor(const MatrixXd& UV, const MatrixXi& F) {
  const VectorXd floor = single_precision_area_floor(UV, F);
  const VectorXd a = signed_face_areas_2d(UV, F);
  return static_cast<int>((a.array() <= floor.array()).count());
}
}  // namespace

int open_thin_triangles(const MatrixXi& F, const VectorXi& side_mask, double width, const VectorXd& min_area, MatrixXd& UV,
                        int max_rounds) {
  int left = 0;
  for (int round = 0; round <= max_rounds; ++round) {
    const VectorXd a = signed_face_areas_2d(UV, F);
    left = 0;
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      if (a[f] > min_area[f]) continue;
      ++left;
      if (round == max_rounds) continue;
      // The vertex opposite the longest edge moves off that edge, perpendicular to it, to twice
      // the floor: the smallest move that opens the triangle (the apex of a sliver). A side
      // vertex only slides along its side, so the next corner is tried when it cannot help.
      int order[3] = {0, 1, 2};
      auto edge = [&](int c) { return (UV.row(F(f, (c + 2) % 3)) - UV.row(F(f, (c + 1) % 3))).head<2>().norm(); };
      std::sort(order, order + 3, [&](int p, int q) { return edge(p) > edge(q); });
      for (int c : order) {
        const int v = F(f, c), m = side_mask.size() ? side_mask[v] : 0;
        if (__builtin_popcount(static_cast<unsigned>(m)) >= 2) continue;
        const Eigen::Vector2d p0 = UV.row(F(f, (c + 1) % 3)).head<2>().transpose(), p1 = UV.row(F(f, (c + 2) % 3)).head<2>().transpose();
        const Eigen::Vector2d e = p1 - p0;
        const double len = e.norm();
        if (!(len > 0)) continue;
        Eigen::Vector2d n(-e.y() / len, e.x() / len);  // left of p0 -> p1: where v must lie (counter-clockwise)
        if (m & (kSideLeft | kSideRight)) n.x() = 0;
        if (m & (kSideBottom | kSideTop)) n.y() = 0;
        const double gain = n.dot(Eigen::Vector2d(-e.y(), e.x()) / len);  // height gained per unit move
        if (!(gain > 0.1)) continue;
        const double height = 2.0 * a[f] / len, needed = 4.0 * min_area[f] / len;
        const double step = (needed - height) / gain;
        double x = UV(v, 0) + step * n.x(), y = UV(v, 1) + step * n.y();
        constrain_to_rectangle(x, y, m, width);
        UV(v, 0) = x;
        UV(v, 1) = y;
        break;
      }
    }
    if (left == 0) break;
  }
  return left;
}

int repair_flips(const MatrixXd& V, const MatrixXi& F, const VectorXi& side_mask, double width, MatrixXd& UV,
                 int* remaining) {
  const int nv = static_cast<int>(UV.rows());
  const double min_area = flip_area_threshold(width, F.rows());
  auto flipped_faces = [&]() {
    std::vector<int> out;
    const VectorXd a = signed_face_areas_2d(UV, F);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (!(a[f] > min_area)) out.push_back(static_cast<int>(f));
    return out;
  };
  std::vector<int> bad = flipped_faces();
  if (bad.empty()) {
    if (remaining) *remaining = 0;
    return 0;
  }
  // Vertex adjacency (one ring) for growing the region.
  std::vector<std::vector<int>> ring(nv);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) ring[F(f, c)].push_back(F(f, (c + 1) % 3)), ring[F(f, c)].push_back(F(f, (c + 2) % 3));
  std::vector<char> in_region(nv, 0);
  for (int f : bad)
    for (int c = 0; c < 3; ++c) in_region[F(f, c)] = 1;
  int moved = 0;
  for (int round = 0; round < 12 && !bad.empty(); ++round) {
    if (round > 0) {
      // Grow by one ring around the vertices of the faces still flipped.
      std::vector<char> grow = in_region;
      for (int f : bad)
        for (int c = 0; c < 3; ++c)
          for (int u : ring[F(f, c)]) grow[u] = 1;
      for (int v = 0; v < nv; ++v)
        for (int u : ring[v])
          if (in_region[v]) grow[u] = 1;
      in_region.swap(grow);
    }
    // Free vertices: in the region and not corners; side vertices stay on their side (they are
    // kept fixed here for simplicity: only interior vertices move).
    std::vector<int> fixed;
    MatrixXd fixed_uv;
    std::vector<int> faces;
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      bool touches = false;
      for (int c = 0; c < 3; ++c) touches = touches || (in_region[F(f, c)] && !(side_mask.size() && side_mask[F(f, c)]));
      if (touches) faces.push_back(static_cast<int>(f));
    }
    MatrixXi Fl(faces.size(), 3);
    for (size_t k = 0; k < faces.size(); ++k) Fl.row(k) = F.row(faces[k]);
    std::vector<char> is_free(nv, 0);
    int nfree = 0;
    for (size_t k = 0; k < faces.size(); ++k)
      for (int c = 0; c < 3; ++c) {
        const int v = Fl(k, c);
        if (in_region[v] && !(side_mask.size() && side_mask[v]) && !is_free[v]) is_free[v] = 1, ++nfree;
      }
    std::vector<char> seen(nv, 0);
    for (size_t k = 0; k < faces.size(); ++k)
      for (int c = 0; c < 3; ++c) {
        const int v = Fl(k, c);
        if (!is_free[v] && !seen[v]) seen[v] = 1, fixed.push_back(v);
      }
    fixed_uv.resize(fixed.size(), 2);
    for (size_t k = 0; k < fixed.size(); ++k) fixed_uv.row(k) = UV.row(fixed[k]).head<2>();
    // Mean-value weights from the surface: the re-placed patch keeps the surface's local shape.
    const MatrixXd local = harmonic_map(V, Fl, fixed, fixed_uv, round < 6 ? HarmonicWeights::MeanValue : HarmonicWeights::Uniform);
    for (int v = 0; v < nv; ++v)
      if (is_free[v]) UV.row(v).head<2>() = local.row(v);
    moved = nfree;
    bad = flipped_faces();
  }
  if (remaining) *remaining = static_cast<int>(bad.size());
  return moved;
}

namespace {

// One flow's inputs and evolving state, shared by its steps below.
struct Flow {
  const MatrixXd& V;
  const MatrixXi& F;
  const VectorXi& side_mask;
  const FlowOptions& opt;
  const ProgressFn& progress;
  int nv;
  double w;
  VectorXd target;    // per-face target measure (target_face_measure)
  double min_area;    // flip threshold (flip_area_threshold)
  MatrixXd UV;        // the current map
  Stats cur;          // its per-vertex |ln ratio| statistics
  FlowReport& rep;

  Stats stats_of(const MatrixXd& uv) const { return vertex_stats(vertex_log_ratio(target, uv, F, nv)); }
  bool met(const Stats& s) const { return s.mean <= opt.tolerance_mean && s.p99 <= opt.tolerance_p99; }
  MatrixXd constrained(MatrixXd P) const {
    for (Eigen::Index v = 0; v < P.rows(); ++v) constrain_to_rectangle(P(v, 0), P(v, 1), side_mask.size() ? side_mask[v] : 0, w);
    return P;
  }
};

// The moved positions of one grid pass made flip-free. The flow is a diffeomorphism, its
// piecewise-linear image of a triangle not quite: a few triangles can flip where the velocity
// varies on the scale of a triangle. Take the moved positions and re-place the vertices around
// those triangles (repair_flips); holding their vertices back instead leaves a stuck patch behind
// that the next passes cannot reach (measured on benchmark B2, the pial surface: element CV 0.039
// instead of 0.004). Only if the repair fails, fall back to per-vertex flip-preventing steps, so
// no pass leaves a flipped triangle.
MatrixXd flip_free_positions(Flow& s, const MatrixXd& moved) {
  MatrixXd next = s.constrained(moved);
  int unrepaired = 0;
  const int repaired = repair_flips(s.V, s.F, s.side_mask, s.w, next, &unrepaired);
  if (unrepaired == 0) {
    s.rep.repaired += repaired;
    return next;
  }
  // Two valid fall-backs: the folded triangles' vertices held back along their paths, or the
  // moved map untangled by neighbour means (untangle_flips); the one with the lower per-vertex
  // error is kept. Holding back cascades on native meshes (a held vertex is overtaken by its
  // neighbours; fs741 pial (benchmark R1), first pass: per-vertex mean 0.27 held back, 0.033
  // untangled); untangling smooths a patch (the fsaverage5 whole-brain rectangle: element CV
  // 0.011 untangled, below 0.01 held back).
  const MatrixXd held = rectangle_step_positions(s.UV, s.F, moved - s.UV, 0.0, s.side_mask, s.w, s.min_area);
  MatrixXd untangled = s.constrained(moved);
  int left = 0;
  const int moved_by_untangle =
      untangle_flips(s.F, s.side_mask, s.w, VectorXd::Constant(s.F.rows(), s.min_area), untangled, &left);
  const bool take = left == 0 && s.stats_of(untangled).mean < s.stats_of(held).mean;
  if (!take) return held;
  s.rep.repaired += moved_by_untangle;
  return untangled;
}

// Grid method: Moser passes until the tolerance, a slow pass or the pass budget. Each pass is an
// explicit attempt loop: a pass that does not lower the per-vertex error (or thins triangles
// below what float32 keeps oriented) is rejected and retried at half its fraction down to
// kMinPassFraction; rejected attempts are counted apart, not as iterations.
void grid_passes(Flow& s) {
  const FlowOptions& opt = s.opt;
  s.rep.stop_reason = "iteration limit";
  double fraction = 1.0;
  for (int pass = 0; pass < opt.grid.max_passes; ++pass) {
    if (s.met(s.cur)) {
      s.rep.stop_reason = "tolerance";
      break;
    }
    MatrixXd next;
    Stats st;
    bool accepted = false;
    for (;;) {
      const MatrixXd moved = moser_grid_pass(s.target, s.UV, s.F, s.side_mask, s.w, opt.grid, fraction);
      next = flip_free_positions(s, moved);
      // Triangles thinned below what float32 storage keeps oriented are opened; a pass that
      // leaves more of them than it found counts as failed (its gain is not worth a map that
      // reads back folded).
      const bool thinned = open_thin_triangles(s.F, s.side_mask, s.w, single_precision_area_floor(next, s.F), next) >
                           count_below_floor(s.UV, s.F);
      st = s.stats_of(next);
      std::ostringstream msg;
      msg << "pass " << pass + 1 << (fraction < 1.0 ? " (partial)" : "") << ": per-vertex mean |ln ratio| " << st.mean
          << ", p99 " << st.p99;
      report(s.progress, "flow", double(pass + 1) / opt.grid.max_passes, msg.str());
      accepted = st.mean < s.cur.mean && !thinned;
      // A full pass could not follow the density (its range too large for the grid): retry
      // with partial passes before giving up.
      if (accepted || !(fraction > kMinPassFraction)) break;
      ++s.rep.rejected_passes;
      fraction *= 0.5;
    }
    if (!accepted) {
      ++s.rep.rejected_passes;
      s.rep.stop_reason = "no improvement";
      break;
    }
    ++s.rep.iterations;
    s.rep.history_mean.push_back(st.mean);
    const bool slow = st.mean > opt.grid.min_pass_gain * s.cur.mean;
    s.UV = std::move(next);
    s.cur = st;
    fraction = std::min(1.0, 2.0 * fraction);
    if (slow) {
      s.rep.stop_reason = "no improvement";
      break;
    }
  }
  if (s.met(s.cur)) s.rep.stop_reason = "tolerance";
}

// Triangle f of F_dom described for the report: its vertices, how many lie on the boundary and its
// area against the mean. A stalled flow names the triangle that limits its step (measured on
// fsaverage5: an interior vertex closing in on an unflippable boundary edge).
std::string describe_triangle(const MatrixXd& UV, const MatrixXi& F_dom, Eigen::Index f, const VectorXi& side_mask) {
  if (f < 0) return "";
  int on_side = 0;
  for (int c = 0; c < 3; ++c) on_side += side_mask.size() && side_mask[F_dom(f, c)] != 0;
  const VectorXd a = signed_face_areas_2d(UV, F_dom);
  std::ostringstream os;
  os << "triangle of vertices " << F_dom(f, 0) << ", " << F_dom(f, 1) << ", " << F_dom(f, 2) << " (" << on_side
     << " on the boundary), area " << a[f] / (a.cwiseAbs().sum() / static_cast<double>(a.size())) << " of the mean";
  return os.str();
}

// Mesh method: DLF Algorithm 1 on a flowing copy Fd of the connectivity (Delaunay flips), or
// Zou's fixed-K schedule (eq. 19) when fixed_steps > 0. The targets h_M are the vertex shares of
// the surface's triangles, or (MeshFlowTargets::Flowing, the paper's reading: "the surface is merely
// interpolated by a different triangulation") of the surface re-triangulated by Fd at each step.
// The adaptive step is the smallest critical step of all triangles (eq. 5): one triangle closing
// in on an edge it cannot flip away (a boundary edge) halves the step at every iteration, and the
// flow stalls (docs/maps.md: measured on fsaverage5). The adaptive flow therefore stops once
// kMeshStallSteps steps in a row have not lowered its own error (its targets against Fd's shares)
// by kMeshStallGain ("stalled", with the limiting triangle in stall_detail).
constexpr int kMeshStallSteps = 5;
constexpr double kMeshStallGain = 1e-3;

void mesh_steps(Flow& s) {
  const FlowOptions& opt = s.opt;
  VectorXd vertex_target = vertex_share(s.target, s.F, s.nv);
  MatrixXi Fd = s.F;
  const int fixed = opt.mesh.fixed_steps;
  const int steps = fixed > 0 ? fixed : opt.mesh.max_iterations;
  // The flow's own error: each vertex's target against its share of the flowing mesh Fd (the
  // output connectivity's shares, s.cur, differ where Fd has flipped edges).
  auto flowing_error = [&](const MatrixXd& uv) {
    const VectorXd dom = vertex_share(signed_face_areas_2d(uv, Fd).cwiseAbs(), Fd, s.nv);
    const double st = vertex_target.sum(), sd = dom.sum();
    VectorXd r(s.nv);
    for (int v = 0; v < s.nv; ++v)
      r[v] = vertex_target[v] > 0 && dom[v] > 0 ? std::log((vertex_target[v] / st) / (dom[v] / sd)) : std::numeric_limits<double>::quiet_NaN();
    return vertex_stats(r);
  };
  Stats best_stats{kInf, kInf, kInf};  // measured after the first flips: Fd changes the shares
  int since_best = 0;
  s.rep.stop_reason = "iteration limit";
  for (int k = 0; k < steps; ++k) {
    if (fixed <= 0 && s.met(s.cur)) {
      s.rep.stop_reason = "tolerance";
      break;
    }
    if (opt.mesh.delaunay_flips) s.rep.edge_flips += delaunay_flip(s.UV, Fd);
    if (opt.mesh.targets == MeshFlowTargets::Flowing)
      vertex_target = vertex_share(target_face_measure(s.V, Fd, opt.density, s.w), Fd, s.nv);
    const double fraction = fixed > 0 ? 1.0 / (fixed - k) : 1.0;
    const MatrixXd D = lie_displacement(s.UV, Fd, vertex_target, fraction, s.side_mask);
    // One scan gives the critical step (eq. 5) and the triangle it comes from. Zou's schedule takes
    // its full step unless a triangle would flip, then theta of the critical step.
    double critical = kInf;
    const Eigen::Index limiting = limiting_face(s.UV, Fd, D, &critical);
    const double lambda = fixed > 0 ? (critical < 1.0 ? opt.theta * critical : 1.0) : std::min(1.0, opt.theta * critical);
    if (!(lambda > 1e-12)) {
      s.rep.stop_reason = "step vanished";
      s.rep.stall_detail = describe_triangle(s.UV, Fd, limiting, s.side_mask);
      break;
    }
    apply_displacement(s.UV, D, lambda, s.side_mask, s.w);
    s.cur = s.stats_of(s.UV);
    ++s.rep.iterations;
    s.rep.history_mean.push_back(s.cur.mean);
    std::ostringstream msg;
    const Stats own = flowing_error(s.UV);
    msg << "step " << k + 1 << " (lambda " << lambda << "): per-vertex mean |ln ratio| " << own.mean << ", p99 " << own.p99
        << " on the flowing mesh; " << s.cur.mean << " on the surface's triangles";
    report(s.progress, "flow", double(k + 1) / steps, msg.str());
    if (fixed > 0) continue;  // Zou's schedule takes exactly its K steps
    if (own.mean < (1.0 - kMeshStallGain) * best_stats.mean) {
      best_stats = own;
      since_best = 0;
    } else if (++since_best == kMeshStallSteps) {
      s.rep.stop_reason = "stalled";
      s.rep.stall_detail = describe_triangle(s.UV, Fd, limiting, s.side_mask);
      break;
    }
  }
  if (s.met(s.cur)) s.rep.stop_reason = "tolerance";
}

// Polish: Gauss-Newton steps on the per-face areas (face_area_newton_displacement) around the
// faces whose |ln ratio| exceeds the band, with per-vertex flip-preventing steps and a halving
// line search; a step is kept only if it lowers the per-face error without raising the
// per-vertex error by more than kPolishVertexSlack. The grid flow leaves sub-cell errors the grid
// cannot see (a native pial surface: per-vertex mean 0.028 after the passes, 0.004 after it).
class Polish {
 public:
  explicit Polish(Flow& s) : s_(s), ring_(s.nv), cur_face_(face_log_ratio_mean(s.target, s.UV, s.F)) {
    // The vertices of the faces beyond a band and polish.rings rings around them (through each
    // face's next corner: a boundary vertex does not reach back along the boundary).
    for (Eigen::Index f = 0; f < s.F.rows(); ++f)
      for (int c = 0; c < 3; ++c) ring_[s.F(f, c)].push_back(s.F(f, (c + 1) % 3));
  }

  // Steps on the whole map until a step gains little.
  void global_steps() {
    const PolishOptions& po = s_.opt.polish;
    int slow_in_a_row = 0;
    for (int k = 0; k < po.iterations; ++k) {
      std::vector<char> free_vertex(s_.nv, 0);
      const int bad = free_around(po.band, free_vertex);
      if (bad == 0) break;
      const MatrixXd D = face_area_newton_displacement(s_.UV, s_.F, s_.target, s_.side_mask, free_vertex, po.cg_iterations);
      const double before = cur_face_;
      const bool better = line_search(D, [&](const MatrixXd& next, double& fm, Stats& st) {
        fm = face_log_ratio_mean(s_.target, next, s_.F);
        st = s_.stats_of(next);
        return fm < cur_face_ && st.mean <= s_.cur.mean * kPolishVertexSlack;
      });
      if (!better) break;
      const bool slow = cur_face_ > 0.99 * before;
      ++s_.rep.polish_iterations;
      std::ostringstream msg;
      msg << "polish " << k + 1 << " (" << bad << " faces outside the band): per-face mean |ln ratio| " << cur_face_
          << ", per-vertex mean " << s_.cur.mean << ", p99 " << s_.cur.p99;
      report(s_.progress, "flow", -1, msg.str());
      // A slow step ends it once the per-vertex mean meets its tolerance; before that, two in a
      // row: on coarse folded meshes one slow step is often a plateau before the Gauss-Newton
      // steps speed up again (a 12 x 12 folded grid: 1 %, then up to 20 % a step).
      slow_in_a_row = slow ? slow_in_a_row + 1 : 0;
      if (slow && (s_.cur.mean <= s_.opt.tolerance_mean || slow_in_a_row == kPolishSlowStepsToStop)) break;
    }
  }

  // The global steps stop when the whole map gains little, which leaves the few spots whose
  // faces are far from their areas, often where the flow cannot reach (a corner, where the
  // Neumann field vanishes: fs741 pial 96 % mask, a corner element at 0.71 of its share). Those
  // get steps of their own: faces beyond far_band and `rings` rings around them, judged on their
  // own error, kept only if the whole map's errors do not rise.
  void far_face_steps() {
    const PolishOptions& po = s_.opt.polish;
    int slow_in_a_row = 0;
    for (int k = 0; k < po.far_iterations; ++k) {
      std::vector<char> free_vertex(s_.nv, 0);
      const int far = free_around(po.far_band, free_vertex);
      if (far == 0) break;
      std::vector<int> local_faces;
      for (Eigen::Index f = 0; f < s_.F.rows(); ++f)
        if (free_vertex[s_.F(f, 0)] || free_vertex[s_.F(f, 1)] || free_vertex[s_.F(f, 2)]) local_faces.push_back(static_cast<int>(f));
      MatrixXi Fl(local_faces.size(), 3);
      VectorXd tl(local_faces.size());
      for (std::size_t i = 0; i < local_faces.size(); ++i) {
        Fl.row(static_cast<Eigen::Index>(i)) = s_.F.row(local_faces[i]);
        tl[static_cast<Eigen::Index>(i)] = s_.target[local_faces[i]];
      }
      const double local_before = face_log_ratio_mean(tl, s_.UV, Fl);
      // The log residual: the area residual prices a crushed face at no more than its target and
      // trades it for larger faces (an ear crushed against a side, variable phantom seed 2
      // control19 lh: faces left at e^-10, element CV 0.0056; with it e^-0.76, 0.0027).
      const MatrixXd D = face_area_newton_displacement(s_.UV, s_.F, s_.target, s_.side_mask, free_vertex, po.cg_iterations,
                                                       FaceAreaResidual::LogArea);
      double local_after = local_before;
      const bool better = line_search(D, [&](const MatrixXd& next, double& fm, Stats& st) {
        local_after = face_log_ratio_mean(tl, next, Fl);
        if (!(local_after < local_before)) return false;
        fm = face_log_ratio_mean(s_.target, next, s_.F);
        st = s_.stats_of(next);
        return fm <= cur_face_ && st.mean <= s_.cur.mean * 1.01;
      });
      if (!better) break;
      ++s_.rep.polish_iterations;
      std::ostringstream msg;
      msg << "polish of the far faces " << k + 1 << " (" << far << " faces beyond " << po.far_band
          << "): their error " << local_before << " -> " << local_after;
      report(s_.progress, "flow", -1, msg.str());
      slow_in_a_row = local_after > 0.99 * local_before ? slow_in_a_row + 1 : 0;
      if (slow_in_a_row == kFarSlowStepsToStop) break;
    }
  }

 private:
  int free_around(double band, std::vector<char>& free_vertex) const {
    const int n = faces_outside_band(s_.target, s_.UV, s_.F, band, free_vertex);
    grow_by_rings(free_vertex, ring_, s_.opt.polish.rings);
    return n;
  }

  // Halving line search on a polish step D: the first scale (1, 1/2, 1/4) whose flip-safe
  // positions `accept` takes (it sets their per-face error and per-vertex stats) is kept.
  // No step thins a triangle that is above twice its float32 floor (twice, as the floor moves
  // with the vertices) below it: opening such slivers afterwards can fail and fall back to
  // untangling, which costs area (see core/square_map.cpp). One limit per line search.
  bool line_search(const MatrixXd& D, const std::function<bool(const MatrixXd&, double&, Stats&)>& accept) {
    VectorXd limit = VectorXd::Constant(s_.F.rows(), s_.min_area);
    if (s_.opt.polish.float32_floor) {
      const VectorXd floor = 2.0 * single_precision_area_floor(s_.UV, s_.F), a0 = signed_face_areas_2d(s_.UV, s_.F);
      for (Eigen::Index f = 0; f < s_.F.rows(); ++f)
        if (a0[f] > floor[f]) limit[f] = std::max(s_.min_area, floor[f]);
    }
    for (double scale = 1.0; scale > 0.1; scale *= 0.5) {
      MatrixXd next = rectangle_step_positions(s_.UV, s_.F, scale * D, s_.opt.theta, s_.side_mask, s_.w, s_.min_area, &limit);
      double fm = 0;
      Stats st;
      if (!accept(next, fm, st)) continue;
      s_.UV = std::move(next);
      s_.cur = st;
      cur_face_ = fm;
      return true;
    }
    return false;
  }

  Flow& s_;
  std::vector<std::vector<int>> ring_;
  double cur_face_;
};

}  // namespace

FlowResult authalic_flow(const MatrixXd& V, const MatrixXi& F, const MatrixXd& UV0, const VectorXi& side_mask,
                         const FlowOptions& opt, const ProgressFn& progress) {
  FlowResult res;
  FlowReport& rep = res.report;
  rep.method = opt.method;
  const double w = opt.width;
  rep.grid_resolution = opt.grid.cells();
  Flow s{V, F, side_mask, opt, progress, static_cast<int>(V.rows()), w, target_face_measure(V, F, opt.density, w),
         flip_area_threshold(w, F.rows()), UV0.leftCols(2), Stats{}, rep};
  s.cur = s.stats_of(s.UV);
  rep.initial_vertex_mean = s.cur.mean;
  rep.initial_vertex_p99 = s.cur.p99;

  if (opt.method == FlowMethod::Grid) grid_passes(s);
  if (opt.method == FlowMethod::Mesh) mesh_steps(s);

  // Flips on the output connectivity (the grid flow is a diffeomorphism only up to its
  // discretisation; the mesh method flows on flipped connectivity): re-place them.
  int remaining = 0;
  const int final_repairs = repair_flips(V, F, side_mask, w, s.UV, &remaining);
  rep.repaired += final_repairs;
  if (final_repairs > 0) s.cur = s.stats_of(s.UV);

  rep.flow_vertex_mean = s.cur.mean;
  if (opt.polish.enabled && remaining == 0) {
    Polish polish(s);
    polish.global_steps();
    polish.far_face_steps();
    if (s.met(s.cur)) rep.stop_reason = "tolerance";
  }

  rep.flips = count_flipped(s.UV, F, s.min_area);
  rep.converged = s.met(s.cur);
  rep.final_vertex_mean = s.cur.mean;
  rep.final_vertex_p99 = s.cur.p99;
  rep.final_vertex_max = s.cur.max;
  res.UV = std::move(s.UV);
  return res;
}

}  // namespace authalic

// Moser's area-restoring flow on the sphere over a fixed cube-sphere background (see sphere_flow.h).
#include "core/sphere_flow.h"


#include <Eigen/CholmodSupport>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <sstream>
#include <unordered_map>

#include "core/error.h"
#include "core/levenberg_marquardt.h"
#include "core/sparse_cholesky.h"

namespace authalic {

namespace {

using Vec3 = Eigen::Vector3d;

constexpr double kQuarterPi = 0.78539816339744830962;

// Cube face frames: outward axis normal n and tangent axes e1, e2 with e1 x e2 = n, so cells
// listed counter-clockwise in (e1, e2) are counter-clockwise seen from outside.
struct CubeFace {
  int axis;   // 0, 1, 2
  int sign;   // +1 / -1
  int e1[3];  // integer unit vectors
  int e2[3];
};
constexpr CubeFace kCubeFaces[6] = {
    {0, +1, {0, 1, 0}, {0, 0, 1}}, {0, -1, {0, 0, 1}, {0, 1, 0}}, {1, +1, {0, 0, 1}, {1, 0, 0}},
    {1, -1, {1, 0, 0}, {0, 0, 1}}, {2, +1, {1, 0, 0}, {0, 1, 0}}, {2, -1, {0, 1, 0}, {1, 0, 0}},
};

int cube_face_of(const Vec3& p) {
  const double ax = std::abs(p[0]), ay = std::abs(p[1]), az = std::abs(p[2]);
  if (ax >= ay && ax >= az) return p[0] >= 0 ? 0 : 1;
  if (ay >= az) return p[1] >= 0 ? 2 : 3;
  return p[2] >= 0 ? 4 : 5;
}

}  // namespace

// ---- CubeSphereGrid --------------------------------------------------------------------------

CubeSphereGrid::CubeSphereGrid(int cells_per_edge) : n_(cells_per_edge) {
  if (n_ < 1) throw ProcessingError("cube-sphere grid: cells per edge must be >= 1");
  const int n = n_;
  // Equal angles on each face: grid line k at angle -pi/4 + k pi/(2n), placed on the cube at
  // tan(angle). Exact symmetry (tan_[n-k] = -tan_[k]) keeps shared cube edges bit-identical.
  tan_.assign(n + 1, 0.0);
  for (int k = 0; k <= n; ++k) {
    if (2 * k == n) continue;
    if (2 * k > n) {
      tan_[k] = -tan_[n - k];
      continue;
    }
    tan_[k] = k == 0 ? -1.0 : std::tan(-kQuarterPi + kQuarterPi * 2.0 * k / n);
  }
  tan_[n] = 1.0;
  // Cell lookup table: bin b of [-1, 1] starts in cell cell_table_[b]; bins are narrower than
  // the narrowest cell, so locate() moves at most one cell from the guess.
  cell_table_.resize(static_cast<std::size_t>(4 * n));
  for (std::size_t b = 0, k = 0; b < cell_table_.size(); ++b) {
    const double w = -1.0 + 2.0 * static_cast<double>(b) / static_cast<double>(cell_table_.size());
    while (static_cast<int>(k) < n - 1 && w >= tan_[k + 1]) ++k;
    cell_table_[b] = static_cast<int>(k);
  }

  // Vertices are identified by integer cube coordinates in {-n, -n+2, ..., n}^3 (at least one at
  // +-n), so the points shared by two or three cube faces are merged exactly.
  const int side = 2 * n + 1;
  auto key_of = [&](int X, int Y, int Z) { return (static_cast<std::int64_t>(X + n) * side + (Y + n)) * side + (Z + n); };
  std::unordered_map<std::int64_t, int> index;
  index.reserve(static_cast<std::size_t>(6 * n * n + 2) * 2);
  std::vector<Vec3> positions;
  positions.reserve(static_cast<std::size_t>(6 * n * n + 2));
  std::vector<int> grid_vertex(static_cast<std::size_t>(6) * (n + 1) * (n + 1));
  for (int f = 0; f < 6; ++f) {
    const CubeFace& cf = kCubeFaces[f];
    for (int i = 0; i <= n; ++i) {
      for (int j = 0; j <= n; ++j) {
        int c[3];
        for (int d = 0; d < 3; ++d) c[d] = (d == cf.axis ? cf.sign * n : 0) + (2 * i - n) * cf.e1[d] + (2 * j - n) * cf.e2[d];
        const std::int64_t key = key_of(c[0], c[1], c[2]);
        auto it = index.find(key);
        int id;
        if (it == index.end()) {
          id = static_cast<int>(positions.size());
          index.emplace(key, id);
          Vec3 p(tan_[(c[0] + n) / 2], tan_[(c[1] + n) / 2], tan_[(c[2] + n) / 2]);
          positions.push_back(p.normalized());
        } else {
          id = it->second;
        }
        grid_vertex[(static_cast<std::size_t>(f) * (n + 1) + i) * (n + 1) + j] = id;
      }
    }
  }
  V_.resize(static_cast<Eigen::Index>(positions.size()), 3);
  for (std::size_t v = 0; v < positions.size(); ++v) V_.row(static_cast<Eigen::Index>(v)) = positions[v].transpose();

  // Split each cell along its shorter diagonal (all faces share the same pattern by symmetry),
  // which keeps every angle acute enough for positive cotangent weights.
  diagonal_.assign(static_cast<std::size_t>(n) * n, 0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      auto at = [&](int a, int b) { return Vec3(1.0, tan_[a], tan_[b]).normalized(); };
      const double d0 = (at(i, j) - at(i + 1, j + 1)).squaredNorm();
      const double d1 = (at(i + 1, j) - at(i, j + 1)).squaredNorm();
      diagonal_[static_cast<std::size_t>(i) * n + j] = d1 < d0 * (1.0 - 1e-12) ? 1 : 0;
    }
  }
  F_.resize(12 * n * n, 3);
  for (int f = 0; f < 6; ++f) {
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        auto gv = [&](int a, int b) { return grid_vertex[(static_cast<std::size_t>(f) * (n + 1) + a) * (n + 1) + b]; };
        const int v00 = gv(i, j), v10 = gv(i + 1, j), v11 = gv(i + 1, j + 1), v01 = gv(i, j + 1);
        const Eigen::Index t = 2 * ((static_cast<Eigen::Index>(f) * n + i) * n + j);
        if (diagonal_[static_cast<std::size_t>(i) * n + j] == 0) {
          F_.row(t) << v00, v10, v11;
          F_.row(t + 1) << v00, v11, v01;
        } else {
          F_.row(t) << v00, v10, v01;
          F_.row(t + 1) << v10, v11, v01;
        }
      }
    }
  }
  // Per face, the three vectors b x c, c x a, a x b: locate()'s barycentric coordinates are their
  // dot products with p, read from one contiguous block instead of three vertex rows.
  dual_.resize(static_cast<std::size_t>(F_.rows()) * 9);
  for (Eigen::Index t = 0; t < F_.rows(); ++t) {
    const Vec3 a = V_.row(F_(t, 0)).transpose(), b = V_.row(F_(t, 1)).transpose(), c = V_.row(F_(t, 2)).transpose();
    const Vec3 d[3] = {b.cross(c), c.cross(a), a.cross(b)};
    for (int k = 0; k < 3; ++k)
      for (int e = 0; e < 3; ++e) dual_[static_cast<std::size_t>(t) * 9 + 3 * k + e] = d[k][e];
  }
}

int CubeSphereGrid::locate(const Vec3& p, Vec3* barycentric) const {
  const int n = n_;
  const int f = cube_face_of(p);
  const CubeFace& cf = kCubeFaces[f];
  const double pa = std::abs(p[cf.axis]);
  // Gnomonic coordinates on the face: great circles are straight lines here, so the radial cone
  // of each flat background triangle is a straight-edged triangle in (u, v).
  const double u = (p[0] * cf.e1[0] + p[1] * cf.e1[1] + p[2] * cf.e1[2]) / pa;
  const double v = (p[0] * cf.e2[0] + p[1] * cf.e2[1] + p[2] * cf.e2[2]) / pa;
  auto cell_of = [&](double w) {
    // first guess from a uniform table over [-1, 1], then settle on the exact tan grid
    const int bin = std::clamp(static_cast<int>((w + 1.0) * 0.5 * static_cast<double>(cell_table_.size())), 0,
                               static_cast<int>(cell_table_.size()) - 1);
    int k = cell_table_[static_cast<std::size_t>(bin)];
    while (k > 0 && w < tan_[k]) --k;
    while (k < n - 1 && w > tan_[k + 1]) ++k;
    return k;
  };
  const int i = cell_of(u), j = cell_of(v);
  const double u0 = tan_[i], u1 = tan_[i + 1], v0 = tan_[j], v1 = tan_[j + 1];
  const Eigen::Index base = 2 * ((static_cast<Eigen::Index>(f) * n + i) * n + j);
  Eigen::Index t;
  if (diagonal_[static_cast<std::size_t>(i) * n + j] == 0) {
    // diagonal 00 -> 11: triangle 0 = (00, 10, 11) lies to its right
    const double cross = (u1 - u0) * (v - v0) - (v1 - v0) * (u - u0);
    t = cross < 0 ? base : base + 1;
  } else {
    // diagonal 10 -> 01: triangle 0 = (00, 10, 01) lies to its left
    const double cross = (u0 - u1) * (v - v0) - (v1 - v0) * (u - u1);
    t = cross > 0 ? base : base + 1;
  }
  if (barycentric) {
    // Radial projection onto the flat triangle: q = s p = la a + lb b + lc c with la+lb+lc = 1
    // gives la : lb : lc = det(p,b,c) : det(a,p,c) : det(a,b,p) = p.(b x c) : p.(c x a) : p.(a x b).
    const double* d = dual_.data() + static_cast<std::size_t>(t) * 9;
    Vec3 l(p[0] * d[0] + p[1] * d[1] + p[2] * d[2], p[0] * d[3] + p[1] * d[4] + p[2] * d[5],
           p[0] * d[6] + p[1] * d[7] + p[2] * d[8]);
    *barycentric = l / l.sum();
  }
  return static_cast<int>(t);
}

// ---- flow ------------------------------------------------------------------------------------

int sphere_flipped_faces(const MatrixXd& S, const MatrixXi& F) {
  int flips = 0;
#pragma omp parallel for schedule(static) reduction(+ : flips)
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Vec3 a = S.row(F(f, 0)).transpose(), b = S.row(F(f, 1)).transpose(), c = S.row(F(f, 2)).transpose();
    if ((b - a).cross(c - a).dot(a + b + c) <= 0) ++flips;
  }
  return flips;
}

namespace {

// A polish step that keeps more than this share of the error is slow.
constexpr double kSlowStep = 0.99;

// Area-weighted mean |ln(A_f / T_f)| with T scaled to the chord areas' total; folded faces count 10.
double sphere_face_error(const MatrixXd& S, const MatrixXi& F, const VectorXd& measure, VectorXd* areas = nullptr) {
  VectorXd a(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Vec3 p = S.row(F(f, 0)).transpose(), q = S.row(F(f, 1)).transpose(), r = S.row(F(f, 2)).transpose();
    const Vec3 n = (q - p).cross(r - p);
    a[f] = n.dot(p + q + r) > 0 ? 0.5 * n.norm() : -0.5 * n.norm();
  }
  const double k = a.sum() / measure.sum();
  double num = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) num += measure[f] * (a[f] > 0 ? std::abs(std::log(a[f] / (k * measure[f]))) : 10.0);
  if (areas) *areas = a;
  return num / measure.sum();
}

}  // namespace

int sphere_flipped_faces_stored(const MatrixXd& S, const MatrixXi& F) {
  const MatrixXd R = S.cast<float>().cast<double>();
  int flips = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    bool bad = false;
    for (const MatrixXd* X : {&S, &R}) {
      const Vec3 a = X->row(F(f, 0)).transpose(), b = X->row(F(f, 1)).transpose(), c = X->row(F(f, 2)).transpose();
      bad = bad || (b - a).cross(c - a).dot(a + b + c) <= 0;
    }
    flips += bad;
  }
  return flips;
}

namespace {

// Gauss-Newton (Levenberg-Marquardt) direction of the per-face polish for the free vertices
// (tangent displacements, #V x 3; zero for the others). Residual √T ln(a/T), ≈ (a − T)/√T near
// the target: the linear residual is bounded by √T however crushed a face is, so its steps
// traded crushed faces for inflated ones (fs741 pial: an element holding 1.27 x its share in
// crushed slivers). Rows: the faces touching a free vertex.
MatrixXd sphere_polish_direction(const MatrixXd& S, const MatrixXi& F, const VectorXd& measure, const VectorXd& a,
                                 const std::vector<char>& free_vertex, int cg_iterations) {
  const Eigen::Index nv = S.rows();
  const double k = a.sum() / measure.sum();
  // Columns in the order the rows (faces) first use their vertices (by vertex id, S655's CG
  // products took 2.6x as long).
  std::vector<int> col(static_cast<std::size_t>(nv), -1);
  int m = 0;
  for (const int v : vertices_in_face_order(F, nv))
    if (free_vertex[v]) col[v] = m++;
  // Tangent basis per free vertex.
  MatrixXd T1 = MatrixXd::Zero(nv, 3), T2 = MatrixXd::Zero(nv, 3);
  for (Eigen::Index v = 0; v < nv; ++v) {
    if (col[v] < 0) continue;
    const Vec3 n = S.row(v).transpose();
    const Vec3 helper = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    const Vec3 t1 = n.cross(helper).normalized(), t2 = n.cross(t1);
    T1.row(v) = t1.transpose();
    T2.row(v) = t2.transpose();
  }
  // Rows: at most the faces, and about 6 per free vertex (its fan); 2 entries per free corner.
  const std::size_t max_rows = static_cast<std::size_t>(std::min<Eigen::Index>(F.rows(), 7 * static_cast<Eigen::Index>(m)));
  JacobianRows J(2 * m, max_rows);
  std::vector<double> rows;
  rows.reserve(max_rows);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    if (col[F(f, 0)] < 0 && col[F(f, 1)] < 0 && col[F(f, 2)] < 0) continue;
    const double target = k * measure[f], af = std::max(a[f], 1e-3 * target), w = std::sqrt(target) / af;
    Vec3 p[3];
    for (int c = 0; c < 3; ++c) p[c] = S.row(F(f, c)).transpose();
    const Vec3 nh = (p[1] - p[0]).cross(p[2] - p[0]).normalized();
    for (int c = 0; c < 3; ++c) {
      const int i = F(f, c);
      if (col[i] < 0) continue;
      const Vec3 g = 0.5 * nh.cross(p[(c + 2) % 3] - p[(c + 1) % 3]);
      J.add(2 * col[i], w * g.dot(T1.row(i).transpose()));
      J.add(2 * col[i] + 1, w * g.dot(T2.row(i).transpose()));
    }
    J.end_row();
    rows.push_back(std::sqrt(target) * std::log(af / target));
  }
  const VectorXd step =
      levenberg_marquardt_step(J, Eigen::Map<const VectorXd>(rows.data(), static_cast<Eigen::Index>(rows.size())), cg_iterations);
  MatrixXd D = MatrixXd::Zero(nv, 3);
  for (Eigen::Index v = 0; v < nv; ++v)
    if (col[v] >= 0) D.row(v) = step[2 * col[v]] * T1.row(v) + step[2 * col[v] + 1] * T2.row(v);
  return D;
}

// Local polish steps: this many in a row removing under 1 % of their faces' error end them.
constexpr int kLocalSlowSteps = 3;

// Regional deviations matter for elements even when no single face is far off: a pocket of a
// few hundred faces each 15 % small (fs741 pial, the medial wall near (-1, 4, -20) mm) put
// 12 % too much cortex into one 64 x 32 element. Per vertex: the measure-weighted mean of
// ln(a_f / T_f) over its faces (crushed faces clamped to -3), smoothed by four Jacobi sweeps
// (x_v <- (x_v + mean of its neighbours) / 2), i.e. over about four rings.
constexpr double kRegionalThreshold = 0.05;

VectorXd regional_log_area_ratio(const MatrixXi& F, const VectorXd& measure, const VectorXd& a,
                                 const std::vector<std::vector<int>>& adj) {
  const Eigen::Index nv = static_cast<Eigen::Index>(adj.size());
  const double k = a.sum() / measure.sum();
  VectorXd num = VectorXd::Zero(nv), den = VectorXd::Zero(nv);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const double ln = a[f] > 0 ? std::clamp(std::log(a[f] / (k * measure[f])), -3.0, 3.0) : -3.0;
    for (int c = 0; c < 3; ++c) num[F(f, c)] += measure[f] * ln, den[F(f, c)] += measure[f];
  }
  VectorXd x = (num.array() / den.array().max(1e-300)).matrix(), y(nv);
  for (int sweep = 0; sweep < 4; ++sweep) {
    for (Eigen::Index v = 0; v < nv; ++v) {
      double s = 0;
      for (int u : adj[static_cast<std::size_t>(v)]) s += x[u];
      y[v] = adj[static_cast<std::size_t>(v)].empty() ? x[v] : 0.5 * (x[v] + s / static_cast<double>(adj[static_cast<std::size_t>(v)].size()));
    }
    x.swap(y);
  }
  return x;
}

// S + λ_v D_v put back on the sphere, with per-vertex λ halved at the vertices of faces that
// would flip (as the square map's local steps), so one bad face slows only its own vertices.
MatrixXd sphere_step_positions(const MatrixXd& S, const MatrixXi& F, const MatrixXd& D, double scale) {
  VectorXd lam = VectorXd::Constant(S.rows(), scale);
  MatrixXd next(S.rows(), 3);
  auto place = [&](Eigen::Index v) { next.row(v) = (S.row(v) + lam[v] * D.row(v)).normalized(); };
  for (Eigen::Index v = 0; v < S.rows(); ++v) place(v);
  halve_steps_until_unfolded(
      F, lam,
      [&](Eigen::Index f) {
        const Vec3 p = next.row(F(f, 0)).transpose(), q = next.row(F(f, 1)).transpose(), o = next.row(F(f, 2)).transpose();
        return (q - p).cross(o - p).dot(p + q + o) <= 0;
      },
      place);
  return next;
}

}  // namespace

double polish_sphere_face_areas(MatrixXd& S, const MatrixXi& F, const VectorXd& measure, int iterations,
                                int cg_iterations, int local_iterations, const ProgressFn& progress) {
  const Eigen::Index nv = S.rows();
  VectorXd a;
  double err = sphere_face_error(S, F, measure, &a);
  const int folded = sphere_flipped_faces(S, F);  // a step may not add any
  // Halving line search along D (scales 1, 1/2, 1/4, 1/8): the first flip-safe scale that
  // `objective(areas, error)` scores below `current`; when that gains less than 1 %, halved again
  // while that scores lower still. A Gauss-Newton step can overshoot the nonlinear ln-area
  // residual: fsaverage5 white with the seam started at its anterior point, full step
  // 0.0325 -> 0.0322, half step -> 0.0239; taking the first decrease ended the global steps there
  // (under 1 % gain) and failed the map (element CV 0.0101). Halving every step instead, greedily,
  // ends worse (8 shorter steps: per-face mean 0.0079 against 0.0059 with full steps).
  // `objective` returns +inf for a step it refuses. Returns whether a step was taken.
  auto line_search = [&](const MatrixXd& D, double current, const std::function<double(const VectorXd&, double)>& objective) {
    constexpr double kRefused = std::numeric_limits<double>::infinity();
    double best = current, best_err = err;
    MatrixXd best_S;
    VectorXd best_a;
    for (double scale = 1.0; scale > 0.1; scale *= 0.5) {
      MatrixXd next = sphere_step_positions(S, F, D, scale);
      VectorXd na;
      const double e = sphere_face_error(next, F, measure, &na);
      const double o = sphere_flipped_faces(next, F) <= folded ? objective(na, e) : kRefused;
      if (!(o < best)) {
        if (best < current) break;  // the previous scale was the best of the halvings
        continue;
      }
      best = o, best_err = e;
      best_S = std::move(next);
      best_a = std::move(na);
      if (best < kSlowStep * current) break;  // a good step: kept as it is
    }
    if (!(best < current)) return false;
    S = std::move(best_S);
    a = std::move(best_a);
    err = best_err;
    return true;
  };
  // Global steps (every vertex free) while they gain 1 %.
  const std::vector<char> all(static_cast<std::size_t>(nv), 1);
  for (int it = 0; it < iterations; ++it) {
    const double before = err;
    const bool stepped = line_search(sphere_polish_direction(S, F, measure, a, all, cg_iterations), err,
                                     [](const VectorXd&, double e) { return e; });
    report(progress, "polish", double(it + 1) / iterations,
           "sphere polish " + std::to_string(it + 1) + ": per-face mean |ln ratio| " + std::to_string(before) + " -> " +
               std::to_string(err));
    if (!stepped || err > 0.99 * before) break;
  }
  // Then local steps about the faces still beyond e^±0.5 of their share, the vertices whose
  // regional error exceeds 5 % (regional_log_area_ratio), and 3 rings around them, judged on
  // those faces' own error: a few hundred crushed faces never move the global error by 1 %, but
  // they can hold a whole element's excess (fs741 pial: element CV 0.00523 -> 0.00506 with the
  // regional set; fsaverage5 spheres S1 (docs/references.md) and fs741 white unchanged).
  // A deeply crushed pocket opens by a bounded factor per step (no face may flip) and some steps
  // gain little before the next gains more: they go on until several slow steps in a row (a
  // voxelised white surface's 50 mm² bulb on a 3 mm neck, crushed to e^-12: the first slow step
  // left 154 faces below e^-5, 32 steps leave 17; docs/robustness.md).
  const std::vector<std::vector<int>> adj = vertex_neighbours(F, nv);
  int slow_in_a_row = 0;
  for (int it = 0; it < local_iterations; ++it) {
    const double k = a.sum() / measure.sum();
    std::vector<char> free_vertex(static_cast<std::size_t>(nv), 0);
    bool any = false;
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (!(a[f] > 0) || std::abs(std::log(a[f] / (k * measure[f]))) > 0.5)
        for (int c = 0; c < 3; ++c) free_vertex[F(f, c)] = 1, any = true;
    const VectorXd regional = regional_log_area_ratio(F, measure, a, adj);
    for (Eigen::Index v = 0; v < nv; ++v)
      if (std::abs(regional[v]) > kRegionalThreshold) free_vertex[v] = 1, any = true;
    if (!any) break;
    grow_by_rings(free_vertex, adj, 3);
    std::vector<int> local;
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (free_vertex[F(f, 0)] || free_vertex[F(f, 1)] || free_vertex[F(f, 2)]) local.push_back(static_cast<int>(f));
    auto local_error = [&](const VectorXd& area) {
      const double kk = area.sum() / measure.sum();
      double num = 0, den = 0;
      for (int f : local) {
        num += measure[f] * (area[f] > 0 ? std::abs(std::log(area[f] / (kk * measure[f]))) : 10.0);
        den += measure[f];
      }
      return num / den;
    };
    const double before = local_error(a), global = err;
    double after = before;
    const bool stepped = line_search(sphere_polish_direction(S, F, measure, a, free_vertex, cg_iterations), before,
                                     [&](const VectorXd& na, double e) { return e > global ? std::numeric_limits<double>::infinity() : local_error(na); });
    if (stepped) after = local_error(a);
    if (!stepped) break;
    slow_in_a_row = after > 0.99 * before ? slow_in_a_row + 1 : 0;
    report(progress, "polish", -1,
           "sphere polish, local step " + std::to_string(it + 1) + " (" + std::to_string(local.size()) + " faces): their error " +
               std::to_string(before) + " -> " + std::to_string(after));
    if (slow_in_a_row == kLocalSlowSteps) break;
  }
  return err;
}

namespace {

// The background with everything that does not change between passes: grid, lumped masses,
// gradient operators and the factorised Laplacian (vertex 0 pinned: the Neumann problem on a
// closed surface is defined up to a constant).
class SphereBackground {
 public:
  explicit SphereBackground(int n) : grid(n) {
    const MatrixXd& V = grid.vertices();
    const MatrixXi& F = grid.faces();
    const Eigen::Index nv = V.rows(), nf = F.rows();
    mass = barycentric_vertex_areas(V, F);
    // P1 gradient of the hat functions on each flat triangle: grad phi_a = n x (c - b) / (2A).
    grad_op.resize(nf, 9);
    face_area.resize(nf);
    for (Eigen::Index f = 0; f < nf; ++f) {
      const Vec3 a = V.row(F(f, 0)).transpose(), b = V.row(F(f, 1)).transpose(), c = V.row(F(f, 2)).transpose();
      const Vec3 cr = (b - a).cross(c - a);
      const double area2 = cr.norm();
      const Vec3 nrm = cr / area2;
      const Vec3 ga = nrm.cross(c - b) / area2, gb = nrm.cross(a - c) / area2, gc = nrm.cross(b - a) / area2;
      grad_op.row(f) << ga.transpose(), gb.transpose(), gc.transpose();
      face_area[f] = 0.5 * area2;
    }
    // Vertex -> incident faces (CSR) for a gather that is independent of the thread count.
    vf_start.assign(static_cast<std::size_t>(nv) + 1, 0);
    for (Eigen::Index f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) ++vf_start[static_cast<std::size_t>(F(f, c)) + 1];
    for (Eigen::Index v = 0; v < nv; ++v) vf_start[v + 1] += vf_start[v];
    vf_list.resize(static_cast<std::size_t>(vf_start.back()));
    std::vector<int> fill(vf_start.begin(), vf_start.end() - 1);
    for (Eigen::Index f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) vf_list[static_cast<std::size_t>(fill[F(f, c)]++)] = static_cast<int>(f);

    // -L restricted to vertices 1..nv-1 is symmetric positive definite.
    const SparseMatrix L = cotmatrix(V, F);
    SparseMatrix K = (-L).bottomRightCorner(nv - 1, nv - 1);
    K.makeCompressed();
    solver = std::make_unique<Eigen::CholmodSimplicialLDLT<SparseMatrix>>();
    {
      const std::lock_guard<std::mutex> ordering(metis_mutex());  // CHOLMOD's default may try METIS
      solver->compute(K);
    }
    if (solver->info() != Eigen::Success) throw ProcessingError("sphere flow: the background Laplacian could not be factorised");
    mean_edge = std::sqrt(4.0 * face_area.mean() / std::sqrt(3.0));
  }

  // Solve -L g = b (sum b = 0), g(0) = 0.
  VectorXd solve(const VectorXd& b) const {
    VectorXd g(b.size());
    g[0] = 0.0;
    g.tail(b.size() - 1) = solver->solve(b.tail(b.size() - 1));
    return g;
  }

  // Per-vertex tangent gradient: area-weighted mean of the incident face gradients (cf. Zou et al. 2011a
  // eq. 16, with area instead of angle weights), projected to the sphere's tangent plane
  // (eqs. 21-22).
  MatrixXd vertex_gradients(const VectorXd& g) const {
    const MatrixXd& V = grid.vertices();
    const MatrixXi& F = grid.faces();
    MatrixXd G(V.rows(), 3);
#pragma omp parallel for schedule(static)
    for (Eigen::Index v = 0; v < V.rows(); ++v) {
      Vec3 sum = Vec3::Zero();
      double wsum = 0.0;
      for (int k = vf_start[v]; k < vf_start[v + 1]; ++k) {
        const int f = vf_list[static_cast<std::size_t>(k)];
        Vec3 gf = Vec3::Zero();
        for (int c = 0; c < 3; ++c) gf += g[F(f, c)] * grad_op.row(f).segment<3>(3 * c).transpose();
        sum += face_area[f] * gf;
        wsum += face_area[f];
      }
      Vec3 gv = sum / wsum;
      const Vec3 p = V.row(v).transpose();
      gv -= gv.dot(p) * p;
      G.row(v) = gv.transpose();
    }
    return G;
  }

  CubeSphereGrid grid;
  VectorXd mass;        // lumped (barycentric) vertex areas of the background, sum ~ 4 pi
  MatrixXd grad_op;     // #F x 9
  VectorXd face_area;
  std::vector<int> vf_start, vf_list;
  std::unique_ptr<Eigen::CholmodSimplicialLDLT<SparseMatrix>> solver;
  double mean_edge = 0.0;
};

// Rasterise the face measure of a sphere map onto the background: each mapped (flat) triangle is
// cut into m x m sub-triangles, whose centroids (radially projected) carry measure/m^2 into the
// three hat functions of the background triangle they fall in. Returns per-background-vertex
// measure W (sum W = sum measure); W / mass is the lumped L2 projection of the density.
VectorXd rasterise_measure(const SphereBackground& bg, const MatrixXd& S, const MatrixXi& F, const VectorXd& measure) {
  const Eigen::Index nf = F.rows();
  const double spacing = 0.5 * bg.mean_edge;  // at least ~2 samples per background edge
  std::vector<int> m(static_cast<std::size_t>(nf));
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < nf; ++f) {
    const Vec3 a = S.row(F(f, 0)).transpose(), b = S.row(F(f, 1)).transpose(), c = S.row(F(f, 2)).transpose();
    const double e = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    m[static_cast<std::size_t>(f)] = std::clamp(static_cast<int>(std::ceil(e / spacing)), 1, 32);
  }
  std::vector<std::int64_t> start(static_cast<std::size_t>(nf) + 1, 0);
  for (Eigen::Index f = 0; f < nf; ++f) start[f + 1] = start[f] + static_cast<std::int64_t>(m[f]) * m[f];
  const std::int64_t ns = start.back();
  std::vector<int> tri(static_cast<std::size_t>(ns));
  std::vector<float> wts(static_cast<std::size_t>(ns) * 3);
#pragma omp parallel for schedule(dynamic, 256)
  for (Eigen::Index f = 0; f < nf; ++f) {
    const Vec3 a = S.row(F(f, 0)).transpose(), b = S.row(F(f, 1)).transpose(), c = S.row(F(f, 2)).transpose();
    const int mf = m[static_cast<std::size_t>(f)];
    const double w = measure[f] / (static_cast<double>(mf) * mf);
    std::int64_t s = start[f];
    auto put = [&](double x, double y) {  // barycentric (1-x-y, x, y) of the sample
      const Vec3 q = ((1.0 - x - y) * a + x * b + y * c).normalized();
      Vec3 l;
      tri[static_cast<std::size_t>(s)] = bg.grid.locate(q, &l);
      for (int k = 0; k < 3; ++k) wts[static_cast<std::size_t>(s) * 3 + k] = static_cast<float>(w * l[k]);
      ++s;
    };
    for (int i = 0; i < mf; ++i) {
      for (int j = 0; i + j < mf; ++j) {
        put((i + 1.0 / 3.0) / mf, (j + 1.0 / 3.0) / mf);                    // upward sub-triangle
        if (i + j + 1 < mf) put((i + 2.0 / 3.0) / mf, (j + 2.0 / 3.0) / mf);  // downward one
      }
    }
  }
  // Serial accumulation in sample order: the sum does not depend on the thread count.
  const MatrixXi& BF = bg.grid.faces();
  VectorXd W = VectorXd::Zero(bg.grid.vertices().rows());
  for (std::int64_t s = 0; s < ns; ++s) {
    const int t = tri[static_cast<std::size_t>(s)];
    for (int k = 0; k < 3; ++k) W[BF(t, k)] += wts[static_cast<std::size_t>(s) * 3 + k];
  }
  // float weights lose ~1e-7 of the total: restore it exactly so sum W = sum measure.
  W *= measure.sum() / W.sum();
  return W;
}

int auto_grid_cells(Eigen::Index num_faces) {
  // About 1.35 background faces per mesh face (48 cells per cube edge for a 20k-face hemisphere),
  // within [32, 64]. Measured on fsaverage5 white / pial (20k faces): element CV 0.0060 / 0.0064
  // at 48 cells, 0.0047 / 0.0054 at 64 and 0.005 at 96, per-face mean |ln area ratio| unchanged
  // (0.037 / 0.042), at 48 cells 25% less CPU time than at 64. On white subdivided twice (328k
  // faces): 64 cells give element CV 0.0018 and per-face 0.017, 96 cells 0.0007 and 0.014 at 2.5
  // times the flow time.
  const double n = std::sqrt(static_cast<double>(num_faces) / 9.0);
  return std::clamp(static_cast<int>(std::ceil(n / 8.0) * 8.0), 32, 64);
}

}  // namespace

MatrixXd moser_sphere_flow(const MatrixXd& S0, const MatrixXi& F, const VectorXd& face_measure, const SphereFlowOptions& options,
                           SphereFlowReport* out_report, const ProgressFn& progress) {
  if (S0.cols() != 3 || F.cols() != 3 || face_measure.size() != F.rows())
    throw ProcessingError("sphere flow: inconsistent sizes of the map, faces and face measure");
  if (!(face_measure.minCoeff() >= 0.0) || !(face_measure.sum() > 0.0))
    throw ProcessingError("sphere flow: the face measure must be non-negative with a positive total");
  const int n = options.grid_cells > 0 ? options.grid_cells : auto_grid_cells(F.rows());
  report(progress, "sphere", 0.0, "background grid " + std::to_string(n) + " cells per cube edge");
  const SphereBackground bg(n);
  const Eigen::Index nbv = bg.grid.vertices().rows();
  if (out_report) {
    out_report->grid_cells = n;
    out_report->grid_vertices = static_cast<int>(nbv);
    out_report->passes.clear();
  }
  // The measure, scaled so that its total is the background's area (mean density 1).
  const VectorXd measure = face_measure * (bg.mass.sum() / face_measure.sum());

  MatrixXd S = S0;
  for (Eigen::Index v = 0; v < S.rows(); ++v) S.row(v).normalize();
  for (int pass = 0; pass < options.max_passes; ++pass) {
    const VectorXd W = rasterise_measure(bg, S, F, measure);
    const VectorXd rho = W.cwiseQuotient(bg.mass);
    SphereFlowPass info;
    info.rho_min = rho.minCoeff();
    info.rho_max = rho.maxCoeff();
    double log_sum = 0.0;
    for (Eigen::Index v = 0; v < nbv; ++v) log_sum += bg.mass[v] * std::abs(std::log(std::max(rho[v], 1e-300)));
    info.rho_abs_log_mean = log_sum / bg.mass.sum();
    const double max_log = std::max(std::abs(std::log(std::max(info.rho_min, 1e-300))), std::abs(std::log(info.rho_max)));
    if (options.tolerance > 0.0 && max_log < options.tolerance) {
      if (out_report) out_report->passes.push_back(info);
      break;
    }
    // Poisson Delta g = rho - 1 in weak form: with libigl's L (negative semi-definite, L ~ M Delta)
    // L g = M (rho - 1) = W - M, i.e. (-L) g = M - W.
    const VectorXd g = bg.solve(bg.mass - W);
    const MatrixXd G = bg.vertex_gradients(g);
    // Velocity u_t = grad g / ((1 - t) rho + t): with L g = M (rho - 1), g has its minima where
    // rho > 1, so grad g points out of crowded regions and spreads them.
    // Time nodes. Where rho << 1 the speed |grad g| / ((1-t) rho + t) is largest at t = 0, so the
    // nodes are graded: geometric in mu = (1-t) rho_min + t, i.e. uniform in ln mu. One step then
    // moves a point by at most |grad g| * dln(mu) / (1 - rho_min); the step count keeps that near
    // options.step_length background edges.
    const double gmax = std::sqrt(G.rowwise().squaredNorm().maxCoeff());
    const double rmin = std::clamp(info.rho_min, 1e-4, 1.0);
    const bool graded = rmin < 0.5;
    const double travel = graded ? gmax * std::log(1.0 / rmin) / (1.0 - rmin) : gmax / rmin;
    int steps = options.rk4_steps;
    if (steps <= 0) steps = std::clamp(static_cast<int>(std::ceil(travel / (options.step_length * bg.mean_edge))), 2, 48);
    info.rk4_steps = steps;
    std::vector<double> nodes(static_cast<std::size_t>(steps) + 1);
    for (int k = 0; k <= steps; ++k) {
      const double u = static_cast<double>(k) / steps;
      nodes[static_cast<std::size_t>(k)] = graded ? (std::pow(rmin, 1.0 - u) - rmin) / (1.0 - rmin) : u;
    }
    nodes.front() = 0.0;
    nodes.back() = 1.0;

    // Per background face, its corners' (grad g, rho) in one contiguous block of 12 doubles, so
    // each velocity evaluation reads one face record instead of six scattered vertex rows.
    const MatrixXi& BF = bg.grid.faces();
    std::vector<double> corner(static_cast<std::size_t>(BF.rows()) * 12);
#pragma omp parallel for schedule(static)
    for (Eigen::Index f = 0; f < BF.rows(); ++f)
      for (int k = 0; k < 3; ++k) {
        double* c = corner.data() + static_cast<std::size_t>(f) * 12 + 4 * k;
        for (int e = 0; e < 3; ++e) c[e] = G(BF(f, k), e);
        c[3] = rho[BF(f, k)];
      }
    auto velocity = [&](const Vec3& x, double t) {
      Vec3 l;
      const int tri = bg.grid.locate(x, &l);
      const double* c = corner.data() + static_cast<std::size_t>(tri) * 12;
      Vec3 gv = Vec3::Zero();
      double r = 0.0;
      for (int k = 0; k < 3; ++k) {
        gv += l[k] * Vec3(c[4 * k], c[4 * k + 1], c[4 * k + 2]);
        r += l[k] * c[4 * k + 3];
      }
      gv -= gv.dot(x) * x;
      return Vec3(gv / ((1.0 - t) * std::max(r, 1e-6) + t));
    };
    MatrixXd next(S.rows(), 3);
#pragma omp parallel for schedule(dynamic, 512)
    for (Eigen::Index v = 0; v < S.rows(); ++v) {
      Vec3 x = S.row(v).transpose();
      for (int k = 0; k < steps; ++k) {
        const double t = nodes[static_cast<std::size_t>(k)];
        const double dt = nodes[static_cast<std::size_t>(k) + 1] - t;
        const Vec3 k1 = velocity(x, t);
        const Vec3 k2 = velocity((x + 0.5 * dt * k1).normalized(), t + 0.5 * dt);
        const Vec3 k3 = velocity((x + 0.5 * dt * k2).normalized(), t + 0.5 * dt);
        const Vec3 k4 = velocity((x + dt * k3).normalized(), t + dt);
        x = (x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)).normalized();
      }
      next.row(v) = x.transpose();
    }
    S.swap(next);
    if (out_report) out_report->passes.push_back(info);
    std::ostringstream msg;
    msg << "pass " << pass + 1 << ": density " << info.rho_min << ".." << info.rho_max << ", " << steps << " RK4 steps";
    report(progress, "sphere", static_cast<double>(pass + 1) / options.max_passes, msg.str());
  }
  return S;
}

}  // namespace authalic

// Haker's conformal sphere map, Moebius normalisation, orientation rule, and the authalic sphere
// pipeline (see sphere_map.h).
#include "core/sphere_map.h"

#include <Eigen/CholmodSupport>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

#include "core/error.h"
#include "core/metrics.h"
#include "core/sparse_cholesky.h"

namespace authalic {

namespace {

using Vec3 = Eigen::Vector3d;


// Weighted median of values (weights >= 0): the smallest value whose cumulative weight reaches half.
double weighted_median(const VectorXd& values, const VectorXd& w) {
  std::vector<int> order(static_cast<std::size_t>(values.size()));
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return values[a] < values[b] || (values[a] == values[b] && a < b); });
  const double half = 0.5 * w.sum();
  double acc = 0.0;
  for (int i : order) {
    acc += w[i];
    if (acc >= half) return values[i];
  }
  return values[order.back()];
}

}  // namespace

// ---- Haker's conformal map -------------------------------------------------------------------

struct HakerConformalSolver::Impl {
  MatrixXd V;
  MatrixXi F;
  Eigen::CholmodSupernodalLLT<SparseMatrix> solver;  // D = -L with vertex 0 pinned
};

HakerConformalSolver::HakerConformalSolver(const MatrixXd& V, const MatrixXi& F) : impl_(std::make_unique<Impl>()) {
  impl_->V = V;
  impl_->F = F;
  // Seed 002 eqs. 5-6: D_PQ = -(cot R + cot S)/2, D_PP = -sum_Q D_PQ, i.e. D = -L (libigl L).
  // D is singular with kernel the constants (section 3.3) and a, b sum to zero, so pinning one
  // vertex (x_0 = 0) leaves a symmetric positive definite system with the same solutions.
  const SparseMatrix D = -cotmatrix(V, F);
  const Eigen::Index n = D.rows();
  SparseMatrix K = D.bottomRightCorner(n - 1, n - 1);
  K.makeCompressed();
  // Nested dissection (METIS) only: CHOLMOD's default also tries AMD first, which costs more
  // than it saves on surface meshes (measured: 164k vertices, 3.2 s vs 5.7 s).
  impl_->solver.cholmod().nmethods = 1;
  impl_->solver.cholmod().method[0].ordering = CHOLMOD_METIS;
  {
    const std::lock_guard<std::mutex> ordering(metis_mutex());
    impl_->solver.analyzePattern(K);
  }
  if (impl_->solver.info() == Eigen::Success) {
    const BlasCall call;
    impl_->solver.factorize(K);
  }
  if (impl_->solver.info() != Eigen::Success)
    throw ProcessingError("conformal sphere map: the cotangent matrix could not be factorised (degenerate triangles?)");
}

HakerConformalSolver::~HakerConformalSolver() = default;

MatrixXd HakerConformalSolver::planar_map(int puncture_face) const {
  const MatrixXd& V = impl_->V;
  const MatrixXi& F = impl_->F;
  if (puncture_face < 0 || puncture_face >= F.rows()) throw ProcessingError("conformal sphere map: puncture face out of range");
  const int ia = F(puncture_face, 0), ib = F(puncture_face, 1), ic = F(puncture_face, 2);
  const Vec3 A = V.row(ia).transpose(), B = V.row(ib).transpose(), C = V.row(ic).transpose();
  // Seed 002 section 3.2: u axis along AB, v axis toward C; E = A + theta (B - A) is the foot of
  // the perpendicular from C. a_Q = d phi_Q / du, b_Q = d phi_Q / dv.
  const double ab = (B - A).norm();
  const double theta = (C - A).dot(B - A) / (ab * ab);
  const Vec3 E = A + theta * (B - A);
  const double ce = (C - E).norm();
  if (!(ab > 0) || !(ce > 0)) throw ProcessingError("conformal sphere map: the puncture face is degenerate");
  const Eigen::Index n = V.rows();
  VectorXd a = VectorXd::Zero(n), b = VectorXd::Zero(n);
  a[ia] += -1.0 / ab;
  a[ib] += 1.0 / ab;
  b[ia] += -(1.0 - theta) / ce;
  b[ib] += -theta / ce;
  b[ic] += 1.0 / ce;
  // D z = a - i b (eq. 7): D x = a, D y = -b (section 3.4, step 2).
  MatrixXd rhs(n - 1, 2);
  rhs.col(0) = a.tail(n - 1);
  rhs.col(1) = -b.tail(n - 1);
  MatrixXd sol;
  {
    const BlasCall call;
    sol = impl_->solver.solve(rhs);
  }
  MatrixXd Z(n, 2);
  Z.row(0).setZero();
  Z.bottomRows(n - 1) = sol;
  return Z;
}

MatrixXd HakerConformalSolver::sphere_map(int puncture_face) const { return inverse_stereographic(planar_map(puncture_face)); }

MatrixXd inverse_stereographic(const MatrixXd& Z) {
  MatrixXd S(Z.rows(), 3);
  for (Eigen::Index i = 0; i < Z.rows(); ++i) {
    const double x = Z(i, 0), y = Z(i, 1), r2 = x * x + y * y;
    S.row(i) << 2.0 * x / (1.0 + r2), 2.0 * y / (1.0 + r2), (r2 - 1.0) / (1.0 + r2);
  }
  return S;
}

// ---- Moebius normalisation -------------------------------------------------------------------

MatrixXd mobius_centre(const MatrixXd& S0, const VectorXd& w, int max_iterations, double* residual) {
  MatrixXd S = S0;
  const double wsum = w.sum();
  auto centroid = [&](const MatrixXd& X) { return Vec3((X.transpose() * w) / wsum); };
  // phi_a(x) = (1 - |a|^2)(x - a)/|x - a|^2 - a: the ball's hyperbolic translation taking a to
  // the origin; it maps the unit sphere to itself conformally, keeping orientation.
  auto apply = [](const MatrixXd& X, const Vec3& a) {
    MatrixXd Y(X.rows(), 3);
    const double s = 1.0 - a.squaredNorm();
    for (Eigen::Index i = 0; i < X.rows(); ++i) {
      const Vec3 d = X.row(i).transpose() - a;
      Vec3 y = s * d / d.squaredNorm() - a;
      Y.row(i) = y.normalized().transpose();
    }
    return Y;
  };
  Vec3 c = centroid(S);
  for (int it = 0; it < max_iterations && c.norm() > 1e-13; ++it) {
    // Newton step: to first order phi_a(x) = x - 2a + 2<a,x> x, so the centroid moves by
    // -2 (I - C) a with C = sum w x x^T / sum w.
    const Eigen::Matrix3d C = (S.transpose() * w.asDiagonal() * S) / wsum;
    Vec3 a = (2.0 * (Eigen::Matrix3d::Identity() - C)).ldlt().solve(c);
    if (!a.allFinite()) a = 0.75 * c;
    if (a.norm() > 0.5) a *= 0.5 / a.norm();  // stay well inside the ball
    // Backtracking: accept only steps that shrink the centroid.
    constexpr int kMaxBacktracks = 30;  // halvings: 2^-30 of the Newton step, below any useful move
    for (int k = 0; k < kMaxBacktracks; ++k) {
      MatrixXd T = apply(S, a);
      const Vec3 ct = centroid(T);
      if (ct.norm() < c.norm()) {
        S.swap(T);
        c = ct;
        break;
      }
      a *= 0.5;
    }
    if (a.norm() < 1e-16) break;
  }
  if (residual) *residual = c.norm();
  return S;
}

// ---- orientation rule ------------------------------------------------------------------------

Eigen::Matrix3d sphere_orientation(const MatrixXd& V, const MatrixXi& F, const MatrixXd& S) {
  const VectorXd w = barycentric_vertex_areas(V, F);
  const Vec3 centre = (V.transpose() * w) / w.sum();
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if (w[i] <= 0) continue;
    Vec3 d = V.row(i).transpose() - centre;
    const double len = d.norm();
    if (len <= 0) continue;
    H += w[i] * S.row(i).transpose().normalized() * (d / len).transpose();
  }
  // maximise tr(R H): H = U Sigma V^T -> R = V diag(1, 1, det(V U^T)) U^T (proper rotation).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixV() * D * svd.matrixU().transpose();
}

// ---- flip repair -----------------------------------------------------------------------------

int repair_sphere_flips(MatrixXd& S, const MatrixXi& F, int max_rounds) {
  const Eigen::Index nv = S.rows();
  const std::vector<std::vector<int>> adj = vertex_neighbours(F, nv);  // for the neighbour means
  std::vector<char> moved(static_cast<std::size_t>(nv), 0);
  for (int round = 0; round < max_rounds; ++round) {
    std::vector<char> mark(static_cast<std::size_t>(nv), 0);
    bool any = false;
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      const Vec3 a = S.row(F(f, 0)).transpose(), b = S.row(F(f, 1)).transpose(), c = S.row(F(f, 2)).transpose();
      if ((b - a).cross(c - a).dot(a + b + c) <= 0) {
        for (int k = 0; k < 3; ++k) mark[F(f, k)] = 1;
        any = true;
      }
    }
    if (!any) break;
    // widen the region every 10 rounds when a small one does not untangle
    grow_by_rings(mark, adj, round / 10);
    // Gauss-Seidel in index order (deterministic): each marked vertex to its neighbours' mean.
    for (int sweep = 0; sweep < 5; ++sweep)
      for (Eigen::Index v = 0; v < nv; ++v) {
        if (!mark[v]) continue;
        Vec3 m = Vec3::Zero();
        for (int u : adj[v]) m += S.row(u).transpose();
        if (m.norm() > 0) S.row(v) = m.normalized().transpose();
        moved[v] = 1;
      }
  }
  return static_cast<int>(std::count(moved.begin(), moved.end(), 1));
}

// ---- pipeline --------------------------------------------------------------------------------

namespace {

// Candidate punctures: faces ranked by their smallest angle (best-shaped first; a well-shaped
// puncture keeps the right-hand side of eq. 7 and the pole region well conditioned), skipping
// faces that touch an already chosen one so that retries land elsewhere.
std::vector<int> puncture_candidates(const MatrixXd& V, const MatrixXi& F, int count) {
  const MatrixXd ang = corner_angles(V, F);
  std::vector<int> order(static_cast<std::size_t>(F.rows()));
  std::iota(order.begin(), order.end(), 0);
  const VectorXd quality = ang.rowwise().minCoeff();
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return quality[a] > quality[b]; });
  std::vector<int> chosen;
  std::vector<char> used(static_cast<std::size_t>(V.rows()), 0);
  for (int f : order) {
    if (static_cast<int>(chosen.size()) >= count) break;
    if (used[F(f, 0)] || used[F(f, 1)] || used[F(f, 2)]) continue;
    chosen.push_back(f);
    for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;
  }
  return chosen;
}

}  // namespace

bool sphere_covers_once(const MatrixXd& S, const MatrixXi& F) {
  if (sphere_flipped_faces(S, F) > 0) return false;
  // Signed spherical triangle areas (Van Oosterom & Strackee 1983) add up to 4π x the map's
  // degree; chord areas do not bound it (a needle along a great circle has chord area and no
  // spherical area).
  double total = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Vec3 a = S.row(F(f, 0)).transpose(), b = S.row(F(f, 1)).transpose(), c = S.row(F(f, 2)).transpose();
    total += 2.0 * std::atan2(a.dot(b.cross(c)), 1.0 + a.dot(b) + b.dot(c) + c.dot(a));
  }
  return std::abs(total - 4.0 * M_PI) < 1e-6 * 4.0 * M_PI;
}

namespace {

// Last steps of either route: flips repaired, the orientation rule applied; S moves into result.
void finish_sphere(const MatrixXd& V, const MatrixXi& F, const SphereMapOptions& options, MatrixXd& S,
                   SphereMapResult& result) {
  result.flips = sphere_flipped_faces(S, F);
  if (result.flips > 0) {
    result.repaired_vertices += repair_sphere_flips(S, F);
    result.flips = sphere_flipped_faces(S, F);
  }
  if (options.orient) {
    result.rotation = sphere_orientation(V, F, S);
    S = S * result.rotation.transpose();
  }
  result.sphere = std::move(S);
}

// One attempt of the square route with the seam's corner at `offset`: the finished sphere in
// `result`, and its placement (element areas measured when it covers the sphere once).
SquarePlacement square_attempt(const MatrixXd& V, const MatrixXi& F, const SphereMapOptions& options, double offset,
                               SphereMapResult& result, const ProgressFn& progress) {
  SquarePlacement p;
  p.corner_offset = offset;
  SphereFromSquareOptions so = options.square_route;
  so.corner_offset = offset;
  try {
    MatrixXd S = sphere_from_square_map(V, F, so, &result.square_route, progress);
    p.corner_vertex = result.square_route.corner_vertex;
    finish_sphere(V, F, options, S, result);
    p.mapped = true;
    p.covers_once = sphere_covers_once(result.sphere, F);
    if (!p.covers_once) p.why = "the square route's sphere does not cover it once";
  } catch (const ProcessingError& e) {
    p.why = e.what();
  }
  result.route = SphereRoute::Square;
  result.conformal = result.sphere;  // this route has no conformal sphere
  if (p.covers_once) {  // the acceptance's metrics (64 x 32), kept with the sphere for the caller
    result.metrics = map_metrics(V, result.sphere, F, Domain::sphere(), 32);
    p.element_cv = result.metrics->element_cv, p.element_min = result.metrics->element_min, p.element_max = result.metrics->element_max;
  }
  return p;
}

// A pocket: an element beyond kSquarePocketDeviation of the mean.
bool has_pocket(const SquarePlacement& p) { return std::max(p.element_max - 1.0, 1.0 - p.element_min) > kSquarePocketDeviation; }

// The square route: corner placements in turn (kCornerOffsets past the first) until one leaves no
// pocket (kSquarePocketDeviation); of those that cover the sphere once, the one with the lowest
// element CV is kept in `result`. Returns why the route gave no sphere ("" when it did); with
// SphereRoute::Square that is thrown instead.
std::string map_by_square_route(const MatrixXd& V, const MatrixXi& F, const SphereMapOptions& options, SphereMapResult& result,
                                const ProgressFn& progress) {
  const double first_offset = options.square_route.corner_offset;
  std::vector<SquarePlacement> tried;
  int kept = -1;
  for (double step : kCornerOffsets) {
    SphereMapResult attempt;
    const SquarePlacement p = square_attempt(V, F, options, first_offset + step, attempt, progress);
    tried.push_back(p);
    const bool better = p.covers_once && (kept < 0 || p.element_cv < tried[static_cast<std::size_t>(kept)].element_cv);
    if (better || tried.size() == 1) {
      result = std::move(attempt);
      kept = better ? static_cast<int>(tried.size()) - 1 : kept;
    }
    if (p.covers_once && !has_pocket(p)) break;
    if (tried.size() == kCornerOffsets.size()) break;
    std::ostringstream msg;
    if (p.covers_once)
      msg << "an element holds " << (p.element_max - 1.0 > 1.0 - p.element_min ? p.element_max : p.element_min) << " x its share (element CV "
          << p.element_cv << ")";
    else
      msg << p.why;
    msg << ": trying the square's corners at another point of the seam";
    report(progress, "sphere", -1, msg.str());
  }
  result.placements = tried;
  if (kept >= 0) {
    if (tried.size() > 1) {
      std::ostringstream msg;
      msg << "kept corner placement " << kept + 1 << " of " << tried.size() << ": element CV "
          << tried[static_cast<std::size_t>(kept)].element_cv;
      report(progress, "sphere", -1, msg.str());
    }
    return "";
  }
  const SquarePlacement& first = tried.front();
  if (options.route == SphereRoute::Square) {
    if (first.mapped) return "";  // `result` holds it: the caller's acceptance names what is wrong
    throw ProcessingError(first.why);
  }
  return first.why;
}

}  // namespace

SphereMapResult authalic_sphere_map(const TriMesh& mesh, const SphereMapOptions& options, const ProgressFn& progress) {
  const MatrixXd& V = mesh.V;
  const MatrixXi& F = mesh.F;
  const TopologyReport topo = analyze_topology(V, F);
  if (!topo.is_sphere() || !topo.is_oriented() || topo.num_vertices_used != mesh.num_vertices())
    throw InputError("surface is not a closed genus-0 surface (" + topo.summary() + (topo.num_vertices_used != mesh.num_vertices() ? ", " + std::to_string(mesh.num_vertices() - topo.num_vertices_used) + " unused vertices" : std::string()) +
                     "); the sphere map needs one closed, oriented, genus-0 manifold (e.g. a FreeSurfer white or pial surface)");
  if (topo.degenerate_faces > 0)
    throw InputError("surface has " + std::to_string(topo.degenerate_faces) + " degenerate (zero-area) triangles; remove or repair them before mapping to the sphere");
  // Outward orientation: positive enclosed volume.
  double volume6 = 0.0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Vec3 a = V.row(F(f, 0)).transpose(), b = V.row(F(f, 1)).transpose(), c = V.row(F(f, 2)).transpose();
    volume6 += a.dot(b.cross(c));
  }
  if (!(volume6 > 0))
    throw InputError("surface triangles are oriented inward (negative enclosed volume); reverse the triangle vertex order");

  SphereMapResult result;
  if (options.route != SphereRoute::Flow) {
    const std::string why = map_by_square_route(V, F, options, result, progress);
    if (why.empty()) return result;
    report(progress, "sphere", -1, why + "; taking the flow route");
    result = SphereMapResult{};
    result.fallback_reason = why;
  }
  result.route = SphereRoute::Flow;
  report(progress, "conformal", 0.0, "factorising the cotangent matrix");
  const HakerConformalSolver haker(V, F);
  const VectorXd w = barycentric_vertex_areas(V, F);

  std::vector<int> candidates;
  if (options.puncture_face >= 0) {
    if (options.puncture_face >= F.rows()) throw InputError("puncture face " + std::to_string(options.puncture_face) + " is out of range; the surface has " + std::to_string(F.rows()) + " faces");
    candidates.push_back(options.puncture_face);
  } else {
    candidates = puncture_candidates(V, F, std::max(1, options.max_puncture_attempts));
  }
  int best_flips = -1;
  for (int f : candidates) {
    ++result.puncture_attempts;
    MatrixXd Z = haker.planar_map(f);
    // Coarse Moebius normalisation in the plane (translation and scale are Moebius maps): put
    // the weighted median at the origin and half of the area inside the unit circle, so the
    // projection spreads the surface over both hemispheres before the exact centring.
    const double mx = weighted_median(Z.col(0), w), my = weighted_median(Z.col(1), w);
    Z.col(0).array() -= mx;
    Z.col(1).array() -= my;
    const double scale = weighted_median(Z.rowwise().norm(), w);
    if (scale > 0) Z /= scale;
    MatrixXd S = inverse_stereographic(Z);
    // The sign of y fixes the orientation: the sphere's faces must be counter-clockwise seen
    // from outside like the surface's.
    if (2 * sphere_flipped_faces(S, F) > F.rows()) S.col(1) = -S.col(1);
    double residual = 0.0;
    S = mobius_centre(S, w, 100, &residual);
    const int flips = sphere_flipped_faces(S, F);
    if (best_flips < 0 || flips < best_flips) {
      best_flips = flips;
      result.conformal = S;
      result.puncture_face = f;
      result.mobius_residual = residual;
    }
    if (flips == 0) break;
  }
  result.conformal_flips = best_flips;
  if (best_flips > 0) result.repaired_vertices += repair_sphere_flips(result.conformal, F);
  {
    std::ostringstream msg;
    msg << "puncture face " << result.puncture_face << ", " << result.conformal_flips << " flipped faces";
    report(progress, "conformal", 1.0, msg.str());
  }

  MatrixXd S = result.conformal;
  if (options.flow) S = moser_sphere_flow(S, F, face_areas(V, F), options.flow_options, &result.flow, progress);
  finish_sphere(V, F, options, S, result);
  if (options.orient) result.conformal = result.conformal * result.rotation.transpose();
  return result;
}

}  // namespace authalic

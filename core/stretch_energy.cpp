// Stretch-energy fixed-point iterations with positive weights (see core/stretch_energy.h).
#include "core/stretch_energy.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/authalic_flow.h"
#include "core/run_beside.h"
#include "core/sparse_cholesky.h"

namespace authalic {
namespace {

// Per half-edge (face f, corner c: the edge opposite c) cotangent weight ½ cot θ_c of the surface,
// clamped to `min_relative` of the mean |weight| so every weight is positive.
MatrixXd surface_cot_weights(const MatrixXd& V, const MatrixXi& F, double min_relative) {
  const MatrixXd W = 0.5 * corner_angles(V, F).array().tan().inverse().matrix();
  const double floor = min_relative * W.cwiseAbs().mean();
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

namespace {

// The Laplacian of the unknowns (L) and its coupling to the held boundary (B): the interior solve
// is L X = B UV_boundary, so a moved boundary costs a solve, not a factorisation. Their pattern
// is the same every iteration: laid out once, with the slot of every contribution (face f, corner
// c: the edge (i, j) opposite c, a diagonal +w and an off-diagonal −w per end that is an unknown;
// a held neighbour goes to B), so an iteration only refills the values.
struct InteriorSystem {
  MatrixXi F;
  std::vector<int> idx;  // vertex -> unknown, -1 for held or unused vertices
  SparseMatrix L, B;
  std::vector<int> l_slot, b_slot;

  template <class Add>
  void for_each_contribution(Add&& add) const {
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int c = 0; c < 3; ++c) {
        const int i = F(f, (c + 1) % 3), j = F(f, (c + 2) % 3);
        for (const auto& [p, q] : {std::pair<int, int>{i, j}, std::pair<int, int>{j, i}}) {
          if (idx[p] < 0) continue;
          add(f, c, idx[p], idx[p], false, true);
          if (idx[q] >= 0)
            add(f, c, idx[p], idx[q], false, false);
          else
            add(f, c, idx[p], q, true, false);
        }
      }
  }

  InteriorSystem(const MatrixXi& faces, std::vector<int> unknown, int m, Eigen::Index nv)
      : F(faces), idx(std::move(unknown)), L(m, m), B(m, nv) {
    std::vector<Eigen::Triplet<double>> t, tb;
    t.reserve(static_cast<std::size_t>(12 * F.rows()));
    for_each_contribution([&](Eigen::Index, int, int r, int col, bool to_boundary, bool) {
      (to_boundary ? tb : t).emplace_back(r, col, 1.0);
    });
    L.setFromTriplets(t.begin(), t.end());
    B.setFromTriplets(tb.begin(), tb.end());
    auto slot_of = [](const SparseMatrix& M, int r, int col) {
      const int* begin = M.innerIndexPtr() + M.outerIndexPtr()[col];
      const int* end = M.innerIndexPtr() + M.outerIndexPtr()[col + 1];
      return static_cast<int>(std::lower_bound(begin, end, r) - M.innerIndexPtr());
    };
    l_slot.reserve(t.size());
    b_slot.reserve(tb.size());
    for (const auto& x : t) l_slot.push_back(slot_of(L, x.row(), x.col()));
    for (const auto& x : tb) b_slot.push_back(slot_of(B, x.row(), x.col()));
  }

  // New weights W(f, c) * scale[f] into the fixed pattern (contributions in their layout order).
  void refill(const MatrixXd& W, const VectorXd& scale) {
    std::fill(L.valuePtr(), L.valuePtr() + L.nonZeros(), 0.0);
    std::fill(B.valuePtr(), B.valuePtr() + B.nonZeros(), 0.0);
    std::size_t n_l = 0, n_b = 0;
    for_each_contribution([&](Eigen::Index f, int c, int, int, bool to_boundary, bool diagonal) {
      const double w = W(f, c) * scale[f];
      if (to_boundary)
        B.valuePtr()[b_slot[n_b++]] += w;
      else
        L.valuePtr()[l_slot[n_l++]] += diagonal ? w : -w;
    });
  }
};

}  // namespace

struct StretchEnergySystem::Parts {
  MatrixXd W;            // #F x 3 clamped cotangent weights of the surface
  VectorXi side_mask;    // #V
  VectorXi on_boundary;  // #V: 1 for the held (slid) boundary vertices
  InteriorSystem sys;    // its L has one row per unknown
};

namespace {

// Unknowns: the vertices used by F that are not on the boundary (side_mask 0).
std::vector<int> interior_unknowns(const MatrixXi& F, const VectorXi& side_mask, Eigen::Index nv, VectorXi* on_boundary,
                                   int* count) {
  std::vector<char> used(static_cast<std::size_t>(nv), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;
  std::vector<int> idx(static_cast<std::size_t>(nv), -1);
  *on_boundary = VectorXi::Zero(nv);
  int m = 0;
  for (Eigen::Index v = 0; v < nv; ++v) {
    if (!used[v]) continue;
    if (side_mask.size() && side_mask[v])
      (*on_boundary)[v] = 1;
    else
      idx[v] = m++;
  }
  *count = m;
  return idx;
}

}  // namespace

StretchEnergySystem::StretchEnergySystem(const MatrixXd& V, const MatrixXi& F, const VectorXi& side_mask, double min_weight) {
  VectorXi on_boundary;
  int m = 0;
  std::vector<int> idx = interior_unknowns(F, side_mask, V.rows(), &on_boundary, &m);
  parts_.reset(new Parts{surface_cot_weights(V, F, min_weight), side_mask, std::move(on_boundary),
                         InteriorSystem(F, std::move(idx), m, V.rows())});
}
StretchEnergySystem::~StretchEnergySystem() = default;
StretchEnergySystem::StretchEnergySystem(StretchEnergySystem&&) noexcept = default;
StretchEnergySystem& StretchEnergySystem::operator=(StretchEnergySystem&&) noexcept = default;

MatrixXd stretch_energy_map(const MatrixXd& V, const MatrixXi& F, const VectorXd& face_target, const MatrixXd& UV0,
                            const VectorXi& side_mask, double width, const StretchEnergyOptions& opt,
                            StretchEnergyReport* report, SpdSolver* reuse) {
  StretchEnergySystem system(V, F, side_mask, opt.min_weight);
  return stretch_energy_map(system, face_target, UV0, width, opt, report, reuse);
}

MatrixXd stretch_energy_map(StretchEnergySystem& system, const VectorXd& face_target, const MatrixXd& UV0, double width,
                            const StretchEnergyOptions& opt, StretchEnergyReport* report, SpdSolver* reuse) {
  StretchEnergySystem::Parts& parts = system.parts();
  InteriorSystem& sys = parts.sys;
  const MatrixXi& F = sys.F;
  const MatrixXd& W = parts.W;
  const VectorXi& side_mask = parts.side_mask;
  const VectorXi& on_boundary = parts.on_boundary;
  const std::vector<int>& idx = sys.idx;
  const int m = static_cast<int>(sys.L.rows());
  const Eigen::Index nv = static_cast<Eigen::Index>(idx.size()), nf = F.rows();
  if (face_target.size() != nf || UV0.rows() != nv || UV0.cols() < 2)
    throw std::invalid_argument("stretch_energy_map: " + std::to_string(face_target.size()) + " face targets and " +
                                std::to_string(UV0.rows()) + " map rows for a system of " + std::to_string(nf) +
                                " faces and " + std::to_string(nv) + " vertices");

  MatrixXd UV = UV0.leftCols(2);
  VectorXd area = signed_face_areas_2d(UV, F);
  const double min_area = flip_area_threshold(area.sum(), nf);
  const double st = face_target.sum();
  double err = mean_log_stretch(area, face_target);
  if (report) report->initial_log_stretch = report->final_log_stretch = err;
  SparseMatrix& L = sys.L;
  SparseMatrix& B = sys.B;
  VectorXd scale = VectorXd::Ones(nf);  // w_k / w_0 = Π σ_j per face
  SpdSolver local;  // the pattern is the same every iteration: one analysis (or the caller's)
  SpdSolver& solver = reuse ? *reuse : local;
  bool refactor_next = false;  // the last inexact solve was slow: the preconditioner has drifted
  for (int k = 0; k < opt.max_iterations && m > 0; ++k) {
    const double sa = area.sum();
    VectorXd trial(nf);
    for (Eigen::Index f = 0; f < nf; ++f)
      trial[f] = scale[f] * std::pow(std::max(1e-300, (area[f] / sa) / (face_target[f] / st)), opt.exponent);
    sys.refill(W, trial);
    // The first step factorises; on the largest meshes later ones solve by CG preconditioned with
    // the last factorisation (the weights change by the faces' stretch, near 1 after the first
    // step), cutting the residual of the current map by opt.inexact_tolerance: a fixed-point
    // iteration needs no exact solves. The preconditioner drifts as the weights accumulate: after
    // a solve that needed more than opt.inexact_refactor_after steps the next step factorises
    // again. A step that folds or does not lower the error is redone exactly (Floater's guarantee
    // holds for the exact solve) before the boundary move is halved.
    bool exact = k == 0 || opt.inexact_tolerance <= 0 || m <= opt.inexact_min_unknowns || refactor_next;
    refactor_next = false;
    // Boundary: slid along its sides by one Moser pass of the current map (Neumann velocity, so
    // corners stay), and only as far as the interior re-solve stays an embedding (halving). The
    // slide needs the map, not the new weights: it runs beside the factorisation.
    MatrixXd slid = UV;
    auto slide_boundary = [&] {
      if (!opt.moser_boundary) return;
      GridFlowOptions slide;
      slide.resolution = opt.boundary_grid;
      slide.smoothing_cells = 1.0;
      slide.rk4_steps = 20;
      slid = moser_grid_pass(face_target, UV, F, side_mask, width, slide, 1.0, on_boundary);
    };
    bool factorised = true;
    if (exact)
      run_beside([&] { factorised = solver.refactor(L); }, slide_boundary);
    else
      slide_boundary();
    if (!factorised) break;
    bool failed = false;
    auto factorise_now = [&] {
      exact = true;
      failed = !solver.refactor(L);
    };
    auto interior_solve = [&](const MatrixXd& rhs) {
      if (!exact) {
        MatrixXd X(m, 2);  // start from the current map
        for (Eigen::Index v = 0; v < nv; ++v)
          if (idx[v] >= 0) X.row(idx[v]) = UV.row(v);
        int iterations = 0;
        const bool converged = solver.solve_preconditioned(L, rhs, X, opt.inexact_tolerance, opt.inexact_max_iterations, &iterations);
        refactor_next = iterations > opt.inexact_refactor_after;
        if (converged) return X;
        factorise_now();
        if (failed) return X;
      }
      return solver.solve(rhs);
    };

    bool accepted = false;
    double e = err;
    MatrixXd next;
    VectorXd next_area;
    for (double lambda = 1.0; lambda >= 0.1 && !accepted; lambda *= 0.5) {
      next = UV;
      if (opt.moser_boundary)
        for (Eigen::Index v = 0; v < nv; ++v)
          if (on_boundary[v]) next.row(v) = UV.row(v) + lambda * (slid.row(v) - UV.row(v));
      const MatrixXd rhs = B * next;
      for (;;) {
        const MatrixXd X = interior_solve(rhs);
        if (failed) break;
        for (Eigen::Index v = 0; v < nv; ++v)
          if (idx[v] >= 0) next.row(v) = X.row(idx[v]);
        // Positive weights and a convex boundary guarantee an embedding (Floater 2003) while the
        // boundary keeps its order; keep the last valid iterate if round-off or a slide past a
        // neighbour folds a triangle.
        next_area = signed_face_areas_2d(next, F);
        e = mean_log_stretch(next_area, face_target);
        accepted = !(next_area.array() <= min_area).any() && e < err;
        if (accepted || exact) break;
        factorise_now();  // the inexact solve folded or did not help: solve exactly
        if (failed) break;
      }
      if (failed) break;
      if (!opt.moser_boundary) break;
    }
    if (!accepted) break;
    UV = std::move(next);
    area = next_area;
    scale = trial;
    const bool slow = e > opt.stop_improvement * err;
    err = e;
    if (report) report->iterations = k + 1, report->final_log_stretch = e;
    if (slow) break;
  }
  return UV;
}

}  // namespace authalic

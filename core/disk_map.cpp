// The authalic map onto the unit disk (see core/disk_map.h).
#include "core/disk_map.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "core/authalic_flow.h"
#include "core/concentric_map.h"
#include "core/conformal_map.h"
#include "core/error.h"
#include "core/grid_overlap.h"
#include "core/metrics.h"
#include "core/sparse_cholesky.h"

namespace authalic {

namespace {

// A folded face counts as this |ln area ratio| in the error, so no step may fold one.
constexpr double kFoldedFaceError = 50.0;

double face_error(const VectorXd& target, const MatrixXd& D, const MatrixXi& F) {
  const VectorXd a = signed_face_areas_2d(D, F);
  double sum = 0;
  int n = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    if (!(target[f] > 0)) continue;
    sum += a[f] > 0 ? std::abs(std::log(a[f] / target[f])) : kFoldedFaceError;
    ++n;
  }
  return n ? sum / n : 0.0;
}

double vertex_error(const VectorXd& target, const MatrixXd& D, const MatrixXi& F) {
  return abs_stats(vertex_log_ratio(target, D, F, static_cast<int>(D.rows()))).mean;
}

// Unfolds the triangles at or below min_area by moving interior vertices to their neighbours'
// mean (untangle_flips), the circle's vertices held. Returns the vertices moved.
// Up to 100 rounds (the region grows by a ring every 10), not untangle_flips' 40: fs741's native
// pial surface folds 302 triangles in the carry, next to the circle, and 40 rounds left 120 of
// them (the map then failed, 83 flips); 60 unfold all. The rounds stop when none is left, so maps
// that unfold sooner are unchanged.
int untangle_disk(MatrixXd& D, const MatrixXi& F, const VectorXi& on_circle, double min_area, int* remaining) {
  constexpr int kMaxRounds = 100;
  return untangle_flips(F, VectorXd::Constant(F.rows(), min_area), D, [&](Eigen::Index v) { return on_circle[v] != 0; }, {},
                        remaining, kMaxRounds);
}


// Splits every boundary edge whose chord spans more than max_angle of the circle into equal
// angular pieces: the inserted vertices lie on the circle (and on the 3D edge, at the same
// fractions, so the fan of pieces has exactly the face's 3D area), recorded as inserted vertices
// of r.initial (parents: the edge's ends). A chord cuts the circle's segment, (Δθ − sin Δθ) / 2 of
// area, out of the cells along it: fs741's cortex boundary has chords of 0.16 rad after the carry,
// a segment of 11 % of a 32 x 32 cell (measured: the cells along it at 0.89-0.94 of their share).
int split_long_chords(SquareMapResult& r, MatrixXd& D, VectorXi& on_circle, double max_angle) {
  const Eigen::Index nf = r.F.rows();
  const VectorXi twin = halfedge_twins(r.F, static_cast<int>(r.V.rows()));
  struct Split {
    Eigen::Index face;
    int corner;  // the boundary edge runs from corner to corner + 1
    int pieces;
  };
  std::vector<Split> splits;
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) {
      if (twin[3 * f + c] >= 0) continue;
      const int i = r.F(f, c), j = r.F(f, (c + 1) % 3);
      const double dtheta = std::abs(std::remainder(std::atan2(D(j, 1), D(j, 0)) - std::atan2(D(i, 1), D(i, 0)), 2 * M_PI));
      const int pieces = static_cast<int>(std::ceil(dtheta / max_angle));
      if (pieces > 1) splits.push_back({f, c, pieces});
    }
  int inserted = 0;
  for (const Split& s : splits) inserted += s.pieces - 1;
  if (inserted == 0) return 0;
  const Eigen::Index nv0 = r.V.rows(), np0 = r.initial.inserted_parents.rows();
  r.V.conservativeResize(nv0 + inserted, 3);
  D.conservativeResize(nv0 + inserted, 2);
  r.UV_initial.conservativeResize(nv0 + inserted, 2);
  r.side_mask.conservativeResize(nv0 + inserted);
  on_circle.conservativeResize(nv0 + inserted);
  r.initial.inserted_parents.conservativeResize(np0 + inserted, 2);
  r.initial.inserted_weight.conservativeResize(np0 + inserted);
  // Each split edge's face becomes a fan of `pieces` faces: one new face per inserted vertex.
  r.F.conservativeResize(nf + inserted, 3);
  r.face_origin.conservativeResize(nf + inserted);
  Eigen::Index v = nv0, g = nf, p = np0;
  for (const Split& s : splits) {
    const int i = r.F(s.face, s.corner), j = r.F(s.face, (s.corner + 1) % 3), k = r.F(s.face, (s.corner + 2) % 3);
    const double ti = std::atan2(D(i, 1), D(i, 0));
    const double dt = std::remainder(std::atan2(D(j, 1), D(j, 0)) - ti, 2 * M_PI);
    const double ti0 = std::atan2(r.UV_initial(i, 1), r.UV_initial(i, 0));
    const double dt0 = std::remainder(std::atan2(r.UV_initial(j, 1), r.UV_initial(j, 0)) - ti0, 2 * M_PI);
    int prev = i;
    for (int m = 1; m <= s.pieces; ++m) {
      int cur = j;
      if (m < s.pieces) {
        const double w = double(m) / s.pieces;
        cur = static_cast<int>(v++);
        r.V.row(cur) = (1 - w) * r.V.row(i) + w * r.V.row(j);
        D.row(cur) << std::cos(ti + w * dt), std::sin(ti + w * dt);
        r.UV_initial.row(cur) << std::cos(ti0 + w * dt0), std::sin(ti0 + w * dt0);
        r.side_mask[cur] = r.side_mask[i] ? r.side_mask[i] : kSideBottom;
        on_circle[cur] = 1;
        r.initial.inserted_parents.row(p) << i, j;
        r.initial.inserted_weight[p++] = w;
      }
      // The fan about k: the first piece replaces the face, the others are appended.
      const Eigen::Index row = m == 1 ? s.face : g++;
      r.F.row(row) << prev, cur, k;
      r.face_origin[row] = r.face_origin[s.face];
      prev = cur;
    }
  }
  return inserted;
}


// The acceptance's element grid (core/metrics.h: 32 x 32).
constexpr int kAcceptanceK = 32;

// Element CV of a disk map at K x K: cortical measure per carried cell.
double disk_element_cv(const MatrixXd& D, const MatrixXi& F, const VectorXd& measure, int k) {
  const auto pieces = disk_grid_overlap(D, F, k, k);
  const VectorXd cells = cell_surface_areas(pieces, measure, piece_face_areas(pieces, static_cast<int>(F.rows())), k * k);
  const double mean = cells.mean();
  return mean > 0 ? std::sqrt((cells.array() - mean).square().mean()) / mean : 0.0;
}

// One Moser pass (moser_grid_pass) on the cells, made in the square [0, 1]^2 that the concentric
// map carries onto the disk: there the cells are a regular grid, and as the map's Jacobian is the
// constant π, a density is the same on both sides. Each face brings its square area times its
// density error on the disk (target / disk area), so the pass evens out the disk's density; the
// circle's vertices slide along the square's sides (the circle), the 4 corners stay.
MatrixXd disk_moser_pass(const MatrixXd& D, const MatrixXi& F, const VectorXd& target, const VectorXi& on_circle) {
  const Eigen::Index nv = D.rows();
  const MatrixXd S = (concentric_disk_to_square(D).array() + 1.0) / 2.0;
  VectorXi side = VectorXi::Zero(nv);
  constexpr double kOnSide = 1e-9;
  for (Eigen::Index v = 0; v < nv; ++v) {
    if (!on_circle[v]) continue;
    if (S(v, 0) <= kOnSide) side[v] |= kSideLeft;
    if (S(v, 0) >= 1 - kOnSide) side[v] |= kSideRight;
    if (S(v, 1) <= kOnSide) side[v] |= kSideBottom;
    if (S(v, 1) >= 1 - kOnSide) side[v] |= kSideTop;
  }
  const VectorXd s = signed_face_areas_2d(S, F), a = signed_face_areas_2d(D, F);
  VectorXd mass(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) mass[f] = a[f] > 0 && s[f] > 0 ? s[f] * std::clamp(target[f] / a[f], 0.8, 1.25) : target[f] / M_PI;
  // (Clamped: a single crushed face, at 90 times its area on B1, is the polish's, not the cells'.)
  mass /= mass.sum();
  GridFlowOptions grid;
  // About 8 faces per cell (B1: 48 cells per side): finer grids see the faces, not the cells.
  grid.resolution = std::clamp(static_cast<int>(std::sqrt(F.rows() / 8.0)), 32, 256);
  const MatrixXd moved = moser_grid_pass(mass, S, F, side, 1.0, grid);
  MatrixXd out = concentric_square_to_disk(MatrixXd(2.0 * moved.array() - 1.0));
  for (Eigen::Index v = 0; v < nv; ++v)
    if (on_circle[v]) out.row(v).normalize();
  return out;
}

}  // namespace

int polish_disk_face_areas(MatrixXd& D, const MatrixXi& F, const VectorXd& target, const VectorXi& on_circle,
                           const DiskMapOptions& opt, const ProgressFn& progress) {
  const Eigen::Index nv = D.rows();
  const std::vector<std::vector<int>> adj = vertex_neighbours(F, nv);
  const double min_area = flip_area_threshold(M_PI, F.rows());
  // The circle's vertices are held, as corners are in face_area_newton_displacement.
  VectorXi held = VectorXi::Zero(nv);
  for (Eigen::Index v = 0; v < nv; ++v)
    if (on_circle[v]) held[v] = kSideLeft | kSideBottom;
  double cur = face_error(target, D, F), cur_vertex = vertex_error(target, D, F);
  int kept = 0, slow_in_a_row = 0;
  for (int k = 0; k < opt.polish_iterations; ++k) {
    // The faces outside the band and `rings` rings around them move.
    std::vector<char> free_vertex(static_cast<std::size_t>(nv), 0);
    const int bad = faces_outside_band(target, D, F, opt.band, free_vertex);
    if (bad == 0) break;
    grow_by_rings(free_vertex, adj, opt.rings);
    const MatrixXd step = face_area_newton_displacement(D, F, target, held, free_vertex, opt.cg_iterations);
    // No step thins a triangle above twice its float32 floor below it (the map is stored as float32).
    const VectorXd a = signed_face_areas_2d(D, F), floor = 2.0 * single_precision_area_floor(D, F);
    VectorXd limit = VectorXd::Constant(F.rows(), min_area);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (a[f] > floor[f]) limit[f] = std::max(min_area, floor[f]);
    bool better = false;
    const double before = cur;
    for (double scale = 1.0; scale > 0.1 && !better; scale *= 0.5) {
      MatrixXd next = local_step_positions(D, F, scale * step, opt.theta, limit);  // the circle is held: no constraint
      const double e = face_error(target, next, F);
      if (!(e < cur)) continue;
      const double ev = vertex_error(target, next, F);
      if (ev > 1.01 * cur_vertex && ev > 1e-3) continue;
      D = std::move(next);
      cur = e, cur_vertex = ev, better = true;
    }
    if (!better) break;
    ++kept;
    std::ostringstream msg;
    msg << "disk polish " << k + 1 << " (" << bad << " faces outside the band): per-face mean |ln ratio| " << cur
        << ", per-vertex mean " << cur_vertex;
    report(progress, "disk", -1, msg.str());
    slow_in_a_row = cur > 0.99 * before ? slow_in_a_row + 1 : 0;
    if (slow_in_a_row >= opt.slow_steps && cur_vertex <= opt.vertex_tolerance) break;
  }
  return kept;
}

void carry_square_map_to_disk(SquareMapResult& r, const VectorXd& density, const DiskMapOptions& opt, DiskMapReport* rep,
                              const ProgressFn& progress) {
  if (std::abs(r.width - 1.0) > 1e-12) throw ProcessingError("disk map: the square map must be of width 1");
  DiskMapReport local;
  DiskMapReport& R = rep ? *rep : local;
  const Eigen::Index nv = r.UV.rows();
  std::vector<char> used(static_cast<std::size_t>(nv), 0);
  for (Eigen::Index f = 0; f < r.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[r.F(f, c)] = 1;
  VectorXi on_circle = VectorXi::Zero(nv);
  for (Eigen::Index v = 0; v < nv; ++v) on_circle[v] = used[v] && r.side_mask.size() && r.side_mask[v] != 0;
  // [0, 1]^2 -> [−1, 1]^2 -> the disk; boundary vertices exactly on the circle, unused ones at the centre.
  auto carry = [&](const MatrixXd& UV) {
    MatrixXd D = concentric_square_to_disk(MatrixXd(2.0 * UV.leftCols(2).array() - 1.0));
    for (Eigen::Index v = 0; v < nv; ++v) {
      if (!used[v]) D.row(v).setZero();
      if (on_circle[v]) D.row(v).normalize();
    }
    return D;
  };
  report(progress, "disk", -1, "carrying the square map onto the disk (Shirley & Chiu's concentric map)");
  MatrixXd D = carry(r.UV);
  r.UV_initial = carry(r.UV_initial);
  R.inserted_vertices = split_long_chords(r, D, on_circle, opt.max_chord_angle);
  VectorXd face_target = target_face_measure(
      r.V, r.F, density.size() > 0 ? VectorXd(extend_to_inserted(MatrixXd(density), r.initial).col(0)) : VectorXd(), M_PI);
  const double min_area = flip_area_threshold(M_PI, r.F.rows());
  R.carried_flips = count_flipped(D, r.F, min_area);
  if (R.carried_flips > 0) {
    int remaining = 0;
    R.untangled_vertices = untangle_disk(D, r.F, on_circle, min_area, &remaining);
  }
  // The polygon's area, not π: boundary chords cut off the circle's segments, and the boundary is
  // held, so targets summing to π would press every face outward.
  face_target *= signed_face_areas_2d(D, r.F).sum() / face_target.sum();
  R.carried_face_error = face_error(face_target, D, r.F);
  // Far faces first, alone: polishing everything at once spread their correction over elements
  // (fs741: element CV 0.0035 this way, 0.0064 in one go).
  DiskMapOptions far = opt;
  far.band = opt.far_band;
  R.polish_iterations = polish_disk_face_areas(D, r.F, face_target, on_circle, far, progress);
  R.polish_iterations += polish_disk_face_areas(D, r.F, face_target, on_circle, opt, progress);
  // Last, the cells: a Moser pass on them (disk_moser_pass), kept only when it evens the
  // acceptance's 32 x 32 elements (B1: CV 0.0050 -> 0.0039; fs741 is already finer than the pass
  // sees, 0.0035 -> 0.0046, so it keeps its map).
  {
    const VectorXd measure = face_areas(r.V, r.F);
    R.cell_cv_before_pass = disk_element_cv(D, r.F, measure, kAcceptanceK);
    MatrixXd moved = local_step_positions(D, r.F, disk_moser_pass(D, r.F, face_target, on_circle) - D, 0.0,
                                          VectorXd::Constant(r.F.rows(), min_area),
                                          [&](Eigen::Index v, double& x, double& y) {  // back onto the circle
                                            if (!on_circle[v]) return;
                                            const double n = std::hypot(x, y);
                                            x /= n, y /= n;
                                          });
    if (count_flipped(moved, r.F, min_area) == 0) {
      const double after = disk_element_cv(moved, r.F, measure, kAcceptanceK);
      if (after < R.cell_cv_before_pass) D = std::move(moved), R.cell_pass_kept = true;
    }
    report(progress, "disk", -1, std::string("Moser pass on the cells ") + (R.cell_pass_kept ? "kept" : "not kept"));
  }
  R.face_error = face_error(face_target, D, r.F);
  R.flips = count_flipped(D, r.F, min_area);
  r.UV = std::move(D);
  r.flips = R.flips;
}

SquareMapResult disk_map(const MatrixXd& V, const MatrixXi& F, const SquareMapOptions& square, const DiskMapOptions& options,
                         DiskMapReport* report, const ProgressFn& progress) {
  if (std::abs(square.width - 1.0) > 1e-12) throw InputError("disk map: the square map's width must be 1");
  SquareMapResult r = square_map(V, F, square, progress);
  carry_square_map_to_disk(r, square.density, options, report, progress);
  if (r.flips > 0) throw ProcessingError("the disk map has " + std::to_string(r.flips) + " flipped triangles");
  return r;
}

}  // namespace authalic

// Atlas map carried to a subject through its sphere registration (see core/atlas_map.h).
#include "core/atlas_map.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/authalic_flow.h"
#include "core/error.h"
#include "core/square_map.h"
#include "core/sulcal_depth.h"

namespace authalic {

namespace {

Eigen::Vector3d row3(const MatrixXd& M, int i) { return M.row(i).head<3>().transpose(); }

// Barycentric coordinates of the central projection of q onto the plane of (a, b, c): q = t (λa a +
// λb b + λc c) with Σλ = 1, from μ = [a b c]⁻¹ q (Cramer's rule), λ = μ / Σμ. Σμ <= 0: q points
// away from the face.
bool central_barycentric(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                         const Eigen::Vector3d& q, Eigen::Vector3d* lambda) {
  const double det = a.dot(b.cross(c));
  if (det == 0) return false;
  Eigen::Vector3d mu(q.dot(b.cross(c)), q.dot(c.cross(a)), q.dot(a.cross(b)));
  mu /= det;
  const double sum = mu.sum();
  if (!(sum > 0)) return false;
  *lambda = mu / sum;
  return true;
}

}  // namespace

SpherePointLocator::SpherePointLocator(const MatrixXd& S, const MatrixXi& F) : S_(S), F_(F) {
  // Cell side about twice the mean edge, so a cell holds a few dozen faces.
  double edge = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) edge += (row3(S, F(f, 0)) - row3(S, F(f, 1))).norm();
  edge = F.rows() > 0 ? edge / static_cast<double>(F.rows()) : 1.0;
  n_ = std::clamp(static_cast<int>(std::ceil(2.2 / std::max(2 * edge, 1e-6))), 1, 200);
  lo_ = -1.1;
  h_ = 2.2 / n_;
  std::vector<std::pair<int, int>> pairs;  // (cell, face)
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    Eigen::Vector3d mn = row3(S, F(f, 0)), mx = mn;
    double longest = 0;
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d p = row3(S, F(f, c));
      mn = mn.cwiseMin(p);
      mx = mx.cwiseMax(p);
      longest = std::max(longest, (p - row3(S, F(f, (c + 1) % 3))).norm());
    }
    // The unit sphere bulges beyond the flat face by at most about longest² / 2.
    const double margin = 0.5 * longest * longest + 1e-9;
    mn.array() -= margin;
    mx.array() += margin;
    int lo[3], hi[3];
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::clamp(static_cast<int>(std::floor((mn[d] - lo_) / h_)), 0, n_ - 1);
      hi[d] = std::clamp(static_cast<int>(std::floor((mx[d] - lo_) / h_)), 0, n_ - 1);
    }
    for (int i = lo[0]; i <= hi[0]; ++i)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int k = lo[2]; k <= hi[2]; ++k) pairs.push_back({(i * n_ + j) * n_ + k, static_cast<int>(f)});
  }
  std::sort(pairs.begin(), pairs.end());
  cell_start_.assign(static_cast<std::size_t>(n_) * n_ * n_ + 1, 0);
  for (const auto& p : pairs) ++cell_start_[static_cast<std::size_t>(p.first) + 1];
  for (std::size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
  cell_faces_.reserve(pairs.size());
  for (const auto& p : pairs) cell_faces_.push_back(p.second);

  const VectorXi twin = halfedge_twins(F, static_cast<int>(S.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (twin[3 * f + c] < 0) boundary_.push_back({static_cast<int>(f), c, (c + 1) % 3});
}

int SpherePointLocator::cell_index(const Eigen::Vector3d& p) const {
  int idx[3];
  for (int d = 0; d < 3; ++d) idx[d] = std::clamp(static_cast<int>(std::floor((p[d] - lo_) / h_)), 0, n_ - 1);
  return (idx[0] * n_ + idx[1]) * n_ + idx[2];
}

int SpherePointLocator::locate(const Eigen::Vector3d& q_in, Eigen::Vector3d* bary) const {
  const Eigen::Vector3d q = q_in.normalized();
  const int cell = cell_index(q);
  // Of the faces whose projection holds q (two or more on a shared edge), the one holding it most
  // deeply (largest smallest coordinate); ties to the lowest face index, so the result does not
  // depend on the order faces were bucketed.
  int best = -1;
  double best_min = -1e-12;
  Eigen::Vector3d lambda;
  for (int i = cell_start_[static_cast<std::size_t>(cell)]; i < cell_start_[static_cast<std::size_t>(cell) + 1]; ++i) {
    const int f = cell_faces_[static_cast<std::size_t>(i)];
    if (!central_barycentric(row3(S_, F_(f, 0)), row3(S_, F_(f, 1)), row3(S_, F_(f, 2)), q, &lambda)) continue;
    const double m = lambda.minCoeff();
    if (m > best_min || (m == best_min && best >= 0 && f < best)) {
      best_min = m;
      best = f;
      *bary = lambda;
    }
  }
  if (best >= 0) {
    *bary = bary->cwiseMax(0.0);
    *bary /= bary->sum();
  }
  return best;
}

int SpherePointLocator::nearest(const Eigen::Vector3d& q_in, Eigen::Vector3d* bary, bool* inside) const {
  const int f = locate(q_in, bary);
  if (inside) *inside = f >= 0;
  if (f >= 0) return f;
  const Eigen::Vector3d q = q_in.normalized();
  int best = -1;
  double best_d = std::numeric_limits<double>::infinity(), best_t = 0;
  int best_a = 0, best_b = 1;
  for (const auto& [face, ca, cb] : boundary_) {
    const Eigen::Vector3d a = row3(S_, F_(face, ca)), e = row3(S_, F_(face, cb)) - a;
    const double l2 = e.squaredNorm();
    const double t = l2 > 0 ? std::clamp((q - a).dot(e) / l2, 0.0, 1.0) : 0.0;
    const double d = (a + t * e - q).squaredNorm();
    if (d < best_d) best_d = d, best = face, best_t = t, best_a = ca, best_b = cb;
  }
  if (best < 0) return -1;
  bary->setZero();
  (*bary)[best_a] = 1 - best_t;
  (*bary)[best_b] = best_t;
  return best;
}

MatrixXd normalize_to_unit_sphere(const MatrixXd& S, const std::string& what) {
  if (S.cols() != 3) throw InputError(what + ": sphere coordinates must be 3D");
  MatrixXd U(S.rows(), 3);
  for (Eigen::Index i = 0; i < S.rows(); ++i) {
    const double r = S.row(i).norm();
    if (!(r > 0) || !std::isfinite(r))
      throw InputError(what + ": vertex " + std::to_string(i) + " is at the sphere's centre or not finite; give a spherical "
                       "surface (FreeSurfer ?h.sphere / ?h.sphere.reg)");
    U.row(i) = S.row(i) / r;
  }
  return U;
}

MatrixXd interpolate_on_sphere(const SpherePointLocator& locator, const MatrixXd& values, const MatrixXd& Q,
                               std::vector<char>* inside) {
  const MatrixXi& F = locator.faces();
  MatrixXd out = MatrixXd::Zero(Q.rows(), values.cols());
  if (inside) inside->assign(static_cast<std::size_t>(Q.rows()), 0);
#pragma omp parallel for schedule(dynamic, 256)
  for (Eigen::Index v = 0; v < Q.rows(); ++v) {
    Eigen::Vector3d b;
    bool in = false;
    const int f = locator.nearest(Q.row(v).transpose(), &b, &in);
    if (f < 0) continue;
    if (inside) (*inside)[static_cast<std::size_t>(v)] = in;
    out.row(v) = b[0] * values.row(F(f, 0)) + b[1] * values.row(F(f, 1)) + b[2] * values.row(F(f, 2));
  }
  return out;
}

AtlasTransfer transfer_atlas_map(const MatrixXd& atlas_S, const MatrixXi& atlas_F, const MatrixXd& atlas_UV,
                                 const MatrixXd& subject_V, const MatrixXd& subject_S, const MatrixXi& subject_F) {
  std::vector<char> used(static_cast<std::size_t>(subject_S.rows()), 0), inside;
  for (Eigen::Index f = 0; f < subject_F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[static_cast<std::size_t>(subject_F(f, c))] = 1;
  AtlasTransfer T;
  T.UV = interpolate_on_sphere(SpherePointLocator(atlas_S, atlas_F), atlas_UV, subject_S, &inside);
  const VectorXd area = barycentric_vertex_areas(subject_V, subject_F);
  double out_area = 0;
  for (Eigen::Index v = 0; v < subject_S.rows(); ++v) {
    if (!used[static_cast<std::size_t>(v)]) {
      T.UV.row(v).setZero();
    } else if (!inside[static_cast<std::size_t>(v)]) {
      ++T.outside;
      out_area += area[v];
    }
  }
  T.outside_area_share = area.sum() > 0 ? out_area / area.sum() : 0;
  return T;
}

std::vector<double> boundary_perimeter_from_map(const MatrixXd& UV, const MatrixXd& V, const MatrixXi& F, double width,
                                                double min_step) {
  if (!(min_step > 0 && min_step < 1)) throw ProcessingError("atlas start: the least boundary step must lie in (0, 1)");
  const int num_vertices = static_cast<int>(V.rows());
  const auto loops = boundary_loops(F, num_vertices);
  if (loops.size() != 1) throw ProcessingError("atlas start: the region has " + std::to_string(loops.size()) + " boundary loops, not one");
  const std::vector<int>& loop = loops.front();
  const double W = width, P = 2 * W + 2;
  auto perimeter_of = [&](int v) {
    const double x = std::clamp(UV(v, 0), 0.0, W), y = std::clamp(UV(v, 1), 0.0, 1.0);
    const double d[4] = {y, W - x, 1 - y, x};  // bottom, right, top, left
    const int side = static_cast<int>(std::min_element(d, d + 4) - d);
    switch (side) {
      case 0: return x;
      case 1: return W + y;
      case 2: return W + 1 + (W - x);
      default: return 2 * W + 1 + (1 - y);
    }
  };
  const std::size_t nb = loop.size();
  std::vector<double> s(nb), step(nb);
  for (std::size_t i = 0; i < nb; ++i) s[i] = perimeter_of(loop[i]);
  double winding = 0;
  for (std::size_t i = 0; i < nb; ++i) {
    double d = std::fmod(s[(i + 1) % nb] - s[i], P);
    if (d >= P / 2) d -= P;
    if (d < -P / 2) d += P;
    step[i] = d;
    winding += d;
  }
  if (std::abs(winding - P) > 1e-6 * P)
    throw ProcessingError("atlas start: the subject's cortex boundary winds " + std::to_string(winding / P) +
                          " times around the atlas square, not once counter-clockwise; check that the atlas and the "
                          "sphere.reg belong to this hemisphere");
  // Monotone with a minimum step: the unwrapped coordinates' increasing least-squares fit under
  // u[k+1] - u[k] >= gap[k] (pool adjacent violators on u[k] - G[k], G the cumulative gaps, then G
  // added back). A backward excursion (a stretch of the subject's boundary inside the atlas cortex
  // that projects onto the sides out of order) is averaged where it occurs instead of shifting the
  // rest of the loop, and each boundary edge keeps at least min_step of its arc-length share:
  // bunched boundary vertices leave a gap elsewhere whose few triangles hold several elements' worth
  // of area while the bunched ones are crushed, and the flow stops short on them. Measured on the
  // variable phantom's first 12 hemispheres (K = 32), element CV after the flow: min_step 0.02 up
  // to 0.0103 (control02 lh), 0.25 up to 0.0056, 0.5 at most 0.0022 (same-element share 2 points
  // lower).
  std::vector<double> G(nb, 0.0), edge(nb);
  double length = 0;
  for (std::size_t i = 0; i < nb; ++i) {
    edge[i] = (V.row(loop[(i + 1) % nb]) - V.row(loop[i])).norm();
    length += edge[i];
  }
  if (!(length > 0)) throw ProcessingError("atlas start: the region's boundary has no length");
  for (std::size_t i = 1; i < nb; ++i) G[i] = G[i - 1] + min_step * P * edge[i - 1] / length;
  std::vector<double> u(nb);
  u[0] = s[0];
  for (std::size_t i = 1; i < nb; ++i) u[i] = u[i - 1] + step[i - 1];
  for (std::size_t i = 0; i < nb; ++i) u[i] -= G[i];
  std::vector<double> level;
  std::vector<std::size_t> count;
  for (std::size_t i = 0; i < nb; ++i) {
    level.push_back(u[i]);
    count.push_back(1);
    while (level.size() > 1 && level[level.size() - 2] >= level.back()) {
      const std::size_t k = level.size() - 1;
      level[k - 1] = (level[k - 1] * count[k - 1] + level[k] * count[k]) / static_cast<double>(count[k - 1] + count[k]);
      count[k - 1] += count[k];
      level.pop_back();
      count.pop_back();
    }
  }
  std::size_t i = 0;
  for (std::size_t b = 0; b < level.size(); ++b)
    for (std::size_t c = 0; c < count[b]; ++c) u[i++] = level[b];
  for (std::size_t k = 0; k < nb; ++k) u[k] += G[k];
  const double eps = min_step * P * edge[nb - 1] / length;  // the closing edge's
  // The loop closes at u[0] + P: squeeze the whole loop if the margins pushed its end beyond.
  const double span = u[nb - 1] - u[0], room = P - eps;
  std::vector<double> out(static_cast<std::size_t>(num_vertices), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < nb; ++k) {
    const double x = span > room ? u[0] + (u[k] - u[0]) * room / span : u[k];
    out[static_cast<std::size_t>(loop[k])] = std::fmod(std::fmod(x, P) + P, P);
  }
  return out;
}

namespace {

// A transferred start squeezes the triangles between a subject vertex and a cortex boundary that
// lies further out than the atlas's: measured on the variable phantom (control03 lh), 19 faces
// below 5 % of their target area, down to e^-14 of it. The grid flow's passes are then rejected
// (each would fold one of them) and the flow stops short: element CV 0.019 instead of 0.0016.
// Their interior vertices are re-placed by neighbour means (untangle_flips) until the faces hold
// 5 % of their target area; those that cannot (an ear of the boundary) are left to the flow.
constexpr double kCrushedStartShare = 0.05;
constexpr int kTransferredStartPasses = 6;
int lift_crushed_faces(const ConformalMapResult& init, MatrixXd& UV) {
  const VectorXd area3d = face_areas(init.V, init.F);
  const VectorXd floor = area3d * (kCrushedStartShare * init.width / area3d.sum());
  const VectorXd a = signed_face_areas_2d(UV, init.F);
  if (((a - floor).array() > 0).all()) return 0;
  int left = 0;
  MatrixXd lifted = UV;
  // The boundary stays where its perimeter coordinates put it (sliding side vertices towards
  // their interior neighbours bunches them: phantom control20 rh, five within 0.005 of the side).
  const int moved = untangle_flips(init.F, floor, lifted, [&](Eigen::Index v) { return init.side_mask[v] != 0; }, {}, &left);
  if (count_flipped(lifted, init.F) > 0) return 0;  // never trade a thin triangle for a fold
  UV = std::move(lifted);
  return moved;
}

}  // namespace

MatrixXd start_from_map(const ConformalMapResult& init, const MatrixXd& start_uv, int* repaired) {
  const double W = init.width, eps = 1e-9;
  const MatrixXd interior = extend_to_inserted(start_uv.topRows(init.num_input_vertices), init.inserted_parents,
                                                    init.inserted_weight);
  MatrixXd UV = init.UV;
  for (Eigen::Index v = 0; v < UV.rows(); ++v) {
    if (init.side_mask[v] != 0) continue;
    UV(v, 0) = std::clamp(interior(v, 0), eps * W, W - eps * W);
    UV(v, 1) = std::clamp(interior(v, 1), eps, 1 - eps);
  }
  int left = 0;
  *repaired = 0;
  if (count_flipped(UV, init.F) > 0) {
    *repaired = repair_flips(init.V, init.F, init.side_mask, W, UV, &left);
    if (left > 0) *repaired += untangle_flips(init.F, init.side_mask, W, VectorXd::Zero(init.F.rows()), UV, &left);
  }
  if (left == 0) *repaired += lift_crushed_faces(init, UV);
  if (left > 0)
    throw ProcessingError("atlas start: " + std::to_string(left) +
                          " triangles of the transferred atlas map stay folded after repair; check that the sphere.reg "
                          "belongs to this surface");
  return UV;
}

Displacement displacement_in_elements(const MatrixXd& UV, const MatrixXd& UV0, const MatrixXi& F, int k) {
  std::vector<char> used(static_cast<std::size_t>(UV.rows()), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[static_cast<std::size_t>(F(f, c))] = 1;
  std::vector<double> d;
  for (Eigen::Index v = 0; v < UV.rows(); ++v)
    if (used[static_cast<std::size_t>(v)]) d.push_back((UV.row(v) - UV0.row(v)).norm() * k);
  Displacement out;
  if (d.empty()) return out;
  std::sort(d.begin(), d.end());
  auto at = [&](double q) { return d[std::min(d.size() - 1, static_cast<std::size_t>(q * static_cast<double>(d.size() - 1) + 0.5))]; };
  out.median = at(0.5);
  out.p95 = at(0.95);
  out.max = d.back();
  return out;
}

AtlasSquare atlas_square_map(const MatrixXd& atlas_V, const MatrixXd& atlas_S, const MatrixXi& atlas_F,
                             const SquareMapOptions& options, const ProgressFn& progress) {
  if (atlas_S.rows() != atlas_V.rows())
    throw InputError("atlas sphere: " + std::to_string(atlas_S.rows()) + " vertices but the atlas surface has " +
                     std::to_string(atlas_V.rows()) + "; give the sphere of the same atlas hemisphere");
  AtlasSquare A;
  // The subjects' flows start from this map and run on the default grid (a given start keeps
  // 512 cells): the atlas map is made on the same grid, so a subject identical to the atlas does
  // not move (with the stretch start's 256 cells here: up to 0.58 element on fsaverage5).
  SquareMapOptions o = options;
  o.flow.grid.resolution = o.flow.grid.cells();
  A.map = square_map(atlas_V, atlas_F, o, progress);
  A.S = normalize_to_unit_sphere(extend_to_inserted(normalize_to_unit_sphere(atlas_S, "atlas sphere"), A.map.initial),
                                 "atlas sphere");
  return A;
}

AtlasMapResult square_map_from_atlas(const MatrixXd& V, const MatrixXi& F, const MatrixXd& sphere_reg, const AtlasSquare& atlas,
                                     SquareMapOptions options, int k, const ProgressFn& progress) {
  if (sphere_reg.rows() != V.rows())
    throw InputError("sphere.reg: " + std::to_string(sphere_reg.rows()) + " vertices but the surface has " +
                     std::to_string(V.rows()) + "; give the sphere.reg of this subject and hemisphere");
  if (!(std::abs(options.width - atlas.map.width) < 1e-12))
    throw InputError("atlas map: its rectangle width differs from the subject's; map both on the same rectangle");
  AtlasMapResult R;
  R.transfer = transfer_atlas_map(atlas.S, atlas.map.F, atlas.map.UV, V, normalize_to_unit_sphere(sphere_reg, "sphere.reg"), F);
  report(progress, "initial", -1,
         "atlas map carried through sphere.reg: " + std::to_string(R.transfer.outside) + " vertices outside the atlas cortex");
  options.start_uv = R.transfer.UV;
  // The transferred start is far from authalic where the subject's area differs from the atlas's
  // (per-vertex mean |ln ratio| about 0.09 against 0.01 for the stretch-energy start), and three
  // grid passes often stop at 0.013-0.016. Measured on two 22-subject variable phantoms (88 maps),
  // element CV above 0.005: 5 maps with 3 passes, 2 with 6 (worst 0.0056).
  options.flow.grid.max_passes = std::max(options.flow.grid.max_passes, kTransferredStartPasses);
  R.map = square_map(V, F, options, progress);
  R.displacement = displacement_in_elements(R.map.UV, R.map.UV_initial, R.map.F, k);
  return R;
}

RegisteredMapResult square_map_registered(const MatrixXd& V, const MatrixXi& F, const AtlasSquare& atlas, SquareMapOptions options,
                                          const FlatRegistrationOptions& registration, int k, const ProgressFn& progress) {
  if (!(std::abs(options.width - atlas.map.width) < 1e-12))
    throw InputError("atlas map: its rectangle width differs from the subject's; map both on the same rectangle");
  RegisteredMapResult R;
  // 1. The subject's own map and both cortices' sulcal depth on their map meshes.
  // Made like the atlas's map (atlas_square_map: the flow on the grid a given start keeps), so a
  // subject identical to the atlas gets the atlas map and is not moved.
  SquareMapOptions own_options = options;
  own_options.start_uv.resize(0, 2);
  own_options.flow.grid.resolution = own_options.flow.grid.cells();
  const SquareMapResult own = square_map(V, F, own_options, progress);
  const VectorXd depth = sulcal_depth_proxy(own.V, own.F);
  const VectorXd atlas_depth = sulcal_depth_proxy(atlas.map.V, atlas.map.F);
  // 2. The area-preserving alignment of the subject's depth pattern onto the atlas's.
  const MatrixXd aligned = register_flat_map(own.UV, own.F, depth, atlas.map.UV, atlas.map.F, atlas_depth, options.width,
                                             registration, &R.registration);
  R.registration_displacement = displacement_in_elements(aligned, own.UV, own.F, k);
  report(progress, "initial", -1,
         "registered to the atlas map by sulcal depth: correlation " + std::to_string(R.registration.correlation_before) + " -> " +
             std::to_string(R.registration.correlation_after));
  // 3. Exact equal area again, from the aligned start (the input vertices' rows).
  options.start_uv = aligned.topRows(V.rows());
  options.start_min_boundary_step = 0.02;  // a flip-free map already: keep its boundary
  R.map = square_map(V, F, options, progress);
  R.displacement = displacement_in_elements(R.map.UV, R.map.UV_initial, R.map.F, k);
  return R;
}

}  // namespace authalic

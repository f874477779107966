// Closed surface -> sphere through the square map of most of it (see core/sphere_from_square.h).
#include "core/sphere_from_square.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "core/conformal_map.h"
#include "core/error.h"
#include "core/region.h"
#include "core/sphere_flow.h"
#include "core/sphere_map.h"
#include "core/stretch_energy.h"

namespace authalic {
namespace {

// The cap: the vertices nearest (along edges) to the surface point closest to the area
// centroid, until they carry `fraction` of the area; cleaned to one disk (core/region.h).
RegionCleanup choose_cap(const MatrixXd& V, const MatrixXi& F, double fraction, int* seed_out) {
  const VectorXd fa = face_areas(V, F);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    c += fa[f] * (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))).transpose() / 3.0;
  c /= fa.sum();
  int seed = 0;
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    const double e = (V.row(v).transpose() - c).squaredNorm();
    if (e < best) best = e, seed = static_cast<int>(v);  // ties: the lowest index
  }
  *seed_out = seed;
  const VectorXd d = edge_path_distances(TriMesh{V, F}, std::vector<bool>(static_cast<std::size_t>(V.rows()), true), seed);
  const VectorXd va = barycentric_vertex_areas(V, F);
  std::vector<int> order(static_cast<std::size_t>(V.rows()));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return d[a] < d[b]; });
  std::vector<bool> in(static_cast<std::size_t>(V.rows()), false);
  double acc = 0;
  const double goal = fraction * va.sum();
  for (int v : order) {
    if (acc >= goal) break;
    in[v] = true;
    acc += va[v];
  }
  return region_faces_from_vertices(V, F, in);
}

// The seam vertex `offset` of the seam's length (3D edge lengths along B's boundary loop) past its
// most anterior vertex (largest y; ties, as on voxelised surfaces: largest z, then x).
int seam_corner_vertex(const MatrixXd& V, const MatrixXi& FB, double offset) {
  const std::vector<int> loop = boundary_loops(FB, static_cast<int>(V.rows())).front();
  const std::size_t n = loop.size();
  std::vector<double> along(n + 1, 0.0);  // length from loop[0] to loop[k]
  std::size_t anterior = 0;
  for (std::size_t k = 0; k < n; ++k) {
    along[k + 1] = along[k] + (V.row(loop[(k + 1) % n]) - V.row(loop[k])).norm();
    const Eigen::Vector3d p = V.row(loop[k]), q = V.row(loop[anterior]);
    if (std::make_tuple(p.y(), p.z(), p.x()) > std::make_tuple(q.y(), q.z(), q.x())) anterior = k;
  }
  const double length = along[n];
  double target = along[anterior] + (offset - std::floor(offset)) * length;
  if (target >= length) target -= length;
  const std::size_t k = static_cast<std::size_t>(std::upper_bound(along.begin(), along.begin() + static_cast<std::ptrdiff_t>(n), target) - along.begin()) - 1;
  return loop[k];
}

// Inverse Lambert azimuthal equal-area projection, pole (0, 0, pole_sign): a point of the unit
// disk scaled to the cap of `share` of the sphere's area. Exact: the disk of radius 2 sqrt(share)
// has area 4π share, the cap's area (Lambert's projection preserves area).
Eigen::Vector3d lambert_cap_point(double x, double y, double share, double pole_sign) {
  const double rho0 = 2.0 * std::sqrt(share);
  const double rho = rho0 * std::min(1.0, std::hypot(x, y));
  const double s = rho0 * std::sqrt(std::max(0.0, 1.0 - 0.25 * rho * rho));
  return {s * x, s * y, pole_sign * (1.0 - 0.5 * rho * rho)};
}

// Vertices whose star does not wind once around them (tangent-plane angle sum far from 2π) are
// put at the normalised mean of their neighbours (widening by rings while that does not help),
// for a few rounds. A star can be folded over
// with every face still positive when its faces are slivers (fs741 white: one vertex, whose
// faces then overlap and one reads back flipped from float32). Returns the vertices left.
int unwind_sphere_stars(MatrixXd& S, const MatrixXi& F, int max_rounds = 12) {
  const Eigen::Index nv = S.rows();
  const std::vector<std::vector<int>> adj = vertex_neighbours(F, nv);
  int bad = 0;
  for (int round = 0; round <= max_rounds; ++round) {
    VectorXd angle = VectorXd::Zero(nv);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int c = 0; c < 3; ++c) {
        const Eigen::Vector3d a = S.row(F(f, c)).transpose();
        Eigen::Vector3d u = S.row(F(f, (c + 1) % 3)).transpose() - a, w = S.row(F(f, (c + 2) % 3)).transpose() - a;
        u -= u.dot(a) * a;
        w -= w.dot(a) * a;
        angle[F(f, c)] += std::atan2(u.cross(w).dot(a), u.dot(w));
      }
    std::vector<char> mark(static_cast<std::size_t>(nv), 0);
    bad = 0;
    for (Eigen::Index v = 0; v < nv; ++v)
      if (!adj[v].empty() && std::abs(angle[v] - 2 * M_PI) > 1.0) mark[v] = 1, ++bad;
    if (bad == 0 || round == max_rounds) break;
    grow_by_rings(mark, adj, round / 3);  // a star of slivers needs its neighbours to move too
    for (int sweep = 0; sweep < 5; ++sweep)
      for (Eigen::Index v = 0; v < nv; ++v) {
        if (!mark[v]) continue;
        Eigen::RowVector3d m = Eigen::RowVector3d::Zero();
        for (int u : adj[v]) m += S.row(u);
        if (m.norm() > 0) S.row(v) = m.normalized();
      }
  }
  return bad;
}

// Faces that would read back folded from float32 (GIFTI) are opened by the smallest move: the
// vertex opposite the longest edge goes off it, in its tangent plane, to a height of a few float
// spacings (as the square map's open_thin_triangles). For images of almost degenerate surface
// triangles (fs741 pial). Returns the faces left.
int open_thin_sphere_triangles(MatrixXd& S, const MatrixXi& F, int max_rounds = 10) {
  const double eps = 16.0 * std::numeric_limits<float>::epsilon();
  int left = 0;
  for (int round = 0; round <= max_rounds; ++round) {
    left = 0;
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      Eigen::Vector3d p[3];
      for (int c = 0; c < 3; ++c) p[c] = S.row(F(f, c)).transpose();
      double longest = 0;
      int apex = 0;
      for (int c = 0; c < 3; ++c) {
        const double l = (p[(c + 2) % 3] - p[(c + 1) % 3]).norm();
        if (l > longest) longest = l, apex = c;
      }
      const Eigen::Vector3d a = p[(apex + 1) % 3], b = p[(apex + 2) % 3], v = p[apex];
      const Eigen::Vector3d axis = (b - a).normalized(), radial = (a + b + v).normalized();
      // Height of the apex over the edge a-b, measured toward the side where it must lie.
      const Eigen::Vector3d side = radial.cross(axis);
      const double height = (v - a).dot(side), needed = 4.0 * eps;
      bool thin = height <= needed;
      if (!thin) {
        const Eigen::Vector3d q[3] = {S.row(F(f, 0)).cast<float>().cast<double>().transpose(),
                                      S.row(F(f, 1)).cast<float>().cast<double>().transpose(),
                                      S.row(F(f, 2)).cast<float>().cast<double>().transpose()};
        thin = (q[1] - q[0]).cross(q[2] - q[0]).dot(q[0] + q[1] + q[2]) <= 0;
      }
      if (!thin) continue;
      ++left;
      if (round == max_rounds) continue;
      S.row(F(f, apex)) = (v + (2.0 * needed - height) * side).normalized().transpose();
    }
    if (left == 0) break;
  }
  return left;
}

}  // namespace

int sphere_polish_cg_iterations(Eigen::Index faces) { return faces <= 65536 ? 100 : 50; }

MatrixXd sphere_from_square_map(const MatrixXd& V, const MatrixXi& F, const SphereFromSquareOptions& opt,
                                SphereFromSquareReport* rep, const ProgressFn& progress) {
  SphereFromSquareReport local;
  SphereFromSquareReport& R = rep ? *rep : local;
  const Eigen::Index nv = V.rows();

  // 1. Cut: the cap C and the rest B, both disks.
  report(progress, "sphere", -1, "cutting the surface into a cap and the rest");
  const RegionCleanup cap = choose_cap(V, F, opt.cap_fraction, &R.seed_vertex);
  std::vector<char> in_cap(static_cast<std::size_t>(F.rows()), 0);
  for (Eigen::Index k = 0; k < cap.face_index.size(); ++k) in_cap[cap.face_index[k]] = 1;
  MatrixXi FB(F.rows() - cap.F.rows(), 3);
  for (Eigen::Index f = 0, k = 0; f < F.rows(); ++f)
    if (!in_cap[f]) FB.row(k++) = F.row(f);
  const MatrixXi& FC = cap.F;
  const std::string cap_problem = disk_topology_problem(cap.topology), rest_problem = disk_topology_problem(V, FB);
  if (!cap.is_disk() || !cap_problem.empty() || !rest_problem.empty())
    throw ProcessingError("sphere (square route): the cut did not give two disks (cap: " +
                          (cap_problem.empty() ? std::string("a disk") : cap_problem) + "; rest: " +
                          (rest_problem.empty() ? std::string("a disk") : rest_problem) + ")");
  R.cap_faces = static_cast<int>(FC.rows());
  R.rest_faces = static_cast<int>(FB.rows());
  const double area_c = face_areas(V, FC).sum(), area_b = face_areas(V, FB).sum();
  const double share_b = area_b / (area_b + area_c), share_c = 1.0 - share_b;
  R.cap_area_fraction = share_c;

  // 2. B: authalic square map -> disk (concentric) -> north cap (Lambert).
  SquareMapOptions so = opt.square;
  so.anatomical_anchor = false;
  so.anchor_vertex = R.corner_vertex = seam_corner_vertex(V, FB, opt.corner_offset);
  so.anchor_position = 0.0;
  R.corner_offset = opt.corner_offset;
  so.orient_outward = false;
  so.cotangent_start = false;
  so.width = 1.0;
  // A short square polish (the sphere polish below finishes it): fs741 pial, sphere element CV
  // 0.011 without, 0.0098 with 8 steps, 4 steps about as good.
  so.flow.polish.iterations = std::min(so.flow.polish.iterations, 4);
  so.flow.polish.far_iterations = std::min(so.flow.polish.far_iterations, 4);
  so.flow.polish.float32_floor = false;  // an intermediate map, never stored
  const SquareMapResult sq = square_map(V, FB, so, progress);
  R.square_flow = sq.flow;
  R.square_stretch = sq.stretch;
  R.square_transport = sq.transport;
  MatrixXd unit = 2.0 * sq.UV.topRows(nv).array() - 1.0;
  const MatrixXd disk_b = concentric_square_to_disk(unit);
  MatrixXd S = MatrixXd::Zero(nv, 3);
  std::vector<char> done(static_cast<std::size_t>(nv), 0);
  for (Eigen::Index f = 0; f < FB.rows(); ++f)
    for (int c = 0; c < 3; ++c) done[FB(f, c)] = 1;
  for (Eigen::Index v = 0; v < nv; ++v)
    if (done[v]) S.row(v) = lambert_cap_point(disk_b(v, 0), disk_b(v, 1), share_b, +1.0).transpose();

  // 3. C: the disk with the seam held where B put it (mirrored: seen from the south pole),
  // Tutte start, stretch-energy iterations -> south cap.
  std::vector<int> fixed;
  VectorXi side = VectorXi::Zero(nv);
  for (const auto& loop : boundary_loops(FC, static_cast<int>(nv)))
    for (int v : loop) fixed.push_back(v), side[v] = 1;
  MatrixXd seam(fixed.size(), 2);
  for (std::size_t k = 0; k < fixed.size(); ++k) {
    const double r = std::max(1e-300, disk_b.row(fixed[k]).norm());
    seam.row(static_cast<Eigen::Index>(k)) << disk_b(fixed[k], 0) / r, -disk_b(fixed[k], 1) / r;
  }
  const MatrixXd tutte = harmonic_map(V, FC, fixed, seam, HarmonicWeights::ClampedCotangent);
  if (!(signed_face_areas_2d(tutte, FC).minCoeff() > 0))
    throw ProcessingError("sphere (square route): the cap's disk map is not an embedding (" +
                          std::to_string(count_flipped(tutte, FC)) + " folded triangles)");
  StretchEnergyOptions co = opt.cap;
  co.moser_boundary = false;
  const MatrixXd disk_c = stretch_energy_map(V, FC, face_areas(V, FC), tutte, side, 1.0, co, &R.cap);
  for (Eigen::Index f = 0; f < FC.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int v = FC(f, c);
      if (side[v] || done[v] == 2) continue;
      S.row(v) = lambert_cap_point(disk_c(v, 0), -disk_c(v, 1), share_c, -1.0).transpose();
      done[v] = 2;
    }
  // 4. The seam and the nonlinear maps bend the slivers of the square map's boundary layer:
  // per-face polish on the sphere (fs741 white: per-face mean 0.016 after the maps).
  // Triangles that straddle a diagonal of the concentric map (where its derivative jumps) can
  // fold if they are slivers: repaired first, as the flow route's are.
  if (sphere_flipped_faces(S, F) > 0) repair_sphere_flips(S, F);
  unwind_sphere_stars(S, F);
  if (sphere_flipped_faces(S, F) > 0) repair_sphere_flips(S, F);
  // 5. Patches the parts' maps crushed (fs741 pial: 598 faces below e^-2 of their area, missing
  // 0.1 % of it, most of it in one pocket of the medial wall) are opened by the equal-area radial
  // rearrangement of core/crushed_patches.h: no grid resolves them.
  const VectorXd measure = face_areas(V, F);
  inflate_crushed_patches(S, F, measure, opt.crushed, &R.crushed);
  {
    std::ostringstream msg;
    msg << "crushed patches opened: " << R.crushed.patches << " (" << R.crushed.crushed_faces << " faces missing "
        << 100 * R.crushed.missing_share << " % of the area), " << R.crushed.patches_undone << " put back";
    report(progress, "sphere", -1, msg.str());
  }
  // 6. What the parts' maps leave at the scale of elements (their boundary layers along the seam,
  // the cap's stretch energy stalled against its held seam) is removed by a coarse Moser pass on
  // the sphere itself (fs741 pial: sphere element CV 0.0124 -> 0.0083, white 0.0020 -> 0.0012);
  // 64 cells per cube edge resolve sub-element errors, fold more triangles and end worse (pial:
  // 0.013). Then the per-face polish (face scale). More rounds of pass and polish are not
  // reliably better: a later pass crushes faces the polish opened (pial CV 0.0031-0.0057 with
  // two rounds, 0.0088 with three, against 0.0052 with one).
  if (opt.sphere_flow.max_passes > 0) {
    report(progress, "sphere", -1, "coarse Moser pass on the sphere");
    S = moser_sphere_flow(S, F, measure, opt.sphere_flow, &R.sphere_flow);
    if (sphere_flipped_faces(S, F) > 0) repair_sphere_flips(S, F);
  }
  const int cg = opt.polish_cg_iterations > 0 ? opt.polish_cg_iterations : sphere_polish_cg_iterations(F.rows());
  report(progress, "sphere", -1, "per-face polish on the sphere");
  R.polish_face_error = polish_sphere_face_areas(S, F, measure, opt.polish_iterations, cg, 40, progress);
  open_thin_sphere_triangles(S, F);
  {
    std::ostringstream msg;
    msg << "cap (" << FC.rows() << " faces, " << 100 * share_c << " % of the area): stretch energy "
        << R.cap.initial_log_stretch << " -> " << R.cap.final_log_stretch << " in " << R.cap.iterations << " steps; sphere polish: per-face mean |ln ratio| " << R.polish_face_error;
    report(progress, "sphere", -1, msg.str());
  }
  return S;
}

}  // namespace authalic

// Region -> authalic square map, with the anatomical orientation rule (see core/square_map.h).
#include "core/square_map.h"

#include <omp.h>

#include <cmath>
#include <future>
#include <limits>
#include <optional>
#include <sstream>

#include "core/atlas_map.h"
#include "core/error.h"
#include "core/run_beside.h"
#include "core/sparse_cholesky.h"
#include "core/stretch_energy.h"

namespace authalic {

std::string region_geometry_problem(const MatrixXd& V, const MatrixXi& F) {
  // Cortical coordinates are within a few hundred mm; 1e38 overflows every area and angle.
  constexpr double kMaxCoordinate = 1e6;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const auto p = V.row(F(f, c));
      if (!p.allFinite() || p.cwiseAbs().maxCoeff() > kMaxCoordinate) {
        std::ostringstream s;
        s << "vertex " << F(f, c) << " is at (" << p(0) << ", " << p(1) << ", " << p(2)
          << "), not finite or beyond 1e6 mm: the coordinates are not in mm or the file is corrupt";
        return s.str();
      }
    }
  // Zero-area triangles have no cotangent weights: the harmonic map's system is singular.
  const std::vector<int> degenerate = degenerate_faces(V, F);
  if (!degenerate.empty())
    return std::to_string(degenerate.size()) + " of its " + std::to_string(F.rows()) + " triangles are degenerate (zero area, first: face " +
           std::to_string(degenerate.front()) + (degenerate.size() == static_cast<std::size_t>(F.rows()) ? "; the region is collapsed to a point or a line" : "") +
           "); remove or repair them (e.g. merge the coincident vertices) before mapping";
  return {};
}

bool orient_outward(const MatrixXd& V, MatrixXi& F, const MatrixXi* surface) {
  const int winding = surface ? region_winding_on_closed_surface(V, F, *surface) : 0;
  // Without it: Σ (c_f − C)·(e1 x e2)/2 is the signed volume (x3) of the cone from C over the
  // region, positive when the faces point away from the hemisphere's centre.
  double vol = winding;
  if (winding == 0) {
    const Eigen::Vector3d C = V.colwise().mean().transpose();
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      const Eigen::Vector3d a = V.row(F(f, 0)).transpose(), b = V.row(F(f, 1)).transpose(), c = V.row(F(f, 2)).transpose();
      vol += ((a + b + c) / 3.0 - C).dot((b - a).cross(c - a));
    }
  }
  if (!(vol < 0)) return false;
  F.col(1).swap(F.col(2));
  return true;
}

int anterior_boundary_anchor(const MatrixXd& V, const MatrixXi& F, RectangleBoundaryMap& boundary) {
  int anterior = -1;
  double best = -std::numeric_limits<double>::infinity();
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int v = F(f, c);
      // Ties broken by the lowest index, so the rule does not depend on face order.
      if (V(v, 1) > best || (V(v, 1) == best && v < anterior)) best = V(v, 1), anterior = v;
    }
  boundary.use_anchor_point = true;
  boundary.anchor_point = V.row(anterior).transpose();
  boundary.anchor_position = rectangle_top_middle(boundary.width);
  return anterior;
}

MatrixXd extend_to_inserted(const MatrixXd& values, const MatrixXi& parents, const VectorXd& weight) {
  const Eigen::Index n0 = values.rows(), k = parents.rows();
  MatrixXd out(n0 + k, values.cols());
  out.topRows(n0) = values;
  for (Eigen::Index i = 0; i < k; ++i) {
    const double w = weight[i];
    out.row(n0 + i) = (1 - w) * out.row(parents(i, 0)) + w * out.row(parents(i, 1));
  }
  return out;
}

MatrixXd extend_to_inserted(const MatrixXd& values, const ConformalMapResult& initial) {
  return extend_to_inserted(values.topRows(initial.num_input_vertices), initial.inserted_parents, initial.inserted_weight);
}

namespace {
// The map is stored as float32 (GIFTI): triangles too thin to keep their orientation at that
// precision (images of almost degenerate surface triangles) are opened by the smallest move, so
// the file a user reads has no flipped triangle (measured: fs741 pial, 16 of 295,000 read back
// flipped before). Untangling is the fall-back; it smooths whole one-rings, which costs area
// there (fs741 pial 96 % mask under OpenBLAS's rounding: 68 thin triangles, element CV 0.0024
// -> 0.0090, exit 3), so the polish runs again after it (then CV 0.0030). Returns the triangles left below the floor.
int keep_orientation_in_single_precision(const MatrixXd& V, const MatrixXi& F, const VectorXi& side_mask,
                                         const FlowOptions& fo, const ProgressFn& progress, MatrixXd& UV,
                                         FlowReport& report) {
  VectorXd floor = single_precision_area_floor(UV, F);
  int left = open_thin_triangles(F, side_mask, fo.width, floor, UV);
  if (left == 0) return 0;
  untangle_flips(F, side_mask, fo.width, floor, UV, &left);
  if (left > 0) return left;
  // The polish again on the untangled map; kept only if it leaves (after opening) no triangle
  // below the floor and a lower per-vertex error, else the untangled map stands.
  FlowOptions polish_only = fo;
  polish_only.grid.max_passes = 0;
  polish_only.polish.cg_iterations *= 4;  // the smoothed spots are badly conditioned: inexact steps stall there
  FlowResult again = authalic_flow(V, F, UV, side_mask, polish_only, progress);
  floor = single_precision_area_floor(again.UV, F);
  if (open_thin_triangles(F, side_mask, fo.width, floor, again.UV) > 0) return 0;
  if (!(again.report.final_vertex_mean < again.report.initial_vertex_mean)) return 0;
  UV = std::move(again.UV);
  report.polish_iterations += again.report.polish_iterations;
  report.final_vertex_mean = again.report.final_vertex_mean;
  report.final_vertex_p99 = again.report.final_vertex_p99;
  report.final_vertex_max = again.report.final_vertex_max;
  report.converged = again.report.converged;
  return 0;
}
}  // namespace

namespace {

// The optimal-transport refinement of an authalic map UV, then the area-restoring flow from it
// (the refinement keeps area only to first order).
FlowResult refine_by_optimal_transport(const ConformalMapResult& init, const VectorXd& measure, const MatrixXd& UV,
                                       const SquareMapOptions& opt, const FlowOptions& fo, const ProgressFn& progress,
                                       OptimalTransportReport* out) {
  report(progress, "transport", -1, "optimal-transport refinement");
  OptimalTransportResult ot = optimal_transport_refine(init.UV, UV, init.F, init.side_mask, opt.width, measure, opt.transport);
  *out = ot.report;
  std::ostringstream msg;
  msg << "optimal transport: " << ot.report.iterations << " steps, cost " << ot.report.initial_cost << " -> "
      << ot.report.final_cost << " (" << ot.report.stop_reason << ")";
  report(progress, "transport", -1, msg.str());
  return authalic_flow(init.V, init.F, ot.UV, init.side_mask, fo, progress);
}

}  // namespace

namespace {

// The conformal map's and the stretch energy's systems, of more than kSpdMetisMinUnknowns rows,
// are ordered by METIS on the region's vertices (mesh_vertex_ordering) instead of on the first
// system: the faces are known before the region is checked, the boundary placed and the system
// assembled, so with more than one thread the ordering runs beside all that (B600, one thread:
// METIS 4.6 s). Computed the same way with one thread, so the map does not depend on the count.
void order_by_mesh(const MatrixXi& F, int num_vertices, SpdSolver& solver) {
  if ((F.rows() + 2) / 2 <= kSpdMetisMinUnknowns) return;  // AMD (or LDLᵀ) orders smaller systems at their analysis
  if (F.minCoeff() < 0 || F.maxCoeff() >= num_vertices) return;  // not checked yet: the checks below refuse it
  const auto policy = omp_get_max_threads() > 1 ? std::launch::async : std::launch::deferred;
  solver.order_by_vertices(std::async(policy, mesh_vertex_ordering, F, num_vertices).share());
}

}  // namespace

SquareMapResult square_map(const MatrixXd& V, const MatrixXi& F_in, const SquareMapOptions& opt, const ProgressFn& progress) {
  if (V.cols() != 3) throw InputError("surface: vertex coordinates must be 3D; give a 3D surface");
  if (!(opt.width > 0)) throw InputError("square map: the rectangle width must be positive");
  // The ordering depends only on the faces' edges (the outward orientation below keeps them), so
  // it starts first and runs beside the region's checks and the boundary placement.
  SpdSolver solver;  // one analysis for the conformal map's systems and the stretch-energy steps
  order_by_mesh(F_in, static_cast<int>(V.rows()), solver);
  if (!opt.region_topology || !disk_topology_problem(*opt.region_topology).empty())
    require_disk(V, F_in, opt.region_name);
  const std::string geometry = region_geometry_problem(V, F_in);
  if (!geometry.empty()) throw InputError(opt.region_name + ": " + geometry);
  if (opt.density.size() > 0) {
    if (opt.density.size() != V.rows())
      throw InputError("density: " + std::to_string(opt.density.size()) + " values for " + std::to_string(V.rows()) +
                       " vertices; give one value per surface vertex");
    for (Eigen::Index f = 0; f < F_in.rows(); ++f)
      for (int c = 0; c < 3; ++c) {
        const double d = opt.density[F_in(f, c)];
        if (!(d > 0) || !std::isfinite(d))
          throw InputError("density: vertex " + std::to_string(F_in(f, c)) + " of the region has density " +
                           std::to_string(d) + "; densities must be positive and finite");
      }
  }

  SquareMapResult R;
  R.width = opt.width;
  R.num_input_vertices = static_cast<int>(V.rows());
  MatrixXi F = F_in;

  if (opt.orient_outward) R.faces_reversed = orient_outward(V, F, opt.surface_faces);
  RectangleBoundaryMap b;
  b.width = opt.width;
  b.sliding_boundary = opt.sliding_initial_boundary;
  b.flip_dividing_edges = opt.flip_dividing_edges;
  if (opt.stretch_start) b.fallback = HarmonicWeights::ClampedCotangent;
  b.try_cotangent = !opt.stretch_start || opt.cotangent_start;
  if (opt.anatomical_anchor) {
    R.anterior_vertex = anterior_boundary_anchor(V, F, b);
  } else if (opt.anchor_vertex >= 0) {
    b.anchor_vertex = R.anterior_vertex = opt.anchor_vertex;
    b.anchor_position = opt.anchor_position;
  }
  const bool given_start = opt.start_uv.rows() > 0;
  if (given_start) {
    if (opt.start_uv.rows() != V.rows() || opt.start_uv.cols() != 2)
      throw InputError("start map: " + std::to_string(opt.start_uv.rows()) + " rows for " + std::to_string(V.rows()) +
                       " vertices; give one 2D position per surface vertex");
    b.boundary_perimeter = boundary_perimeter_from_map(opt.start_uv, V, F, opt.width, opt.start_min_boundary_step);
    b.try_cotangent = false;  // the interior is replaced by the given start
    b.fallback = HarmonicWeights::ClampedCotangent;
  }
  report(progress, "initial", -1, "conformal map");
  ConformalMapResult init = conformal_rectangle_mesh(V, F, b);
  // The stretch-energy system needs the mesh, not the map: it is built beside the conformal solve.
  const bool stretch_start = opt.stretch_start && !given_start;
  std::optional<StretchEnergySystem> stretch_system;
  run_beside([&] { conformal_rectangle_solve(init, b, &solver); },
             [&] {
               if (stretch_start) stretch_system.emplace(init.V, init.F, init.side_mask, opt.stretch.min_weight);
             });
  R.surface_area = face_areas(init.V, init.F).sum();
  {
    std::ostringstream msg;
    msg << "conformal map (" << to_string(init.weights) << " weights): " << count_flipped(init.UV, init.F, 0.0)
        << " flipped triangles, " << init.cotangent_flips << " with cotangent weights";
    report(progress, "initial", -1, msg.str());
  }

  FlowOptions fo = opt.flow;
  fo.width = opt.width;
  if (opt.density.size() > 0) fo.density = extend_to_inserted(opt.density, init).col(0);
  MatrixXd start = init.UV;
  if (given_start) {
    start = start_from_map(init, opt.start_uv, &R.start_repaired);
    init.UV = start;
    report(progress, "initial", -1, "given start: " + std::to_string(R.start_repaired) + " vertices re-placed to unfold it");
  } else if (stretch_start) {
    report(progress, "stretch", -1, "stretch-energy start");
    const VectorXd target = target_face_measure(init.V, init.F, fo.density, opt.width);
    start = stretch_energy_map(*stretch_system, target, init.UV, opt.width, opt.stretch, &R.stretch, &solver);
    std::ostringstream msg;
    msg << "stretch-energy start: " << R.stretch.iterations << " iterations, mean |ln stretch| per face "
        << R.stretch.initial_log_stretch << " -> " << R.stretch.final_log_stretch;
    report(progress, "stretch", -1, msg.str());
  }
  if (fo.grid.resolution <= 0 && opt.stretch_start && !given_start)
    fo.grid.resolution = grid_resolution_for(init.F.rows(), opt.width);  // the start is almost authalic
  FlowResult flow = authalic_flow(init.V, init.F, start, init.side_mask, fo, progress);
  const VectorXd measure = target_face_measure(init.V, init.F, fo.density, opt.width);
  if (opt.optimal_transport) flow = refine_by_optimal_transport(init, measure, flow.UV, opt, fo, progress, &R.transport);
  R.transport_cost = transport_cost(init.UV, flow.UV, init.F, measure);

  R.V = std::move(init.V);
  R.F = std::move(init.F);
  R.UV_initial = std::move(init.UV);
  R.UV = std::move(flow.UV);
  R.face_origin = init.face_origin;
  R.side_mask = init.side_mask;
  R.flow = flow.report;
  R.initial = std::move(init);
  R.initial.V.resize(0, 3);
  R.initial.F.resize(0, 3);
  R.initial.UV.resize(0, 2);
  R.flips = keep_orientation_in_single_precision(R.V, R.F, R.side_mask, fo, progress, R.UV, R.flow);
  if (R.flips > 0)
    throw ProcessingError("square map: the flow left " + std::to_string(R.flips) +
                          " folded triangles that the repair could not remove (per-vertex mean |ln area ratio| " +
                          std::to_string(R.flow.final_vertex_mean) +
                          "); the map is not authalic. Check the region for degenerate triangles, or try a finer flow grid");
  return R;
}

}  // namespace authalic

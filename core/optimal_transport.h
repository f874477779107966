#pragma once
// Optimal-mass-transport refinement of an authalic map on the rectangle [0, W] x [0, 1].
//
// Among all area-preserving maps from the conformal start X (the surface measure μ pushed to the
// rectangle by the conformal map) to the uniform measure, the optimal-transport one moves area
// the least, ∫ |x − T(x)|² dμ, and so keeps shapes closest to the conformal start (Dominitz &
// Tannenbaum 2010, section 2.3). They reach it from any area-preserving map g⁰ by rearranging
// the source with μ-preserving flows s^t (g⁰ = g^t ∘ s^t) along the gradient of the cost, eq. (8)-(12),
// whose Hamiltonian H = div(J(x − g)) is the curl of the map.
//
// Here the same gradient flow is written on the target side, where the measure is uniform and a
// regular grid resolves it: with Y = g(X) the authalic positions of the vertices, the cost is
//     C(Y) = Σ_i μ_i |Y_i − X_i|²,                                  (μ_i: vertex share of μ)
// and area is kept by moving Y along divergence-free velocities w with w·n = 0 on the sides
// (the rearrangement r^t of the target that keeps the uniform measure, h^t = h⁰ ∘ (r^t)⁻¹ for the
// inverse map h = g⁻¹). dC/dt = −2 ∫ (Y − X)·w, so the steepest descent among such w is the
// Leray (Helmholtz) projection of the displacement field f = Y − X onto divergence-free fields:
//     w = f − ∇p,   Δp = div f,   ∂p/∂n = 0 on the walls (zero normal flux),
// solved exactly on a staggered (MAC) grid by the cosine transform (core/poisson_dct.h), whose
// 5-point Neumann Laplacian is the MAC divergence of the MAC gradient, so w is discretely
// divergence-free. At the optimum f is a gradient (w = 0): T = id − ∇φ, Brenier's map.
//
// Each step moves Y by −τ w (τ ≤ 1, halved until the cost falls and no triangle flips). The
// interpolated field is divergence-free only up to the grid, so the refined map is area-preserving
// to first order; square_map restores exact areas afterwards with the area-restoring flow.
#include <string>
#include <vector>

#include "core/mesh.h"

namespace authalic {

struct OptimalTransportOptions {
  // Cells along the unit side of the grid the projection is solved on (0: chosen from the
  // vertex count, about one cell per 4 vertices, between 32 and 256).
  int grid_resolution = 0;
  int max_iterations = 60;
  // Stop when a step lowers the cost by less than this fraction.
  double min_relative_decrease = 1e-4;
};

struct OptimalTransportReport {
  int iterations = 0;        // accepted steps
  int grid_resolution = 0;
  std::string stop_reason;   // "converged", "iteration limit", "step vanished"
  // Transport cost ∫ |x − T(x)|² dμ / ∫ dμ (mean squared displacement from the start, in squared
  // domain units): before and after the refinement.
  double initial_cost = 0, final_cost = 0;
  std::vector<double> history;  // cost after each accepted step
};

struct OptimalTransportResult {
  MatrixXd UV;  // #V x 2, the refined map
  OptimalTransportReport report;
};

// Transport cost of the map UV from the start X: Σ μ_i |UV_i − X_i|² / Σ μ_i, with μ_i a third of
// the face_measure (#F) of each face around vertex i. UV, X: #V x 2.
double transport_cost(const MatrixXd& X, const MatrixXd& UV, const MatrixXi& F, const VectorXd& face_measure);

// The refinement above. X: #V x 2 conformal start, UV: #V x 2 an authalic map of the same mesh
// (F: faces of a disk, no flipped triangle) into [0, W] x [0, 1], side_mask: RectangleSide bits
// (core/conformal_map.h) of the boundary vertices, which slide along their side (corners stay),
// face_measure: #F target measure (core/authalic_flow.h target_face_measure). Deterministic for
// any thread count; the result has no flipped triangle.
OptimalTransportResult optimal_transport_refine(const MatrixXd& X, const MatrixXd& UV, const MatrixXi& F,
                                                const VectorXi& side_mask, double width, const VectorXd& face_measure,
                                                const OptimalTransportOptions& options = {});

// The Leray projection on its own (exposed for tests): the divergence-free part w of a field f
// given by its cell averages (fx, fy: ny x nx, cells of size hx x hy), on the staggered grid:
// wx ny x (nx + 1) at the vertical cell faces, wy (ny + 1) x nx at the horizontal ones, zero on
// the walls, with a discrete divergence of zero in every cell.
void leray_projection(const MatrixXd& fx, const MatrixXd& fy, double hx, double hy, MatrixXd* wx, MatrixXd* wy);

}  // namespace authalic

#pragma once
// A roughly authalic start for the area-restoring flow: fixed-point iterations of the stretch
// energy minimisation of Yueh, Lin, Wu & Yau 2019 (J. Sci. Comput. 78, Algorithm 1), with the
// boundary on the rectangle's sides: slid along them by one Moser grid pass per iteration
// (moser_boundary), or held where the initial map put it.
//
// The stretch energy E_S(f) = ½ Σ_τ σ(τ) E_D,τ(f), with σ(τ) = |f(τ)| / |τ| the triangle's
// stretch (map area over target measure, both normalised to equal totals; Yueh's 1/σ_{f⁻¹}), is
// minimised by authalic maps. Its fixed-point iteration solves the Laplace problem with the
// surface's cotangent weights multiplied by the current stretch of each triangle: a triangle
// squeezed by the map (σ < 1) gets soft edges and is pushed open, an inflated one is pulled in.
// Here the factor accumulates over the iterations (w_k = w_0 Π σ_j), so a face still squeezed
// keeps softening; the plain iteration overshoots after one step on the cortex (measured on
// fsaverage5 and fs741). The cotangent weights are clamped to a small positive floor, so with the
// boundary held every iterate is a Tutte embedding with positive weights of a disk with a convex
// boundary (Floater 2003): no triangle can fold, however large the compression of the start (the
// failure of a uniform-grid flow on a native cortex, where the conformal start squeezes parts of
// the cortex by 10^3).
#include <memory>

#include "core/mesh.h"
#include "core/sparse_cholesky.h"

namespace authalic {

struct StretchEnergyOptions {
  int max_iterations = 10;
  double exponent = 1.0;        // each step multiplies the weights by σ^exponent
  double min_weight = 1e-2;     // floor of the cotangent weights, relative to their mean
  double stop_improvement = 0.8;  // stop when a step keeps more than this share of the error
  // Slide the boundary along the sides by a Moser pass of each iterate (grid of this resolution).
  bool moser_boundary = true;
  int boundary_grid = 256;
  // Steps after the first: conjugate gradients preconditioned with the last factorisation,
  // cutting the residual of the current map by this factor in at most inexact_max_iterations
  // (else a refactorisation), and a refactorisation at the next step after a solve that needed
  // more than inexact_refactor_after; tolerance 0: every step exact.
  // Only systems of more than inexact_min_unknowns (SpdSolver's METIS range): below, an AMD-ordered
  // factorisation costs 8-10 solves and a CG step 1.6, and the steps take 5-14 CG steps, so an
  // exact step costs as much (fs741 lh.white: 1.00x the CPU time; B3 1.05-1.10x) and its
  // factorisation runs beside the boundary slide (2 threads: 0.91x the wall time on both). At
  // 600k vertices (METIS) exact steps cost 1.14x the CPU time.
  double inexact_tolerance = 1e-3;
  int inexact_max_iterations = 20;
  int inexact_refactor_after = 10;
  Eigen::Index inexact_min_unknowns = kSpdMetisMinUnknowns;
};

struct StretchEnergyReport {
  int iterations = 0;
  double initial_log_stretch = 0;  // mean |ln σ| per face, area weighted
  double final_log_stretch = 0;
};

// Inputs: V #V x 3 surface, F #F x 3 faces of a disk (oriented so UV0 is counter-clockwise),
// face_target #F measure each face should receive (its area, or area x density), UV0 #V x 2
// initial map without flipped triangles in [0, W] x [0, 1], side_mask #V RectangleSide bits
// (core/conformal_map.h) of the boundary vertices (non-zero), width W. With moser_boundary they
// move along their sides by the Moser velocity of the current map (corners stay; the move is
// halved until the re-solve is an embedding and lowers the error): held at arc length, a jagged
// stretch of border keeps too much perimeter (fs741's 96 % mask: one corner 30x inflated).
// Letting them slide freely inside the energy instead (a free boundary) folds triangles after two
// steps there. Without moser_boundary they are held (any convex boundary: W is unused).
// Output: #V x 2 map; the vertices not used by F and the fixed ones keep UV0.
MatrixXd stretch_energy_map(const MatrixXd& V, const MatrixXi& F, const VectorXd& face_target, const MatrixXd& UV0,
                            const VectorXi& side_mask, double width, const StretchEnergyOptions& options = {},
                            StretchEnergyReport* report = nullptr, SpdSolver* solver = nullptr);

// What the iterations need that does not depend on a map: the surface's cotangent weights clamped
// to min_weight of their mean, the unknowns (vertices used by F off the boundary) and the Laplacian's
// pattern with the slot of every contribution, which each iteration refills. Building it costs
// about one factorisation (fs741 lh.white: 0.28 s), so a caller can build it beside other work on
// the same mesh (square_map: beside the conformal solve; core/run_beside.h).
class StretchEnergySystem {
 public:
  StretchEnergySystem(const MatrixXd& V, const MatrixXi& F, const VectorXi& side_mask, double min_weight);
  ~StretchEnergySystem();
  StretchEnergySystem(StretchEnergySystem&&) noexcept;
  StretchEnergySystem& operator=(StretchEnergySystem&&) noexcept;
  struct Parts;  // core/stretch_energy.cpp
  Parts& parts() { return *parts_; }

 private:
  std::unique_ptr<Parts> parts_;
};

// The same iterations on a prepared system (its F, side_mask and weights; options.min_weight is
// not read again). The system's values are overwritten; its pattern is kept. face_target has one
// entry per face of the system, UV0 one row per vertex (std::invalid_argument otherwise).
MatrixXd stretch_energy_map(StretchEnergySystem& system, const VectorXd& face_target, const MatrixXd& UV0, double width,
                            const StretchEnergyOptions& options = {}, StretchEnergyReport* report = nullptr,
                            SpdSolver* solver = nullptr);

}  // namespace authalic

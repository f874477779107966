#pragma once
// Registration of a flat map to an atlas's flat map by an area-preserving deformation of the
// rectangle (issue 14 part 2: correspondence without a spherical registration).
//
// Both maps are authalic maps of a cortex onto [0, W] x [0, 1]; a per-vertex feature (e.g. the
// sulcal depth, core/sulcal_depth.h) is given on each. The subject's vertices are moved by a
// sequence of small steps of a velocity field v that is divergence-free with no flux through the
// sides (incompressible demons): a divergence-free flow keeps every region's area, so the map
// stays authalic (up to the advection's discretisation error, which the area-restoring flow then
// removes) while the subject's feature pattern is pulled onto the atlas's.
//
// One iteration (at a smoothing scale σ; coarse to fine over options.sigmas):
//  1. both features as images on a cell-centred grid by normalised convolution (bilinear splat of
//     the flat-area-weighted values, Gaussian σ, divided by the splatted weights);
//  2. the demons force at each cell (Thirion 1998; symmetric gradient):
//       f = (S − A) ∇m / (|∇m|² + (S − A)² / h²),   m = (S + A) / 2,
//     which moves the subject's pattern S toward the atlas's A by at most h/2 (h: the cell size);
//  3. fluid regularisation: f smoothed by a Gaussian (options.fluid σ);
//  4. the Leray projection on the staggered (MAC) grid: normal components on the sides set to 0,
//     then v = f − ∇φ with Δφ = div f (Neumann; core/poisson_dct.h), so the discrete divergence is
//     exactly 0 in every cell and no velocity crosses a side (boundary vertices slide along it);
//  5. the step is capped (largest vertex move, largest |∇v| dt), halved while it would fold a
//     triangle (a smooth divergence-free flow does not fold, but a mesh's straight edges see it only
//     at their ends), and the vertices move by one RK4 step; the iteration is kept only when it
//     lowers the images' mismatch Σ ρ (S − A)² / Σ ρ (ρ: the subject's splatted weights).
// A level ends when 5 iterations in a row lower the mismatch by less than 0.1 %, or when a step
// no longer lowers it. Measured (tests/core/test_flat_registration.cpp): a known swirl of about one
// element is undone to 3 % of it with face areas kept within 0.65 % (mean |ln ratio|).
#include <vector>

#include "core/mesh.h"

namespace authalic {

struct FlatRegistrationOptions {
  int grid = 64;                                    // cells per unit length
  std::vector<double> sigmas = {0.08, 0.04, 0.02};  // feature smoothing per level (unit lengths)
  int iterations = 60;                              // per level, at most
  double fluid = 3.0;                               // velocity smoothing σ, in units of the level's σ
  double max_move = 0.5;                            // largest vertex move per iteration, in cells
  double max_strain = 0.2;                          // largest |∇v| dt per iteration
};

struct FlatRegistrationReport {
  // Area-weighted correlation of the subject's feature with the atlas's image at the vertices
  // (finest σ) before and after.
  double correlation_before = 0, correlation_after = 0;
  int iterations = 0;   // kept iterations over all levels
  double max_move = 0;  // largest vertex displacement (unit lengths)
};

// Inputs: UV #V x 2 (the subject's authalic map on [0, width] x [0, 1]), F its faces, feature #V;
// atlas_UV, atlas_F, atlas_feature: the atlas's map and feature. Features are compared after
// each is standardised (flat-area-weighted mean 0, SD 1). Vertices used by no face keep their UV.
// Returns the registered UV (#V x 2, inside the rectangle).
MatrixXd register_flat_map(const MatrixXd& UV, const MatrixXi& F, const VectorXd& feature, const MatrixXd& atlas_UV,
                           const MatrixXi& atlas_F, const VectorXd& atlas_feature, double width,
                           const FlatRegistrationOptions& options = {}, FlatRegistrationReport* report = nullptr);

}  // namespace authalic

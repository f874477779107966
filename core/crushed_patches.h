#pragma once
// Crushed patches of a sphere map opened by an equal-area radial rearrangement.
//
// A map started from a harmonic (Tutte) embedding can squeeze a pocket of the surface (a narrow
// fold, e.g. where a native pial surface's medial wall turns under itself) to e^-6 of its area.
// The patch is then far below any background grid's resolution, and a per-face polish opens it
// by a bounded factor per step: it stays crushed, and its whole cortical area sits in one
// element of the sphere (fs741 pial: 23 mm² in 0.3 % of an element, which holds 1.27 x its share).
//
// For each connected patch of crushed faces (ln(map share / target share) < crushed_log_ratio,
// faces joined by a vertex) whose missing area is worth it, a window about the patch's centre c
// is rearranged radially. In the Lambert azimuthal equal-area coordinates about c the chord
// distance ρ = |p − c| is an equal-area radius (a spherical cap of chord radius ρ has area πρ²),
// so the map along each great circle from c
//     ρ -> R(ρ) = ρ_w sqrt(M(ρ) / M(ρ_w)),
// M(ρ) the target measure of the faces inside chord radius ρ (each face's measure spread
// uniformly over the radial span of its corners), gives every disk about c an area proportional
// to its target measure: the patch receives its share, the rest of the window gives it up evenly,
// and nothing outside the window moves (R(ρ_w) = ρ_w). It is the exact Moser flow of a radially
// symmetric density, so a uniformly crushed round patch is scaled up conformally. The window
// holds `window_factor` times the patch's missing measure, so what is left is a density excess
// of about 1/window_factor over a window of several elements: the scale a coarse Moser pass
// resolves. Faces the rearrangement folds (slivers lying along a circle about c) are repaired by
// neighbour means; a window whose folds the repair cannot remove, or whose crushed faces end up
// missing more measure than before, is put back as it was.
#include "core/mesh.h"

namespace authalic {

struct CrushedPatchOptions {
  double crushed_log_ratio = -2.0;   // a face is crushed below e^-2 of its share
  double min_missing_share = 1e-5;   // patches missing less of the total measure are left alone
  int min_faces = 10;                // ... and patches of fewer faces: the per-face polish's job
                                     // (a window about one face shears its neighbourhood for
                                     // nothing: fsaverage5 white, sphere CV 0.0060 -> 0.017)
  double window_factor = 40.0;       // window measure / the patch's missing measure
  double max_window_share = 0.02;    // cap of a window's measure (share of the total)
};

struct CrushedPatchReport {
  int patches = 0;             // patches rearranged
  int crushed_faces = 0;       // faces in them
  double missing_share = 0;    // their missing measure before, share of the total
  int patches_undone = 0;      // windows put back: folds not repaired, or no less missing
};

// Inputs: S #V x 3 unit vectors (no flipped face), F #F x 3 counter-clockwise seen from outside,
// face_measure #F target measure (ratios matter). Output: S moved; no face is flipped on return.
void inflate_crushed_patches(MatrixXd& S, const MatrixXi& F, const VectorXd& face_measure,
                             const CrushedPatchOptions& options = {}, CrushedPatchReport* report = nullptr);

}  // namespace authalic

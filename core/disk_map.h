#pragma once
// The authalic map of a cortical region onto the unit disk (Zou et al. 2011a section 4.5.1: the
// same flow with the boundary on the unit circle by arc length, vertices sliding on it).
//
//   disk_map(V, F) = polish_disk(concentric(square_map(V, F)))
//
// Shirley & Chiu's concentric map (core/concentric_map.h) scales area by π/4 everywhere and takes
// the square's boundary to the circle by arc length (the frontal pole at the top middle of the
// square goes to the top of the disk, (0, 1)), so the square's authalic map is an authalic map of
// the disk up to the mesh's linear interpolation: the map is not linear inside a triangle and its
// derivative jumps across the square's diagonals, so thin triangles are bent (B1: per-face mean
// |ln area ratio| 0.018 -> 0.032, 6 folded; fs741: 109 folded). What the carry leaves is at the
// scale of single faces, which the per-face polish removes: Gauss-Newton steps on the face areas
// (as the square's polish, core/authalic_flow.h), first about the far-off faces alone, then about
// all faces beyond a band; last, one Moser pass on the cells (in the square the concentric map
// carries onto the disk), kept only when it lowers the 32 x 32 element CV. The boundary vertices
// slid along the circle in the square's flow (its sides are the circle's quarters) and are held by
// the polish: sliding them opened chords of 0.37 rad on fs741 (the circle's segment under a chord
// is lost to the cells along it). Long chords are split first. Cell-scale area, which the elements see, is kept by the carry up to the mesh's
// interpolation; the disk's elements are the square's cells carried the same way (core/domain.h).
// Measured (flatten --domain disk, bench/bench_disk.sh): B1 element CV 0.0040, per-face mean
// 0.0079; fs741 lh white CV 0.0037, per-face 0.0083 (the square maps: 0.0024 / 0.018 and 0.0003
// / 0.0093).
#include "core/mesh.h"
#include "core/progress.h"
#include "core/square_map.h"

namespace authalic {

struct DiskMapOptions {
  int polish_iterations = 60;  // Gauss-Newton steps at most (each of the two stages)
  // They stop after this many steps in a row that each gain under 1 %: the gains come in bursts
  // (fs741 lh.white: 0.6 %, 0.1 %, then 10 %), and stopping after 2 left that map's element CV at
  // 0.0051 or 0.0026 depending on the last bits of the square map; after 3, 0.0037 (B1 0.0041 ->
  // 0.0040).
  int slow_steps = 3;
  // ... but only once the per-vertex mean |ln area ratio| is within this (the flow's tolerance).
  // A carry that folded many slivers leaves an untangled patch whose error comes down in bursts
  // after runs of slow steps: fs741 pial on one machine (306 folds, 7,313 vertices
  // untangled) stopped at per-vertex 0.0134, element CV 0.014 (exit 3); polished on, 0.0067 and
  // 0.0078 in 84 steps.
  double vertex_tolerance = 0.006;
  double far_band = 1.0;       // first the faces beyond this (the untangled ones), and `rings` rings around them
  double band = 0.01;          // then the faces whose |ln area ratio| exceeds this, and `rings` rings around them
  int rings = 3;
  int cg_iterations = 50;      // conjugate-gradient iterations per step (inexact Newton)
  double theta = 0.5;          // fraction of each vertex's critical flip-preventing step (DLF eq. 5)
  // Boundary edges spanning more of the circle are split (a chord of Δθ misses (Δθ − sin Δθ) / 2 of
  // the disk: at 2π/256, 4e-4 of a 32 x 32 cell).
  double max_chord_angle = 2 * M_PI / 256;
};

struct DiskMapReport {
  int inserted_vertices = 0;     // boundary vertices inserted on long chords (appended, like the square's corner splits)
  int carried_flips = 0;         // triangles the concentric map folded (thin ones bent across a diagonal)
  int untangled_vertices = 0;    // vertices moved to unfold them
  double carried_face_error = 0; // per-face mean |ln area ratio| right after the carry (and untangling)
  double face_error = 0;         // after the polish
  int polish_iterations = 0;
  double cell_cv_before_pass = 0; // 32 x 32 element CV before the final Moser pass on the cells
  bool cell_pass_kept = false;    // the pass lowered it (else the polished map is kept)
  int flips = 0;                 // flipped triangles of the result (0 unless something failed)
};

// Carries a square map (SquareMapResult of width 1) onto the unit disk in place: UV and
// UV_initial become disk coordinates (#V' x 2, the unit disk centred at the origin; unused
// vertices at the centre), then the per-face polish brings UV's face areas to their targets: the
// faces' 3D areas, or with density (#V of the square map's input, as SquareMapOptions::density)
// the measure-controlled ones, scaled to the disk's area π. side_mask keeps marking the boundary
// vertices (any bit: on the circle). r.flips counts the result's flipped triangles.
// Deterministic for any thread count.
void carry_square_map_to_disk(SquareMapResult& r, const VectorXd& density = VectorXd(), const DiskMapOptions& options = {},
                              DiskMapReport* report = nullptr, const ProgressFn& progress = {});

// The one call: square_map (options.width must be 1), then the carry above with the square map's
// own target (its density, if any). Throws as square_map does.
SquareMapResult disk_map(const MatrixXd& V, const MatrixXi& F, const SquareMapOptions& square = {},
                         const DiskMapOptions& options = {}, DiskMapReport* report = nullptr,
                         const ProgressFn& progress = {});

// Gauss-Newton steps on the per-face areas of a disk map D (#V x 2) towards face_target (#F):
// minimise Σ_f (a_f − T_f)² / T_f (face_area_newton_displacement) over the interior vertices of
// the faces beyond options.band and options.rings rings around them (on_circle #V, non-zero:
// held), each step with per-vertex flip-preventing steps and a halving line search, kept only when
// it lowers the per-face mean |ln(a_f / T_f)| without raising the per-vertex mean by over 1 %.
// Returns the steps kept; D is updated in place.
int polish_disk_face_areas(MatrixXd& D, const MatrixXi& F, const VectorXd& face_target, const VectorXi& on_circle,
                           const DiskMapOptions& options = {}, const ProgressFn& progress = {});

}  // namespace authalic

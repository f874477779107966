#pragma once
// A cortex region given by its vertices (FreeSurfer .label, GIFTI label or shape mask) -> a face
// set that is one disk, as the square map needs, with a record of what was changed.
//
// Real labels are not clean disks: "faces with all three vertices in the label" has small holes
// (vertices missing from the label), isolated islands, and pinch (bow-tie) vertices where two
// parts of the region touch only at a vertex. region_faces_from_vertices cleans that up in four
// steps, each deterministic (no hashing, no threads: the same input gives the same faces):
//
//  1. faces: the rows of F whose three vertices are all in the region ("raw" faces);
//  2. islands: components of the raw faces connected over edges (faces touching only at a vertex
//     are separate); the largest by area is kept (ties: the one with the lowest face index), the
//     others are dropped. A bow-tie flap hanging on the region by one vertex is such an island;
//  3. holes: the faces of F outside the region, grouped by flood fill over edges, that share an
//     edge with the region. The outer side is the group of largest area (on a closed hemisphere:
//     the medial wall); when the region or a group reaches the border of an open F, the border is
//     the outer side and every enclosed group is a hole. Every other group (a hole enclosed by a
//     boundary loop) whose area is below opt.max_hole_fraction of the region's area (after step 2)
//     is filled with its faces of F. Filling also resolves the pinches that enclose a small pocket;
//  4. pinches left (a vertex whose region faces form more than one fan): the faces of the
//     smaller fans at that vertex are removed, keeping the fan of largest area (repeated while a
//     removal pinches a neighbour), then any piece cut loose is dropped. A pinch that encloses a
//     pocket too big to fill thus opens the pocket into the outside with a few faces removed,
//     where adding faces to close the pinch would turn the pocket into an unfillable hole: removing
//     the fan keeps the region closest to the label and makes it a disk.
//
// Inputs: V (#V x 3, mm), F (#F x 3, the whole surface, e.g. a closed hemisphere), in_region
// (#V: vertex is in the label). Output: RegionCleanup with the face set (rows of F, in F's order,
// indices into V) and the counts/areas (mm^2, from V) of what each step changed. It does not throw
// when the result is still not one disk: is_disk() is false and problem() says why (the measured
// topology and the largest hole that was not filled), for the caller's InputError.
#include <string>
#include <vector>

#include "core/mesh.h"

namespace authalic {

struct RegionCleanupOptions {
  // Holes with area < max_hole_fraction x region area are filled; 0 fills none.
  double max_hole_fraction = 0.01;
};

struct RegionCleanup {
  MatrixXi F;                 // #F' x 3 region faces: rows of the input F, in its order
  VectorXi face_index;        // #F': row of the input F of each region face
  TopologyReport topology;    // of F (the cleaned region)
  double area_mm2 = 0;        // area of the cleaned region
  double max_hole_fraction = 0.01;  // the option used

  int label_vertices = 0;     // vertices with in_region true
  int raw_faces = 0;          // faces of the input F with all three vertices in the region
  double raw_area_mm2 = 0;
  int raw_pinch_vertices = 0; // vertices of the raw faces where they form more than one fan

  // Step 2: islands dropped (and not brought back by a filled hole around them).
  int islands_dropped = 0;
  int island_faces = 0;
  int island_vertices = 0;    // label vertices lost with them (not in the cleaned region)
  double island_area_mm2 = 0;
  double largest_island_mm2 = 0;  // the largest dropped island, and its share of the kept piece
  double largest_island_fraction = 0;

  // Step 3: holes filled.
  int holes_filled = 0;
  int hole_faces_added = 0;   // faces of F added (not raw faces)
  int hole_vertices_added = 0;  // vertices added (used by no raw face)
  double hole_area_mm2 = 0;   // area of the added faces

  // Step 4 (and steps 2-3): pinch vertices of the raw faces that the cleaned region no longer has.
  int pinch_vertices_fixed = 0;
  int pinch_faces_removed = 0;     // faces removed by step 4 (smaller fans and pieces cut loose)
  int pinch_vertices_removed = 0;  // vertices lost with them
  double pinch_area_mm2 = 0;

  // Net difference to the label.
  int label_vertices_outside = 0;  // label vertices not in the cleaned region (incl. those in no whole face)
  int vertices_outside_label = 0;  // cleaned region vertices not in the label

  // Holes left (enclosed by a boundary loop other than the outer one, too large to fill).
  int holes_unfilled = 0;
  double largest_unfilled_hole_mm2 = 0;
  int largest_unfilled_hole_vertices = 0;  // its vertices not on the region
  // Of the area the filling rule compares holes with (the kept piece before filling), so a hole
  // reported too large is at least max_hole_fraction of it.
  double largest_unfilled_hole_fraction = 0;
  double fill_rule_area_mm2 = 0;
  // When the result is not one disk: what is wrong with the surface itself (non-manifold,
  // inconsistently oriented or repeated triangles), which the region would show as holes and
  // loops; "" when the surface is clean. Measured only on failure.
  std::string surface_damage;

  bool is_disk() const { return F.rows() > 0 && topology.is_disk() && topology.is_oriented(); }
  bool changed() const { return islands_dropped + holes_filled + pinch_faces_removed > 0; }
  // One line, e.g. "filled 3 holes (12 vertices, 4.1 mm^2), dropped 2 islands (5 vertices, 1.2 mm^2),
  // fixed 1 pinch vertex (removed 1 face, 0 vertices, 0.2 mm^2)", or "no cleanup needed".
  std::string summary() const;
  // Empty when is_disk(); otherwise why not, for an InputError message: "the region is not one disk
  // after cleanup (<topology summary>); 1 hole was too large to fill, the largest 336.2 mm^2
  // (1.38 % of the region before filling, 17 vertices; holes below 1 % of the region are filled)", then
  // "; cleanup: <summary()>" when something was changed.
  std::string problem() const;
  // Empty unless an island of at least max_hole_fraction of the kept piece was dropped: then the
  // label is more than one piece of cortex (a map of the largest would leave the others out
  // without a word), e.g. "the region is 2 pieces: an island of 46356.6 mm^2 (97.3 % of the
  // largest piece, 70351 vertices) would be left out; ...".
  std::string pieces_problem() const;
};

RegionCleanup region_faces_from_vertices(const MatrixXd& V, const MatrixXi& F, const std::vector<bool>& in_region,
                                         const RegionCleanupOptions& opt = {});


}  // namespace authalic

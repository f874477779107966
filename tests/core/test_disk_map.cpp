// The disk domain (issue 18 part 2): Shirley & Chiu's concentric map and its inverse, the disk's
// equal-area element cells (exact clipping through the concentric map), and the authalic disk map
// (core/disk_map.h) on small meshes with known answers.
#include <gtest/gtest.h>

#include <cmath>

#include "common/hard_meshes.h"
#include "core/concentric_map.h"
#include "core/disk_map.h"
#include "core/domain.h"
#include "core/metrics.h"

using namespace authalic;

TEST(ConcentricMap, InverseUndoesTheMapAndTheSquaresBoundaryIsTheCircle) {
  double worst = 0;
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j) {
      const double a = -1 + i / 20.0, b = -1 + j / 20.0;
      const Eigen::Vector2d d = concentric_square_to_disk(a, b);
      const Eigen::Vector2d s = concentric_disk_to_square(d.x(), d.y());
      worst = std::max(worst, (s - Eigen::Vector2d(a, b)).norm());
      // Concentric squares go to concentric circles: |d| = max(|a|, |b|).
      EXPECT_NEAR(d.norm(), std::max(std::abs(a), std::abs(b)), 1e-12);
    }
  EXPECT_LT(worst, 1e-12);
  // The middle of the top side (the frontal pole of a square map) goes to the top of the disk.
  EXPECT_LT((concentric_square_to_disk(0, 1) - Eigen::Vector2d(0, 1)).norm(), 1e-15);
  EXPECT_LT((concentric_disk_to_square(0, -1) - Eigen::Vector2d(0, -1)).norm(), 1e-15);
}

TEST(DiskDomain, ParsesAndPlacesPointsInTheCarriedCells) {
  EXPECT_EQ(parse_domain_kind("disk", "--domain"), DomainKind::Disk);
  const Domain d = Domain::disk();
  EXPECT_EQ(d.element_cols(8), 8);
  EXPECT_EQ(d.element_rows(8), 8);
  EXPECT_NEAR(d.area(), M_PI, 1e-15);
  // (0, 0.999) lies at the top of the disk: the square's top row, middle columns.
  const double top[2] = {0.0, 0.999};
  EXPECT_EQ(d.element_of_point(8, top), 7 * 8 + 4);
  const double left[2] = {-0.999, 0.001};
  EXPECT_EQ(d.element_of_point(8, left), 4 * 8 + 0);
  const Eigen::Vector3d out = d.constrain(Eigen::Vector3d(3, 4, 0));
  EXPECT_NEAR(out.x(), 0.6, 1e-15);
  EXPECT_NEAR(out.y(), 0.8, 1e-15);
}

TEST(DiskGridOverlap, AFlatDiskGivesEveryInnerCellExactlyItsShare) {
  // The disk mapped to itself: a cell's cortical area is the cell's own area, π / K², exactly,
  // for every cell away from the inscribed polygon's chords.
  const TriMesh m = test::uneven_disk(24, 96);
  const MatrixXd D = m.V.leftCols(2);
  const int k = 8;
  const auto pieces = disk_grid_overlap(D, m.F, k, k);
  const VectorXd a3 = face_areas(m.V, m.F);
  // Each face's pieces add up to its disk area (edges followed to 1e-11).
  const VectorXd per_face = piece_face_areas(pieces, static_cast<int>(m.F.rows()));
  EXPECT_LT((per_face - a3).cwiseAbs().maxCoeff(), 1e-9);
  const VectorXd cells = cell_surface_areas(pieces, a3, per_face, k * k);
  int inner = 0;
  for (int row = 0; row < k; ++row)
    for (int col = 0; col < k; ++col) {
      // Cells whose square lies within max(|a|, |b|) <= 0.75: well inside the polygon (radius > 0.999).
      const double a0 = -1 + 2.0 * col / k, a1 = a0 + 2.0 / k, b0 = -1 + 2.0 * row / k, b1 = b0 + 2.0 / k;
      if (std::max({std::abs(a0), std::abs(a1), std::abs(b0), std::abs(b1)}) > 0.75) continue;
      ++inner;
      // Curves followed to 1e-11, at most 7 bisections: 2e-7 at the centre, where the sectors meet.
      EXPECT_NEAR(cells[row * k + col] / (M_PI / (k * k)), 1.0, 1e-6) << row << " " << col;
    }
  EXPECT_EQ(inner, 36);
  // Nothing outside the disk; the chords lose only their thin segments.
  EXPECT_NEAR(cells.sum(), a3.sum(), 1e-9);
  EXPECT_GT(cells.sum(), M_PI * (1 - 1e-3));
}

TEST(DiskMap, CarriesTheSquareMapAndEndsAuthalicOnACurvedPatch) {
  TriMesh m = test::folded_patch(30);
  SquareMapOptions so;
  so.flow.grid.resolution = 256;
  const SquareMapResult square = square_map(m.V, m.F, so);
  DiskMapReport rep;
  const SquareMapResult disk = disk_map(m.V, m.F, so, {}, &rep);
  EXPECT_EQ(disk.flips, 0);
  EXPECT_EQ(rep.flips, 0);
  // The boundary is the square map's, carried: by arc length on the circle, the square's top
  // middle at the top of the disk. The polish holds it; only the final cell pass, when kept, slides
  // it along the circle, by a small fraction of an element (here a 1/8 cell spans 0.785 rad).
  int on_circle = 0;
  double slide = 0;
  for (Eigen::Index v = 0; v < square.UV.rows(); ++v) {
    if (square.side_mask[v] == 0) continue;
    ++on_circle;
    const Eigen::Vector2d want = concentric_square_to_disk(2 * square.UV(v, 0) - 1, 2 * square.UV(v, 1) - 1).normalized();
    EXPECT_NEAR(disk.UV.row(v).norm(), 1.0, 1e-12) << v;
    slide = std::max(slide, (disk.UV.row(v).transpose() - want).norm());
  }
  EXPECT_GT(on_circle, 100);
  EXPECT_LT(slide, rep.cell_pass_kept ? 0.01 : 1e-12) << "cell pass kept: " << rep.cell_pass_kept;
  // Authalic on the disk: the element areas and the per-face areas.
  const MapMetrics mm = map_metrics(disk.V, disk.UV, disk.F, Domain::disk(), 8);
  EXPECT_EQ(mm.flips, 0);
  EXPECT_LT(mm.element_cv, 0.01);
  EXPECT_LT(mm.face_ln_area.mean, 0.02);
  EXPECT_LT(rep.face_error, rep.carried_face_error);
  EXPECT_NEAR(mm.domain_area, M_PI, 0.01);
}

TEST(DiskMap, SplitsLongBoundaryChordsOntoTheCircle) {
  // A coarse boundary (12 sides): every chord spans 30 degrees, far beyond 2π/256, so each boundary
  // edge is split into equal arcs whose new vertices lie on the circle and on the 3D edge.
  TriMesh m = test::uneven_disk(6, 12);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) m.V(v, 2) = 0.3 * m.V(v, 0) * m.V(v, 0);
  SquareMapOptions so;
  so.flow.grid.resolution = 64;
  DiskMapReport rep;
  const SquareMapResult r = disk_map(m.V, m.F, so, {}, &rep);
  EXPECT_GT(rep.inserted_vertices, 12 * 5);
  EXPECT_EQ(r.flips, 0);
  const Eigen::Index n0 = r.V.rows() - rep.inserted_vertices;
  for (Eigen::Index v = n0; v < r.V.rows(); ++v) EXPECT_NEAR(r.UV.row(v).norm(), 1.0, 1e-12) << v;
  // The polygon now misses almost nothing of the disk.
  EXPECT_GT(signed_face_areas_2d(r.UV, r.F).sum(), M_PI * (1 - 1e-3));
  // The inserted vertices are recorded like the square's corner splits (parents and weights).
  EXPECT_EQ(r.initial.inserted_parents.rows(), r.initial.inserted_weight.size());
  EXPECT_GE(r.initial.inserted_parents.rows(), rep.inserted_vertices);
}

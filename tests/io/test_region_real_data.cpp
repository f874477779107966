// The real cortex labels of ../shared/data (fs741: a FreeSurfer 7.4.1 subject at native
// resolution, its ?h.cortex.label and a 96 % shape mask) become one disk with the region cleanup
// (core/region.h), changing little: the measured counts are pinned so a change in the cleanup
// shows up here. Maps are not run (that is the map tests' business).
#include <gtest/gtest.h>

#include "common/test_data.h"
#include "core/region.h"
#include "io/surface_io.h"

using namespace authalic;

namespace {

// The fs741 white surface, read once for the tests of this file (~1 s).
const io::Surface& fs741_white(const std::string& path) {
  static const io::Surface s = io::read_surface(path);
  return s;
}

RegionCleanup cleanup_of(const io::Surface& s, const std::string& label_path) {
  const int n = s.mesh.num_vertices();
  std::vector<bool> in(static_cast<std::size_t>(n), false);
  for (int v : io::read_region_vertices(label_path, n)) in[v] = true;
  return region_faces_from_vertices(s.mesh.V, s.mesh.F, in);
}

void expect_small_disk_cleanup(const RegionCleanup& r, const std::string& what) {
  EXPECT_TRUE(r.is_disk()) << what << ": " << r.problem();
  EXPECT_EQ(r.topology.num_components, 1) << what;
  EXPECT_EQ(r.topology.num_boundary_loops, 1) << what;
  EXPECT_EQ(r.topology.euler_characteristic, 1) << what;
  EXPECT_TRUE(r.topology.is_manifold()) << what;
  // Little changed: under 0.5 % of the label's area either way.
  EXPECT_LT(r.hole_area_mm2 + r.island_area_mm2 + r.pinch_area_mm2, 0.005 * r.area_mm2) << what << ": " << r.summary();
}

}  // namespace

TEST(RegionRealData, Fs741CortexLabelIsOneDisk) {
  AUTHALIC_REQUIRE_SHARED(white, "fs741/lh.white.surf.gii");
  AUTHALIC_REQUIRE_SHARED(label, "fs741/lh.cortex.label");
  const RegionCleanup r = cleanup_of(fs741_white(white), label);
  expect_small_disk_cleanup(r, "fs741 lh.cortex.label");
  // Measured: the label's whole faces are already one disk (its README: holes filled when it was
  // derived), so nothing changes.
  EXPECT_EQ(r.label_vertices, 147976);
  EXPECT_EQ(r.raw_faces, 295309);
  EXPECT_EQ(r.F.rows(), r.raw_faces);
  EXPECT_FALSE(r.changed()) << r.summary();
  EXPECT_EQ(r.label_vertices_outside, 0);
  EXPECT_EQ(r.vertices_outside_label, 0);
}

TEST(RegionRealData, Fs741Cortex96MaskIsOneDisk) {
  AUTHALIC_REQUIRE_SHARED(white, "fs741/lh.white.surf.gii");
  AUTHALIC_REQUIRE_SHARED(mask, "fs741/lh.cortex96_mask.shape.gii");
  const RegionCleanup r = cleanup_of(fs741_white(white), mask);
  expect_small_disk_cleanup(r, "fs741 lh.cortex96_mask.shape.gii");
  // Measured: one disk as it is; its outer side (the pinned medial wall, 4 % of the white area) is
  // the largest side and stays out.
  EXPECT_EQ(r.label_vertices, 158403);
  EXPECT_EQ(r.raw_faces, 316436);
  EXPECT_EQ(r.F.rows(), r.raw_faces);
  EXPECT_FALSE(r.changed()) << r.summary();
  EXPECT_EQ(r.label_vertices_outside, 0);
}

TEST(RegionRealData, Fs741RawCortexWithFreeSurferDefectsCleansToThe96Mask) {
  // The raw cortex the 96 % mask was derived from (shared/data/README.md): vertices where the pial
  // surface is not pinned onto the white one, |pial - white| > 0.8 mm. Like a FreeSurfer label it
  // has small holes, islands and pinch vertices; cleaned, it is one disk with exactly the mask's faces.
  AUTHALIC_REQUIRE_SHARED(white, "fs741/lh.white.surf.gii");
  AUTHALIC_REQUIRE_SHARED(pial, "fs741/lh.pial.surf.gii");
  AUTHALIC_REQUIRE_SHARED(mask, "fs741/lh.cortex96_mask.shape.gii");
  const io::Surface& w = fs741_white(white);
  const io::Surface p = io::read_surface(pial);
  const int n = w.mesh.num_vertices();
  std::vector<bool> in(static_cast<std::size_t>(n));
  for (int v = 0; v < n; ++v) in[v] = (p.mesh.V.row(v) - w.mesh.V.row(v)).norm() > 0.8;
  const RegionCleanup r = region_faces_from_vertices(w.mesh.V, w.mesh.F, in);
  ASSERT_FALSE(analyze_topology(w.mesh.V, [&] {
                 MatrixXi F(r.raw_faces, 3);
                 for (int f = 0, k = 0; f < w.mesh.num_faces(); ++f)
                   if (in[w.mesh.F(f, 0)] && in[w.mesh.F(f, 1)] && in[w.mesh.F(f, 2)]) F.row(k++) = w.mesh.F.row(f);
                 return F;
               }()).is_disk());
  expect_small_disk_cleanup(r, "fs741 |pial - white| > 0.8 mm");
  // Measured.
  EXPECT_EQ(r.label_vertices, 158398);
  EXPECT_EQ(r.raw_pinch_vertices, 8);
  EXPECT_EQ(r.holes_filled, 15);
  EXPECT_EQ(r.hole_vertices_added, 110);
  EXPECT_NEAR(r.hole_area_mm2, 128.1, 0.05);
  EXPECT_EQ(r.islands_dropped, 2);
  EXPECT_EQ(r.island_vertices, 90);
  EXPECT_NEAR(r.island_area_mm2, 18.8, 0.05);
  EXPECT_EQ(r.pinch_vertices_fixed, 8);
  EXPECT_EQ(r.pinch_faces_removed, 0);
  // The same faces as the shared mask's.
  const RegionCleanup m = cleanup_of(w, mask);
  ASSERT_FALSE(m.changed());
  EXPECT_EQ(r.face_index, m.face_index);
}

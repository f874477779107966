// The hard-mesh generators (tests/common/hard_meshes.h) have the topology they claim, so the map
// tests that feed them to the flatteners test refusals and repairs, not broken fixtures.
#include <gtest/gtest.h>

#include "common/hard_meshes.h"

using namespace authalic;
using namespace authalic::test;

TEST(HardMeshes, ValidOnesAreOrientedDisks) {
  for (const TriMesh& m : {uneven_disk(), folded_patch(20), protrusion_patch(), noisy_patch(), sliver_patch(), comb_patch()}) {
    const TopologyReport r = analyze_topology(m.V, m.F);
    EXPECT_TRUE(r.is_disk()) << r.summary();
    EXPECT_TRUE(r.is_oriented()) << r.summary();
    EXPECT_EQ(r.degenerate_faces, 0) << r.summary();
  }
}

TEST(HardMeshes, UnevenDiskSpansThreeOrdersOfMagnitude) {
  const TriMesh m = uneven_disk();
  const VectorXd a = face_areas(m.V, m.F);
  EXPECT_GT(a.maxCoeff() / a.minCoeff(), 1000.0);
}

TEST(HardMeshes, SliverPatchHasAnglesBelowHalfADegree) {
  const TriMesh m = sliver_patch();
  EXPECT_LT(corner_angles(m.V, m.F).minCoeff(), 0.5 * M_PI / 180);
}

TEST(HardMeshes, InvalidOnesHaveTheirMeasuredTopology) {
  const TriMesh ann = annulus_patch();
  EXPECT_EQ(analyze_topology(ann.V, ann.F).num_boundary_loops, 2);
  const TriMesh two = two_component_patch();
  EXPECT_EQ(analyze_topology(two.V, two.F).num_components, 2);
  const TriMesh tor = torus_mesh();
  EXPECT_EQ(analyze_topology(tor.V, tor.F).genus, 1);
  const TriMesh nm = non_manifold_patch();
  EXPECT_EQ(analyze_topology(nm.V, nm.F).non_manifold_edges, 1);
  const TriMesh mis = misoriented_patch();
  EXPECT_GT(analyze_topology(mis.V, mis.F).inconsistent_orientation_edges, 0);
  const TriMesh dup = duplicated_vertex_patch();
  EXPECT_EQ(analyze_topology(dup.V, dup.F).num_components, 2);
  // Exact merging of coincident vertices gives back one disk.
  const VectorXi rep = duplicate_vertices(dup.V);
  MatrixXi merged = dup.F;
  for (int f = 0; f < merged.rows(); ++f)
    for (int c = 0; c < 3; ++c) merged(f, c) = rep[merged(f, c)];
  EXPECT_TRUE(analyze_topology(dup.V, merged).is_disk()) << analyze_topology(dup.V, merged).summary();
}

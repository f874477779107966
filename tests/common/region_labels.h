#pragma once
// Vertex labels with the defects of real FreeSurfer cortex labels, on an icosphere "hemisphere"
// (radius 50 mm, so areas are in mm^2 of brain size), for the region cleanup tests
// (core/region.h). Each label is a cap (the "cortex", 80 % of the sphere; the rest is the
// "medial wall", by default) plus defects at known places, so the tests know the exact counts.
#include <algorithm>
#include <vector>

#include "common/hard_meshes.h"

namespace authalic::test {

struct DefectLabel {
  TriMesh mesh;
  std::vector<bool> in;          // per vertex: in the label
  int hole_vertex = -1;          // a cap vertex left out of the label (a 1-vertex hole)
  std::vector<int> big_hole;     // cap vertices left out (a hole above 1 % of the cap)
  std::vector<int> island;       // label vertices far out in the medial wall (a vertex and its ring)
  int bowtie = -1;               // cap vertex where a flap face touches the cap only at this vertex
  int flap[2] = {-1, -1};        // the flap's other two vertices (in the label)
};

inline int nearest_vertex(const TriMesh& m, Eigen::Vector3d dir) {
  dir.normalize();
  int best = 0;
  for (int v = 1; v < m.num_vertices(); ++v)
    if (m.V.row(v).dot(dir) > m.V.row(best).dot(dir)) best = v;
  return best;
}

// The icosphere (4 levels: 2562 vertices, 5120 faces) of radius 50 with the cap z > z0 R
// (z0 = -0.6: 80 % of the sphere).
inline DefectLabel cap_label(double z0 = -0.6) {
  DefectLabel d;
  d.mesh = icosphere(4);
  d.mesh.V *= 50.0;
  d.in.assign(static_cast<std::size_t>(d.mesh.num_vertices()), false);
  for (int v = 0; v < d.mesh.num_vertices(); ++v) d.in[v] = d.mesh.V(v, 2) > z0 * 50.0;
  return d;
}

// Cap with a 1-vertex hole, an island (a vertex and its one-ring in the medial wall) and a
// bow-tie: a flap face (b, x, y) whose x and y are in the label but none of their other
// neighbours is, so the flap touches the cap only at b.
inline DefectLabel cap_label_with_hole_island_bowtie(double z0 = -0.6) {
  DefectLabel d = cap_label(z0);
  const TriMesh& m = d.mesh;
  const auto ring = vertex_neighbours(m.F, m.num_vertices());
  d.hole_vertex = nearest_vertex(m, {0.3, 0.2, 0.93});
  d.in[d.hole_vertex] = false;
  const int pole = nearest_vertex(m, {0.1, 0.05, -1.0});
  d.island.push_back(pole);
  for (int w : ring[pole]) d.island.push_back(w);
  for (int v : d.island) d.in[v] = true;
  // The bow-tie on the cap's boundary toward +x: b is the boundary vertex nearest (1, 0, z0),
  // (b, x, y) a face at b with x, y outside the cap.
  const int b = [&] {
    int best = -1;
    const Eigen::Vector3d p = Eigen::Vector3d(1.0, 0.0, z0).normalized() * 50.0;
    for (int v = 0; v < m.num_vertices(); ++v) {
      if (!d.in[v]) continue;
      bool boundary = false;
      for (int w : ring[v]) boundary = boundary || !d.in[w];
      if (boundary && (best < 0 || (m.V.row(v).transpose() - p).norm() < (m.V.row(best).transpose() - p).norm())) best = v;
    }
    return best;
  }();
  for (int f = 0; f < m.num_faces() && d.bowtie < 0; ++f)
    for (int c = 0; c < 3; ++c)
      if (m.F(f, c) == b && !d.in[m.F(f, (c + 1) % 3)] && !d.in[m.F(f, (c + 2) % 3)]) {
        d.bowtie = b;
        d.flap[0] = m.F(f, (c + 1) % 3);
        d.flap[1] = m.F(f, (c + 2) % 3);
        break;
      }
  for (int x : d.flap)
    for (int w : ring[x])
      if (w != b && w != d.flap[0] && w != d.flap[1]) d.in[w] = false;
  for (int x : d.flap) d.in[x] = true;
  return d;
}

// Cap with a hole of every vertex within 9 mm of a cap point: above 1 % of the cap (1.4 % of the
// 80 % cap).
inline DefectLabel cap_label_with_big_hole(double z0 = -0.6) {
  DefectLabel d = cap_label(z0);
  const Eigen::Vector3d p = Eigen::Vector3d(0.3, 0.2, 0.93).normalized() * 50.0;
  for (int v = 0; v < d.mesh.num_vertices(); ++v)
    if ((d.mesh.V.row(v).transpose() - p).norm() < 9.0) {
      d.in[v] = false;
      d.big_hole.push_back(v);
    }
  return d;
}

}  // namespace authalic::test

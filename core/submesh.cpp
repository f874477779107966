// Submesh extraction with index maps, and midpoint subdivision.
#include "core/mesh.h"

namespace authalic {

Submesh submesh_from_faces(const TriMesh& parent, const std::vector<bool>& face_mask) {
  Submesh s;
  const Eigen::Index nv = parent.V.rows();
  s.parent_to_vertex = VectorXi::Constant(nv, -1);
  int kept_faces = 0;
  for (Eigen::Index f = 0; f < parent.F.rows(); ++f)
    if (face_mask[f]) ++kept_faces;
  std::vector<char> used(nv, 0);
  for (Eigen::Index f = 0; f < parent.F.rows(); ++f)
    if (face_mask[f])
      for (int c = 0; c < 3; ++c) used[parent.F(f, c)] = 1;
  int count = 0;
  for (Eigen::Index v = 0; v < nv; ++v)
    if (used[v]) s.parent_to_vertex[v] = count++;  // keep the parent's vertex order
  s.vertex_to_parent.resize(count);
  s.mesh.V.resize(count, parent.V.cols());
  for (Eigen::Index v = 0; v < nv; ++v)
    if (used[v]) {
      s.vertex_to_parent[s.parent_to_vertex[v]] = static_cast<int>(v);
      s.mesh.V.row(s.parent_to_vertex[v]) = parent.V.row(v);
    }
  s.mesh.F.resize(kept_faces, 3);
  s.face_to_parent.resize(kept_faces);
  int k = 0;
  for (Eigen::Index f = 0; f < parent.F.rows(); ++f) {
    if (!face_mask[f]) continue;
    for (int c = 0; c < 3; ++c) s.mesh.F(k, c) = s.parent_to_vertex[parent.F(f, c)];
    s.face_to_parent[k++] = static_cast<int>(f);
  }
  return s;
}

Submesh submesh_from_vertices(const TriMesh& parent, const std::vector<bool>& vertex_mask) {
  std::vector<bool> face_mask(parent.F.rows());
  for (Eigen::Index f = 0; f < parent.F.rows(); ++f)
    face_mask[f] = vertex_mask[parent.F(f, 0)] && vertex_mask[parent.F(f, 1)] && vertex_mask[parent.F(f, 2)];
  return submesh_from_faces(parent, face_mask);
}

TriMesh subdivide_midpoint(const TriMesh& mesh, int times) {
  TriMesh cur = mesh;
  for (int it = 0; it < times; ++it) {
    const int nv = cur.num_vertices();
    const EdgeTopology t = edge_topology(cur.F, nv);
    TriMesh next;
    next.V.resize(nv + t.E.rows(), cur.V.cols());
    next.V.topRows(nv) = cur.V;
    for (Eigen::Index e = 0; e < t.E.rows(); ++e) next.V.row(nv + e) = 0.5 * (cur.V.row(t.E(e, 0)) + cur.V.row(t.E(e, 1)));
    next.F.resize(cur.F.rows() * 4, 3);
    for (Eigen::Index f = 0; f < cur.F.rows(); ++f) {
      const int a = cur.F(f, 0), b = cur.F(f, 1), c = cur.F(f, 2);
      // FE(f, k) is the edge opposite corner k: mid of (b,c) is FE(f,0), (c,a) FE(f,1), (a,b) FE(f,2).
      const int bc = nv + t.FE(f, 0), ca = nv + t.FE(f, 1), ab = nv + t.FE(f, 2);
      next.F.row(4 * f + 0) << a, ab, ca;
      next.F.row(4 * f + 1) << b, bc, ab;
      next.F.row(4 * f + 2) << c, ca, bc;
      next.F.row(4 * f + 3) << ab, bc, ca;
    }
    cur = std::move(next);
  }
  return cur;
}

}  // namespace authalic

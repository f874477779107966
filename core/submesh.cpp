// Submesh extraction with index maps, and midpoint subdivision.
#include <string>
#include <unordered_map>

#include "core/error.h"
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

MatrixXi subdivide_midpoint_region(const TriMesh& mesh, const MatrixXi& region, int times) {
  MatrixXi full = mesh.F, part = region;
  int nv = mesh.num_vertices();
  for (int it = 0; it < times; ++it) {
    const EdgeTopology t = edge_topology(full, nv);
    // The full mesh's edge numbering decides the midpoints' indices (as in subdivide_midpoint).
    std::unordered_map<long long, int> edge_of;
    edge_of.reserve(static_cast<std::size_t>(t.E.rows()) * 2);
    auto key = [nv](int a, int b) { return static_cast<long long>(std::min(a, b)) * nv + std::max(a, b); };
    for (Eigen::Index e = 0; e < t.E.rows(); ++e) edge_of.emplace(key(t.E(e, 0), t.E(e, 1)), static_cast<int>(e));
    auto mid = [&](Eigen::Index f, int a, int b) {
      const auto found = edge_of.find(key(a, b));
      if (found == edge_of.end())
        throw InputError("face set: triangle " + std::to_string(f) + " uses the edge (" + std::to_string(a) + ", " +
                         std::to_string(b) + ") that the surface does not have; give a face set of the surface's own triangles");
      return nv + found->second;
    };
    MatrixXi next(part.rows() * 4, 3);
    for (Eigen::Index f = 0; f < part.rows(); ++f) {
      const int a = part(f, 0), b = part(f, 1), c = part(f, 2);
      const int ab = mid(f, a, b), bc = mid(f, b, c), ca = mid(f, c, a);
      next.row(4 * f + 0) << a, ab, ca;
      next.row(4 * f + 1) << b, bc, ab;
      next.row(4 * f + 2) << c, ca, bc;
      next.row(4 * f + 3) << ab, bc, ca;
    }
    part = std::move(next);
    if (it + 1 < times) full = subdivide_midpoint(TriMesh{MatrixXd::Zero(nv, 3), full}, 1).F;
    nv += static_cast<int>(t.E.rows());
  }
  return part;
}

}  // namespace authalic

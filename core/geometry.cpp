// Geometric quantities of triangle meshes: areas, cotangent Laplacian, mass matrix, normals.
#include <cmath>
#include <vector>

#include "core/mesh.h"

namespace authalic {

namespace {

Eigen::Vector3d row3(const MatrixXd& V, int i) {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int c = 0; c < std::min<int>(3, static_cast<int>(V.cols())); ++c) p[c] = V(i, c);
  return p;
}

double cot(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  // cot of the angle between a and b = (a.b)/|a x b|; guarded so a degenerate corner gives a
  // large finite weight rather than inf/NaN.
  const double c = a.cross(b).norm();
  return a.dot(b) / std::max(c, 1e-300);
}

}  // namespace

VectorXd face_areas(const MatrixXd& V, const MatrixXi& F) {
  VectorXd A(F.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = row3(V, F(f, 0)), b = row3(V, F(f, 1)), c = row3(V, F(f, 2));
    A[f] = 0.5 * (b - a).cross(c - a).norm();
  }
  return A;
}

VectorXd signed_face_areas_2d(const MatrixXd& V, const MatrixXi& F) {
  VectorXd A(F.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const double ux = V(F(f, 1), 0) - V(F(f, 0), 0), uy = V(F(f, 1), 1) - V(F(f, 0), 1);
    const double wx = V(F(f, 2), 0) - V(F(f, 0), 0), wy = V(F(f, 2), 1) - V(F(f, 0), 1);
    A[f] = 0.5 * (ux * wy - uy * wx);
  }
  return A;
}

VectorXd barycentric_vertex_areas(const MatrixXd& V, const MatrixXi& F) {
  // Zou et al. 2011 eq. 11: each face gives a third of its area to each corner. Accumulated
  // serially in face order so the sum does not depend on the thread count.
  const VectorXd fa = face_areas(V, F);
  VectorXd A = VectorXd::Zero(V.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) A[F(f, c)] += fa[f] / 3.0;
  return A;
}

SparseMatrix cotmatrix(const MatrixXd& V, const MatrixXi& F) {
  // L_ij = (cot alpha_ij + cot beta_ij)/2 (Zou eq. 12-14 without the 1/A_i, i.e. the FEM
  // stiffness matrix with libigl's sign), L_ii = -sum_j L_ij.
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<std::size_t>(F.rows()) * 12);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int i = F(f, c), j = F(f, (c + 1) % 3), k = F(f, (c + 2) % 3);
      // angle at k is opposite edge (i, j)
      const double w = 0.5 * cot(row3(V, i) - row3(V, k), row3(V, j) - row3(V, k));
      t.emplace_back(i, j, w);
      t.emplace_back(j, i, w);
      t.emplace_back(i, i, -w);
      t.emplace_back(j, j, -w);
    }
  }
  SparseMatrix L(V.rows(), V.rows());
  L.setFromTriplets(t.begin(), t.end());
  return L;
}

SparseMatrix massmatrix(const MatrixXd& V, const MatrixXi& F) {
  const VectorXd A = barycentric_vertex_areas(V, F);
  SparseMatrix M(V.rows(), V.rows());
  M.reserve(Eigen::VectorXi::Ones(V.rows()));
  for (Eigen::Index i = 0; i < V.rows(); ++i) M.insert(i, i) = A[i];
  M.makeCompressed();
  return M;
}

MatrixXd face_normals(const MatrixXd& V, const MatrixXi& F) {
  MatrixXd N(F.rows(), 3);
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = row3(V, F(f, 0)), b = row3(V, F(f, 1)), c = row3(V, F(f, 2));
    Eigen::Vector3d n = (b - a).cross(c - a);
    const double len = n.norm();
    N.row(f) = (len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero()).transpose();
  }
  return N;
}

MatrixXd vertex_normals(const MatrixXd& V, const MatrixXi& F) {
  // Area-weighted: the sum of unnormalised face normals (|n| = 2 * area). Serial accumulation
  // keeps the result independent of the thread count.
  MatrixXd N = MatrixXd::Zero(V.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = row3(V, F(f, 0)), b = row3(V, F(f, 1)), c = row3(V, F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) N.row(F(f, k)) += n.transpose();
  }
  for (Eigen::Index i = 0; i < N.rows(); ++i) {
    const double len = N.row(i).norm();
    if (len > 0) N.row(i) /= len;
  }
  return N;
}

MatrixXd corner_angles(const MatrixXd& V, const MatrixXi& F) {
  MatrixXd A(F.rows(), 3);
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d p = row3(V, F(f, c));
      const Eigen::Vector3d u = row3(V, F(f, (c + 1) % 3)) - p, w = row3(V, F(f, (c + 2) % 3)) - p;
      A(f, c) = std::atan2(u.cross(w).norm(), u.dot(w));
    }
  }
  return A;
}

}  // namespace authalic

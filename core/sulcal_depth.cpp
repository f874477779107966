// Sulcal-depth proxy: depth below an implicitly smoothed copy of the surface (see sulcal_depth.h).
#include "core/sulcal_depth.h"

#include <cmath>

#include "core/sparse_cholesky.h"

namespace authalic {

VectorXd sulcal_depth_proxy(const MatrixXd& V, const MatrixXi& F) {
  const Eigen::Index n = V.rows();
  VectorXd depth = VectorXd::Zero(n);
  if (n == 0 || F.rows() == 0) return depth;
  const VectorXd mass = barycentric_vertex_areas(V, F);
  const double total = mass.sum();
  if (!(total > 0)) return depth;
  const double t = std::pow(0.05 * std::sqrt(total), 2);
  // (M - t L) is symmetric positive definite on the used vertices; unused vertices get a unit
  // diagonal so the system stays regular (their rows are then just P = V).
  SparseMatrix A = -t * cotmatrix(V, F);
  for (Eigen::Index i = 0; i < n; ++i) A.coeffRef(i, i) += mass[i] > 0 ? mass[i] : 1.0;
  A.makeCompressed();
  MatrixXd rhs(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) rhs.row(i) = (mass[i] > 0 ? mass[i] : 1.0) * V.row(i).leftCols(3);
  // One sparse Cholesky factorisation for the three coordinates (core/sparse_cholesky.h). The
  // Jacobi-preconditioned CG it replaces (tolerance 1e-8) took about 600 iterations per
  // coordinate on a native hemisphere (t is about 200 squared edge lengths), a third of `run`'s
  // CPU on fs741 (the report shades both pial surfaces).
  const SpdSolver solver(A);
  if (!solver.ok()) return depth;
  const MatrixXd P = solver.solve(rhs);
  const MatrixXd N = vertex_normals(P, F);
  double sum = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(mass[i] > 0)) continue;
    // positive below the smoothed surface (in a sulcus), as FreeSurfer's sulc
    depth[i] = -(V.row(i).leftCols(3) - P.row(i)).dot(N.row(i));
    sum += mass[i] * depth[i];
  }
  const double mean = sum / total;
  for (Eigen::Index i = 0; i < n; ++i)
    if (mass[i] > 0) depth[i] -= mean;
  return depth;
}

}  // namespace authalic

#pragma once
// Inexact Levenberg-Marquardt steps for the per-face area polishes of the square, disk and sphere
// maps (core/authalic_flow.h, core/sphere_flow.h): min |J x + r|² where each row of J is one face
// and holds the derivatives of its residual by its vertices' free coordinates (at most 6).
#include <vector>

#include "core/mesh.h"

namespace authalic {

// A Jacobian stored by rows (compressed sparse rows), appended row by row: the polishes produce
// one row per face, in face order, so no triplet list or sort is needed.
class JacobianRows {
 public:
  explicit JacobianRows(Eigen::Index cols, std::size_t expected_rows = 0);
  void add(int col, double value) {  // an entry of the row being built
    col_.push_back(col);
    value_.push_back(value);
  }
  void end_row() { row_start_.push_back(static_cast<int>(col_.size())); }

  Eigen::Index rows() const { return static_cast<Eigen::Index>(row_start_.size()) - 1; }
  Eigen::Index cols() const { return cols_; }
  // y = Jᵀ x.
  VectorXd transpose_times(const Eigen::Ref<const VectorXd>& x) const;
  // y = Jᵀ (J x), one pass over the rows (each row's entries are read once): the products of
  // the conjugate-gradient iterations, which are memory-bound at a native mesh's size.
  void normal_times(const VectorXd& x, VectorXd& y) const;
  // diag(Jᵀ J).
  VectorXd normal_diagonal() const;

 private:
  // y += Jᵀ (J x) over rows [begin, end).
  void normal_times_rows(const VectorXd& x, VectorXd& y, Eigen::Index begin, Eigen::Index end) const;

  Eigen::Index cols_;
  std::vector<int> row_start_{0}, col_;
  std::vector<double> value_;
};

// One inexact Levenberg-Marquardt step for min |J x + r|²: (Jᵀ J + μ diag(Jᵀ J)) δ = −Jᵀ r with
// μ = 1e-3 (Marquardt's scaling), by at most cg_iterations Jacobi-preconditioned conjugate-gradient
// iterations (relative residual tolerance 1e-4, δ₀ = 0). The polishes' line searches keep only
// the steps that help, so an unconverged solve costs accuracy of a step, not safety. The result
// does not depend on the thread count.
VectorXd levenberg_marquardt_step(const JacobianRows& J, const Eigen::Ref<const VectorXd>& r, int cg_iterations);

}  // namespace authalic

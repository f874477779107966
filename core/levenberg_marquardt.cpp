#include "core/levenberg_marquardt.h"

#include <limits>

#include "core/run_beside.h"

namespace authalic {

namespace {
// Above this many rows the normal products run as two fixed halves, one per thread, each into its
// own sum (added in a fixed order: the same bits with one thread or two). Below it one pass.
constexpr Eigen::Index kSplitRows = 50000;
}  // namespace

JacobianRows::JacobianRows(Eigen::Index cols, std::size_t expected_rows) : cols_(cols) {
  row_start_.reserve(expected_rows + 1);
  col_.reserve(6 * expected_rows);
  value_.reserve(6 * expected_rows);
}

VectorXd JacobianRows::transpose_times(const Eigen::Ref<const VectorXd>& x) const {
  VectorXd y = VectorXd::Zero(cols_);
  for (Eigen::Index i = 0; i < rows(); ++i)
    for (int k = row_start_[i]; k < row_start_[i + 1]; ++k) y[col_[k]] += value_[k] * x[i];
  return y;
}

VectorXd JacobianRows::normal_diagonal() const {
  VectorXd d = VectorXd::Zero(cols_);
  for (std::size_t k = 0; k < col_.size(); ++k) d[col_[k]] += value_[k] * value_[k];
  return d;
}

void JacobianRows::normal_times_rows(const VectorXd& x, VectorXd& y, Eigen::Index begin, Eigen::Index end) const {
  for (Eigen::Index i = begin; i < end; ++i) {
    const int b = row_start_[i], e = row_start_[i + 1];
    double s = 0;
    for (int k = b; k < e; ++k) s += value_[k] * x[col_[k]];
    for (int k = b; k < e; ++k) y[col_[k]] += value_[k] * s;
  }
}

void JacobianRows::normal_times(const VectorXd& x, VectorXd& y) const {
  const Eigen::Index n = rows();
  y.setZero(cols_);
  if (n < kSplitRows) return normal_times_rows(x, y, 0, n);
  VectorXd second = VectorXd::Zero(cols_);
  run_beside([&] { normal_times_rows(x, y, 0, n / 2); }, [&] { normal_times_rows(x, second, n / 2, n); });
  y += second;
}

VectorXd levenberg_marquardt_step(const JacobianRows& J, const Eigen::Ref<const VectorXd>& r, int cg_iterations) {
  // Preconditioned CG on (Jᵀ J + μ D) δ = −Jᵀ r without forming Jᵀ J: each product is one pass
  // over J's rows (JacobianRows::normal_times).
  const Eigen::Index n = J.cols();
  const VectorXd d = J.normal_diagonal();
  const VectorXd shift = 1e-3 * d.array() + 1e-18;
  const VectorXd inv_m = (d + shift).cwiseInverse();
  const VectorXd b = -J.transpose_times(r);
  VectorXd x = VectorXd::Zero(n);
  const double threshold = std::max(1e-8 * b.squaredNorm(), std::numeric_limits<double>::min());
  VectorXd res = b;
  if (!(res.squaredNorm() >= threshold)) return x;
  VectorXd p = inv_m.cwiseProduct(res), z(n), Ap(n);
  double rz = res.dot(p);
  for (int it = 0; it < cg_iterations; ++it) {
    J.normal_times(p, Ap);
    Ap += shift.cwiseProduct(p);
    const double alpha = rz / p.dot(Ap);
    x += alpha * p;
    res -= alpha * Ap;
    if (res.squaredNorm() < threshold) break;
    z = inv_m.cwiseProduct(res);
    const double rz_new = res.dot(z);
    p = z + (rz_new / rz) * p;
    rz = rz_new;
  }
  return x;
}

}  // namespace authalic

// Shirley & Chiu's concentric map and its inverse (see core/concentric_map.h).
#include "core/concentric_map.h"

#include <cmath>

namespace authalic {

Eigen::Vector2d concentric_square_to_disk(double a, double b) {
  const double q = M_PI / 4.0;
  double r = 0, phi = 0;
  // The four triangular sectors of the square between its diagonals (eq. 4).
  if (a > -b) {
    if (a > b) {
      r = a, phi = q * (b / a);
    } else {
      r = b, phi = q * (2.0 - a / b);
    }
  } else {
    if (a < b) {
      r = -a, phi = q * (4.0 + b / a);
    } else {
      r = -b, phi = b != 0 ? q * (6.0 - a / b) : 0.0;
    }
  }
  return {r * std::cos(phi), r * std::sin(phi)};
}

Eigen::Vector2d concentric_disk_to_square(double x, double y) {
  // Inverse of eq. 4: r and φ in [−π/4, 7π/4), then the sector φ falls into.
  const double r = std::sqrt(x * x + y * y);
  if (!(r > 0)) return {0.0, 0.0};
  const double q = M_PI / 4.0;
  double phi = std::atan2(y, x);
  if (phi < -q) phi += 2.0 * M_PI;
  if (phi < q) return {r, r * phi / q};                       // a = r, b / a = φ / q
  if (phi < 3.0 * q) return {-r * (phi / q - 2.0), r};        // b = r, a / b = 2 − φ / q
  if (phi < 5.0 * q) return {-r, -r * (phi / q - 4.0)};       // a = −r, b / a = φ / q − 4
  return {r * (phi / q - 6.0), -r};                           // b = −r, a / b = 6 − φ / q
}

MatrixXd concentric_square_to_disk(const MatrixXd& P) {
  MatrixXd D(P.rows(), 2);
  for (Eigen::Index i = 0; i < P.rows(); ++i) D.row(i) = concentric_square_to_disk(P(i, 0), P(i, 1)).transpose();
  return D;
}

MatrixXd concentric_disk_to_square(const MatrixXd& D) {
  MatrixXd P(D.rows(), 2);
  for (Eigen::Index i = 0; i < D.rows(); ++i) P.row(i) = concentric_disk_to_square(D(i, 0), D(i, 1)).transpose();
  return P;
}

}  // namespace authalic

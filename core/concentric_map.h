#pragma once
// Shirley & Chiu's concentric map (Shirley & Chiu 1997, "A low distortion map between disk and
// square", eq. 4-5) between the square [−1, 1]^2 and the unit disk, and its inverse.
// The square's concentric squares go to concentric circles and area is scaled by π/4 everywhere
// (in the sector |a| > |b|: r = a, φ = (π/4) b/a, so dA = r dr dφ = (π/4) da db), so it carries an
// authalic map of the square to an authalic map of the disk. It is continuous, bijective and
// orientation-preserving; its derivative jumps across the square's diagonals (and it is not
// differentiable at the centre), so a straight triangle edge of one side is a curve on the other.
// The boundary goes to the boundary uniformly: arc length on a side is arc length on the circle.
#include <Eigen/Core>

#include "core/mesh.h"

namespace authalic {

// (a, b) in [−1, 1]^2 -> the unit disk.
Eigen::Vector2d concentric_square_to_disk(double a, double b);
// The unit disk -> [−1, 1]^2 (the exact inverse; points with r > 1 go outside the square).
Eigen::Vector2d concentric_disk_to_square(double x, double y);

// Row-wise versions: #P x 2 (extra columns ignored) -> #P x 2.
MatrixXd concentric_square_to_disk(const MatrixXd& P);
MatrixXd concentric_disk_to_square(const MatrixXd& D);

}  // namespace authalic

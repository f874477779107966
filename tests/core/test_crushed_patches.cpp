// Crushed patches of a sphere map (core/crushed_patches.h) and the per-face sphere polish that
// must open them (core/sphere_flow.h): known answers on a sphere crushed on purpose.
#include <gtest/gtest.h>

#include <cmath>

#include "common/hard_meshes.h"
#include "core/crushed_patches.h"
#include "core/sphere_flow.h"

using namespace authalic;
using authalic::test::icosphere;

namespace {

// The identity map of a fine icosphere with a cap about `c` squeezed radially: chord distances
// d < 0.1 scaled by 0.1 (the faces there keep 1 % of their area, ln ratio -4.6), then a linear
// blend of the scale to 1 at d = 0.3 (monotone, so no face flips). Outside 0.3 nothing moves.
MatrixXd crushed_map(const MatrixXd& V, const Eigen::Vector3d& c) {
  MatrixXd S = V;
  for (Eigen::Index v = 0; v < S.rows(); ++v) {
    const Eigen::Vector3d p = V.row(v).transpose();
    const double d = (p - c).norm();
    if (d >= 0.3 || d <= 0) continue;
    const double s = d < 0.1 ? 0.1 : 0.1 + 0.9 * (d - 0.1) / 0.2, R = s * d;
    const Eigen::Vector3d u = (p - p.dot(c) * c).normalized();
    const double theta = 2 * std::asin(0.5 * R);
    S.row(v) = (std::cos(theta) * c + std::sin(theta) * u).transpose();
  }
  return S;
}

// Share of the total target measure the faces below e^-2 of their share are missing.
double missing_share(const MatrixXd& S, const MatrixXi& F, const VectorXd& measure) {
  VectorXd a(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d p = S.row(F(f, 0)), q = S.row(F(f, 1)), r = S.row(F(f, 2));
    a[f] = 0.5 * (q - p).cross(r - p).norm();
  }
  a /= a.sum();
  const VectorXd t = measure / measure.sum();
  double m = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (a[f] < std::exp(-2.0) * t[f]) m += t[f] - a[f];
  return m;
}

}  // namespace

TEST(CrushedPatches, RadialRearrangementOpensASqueezedCapAndLeavesTheRestAlone) {
  const TriMesh m = icosphere(5);  // 20,480 faces
  const Eigen::Vector3d c = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  MatrixXd S = crushed_map(m.V, c);
  const VectorXd measure = face_areas(m.V, m.F);
  ASSERT_EQ(sphere_flipped_faces(S, m.F), 0);
  const double before = missing_share(S, m.F, measure);
  ASSERT_GT(before, 0.002);  // the cap d < 0.1 holds 0.25 % of the sphere's measure, in 1 % of its area

  CrushedPatchReport rep;
  MatrixXd out = S;
  inflate_crushed_patches(out, m.F, measure, {}, &rep);
  EXPECT_EQ(rep.patches, 1);
  EXPECT_EQ(rep.patches_undone, 0);
  EXPECT_NEAR(rep.missing_share, before, 1e-12);
  EXPECT_EQ(sphere_flipped_faces(out, m.F), 0);
  // The patch is opened (what is left is the window's even excess, not crushed faces) ...
  EXPECT_LT(missing_share(out, m.F, measure), 0.05 * before);
  // ... and vertices beyond the window do not move: it holds 40 x the missing share, about 10 %
  // of the sphere, a cap of chord radius about 0.63.
  int far_moved = 0;
  for (Eigen::Index v = 0; v < S.rows(); ++v)
    if ((m.V.row(v).transpose() - c).norm() > 1.2 && out.row(v) != S.row(v)) ++far_moved;
  EXPECT_EQ(far_moved, 0);
}

TEST(CrushedPatches, NothingCrushedNothingMoves) {
  const TriMesh m = icosphere(4);
  MatrixXd S = m.V;
  CrushedPatchReport rep;
  inflate_crushed_patches(S, m.F, face_areas(m.V, m.F), {}, &rep);
  EXPECT_EQ(rep.patches, 0);
  EXPECT_TRUE(S == m.V);
}

TEST(SpherePolish, LogResidualOpensCrushedFacesInsteadOfTradingThem) {
  // The polish's residual is √T ln(a/T): a face at 1 % of its area is far from its target in
  // that measure, and one Gauss-Newton step in it opens the squeezed cap. With the linear
  // residual (a − T)/√T, bounded by √T, one step left 40 % of the missing area (measured).
  const TriMesh m = icosphere(4);
  const Eigen::Vector3d c = Eigen::Vector3d(-0.2, 0.7, 0.4).normalized();
  MatrixXd S = crushed_map(m.V, c);
  const VectorXd measure = face_areas(m.V, m.F);
  const double before = missing_share(S, m.F, measure);
  ASSERT_GT(before, 0.002);
  polish_sphere_face_areas(S, m.F, measure, 1);
  EXPECT_EQ(sphere_flipped_faces(S, m.F), 0);
  EXPECT_LT(missing_share(S, m.F, measure), 0.1 * before);
}

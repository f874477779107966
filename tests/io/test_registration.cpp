// Rigid registration (io/registration.h, ITK v4 + Mattes MI) recovers a known rigid motion: the same
// synthetic head stored with a rotated and shifted affine must map back to within a millimetre.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "io/registration.h"

using namespace authalic;

namespace {

// A synthetic head: ellipsoids of different intensities (asymmetric, so no rotation is ambiguous).
io::Volume synthetic_head(const Eigen::Matrix4d& vox2ras) {
  io::Volume v;
  v.dims = {56, 64, 52};
  v.vox2ras = vox2ras;
  v.data.assign(v.num_voxels(), 0.0f);
  struct Blob { Eigen::Vector3d c, r; float value; };
  const Blob blobs[] = {{{0, 0, 0}, {62, 75, 60}, 1.0f},  // head
                        {{-20, 10, 5}, {18, 25, 15}, 3.0f},
                        {{25, -15, 10}, {12, 18, 22}, 2.0f},
                        {{5, 35, -20}, {10, 10, 8}, 4.0f}};
  for (int k = 0; k < v.dims[2]; ++k)
    for (int j = 0; j < v.dims[1]; ++j)
      for (int i = 0; i < v.dims[0]; ++i) {
        const Eigen::Vector3d x = (vox2ras * Eigen::Vector4d(i, j, k, 1)).head<3>();
        float value = 0;
        for (const Blob& b : blobs)
          if (((x - b.c).array() / b.r.array()).matrix().squaredNorm() <= 1.0) value += b.value;
        v.data[static_cast<std::size_t>(i) + 56u * (j + 64u * static_cast<std::size_t>(k))] = value;
      }
  return v;
}

}  // namespace

TEST(Registration, RecoversAKnownRigidMotion) {
  Eigen::Matrix4d A = Eigen::Matrix4d::Identity();
  A.block<3, 3>(0, 0) *= 3.0;
  A.block<3, 1>(0, 3) = Eigen::Vector3d(-82.5, -94.5, -76.5);
  const io::Volume t1 = synthetic_head(A);
  // The PET: the same voxels, stored with an affine rotated by 5 degrees about z and shifted.
  Eigen::Matrix4d R = Eigen::Matrix4d::Identity();
  const double a = 5.0 * M_PI / 180.0;
  R.block<3, 3>(0, 0) << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  R.block<3, 1>(0, 3) = Eigen::Vector3d(6, -4, 3);
  io::Volume pet = t1;
  pet.vox2ras = R * A;
  // A point at voxel index i is at A i in the T1 and at R A i in the PET: t1_to_pet = R.
  const io::RigidRegistration reg = io::register_rigid(t1, pet);
  double worst = 0;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(50, 0, 0), Eigen::Vector3d(0, 60, 0),
                                   Eigen::Vector3d(0, 0, 50), Eigen::Vector3d(-40, -40, 30)}) {
    const Eigen::Vector3d want = (R * p.homogeneous()).head<3>(), got = (reg.t1_to_pet * p.homogeneous()).head<3>();
    worst = std::max(worst, (want - got).norm());
  }
  EXPECT_LT(worst, 1.0) << "recovered:\n" << reg.t1_to_pet << "\nexpected:\n" << R << "\nstop: " << reg.stop_condition;
  EXPECT_GT(reg.iterations, 0);
  EXPECT_LT(reg.metric, 0.0);  // Mattes MI in ITK's sign convention: negative when aligned
  // Rigid: the rotation part stays orthonormal.
  EXPECT_LT((reg.t1_to_pet.block<3, 3>(0, 0) * reg.t1_to_pet.block<3, 3>(0, 0).transpose() - Eigen::Matrix3d::Identity()).norm(),
            1e-9);
}

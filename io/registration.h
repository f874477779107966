#pragma once
// Rigid registration of a PET to the subject's T1 (ITK v4, Mattes mutual information), for PET that
// is not already co-registered. Volumes are handed to ITK in memory.
#include <Eigen/Core>
#include <string>

#include "io/volume_io.h"

namespace authalic::io {

struct RigidRegistration {
  Eigen::Matrix4d t1_to_pet = Eigen::Matrix4d::Identity();  // T1 scanner RAS (mm) -> PET world RAS (mm)
  double metric = 0;            // final Mattes mutual information (ITK's sign: lower is better)
  int iterations = 0;           // optimizer iterations at the finest level
  std::string stop_condition;   // the optimizer's reason for stopping
};

// Registers `pet` (moving) to `t1` (fixed). Surface points in the T1's scanner RAS map to the PET's
// world coordinates by t1_to_pet. Throws ProcessingError when ITK fails.
RigidRegistration register_rigid(const Volume& t1, const Volume& pet);

}  // namespace authalic::io

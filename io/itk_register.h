#pragma once
// Internal bridge to ITK's registration (io/itk_register.cpp). No Eigen and no ITK types here (ITK's
// bundled Eigen must not meet the system Eigen in one translation unit): plain arrays cross.
#include <array>
#include <string>
#include <vector>

namespace authalic::io::detail {

struct PlainVolume {
  std::array<int, 3> dims{0, 0, 0};
  const std::vector<float>* data = nullptr;  // x fastest
  std::array<double, 16> vox2ras{};          // row-major 4x4, RAS
};

struct PlainRigidResult {
  std::array<double, 16> fixed_to_moving_ras{};  // row-major 4x4: fixed RAS (mm) -> moving RAS (mm)
  double metric = 0;                             // final Mattes mutual information (negative: better)
  int iterations = 0;                            // at the finest level
  std::string stop_condition;
};

// Rigid (Euler 3D) registration, Mattes mutual information, ITK v4 framework, 3 resolution levels.
PlainRigidResult itk_register_rigid(const PlainVolume& fixed, const PlainVolume& moving);

}  // namespace authalic::io::detail

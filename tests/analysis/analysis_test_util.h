#pragma once
// Shared fixtures of the analysis tests: a sphere mesh, volumes with known values.
#include <cmath>
#include <functional>

#include "core/mesh.h"
#include "io/volume_io.h"

namespace authalic::test {

// Octahedron subdivided `levels` times (midpoint), projected onto a sphere of `radius` around
// `centre`; faces counter-clockwise seen from outside.
inline TriMesh sphere_mesh(int levels, double radius, const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  TriMesh m;
  m.V.resize(6, 3);
  m.V << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
  m.F.resize(8, 3);
  m.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  m = subdivide_midpoint(m, levels);
  for (int v = 0; v < m.V.rows(); ++v) m.V.row(v) = centre.transpose() + radius * m.V.row(v).normalized();
  return m;
}

// A volume of dims with the given affine whose voxel values are f(world position of the voxel centre).
inline io::Volume function_volume(std::array<int, 3> dims, const Eigen::Matrix4d& vox2ras,
                                  const std::function<double(const Eigen::Vector3d&)>& f) {
  io::Volume vol;
  vol.dims = dims;
  vol.vox2ras = vox2ras;
  vol.data.resize(vol.num_voxels());
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i) {
        const Eigen::Vector3d w = (vox2ras * Eigen::Vector4d(i, j, k, 1)).head<3>();
        vol.data[static_cast<std::size_t>(i) + static_cast<std::size_t>(dims[0]) * (j + static_cast<std::size_t>(dims[1]) * k)] =
            static_cast<float>(f(w));
      }
  return vol;
}

// An oblique, radiological (negative x axis) affine with anisotropic voxels, centred near the origin.
inline Eigen::Matrix4d oblique_radiological_affine() {
  Eigen::Matrix4d A = Eigen::Matrix4d::Identity();
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.3, 0.5, 0.8).normalized())).toRotationMatrix();
  A.block<3, 3>(0, 0) = R * Eigen::Vector3d(-2.0, 1.5, 2.5).asDiagonal();
  A.block<3, 1>(0, 3) = Eigen::Vector3d(80, -70, -60);
  return A;
}

}  // namespace authalic::test

#pragma once
// Internal: per-format volume readers behind io/volume_io.h, and the frame handling they share.
#include <cstddef>
#include <functional>
#include <string>

#include "io/volume_io.h"

namespace authalic::io::detail {

// Largest volume (bytes of decoded voxels) a reader accepts. Protects against corrupt headers that
// declare absurd sizes; the fuzz targets lower it.
extern std::size_t g_max_volume_bytes;

// Fills volume->data from a file with `frames` frames of `voxels` voxels each (frame slowest),
// honouring options (one frame, or the sum of all). value(i) returns the scaled value of element
// i of the whole 4D array. A 4D file without a choice is an InputError naming the frame count.
void take_frames(const std::string& path, long long frames, std::size_t voxels, const std::function<float(std::size_t)>& value,
                 const VolumeReadOptions& options, Volume* volume);

// Throws unless the affine is finite and invertible.
void check_affine(const std::string& path, const Eigen::Matrix4d& vox2ras, const std::string& source);

Volume read_nifti(const std::string& path, const VolumeReadOptions& options);    // io/nifti_io.cpp
// NIfTI-1 float32 (nifti-clib 3.0 cannot be made to write a valid single-file NIfTI-2: measured).
void write_nifti1(const std::string& path, const Volume& volume, const NiftiWriteOptions& options);
Volume read_mgh(const std::string& path, const VolumeReadOptions& options);      // io/mgh_io.cpp
Volume parse_mgh(const std::string& bytes, const std::string& path, const VolumeReadOptions& options);
Volume read_dicom_series(const std::string& directory, const VolumeReadOptions& options);  // io/volume_io.cpp

}  // namespace authalic::io::detail

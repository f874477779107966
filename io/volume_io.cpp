// Volume dispatch (directory -> DICOM, magic/extension -> NIfTI or MGH), frame selection shared by
// all readers, and the bridge to the ITK/GDCM translation unit (io/itk_dicom.cpp).
#include "io/volume_io.h"

#include <Eigen/LU>

#include <cmath>
#include <filesystem>

#include "io/io_internal.h"
#include "io/itk_dicom.h"
#include "io/volume_formats.h"

namespace authalic::io {

namespace detail {

std::size_t g_max_volume_bytes = std::size_t(16) << 30;  // 16 GiB

void take_frames(const std::string& path, long long frames, std::size_t voxels, const std::function<float(std::size_t)>& value,
                 const VolumeReadOptions& options, Volume* volume) {
  if (frames < 1) frames = 1;
  if (options.frame >= 0 && options.sum_frames)
    fail(path, "both a frame and summing all frames were asked for", "choose one");
  if (frames > 1 && options.frame < 0 && !options.sum_frames)
    fail(path, "is 4D with " + std::to_string(frames) + " frames and no frame was chosen",
         "choose one frame (0.." + std::to_string(frames - 1) + ") or sum all frames (e.g. --frame N or --sum-frames)");
  if (options.frame >= frames)
    fail(path, "has " + std::to_string(frames) + " frame(s); frame " + std::to_string(options.frame) + " does not exist",
         "choose a frame between 0 and " + std::to_string(frames - 1));
  volume->data.assign(voxels, 0.0f);
  if (options.sum_frames && frames > 1) {
    // Sum in double, frame order fixed: deterministic and exact for any realistic frame count.
    std::vector<double> acc(voxels, 0.0);
    for (long long t = 0; t < frames; ++t)
      for (std::size_t i = 0; i < voxels; ++i) acc[i] += value(static_cast<std::size_t>(t) * voxels + i);
    for (std::size_t i = 0; i < voxels; ++i) volume->data[i] = static_cast<float>(acc[i]);
  } else {
    const std::size_t offset = static_cast<std::size_t>(std::max(options.frame, 0)) * voxels;
    for (std::size_t i = 0; i < voxels; ++i) volume->data[i] = value(offset + i);
  }
}

void check_affine(const std::string& path, const Eigen::Matrix4d& m, const std::string& source) {
  const double det = m.block<3, 3>(0, 0).determinant();
  if (!m.allFinite() || !std::isfinite(det) || std::abs(det) < 1e-12)
    fail(path, "the " + source + " affine is not finite or not invertible (zero voxel size?)",
         "fix the orientation in the header (e.g. with nibabel) and retry");
}

Volume read_dicom_series(const std::string& directory, const VolumeReadOptions& options) {
  const DicomSeries s = itk_read_dicom_series(directory);
  Volume v;
  v.dims = s.dims;
  v.source_path = directory;
  v.orientation_source = "dicom";
  v.source_series = s.series_uid + " '" + (s.series_description.empty() ? std::string("no description") : s.series_description) +
                    "' (" + (s.modality.empty() ? std::string("no modality") : s.modality) + ", " + std::to_string(s.num_files) +
                    (s.num_files == 1 ? " file)" : " files)");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) v.vox2ras(r, c) = s.vox2ras[4 * r + c];
  check_affine(directory, v.vox2ras, "DICOM");
  if (s.units == "BQML") v.units = "Bq/mL";
  else v.units = s.units;
  const std::size_t voxels = static_cast<std::size_t>(s.dims[0]) * s.dims[1] * s.dims[2];
  take_frames(directory, s.frames, voxels, [&](std::size_t i) { return s.data[i]; }, options, &v);
  return v;
}

}  // namespace detail

Volume read_volume(const std::string& path, const VolumeReadOptions& options) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return detail::read_dicom_series(path, options);
  detail::require_readable(path);
  const std::string name = detail::lower_filename(path);
  if (detail::ends_with(name, ".mgh") || detail::ends_with(name, ".mgz")) return detail::read_mgh(path, options);
  if (detail::ends_with(name, ".nii") || detail::ends_with(name, ".nii.gz") || detail::ends_with(name, ".hdr") ||
      detail::ends_with(name, ".img"))
    return detail::read_nifti(path, options);
  // Unknown extension: look at the content (NIfTI: sizeof_hdr 348 or 540 at offset 0; MGH: version 1).
  const std::string bytes = detail::read_file_maybe_gz(path);
  if (bytes.size() >= 4) {
    const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
    const std::uint32_t le = p[0] | (p[1] << 8) | (p[2] << 16) | (std::uint32_t(p[3]) << 24);
    const std::uint32_t be = (std::uint32_t(p[0]) << 24) | (p[1] << 16) | (p[2] << 8) | p[3];
    if (le == 348 || be == 348 || le == 540 || be == 540)
      detail::fail(path, "looks like NIfTI but has no .nii/.nii.gz extension", "rename it to .nii or .nii.gz (nifti-clib needs the extension)");
    if (be == 1) return detail::parse_mgh(bytes, path, options);
  }
  detail::fail(path, "unknown volume format", "give a NIfTI (.nii, .nii.gz), MGH/MGZ (.mgh, .mgz) or a folder with a DICOM series");
}

void write_nifti(const std::string& path, const Volume& volume, const std::string& description) {
  NiftiWriteOptions options;
  options.description = description;
  detail::write_nifti1(path, volume, options);
}

void write_nifti(const std::string& path, const Volume& volume, const NiftiWriteOptions& options) {
  detail::write_nifti1(path, volume, options);
}

void write_dicom_series(const std::string& directory, const Volume& volume) {
  if (volume.num_voxels() == 0 || volume.data.size() != volume.num_voxels())
    throw InputError(directory + ": volume data does not match its grid; nothing written");
  detail::check_affine(directory, volume.vox2ras, "affine");
  std::array<double, 16> m{};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[4 * r + c] = volume.vox2ras(r, c);
  detail::itk_write_dicom_series(directory, volume.dims, volume.data, m);
}

}  // namespace authalic::io

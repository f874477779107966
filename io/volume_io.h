#pragma once
// 3D/4D volumes (PET, MRI) from NIfTI-1/2 (nifti-clib), MGH/MGZ and DICOM series (ITK/GDCM).
#include <Eigen/Core>

#include <array>
#include <string>
#include <vector>

namespace authalic::io {

// A scalar volume in memory. Voxel (i,j,k) is data[i + nx*(j + ny*k)] (x fastest, as NIfTI).
// World coordinates are RAS mm (NIfTI/FreeSurfer scanner convention), so world = vox2ras * (i,j,k,1).
struct Volume {
  std::array<int, 3> dims{0, 0, 0};
  std::vector<float> data;                   // scaled values (scl_slope/inter applied)
  Eigen::Matrix4d vox2ras = Eigen::Matrix4d::Identity();
  std::string orientation_source;            // "sform", "qform", "mgh", "dicom", ...
  std::string source_path;
  std::string units;                         // e.g. "Bq/mL" when known, else ""
  std::string source_series;                 // DICOM: the series read, "UID 'description' (modality, N files)"
  std::size_t num_voxels() const { return static_cast<std::size_t>(dims[0]) * dims[1] * dims[2]; }
  float at(int i, int j, int k) const {
    return data[static_cast<std::size_t>(i) + static_cast<std::size_t>(dims[0]) * (j + static_cast<std::size_t>(dims[1]) * k)];
  }
  Eigen::Vector3d voxel_size() const {       // mm, column norms of the affine
    return vox2ras.block<3, 3>(0, 0).colwise().norm().transpose();
  }
};

struct VolumeReadOptions {
  int frame = -1;          // for 4D files: which frame (0-based); -1 = none chosen
  bool sum_frames = false; // for 4D files: sum all frames (e.g. a static image from dynamic frames)
  // authalic's element images (a grid on the map, not in a scanner; NiftiWriteOptions::map_grid):
  // accepted with their own affine (orientation_source "map grid") instead of refused, and so are
  // NIfTI files with no orientation (sform and qform codes 0, as element images were written
  // before): NIfTI's method 1 (diagonal pixdim affine, orientation_source "pixdim"). Never for a
  // PET, whose position matters.
  bool allow_map_grid = false;
};

// Reads NIfTI (.nii, .nii.gz), MGH/MGZ (.mgh, .mgz) or a DICOM series (a directory holding one PET
// series, or one series of any modality; several candidates, missing slices, uneven spacing, gantry
// tilt and repeated positions are refused; ITK/GDCM, LPS converted to RAS). The affine is
// the sform when its code is > 0, else the qform when > 0 (stated in orientation_source); a file
// with neither is refused. A 4D file needs options.frame or options.sum_frames.
Volume read_volume(const std::string& path, const VolumeReadOptions& options = {});

// Writes a DICOM series (one file per slice, int16 with a rescale slope, PET modality) into the
// folder `directory` (created if needed). For tests and phantoms: real PET comes from scanners.
void write_dicom_series(const std::string& directory, const Volume& volume);

// ---- MGH/MGZ (FreeSurfer volumes) ---------------------------------------------------------
// Header of an .mgh/.mgz file (FreeSurfer's utils/mghendian/mri_identify: big-endian, 284 bytes).
struct MghHeader {
  std::array<int, 4> dims{0, 0, 0, 1};          // width, height, depth, frames
  int type = 3;                                  // 0 uchar, 1 int32, 3 float32, 4 int16
  bool good_ras = false;                         // goodRASflag: the orientation below is valid
  Eigen::Vector3d delta = Eigen::Vector3d::Ones();  // voxel size (mm)
  Eigen::Matrix3d Mdc = Eigen::Matrix3d::Identity(); // columns: unit directions of the i, j, k axes in RAS
  Eigen::Vector3d c_ras = Eigen::Vector3d::Zero();   // scanner RAS of the volume centre
};
MghHeader read_mgh_header(const std::string& path);
// Scanner vox2ras: Mdc*diag(delta), with the centre voxel (dims/2) at c_ras.
Eigen::Matrix4d mgh_vox2ras(const MghHeader& header);
// tkregister vox2ras (FreeSurfer's MRIxfmCRS2XYZtkreg): the same with c_ras = 0.
Eigen::Matrix4d mgh_tkr_vox2ras(const MghHeader& header);
// tkregister RAS -> scanner RAS = vox2ras * inverse(tkr vox2ras) (a translation by c_ras).
// This is what takes FreeSurfer surface coordinates (lh.white) into the scanner space of the PET.
Eigen::Matrix4d mgh_tkr_to_scanner(const MghHeader& header);
// Writes float32 MGH (.mgh) or gzipped MGZ (.mgz) with the volume's affine. Atomic.
void write_mgh(const std::string& path, const Volume& volume);

// Writes NIfTI-1 float32 (.nii or .nii.gz) with sform = qform = vox2ras (code 2: aligned). Atomic.
void write_nifti(const std::string& path, const Volume& volume, const std::string& description = {});

// The text in an element image's header descrip that marks it as a grid on the map (with sform
// code NIFTI_XFORM_TEMPLATE_OTHER); read_volume refuses such an image unless allow_map_grid.
inline constexpr const char* kMapGridMarker = "map grid";
struct NiftiWriteOptions {
  std::string description;  // header descrip (the first 79 characters)
  // A grid that lives on a map (element images), not in a scanner: sform and qform code 5
  // (NIFTI_XFORM_TEMPLATE_OTHER: the element grid's own space, the same for every subject) with
  // the volume's affine, so every tool puts voxel (i, j, k) at the same place (with codes 0,
  // Workbench and nibabel fell back to different affines, x flipped in one); descrip carries
  // kMapGridMarker (prepended when the description lacks it).
  bool map_grid = false;
  int intent_code = 0;      // NIFTI_INTENT_*, e.g. 5 = NIFTI_INTENT_ZSCORE
  std::string intent_name;  // the first 15 characters
};
void write_nifti(const std::string& path, const Volume& volume, const NiftiWriteOptions& options);

}  // namespace authalic::io

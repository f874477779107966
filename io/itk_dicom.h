#pragma once
// Internal bridge to ITK/GDCM (io/itk_dicom.cpp). No Eigen and no ITK types here: ITK's bundled
// Eigen must not meet the system Eigen in one translation unit (measured), so data crosses as
// plain arrays.
#include <array>
#include <string>
#include <vector>

namespace authalic::io::detail {

struct DicomSeries {
  std::array<int, 3> dims{0, 0, 0};   // columns, rows, slices
  int frames = 1;                     // time frames found (slices / distinct positions)
  std::vector<float> data;            // rescaled values, x fastest, then y, z, frame
  std::array<double, 16> vox2ras{};   // row-major 4x4, RAS (converted from DICOM's LPS)
  std::string units;                  // (0054,1001) Units, e.g. "BQML"
  std::string modality;               // (0008,0060)
  std::string series_uid;             // (0020,000e) of the series read
  std::string series_description;     // (0008,103e)
  int num_files = 0;                  // files of the series read
  int num_series = 0;                 // series found in the folder
};

// True when the folder holds at least one DICOM file GDCM can read.
bool itk_is_dicom_directory(const std::string& directory);
// Reads the one series of the folder: its PET series (Modality PT) when it has any, else its only
// series; several candidates are refused with their list. Slice positions are checked along the
// orientation's normal (duplicates, uneven spacing, gantry tilt refused). Throws InputError naming
// the folder on failure.
DicomSeries itk_read_dicom_series(const std::string& directory);
// Writes one int16 file per slice with RescaleSlope/Intercept so the floats survive to 1/32000 of
// their range. Throws std::runtime_error naming the folder on failure.
void itk_write_dicom_series(const std::string& directory, const std::array<int, 3>& dims, const std::vector<float>& data,
                            const std::array<double, 16>& vox2ras);

}  // namespace authalic::io::detail

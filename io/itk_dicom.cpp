// DICOM series through ITK/GDCM. ITK code lives only in io/itk_*.cpp (its bundled Eigen breaks
// the system Eigen in one translation unit), so nothing here includes Eigen or core/mesh.h.
// DICOM patient coordinates are LPS (x to the patient's left, y posterior); the rest of Authalic
// uses RAS, so x and y flip sign: RAS = diag(-1, -1, 1) * LPS.
#include "io/itk_dicom.h"

#include <gdcmTrace.h>
#include <gdcmUIDGenerator.h>
#include <itkGDCMImageIO.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkImage.h>
#include <itkImageRegionConstIterator.h>
#include <itkImageSeriesReader.h>
#include <itkImageSeriesWriter.h>
#include <itkMetaDataObject.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>

#include "core/error.h"

namespace authalic::io::detail {

namespace {

using FloatImage = itk::Image<float, 3>;
using FloatSlice = itk::Image<float, 2>;

std::string dict_string(const itk::MetaDataDictionary& dict, const std::string& key) {
  std::string value;
  itk::ExposeMetaData<std::string>(dict, key, value);
  const std::size_t e = value.find_last_not_of(" \0", std::string::npos, 2);
  return e == std::string::npos ? std::string() : value.substr(0, e + 1);
}

[[noreturn]] void input_error(const std::string& dir, const std::string& problem, const std::string& hint) {
  throw InputError(dir + ": " + problem + "; " + hint);
}

std::string one_line(const std::string& s) {
  std::string out = s;
  std::replace(out.begin(), out.end(), '\n', ' ');
  std::replace(out.begin(), out.end(), '\r', ' ');
  if (out.size() > 300) out = out.substr(0, 300) + "...";
  return out;
}

}  // namespace

bool itk_is_dicom_directory(const std::string& directory) {
  auto names = itk::GDCMSeriesFileNames::New();
  names->SetDirectory(directory);
  return !names->GetSeriesUIDs().empty();
}

DicomSeries itk_read_dicom_series(const std::string& directory) {
  // GDCM and ITK print their warnings (private tags, odd spacing) on stderr before our one-line
  // error; what matters reaches the user through the exceptions caught below.
  gdcm::Trace::WarningOff();
  gdcm::Trace::DebugOff();
  gdcm::Trace::ErrorOff();
  itk::Object::GlobalWarningDisplayOff();
  DicomSeries out;
  std::vector<std::string> files;
  try {
    auto names = itk::GDCMSeriesFileNames::New();
    names->SetUseSeriesDetails(true);
    names->SetDirectory(directory);
    const std::vector<std::string>& uids = names->GetSeriesUIDs();
    out.num_series = static_cast<int>(uids.size());
    if (uids.empty())
      input_error(directory, "folder holds no DICOM series GDCM can read", "give the folder with the PET DICOM files, or a NIfTI");
    // Several series (e.g. CT + PET, or several reconstructions): take the one with the most files.
    std::size_t best = 0;
    for (const std::string& uid : uids) {
      const std::vector<std::string> f = names->GetFileNames(uid);
      if (f.size() > best) {
        best = f.size();
        files = f;
        out.series_uid = uid;
      }
    }
  } catch (const itk::ExceptionObject& e) {
    input_error(directory, "cannot list the DICOM files: " + one_line(e.GetDescription()), "check the folder");
  }
  using Reader = itk::ImageSeriesReader<FloatImage>;
  auto reader = Reader::New();
  auto io = itk::GDCMImageIO::New();
  reader->SetImageIO(io);
  reader->SetFileNames(files);
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    input_error(directory, "GDCM could not read the series: " + one_line(e.GetDescription()), "the DICOM files are corrupt or not an image series");
  }
  // Dynamic (4D) PET stores several frames at the same slice positions; the series reader would
  // stack them into one wrong 3D volume, so detect that and refuse clearly.
  std::set<std::string> positions;
  const Reader::DictionaryArrayType* dicts = reader->GetMetaDataDictionaryArray();
  if (dicts)
    for (const auto* d : *dicts)
      if (d) positions.insert(dict_string(*d, "0020|0032"));
  if (!positions.empty() && positions.size() < files.size())
    input_error(directory,
                "series has " + std::to_string(files.size()) + " files at only " + std::to_string(positions.size()) +
                    " slice positions (dynamic, multi-frame PET)",
                "convert it to a 4D NIfTI (e.g. dcm2niix) and choose a frame or sum the frames");

  FloatImage::Pointer image = reader->GetOutput();
  const auto region = image->GetLargestPossibleRegion();
  const auto size = region.GetSize();
  for (int d = 0; d < 3; ++d) out.dims[d] = static_cast<int>(size[d]);
  const auto spacing = image->GetSpacing();
  const auto origin = image->GetOrigin();
  const auto direction = image->GetDirection();
  // LPS affine: column c = direction(:, c) * spacing[c]; then flip the first two rows for RAS.
  const double flip[3] = {-1.0, -1.0, 1.0};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.vox2ras[4 * r + c] = flip[r] * direction(r, c) * spacing[c];
    out.vox2ras[4 * r + 3] = flip[r] * origin[r];
  }
  out.vox2ras[15] = 1.0;
  out.data.resize(static_cast<std::size_t>(size[0]) * size[1] * size[2]);
  // ITK buffers are x fastest, then y, then z: the same layout as authalic::io::Volume.
  std::copy(image->GetBufferPointer(), image->GetBufferPointer() + out.data.size(), out.data.begin());
  const itk::MetaDataDictionary& dict = io->GetMetaDataDictionary();
  out.units = dict_string(dict, "0054|1001");
  out.modality = dict_string(dict, "0008|0060");
  out.frames = 1;
  return out;
}

void itk_write_dicom_series(const std::string& directory, const std::array<int, 3>& dims, const std::vector<float>& data,
                            const std::array<double, 16>& vox2ras) {
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec) throw std::runtime_error(directory + ": cannot create the folder: " + ec.message());
  // int16 with one rescale slope for the series: values = stored * slope + intercept.
  float lo = 0, hi = 0;
  bool first = true;
  for (const float x : data)
    if (std::isfinite(x)) {
      lo = first ? x : std::min(lo, x);
      hi = first ? x : std::max(hi, x);
      first = false;
    }
  const double intercept = 0.0;
  const double max_abs = std::max(std::abs(static_cast<double>(lo)), std::abs(static_cast<double>(hi)));
  const double slope = max_abs > 0 ? max_abs / 32000.0 : 1.0;

  // The image holds real values; GDCMImageIO applies the inverse of the rescale given in the
  // dictionary on write (ITK >= 4.7), storing int16.
  auto image = FloatImage::New();
  FloatImage::RegionType region;
  FloatImage::SizeType size;
  for (int d = 0; d < 3; ++d) size[d] = static_cast<itk::SizeValueType>(dims[d]);
  region.SetSize(size);
  image->SetRegions(region);
  FloatImage::SpacingType spacing;
  FloatImage::PointType origin;
  FloatImage::DirectionType direction;
  const double flip[3] = {-1.0, -1.0, 1.0};
  for (int c = 0; c < 3; ++c) {
    double norm = 0;
    for (int r = 0; r < 3; ++r) norm += vox2ras[4 * r + c] * vox2ras[4 * r + c];
    spacing[c] = std::sqrt(norm);
    for (int r = 0; r < 3; ++r) direction(r, c) = flip[r] * vox2ras[4 * r + c] / spacing[c];
  }
  for (int r = 0; r < 3; ++r) origin[r] = flip[r] * vox2ras[4 * r + 3];
  image->SetSpacing(spacing);
  image->SetOrigin(origin);
  image->SetDirection(direction);
  image->Allocate();
  float* buffer = image->GetBufferPointer();
  for (std::size_t i = 0; i < data.size(); ++i) buffer[i] = std::isfinite(data[i]) ? data[i] : 0.0f;

  gdcm::UIDGenerator uid;
  const std::string study = uid.Generate();
  const std::string series = uid.Generate();
  const std::string frame_of_reference = uid.Generate();
  auto io = itk::GDCMImageIO::New();
  io->KeepOriginalUIDOn();
  std::vector<itk::MetaDataDictionary> dictionaries(static_cast<std::size_t>(dims[2]));
  std::vector<itk::MetaDataDictionary*> pointers;
  std::vector<std::string> names;
  auto num = [](double v) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.10g", v);
    return std::string(buf);
  };
  for (int k = 0; k < dims[2]; ++k) {
    itk::MetaDataDictionary& d = dictionaries[static_cast<std::size_t>(k)];
    FloatImage::IndexType index{{0, 0, k}};
    FloatImage::PointType p;
    image->TransformIndexToPhysicalPoint(index, p);
    itk::EncapsulateMetaData<std::string>(d, "0008|0060", "PT");
    itk::EncapsulateMetaData<std::string>(d, "0008|0016", "1.2.840.10008.5.1.4.1.1.128");  // PET Image Storage
    itk::EncapsulateMetaData<std::string>(d, "0008|0018", uid.Generate());
    itk::EncapsulateMetaData<std::string>(d, "0020|000d", study);
    itk::EncapsulateMetaData<std::string>(d, "0020|000e", series);
    itk::EncapsulateMetaData<std::string>(d, "0020|0052", frame_of_reference);
    itk::EncapsulateMetaData<std::string>(d, "0010|0010", "AUTHALIC^PHANTOM");
    itk::EncapsulateMetaData<std::string>(d, "0010|0020", "phantom");
    itk::EncapsulateMetaData<std::string>(d, "0008|103e", "authalic test series");
    itk::EncapsulateMetaData<std::string>(d, "0020|0013", std::to_string(k + 1));
    itk::EncapsulateMetaData<std::string>(d, "0020|0032", num(p[0]) + "\\" + num(p[1]) + "\\" + num(p[2]));
    itk::EncapsulateMetaData<std::string>(d, "0020|0037",
                                          num(direction(0, 0)) + "\\" + num(direction(1, 0)) + "\\" + num(direction(2, 0)) + "\\" +
                                              num(direction(0, 1)) + "\\" + num(direction(1, 1)) + "\\" + num(direction(2, 1)));
    itk::EncapsulateMetaData<std::string>(d, "0028|0030", num(spacing[1]) + "\\" + num(spacing[0]));
    itk::EncapsulateMetaData<std::string>(d, "0018|0050", num(spacing[2]));
    itk::EncapsulateMetaData<std::string>(d, "0028|1052", num(intercept));
    itk::EncapsulateMetaData<std::string>(d, "0028|1053", num(slope));
    itk::EncapsulateMetaData<std::string>(d, "0054|1001", "BQML");
    itk::EncapsulateMetaData<std::string>(d, "0028|0100", "16");  // bits allocated
    itk::EncapsulateMetaData<std::string>(d, "0028|0101", "16");  // bits stored
    itk::EncapsulateMetaData<std::string>(d, "0028|0102", "15");  // high bit
    itk::EncapsulateMetaData<std::string>(d, "0028|0103", "1");   // signed
    pointers.push_back(&d);
    char name[64];
    std::snprintf(name, sizeof(name), "slice%04d.dcm", k + 1);
    names.push_back((std::filesystem::path(directory) / name).string());
  }
  auto writer = itk::ImageSeriesWriter<FloatImage, FloatSlice>::New();
  writer->SetInput(image);
  writer->SetImageIO(io);
  writer->SetFileNames(names);
  writer->SetMetaDataDictionaryArray(&pointers);
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw std::runtime_error(directory + ": GDCM could not write the series: " + one_line(e.GetDescription()));
  }
}

}  // namespace authalic::io::detail


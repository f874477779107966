// DICOM series through ITK/GDCM. ITK code lives only in io/itk_*.cpp (its bundled Eigen breaks
// the system Eigen in one translation unit), so nothing here includes Eigen or core/mesh.h.
// DICOM patient coordinates are LPS (x to the patient's left, y posterior); the rest of Authalic
// uses RAS, so x and y flip sign: RAS = diag(-1, -1, 1) * LPS.
#include "io/itk_dicom.h"

#include <gdcmScanner.h>
#include <gdcmTag.h>
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
#include <cstdlib>
#include <filesystem>
#include <numeric>
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


// Header tags read for every file before any pixel is: which series is which, and where each
// slice lies.
const gdcm::Tag kModality(0x0008, 0x0060);
const gdcm::Tag kSeriesDescription(0x0008, 0x103e);
const gdcm::Tag kSeriesUid(0x0020, 0x000e);
const gdcm::Tag kPosition(0x0020, 0x0032);     // ImagePositionPatient (LPS mm)
const gdcm::Tag kOrientation(0x0020, 0x0037);  // ImageOrientationPatient (row, column cosines)
const gdcm::Tag kNumberOfFrames(0x0028, 0x0008);

std::string trimmed(const char* value) {
  if (!value) return {};
  const std::string v(value);
  const std::size_t b = v.find_first_not_of(" \0", 0, 2);
  const std::size_t e = v.find_last_not_of(" \0", std::string::npos, 2);
  return b == std::string::npos ? std::string() : v.substr(b, e - b + 1);
}

std::string scanned(const gdcm::Scanner& scanner, const std::string& file, const gdcm::Tag& tag) {
  return trimmed(scanner.GetValue(file.c_str(), tag));
}

// A DICOM decimal string "a\b\c" with exactly n finite numbers, else empty.
std::vector<double> decimals(const std::string& text, std::size_t n) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, '\\')) {
    const char* begin = item.c_str();
    char* end = nullptr;
    const double x = std::strtod(begin, &end);
    if (end == begin || !std::isfinite(x)) return {};
    out.push_back(x);
  }
  if (out.size() != n) out.clear();
  return out;
}

std::string mm(double x) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3f mm", x);
  return buf;
}

std::string file_name(const std::string& path) { return std::filesystem::path(path).filename().string(); }

struct SeriesEntry {
  std::string uid, description, modality;
  std::vector<std::string> files;
};

std::string describe(const SeriesEntry& s) {
  return s.uid + " '" + (s.description.empty() ? std::string("no description") : s.description) + "' (" +
         (s.modality.empty() ? std::string("no modality") : s.modality) + ", " + std::to_string(s.files.size()) +
         (s.files.size() == 1 ? " file)" : " files)");
}

// The one series to read: the PET series (Modality PT) when the folder has any, else all series;
// more than one candidate is refused with their list (reading the largest one gave the CT of a
// PET/CT export, or whichever of AC and NAC sorted first, as success).
SeriesEntry choose_series(const std::string& dir, std::vector<SeriesEntry> all) {
  const bool any_pet = std::any_of(all.begin(), all.end(), [](const SeriesEntry& s) { return s.modality == "PT"; });
  std::vector<SeriesEntry> candidates;
  for (const SeriesEntry& s : all)
    if (!any_pet || s.modality == "PT") candidates.push_back(s);
  if (candidates.size() == 1) return candidates.front();
  std::string list;
  const std::size_t shown = std::min<std::size_t>(candidates.size(), 8);
  for (std::size_t i = 0; i < shown; ++i) list += (i ? "; " : "") + describe(candidates[i]);
  if (shown < candidates.size()) list += "; and " + std::to_string(candidates.size() - shown) + " more";
  const std::size_t ignored = all.size() - candidates.size();
  const std::string what = std::to_string(candidates.size()) + (any_pet ? " PET series" : " series (none of them PET)") +
                           (ignored ? " (besides " + std::to_string(ignored) + " non-PET series, ignored)" : std::string());
  input_error(dir, "holds " + what + ", so which one to read is ambiguous: " + list,
              "give a folder that holds only the series to read (move the other series' files to another folder)");
}

// The files of a single-frame-per-file series in order along the orientation's normal, after
// checking that they form one regular stack: ITK's series reader places slice k at
// first + k * (last - first) / (n - 1) with the in-plane axes of the first file, whatever the
// positions say, so a missing slice, uneven spacing or a gantry tilt gave wrong positions as
// success. Positions are compared as numbers (DICOM strings of one position may differ).
std::vector<std::string> check_slice_stack(const std::string& dir, const std::vector<std::string>& files, const gdcm::Scanner& scanner) {
  const std::size_t n = files.size();
  if (n < 2) return files;  // one file (enhanced multi-frame included): GDCM reads its own geometry
  for (const std::string& f : files) {
    const std::string frames = scanned(scanner, f, kNumberOfFrames);
    if (!frames.empty() && std::atoi(frames.c_str()) > 1) return files;  // multi-frame files: not checked here
  }
  const std::vector<double> iop = decimals(scanned(scanner, files.front(), kOrientation), 6);
  if (iop.empty())
    input_error(dir, file_name(files.front()) + " has no usable ImageOrientationPatient (0020,0037), so the slice geometry is unknown",
                "give a complete PET DICOM series, or a NIfTI");
  for (const std::string& f : files) {
    const std::vector<double> other = decimals(scanned(scanner, f, kOrientation), 6);
    bool same = !other.empty();
    for (std::size_t i = 0; same && i < 6; ++i) same = std::abs(other[i] - iop[i]) <= 1e-4;
    if (!same)
      input_error(dir, "slices have different orientations (ImageOrientationPatient of " + file_name(f) + " differs from " +
                           file_name(files.front()) + ")",
                  "give a folder with one series of parallel slices");
  }
  const double r[3] = {iop[0], iop[1], iop[2]}, c[3] = {iop[3], iop[4], iop[5]};
  double normal[3] = {r[1] * c[2] - r[2] * c[1], r[2] * c[0] - r[0] * c[2], r[0] * c[1] - r[1] * c[0]};
  const double norm = std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
  if (!(norm > 0.99 && norm < 1.01))
    input_error(dir, "ImageOrientationPatient is not two perpendicular unit vectors", "fix the orientation tags or give a NIfTI");
  for (double& x : normal) x /= norm;

  std::vector<std::array<double, 3>> position(n);
  std::vector<double> along(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::vector<double> p = decimals(scanned(scanner, files[i], kPosition), 3);
    if (p.empty())
      input_error(dir, file_name(files[i]) + " has no usable ImagePositionPatient (0020,0032), so its slice position is unknown",
                  "give a complete PET DICOM series, or a NIfTI");
    position[i] = {p[0], p[1], p[2]};
    along[i] = p[0] * normal[0] + p[1] * normal[1] + p[2] * normal[2];
  }
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return along[a] < along[b]; });
  std::vector<double> d(n);
  for (std::size_t i = 0; i < n; ++i) d[i] = along[order[i]];

  // Duplicated positions (dynamic PET: every frame at the same slices), compared numerically so
  // that positions written 0.001 mm apart are still one position.
  const double mean_gap = (d[n - 1] - d[0]) / static_cast<double>(n - 1);
  const double same_position = mean_gap > 0 ? std::min(0.05, 0.1 * mean_gap) : 0.05;
  std::size_t distinct = 1;
  for (std::size_t i = 1; i < n; ++i)
    if (d[i] - d[i - 1] >= same_position) ++distinct;
  if (distinct < n)
    input_error(dir,
                "series has " + std::to_string(n) + " files at only " + std::to_string(distinct) +
                    " slice positions (dynamic, multi-frame PET)",
                "convert it to a 4D NIfTI (e.g. dcm2niix) and choose a frame or sum the frames");

  const double spacing = d[1] - d[0];
  const double tolerance = std::max(0.01, 0.01 * spacing);  // DICOM positions are rounded decimals
  // Gantry tilt: the slice origins must lie on the line through the first along the normal
  // (plus 1e-4 of the distance, for orientation cosines written with few decimals).
  const std::array<double, 3>& p0 = position[order[0]];
  double worst = 0, worst_along = 0;
  std::size_t worst_slice = 0;
  bool tilted = false;
  for (std::size_t i = 1; i < n; ++i) {
    const std::array<double, 3>& p = position[order[i]];
    double off[3];
    for (int a = 0; a < 3; ++a) off[a] = p[a] - p0[a] - (d[i] - d[0]) * normal[a];
    const double beside = std::sqrt(off[0] * off[0] + off[1] * off[1] + off[2] * off[2]);
    tilted = tilted || beside > tolerance + 1e-4 * (d[i] - d[0]);
    if (beside > worst) {
      worst = beside;
      worst_along = d[i] - d[0];
      worst_slice = i;
    }
  }
  if (tilted) {
    char angle[32];
    std::snprintf(angle, sizeof(angle), "%.1f", std::atan2(worst, worst_along) * (180.0 / 3.14159265358979323846));
    input_error(dir,
                "slices are not stacked along the orientation's normal: slice " + std::to_string(worst_slice + 1) + " of " +
                    std::to_string(n) + " lies " + mm(worst) + " beside the normal through slice 1 (gantry tilt " + angle +
                    " degrees?)",
                "the grid would be sheared; resample it to a regular grid (e.g. dcm2niix corrects gantry tilt) and give the NIfTI");
  }
  // Uniform spacing along the normal.
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const double gap = d[i + 1] - d[i];
    if (std::abs(gap - spacing) <= tolerance) continue;
    const double big = std::max(gap, spacing), small = std::min(gap, spacing);
    const double multiple = std::round(big / small);
    const bool missing = multiple >= 2 && std::abs(big - multiple * small) <= multiple * tolerance;
    input_error(dir,
                "slice spacing is not uniform: " + mm(spacing) + ", then " + mm(gap) + " between slices " + std::to_string(i + 1) +
                    " and " + std::to_string(i + 2) + " of " + std::to_string(n) + " (counted along the normal" +
                    (missing ? "; a missing slice?)" : ")"),
                "the slices cannot be stacked at one spacing; add the missing files or give a NIfTI on a regular grid");
  }
  std::vector<std::string> sorted(n);
  for (std::size_t i = 0; i < n; ++i) sorted[i] = files[order[i]];
  return sorted;
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
    std::vector<SeriesEntry> all;
    std::vector<std::string> every_file;
    for (const std::string& uid : uids) {
      SeriesEntry s;
      s.files = names->GetFileNames(uid);
      if (s.files.empty()) continue;
      every_file.insert(every_file.end(), s.files.begin(), s.files.end());
      all.push_back(std::move(s));
    }
    gdcm::Scanner scanner;
    for (const gdcm::Tag& t : {kModality, kSeriesDescription, kSeriesUid, kPosition, kOrientation, kNumberOfFrames}) scanner.AddTag(t);
    if (!scanner.Scan(every_file)) input_error(directory, "GDCM could not read the DICOM headers", "check the folder");
    for (SeriesEntry& s : all) {
      s.uid = scanned(scanner, s.files.front(), kSeriesUid);
      s.description = scanned(scanner, s.files.front(), kSeriesDescription);
      s.modality = scanned(scanner, s.files.front(), kModality);
    }
    const SeriesEntry chosen = choose_series(directory, std::move(all));
    files = check_slice_stack(directory, chosen.files, scanner);
    out.series_uid = chosen.uid;
    out.series_description = chosen.description;
    out.modality = chosen.modality;
    out.num_files = static_cast<int>(chosen.files.size());
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
  if (out.modality.empty()) out.modality = dict_string(dict, "0008|0060");
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


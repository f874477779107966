// DICOM folders as scanners export them: which series is read (PET beside CT, AC beside NAC) and
// whether the slices form one regular stack (missing slice, uneven spacing, gantry tilt, dynamic
// frames with jittered positions). The files are written here byte by byte (Part 10, explicit VR
// little endian, one slice per file), independently of ITK/GDCM, so every tag and position is
// exactly what the test says.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "io/io_test_util.h"
#include "io/volume_io.h"

using namespace authalic;
using namespace authalic::io;
using namespace authalic::test;

namespace {

// ---- a minimal DICOM writer ---------------------------------------------------------------

void put16(std::string& out, unsigned v) {
  out += static_cast<char>(v & 0xff);
  out += static_cast<char>((v >> 8) & 0xff);
}
void put32(std::string& out, std::uint32_t v) {
  put16(out, v & 0xffff);
  put16(out, v >> 16);
}

// One data element, explicit VR little endian; the value padded to an even length.
void element(std::string& out, unsigned group, unsigned elem, const std::string& vr, std::string value) {
  if (value.size() % 2) value += (vr == "UI" || vr == "OB" || vr == "OW") ? '\0' : ' ';
  put16(out, group);
  put16(out, elem);
  out += vr;
  if (vr == "OB" || vr == "OW" || vr == "SQ" || vr == "UN" || vr == "UT") {
    put16(out, 0);
    put32(out, static_cast<std::uint32_t>(value.size()));
  } else {
    put16(out, static_cast<unsigned>(value.size()));
  }
  out += value;
}
std::string us(unsigned v) {
  std::string s;
  put16(s, v);
  return s;
}

std::string ds(const std::vector<double>& v, const char* format = "%.10g") {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) {
    char buf[40];
    std::snprintf(buf, sizeof(buf), format, v[i]);
    s += (i ? "\\" : "") + std::string(buf);
  }
  return s;
}

struct Vec3 {
  double x, y, z;
};
Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }

// A series of single-frame files: slice k at positions[k] (LPS mm), pixel (i, j) of slice k
// stored as 100 k + 10 j + i + stored_offset, value = stored * slope + intercept.
struct Series {
  std::string uid, description, modality = "PT", prefix = "s";
  int nx = 5, ny = 4;
  double column_spacing = 2.5, row_spacing = 2.0;  // mm along i (row cosine) and along j (column cosine)
  Vec3 row{1, 0, 0}, col{0, 1, 0};                  // ImageOrientationPatient
  std::vector<Vec3> positions;
  double slope = 0.5, intercept = 0.0;
  int stored_offset = 0;
  const char* position_format = "%.10g";  // real scanners round: e.g. "%.3f"
};

int g_uid = 0;
std::string new_uid() { return "1.2.826.0.1.3680043.8.498.77." + std::to_string(++g_uid); }

// Positions of a regular stack: first + k * spacing * normal.
std::vector<Vec3> stack(Vec3 first, Vec3 row, Vec3 col, double spacing, int n) {
  std::vector<Vec3> p;
  for (int k = 0; k < n; ++k) p.push_back(first + (k * spacing) * cross(row, col));
  return p;
}

void write_series(const std::string& dir, const Series& s) {
  std::filesystem::create_directories(dir);
  const bool pet = s.modality == "PT";
  const std::string sop_class = pet ? "1.2.840.10008.5.1.4.1.1.128" : "1.2.840.10008.5.1.4.1.1.2";
  const std::string study = "1.2.826.0.1.3680043.8.498.77.1000", frame_of_reference = "1.2.826.0.1.3680043.8.498.77.1001";
  for (std::size_t k = 0; k < s.positions.size(); ++k) {
    const std::string instance = new_uid();
    std::string meta;
    element(meta, 0x0002, 0x0001, "OB", std::string("\0\1", 2));
    element(meta, 0x0002, 0x0002, "UI", sop_class);
    element(meta, 0x0002, 0x0003, "UI", instance);
    element(meta, 0x0002, 0x0010, "UI", "1.2.840.10008.1.2.1");  // explicit VR little endian
    element(meta, 0x0002, 0x0012, "UI", "1.2.826.0.1.3680043.8.498.77.9");
    std::string out(128, '\0');
    out += "DICM";
    std::string length;
    put32(length, static_cast<std::uint32_t>(meta.size()));
    element(out, 0x0002, 0x0000, "UL", length);
    out += meta;
    const Vec3& p = s.positions[k];
    element(out, 0x0008, 0x0016, "UI", sop_class);
    element(out, 0x0008, 0x0018, "UI", instance);
    element(out, 0x0008, 0x0060, "CS", s.modality);
    element(out, 0x0008, 0x103e, "LO", s.description);
    element(out, 0x0010, 0x0010, "PN", "AUTHALIC^DICOM");
    element(out, 0x0010, 0x0020, "LO", "dicom-test");
    element(out, 0x0018, 0x0050, "DS", ds({2.0}));
    element(out, 0x0020, 0x000d, "UI", study);
    element(out, 0x0020, 0x000e, "UI", s.uid);
    element(out, 0x0020, 0x0011, "IS", "1");
    element(out, 0x0020, 0x0013, "IS", std::to_string(k + 1));
    element(out, 0x0020, 0x0032, "DS", ds({p.x, p.y, p.z}, s.position_format));
    element(out, 0x0020, 0x0037, "DS", ds({s.row.x, s.row.y, s.row.z, s.col.x, s.col.y, s.col.z}));
    element(out, 0x0020, 0x0052, "UI", frame_of_reference);
    element(out, 0x0028, 0x0002, "US", us(1));
    element(out, 0x0028, 0x0004, "CS", "MONOCHROME2");
    element(out, 0x0028, 0x0010, "US", us(static_cast<unsigned>(s.ny)));  // rows: j
    element(out, 0x0028, 0x0011, "US", us(static_cast<unsigned>(s.nx)));  // columns: i
    element(out, 0x0028, 0x0030, "DS", ds({s.row_spacing, s.column_spacing}));
    element(out, 0x0028, 0x0100, "US", us(16));
    element(out, 0x0028, 0x0101, "US", us(16));
    element(out, 0x0028, 0x0102, "US", us(15));
    element(out, 0x0028, 0x0103, "US", us(1));
    element(out, 0x0028, 0x1052, "DS", ds({s.intercept}));
    element(out, 0x0028, 0x1053, "DS", ds({s.slope}));
    if (pet) element(out, 0x0054, 0x1001, "CS", "BQML");
    std::string pixels;
    for (int j = 0; j < s.ny; ++j)
      for (int i = 0; i < s.nx; ++i) put16(pixels, static_cast<unsigned>(static_cast<int>(100 * k) + 10 * j + i + s.stored_offset));
    element(out, 0x7fe0, 0x0010, "OW", pixels);
    char name[64];
    std::snprintf(name, sizeof(name), "%s%04zu.dcm", s.prefix.c_str(), k);
    write_bytes(dir + "/" + name, out);
  }
}

Series pet_series(const std::string& description, int slices = 8) {
  Series s;
  s.uid = new_uid();
  s.description = description;
  s.positions = stack({-40.0, -55.0, -30.0}, s.row, s.col, 2.0, slices);
  return s;
}

float pet_value(const Series& s, int i, int j, int k) {
  return static_cast<float>((100 * k + 10 * j + i + s.stored_offset) * s.slope + s.intercept);
}

std::string message_of(const std::string& dir) {
  try {
    read_volume(dir);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(nothing thrown)";
}

}  // namespace

TEST(DicomSeries, ObliqueSeriesWithRoundedPositionsReadsWithItsGeometry) {
  const std::string dir = temp_dir("dicom_series") + "/oblique";
  Series s;
  s.uid = new_uid();
  s.description = "PET AC oblique";
  const double a = 20.0 * 3.14159265358979323846 / 180.0;  // rotated 20 degrees about x (LPS)
  s.row = {1, 0, 0};
  s.col = {0, std::cos(a), std::sin(a)};
  s.nx = 6;
  s.ny = 5;
  const double spacing = 3.27;
  s.positions = stack({-80.25, -95.5, -41.125}, s.row, s.col, spacing, 7);
  s.position_format = "%.3f";  // rounded to 0.001 mm as scanners write them: still one regular stack
  std::reverse(s.positions.begin(), s.positions.end());  // file order opposite to the normal
  write_series(dir, s);
  const Volume v = read_volume(dir);
  ASSERT_EQ(v.dims, (std::array<int, 3>{6, 5, 7}));
  EXPECT_EQ(v.orientation_source, "dicom");
  EXPECT_EQ(v.units, "Bq/mL");
  EXPECT_EQ(v.source_series, s.uid + " 'PET AC oblique' (PT, 7 files)");
  // Expected: RAS = diag(-1,-1,1) * (first + i * cs * row + j * rs * col + k * spacing * normal),
  // with the first slice the one lowest along the normal (the last file written).
  const Vec3 n = cross(s.row, s.col);
  const Vec3 first = s.positions.back();
  const Vec3 axes[3] = {s.column_spacing * s.row, s.row_spacing * s.col, spacing * n};
  const double flip[3] = {-1, -1, 1};
  for (int c = 0; c < 3; ++c) {
    const double axis[3] = {axes[c].x, axes[c].y, axes[c].z};
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(v.vox2ras(r, c), flip[r] * axis[r], 1e-3) << r << "," << c;
  }
  const double origin[3] = {first.x, first.y, first.z};
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(v.vox2ras(r, 3), flip[r] * origin[r], 1e-3) << r;
  // The files were written in reverse: file f holds slice 6 - f's stored values at position f.
  for (int k = 0; k < 7; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 6; ++i) ASSERT_FLOAT_EQ(v.at(i, j, k), pet_value(s, i, j, 6 - k)) << i << "," << j << "," << k;
}

TEST(DicomSeries, PetBesideCtInOneFolderReadsThePet) {
  // A PET/CT export: the CT has more files (thinner slices); the largest series was read before.
  const std::string dir = temp_dir("dicom_series") + "/pet_ct";
  const Series pet = pet_series("PET WB AC", 6);
  write_series(dir, pet);
  Series ct = pet_series("CT WB 1.0", 12);
  ct.modality = "CT";
  ct.prefix = "ct";
  ct.slope = 1.0;
  ct.intercept = -1000.0;
  ct.positions = stack({-40.0, -55.0, -30.0}, ct.row, ct.col, 1.0, 12);
  write_series(dir, ct);
  const Volume v = read_volume(dir);
  ASSERT_EQ(v.dims, (std::array<int, 3>{5, 4, 6}));
  EXPECT_EQ(v.source_series, pet.uid + " 'PET WB AC' (PT, 6 files)");
  EXPECT_EQ(v.units, "Bq/mL");
  EXPECT_NEAR(v.voxel_size()[2], 2.0, 1e-6);
  for (int k = 0; k < 6; ++k) EXPECT_FLOAT_EQ(v.at(3, 2, k), pet_value(pet, 3, 2, k)) << k;
}

TEST(DicomSeries, TwoPetSeriesAreRefusedWithTheirList) {
  // AC and NAC reconstructions with equal file counts: whichever UID sorted first was read.
  const std::string dir = temp_dir("dicom_series") + "/ac_nac";
  Series ac = pet_series("PET AC");
  ac.uid = "1.2.826.0.1.3680043.8.498.77.2";
  Series nac = pet_series("PET NAC");
  nac.uid = "1.2.826.0.1.3680043.8.498.77.1";
  nac.prefix = "nac";
  nac.slope = 0.15;
  write_series(dir, ac);
  write_series(dir, nac);
  expect_input_error([&] { read_volume(dir); }, dir, "holds 2 PET series, so which one to read is ambiguous");
  const std::string msg = message_of(dir);
  EXPECT_NE(msg.find(ac.uid + " 'PET AC' (PT, 8 files)"), std::string::npos) << msg;
  EXPECT_NE(msg.find(nac.uid + " 'PET NAC' (PT, 8 files)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("give a folder that holds only the series to read"), std::string::npos) << msg;

  // A CT beside them is left out of the list and counted as ignored.
  Series ct = pet_series("CT", 12);
  ct.modality = "CT";
  ct.prefix = "ct";
  ct.positions = stack({-40.0, -55.0, -30.0}, ct.row, ct.col, 1.0, 12);
  write_series(dir, ct);
  expect_input_error([&] { read_volume(dir); }, dir, "holds 2 PET series (besides 1 non-PET series, ignored)");
  EXPECT_EQ(message_of(dir).find(ct.uid), std::string::npos);

  // Two series and no PET: both are candidates.
  const std::string dir2 = temp_dir("dicom_series") + "/two_ct";
  write_series(dir2, ct);
  Series ct2 = ct;
  ct2.uid = new_uid();
  ct2.prefix = "ct2";
  write_series(dir2, ct2);
  expect_input_error([&] { read_volume(dir2); }, dir2, "holds 2 series (none of them PET)");
}

TEST(DicomSeries, MissingSliceAndUnevenSpacingAreRefused) {
  const std::string root = temp_dir("dicom_series");
  Series gap = pet_series("gap", 10);
  gap.positions.erase(gap.positions.begin() + 4);  // slice 5 of 10 missing: 2 mm, then 4 mm
  write_series(root + "/gap", gap);
  expect_input_error([&] { read_volume(root + "/gap"); }, root + "/gap",
                     "slice spacing is not uniform: 2.000 mm, then 4.000 mm between slices 4 and 5 of 9 (counted along the normal; "
                     "a missing slice?)");

  Series uneven = pet_series("uneven", 10);
  for (std::size_t k = 5; k < uneven.positions.size(); ++k) uneven.positions[k].z += 1.0 * static_cast<double>(k - 4);  // 3 mm from slice 5
  write_series(root + "/uneven", uneven);
  expect_input_error([&] { read_volume(root + "/uneven"); }, root + "/uneven",
                     "slice spacing is not uniform: 2.000 mm, then 3.000 mm between slices 5 and 6 of 10 (counted along the normal)");

  // Rounding of the written positions (0.005 mm here) is not unevenness.
  Series rounded = pet_series("rounded", 10);
  for (std::size_t k = 0; k < rounded.positions.size(); ++k) rounded.positions[k].z += (k % 2 ? 0.004 : -0.004);
  write_series(root + "/rounded", rounded);
  EXPECT_EQ(read_volume(root + "/rounded").dims[2], 10);
}

TEST(DicomSeries, GantryTiltIsRefused) {
  // Positions step along y as well as z (15 degrees) while the orientation stays axial, as tilted
  // CT/PET store it: ITK stacked them as an untilted box.
  const std::string dir = temp_dir("dicom_series") + "/tilt";
  Series s = pet_series("tilted", 8);
  const double t = std::tan(15.0 * 3.14159265358979323846 / 180.0);
  for (std::size_t k = 0; k < s.positions.size(); ++k) s.positions[k].y += 2.0 * static_cast<double>(k) * t;
  write_series(dir, s);
  expect_input_error([&] { read_volume(dir); }, dir, "slices are not stacked along the orientation's normal");
  expect_input_error([&] { read_volume(dir); }, dir, "(gantry tilt 15.0 degrees?)");
}

TEST(DicomSeries, DynamicSeriesIsRefusedAlsoWithJitteredPositions) {
  const std::string root = temp_dir("dicom_series");
  for (const double jitter : {0.0, 0.001}) {
    const std::string dir = root + (jitter > 0 ? "/dynamic_jitter" : "/dynamic");
    Series f1 = pet_series("dynamic", 6);
    f1.prefix = "f1_";
    Series f2 = f1;
    f2.prefix = "f2_";
    f2.stored_offset = 1000;
    for (Vec3& p : f2.positions) p.z += jitter;  // a second frame 0.001 mm off: still the same slices
    write_series(dir, f1);
    write_series(dir, f2);
    expect_input_error([&] { read_volume(dir); }, dir, "series has 12 files at only 6 slice positions (dynamic, multi-frame PET)");
  }
}

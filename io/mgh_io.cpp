// FreeSurfer MGH/MGZ volumes (orig.mgz, brain.mgz, ...). Layout (FreeSurfer utils/mriio.cpp,
// mghRead; nibabel.freesurfer.mghformat): big-endian; int32 version=1, width, height, depth,
// frames, type, dof; int16 goodRASflag; float32 delta[3], Mdc[9] (x_r x_a x_s y_r y_a y_s z_r
// z_a z_s: the RAS direction of each voxel axis), c_ras[3]; data at byte 284, x fastest, frame
// slowest. .mgz is the same gzipped.
#include <Eigen/LU>

#include <cmath>
#include <cstdint>

#include "io/atomic_file.h"
#include "io/io_internal.h"
#include "io/volume_formats.h"

namespace authalic::io {

namespace {

constexpr std::size_t kMghDataOffset = 284;
enum MghType { kUchar = 0, kInt = 1, kFloat = 3, kShort = 4 };

int type_size(int type) {
  switch (type) {
    case kUchar: return 1;
    case kShort: return 2;
    case kInt:
    case kFloat: return 4;
    default: return 0;
  }
}

MghHeader parse_header(detail::BigEndianReader& in) {
  MghHeader h;
  const int version = in.i32("version");
  if (version != 1)
    in.fail("wrong version/magic " + std::to_string(version) + " (expected 1)", "this is not an MGH/MGZ volume");
  for (int d = 0; d < 4; ++d) h.dims[d] = in.i32("dimensions");
  h.type = in.i32("data type");
  in.i32("dof");
  h.good_ras = in.i16("goodRASflag") > 0;
  for (int d = 0; d < 3; ++d) h.delta[d] = in.f32("voxel size");
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) h.Mdc(r, c) = in.f32("direction cosines");  // column c = axis c
  for (int d = 0; d < 3; ++d) h.c_ras[d] = in.f32("centre RAS");
  for (int d = 0; d < 4; ++d)
    if (h.dims[d] < 1)
      in.fail("has an invalid dimension " + std::to_string(h.dims[d]), "the header is corrupt");
  if (type_size(h.type) == 0)
    in.fail("has unsupported data type " + std::to_string(h.type), "supported: uchar (0), int (1), float (3), short (4)");
  return h;
}

}  // namespace

Eigen::Matrix4d mgh_vox2ras(const MghHeader& h) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  const Eigen::Matrix3d MD = h.Mdc * h.delta.asDiagonal();
  const Eigen::Vector3d centre(h.dims[0] / 2.0, h.dims[1] / 2.0, h.dims[2] / 2.0);
  m.block<3, 3>(0, 0) = MD;
  m.block<3, 1>(0, 3) = h.c_ras - MD * centre;
  return m;
}

Eigen::Matrix4d mgh_tkr_vox2ras(const MghHeader& h) {
  MghHeader centred = h;
  centred.c_ras.setZero();
  return mgh_vox2ras(centred);
}

Eigen::Matrix4d mgh_tkr_to_scanner(const MghHeader& h) { return mgh_vox2ras(h) * mgh_tkr_vox2ras(h).inverse(); }

MghHeader read_mgh_header(const std::string& path) {
  const std::string bytes = detail::read_file_maybe_gz(path);
  detail::BigEndianReader in(bytes, path, "MGH");
  MghHeader h = parse_header(in);
  if (!h.good_ras) detail::fail(path, "has no valid orientation (goodRASflag = 0)", "re-create it with FreeSurfer (mri_convert)");
  return h;
}

namespace detail {

Volume parse_mgh(const std::string& bytes, const std::string& path, const VolumeReadOptions& options) {
  BigEndianReader in(bytes, path, "MGH");
  const MghHeader h = parse_header(in);
  if (!h.good_ras)
    in.fail("has no valid orientation (goodRASflag = 0), so voxel positions in mm are unknown",
            "re-create it with FreeSurfer (mri_convert) or give a NIfTI with an sform");
  if (!h.delta.allFinite() || !h.Mdc.allFinite() || !h.c_ras.allFinite() || (h.delta.array() <= 0).any())
    in.fail("has non-finite or non-positive orientation values", "the header is corrupt");
  const int size = type_size(h.type);
  const long double total = static_cast<long double>(h.dims[0]) * h.dims[1] * h.dims[2] * h.dims[3] * size;
  if (total > static_cast<long double>(g_max_volume_bytes))
    in.fail("declares more voxel data than the " + fmt_size(g_max_volume_bytes) + " limit", "the header is corrupt or the image is too large");
  const std::size_t voxels = static_cast<std::size_t>(h.dims[0]) * h.dims[1] * h.dims[2];
  const std::size_t needed = static_cast<std::size_t>(total);
  if (bytes.size() < kMghDataOffset + needed)
    in.fail("truncated: " + std::to_string(h.dims[0]) + "x" + std::to_string(h.dims[1]) + "x" + std::to_string(h.dims[2]) + "x" +
                std::to_string(h.dims[3]) + " voxels need " + std::to_string(kMghDataOffset + needed) + " bytes, the file has " +
                std::to_string(bytes.size()),
            "the file is incomplete; re-copy or re-create it");
  Volume v;
  v.vox2ras = mgh_vox2ras(h);
  check_affine(path, v.vox2ras, "MGH header");
  v.orientation_source = "mgh";
  v.source_path = path;
  v.dims = {h.dims[0], h.dims[1], h.dims[2]};
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data() + kMghDataOffset);
  std::function<float(std::size_t)> value;
  switch (h.type) {
    case kUchar: value = [p](std::size_t i) { return static_cast<float>(p[i]); }; break;
    case kShort:
      value = [p](std::size_t i) {
        return static_cast<float>(static_cast<std::int16_t>((std::uint16_t(p[2 * i]) << 8) | p[2 * i + 1]));
      };
      break;
    case kInt:
      value = [p](std::size_t i) {
        const std::uint32_t u = (std::uint32_t(p[4 * i]) << 24) | (std::uint32_t(p[4 * i + 1]) << 16) | (std::uint32_t(p[4 * i + 2]) << 8) | p[4 * i + 3];
        return static_cast<float>(static_cast<std::int32_t>(u));
      };
      break;
    default:
      value = [p](std::size_t i) {
        const std::uint32_t u = (std::uint32_t(p[4 * i]) << 24) | (std::uint32_t(p[4 * i + 1]) << 16) | (std::uint32_t(p[4 * i + 2]) << 8) | p[4 * i + 3];
        float f;
        std::memcpy(&f, &u, 4);
        return f;
      };
  }
  take_frames(path, h.dims[3], voxels, value, options, &v);
  return v;
}

Volume read_mgh(const std::string& path, const VolumeReadOptions& options) {
  return parse_mgh(read_file_maybe_gz(path), path, options);
}

}  // namespace detail

void write_mgh(const std::string& path, const Volume& volume) {
  if (volume.num_voxels() == 0 || volume.data.size() != volume.num_voxels())
    throw InputError(path + ": volume data does not match its grid; nothing written");
  detail::check_affine(path, volume.vox2ras, "affine");
  const Eigen::Matrix3d MD = volume.vox2ras.block<3, 3>(0, 0);
  const Eigen::Vector3d delta = MD.colwise().norm().transpose();
  const Eigen::Matrix3d Mdc = MD * delta.cwiseInverse().asDiagonal();
  const Eigen::Vector3d centre(volume.dims[0] / 2.0, volume.dims[1] / 2.0, volume.dims[2] / 2.0);
  const Eigen::Vector3d c_ras = MD * centre + volume.vox2ras.block<3, 1>(0, 3);
  detail::BigEndianWriter out;
  out.i32(1);
  for (int d = 0; d < 3; ++d) out.i32(volume.dims[d]);
  out.i32(1);
  out.i32(kFloat);
  out.i32(0);
  out.i16(1);
  for (int d = 0; d < 3; ++d) out.f32(static_cast<float>(delta[d]));
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) out.f32(static_cast<float>(Mdc(r, c)));
  for (int d = 0; d < 3; ++d) out.f32(static_cast<float>(c_ras[d]));
  out.out.resize(kMghDataOffset, '\0');
  out.out.reserve(kMghDataOffset + 4 * volume.data.size());
  for (const float x : volume.data) out.f32(x);
  const bool gz = detail::ends_with(detail::lower_filename(path), ".mgz") || detail::ends_with(detail::lower_filename(path), ".gz");
  write_file_atomically(path, gz ? detail::gzip(out.out) : out.out);
}

}  // namespace authalic::io

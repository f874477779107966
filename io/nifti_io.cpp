// NIfTI-1 and NIfTI-2 through nifti-clib's nifti2 API (nifti_image_read reads both versions).
// This translation unit must not include gifti_io.h (it pulls nifti1_io.h; the two clash).
// Orientation, as the NIfTI-1 standard (nifti1.h, "Method 3" before "Method 2"): the sform when
// sform_code > 0, else the qform when qform_code > 0; a file with neither is refused rather than
// guessed (Method 1, pixdim only, has no defined world position).
#include <nifti2_io.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <filesystem>
#include <memory>
#include <mutex>
#include <sstream>
#include <system_error>

#include "io/atomic_file.h"
#include "io/io_internal.h"
#include "io/volume_formats.h"

namespace authalic::io::detail {

namespace {

std::mutex& nifti_mutex() {  // nifti-clib has global options (debug level)
  static std::mutex m;
  return m;
}

struct NiftiDeleter {
  void operator()(nifti_image* n) const { nifti_image_free(n); }
};
using NiftiPtr = std::unique_ptr<nifti_image, NiftiDeleter>;

Eigen::Matrix4d to_eigen(const nifti_dmat44& m) {
  Eigen::Matrix4d out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out(r, c) = m.m[r][c];
  return out;
}

const char* type_name(int datatype) {
  switch (datatype) {
    case DT_UINT8: return "uint8";
    case DT_INT8: return "int8";
    case DT_INT16: return "int16";
    case DT_UINT16: return "uint16";
    case DT_INT32: return "int32";
    case DT_UINT32: return "uint32";
    case DT_FLOAT32: return "float32";
    case DT_FLOAT64: return "float64";
    case DT_INT64: return "int64";
    case DT_UINT64: return "uint64";
    case DT_COMPLEX64: return "complex64";
    case DT_COMPLEX128: return "complex128";
    case DT_RGB24: return "rgb24";
    case DT_RGBA32: return "rgba32";
    default: return "unknown";
  }
}

template <class T>
float get(const void* data, std::size_t i) {
  return static_cast<float>(static_cast<const T*>(data)[i]);
}

std::string plain_number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

// Raw header checks before nifti-clib parses the header.
//  - Byte order: sizeof_hdr, dim[0] and datatype must agree on it. nifti-clib 3.0 picks the byte
//    order from dim[0] alone and smashes its stack on a NIfTI-2 header whose sizeof_hdr reads in
//    the other order with an unknown datatype (fuzz find).
//  - Orientation: nifti-clib turns non-finite header floats into 0 and a voxel size <= 0 into
//    1 mm while reading, so a NaN quaternion or a zero pixdim would silently become another
//    orientation (and then "95 % of the surface outside the field of view"). The raw fields of
//    the transform in use are checked.
void check_orientation_fields(const std::string& h, const std::string& path) {
  NiftiHeaderView view{h};
  if (!nifti_header_view(h, &view)) return;  // nifti-clib refuses it with its own message
  const long long ndim = view.dim(0);
  const int datatype = view.datatype();
  static const int known[] = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 768, 1024, 1280, 1536, 1792, 2048, 2304};
  if (ndim < 1 || ndim > 7 || std::find(std::begin(known), std::end(known), datatype) == std::end(known))
    fail(path, "the header is inconsistent (dim[0] " + std::to_string(ndim) + ", datatype " + std::to_string(datatype) +
                   " in the byte order its sizeof_hdr gives)",
         "the file is corrupt; re-create it");
  const int qform = view.v2 ? field_at<std::int32_t>(h, 344, view.swap) : field_at<std::int16_t>(h, 252, view.swap);
  const int sform = view.v2 ? field_at<std::int32_t>(h, 348, view.swap) : field_at<std::int16_t>(h, 254, view.swap);
  if (sform > 0) {
    for (int i = 0; i < 12; ++i)
      if (!std::isfinite(view.real(280 + 4 * i, 400 + 8 * i)))
        fail(path, "the sform (srow) holds a non-finite number", "fix the header's orientation (e.g. nibabel set_sform) and retry");
  } else if (qform > 0) {
    static const char* names[] = {"quatern_b", "quatern_c", "quatern_d", "qoffset_x", "qoffset_y", "qoffset_z"};
    for (int i = 0; i < 6; ++i)
      if (!std::isfinite(view.real(256 + 4 * i, 352 + 8 * i)))
        fail(path, std::string("the qform's ") + names[i] + " is not a finite number (nifti-clib would read it as 0, another orientation)",
             "fix the header's orientation (e.g. nibabel set_qform) and retry");
    for (int d = 1; d <= 3; ++d) {
      const double p = view.real(76 + 4 * d, 104 + 8 * d);
      if (!(p > 0) || !std::isfinite(p))
        fail(path, "pixdim[" + std::to_string(d) + "] (the voxel size) is " + plain_number(p) + ", so the qform's voxel positions in mm are unknown",
             "set the voxel size in the header (e.g. nibabel header.set_zooms) and retry");
    }
  }
}

}  // namespace

Volume read_nifti(const std::string& path, const VolumeReadOptions& options) {
  require_readable(path);
  // Gzipped files are inflated here (size-limited, CRC-checked) and handed to nifti-clib as a
  // private .nii: nifti-clib 3.0 reads some valid .nii.gz short (measured on a NIfTI-2 float64
  // file from nibabel) and cannot bound a gzip bomb.
  std::unique_ptr<TempFile> plain;
  std::string file = path;
  {
    std::string bytes = read_file(path);
    const bool gz = is_gzip(bytes);
    if (gz) bytes = gunzip(bytes, path);
    check_orientation_fields(bytes, path);
    if (gz) {
      plain = std::make_unique<TempFile>(".nii");
      plain->write(bytes);
      file = plain->path();
    } else if (ends_with(lower_filename(path), ".gz")) {
      fail(path, "has a .gz name but is not gzip-compressed", "rename it to .nii or re-compress it");
    }
  }
  NiftiPtr nim;
  {
    std::lock_guard<std::mutex> lock(nifti_mutex());
    nifti_set_debug_level(0);
    nim.reset(nifti_image_read(file.c_str(), 0));  // header first: check sizes before allocating
  }
  if (!nim) fail(path, "not a readable NIfTI file (bad header, wrong magic or unreadable)", "check that it is a .nii/.nii.gz image");
  if (nim->nifti_type == NIFTI_FTYPE_ANALYZE)
    fail(path, "is an ANALYZE 7.5 image, which has no defined orientation", "convert it to NIfTI with an orientation (sform/qform)");
  for (int d = 1; d <= 7; ++d)
    if (nim->dim[d] < 0) fail(path, "has a negative dimension", "the header is corrupt");
  if (nim->ndim < 1 || nim->nx < 1 || nim->ny < 1 || nim->nz < 1)
    fail(path, "has an empty or invalid grid (" + std::to_string(nim->nx) + " x " + std::to_string(nim->ny) + " x " + std::to_string(nim->nz) + ")",
         "the header is corrupt");
  if (nim->nu > 1 || nim->nv > 1 || nim->nw > 1)
    fail(path, "has more than 4 dimensions (dims 5-7: " + std::to_string(nim->nu) + ", " + std::to_string(nim->nv) + ", " + std::to_string(nim->nw) + ")",
         "give a 3D or 4D (x, y, z, time) image");
  switch (nim->datatype) {
    case DT_UINT8: case DT_INT8: case DT_INT16: case DT_UINT16: case DT_INT32: case DT_UINT32: case DT_FLOAT32: case DT_FLOAT64:
      break;
    default:
      fail(path, std::string("has unsupported data type ") + type_name(nim->datatype) + " (code " + std::to_string(nim->datatype) + ")",
           "convert it to uint8, int16, int32, float32 or float64");
  }
  // Voxel count in 128-bit-safe steps: a corrupt header must not overflow into a small allocation.
  const long long nx = nim->nx, ny = nim->ny, nz = nim->nz, nt = std::max<long long>(1, nim->nt);
  const long double total = static_cast<long double>(nx) * ny * nz * nt * nim->nbyper;
  if (total > static_cast<long double>(g_max_volume_bytes))
    fail(path, "declares " + std::to_string(nx) + " x " + std::to_string(ny) + " x " + std::to_string(nz) + " x " + std::to_string(nt) +
                   " voxels (" + fmt_size(static_cast<std::size_t>(std::min<long double>(total, 1e18L))) + "), more than the " +
                   fmt_size(g_max_volume_bytes) + " limit",
         "the header is corrupt or the image is too large");
  if (nx * ny * nz > 2147483647LL) fail(path, "has more than 2^31 voxels per frame", "the image is too large");
  {
    // The data must be in the file (nifti-clib would otherwise read short and zero-fill).
    const std::string img = nim->iname ? nim->iname : file;
    std::error_code ec;
    const auto size = std::filesystem::file_size(img, ec);
    const long double needed = static_cast<long double>(nim->iname_offset) + total;
    if (!ec && static_cast<long double>(size) < needed)
      fail(path, "truncated: the header declares " + std::to_string(static_cast<long long>(needed)) + " bytes of header and data, the file has " +
                     std::to_string(size),
           "the file is incomplete; re-copy or re-create it");
  }
  // Orientation before data: no point loading an image we must refuse.
  Volume v;
  bool scanner_affine = false;  // the sform or qform: in the header's spatial units
  const std::string descrip(nim->descrip, strnlen(nim->descrip, sizeof(nim->descrip)));
  if (nim->sform_code == NIFTI_XFORM_TEMPLATE_OTHER && descrip.find(kMapGridMarker) != std::string::npos) {
    // An element image written by authalic: its own grid space, never a scanner's.
    if (!options.allow_map_grid)
      fail(path, "is an authalic element image (a grid on the cortical map, not a scanner space), so it has no position in the brain",
           "give the scanner image (e.g. the PET), not an element image");
    v.vox2ras = to_eigen(nim->sto_xyz);
    v.orientation_source = "map grid";
  } else if (nim->sform_code > 0) {
    v.vox2ras = to_eigen(nim->sto_xyz);
    v.orientation_source = "sform";
    scanner_affine = true;
  } else if (nim->qform_code > 0) {
    v.vox2ras = to_eigen(nim->qto_xyz);
    v.orientation_source = "qform";
    scanner_affine = true;
  } else if (options.allow_map_grid) {
    v.vox2ras = Eigen::Vector4d(nim->dx > 0 ? nim->dx : 1.0, nim->dy > 0 ? nim->dy : 1.0, nim->dz > 0 ? nim->dz : 1.0, 1.0).asDiagonal();
    v.orientation_source = "pixdim";
  } else {
    fail(path, "no usable orientation (sform_code and qform_code are both 0), so voxel positions in mm are unknown",
         "set the orientation (e.g. nibabel set_sform/set_qform, fslorient or the converter's options) and retry");
  }
  // The affine is in the header's spatial units (NIfTI-1 xyzt_units; 0 "unknown" is taken as
  // mm, as every tool does): metres and micrometres are converted to mm, as ITK does.
  if (scanner_affine) {
    const double to_mm = nim->xyz_units == NIFTI_UNITS_METER ? 1000.0 : nim->xyz_units == NIFTI_UNITS_MICRON ? 0.001 : 1.0;
    if (to_mm != 1.0) {
      v.vox2ras.topRows<3>() *= to_mm;
      v.orientation_source += nim->xyz_units == NIFTI_UNITS_METER ? " (metres, converted to mm)" : " (micrometres, converted to mm)";
    }
  }
  check_affine(path, v.vox2ras, v.orientation_source);
  {
    std::lock_guard<std::mutex> lock(nifti_mutex());
    if (nifti_image_load(nim.get()) != 0 || !nim->data)
      fail(path, "could not read the voxel data (truncated or corrupt file)", "the file is incomplete; re-copy or re-create it");
  }
  if (nim->datatype == DT_FLOAT32 || nim->datatype == DT_FLOAT64) {
    // nifti-clib replaces every non-finite float by 0 while loading (FIXED_FLOAT in
    // nifti_read_buffer), which would turn missing data (NaN voxels) into real zeros: take the
    // values from the file's bytes instead (`file` is already the uncompressed image).
    const std::string img = nim->iname ? nim->iname : file;
    std::ifstream raw_in(img, std::ios::binary);
    raw_in.seekg(static_cast<std::streamoff>(nim->iname_offset));
    raw_in.read(static_cast<char*>(nim->data), static_cast<std::streamsize>(nim->nvox * nim->nbyper));
    if (!raw_in) fail(path, "could not read the voxel data (truncated or corrupt file)", "the file is incomplete; re-copy or re-create it");
    if (nim->byteorder != nifti_short_order()) nifti_swap_Nbytes(nim->nvox, nim->nbyper, nim->data);
  }
  // scl_slope = 0 means "no scaling" (nifti1.h); NaN slopes are treated the same, as nibabel does.
  double slope = nim->scl_slope, inter = nim->scl_inter;
  if (!std::isfinite(slope) || slope == 0.0) {
    slope = 1.0;
    inter = 0.0;
  }
  if (!std::isfinite(inter)) inter = 0.0;
  const void* data = nim->data;
  std::function<float(std::size_t)> raw;
  switch (nim->datatype) {
    case DT_UINT8: raw = [data](std::size_t i) { return get<std::uint8_t>(data, i); }; break;
    case DT_INT8: raw = [data](std::size_t i) { return get<std::int8_t>(data, i); }; break;
    case DT_INT16: raw = [data](std::size_t i) { return get<std::int16_t>(data, i); }; break;
    case DT_UINT16: raw = [data](std::size_t i) { return get<std::uint16_t>(data, i); }; break;
    case DT_INT32: raw = [data](std::size_t i) { return get<std::int32_t>(data, i); }; break;
    case DT_UINT32: raw = [data](std::size_t i) { return get<std::uint32_t>(data, i); }; break;
    case DT_FLOAT32: raw = [data](std::size_t i) { return get<float>(data, i); }; break;
    default: raw = [data](std::size_t i) { return get<double>(data, i); }; break;
  }
  const bool scaled = !(slope == 1.0 && inter == 0.0);
  v.dims = {static_cast<int>(nx), static_cast<int>(ny), static_cast<int>(nz)};
  v.source_path = path;
  const std::size_t voxels = static_cast<std::size_t>(nx * ny * nz);
  if (scaled)
    take_frames(path, nt, voxels, [&](std::size_t i) { return static_cast<float>(raw(i) * slope + inter); }, options, &v);
  else
    take_frames(path, nt, voxels, raw, options, &v);
  return v;
}

void write_nifti1(const std::string& path, const Volume& volume, const NiftiWriteOptions& options) {
  const std::string name = lower_filename(path);
  if (!(ends_with(name, ".nii") || ends_with(name, ".nii.gz")))
    throw InputError(path + ": NIfTI output needs a .nii or .nii.gz name; nothing written");
  if (volume.num_voxels() == 0 || volume.data.size() != volume.num_voxels())
    throw InputError(path + ": volume has " + std::to_string(volume.data.size()) + " values for a " + std::to_string(volume.dims[0]) + "x" +
                     std::to_string(volume.dims[1]) + "x" + std::to_string(volume.dims[2]) + " grid; nothing written");
  check_affine(path, volume.vox2ras, "affine");
  write_atomically(path, [&](const std::string& tmp) {
    const int64_t dims[8] = {3, volume.dims[0], volume.dims[1], volume.dims[2], 1, 1, 1, 1};
    NiftiPtr nim(nifti_make_new_nim(dims, DT_FLOAT32, 0));
    if (!nim) throw std::runtime_error("nifti-clib could not create an image");
    nifti_dmat44 m;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m.m[r][c] = volume.vox2ras(r, c);
    nim->sform_code = options.map_grid ? NIFTI_XFORM_TEMPLATE_OTHER : NIFTI_XFORM_ALIGNED_ANAT;
    nim->qform_code = options.map_grid ? NIFTI_XFORM_TEMPLATE_OTHER : NIFTI_XFORM_ALIGNED_ANAT;
    nim->intent_code = options.intent_code;
    std::snprintf(nim->intent_name, sizeof(nim->intent_name), "%s", options.intent_name.substr(0, 15).c_str());
    nim->sto_xyz = m;
    nim->sto_ijk = nifti_dmat44_inverse(m);
    // The qform holds rotation + voxel sizes only; nifti-clib fits the nearest rotation (exact for
    // any affine without shear), pixdim then records the voxel sizes.
    double qb, qc, qd, qx, qy, qz, dx, dy, dz, qfac;
    nifti_dmat44_to_quatern(m, &qb, &qc, &qd, &qx, &qy, &qz, &dx, &dy, &dz, &qfac);
    nim->quatern_b = qb;
    nim->quatern_c = qc;
    nim->quatern_d = qd;
    nim->qoffset_x = qx;
    nim->qoffset_y = qy;
    nim->qoffset_z = qz;
    nim->qfac = qfac;
    nim->dx = nim->pixdim[1] = dx;
    nim->dy = nim->pixdim[2] = dy;
    nim->dz = nim->pixdim[3] = dz;
    nim->qto_xyz = nifti_quatern_to_dmat44(qb, qc, qd, qx, qy, qz, dx, dy, dz, qfac);
    nim->qto_ijk = nifti_dmat44_inverse(nim->qto_xyz);
    nim->xyz_units = NIFTI_UNITS_MM;
    nim->scl_slope = 1.0;
    nim->scl_inter = 0.0;
    std::string descrip = options.description.substr(0, 79);
    if (options.map_grid && descrip.find(kMapGridMarker) == std::string::npos)  // the reader tells element images by it
      descrip = (std::string(kMapGridMarker) + "; " + options.description).substr(0, 79);
    std::snprintf(nim->descrip, sizeof(nim->descrip), "%s", descrip.c_str());
    nim->data = std::malloc(volume.data.size() * sizeof(float));
    if (!nim->data) throw std::runtime_error("out of memory");
    std::memcpy(nim->data, volume.data.data(), volume.data.size() * sizeof(float));
    float lo = 0, hi = 0;
    bool first = true;
    for (const float x : volume.data)
      if (std::isfinite(x)) {
        lo = first ? x : std::min(lo, x);
        hi = first ? x : std::max(hi, x);
        first = false;
      }
    nim->cal_min = lo;
    nim->cal_max = hi;
    {
      std::lock_guard<std::mutex> lock(nifti_mutex());
      nifti_set_debug_level(0);
      if (nifti_set_filenames(nim.get(), tmp.c_str(), 0, 1) != 0) throw std::runtime_error("nifti-clib rejected the file name " + tmp);
      nifti_image_write(nim.get());  // returns nothing: verified below
    }
    // nifti_image_write reports no errors (a full disk included): check that all bytes arrived.
    const std::string bytes = read_file_maybe_gz(tmp);
    const std::size_t header = 352;
    if (bytes.size() < header + volume.data.size() * sizeof(float))
      throw std::system_error(errno ? errno : EIO, std::generic_category(), "NIfTI file incomplete after writing (disk full?)");
  });
}

}  // namespace authalic::io::detail

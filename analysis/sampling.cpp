// PET sampling on cortical surfaces and intensity normalisation (see analysis/sampling.h).
#include "analysis/sampling.h"

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "core/error.h"

namespace authalic::analysis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string format_number(double x, int precision = 4) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", precision, x);
  return buf;
}

std::string volume_name(const io::Volume& volume) {
  return volume.source_path.empty() ? std::string("volume") : volume.source_path;
}

// Vertices referenced by a face.
std::vector<bool> used_vertices(const MatrixXi& F, int num_vertices) {
  std::vector<bool> used(static_cast<std::size_t>(num_vertices), false);
  for (int f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int v = F(f, c);
      if (v >= 0 && v < num_vertices) used[static_cast<std::size_t>(v)] = true;
    }
  return used;
}

void check_faces(const MatrixXi& F, int num_vertices) {
  if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= num_vertices))
    throw InputError("surface: face indices outside 0.." + std::to_string(num_vertices - 1) +
                     "; the surface file is inconsistent");
}

// Reduction of one segment's samples. A segment with a missing sample (outside the field of view,
// or every voxel around it NaN) has no value: the statistic of the rest would describe part of
// the segment only (measured: a PET cut 47 mm above the AC moved such vertices by -17 % to +26 %).
struct SegmentStat {
  SamplingStatistic statistic;
  double sum = 0.0, best = -std::numeric_limits<double>::infinity();
  int n = 0, missing = 0;
  void add(double v) {
    if (!std::isfinite(v)) {
      ++missing;
      return;
    }
    sum += v;
    best = std::max(best, v);
    ++n;
  }
  bool partial() const { return n > 0 && missing > 0; }
  double value() const {
    if (n == 0 || missing > 0) return kNaN;
    return statistic == SamplingStatistic::Mean ? sum / n : best;
  }
};

// Counts the partial segments of the vertices inside the field of view (partial[v] != 0).
void count_partial(const std::vector<char>& partial, SamplingResult& r) {
  r.partial_vertices = 0;
  for (char p : partial) r.partial_vertices += p != 0;
}

constexpr double kMinStepMm = 0.05;

double default_step(const io::Volume& volume, const SamplingOptions& options) {
  const double half_voxel = 0.5 * volume.voxel_size().minCoeff();
  if (!(half_voxel > 0) || !std::isfinite(half_voxel))
    throw InputError(volume_name(volume) + ": voxel size is zero or not finite; the file's affine is broken");
  // The step is bounded below so that the sample count stays an int and the run stays short
  // (a 10 mm ribbon at 0.05 mm is 200 samples; 1e-9 mm overflowed the count).
  if (!std::isfinite(options.step_mm) || options.step_mm < 0 || (options.step_mm > 0 && options.step_mm < kMinStepMm))
    throw InputError("--step " + format_number(options.step_mm) + " mm: give a step of at least " + format_number(kMinStepMm) +
                     " mm (or none: half the smallest voxel)");
  if (options.step_mm > 0) return std::min(options.step_mm, half_voxel);
  return half_voxel;
}

// Counts NaN vertices; refuses a result with no usable value (issue 8: an all-NaN or all-zero PET
// would otherwise give maps of nothing without a word).
void finish(SamplingResult& r, const io::Volume& volume) {
  r.nan_vertices = 0;
  int finite = 0, nonzero = 0;
  for (Eigen::Index v = 0; v < r.values.size(); ++v) {
    if (std::isnan(r.values(v))) ++r.nan_vertices;
    if (std::isfinite(r.values(v))) ++finite, nonzero += r.values(v) != 0;
  }
  if (r.vertices_checked > 0 && finite == 0)
    throw InputError(volume_name(volume) + ": no finite value could be sampled at any of the surface's " +
                     std::to_string(r.vertices_checked) +
                     " vertices (the voxels there are NaN); check the PET file and its registration to the surface");
  if (finite > 0 && nonzero == 0)
    throw InputError(volume_name(volume) + ": every value sampled at the surface's " + std::to_string(finite) +
                     " vertices is 0 (an empty or all-zero PET?); check the PET file");
  // NaN vertices among those used, beyond the ones outside the field of view (noted already).
  if (r.partial_vertices > 0)
    r.notes.push_back(std::to_string(r.partial_vertices) + " vertices have part of their sampling segment outside the field of view "
                      "or on NaN or infinite voxels; they are NaN in the output and left out of means (a value from part of the segment "
                      "would lean toward one end of it)");
  const int nan_inside =
      r.nan_vertices - (static_cast<int>(r.values.size()) - r.vertices_checked) - r.vertices_outside - r.partial_vertices;
  if (nan_inside > 0)
    r.notes.push_back(std::to_string(nan_inside) + " vertices have no finite value (NaN or infinite voxels); they are NaN in the "
                      "output and left out of means");
}

std::string stat_name(SamplingStatistic s) { return s == SamplingStatistic::Mean ? "mean" : "max"; }

}  // namespace

// ---- trilinear interpolation -------------------------------------------------------------

TrilinearSampler::TrilinearSampler(const io::Volume& volume) : volume_(&volume) {
  if (volume.num_voxels() == 0 || volume.data.size() != volume.num_voxels())
    throw InputError(volume_name(volume) + ": the volume is empty or its data do not match its dimensions");
  const Eigen::Matrix3d A = volume.vox2ras.block<3, 3>(0, 0);
  if (!(std::abs(A.determinant()) > 0) || !A.allFinite())
    throw InputError(volume_name(volume) + ": the voxel-to-world affine is singular; the file's sform/qform is broken");
  ras2vox_ = A.inverse();
  ras2vox_t_ = -ras2vox_ * volume.vox2ras.block<3, 1>(0, 3);
}

bool TrilinearSampler::inside(const Eigen::Vector3d& world) const {
  const Eigen::Vector3d x = to_index(world);
  for (int a = 0; a < 3; ++a)
    if (!(x(a) >= -0.5 && x(a) <= volume_->dims[a] - 0.5)) return false;
  return true;
}

double TrilinearSampler::at_index(const Eigen::Vector3d& x) const {
  const auto& d = volume_->dims;
  int i0[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    if (!(x(a) >= -0.5 && x(a) <= d[a] - 0.5)) return kNaN;  // also catches NaN
    // Clamp the outer half voxel onto the edge centres (constant extrapolation).
    const double c = std::clamp(x(a), 0.0, static_cast<double>(d[a] - 1));
    int lo = static_cast<int>(std::floor(c));
    if (lo >= d[a] - 1) lo = std::max(0, d[a] - 2);
    i0[a] = lo;
    t[a] = d[a] == 1 ? 0.0 : c - lo;
  }
  const std::size_t sx = 1, sy = static_cast<std::size_t>(d[0]), sz = sy * static_cast<std::size_t>(d[1]);
  const std::size_t step[3] = {d[0] > 1 ? sx : 0, d[1] > 1 ? sy : 0, d[2] > 1 ? sz : 0};
  const std::size_t base = static_cast<std::size_t>(i0[0]) * sx + static_cast<std::size_t>(i0[1]) * sy +
                           static_cast<std::size_t>(i0[2]) * sz;
  const float* p = volume_->data.data();
  double sum = 0.0, wsum = 0.0;
  bool all_finite = true;
  for (int c = 0; c < 8; ++c) {
    const int bx = c & 1, by = (c >> 1) & 1, bz = (c >> 2) & 1;
    const double w = (bx ? t[0] : 1 - t[0]) * (by ? t[1] : 1 - t[1]) * (bz ? t[2] : 1 - t[2]);
    const double v = p[base + bx * step[0] + by * step[1] + bz * step[2]];
    if (!std::isfinite(v)) {  // NaN (and Inf) voxels: the other corners are re-weighted
      if (w > 0) all_finite = false;
      continue;
    }
    sum += w * v;
    wsum += w;
  }
  if (all_finite) return sum;
  return wsum > 0 ? sum / wsum : kNaN;
}

MatrixXd transform_points(const Eigen::Matrix4d& T, const MatrixXd& V) {
  MatrixXd out(V.rows(), 3);
  const Eigen::Matrix3d A = T.block<3, 3>(0, 0);
  const Eigen::Vector3d b = T.block<3, 1>(0, 3);
  for (Eigen::Index i = 0; i < V.rows(); ++i) out.row(i) = (A * V.row(i).head<3>().transpose() + b).transpose();
  return out;
}

Eigen::Matrix4d parse_affine_text(const std::string& text, const std::string& what) {
  std::istringstream in(text);
  std::vector<double> numbers;
  std::string line;
  while (std::getline(in, line)) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream ls(line);
    std::string token;
    while (ls >> token) {
      try {
        std::size_t used = 0;
        const double v = std::stod(token, &used);
        if (used != token.size() || !std::isfinite(v)) throw std::invalid_argument(token);
        numbers.push_back(v);
      } catch (const std::exception&) {
        throw InputError(what + ": '" + token + "' is not a number; write the 4x4 matrix as 16 numbers, row by row");
      }
    }
  }
  if (numbers.size() != 16 && numbers.size() != 12)
    throw InputError(what + ": found " + std::to_string(numbers.size()) +
                     " numbers, expected 16 (a 4x4 matrix, row by row) or 12 (its first three rows)");
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  for (int r = 0; r < static_cast<int>(numbers.size()) / 4; ++r)
    for (int c = 0; c < 4; ++c) T(r, c) = numbers[static_cast<std::size_t>(4 * r + c)];
  if (numbers.size() == 16 && (std::abs(T(3, 0)) + std::abs(T(3, 1)) + std::abs(T(3, 2)) > 1e-9 || std::abs(T(3, 3) - 1) > 1e-9))
    throw InputError(what + ": the last row must be 0 0 0 1 (an affine matrix)");
  if (!(std::abs(T.block<3, 3>(0, 0).determinant()) > 1e-12))
    throw InputError(what + ": the matrix is singular; expected a rigid or affine surface-to-volume transform");
  return T;
}

// ---- field of view -----------------------------------------------------------------------

void check_field_of_view(const io::Volume& volume, const MatrixXd& V_world, const std::vector<bool>& use,
                         const SamplingOptions& options, SamplingResult& result) {
  const TrilinearSampler sampler(volume);
  int checked = 0, outside = 0;
  for (Eigen::Index v = 0; v < V_world.rows(); ++v) {
    if (!use.empty() && !use[static_cast<std::size_t>(v)]) continue;
    ++checked;
    if (!sampler.inside(V_world.row(v).head<3>().transpose())) ++outside;
  }
  result.vertices_checked = checked;
  result.vertices_outside = outside;
  result.outside_fraction = checked > 0 ? static_cast<double>(outside) / checked : 0.0;
  if (checked == 0) throw InputError("surface: no vertex is used by a triangle; nothing to sample");
  if (result.outside_fraction > options.max_outside_fraction)
    throw InputError(volume_name(volume) + ": " + format_number(100.0 * result.outside_fraction, 3) + "% of the surface's vertices (" +
                     std::to_string(outside) + " of " + std::to_string(checked) +
                     ") lie outside the volume's field of view; check that the surface belongs to this scan and " +
                     options.alignment_hint);
  if (outside > 0)
    result.notes.push_back(std::to_string(outside) + " of " + std::to_string(checked) + " vertices (" +
                           format_number(100.0 * result.outside_fraction, 3) + "%) lie outside the volume's field of view");
}

// ---- sampling modes ----------------------------------------------------------------------

SamplingResult sample_normal_projection(const io::Volume& volume, const MatrixXd& V_world, const MatrixXi& F,
                                        const SamplingOptions& options) {
  const int nv = static_cast<int>(V_world.rows());
  check_faces(F, nv);
  if (!(options.depth_mm >= 0) || !std::isfinite(options.depth_mm))
    throw InputError("--depth: must be a finite number of mm >= 0");
  SamplingResult r;
  const auto used = used_vertices(F, nv);
  check_field_of_view(volume, V_world, used, options, r);

  const double max_step = default_step(volume, options);
  // The tolerance absorbs a voxel size stored in single precision (1.9999999 mm made 11 intervals
  // of 0.909 mm where 10 of 1 mm were meant).
  const int intervals = options.depth_mm > 0 ? std::max(1, static_cast<int>(std::ceil(options.depth_mm / max_step - 1e-6))) : 0;
  r.step_mm = intervals > 0 ? options.depth_mm / intervals : 0.0;
  r.samples_per_vertex = intervals + 1;

  MatrixXd N = vertex_normals(V_world, F);
  // Orientation: on a cortical surface the outward normals point away from its centroid on the
  // whole (exactly 3 x the enclosed volume for a closed surface). Clockwise faces flip them.
  const VectorXd area = barycentric_vertex_areas(V_world, F);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double total = 0;
  for (int v = 0; v < nv; ++v)
    if (used[static_cast<std::size_t>(v)]) {
      centroid += area(v) * V_world.row(v).head<3>().transpose();
      total += area(v);
    }
  if (total > 0) centroid /= total;
  double flux = 0;
  for (int v = 0; v < nv; ++v)
    if (used[static_cast<std::size_t>(v)]) flux += area(v) * N.row(v).dot(V_world.row(v).head<3>() - centroid.transpose());
  if (flux < 0) {
    N = -N;
    r.normals_flipped = true;
    r.notes.push_back("the surface's triangles are clockwise seen from outside: vertex normals were reversed so that "
                      "'inward' points into the cortex");
  }
  const double sign = options.outward ? 1.0 : -1.0;

  const TrilinearSampler sampler(volume);
  r.values = VectorXd::Constant(nv, kNaN);
  std::vector<char> partial(static_cast<std::size_t>(nv), 0);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < nv; ++v) {
    if (!used[static_cast<std::size_t>(v)]) continue;
    const Eigen::Vector3d n = N.row(v).transpose();
    if (n.squaredNorm() == 0) continue;
    // Walk in voxel indices: one affine transform per vertex, not per sample.
    const Eigen::Vector3d x = sampler.to_index(V_world.row(v).head<3>().transpose());
    const Eigen::Vector3d d = sampler.direction_to_index((sign * r.step_mm) * n);
    SegmentStat s{options.statistic};
    for (int k = 0; k <= intervals; ++k) s.add(sampler.at_index(x + k * d));
    r.values(v) = s.value();
    partial[static_cast<std::size_t>(v)] = s.partial() && sampler.inside(V_world.row(v).head<3>().transpose());
  }
  count_partial(partial, r);
  r.method = std::string("normal projection, ") + (options.outward ? "outward" : "inward (inverse normal)") + ", depth " +
             format_number(options.depth_mm) + " mm, step " + format_number(r.step_mm) + " mm, " +
             std::to_string(r.samples_per_vertex) + " samples, " + stat_name(options.statistic) + ", trilinear";
  finish(r, volume);
  return r;
}

SamplingResult sample_ribbon(const io::Volume& volume, const MatrixXd& white_world, const MatrixXd& pial_world,
                             const MatrixXi& F, const SamplingOptions& options) {
  if (white_world.rows() != pial_world.rows())
    throw InputError("--ribbon: the two surfaces have " + std::to_string(white_world.rows()) + " and " +
                     std::to_string(pial_world.rows()) +
                     " vertices; ribbon mode needs the white and pial surfaces of one subject (same vertices)");
  const int nv = static_cast<int>(white_world.rows());
  check_faces(F, nv);
  SamplingResult r;
  const auto used = used_vertices(F, nv);
  check_field_of_view(volume, pial_world, used, options, r);
  const double max_step = default_step(volume, options);
  r.step_mm = max_step;
  const int min_intervals = std::max(1, options.min_ribbon_samples - 1);
  r.samples_per_vertex = min_intervals + 1;

  const TrilinearSampler sampler(volume);
  r.values = VectorXd::Constant(nv, kNaN);
  std::vector<char> partial(static_cast<std::size_t>(nv), 0);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < nv; ++v) {
    if (!used[static_cast<std::size_t>(v)]) continue;
    const Eigen::Vector3d a = white_world.row(v).head<3>().transpose();
    const Eigen::Vector3d b = pial_world.row(v).head<3>().transpose();
    const double length = (b - a).norm();
    const int intervals = std::max(min_intervals, static_cast<int>(std::ceil(length / max_step - 1e-6)));
    const Eigen::Vector3d ia = sampler.to_index(a), ib = sampler.to_index(b);
    SegmentStat s{options.statistic};
    for (int k = 0; k <= intervals; ++k) {
      const double t = static_cast<double>(k) / intervals;
      s.add(sampler.at_index((1 - t) * ia + t * ib));
    }
    r.values(v) = s.value();
    partial[static_cast<std::size_t>(v)] = s.partial() && sampler.inside(b);  // the field of view is checked at the pial end
  }
  count_partial(partial, r);
  r.method = "ribbon (white to pial segment), at least " + std::to_string(r.samples_per_vertex) + " samples, step <= " +
             format_number(max_step) + " mm, " + stat_name(options.statistic) + ", trilinear";
  finish(r, volume);
  return r;
}

SamplingResult sample_at_vertices(const io::Volume& volume, const MatrixXd& V_world, const MatrixXi& F,
                                  const SamplingOptions& options) {
  const int nv = static_cast<int>(V_world.rows());
  check_faces(F, nv);
  SamplingResult r;
  check_field_of_view(volume, V_world, {}, options, r);
  const TrilinearSampler sampler(volume);
  r.values.resize(nv);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < nv; ++v) r.values(v) = sampler(V_world.row(v).head<3>().transpose());
  r.samples_per_vertex = 1;
  r.method = "trilinear value at each vertex";
  finish(r, volume);
  return r;
}

// ---- normalisation -----------------------------------------------------------------------

std::string to_string(NormalisationKind kind) {
  switch (kind) {
    case NormalisationKind::None: return "none";
    case NormalisationKind::GlobalMean: return "global";
    case NormalisationKind::ReferenceRegion: return "reference-region";
  }
  return "none";
}

Normalisation global_cortical_mean(const VectorXd& values, const MatrixXd& V, const MatrixXi& F) {
  if (values.size() != V.rows())
    throw InputError("values: " + std::to_string(values.size()) + " values for a surface of " + std::to_string(V.rows()) +
                     " vertices");
  const VectorXd area = barycentric_vertex_areas(V, F);
  double sum = 0, sum_abs = 0, weight = 0;
  int count = 0;
  for (Eigen::Index v = 0; v < values.size(); ++v) {
    if (!(area(v) > 0) || !std::isfinite(values(v))) continue;
    sum += area(v) * values(v);
    sum_abs += area(v) * std::abs(values(v));
    weight += area(v);
    ++count;
  }
  if (!(weight > 0) || !(sum / weight > 0))
    throw InputError("global normalisation: the cortical mean of the sampled values is " +
                     (weight > 0 ? format_number(sum / weight) : std::string("undefined")) +
                     " (not positive); use --normalize none or a reference-region mask");
  // Uptake is positive almost everywhere, so the mean is close to the mean magnitude; noise
  // around zero (an empty or misregistered PET) has a tiny mean and would give ratios of +-50.
  if (sum < 0.5 * sum_abs)
    throw InputError("global normalisation: the cortical mean " + format_number(sum / weight) + " is small against the mean magnitude " +
                     format_number(sum_abs / weight) +
                     " of the sampled values: the PET on the cortex is mostly noise around zero (an empty PET, or one "
                     "not registered to the surfaces?); check it, or use --normalize none");
  Normalisation n;
  n.kind = NormalisationKind::GlobalMean;
  n.reference_value = sum / weight;
  n.count = count;
  n.units = "ratio to the global cortical mean";
  n.description = "global: divided by the area-weighted cortical mean " + format_number(n.reference_value, 6) + " over " +
                  std::to_string(count) + " vertices";
  return n;
}

Normalisation reference_region_mean(const io::Volume& pet, const io::Volume& mask) {
  const std::string name = mask.source_path.empty() ? std::string("mask") : mask.source_path;
  if (mask.num_voxels() == 0 || mask.data.size() != mask.num_voxels())
    throw InputError(name + ": the mask is empty; give a NIfTI mask of the reference region (1 inside, 0 outside)");
  const TrilinearSampler sampler(pet);
  double sum = 0;
  int count = 0, in_mask = 0;
  // Sequential sum in voxel order: the result does not depend on the thread count.
  for (int k = 0; k < mask.dims[2]; ++k)
    for (int j = 0; j < mask.dims[1]; ++j)
      for (int i = 0; i < mask.dims[0]; ++i) {
        if (!(mask.at(i, j, k) > 0.5f)) continue;
        ++in_mask;
        const Eigen::Vector3d world = (mask.vox2ras * Eigen::Vector4d(i, j, k, 1)).head<3>();
        const double v = sampler(world);
        if (std::isnan(v)) continue;
        sum += v;
        ++count;
      }
  if (in_mask == 0)
    throw InputError(name + ": no voxel of the mask is > 0.5; give a binary mask of the reference region (e.g. cerebellum)");
  if (count == 0)
    throw InputError(name + ": none of the mask's " + std::to_string(in_mask) +
                     " voxels lies inside the PET's field of view; the mask must be in the PET's (or the same scanner) space");
  const double mean = sum / count;
  if (!(mean > 0))
    throw InputError(name + ": the mean PET value inside the reference region is " + format_number(mean) +
                     " (not positive); check that the mask covers tissue in this PET");
  Normalisation n;
  n.kind = NormalisationKind::ReferenceRegion;
  n.reference_value = mean;
  n.count = count;
  n.mask_path = mask.source_path;
  n.units = "SUVR";
  n.description = "reference-region: divided by the mean " + format_number(mean, 6) + " over " + std::to_string(count) +
                  " voxels of " + name + " (SUV ratio)";
  if (count < in_mask)
    n.description += "; " + std::to_string(in_mask - count) + " mask voxels outside the PET or NaN were left out";
  return n;
}

void apply_normalisation(VectorXd& values, const Normalisation& normalisation) {
  if (normalisation.kind == NormalisationKind::None) return;
  values /= normalisation.reference_value;
}

}  // namespace authalic::analysis

#pragma once
// PET on the cortex: values of a volume sampled at, below or between cortical surfaces
// (the "normal fusion" of Zou et al. 2011, `000_9f60545f35b9287a.txt` section 5.2: "the PET tracer
// concentration is calculated by averaging its measurement along the inverse normal direction
// within 10 mm from the cortical surface"), and intensity normalisation (SUV ratios).
//
// Coordinates. Everything here works in the volume's world space, scanner RAS mm:
// world = vox2ras * (i, j, k, 1), whatever the axes' signs (radiological files, whose sform has a
// negative x axis, need nothing special). Surface vertices are moved into that space first with
// a 4x4 surface-to-volume matrix (io::Surface::to_scanner for FreeSurfer surfaces: tkregister
// RAS + c_ras; or an explicit matrix); normals are computed after the move, so depths are mm of
// the volume's world.
//
// Interpolation is trilinear between voxel centres. Out of the field of view: a point within half
// a voxel of the outer voxel centres takes the edge value (the outer voxels' own extent), anything
// further is NaN. NaN (and infinite) voxels, masked-out scanner data, are left out: the finite
// corners of the interpolation cell are re-weighted; a point whose corners are all NaN is NaN. A
// vertex whose segment has such a sample (part of it outside the field of view or on NaN voxels)
// is NaN: the statistic of the rest would describe one end of the segment only.
#include <Eigen/Core>

#include <string>
#include <vector>

#include "core/mesh.h"
#include "io/volume_io.h"

namespace authalic::analysis {

// Trilinear interpolation of a volume at world points (RAS mm). Cheap to copy; keeps a pointer
// to the volume, which must outlive it.
class TrilinearSampler {
 public:
  explicit TrilinearSampler(const io::Volume& volume);
  // Value at a world point; NaN outside the field of view (see above).
  double operator()(const Eigen::Vector3d& world) const { return at_index(to_index(world)); }
  // Value at continuous voxel indices (i, j, k), voxel centres at integers.
  double at_index(const Eigen::Vector3d& index) const;
  Eigen::Vector3d to_index(const Eigen::Vector3d& world) const { return ras2vox_ * world + ras2vox_t_; }
  // A world displacement (mm) in voxel indices.
  Eigen::Vector3d direction_to_index(const Eigen::Vector3d& d) const { return ras2vox_ * d; }
  // Is the world point within the field of view (half a voxel beyond the outer voxel centres)?
  bool inside(const Eigen::Vector3d& world) const;

 private:
  const io::Volume* volume_;
  Eigen::Matrix3d ras2vox_;
  Eigen::Vector3d ras2vox_t_;
};

// Applies a 4x4 affine to points (#V x 3): rows p -> (T * (p, 1)).head(3).
MatrixXd transform_points(const Eigen::Matrix4d& T, const MatrixXd& V);
// Parses a 4x4 matrix written as 16 (or 12: the last row 0 0 0 1 implied) whitespace-separated
// numbers, row by row; '#' starts a comment. Throws InputError naming `what` (e.g. the file).
Eigen::Matrix4d parse_affine_text(const std::string& text, const std::string& what);

enum class SamplingStatistic { Mean, Max };

struct SamplingOptions {
  double depth_mm = 10.0;        // normal projection: segment length below (or above) the surface
  double step_mm = 0.0;          // <= 0: half the smallest voxel size (the largest allowed step)
  bool outward = false;          // along +normal instead of the inverse normal
  SamplingStatistic statistic = SamplingStatistic::Mean;  // max as in 3D-SSP
  int min_ribbon_samples = 11;   // ribbon mode: at least this many samples from white to pial
  // Refuse (InputError) when more than this fraction of the vertices is outside the field of view.
  double max_outside_fraction = 0.5;
  // What that refusal tells the user to check, besides whether the surface belongs to the scan.
  std::string alignment_hint = "the surface-to-volume transform (--surface-to-volume, FreeSurfer c_ras)";
};

struct SamplingResult {
  VectorXd values;               // #V; NaN where nothing could be sampled
  std::string method;            // e.g. "normal projection, inward, depth 10 mm, step 1 mm, 11 samples, mean"
  double step_mm = 0.0;          // the step actually used (depth / number of intervals)
  int samples_per_vertex = 0;    // normal projection: depth/step + 1; ribbon: the minimum
  int vertices_checked = 0;      // vertices taking part (used by a face; all in vertex mode)
  int vertices_outside = 0;      // of those, outside the field of view (at the vertex itself)
  double outside_fraction = 0.0;
  int nan_vertices = 0;          // vertices whose value is NaN
  // Vertices inside the field of view whose segment has a sample outside it or on NaN voxels:
  // NaN, as a statistic over part of the segment leans toward one end of it (the deeper, white
  // matter end where the PET's field of view cuts the cortex).
  int partial_vertices = 0;
  bool normals_flipped = false;  // faces were clockwise seen from outside: normals were reversed
  std::vector<std::string> notes;
};

// Field-of-view check shared by all modes: counts the vertices (rows of V_world with use[v],
// or all when use is empty) outside the volume, and throws InputError naming the volume with the
// fraction when it exceeds options.max_outside_fraction.
void check_field_of_view(const io::Volume& volume, const MatrixXd& V_world, const std::vector<bool>& use,
                         const SamplingOptions& options, SamplingResult& result);

// Normal projection: for each vertex used by F, `statistic` of the trilinear samples at
// x - t n (t = 0, step, ..., depth; +t n when outward), n the area-weighted unit vertex normal of
// the surface in world space. The step is the largest step <= the requested one (default: half
// the smallest voxel size) that divides the depth, so the samples are evenly spread and include
// both ends: for a volume linear in world position the mean equals the value at the segment's
// midpoint exactly. Normals are checked to point outward (sum of area-weighted n . (x - centroid)
// > 0) and reversed with a note when the faces are clockwise. Vertices used by no face are NaN.
SamplingResult sample_normal_projection(const io::Volume& volume, const MatrixXd& V_world, const MatrixXi& F,
                                        const SamplingOptions& options = {});

// Ribbon mode: `statistic` of evenly spaced samples on the segment from white(v) to pial(v)
// (both ends included; intervals = max(min_ribbon_samples - 1, ceil(length / step))). The two
// surfaces must have the same vertices (white and pial of one FreeSurfer subject).
SamplingResult sample_ribbon(const io::Volume& volume, const MatrixXd& white_world, const MatrixXd& pial_world,
                             const MatrixXi& F, const SamplingOptions& options = {});

// Trilinear value at each vertex (`--trilinear`), as wb_command -volume-to-surface-mapping -trilinear.
SamplingResult sample_at_vertices(const io::Volume& volume, const MatrixXd& V_world, const MatrixXi& F,
                                  const SamplingOptions& options = {});

// ---- intensity normalisation -------------------------------------------------------------

enum class NormalisationKind { None, GlobalMean, ReferenceRegion };
// "none", "global", "reference-region" (the names stored in every output's metadata).
std::string to_string(NormalisationKind kind);

struct Normalisation {
  NormalisationKind kind = NormalisationKind::None;
  double reference_value = 1.0;  // the divisor, in the volume's units
  int count = 0;                 // vertices (global) or mask voxels (reference region) averaged
  std::string mask_path;         // reference region: the mask file
  std::string units;             // units of the normalised values ("SUVR", "ratio to global cortical mean", ...)
  std::string description;       // one line for metadata and logs
};

// Global cortical mean: the area-weighted (barycentric vertex areas) mean of the finite values
// over the vertices used by F. Throws ProcessingError when it is not positive.
Normalisation global_cortical_mean(const VectorXd& values, const MatrixXd& V, const MatrixXi& F);
// Reference region: mean PET over the mask's voxels with value > 0.5, the PET interpolated at each
// mask voxel centre (exact when both grids coincide; any grid works, the mask need not be
// resampled first). Throws InputError naming the mask when no mask voxel lies inside the PET or the
// mean is not positive.
Normalisation reference_region_mean(const io::Volume& pet, const io::Volume& mask);
// values / reference_value, in place (NaN stays NaN).
void apply_normalisation(VectorXd& values, const Normalisation& normalisation);

}  // namespace authalic::analysis

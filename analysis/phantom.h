#pragma once
// Phantom cohort: PET scans of "controls" and "patients" on known cortical surfaces, with a planted
// hypometabolic region of known extent and depth, so the whole chain (maps, PET sampling, equal-area
// elements, normative z-scores; Zou et al. 2011, `000_9f60545f35b9287a.txt` section 5.2) can be
// checked against a ground truth.
//
// Two sources of anatomy and PET:
//  - shared data (../shared/data): fsaverage5 left white/pial with the cortex of flat_left's face
//    set, and SPM's PET template spm/PET.nii as the healthy tracer distribution;
//  - synthetic (always available; the only kind committed in sample_data/): a built-in folded
//    hemisphere (a geodesic icosphere shaped into an asymmetric ellipsoid with sinusoidal folds,
//    pial = white + 2.5 mm along the normal, medial-wall cap removed from the cortex so the cortex
//    is a disk) and a tissue-model PET (grey-matter ribbon 1.0, white matter 0.3, CSF 0.05) on a
//    regular grid.
// The right hemisphere is the mirror (x -> -x) of the left in both cases.
//
// Each subject's PET = healthy template x global scale x smooth low-frequency multiplicative field
// (x (1 - depth) in the lesion column for patients), plus noise (SD proportional to sqrt(value)),
// then blurred by a Gaussian of the subject's resolution (FWHM). The lesion column under the
// planted patch (a geodesic disk of the white surface around a posterior-parietal / precuneus
// point) is every voxel within 25 mm of the surface whose nearest surface vertex lies in the
// patch, plus every voxel within 3 mm of a patch vertex's inward normal segment (pial + 2 mm down
// to pial - 20 mm), so every sampling scheme (normal projection 10 mm inward, ribbon, trilinear)
// sees the full depth inside the patch.
#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/progress.h"
#include "io/volume_io.h"

namespace authalic::analysis {

// Deterministic random numbers on every platform (std::normal_distribution is not portable):
// SplitMix64 seeding a xoshiro256** stream, Box-Muller normals.
class PhantomRng {
 public:
  explicit PhantomRng(std::uint64_t seed);
  std::uint64_t next();
  double uniform();  // [0, 1)
  double normal();   // N(0, 1)

 private:
  std::uint64_t s_[4];
  bool has_spare_ = false;
  double spare_ = 0.0;
};

// ---- anatomy ---------------------------------------------------------------------------------

struct Hemisphere {
  TriMesh white, pial;        // same vertices (index by index) and faces, RAS mm
  std::vector<bool> cortex;   // per vertex: part of the cortex (the disk); false = medial wall
  bool left = true;
};

struct SyntheticHemisphereOptions {
  int frequency = 20;                        // geodesic icosphere frequency: 10 f^2 + 2 vertices (20 -> 4002)
  double centre[3] = {-30.0, -18.0, 12.0};   // mm, left hemisphere
  double lateral_semi_axis = 35.0;           // mm, toward -x
  double medial_semi_axis = 25.0;            // mm, toward +x (the medial side is flatter)
  double ap_semi_axis = 80.0;                // mm, y
  double si_semi_axis = 55.0;                // mm, z
  double fold_amplitude_mm = 5.0;            // radial fold amplitude (gyral crown to sulcal fundus ~ 2x)
  double fold_frequency = 14.0;              // waves per radian of the unit sphere (~ 25-30 mm apart)
  double thickness_mm = 2.5;                 // pial = white + thickness along the vertex normal
  double medial_wall_angle_deg = 38.0;       // cap around the medial axis removed from the cortex
};

// The built-in folded left hemisphere. White is a radial graph over the unit sphere,
// p(u) = c + S u + folds(u) S u / |S u| (S = semi-axes), so inside/outside tests in the PET model
// are exact.
Hemisphere synthetic_left_hemisphere(const SyntheticHemisphereOptions& options = {});
// Is the point (RAS mm) inside the synthetic left white surface (the continuous one the mesh samples)?
bool inside_synthetic_white(const Eigen::Vector3d& p, const SyntheticHemisphereOptions& options);

// x -> -x with the faces re-oriented (counter-clockwise seen from outside stays true).
Hemisphere mirror_hemisphere(const Hemisphere& hemisphere);

// Shortest-path distances along the edges (core/mesh.h).
using authalic::edge_path_distances;

// ---- PET ---------------------------------------------------------------------------------------

// Tissue-model PET of a synthetic brain (both hemispheres: x >= 0 is the mirror of the left) on a
// regular grid of `voxel_mm`: grey-matter ribbon 1.0, white matter 0.3, CSF up to 8 mm outside the
// pial 0.05, 0 beyond (outside the head); 2x2x2 supersampling gives partial-volume values. Unblurred.
io::Volume synthetic_pet_template(const Hemisphere& left, const SyntheticHemisphereOptions& options, double voxel_mm);

struct PlantedRegion {
  int centre_vertex = -1;              // on the left hemisphere
  double radius_mm = 22.0;             // geodesic (edge-path) radius on the white surface
  double depth = 0.25;                 // fractional reduction (0.25 = -25%)
  std::vector<bool> left_mask, right_mask;  // per-vertex membership (cortex vertices only)
};
// The planted patch: the cortex vertex of the left white surface nearest to `target` (RAS mm)
// and every cortex vertex within `radius_mm` of it along the surface; the right hemisphere's
// patch is the mirror image (same vertex indices).
PlantedRegion plant_region(const Hemisphere& left, const Eigen::Vector3d& target, double radius_mm, double depth);
// Default target: a posterior-parietal / precuneus-like point of each source, RAS mm.
Eigen::Vector3d default_region_target(bool synthetic, const SyntheticHemisphereOptions& options = {});

// How deep below (and above) the surface the planted reduction reaches: deeper than the 10 mm
// normal projection plus the reach of the scanner blur, so the sampled values show the full depth.
constexpr double kRegionColumnDepthMm = 25.0;
// Per-voxel multiplier: 1 - depth in the lesion column of both hemispheres, 1 elsewhere.
std::vector<float> region_multiplier(const io::Volume& grid, const Hemisphere& left, const Hemisphere& right,
                                     const PlantedRegion& region, double column_depth_mm = kRegionColumnDepthMm);

struct SubjectEffects {
  double global_scale = 1.0;         // multiplies everything (absolute quantitation varies)
  // Low-frequency multiplicative field 1 + a cos(k . x + phi): one plane wave of wavelength
  // 150-300 mm in a random direction.
  double field_amplitude = 0.0;
  double field_wave[3] = {0, 0, 0};  // k, rad/mm
  double field_phase = 0.0;
  // Regional variability: the head is cut into fixed cubes of parcel_mm (the same regions in
  // every subject); each subject multiplies each cube by its own 1 + U(-a, a), independently.
  // Independent regions make the share of abnormal elements of a healthy subject stable from one
  // subject to the next, and the uniform law keeps the tails of the element values light.
  double parcel_amplitude = 0.0;
  double parcel_mm = 25.0;
  std::uint64_t parcel_seed = 0;
  double noise_fraction = 0.04;      // noise SD = noise_fraction * sqrt(value * reference), before the blur
  double fwhm_mm = 7.0;              // Gaussian resolution blur
  std::uint64_t noise_seed = 0;
};
// Random effects of one subject (deterministic given the generator state): global scale
// exp(N(0, 0.1)), field amplitude 0.02, regional amplitude 0.10 on 25 mm cubes, FWHM uniform in
// [6, 8] mm, noise 4 %.
SubjectEffects draw_subject_effects(PhantomRng& rng);

// Applies one subject's effects to the healthy template: template x scale x field x multiplier,
// noise, blur; `reference` is the template's grey-matter level in output units (e.g. 8000 Bq/mL
// for GM = 1.0). An empty multiplier means no lesion. Values are rounded to whole units; voxels
// where the template is 0 (outside the head) stay 0.
io::Volume subject_pet(const io::Volume& healthy, const SubjectEffects& effects, const std::vector<float>& multiplier,
                       double reference);

// Separable Gaussian blur (FWHM mm, per-axis voxel sizes from the affine), edges clamped.
void gaussian_blur(io::Volume& volume, double fwhm_mm);

// ---- the cohort on disk -------------------------------------------------------------------

struct PhantomOptions {
  int controls = 20;
  int patients = 2;
  std::uint64_t seed = 1;
  bool synthetic = false;       // force the synthetic source even when shared data exist
  std::string shared_dir;       // ../shared/data; empty or missing = synthetic
  double voxel_mm = 3.0;        // synthetic PET grid
  double region_radius_mm = 22.0;
  double region_depth = 0.25;
  SyntheticHemisphereOptions synthetic_options;
  // Anatomical variability (issue 14, analysis/phantom_anatomy.h; shared data only): every subject
  // gets its own smooth random variant of the template's anatomy, with its sphere.reg (the exact
  // correspondence) and its PET carried by the same deformation; the lesion is planted in template
  // (atlas) coordinates. The template is written as an atlas folder OUT/atlas (FreeSurfer layout).
  bool anatomical_variability = false;
  double area_change = 0.15;  // local surface area changes up to about this fraction
  double deformation_wavelength_mm = 120.0;  // of the area changes (analysis/phantom_anatomy.h)
  double fold_change = 0.12;  // normal offset per mm of sulcal depth (folding change), at most
};

struct PhantomSubject {
  std::string id;     // "control01", "patient01"
  std::string role;   // "control" or "patient"
  double age = 0;     // years
  std::string pet;    // path relative to the output folder
  SubjectEffects effects;
};

struct PhantomResult {
  std::string source;  // "synthetic" or "shared: fsaverage5 + spm/PET.nii"
  std::vector<PhantomSubject> subjects;
  std::string cohort_csv;  // absolute path
  PlantedRegion region;
  double region_area_mm2 = 0;  // white-surface area of the left patch (barycentric vertex areas)
};

// Writes the cohort into out_dir (created; existing files with the same names are replaced
// atomically):
//   cohort.csv        subject_id,role,age,pet,lh_white,lh_pial,rh_white,rh_pial,lh_cortex,rh_cortex
//                     (paths relative to out_dir)
//   phantom.json      generator, seed, source, per-subject effects, planted region
//   surf/{lh,rh}.{white,pial}   FreeSurfer surfaces (scanner RAS, c_ras = 0)
//   label/{lh,rh}.cortex.label  FreeSurfer labels of the cortex (the disk)
//   truth/{lh,rh}.lesion.label.gii  per-vertex planted region (1) / healthy (0); truth/lesion.json
//   sub-<id>/sub-<id>_pet.nii.gz    PET (Bq/mL, float32)
// With anatomical_variability the subjects' anatomy is their own: cohort.csv points at
//   sub-<id>/surf/{lh,rh}.{white,pial,sphere.reg}, sub-<id>/label/{lh,rh}.cortex.label (columns
//   lh_sphere_reg, rh_sphere_reg added), sub-<id>/truth/{lh,rh}.lesion.label.gii (the lesion carried
//   over) and sub-<id>/truth/{lh,rh}.atlas_uv.func.gii (the atlas map at each vertex's corresponding
//   atlas point: the ground truth of element correspondence); the template is OUT/atlas.
// Same options (seed included) -> byte-identical files.
PhantomResult write_phantom(const std::string& out_dir, const PhantomOptions& options, const ProgressFn& progress = {});

}  // namespace authalic::analysis

#pragma once
// Normative reference of equal-area cortical elements from control subjects, and the comparison of
// a patient with it (Zou et al. 2011a section 5.2, last paragraph:
// "once normative brain patterns for each element are derived from a group of control subjects,
// whether a particular cortical element derived from a patient falls into the abnormal can be
// subsequently determined according to the comparison against the normative reference"; the
// element-wise z-score of NEUROSTAT/3D-SSP).
//
// Statistics. Per element, over the controls whose value there is finite: n, mean and M2 (sum of
// squared deviations) by Welford's online update, so a reference is built streaming, one table
// at a time, in memory independent of the number of subjects (the values kept for the chance
// clusters, below, stop growing at kMaxChanceControls subjects). When every control has an age, the
// age's mean and M2 and the co-moment C = sum (a - mean_a)(y - mean_y) are kept as well: the
// sufficient statistics of the least-squares line y = mean_y + beta (a - mean_a), beta = C / M2_a,
// residual variance (M2_y - C^2 / M2_a) / (n - 2). Two references merge exactly with Chan, Golub &
// LeVeque's pairwise formulas (delta = mean_B - mean_A, n = n_A + n_B):
//     mean = mean_A + delta n_B / n,   M2 = M2_A + M2_B + delta^2 n_A n_B / n,
//     C = C_A + C_B + delta_a delta_y n_A n_B / n,
// so references built on separate machines and merged equal the reference of all their subjects
// up to floating-point reassociation.
//
// Chance clusters. With |z| >= 2 a healthy subject has ~5 % of its elements flagged, and
// neighbouring elements are correlated, so chance clusters of several elements are normal. The
// reference therefore also keeps each control's element values (subject_values), and a comparison
// measures how large the chance clusters get: each control is compared, as a patient, with the
// reference of the other controls (leave-one-out: the Welford update undone for its values), and
// the mass of its largest hypo and of its largest hyper cluster is kept. A cluster's mass is the
// sum over its elements of |z| - threshold (Bullmore et al., IEEE TMI 1999): a smooth healthy
// variation can flag as many elements as a lesion, but only just beyond the threshold (the sample
// phantom: one control's largest hypo cluster has 55 elements or more, as many as the planted
// region's, but the controls' masses stay below 63, against 168 and 125 for patient01's two planted
// regions). A patient's cluster of mass m gets p = (1 + controls whose largest cluster of
// its sign has mass >= m) / (1 + controls): the maximum statistic of permutation tests (Nichols &
// Holmes, Hum. Brain Mapp. 2002), with the controls as the draws from the null, so p is corrected
// for the number of elements and clusters looked at. With 20 controls the smallest p is 1/21 = 0.048.
// The values of the first kMaxChanceControls subjects are kept (a reference of 1,000 controls would
// otherwise grow with them; 100 draws resolve p to 0.01), and their leave-one-out references are
// the whole reference without each of them. Each control is judged against n - 1 controls and the
// patient against n, so p is conservative, noticeably so for small references (a reference of 5 of the sample's controls gives patient01's
// largest clusters p of 0.67 and more, as 4-control references have heavy-tailed z-scores; all 20
// give its two planted regions 0.048).
//
// Sign convention. z = (patient - expected) / SD, so hypometabolism gives negative z and an
// element is flagged abnormal at z <= -threshold (hypo) or z >= +threshold (hyper). NEUROSTAT/3D-SSP
// report the opposite sign, (normal mean - patient) / SD, as a positive "decrease" z; negate ours
// to compare with them. SD is by default the predictive SD of a new control (CompareOptions::
// predictive), slightly larger than the reference SD for small references.
//
// File format (JSON, versioned; see reference_to_json for every field):
//   {"format": "authalic-normative-reference", "version": 1, "software": "authalic 0.1.0 (rev)",
//    "domain": "square", "k": 32, "rows": 32, "cols": 32, "hemispheres": ["left", "right"],
//    "normalisation": "global", "units": "...", "correspondence": "per-subject" | "atlas <id>", "num_subjects": N, "age_model": true,
//    "subjects": [{"id": "...", "age": 61.0 | null, "table": "path"}],
//    "elements": {"n": [...], "mean": [...], "m2": [...], "age_mean": [...], "age_m2": [...],
//                 "age_value_comoment": [...], "sd": [...]},
//    "subject_values_encoding": "...", "subject_values": ["<base64>", ...]}
//   (the first 100 subjects' values, each as base64 of little-endian float64, NaN where it had
//    none; absent in files written before 2026-12-07, which compare without p)
// Arrays run over hemisphere blocks in the listed order, then element id (row * cols + col);
// "sd" is derived (sqrt(m2 / (n - 1))) for readers, and ignored when reading.
#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include "analysis/elements.h"
#include "core/progress.h"

namespace authalic::analysis {

inline constexpr int kNormativeFormatVersion = 1;
// ElementTable::metadata key of the reference-region mask's SHA-256 (written by `run` and, from
// `sample`'s output, by `elements`).
inline constexpr const char* kReferenceMaskKey = "reference_mask_sha256";

struct NormativeSubject {
  std::string id;
  double age = std::numeric_limits<double>::quiet_NaN();
  std::string table;  // the element table it came from
};

// A reference needs this many controls (normative build and merge refuse fewer): with fewer the
// SD, and so every z-score, is not a normal range.
inline constexpr int kMinControls = 3;
// Element values beyond this magnitude are refused when building a reference (their squares
// overflow the sums of squares).
// Controls whose element values a reference keeps for the chance clusters: the first ones.
inline constexpr std::size_t kMaxChanceControls = 100;
inline constexpr double kMaxReferenceValue = 1e15;

struct NormativeReference {
  ElementGrid grid;
  std::vector<std::string> hemispheres;  // blocks, in order
  std::string normalisation = "none";
  std::string units;
  std::string software;                  // of the program that wrote it
  // How elements correspond across its subjects: "per-subject" or "atlas <identity>" (issue 14,
  // analysis/atlas.h); a patient table must match (check_compatible). Files without it: per-subject.
  std::string correspondence = kPerSubjectCorrespondence;
  // SHA-256 of the reference-region mask the values were normalised with (kReferenceMaskKey of
  // the tables; "" when not reference-region or not recorded): a patient normalised with another
  // region is refused (check_compatible), its SUVRs are not the controls'.
  std::string reference_mask;
  std::vector<NormativeSubject> subjects;
  bool age_model = false;                // age statistics kept (every subject has an age)
  bool partial = false;                  // built for merging (normative build --partial): not for comparing
  // Per element (hemispheres.size() * grid.num_elements()):
  std::vector<double> n, mean, m2;       // n stored as double (exact below 2^53)
  // The values of the first min(subjects, kMaxChanceControls) subjects (in `subjects` order; NaN
  // where one had none), for the chance clusters (see the top of this file). Empty when a reference
  // without them was read or merged in.
  std::vector<std::vector<double>> subject_values;
  // Whether subject_values holds what it should (not the case after a reference without them).
  bool keeps_values() const { return subject_values.size() == std::min(subjects.size(), kMaxChanceControls); }
  std::vector<double> age_mean, age_m2, comoment;  // empty when !age_model
  int num_values() const { return static_cast<int>(hemispheres.size()) * grid.num_elements(); }
  // Sample SD of element i (NaN for n < 2).
  double sd(int i) const;
};

// The age model fits a line per element, leaving n - 2 degrees of freedom for its residual SD:
// with few controls that SD can all but vanish (3 controls, 1 degree of freedom: z-scores in the
// tens of thousands, measured on the synthetic phantom). With 8 controls it keeps 6, and each
// leave-one-out reference of the chance clusters 5.
inline constexpr int kMinAgeModelControls = 8;

// Whether z can be age adjusted against `ref`: every control had an age (age_model), there are at
// least `min_controls` of them (kMinAgeModelControls; its leave-one-out references are judged
// with one less) and the ages differ (a slope needs a spread; controls all of one age give
// age_m2 = 0 and no model).
bool has_age_model(const NormativeReference& ref, int min_controls = kMinAgeModelControls);
// The share of a healthy subject's elements expected at |z| >= threshold when element values are
// normal among the controls: with the predictive SD, z follows Student's t with n - 1 degrees of
// freedom (n - 2 with the age model); the plain SD's z is sqrt(1 + 1/n) times such a t (taking the
// age term of the inflation as 0). E.g. 6 controls, threshold 2: 10.2 %; 20 controls: 6.0 %.
double expected_abnormal_share(int controls, bool age_model, bool predictive, double threshold);
// Why a reference has no usable age model: too few controls, all of one age, or some controls
// without an age (named); "" when it has one or when no control has an age.
std::string age_model_absent_reason(const NormativeReference& ref, int min_controls = kMinAgeModelControls);

// An empty reference shaped like `table` (grid, hemispheres, normalisation, units).
NormativeReference empty_reference_like(const ElementTable& table);
// Throws InputError("<what>: <which property> differs: ... ; <hint>") when the table cannot be
// pooled with / compared against the reference (domain, K, hemispheres, normalisation, units).
void check_compatible(const NormativeReference& reference, const ElementTable& table, const std::string& what);
// Welford update with one control's table (must be compatible; a subject id already in the
// reference is refused).
void add_subject(NormativeReference& reference, const ElementTable& table, const std::string& source);
// Chan et al. pairwise merge; refuses incompatible references and subjects present in both.
NormativeReference merge_references(const NormativeReference& a, const NormativeReference& b,
                                    const std::string& a_name = "first reference",
                                    const std::string& b_name = "second reference");

// Streams the tables (parsed in parallel in small batches, added in the given order) into a
// reference. Throws InputError naming the first bad or incompatible table.
NormativeReference build_reference(const std::vector<std::string>& table_paths, const ProgressFn& progress = {});

std::string reference_to_json(const NormativeReference& reference);
NormativeReference reference_from_json(const std::string& text, const std::string& path);
void write_reference(const std::string& path, const NormativeReference& reference);  // atomic
NormativeReference read_reference(const std::string& path);
// The reference without subject s (its values' Welford update undone), for leave-one-out
// comparisons: its statistics, without subject_values. std::out_of_range for a subject whose
// values it does not keep.
NormativeReference leave_one_out(const NormativeReference& reference, std::size_t s);
// Elements with at least min_subjects controls and a finite SD > 0.
int usable_elements(const NormativeReference& reference, int min_subjects);
// Throws InputError("<what>: ...") for a reference a comparison cannot use: fewer than kMinControls
// controls, or no usable element. `normative build` and `merge` call it before writing.
void check_reference_usable(const NormativeReference& reference, const std::string& what);

// ---- comparison of a patient ------------------------------------------------------------

struct CompareOptions {
  std::string reference_name = "the normative reference";  // the file, for messages
  std::string patient_name;      // the patient's element table (file), for messages; "" names the subject
  double threshold = 2.0;        // |z| at or beyond which an element is abnormal
  bool use_age = true;           // use the age model when the reference has one and the age is known
  double age = std::numeric_limits<double>::quiet_NaN();  // patient's age (years); NaN = from the table
  int min_subjects = 3;          // elements with fewer controls get no z
  // The age model needs this many controls (kMinAgeModelControls; one less for a leave-one-out
  // reference, so that the controls' chance clusters use the patient's model).
  int age_model_min_controls = kMinAgeModelControls;
  // SD of the comparison. true: the predictive SD of a new control's value, the reference SD times
  // sqrt(1 + 1/n), with the age model the residual SD times sqrt(1 + 1/n + (age - mean age)^2 /
  // sum of squared age deviations) (the single case against a control sample: Crawford & Howell
  // 1998, Crawford & Garthwaite 2006). It accounts for the reference's own uncertainty, so that a
  // healthy subject has ~5 % of elements at |z| >= 2 also with ~20 controls (the plain SD flags
  // more: 6.4 % in the sample phantom's leave-one-out, 4.9 % with the predictive SD). false: the
  // plain reference SD (NEUROSTAT/3D-SSP), nearly the same for large references.
  bool predictive = true;
  // Rescale the patient's values to the reference before z, by the one factor s that best fits
  // the elements found normal (|z| < threshold), refitted until that set settles. The tables are
  // normalised to the global cortical mean, which a focal hypometabolism lowers: every healthy
  // element then looks relatively hypermetabolic (Borghammer et al., NeuroImage 2008; Yakushev et
  // al.'s data-driven reference cluster, NeuroImage 2009, is the same idea). Fitting s on the
  // normal elements only takes that bias out; for a healthy subject s stays within ~1 % of 1.
  // false: the values as they are (the global normalisation alone).
  bool rescale = true;
  // Measure the chance clusters of the controls (leave-one-out, see the top of this file) and give
  // each cluster its p; needs a reference with subject_values and at least kMinControls + 1 controls.
  bool chance_clusters = true;
};

struct ElementCluster {
  int id = 0;                    // 1-based, in the order below
  int block = 0;
  std::string hemisphere;
  int sign = -1;                 // -1 hypo (z <= -threshold), +1 hyper
  std::vector<int> elements;     // element ids within the block, ascending
  double area_mm2 = 0.0;         // patient's cortical area of the elements
  double peak_z = 0.0;           // most extreme z
  double mean_z = 0.0;
  int peak_element = -1, peak_row = -1, peak_col = -1;
  Eigen::Vector3d peak_ras = Eigen::Vector3d::Zero();  // centroid of the peak element, scanner RAS mm
  double mass = 0.0;             // sum over its elements of |z| - threshold
  // Chance clusters (CompareOptions::chance_clusters): the controls whose largest cluster of this
  // sign has at least this mass, and p = (1 + that) / (1 + controls); -1 and NaN when not measured.
  int controls_as_large = -1;
  double p_controls = std::numeric_limits<double>::quiet_NaN();
};

struct Comparison {
  // Per value (blocks x elements, as NormativeReference):
  std::vector<double> z, expected, sd;  // sd: the SD z is measured in
  std::vector<int> flag;         // -1 hypo, +1 hyper, 0 normal or no z
  std::vector<int> cluster;      // cluster id, 0 = none
  std::vector<ElementCluster> clusters;  // by size (elements) descending, then |peak z|, then position
  bool age_adjusted = false;
  bool predictive = true;        // sd is the predictive SD (CompareOptions::predictive)
  // CompareOptions::rescale: z = (scale * value - expected) / sd; scale = 1 when not rescaled.
  bool rescaled = false;
  double scale = 1.0;
  int scale_elements = 0;        // elements the factor was fitted on (found normal)
  int scale_rounds = 0;
  double patient_age = std::numeric_limits<double>::quiet_NaN();
  int num_compared = 0, num_hypo = 0, num_hyper = 0, num_without_z = 0;
  double threshold = 2.0;
  // Chance clusters: per control (leave-one-out), the mass of its largest hypo and hyper cluster
  // (0: none); empty when not measured (chance_note says why).
  std::vector<double> control_mass_hypo, control_mass_hyper;
  std::string chance_note;
  std::vector<std::string> notes;
};

// z-scores, flags and clusters. Clusters join abnormal elements of the same sign that touch
// (8-neighbourhood): on the rectangle not across the hemisphere seam (between columns K-1 and K);
// on the sphere wrapping in longitude (column cols-1 touches column 0); never across blocks. Then,
// with options.chance_clusters, the controls' chance clusters and each cluster's p (the controls
// are given the patient's seam: the reference does not keep theirs).
Comparison compare_to_reference(const NormativeReference& reference, const ElementTable& patient,
                                const CompareOptions& options = {});

// ---- outputs of a comparison -------------------------------------------------------------

struct ComparisonOutputPaths {
  std::string z_nifti, z_png, abnormal_csv, summary_json;
  std::vector<std::string> z_func;  // one per block given vertex elements
  std::vector<std::string> all() const;
};
// The paths write_comparison_outputs writes for PREFIX; with_vertices[b]: block b gets a
// per-vertex z file (its vertex_elements entry is non-empty).
ComparisonOutputPaths comparison_output_paths(const std::string& prefix, const std::vector<std::string>& hemispheres,
                                              const std::vector<bool>& with_vertices);
// Writes:
//   PREFIX_z.nii.gz        cols x rows x blocks float image of z (NaN where no z)
//   PREFIX_z.png           the z elements per block, diverging colour map over [-5, 5], colour bar
//   PREFIX_z.func.gii      per-vertex z (the z of the vertex's element; NaN outside), for each block
//                          whose vertex_elements entry is non-empty; with several blocks
//                          PREFIX_<hemisphere>_z.func.gii
//   PREFIX_abnormal.csv    one row per abnormal element: hemisphere,id,row,col,value,expected,sd,z,
//                          (value: the patient's value times the rescaling factor, so z = (value - expected) / sd)
//                          direction,cluster,area_mm2,centroid_x_mm,centroid_y_mm,centroid_z_mm
//   PREFIX.json            summary: reference, patient, threshold, counts, clusters, outputs
// vertex_elements[b](v) = element id of vertex v in block b (-1 none), e.g. from the element label
// file (key - 1) or ElementResult::vertex_element.
ComparisonOutputPaths write_comparison_outputs(const std::string& prefix, const NormativeReference& reference,
                                               const std::string& reference_path, const ElementTable& patient,
                                               const std::string& patient_path, const Comparison& comparison,
                                               const std::vector<VectorXi>& vertex_elements);
// The clusters as a JSON array (id, hemisphere, sign, num_elements, area_mm2, peak_z, mean_z,
// peak element/row/col, peak_ras_mm, mass, controls_as_large, p_controls): the summary's "clusters" and
// `run --json`'s.
std::string clusters_json(const std::vector<ElementCluster>& clusters);
// The chance clusters of a comparison as JSON: per control the mass of its largest hypo and hyper
// cluster, the definition of p, or why they were not measured.
std::string chance_clusters_json(const Comparison& comparison);
// The summary JSON document written above (also printed by --json).
std::string comparison_summary_json(const NormativeReference& reference, const std::string& reference_path,
                                    const ElementTable& patient, const std::string& patient_path,
                                    const Comparison& comparison, const ComparisonOutputPaths& paths);

// Cluster labelling on one block's grid (exposed for tests): flags per element (-1/0/+1) ->
// cluster index per element (0 = none, 1..m), the number of clusters in *count.
std::vector<int> label_clusters(const ElementGrid& grid, const std::vector<int>& flags, int* count);

}  // namespace authalic::analysis

#pragma once
// The clinician's per-subject pipeline (`authalic run`, issue 7). It composes the other steps and
// adds no math of its own: load and check inputs -> authalic square map per hemisphere (and the
// 2:1 whole-brain rectangle) -> PET sampling -> equal-area elements -> comparison with a normative
// reference when given -> report.
//
// Output safety: everything is written into a staging folder `OUT/.sub-<id>.partial-<pid>` that
// is renamed to `OUT/sub-<id>` only when every file is complete, so an interrupted run never
// leaves a folder that looks finished. Same inputs -> identical files (no timestamps in outputs;
// the log's timings live in sub-<id>_log.txt only). File names: SubjectFiles below.
#include <string>
#include <vector>

#include "core/progress.h"

namespace authalic::analysis {

struct SubjectInputs {
  std::string id;  // subject label without "sub-"
  std::string lh_white, lh_pial, rh_white, rh_pial;  // surfaces (FreeSurfer, GIFTI, ...)
  std::string lh_cortex, rh_cortex;                  // cortex regions (FreeSurfer label, GIFTI label/mask)
  std::string pet;                                   // NIfTI, MGH/MGZ or a DICOM folder
  std::string t1;                                    // optional, for --register
  // Optional FreeSurfer ?h.sphere.reg (vertices on the atlas sphere): with RunOptions::atlas_dir the
  // maps are made in atlas correspondence (analysis/atlas.h).
  std::string lh_sphere_reg, rh_sphere_reg;
  std::string normative;                             // optional reference (authalic normative build)
  double age = 0;                                    // years, 0 = unknown
  std::string sex;                                   // "F", "M", "O" or empty (unknown)
  std::string lh_annot, rh_annot;                    // optional FreeSurfer ?h.aparc.annot: names regions in the report
  // Scan details for the report header (empty: from the PET's BIDS sidecar JSON when present).
  std::string scan_date, tracer, dose;
};

// FreeSurfer's label/?h.aparc.annot beside the cortex labels (the subject's label/ folder), when
// present and not given explicitly.
void default_annotations(SubjectInputs& inputs);

// FreeSurfer subject folder -> inputs: surf/?h.white, surf/?h.pial, label/?h.cortex.label, and
// surf/?h.sphere.reg when present (left empty when missing; run says which mode it used);
// the surfaces' footers carry c_ras (tkregister RAS -> scanner RAS). Throws InputError naming the
// missing file.
SubjectInputs inputs_from_subjects_dir(const std::string& subjects_dir, const std::string& subject);

// The BIDS label of a subject id as users write it: a leading "sub-" (the participant_id of
// participants.tsv, a BIDS folder name) dropped, so "sub-01" and "01" both give sub-01/.
std::string bids_subject_label(const std::string& id);

// The names `run` gives its files in OUT/sub-<id>/ (BIDS derivatives: every name is
// sub-<id>[_hemi-L|R][_<entity>-<value>...]_<suffix>.<extension>), in one place for run, group
// and the tests. hemi: "L" or "R".
struct SubjectFiles {
  std::string id;  // subject label without "sub-"

  std::string folder() const { return "sub-" + id; }
  std::string surface(const std::string& hemi, const std::string& kind) const { return h(hemi) + "_" + kind + ".surf.gii"; }
  std::string flat(const std::string& hemi) const { return h(hemi) + "_space-authalic_flat.surf.gii"; }
  std::string rectangle_flat(const std::string& hemi) const { return h(hemi) + "_space-authalicrect_flat.surf.gii"; }
  std::string pet(const std::string& hemi) const { return h(hemi) + "_pet.func.gii"; }
  std::string zscore(const std::string& hemi) const { return h(hemi) + "_zscore.func.gii"; }
  std::string element_labels(const std::string& hemi) const { return h(hemi) + "_desc-elements_dseg.label.gii"; }
  // ext ".nii.gz" or ".png" (they share one sidecar).
  std::string pet_elements(const std::string& hemi, const std::string& ext) const { return h(hemi) + "_desc-elements_pet" + ext; }
  std::string zscore_elements(const std::string& hemi, const std::string& ext) const {
    return h(hemi) + "_desc-elements_zscore" + ext;
  }
  std::string element_table() const { return folder() + "_elements.tsv"; }
  std::string clusters() const { return folder() + "_clusters.tsv"; }
  std::string workbench_spec() const { return folder() + "_workbench.spec"; }
  std::string report() const { return folder() + "_report.html"; }
  std::string report_pdf() const { return folder() + "_report.pdf"; }
  std::string log() const { return folder() + "_log.txt"; }

 private:
  std::string h(const std::string& hemi) const { return folder() + "_hemi-" + hemi; }
};

struct RunOptions {
  std::string out_dir;          // the subject's folder goes to out_dir/sub-<id>
  bool force = false;           // replace an existing sub-<id> folder
  int k = 32;                   // K x K elements per hemisphere square (2K x K on the rectangle)
  double depth_mm = 10.0;       // normal projection depth (Zou et al. 2011, section 5.2)
  std::string normalize = "global";  // "none", "global", or a NIfTI mask path (reference region)
  double z_threshold = 2.0;     // |z| flagged as abnormal
  bool rescale = true;          // CompareOptions::rescale
  bool report = true;           // write sub-<id>_report.html and sub-<id>_report.pdf
  // Clusters with fewer elements are not reported (at K = 32 one element is ~0.1 % of a
  // hemisphere's cortex; 3 elements, ~90-270 mm^2, keeps the isolated single-element flags that
  // chance alone produces out of the report).
  int min_cluster_elements = 3;
  bool rectangle = true;        // also the 2:1 whole-brain rectangle map
  bool require_age = false;     // refuse a reference with an age model when the age is unknown
  int pet_frame = -1;           // 4D PET: the frame to sample (0-based); -1: none chosen
  bool pet_sum_frames = false;  // 4D PET: sum all frames
  std::string command_line;     // as invoked, recorded in every sidecar (provenance); may be empty
  // Atlas folder in FreeSurfer layout (analysis/atlas.h): with both sphere.reg inputs the maps start
  // from the atlas's map carried through sphere.reg (elements correspond across subjects); without
  // them the subject's maps are registered to the atlas's by sulcal depth (core/atlas_map.h,
  // square_map_registered; mode "registration") and the run says so (a warning).
  std::string atlas_dir;
};

struct RunSummary {
  std::string subject_dir;      // final folder
  std::vector<std::pair<std::string, double>> step_seconds;
  int flips_left = 0, flips_right = 0;
  double element_cv_left = 0, element_cv_right = 0;
  int abnormal_elements = -1;   // -1 without a reference
  int clusters = -1;
  std::string clusters_json;    // the clusters as a JSON array (analysis/normative.h clusters_json); "" without a reference
  std::vector<std::string> files;  // written, relative to subject_dir
  std::vector<std::string> warnings;  // also in the log and the report
};

// The element correspondence mode a run with these inputs records (issue 14): "per-subject"
// without --atlas; with it "atlas <lh identity>+<rh identity>" when both sphere.reg are given, else
// "registration ...". Reads only the atlas files' checksums, so `group` can check a cohort's modes
// before any map. Throws InputError for an atlas folder without its files.
std::string correspondence_mode(const SubjectInputs& inputs, const RunOptions& options);

// Runs the pipeline. Throws InputError (bad input, nothing written) or ProcessingError.
RunSummary run_subject(const SubjectInputs& inputs, const RunOptions& options, const ProgressFn& progress = {});

}  // namespace authalic::analysis

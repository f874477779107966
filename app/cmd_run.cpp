// authalic run: the clinician's per-subject pipeline (analysis/pipeline.h). Exit codes: 0 ok,
// 2 bad input (nothing written), 3 processing failure.

#include <chrono>
#include <cstdio>
#include <cstdlib>

#include <iostream>
#include <nlohmann/json.hpp>

#include "analysis/pipeline.h"
#include "app/command.h"
#include "core/error.h"

namespace authalic::app {
namespace {

struct RunArgs {
  analysis::SubjectInputs inputs;
  analysis::RunOptions options;
  std::string subjects_dir, subject;
};

int run(RunArgs& a) {
  analysis::SubjectInputs in = a.inputs;
  in.id = analysis::bids_subject_label(in.id);
  if (!a.subjects_dir.empty() || !a.subject.empty()) {
    // FreeSurfer's convention: without --subjects-dir, the SUBJECTS_DIR environment variable.
    const char* env = std::getenv("SUBJECTS_DIR");
    const std::string subjects_dir = !a.subjects_dir.empty() ? a.subjects_dir : (env ? env : "");
    if (a.subject.empty())
      throw InputError("--subjects-dir needs --subject (the subject's folder name); or give the explicit --lh-white ... inputs");
    if (subjects_dir.empty())
      throw InputError("--subject " + a.subject + ": give --subjects-dir or set SUBJECTS_DIR (FreeSurfer's subjects folder)");
    const std::string id = in.id;
    in = analysis::inputs_from_subjects_dir(subjects_dir, a.subject);
    if (!id.empty()) in.id = id;
    in.pet = a.inputs.pet;
    in.normative = a.inputs.normative;
    in.age = a.inputs.age;
    in.t1 = a.inputs.t1;
    in.sex = a.inputs.sex;
    in.scan_date = a.inputs.scan_date;
    in.tracer = a.inputs.tracer;
    in.dose = a.inputs.dose;
    if (!a.inputs.lh_annot.empty()) in.lh_annot = a.inputs.lh_annot;
    if (!a.inputs.rh_annot.empty()) in.rh_annot = a.inputs.rh_annot;
    if (!a.inputs.lh_sphere_reg.empty()) in.lh_sphere_reg = a.inputs.lh_sphere_reg;
    if (!a.inputs.rh_sphere_reg.empty()) in.rh_sphere_reg = a.inputs.rh_sphere_reg;
    // Which correspondence the run will use, and why (issue 14).
    if (a.options.atlas_dir.empty())
      info("authalic run: per-subject element correspondence (no --atlas" +
           std::string(in.lh_sphere_reg.empty() ? ")" : "; give --atlas DIR to map through surf/?h.sphere.reg)"));
    else if (in.lh_sphere_reg.empty() || in.rh_sphere_reg.empty())
      info("authalic run: " + subjects_dir + "/" + a.subject + "/surf/" + (in.lh_sphere_reg.empty() ? "lh" : "rh") +
           ".sphere.reg is missing: element correspondence by registration to the atlas map (sulcal depth) instead "
           "of through FreeSurfer's registration");
    else
      info("authalic run: atlas element correspondence through surf/?h.sphere.reg (atlas " + a.options.atlas_dir + ")");
  } else {
    const std::pair<const char*, const std::string*> need[] = {
        {"--lh-white", &in.lh_white}, {"--lh-pial", &in.lh_pial},     {"--rh-white", &in.rh_white},
        {"--rh-pial", &in.rh_pial},   {"--lh-cortex", &in.lh_cortex}, {"--rh-cortex", &in.rh_cortex}};
    for (const auto& [flag, value] : need)
      if (value->empty())
        throw InputError(std::string(flag) + " is missing; give all six surface/label inputs, or --subjects-dir and --subject");
  }
  analysis::default_annotations(in);
  if (in.pet.empty()) throw InputError("--pet is missing; give the subject's PET (NIfTI, MGH/MGZ or a DICOM folder)");
  analysis::RunOptions options = a.options;
  options.command_line = global_options().command_line;
  // Wall time: the two hemispheres' steps overlap, so the sum of the step times overstates it.
  const auto start = std::chrono::steady_clock::now();
  const analysis::RunSummary s = analysis::run_subject(in, options, terminal_progress());
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!global_options().json)
    for (const auto& w : s.warnings) std::cerr << "authalic run: warning: " << w << '\n';
  if (global_options().json) {
    nlohmann::json j = {{"subject_dir", s.subject_dir},
                        {"warnings", s.warnings},
                        {"flips", {{"left", s.flips_left}, {"right", s.flips_right}}},
                        {"element_area_cv", {{"left", s.element_cv_left}, {"right", s.element_cv_right}}},
                        {"files", s.files}};
    if (s.abnormal_elements >= 0) {
      j["abnormal_elements"] = s.abnormal_elements;
      j["num_clusters"] = s.clusters;
      j["clusters"] = nlohmann::json::parse(s.clusters_json);
    }
    for (const auto& [step, sec] : s.step_seconds) j["step_seconds"][step] = sec;
    j["seconds"] = wall;
    std::cout << j.dump(2) << '\n';
  } else {
    char text[32];
    for (const auto& [step, sec] : s.step_seconds) {
      std::snprintf(text, sizeof text, "%.2f", sec);
      info("  " + step + ": " + text + " s");
    }
    std::snprintf(text, sizeof text, "%.1f", wall);
    info("authalic run: sub-" + in.id + " done in " + text + " s (wall time); report: " + s.subject_dir + "/" +
         analysis::SubjectFiles{in.id}.report());
  }
  return 0;
}

const bool registered = register_command({70, [](CLI::App& parent) {
  auto a = std::make_shared<RunArgs>();
  CLI::App* sub = parent.add_subcommand(
      "run",
      "Per-subject pipeline: load and check inputs -> authalic square map per hemisphere -> PET by normal projection "
      "(inward from the pial surface) -> equal-area elements -> z-scores against a normative reference (if given) "
      "-> report. Writes OUT/sub-<id>/ (BIDS-derivative names, a JSON sidecar per file, the white and pial surfaces in scanner RAS, a Workbench spec sub-<id>_workbench.spec, sub-<id>_report.html and .pdf, sub-<id>_log.txt); "
      "the folder appears only when complete. Surfaces in tkregister RAS (FreeSurfer) are moved to scanner RAS "
      "with their footer's c_ras. Exit codes: 0 ok, 2 bad input, 3 processing failure.");
  auto& in = a->inputs;
  sub->add_option("--id", in.id, "Subject label (letters and digits; a leading sub- is dropped: sub-01 and 01 both write sub-01/; default: the FreeSurfer subject name)");
  sub->add_option("--lh-white", in.lh_white, "Left white surface (FreeSurfer, GIFTI, VTK, ...; mm)");
  sub->add_option("--lh-pial", in.lh_pial, "Left pial surface, same vertices as --lh-white");
  sub->add_option("--rh-white", in.rh_white, "Right white surface");
  sub->add_option("--rh-pial", in.rh_pial, "Right pial surface");
  sub->add_option("--lh-cortex", in.lh_cortex, "Left cortex region: FreeSurfer label or GIFTI label/mask (its vertices), or a surface on the same vertices whose triangles are the cortex (.surf.gii, e.g. a flat patch); one disk");
  sub->add_option("--rh-cortex", in.rh_cortex, "Right cortex region");
  sub->add_option("--subjects-dir", a->subjects_dir, "FreeSurfer SUBJECTS_DIR (instead of the six inputs above); default: the SUBJECTS_DIR environment variable");
  sub->add_option("--subject", a->subject, "FreeSurfer subject name in --subjects-dir (or $SUBJECTS_DIR); the output id (without --id) is its letters and digits, a leading sub- dropped (sub-01 -> sub-01/)");
  sub->add_option("--pet", in.pet, "PET volume registered to the surfaces (NIfTI, MGH/MGZ, DICOM folder); world = scanner RAS");
  sub->add_option("--t1", in.t1, "T1 MRI the surfaces belong to: the PET is rigidly registered to it (ITK v4, Mattes mutual information) before sampling; without it the PET is assumed co-registered");
  sub->add_option("--atlas", a->options.atlas_dir,
                  "Atlas folder in FreeSurfer layout (surf/?h.white, surf/?h.sphere, label/?h.cortex.label; e.g. "
                  "$FREESURFER_HOME/subjects/fsaverage): the maps start from the atlas's authalic map carried through the "
                  "subject's sphere.reg, so elements cover the same anatomy in every subject. Without a sphere.reg the "
                  "subject's maps are registered to the atlas's by sulcal depth (an area-preserving deformation; mode "
                  "'registration') and the run says so");
  sub->add_option("--lh-sphere-reg", in.lh_sphere_reg, "Left ?h.sphere.reg (with --atlas; --subjects-dir finds surf/lh.sphere.reg)");
  sub->add_option("--rh-sphere-reg", in.rh_sphere_reg, "Right ?h.sphere.reg");
  sub->add_option("--normative", in.normative, "Normative reference (authalic normative build): adds z-scores");
  sub->add_option("--frame", a->options.pet_frame, "4D PET: the frame to sample (0-based)")->check(in_range(0, 100000));
  sub->add_flag("--require-age", a->options.require_age,
                "Refuse a --normative reference with an age model when --age is not given (else: a warning, z not age adjusted)");
  sub->add_flag("--sum-frames", a->options.pet_sum_frames, "4D PET: sum all frames (a static image from dynamic frames)");
  sub->add_option("--age", in.age, "Age in years (used by references with an age model)")->check(age_years());
  sub->add_option("--sex", in.sex, "Sex, recorded in the report and the sidecars: F, M or O (female, male, other)")->transform(sex_letter());
  sub->add_option("--lh-annot", in.lh_annot,
                  "Left FreeSurfer annotation naming regions in the report (default: lh.aparc.annot beside --lh-cortex, e.g. the "
                  "subject's label/ folder; without one, lobes from coordinates)");
  sub->add_option("--rh-annot", in.rh_annot, "Right FreeSurfer annotation (default: rh.aparc.annot beside --rh-cortex)");
  sub->add_option("--scan-date", in.scan_date, "Scan date for the report header, e.g. 2024-03-18 (default: the PET's BIDS sidecar)");
  sub->add_option("--tracer", in.tracer, "Tracer for the report header, e.g. [18F]FDG (default: TracerName in the PET's BIDS sidecar)");
  sub->add_option("--dose", in.dose, "Injected dose for the report header, e.g. '205 MBq' (default: the PET's BIDS sidecar)");
  sub->add_option("--min-cluster", a->options.min_cluster_elements,
                  "Smallest cluster of abnormal elements reported, in elements (default 3)")
      ->check(in_range(1, 100000));
  sub->add_option("--out", a->options.out_dir, "Output folder; the subject goes to OUT/sub-<id>")->required();
  sub->add_flag("--force", a->options.force, "Replace an existing OUT/sub-<id>");
  add_k_option(*sub, a->options.k, {DomainKind::Square}, 2, 512);
  sub->add_option("--depth", a->options.depth_mm, "Normal projection depth, mm (default 10, Zou et al. 2011)")
      ->check(in_range(0.0, 50.0));
  sub->add_option("--normalize,--normalise", a->options.normalize,
                  "Intensity normalisation: none, global (cortical mean), or a reference-region mask NIfTI (SUVR)");
  sub->add_option("--threshold", a->options.z_threshold, "|z| at or beyond which an element is abnormal (default 2)")
      ->check(in_range(0.5, 10));
  sub->add_flag("--no-rescale", [a](std::int64_t) { a->options.rescale = false; },
                "Compare the globally normalised values as they are, without rescaling the subject to the reference "
                "over its normal elements (see `authalic normative compare --help`)");
  sub->add_flag("--no-report", [a](std::int64_t) { a->options.report = false; }, "Skip sub-<id>_report.html and sub-<id>_report.pdf");
  sub->add_flag("--no-rectangle", [a](std::int64_t) { a->options.rectangle = false; },
                "Skip the whole-brain 2:1 rectangle map (sub-<id>_hemi-?_space-authalicrect_flat.surf.gii)");
  add_common_options(*sub);
  sub->callback([a]() { set_exit_code(run(*a)); });
}});

}  // namespace
}  // namespace authalic::app

#include "analysis/pipeline.h"

#include <unistd.h>

#include <chrono>
#include <exception>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <omp.h>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "analysis/atlas.h"
#include "analysis/cortex_region.h"
#include "analysis/elements.h"
#include "analysis/normative.h"
#include "analysis/render.h"
#include "analysis/regions.h"
#include "analysis/report.h"
#include "analysis/report_figures.h"
#include "analysis/report_inputs.h"
#include "analysis/sampling.h"
#include "core/authalic_flow.h"
#include "core/conformal_map.h"
#include "core/error.h"
#include "core/metrics.h"
#include "core/rectangle_map.h"
#include "core/region.h"
#include "core/square_map.h"
#include "core/version.h"
#include "io/atomic_file.h"
#include "io/checksum.h"
#include "io/file_roles.h"
#include "io/freesurfer_annot.h"
#include "io/image_io.h"
#include "io/lock_file.h"
#include "io/signal_cleanup.h"
#include "io/registration.h"
#include "io/surface_io.h"
#include "io/workbench_spec.h"
#include "io/volume_io.h"

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace authalic::analysis {

namespace {


// Per-step wall times for the log (never written into the data files: outputs stay identical).
class StepLog {
 public:
  explicit StepLog(const ProgressFn& progress) : progress_(progress) {}
  void begin(const std::string& name) {
    name_ = name;
    start_ = std::chrono::steady_clock::now();
    report(progress_, "run", -1, name + " ...");
  }
  void end(RunSummary& summary) {
    add(name_, std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(), summary);
    report(progress_, "run", -1, name_ + " done");
  }
  // A remark about the current step, printed under its timing line.
  void note(const std::string& line) { notes_.push_back(line); }
  // The run's warnings not logged yet, as notes of this step.
  void note_new_warnings(const std::vector<std::string>& warnings) {
    for (; warnings_logged_ < warnings.size(); ++warnings_logged_) note("warning: " + warnings[warnings_logged_]);
  }
  // A step timed elsewhere (one of two run side by side): its line and its remark.
  void timed(const std::string& name, double seconds, const std::string& remark, RunSummary& summary) {
    note(remark);
    add(name, seconds, summary);
  }
  std::string text() const {
    std::string t;
    for (const auto& l : lines_) t += l + "\n";
    return t;
  }

 private:
  // The step's timing line, then the notes taken since the last one.
  void add(const std::string& name, double seconds, RunSummary& summary) {
    summary.step_seconds.emplace_back(name, seconds);
    std::ostringstream line;
    line << std::left << std::setw(44) << name << std::right << std::fixed << std::setprecision(3) << seconds << " s";
    lines_.push_back(line.str());
    for (const auto& n : notes_) lines_.push_back("  " + n);
    notes_.clear();
  }

  ProgressFn progress_;
  std::string name_;
  std::chrono::steady_clock::time_point start_;
  std::vector<std::string> lines_, notes_;
  std::size_t warnings_logged_ = 0;
};

struct Hemisphere {
  std::string name, tag;  // "left"/"L"
  bool left = true;
  io::Surface white, pial;
  std::vector<int> cortex;      // region vertices
  MatrixXi cortex_faces;        // faces of the white surface inside the cortex region
  TopologyReport cortex_topology;  // of cortex_faces (checked once, when read)
  // map
  std::string sphere_reg;       // atlas mode: the subject's sphere.reg ("" per subject)
  std::unique_ptr<Atlas> atlas; // atlas mode: the atlas hemisphere and its map
  SquareMapResult map;          // the authalic square map (V, F, UV in [0,1]^2, flow report)
  MapMetrics metrics;
  // PET
  SamplingResult sampling;
  // Of the cortex's vertices (the pial surface's medial wall left out): how many, how many outside
  // the PET's field of view, how many without a finite value (outside, or NaN voxels).
  int cortex_vertices = 0, cortex_outside = 0, cortex_no_value = 0;
  VectorXd pet;                 // per surface vertex (normalised)
  ElementResult elements;
  Parcellation regions;         // anatomical names for the report
};

void check_id(const std::string& id) {
  if (id.empty()) throw InputError("--id: empty subject id; give a label such as 01 or patient01");
  for (char c : id)
    if (!std::isalnum(static_cast<unsigned char>(c)))
      throw InputError("--id '" + id + "': BIDS labels are letters and digits only; e.g. 'patient01'");
}

// Refuses inputs that read fine but cannot be the anatomy they are named as (issue 17): white and
// pial swapped (elements would sample the wrong side of the ribbon: the pial surface encloses the
// white one, so its area is the larger, about 1.2-1.5x on FreeSurfer subjects) and left and right
// swapped (the left hemisphere lies at smaller RAS x than the right one).
void check_anatomy(const Hemisphere (&hemis)[2], const SubjectInputs& in) {
  const std::string white_path[2] = {in.lh_white, in.rh_white}, pial_path[2] = {in.lh_pial, in.rh_pial};
  const char* white_flag[2] = {"--lh-white", "--rh-white"};
  for (int k = 0; k < 2; ++k) {
    const double white = face_areas(hemis[k].white.mesh.V, hemis[k].white.mesh.F).sum();
    const double pial = face_areas(hemis[k].pial.mesh.V, hemis[k].pial.mesh.F).sum();
    if (!(pial > white)) {
      std::ostringstream s;
      s << std::fixed << std::setprecision(0) << pial_path[k] << ": the " << hemis[k].name << " pial surface's area (" << pial
        << " mm^2) is not larger than the white surface's (" << white << " mm^2, " << white_path[k]
        << "); white and pial look swapped: give the white surface as " << white_flag[k];
      throw InputError(s.str());
    }
  }
  // One file as both hemispheres would read as "left and right swapped" (it lies at its own x).
  std::error_code ec;
  if (fs::equivalent(in.lh_white, in.rh_white, ec))
    throw InputError(in.rh_white + ": the same file was given as --lh-white and --rh-white; give each hemisphere its own surface");
  const double lx = hemis[0].white.mesh.V.col(0).mean(), rx = hemis[1].white.mesh.V.col(0).mean();
  if (!(lx < rx)) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(1) << in.lh_white << ": the left hemisphere lies at larger RAS x (mean " << lx
      << " mm) than the right one (" << in.rh_white << ", mean " << rx
      << " mm); left and right look swapped: give ?h = lh files as --lh-*";
    throw InputError(s.str());
  }
}

// Reads one hemisphere; returns a line for the log saying how a vertex label was cleaned up
// into one disk (core/region.h), empty for a face set.
std::string load_hemisphere(Hemisphere& h, const std::string& white, const std::string& pial, const std::string& cortex) {
  h.white = io::read_surface(white);
  h.pial = io::read_surface(pial);
  const int n = h.white.mesh.num_vertices();
  if (h.pial.mesh.num_vertices() != n)
    throw InputError(pial + ": has " + std::to_string(h.pial.mesh.num_vertices()) + " vertices but " + white + " has " +
                     std::to_string(n) + "; white and pial must come from the same subject and hemisphere");
  io::require_vertex_numbering(h.white, white, cortex);
  CortexRegion region = read_cortex_region(h.white.mesh, white, cortex, h.name);
  h.cortex_faces = std::move(region.F);
  h.cortex_topology = region.topology;
  std::vector<char> used(n, 0);
  for (Eigen::Index f = 0; f < h.cortex_faces.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[h.cortex_faces(f, c)] = 1;
  h.cortex.clear();
  for (int v = 0; v < n; ++v)
    if (used[v]) h.cortex.push_back(v);
  return region.note;
}

// Writes `s` as GIFTI at `path` in scanner RAS (mm), the PET's world: FreeSurfer's tkregister
// coordinates moved by c_ras (io::Surface::to_scanner), so Workbench shows it over the PET and the
// T1 without a transform. `kind` is "white" or "pial".
void write_anatomical_surface(const std::string& path, const io::Surface& s, const std::string& structure, const std::string& kind) {
  io::SurfaceWriteOptions o;
  o.anatomical_structure = structure;
  o.geometric_type = "Anatomical";
  o.space = "NIFTI_XFORM_SCANNER_ANAT";
  o.metadata = {{"AnatomicalStructureSecondary", kind == "white" ? "GrayWhite" : "Pial"},
                {"units", "mm"}, {"space", "scanner RAS (mm), the PET's world coordinates"}};
  io::write_surface(path, TriMesh{transform_points(s.to_scanner, s.mesh.V), s.mesh.F}, o);
}

}  // namespace

std::string bids_subject_label(const std::string& id) { return id.rfind("sub-", 0) == 0 ? id.substr(4) : id; }

SubjectInputs inputs_from_subjects_dir(const std::string& subjects_dir, const std::string& subject) {
  const fs::path base = fs::path(subjects_dir) / subject;
  if (!fs::is_directory(base))
    throw InputError(base.string() + ": no such FreeSurfer subject folder; check --subjects-dir and --subject");
  SubjectInputs in;
  in.id = subject;
  auto need = [&](const std::string& rel) {
    const fs::path p = base / rel;
    if (!fs::exists(p)) throw InputError(p.string() + ": missing from the FreeSurfer subject folder; was recon-all run to the end?");
    return p.string();
  };
  in.lh_white = need("surf/lh.white");
  in.lh_pial = need("surf/lh.pial");
  in.rh_white = need("surf/rh.white");
  in.rh_pial = need("surf/rh.pial");
  in.lh_cortex = need("label/lh.cortex.label");
  in.rh_cortex = need("label/rh.cortex.label");
  for (auto [hemi, reg] : {std::pair<const char*, std::string*>{"lh", &in.lh_sphere_reg}, {"rh", &in.rh_sphere_reg}})
    if (fs::exists(base / "surf" / (std::string(hemi) + ".sphere.reg"))) *reg = (base / "surf" / (std::string(hemi) + ".sphere.reg")).string();
  // BIDS labels are alphanumeric: FreeSurfer subject names often are not (bert_01). A name that
  // already is a BIDS subject ("sub-01") gives its label, not "sub01" (folder sub-sub01).
  const std::string name = bids_subject_label(subject);
  std::string id;
  for (char c : name)
    if (std::isalnum(static_cast<unsigned char>(c))) id += c;
  in.id = id;
  default_annotations(in);  // label/?h.aparc.annot when recon-all made it
  return in;
}

namespace {

// (The anatomical orientation rule and the mirroring of the right hemisphere live in the map.)
// The authalic square map with the anatomical orientation rule (core/square_map.h): faces
// outward, frontal pole at the top middle, so the right hemisphere comes out as the mirror image
// of the left, as a reader of the two flat maps side by side expects.
// In atlas mode the map starts from the atlas's map carried through sphere.reg (core/atlas_map.h);
// returns a line for the log (how far the flow moved the vertices from the atlas position).
std::string map_hemisphere(Hemisphere& h, const ProgressFn& progress) {
  SquareMapOptions options;
  options.region_name = h.name + " hemisphere cortex";
  options.region_topology = h.cortex_topology;
  options.surface_faces = &h.white.mesh.F;
  if (!h.atlas) {
    h.map = square_map(h.white.mesh.V, h.cortex_faces, options, progress);
    return "per-subject correspondence";
  }
  std::ostringstream s;
  if (h.sphere_reg.empty()) {
    RegisteredMapResult r = square_map_registered(h.white.mesh.V, h.cortex_faces, h.atlas->square, options, {}, 32, progress);
    h.map = std::move(r.map);
    s << "registration to the atlas map (" << h.atlas->files.white << ", identity " << h.atlas->identity
      << ") by sulcal depth: correlation " << r.registration.correlation_before << " -> " << r.registration.correlation_after
      << " in " << r.registration.iterations << " area-preserving steps, vertices moved by median "
      << r.registration_displacement.median << ", max " << r.registration_displacement.max
      << " elements (K = 32); the flow then moved them by median " << r.displacement.median << " elements";
    return s.str();
  }
  const io::Surface reg = io::read_surface(h.sphere_reg);
  if (reg.mesh.num_vertices() != h.white.mesh.num_vertices())
    throw InputError(h.sphere_reg + ": has " + std::to_string(reg.mesh.num_vertices()) + " vertices but the " + h.name +
                     " white surface has " + std::to_string(h.white.mesh.num_vertices()) + "; give this hemisphere's sphere.reg");
  AtlasMapResult r = square_map_from_atlas(h.white.mesh.V, h.cortex_faces, reg.mesh.V, h.atlas->square, options, 32, progress);
  h.map = std::move(r.map);
  s << "atlas correspondence (" << h.atlas->files.white << ", identity " << h.atlas->identity << "): "
    << r.transfer.outside << " vertices outside the atlas cortex (" << 100 * r.transfer.outside_area_share
    << " % of the area, placed at its nearest point); the flow moved vertices from the atlas position by median "
    << r.displacement.median << ", 95th percentile " << r.displacement.p95 << ", max " << r.displacement.max << " elements (K = 32)";
  return s.str();
}

// Atlas, registration or per-subject correspondence (issue 14). With --atlas: through sphere.reg
// when both hemispheres have one, else registered to the atlas map by sulcal depth (with a
// warning saying why). Loads the atlas hemispheres (their maps are computed here). Returns the
// mode recorded in every output.
std::string choose_correspondence(Hemisphere (&hemis)[2], const SubjectInputs& in, const RunOptions& options,
                                  RunSummary& summary, const ProgressFn& progress) {
  if (options.atlas_dir.empty()) return kPerSubjectCorrespondence;
  const bool registered = in.lh_sphere_reg.empty() || in.rh_sphere_reg.empty();
  if (registered)
    summary.warnings.push_back(std::string("--atlas ") + options.atlas_dir + ": the subject has no " +
                               (in.lh_sphere_reg.empty() ? "lh" : "rh") +
                               ".sphere.reg (FreeSurfer's surf/?h.sphere.reg, or --lh-sphere-reg/--rh-sphere-reg): the maps "
                               "were registered to the atlas's by sulcal depth (mode 'registration'), not carried through "
                               "FreeSurfer's registration; compare them only with a reference built in registration mode");
  for (Hemisphere& h : hemis) {
    h.sphere_reg = registered ? "" : (h.left ? in.lh_sphere_reg : in.rh_sphere_reg);
    h.atlas = std::make_unique<Atlas>(load_atlas(atlas_files_from_dir(options.atlas_dir, h.left ? "lh" : "rh"), progress));
  }
  return correspondence_mode(in, options);
}

// The step: the mode, logged, and refused before minutes of mapping when the reference (if any) was
// built in another one.
std::string correspondence_step(Hemisphere (&hemis)[2], const SubjectInputs& in, const RunOptions& options,
                                const NormativeReference* reference, StepLog& log, RunSummary& summary,
                                const ProgressFn& progress) {
  log.begin("element correspondence");
  const std::string mode = choose_correspondence(hemis, in, options, summary, progress);
  log.note("mode: " + mode);
  if (reference && reference->correspondence != mode)
    throw InputError(in.normative + ": the reference's element correspondence is '" + reference->correspondence +
                     "' but this run's is '" + mode + "'; elements would cover different anatomy: run in the "
                     "reference's mode (with or without --atlas and sphere.reg) or use a reference built in this one");
  log.end(summary);
  return mode;
}

// Acceptance of a map before anything is computed from it (core/metrics.h): a failed map stops
// the run with exit 3, naming the map and its numbers. m: the map's metrics at the run's K; when
// K is not 32 (the acceptance grid), V (non-null), UV and F measure it again at 32.
void require_authalic(const std::string& what, const MapMetrics& m, const MatrixXd* V, const MatrixXd& UV, const MatrixXi& F,
                      const Domain& domain) {
  const MapMetrics at32 = V ? map_metrics(*V, UV, F, domain, 32) : m;
  const std::string problem = authalic_acceptance_problem(at32, at32.vertex_ln_area.mean, true);
  if (!problem.empty())
    throw ProcessingError(what + ": the map is not authalic: " + problem + "; no z-scores or report were written");
}

// The whole brain on the 2:1 rectangle: the two hemispheres side by side, each part's width
// proportional to its cortical area (core/rectangle_map.h, form b). Returns its metrics.
MapMetrics rectangle_step(const Hemisphere (&hemis)[2], const RunOptions& options, StepLog& log, RunSummary& summary,
                          HemisphereRectangles& rect) {
  log.begin("authalic 2:1 rectangle (both hemispheres)");
  // The two square maps stretched to their shares (core/rectangle_map.h): no map is recomputed.
  rect = hemisphere_rectangles_from_squares(hemis[0].map, hemis[1].map);
  const Eigen::Index nl = rect.left.V.rows();
  MatrixXd V(nl + rect.right.V.rows(), 3), UV(nl + rect.right.V.rows(), 2);
  V << rect.left.V, rect.right.V;
  UV << rect.left.UV, rect.right.UV;
  MatrixXi F(rect.left.F.rows() + rect.right.F.rows(), 3);
  F << rect.left.F, (rect.right.F.array() + static_cast<int>(nl)).matrix();
  const MapMetrics m = map_metrics(V, UV, F, Domain::rectangle(), options.k);
  log.note("left part width " + std::to_string(rect.split) + " of 2; flips " + std::to_string(m.flips) +
           ", element-area CV " + std::to_string(m.element_cv) + " (" + std::to_string(2 * options.k) + "x" +
           std::to_string(options.k) + ")");
  require_authalic("the 2:1 rectangle of both hemispheres", m, options.k == 32 ? nullptr : &V, UV, F, Domain::rectangle());
  log.end(summary);
  return m;
}

// The element image of one block as a K x K NIfTI (voxel (col, row)); the affine is a plain
// index grid: element images live in the map's domain, not in scanner space.
// The clusters of abnormal elements as TSV (BIDS tabular file): one row per cluster, in the
// comparison's order (largest first); columns described by clusters_tsv_sidecar.
std::string clusters_tsv(const std::vector<ElementCluster>& clusters) {
  std::ostringstream s;
  s << "cluster\themisphere\tdirection\telements\tarea_mm2\tpeak_z\tmean_z\tpeak_row\tpeak_col\tpeak_x_mm\tpeak_y_mm\tpeak_z_mm\t"
       "mass\tcontrols_as_large\tp_controls\n";
  s << std::setprecision(6);
  for (const ElementCluster& c : clusters) {
    s << c.id << '\t' << c.hemisphere << '\t' << (c.sign < 0 ? "hypo" : "hyper") << '\t' << c.elements.size() << '\t'
      << c.area_mm2 << '\t' << c.peak_z << '\t' << c.mean_z << '\t' << c.peak_row << '\t' << c.peak_col << '\t' << c.peak_ras.x()
      << '\t' << c.peak_ras.y() << '\t' << c.peak_ras.z() << '\t' << c.mass << '\t';
    // BIDS tabular files write a missing value as n/a.
    if (c.controls_as_large >= 0)
      s << c.controls_as_large << '\t' << c.p_controls << '\n';
    else
      s << "n/a\tn/a\n";
  }
  return s.str();
}

json clusters_tsv_sidecar(double threshold) {
  auto col = [](const std::string& d, const std::string& units = "") {
    json j = {{"Description", d}};
    if (!units.empty()) j["Units"] = units;
    return j;
  };
  return {{"description", "clusters of abnormal elements: touching elements (sharing an edge or a corner: 8 neighbours, not across the seam between hemispheres) of one sign with |z| >= " + std::to_string(threshold)},
          {"cluster", col("cluster number, largest first")},
          {"hemisphere", col("left or right")},
          {"direction", col("hypo (z <= -threshold) or hyper (z >= threshold)")},
          {"elements", col("number of equal-area elements")},
          {"area_mm2", col("cortical area of the elements", "mm^2")},
          {"peak_z", col("most extreme z of the cluster")},
          {"mean_z", col("mean z of its elements")},
          {"peak_row", col("element row of the peak (from the bottom of the square)")},
          {"peak_col", col("element column of the peak")},
          {"peak_x_mm", col("centroid of the peak element, scanner RAS x", "mm")},
          {"peak_y_mm", col("centroid of the peak element, scanner RAS y", "mm")},
          {"peak_z_mm", col("centroid of the peak element, scanner RAS z", "mm")},
          {"mass", col("cluster mass: the sum over its elements of |z| - threshold")},
          {"controls_as_large", col("controls (each compared with the other controls, leave-one-out) whose largest cluster of "
                                    "this direction has at least this mass; n/a when not measured")},
          {"p_controls", col("(1 + controls_as_large) / (1 + controls): the cluster's p against the controls' chance "
                             "clusters (maximum statistic, corrected for the elements and clusters looked at); n/a when "
                             "not measured")}};
}

// The element images' space, for their sidecars (write_element_nifti's header convention).
std::string element_space_note(double element_area_mm2) {
  std::ostringstream s;
  s << "the authalic map's element grid, its own space, not a scanner's (NIfTI sform/qform code 5, NIFTI_XFORM_TEMPLATE_OTHER, "
       "affine diag(s, s, 1) with s = sqrt(element area) mm: voxel (i, j) at (i s, j s, 0) mm); voxel (i, j) = element column i, "
       "row j from the bottom; element area "
    << element_area_mm2 << " mm^2 of cortex";
  return s.str();
}

// OUT/dataset_description.json: the output folder as a BIDS derivative dataset. The same bytes for
// every subject (no dates, no per-subject command line: those are in each file's sidecar), so runs
// into one folder, in parallel or one after another, agree.
void write_dataset_description(const std::string& out_dir) {
  const json d = {{"Name", "Authalic: equal-area cortical elements of PET"},
                  {"BIDSVersion", "1.9.0"},
                  {"DatasetType", "derivative"},
                  {"GeneratedBy",
                   {{{"Name", "authalic"},
                     {"Version", std::string(kVersion) + " (" + kGitRevision + ")"},
                     {"Description", "authalic square/rectangle maps, PET sampled along the inward normal, equal-area elements, "
                                     "z-scores against a normative reference; each file's .json sidecar records the command "
                                     "line, parameters and inputs (path as given, SHA-256)"}}}}};
  io::write_file_atomically((fs::path(out_dir) / "dataset_description.json").string(), d.dump(2) + "\n");
}

json input_checksums(const SubjectInputs& in) {
  json j;
  for (const auto& [key, path] : std::vector<std::pair<std::string, std::string>>{
           {"lh_white", in.lh_white}, {"lh_pial", in.lh_pial}, {"rh_white", in.rh_white}, {"rh_pial", in.rh_pial},
           {"lh_cortex", in.lh_cortex}, {"rh_cortex", in.rh_cortex}, {"pet", in.pet}, {"t1", in.t1}, {"normative", in.normative},
           {"lh_sphere_reg", in.lh_sphere_reg}, {"rh_sphere_reg", in.rh_sphere_reg}}) {
    if (path.empty()) continue;
    j[key] = {{"path", path},  // as given (relative paths: to the folder the command ran in)
              {"sha256", fs::is_directory(path) ? std::string("(folder)") : io::sha256_file(path)}};
  }
  return j;
}

// The output folder for the run's lifetime: created if missing, and removed again (only if still
// empty) when the run fails or is ended by SIGTERM/SIGINT, so that bad input leaves nothing behind.
class OutFolder {
 public:
  explicit OutFolder(const std::string& path) : path_(path) {
    std::error_code ec;
    if (fs::exists(path_, ec)) {
      if (!fs::is_directory(path_, ec)) throw InputError(path_ + ": --out exists and is not a folder; give a folder");
      return;
    }
    // Registered before it exists: a signal between creating and registering left it behind.
    on_signal_ = std::make_unique<io::RemovedOnSignal>(path_, io::RemovedOnSignal::Kind::FolderIfEmpty);
    fs::create_directories(path_, ec);
    if (ec) throw InputError(path_ + ": cannot create the output folder (" + ec.message() + ")");
    created_ = true;
  }
  ~OutFolder() {
    std::error_code ec;
    if (created_ && std::uncaught_exceptions() > 0 && fs::is_empty(path_, ec)) fs::remove(path_, ec);
  }
  OutFolder(const OutFolder&) = delete;
  OutFolder& operator=(const OutFolder&) = delete;

 private:
  std::string path_;
  bool created_ = false;
  std::unique_ptr<io::RemovedOnSignal> on_signal_;
};

// The hidden folder the outputs are written into before it is renamed to sub-<id>.
fs::path staging_folder(const RunOptions& options, const std::string& id) {
  return fs::path(options.out_dir) / (".sub-" + id + ".partial-" + std::to_string(::getpid()));
}

// The staging folder is removed when the run fails (an exception: a bad BIDS sidecar found by the
// report, a full disk) or is ended by SIGTERM/SIGINT/SIGHUP (Ctrl-C, a scheduler's time limit):
// it was left behind until the next run of the same subject. SIGKILL still leaves it to that run.
class StagingGuard {
 public:
  explicit StagingGuard(fs::path stage) : stage_(std::move(stage)), on_signal_(stage_.string(), io::RemovedOnSignal::Kind::FolderOfFiles) {}
  ~StagingGuard() {
    std::error_code ec;
    if (std::uncaught_exceptions() > 0) fs::remove_all(stage_, ec);
  }
  StagingGuard(const StagingGuard&) = delete;
  StagingGuard& operator=(const StagingGuard&) = delete;

 private:
  fs::path stage_;
  io::RemovedOnSignal on_signal_;
};

// Staging (.sub-<id>.partial-<pid>) and swap (.sub-<id>.old-<pid>) folders left by runs that were
// killed: called under the subject's lock, so no live run owns them.
void remove_dead_staging(const std::string& out_dir, const std::string& id) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(out_dir, ec)) {
    const std::string name = entry.path().filename().string();
    for (const std::string kind : {".partial-", ".old-"})
      if (name.rfind(".sub-" + id + kind, 0) == 0) fs::remove_all(entry.path(), ec);
  }
}

}  // namespace

namespace {

// The report's header rows: subject and scan (flags win over the PET's BIDS sidecar).
KeyValues subject_rows(const SubjectInputs& in) {
  const ScanDetails scan = scan_details_from_sidecar(in.pet);
  auto either = [](const std::string& a, const std::string& b) { return !a.empty() ? a : !b.empty() ? b : "not given"; };
  return {{"age", in.age > 0 ? human_number(in.age) + " years" : "unknown"},
          {"sex", in.sex.empty() ? "unknown" : in.sex == "F" ? "female" : in.sex == "M" ? "male" : "other"},
          {"scan date", either(in.scan_date, scan.scan_date)},
          {"tracer", either(in.tracer, scan.tracer)},
          {"injected dose", either(in.dose, scan.dose)},
          {"PET", fs::path(in.pet).filename().string() + (scan.sidecar.empty() ? "" : " (BIDS sidecar read)")}};
}

// Quality flags: each map's acceptance numbers, the PET's coverage, the registration.
KeyValues quality_rows(const Hemisphere (&hemis)[2], const RunOptions& options, const std::string& registration) {
  KeyValues q;
  for (const Hemisphere& h : hemis) {
    char buf[200];
    // The limit is the one require_authalic applied on the 32 x 32 grid (looser on a coarse mesh).
    std::snprintf(buf, sizeof(buf), "%d flipped triangles, element-area CV %.4f at %dx%d (accepted: 0 flips, CV <= %.4f at 32x32)",
                  h.metrics.flips, h.metrics.element_cv, h.metrics.element_cols, h.metrics.element_rows,
                  element_cv_limit(h.metrics.faces, 32 * 32));
    q.emplace_back(h.name + " square map", buf);
  }
  for (const Hemisphere& h : hemis) {
    char buf[160];
    const double outside = static_cast<double>(h.cortex_outside) / std::max(1, h.cortex_vertices);
    std::snprintf(buf, sizeof(buf), "%.1f %% of the cortex's vertices outside the PET's field of view, %d without a value%s",
                  100.0 * outside, h.cortex_no_value, h.cortex_no_value > 0 ? " (check the scan's coverage)" : "");
    q.emplace_back(h.name + " PET coverage", buf);
  }
  q.emplace_back("registration", registration.empty() ? "none: the PET was taken as registered to the surfaces (no --t1)" : registration);
  return q;
}

// One hemisphere's pictures and values for the report.
ReportHemisphere report_hemisphere(const Hemisphere& h, int K, const std::vector<double>& z, const HemisphereRectangles& rect) {
  ReportHemisphere rh;
  rh.name = h.name;
  rh.left = h.left;
  rh.flat_uv = h.map.UV;
  rh.faces = h.map.F;
  rh.grid_cols = rh.grid_rows = K;
  rh.surface_V = h.pial.mesh.V;
  rh.surface_F = h.pial.mesh.F;
  rh.shading = sulcal_shading(h.pial.mesh.V, h.pial.mesh.F);
  rh.element_of_vertex = h.elements.vertex_element;
  // Per map vertex: the surface's values, NaN for vertices the map inserted (drawn gray).
  rh.pet = VectorXd::Constant(h.map.UV.rows(), std::numeric_limits<double>::quiet_NaN());
  rh.pet.head(h.white.mesh.num_vertices()) = h.pet.head(h.white.mesh.num_vertices());
  rh.element_pet = block_values(h.elements.block);
  rh.element_z = z;
  const RectanglePart& part = h.left ? rect.left : rect.right;
  rh.rectangle_uv = part.UV;
  rh.rectangle_faces = part.F;
  rh.distortion = {{"flipped triangles", std::to_string(h.metrics.flips)},
                   {"element-area CV (K=" + std::to_string(K) + ")", format_fixed(h.metrics.element_cv, 4)},
                   {"per-face mean |ln area ratio|", format_fixed(h.metrics.face_ln_area.mean, 4)}};
  return rh;
}

// Clusters named by region (majority of their vertices; the peak element's region), the
// regional table and the findings sentence.
void name_findings(ReportData& rd, const Hemisphere (&hemis)[2], const Comparison& cmp, int K) {
  std::vector<std::vector<int>> vertices[2];
  for (int b = 0; b < 2; ++b) {
    vertices[b] = vertices_of_elements(hemis[b].elements.vertex_element, K * K);
    const std::vector<double> z(cmp.z.begin() + b * K * K, cmp.z.begin() + (b + 1) * K * K);
    for (const RegionRow& r : regional_table(hemis[b].name, hemis[b].regions, z, vertices[b]))
      rd.regions.push_back({r.hemisphere, r.lobe, r.region, r.elements, r.mean_z});
  }
  std::vector<Finding> findings;
  for (const ElementCluster& c : cmp.clusters) {
    ReportCluster r;
    r.id = c.id;
    r.hemisphere = c.hemisphere;
    r.sign = c.sign < 0 ? "hypo" : "hyper";
    r.num_elements = static_cast<int>(c.elements.size());
    r.area_mm2 = c.area_mm2;
    r.peak_z = c.peak_z;
    r.mean_z = c.mean_z;
    r.peak_row = c.peak_row;
    r.peak_col = c.peak_col;
    for (int i = 0; i < 3; ++i) r.peak_ras[i] = c.peak_ras[i];
    const int b = std::clamp(c.block, 0, 1);
    std::vector<int> members;
    for (int e : c.elements) members.insert(members.end(), vertices[b][e].begin(), vertices[b][e].end());
    const RegionShare share = majority_region(hemis[b].regions, members);
    r.region = share.name;
    r.region_fraction = share.fraction;
    if (c.peak_element >= 0) r.peak_region = majority_region(hemis[b].regions, vertices[b][c.peak_element]).name;
    r.controls_as_large = c.controls_as_large;
    r.controls = static_cast<int>(cmp.control_mass_hypo.size());
    r.p_controls = c.p_controls;
    findings.push_back({r.sign, r.hemisphere, r.region.empty() ? "cortex" : r.region, r.peak_z, r.area_mm2, r.controls_as_large, r.controls});
    rd.clusters.push_back(r);
  }
  rd.region_method = hemis[0].regions.method;
  rd.summary = findings_summary(findings, rd.normative.threshold, rd.normative.min_cluster_elements);
}

ReportNormative report_normative(const NormativeReference& reference, const SubjectInputs& in, const RunOptions& options,
                                 const Comparison& cmp) {
  ReportNormative n;
  n.present = true;
  n.num_subjects = static_cast<int>(reference.subjects.size());
  double lo = 1e300, hi = -1e300;
  int known = 0;
  for (const NormativeSubject& s : reference.subjects)
    if (std::isfinite(s.age)) {
      lo = std::min(lo, s.age);
      hi = std::max(hi, s.age);
      ++known;
    }
  // The range alone read as the ages the z-scores were adjusted for: say whether they were.
  if (hi >= lo)
    n.age_range = human_number(lo) + "-" + human_number(hi) + " years" +
                  (known < n.num_subjects ? " (" + std::to_string(known) + " of " + std::to_string(n.num_subjects) + " known)" : "") +
                  (cmp.age_adjusted ? " (z age adjusted)" : " (z NOT age adjusted)");
  n.normalisation = reference.normalisation;
  n.domain = "square, K = " + std::to_string(reference.grid.k);
  n.correspondence = "element by element on the authalic square (the same K x K grid in every subject)";
  n.description = fs::path(in.normative).filename().string() + ", built by " + reference.software;
  n.threshold = options.z_threshold;
  n.min_cluster_elements = options.min_cluster_elements;
  n.chance_clusters = cmp.control_mass_hypo.empty()
                          ? "p not measured: " + cmp.chance_note
                          : "p: against chance clusters in the " + std::to_string(cmp.control_mass_hypo.size()) +
                                " controls, each compared with the others (leave-one-out): (1 + controls with a cluster of "
                                "the same direction and at least the mass, sum of |z| - " + format_fixed(cmp.threshold, 1) +
                                ") / (1 + controls); corrected for the number of elements and clusters looked at";
  n.chance_clusters_short = cmp.control_mass_hypo.empty()
                                ? "p: not measured: " + cmp.chance_note
                                : "p: against the largest chance cluster (mass: sum of |z| - " + format_fixed(cmp.threshold, 1) +
                                      ") of each of the " + std::to_string(cmp.control_mass_hypo.size()) +
                                      " controls, compared with the others";
  n.age_adjusted = cmp.age_adjusted;
  n.predictive = cmp.predictive;
  n.rescaled = cmp.rescaled;
  n.expected_abnormal_share = expected_abnormal_share(n.num_subjects, cmp.age_adjusted, cmp.predictive, options.z_threshold);
  if (cmp.rescaled) {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "x %.4f, fitted on the %d elements with |z| < %.1f", cmp.scale, cmp.scale_elements,
                  options.z_threshold);
    n.rescale = buf;
  } else {
    n.rescale = "none";
  }
  return n;
}

ReportData report_data(const SubjectInputs& in, const RunOptions& options, const Hemisphere (&hemis)[2],
                       const HemisphereRectangles& rect, const ElementTable& table, const Comparison* cmp,
                       const NormativeReference& reference, const json& params, const RunSummary& summary,
                       const std::string& registration) {
  ReportData rd;
  rd.subject_id = in.id;
  rd.software = software_version();
  rd.pet_units = table.units;
  rd.subject_info = subject_rows(in);
  for (const std::string& w : summary.warnings) rd.notes.push_back("Warning: " + w + ".");
  for (const auto& [k, v] : params.items()) rd.parameters.emplace_back(k, v.is_string() ? v.get<std::string>() : v.dump());
  if (cmp) rd.parameters.emplace_back("minimum cluster size", std::to_string(options.min_cluster_elements) + " elements");
  rd.quality = quality_rows(hemis, options, registration);
  const int K = options.k;
  for (int b = 0; b < 2; ++b) {
    std::vector<double> z;
    if (cmp) z.assign(cmp->z.begin() + b * K * K, cmp->z.begin() + (b + 1) * K * K);
    rd.hemispheres.push_back(report_hemisphere(hemis[b], K, z, rect));
  }
  if (cmp) {
    rd.normative = report_normative(reference, in, options, *cmp);
    name_findings(rd, hemis, *cmp, K);
  } else {
    rd.notes.push_back("No normative reference was given (--normative): PET only, no z-scores.");
  }
  return rd;
}

// The hemisphere's regions: its annotation when given, else lobes from coordinates.
Parcellation hemisphere_regions(const Hemisphere& h, const std::string& annot) {
  if (annot.empty()) return lobes_from_coordinates(h.white.mesh.V, h.cortex_faces);
  return parcellation_from_annotation(io::read_freesurfer_annotation(annot, h.white.mesh.num_vertices()),
                                      fs::path(annot).filename().string());
}

}  // namespace

void default_annotations(SubjectInputs& in) {
  auto beside = [](const std::string& cortex, const char* name) {
    if (cortex.empty()) return std::string();
    const fs::path p = fs::path(cortex).parent_path() / name;
    return fs::is_regular_file(p) ? p.string() : std::string();
  };
  if (in.lh_annot.empty()) in.lh_annot = beside(in.lh_cortex, "lh.aparc.annot");
  if (in.rh_annot.empty()) in.rh_annot = beside(in.rh_cortex, "rh.aparc.annot");
}

namespace {

// Everything read in step 1 besides the hemispheres: the PET, the reference (if any), the
// reference-region mask (if any) and the inputs' checksums for the sidecars.
struct LoadedInputs {
  io::Volume pet;
  NormativeReference reference;
  bool compare = false;
  std::unique_ptr<io::Volume> mask;
  json checksums;
};

// Step 1. Everything is read and checked before anything is written, so bad input fails fast
// and leaves nothing behind.
LoadedInputs load_and_check_inputs(Hemisphere (&hemis)[2], const SubjectInputs& in, const RunOptions& options, StepLog& log,
                                   RunSummary& summary) {
  log.begin("load and check inputs");
  hemis[0].name = "left";
  hemis[0].tag = "L";
  hemis[1].name = "right";
  hemis[1].tag = "R";
  hemis[1].left = false;
  const std::string left_note = load_hemisphere(hemis[0], in.lh_white, in.lh_pial, in.lh_cortex);
  const std::string right_note = load_hemisphere(hemis[1], in.rh_white, in.rh_pial, in.rh_cortex);
  for (const std::string& note : {left_note, right_note})
    if (!note.empty()) log.note(note);
  check_anatomy(hemis, in);
  hemis[0].regions = hemisphere_regions(hemis[0], in.lh_annot);
  hemis[1].regions = hemisphere_regions(hemis[1], in.rh_annot);
  LoadedInputs r;
  io::VolumeReadOptions pet_options;
  pet_options.frame = options.pet_frame;
  pet_options.sum_frames = options.pet_sum_frames;
  r.pet = io::read_volume(in.pet, pet_options);
  if (!r.pet.source_series.empty()) log.note("PET DICOM series read: " + r.pet.source_series);
  r.compare = !in.normative.empty();
  if (r.compare) r.reference = read_reference(in.normative);
  // Refused before any map is computed; without --require-age the comparison says so (step 5).
  if (r.compare && has_age_model(r.reference) && !(in.age > 0) && options.require_age)
    throw InputError(in.normative + ": the reference has an age model but no --age was given; give --age YEARS, or drop "
                                    "--require-age to compare without age adjustment");
  if (options.normalize != "none" && options.normalize != "global") r.mask = std::make_unique<io::Volume>(io::read_volume(options.normalize));
  r.checksums = input_checksums(in);
  if (!r.pet.source_series.empty()) r.checksums["pet"]["dicom_series"] = r.pet.source_series;  // which series of the folder
  log.end(summary);
  return r;
}

// Step 2. The authalic square map per hemisphere, each accepted (exit 3) before it is used.
// The two maps are made side by side, one OpenMP thread each (nested regions run serially):
// a map's parallel share is about 30 %, so two maps at once on two cores end sooner than two in
// a row on two threads each. A map does not depend on its thread count, so neither do the outputs.
// Progress lines are serialised and name their hemisphere; an error is rethrown after both ended,
// the left one's first.
void map_hemispheres(Hemisphere (&hemis)[2], const SubjectInputs& in, const RunOptions& options, StepLog& log,
                     RunSummary& summary, const ProgressFn& progress) {
  auto step = [](const Hemisphere& h) { return "authalic square map (" + h.name + ")"; };
  for (const Hemisphere& h : hemis) report(progress, "run", -1, step(h) + " ...");
  std::mutex progress_mutex;
  std::string remark[2];
  double seconds[2] = {0, 0};
  std::exception_ptr error[2];
  const int threads = std::min(2, omp_get_max_threads());  // --threads 1: one after the other
#pragma omp parallel for num_threads(threads) schedule(static, 1)
  for (int i = 0; i < 2; ++i) {
    Hemisphere& h = hemis[i];
    const ProgressFn serial = [&](const std::string& stage, double fraction, const std::string& message) {
      const std::lock_guard<std::mutex> lock(progress_mutex);
      report(progress, stage, fraction, h.name + ": " + message);
    };
    const auto start = std::chrono::steady_clock::now();
    try {
      remark[i] = map_hemisphere(h, serial);
      h.metrics = map_metrics(h.map.V, h.map.UV, h.map.F, Domain::square(), options.k);
    } catch (...) {
      error[i] = std::current_exception();
    }
    seconds[i] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  for (const std::exception_ptr& e : error)
    if (e) std::rethrow_exception(e);
  for (int i = 0; i < 2; ++i) {
    Hemisphere& h = hemis[i];
    require_authalic(h.name + " hemisphere (" + (h.left ? in.lh_white : in.rh_white) + ")", h.metrics,
                     options.k == 32 ? nullptr : &h.map.V, h.map.UV, h.map.F, Domain::square());
    log.timed(step(h), seconds[i],
              remark[i] + "; flips " + std::to_string(h.metrics.flips) + ", element-area CV " +
                  std::to_string(h.metrics.element_cv) + ", flow " + h.map.flow.stop_reason,
              summary);
    report(progress, "run", -1, step(h) + " done");
  }
}

// With a T1, the PET is first registered to it (rigid, Mattes MI): surfaces are in the T1's
// scanner RAS, so they reach the PET's world coordinates through the registration. Returns the
// T1 -> PET transform (identity without a T1) and sets `registration` to the log's line about it.
Eigen::Matrix4d register_pet_to_t1(const SubjectInputs& in, const io::Volume& pet, StepLog& log, std::string& registration) {
  Eigen::Matrix4d t1_to_pet = Eigen::Matrix4d::Identity();
  if (!in.t1.empty()) {
    const io::RigidRegistration reg = io::register_rigid(io::read_volume(in.t1), pet);
    t1_to_pet = reg.t1_to_pet;
    std::ostringstream m;
    m << "PET registered to the T1 (ITK v4 rigid, Mattes MI " << reg.metric << ", " << reg.iterations
      << " iterations); T1 RAS -> PET RAS translation " << t1_to_pet.block<3, 1>(0, 3).transpose() << " mm";
    log.note(m.str());
    registration = m.str();
  }
  return t1_to_pet;
}

// The subject's normalisation: the global cortical mean of both hemispheres together, or the
// mean over a reference-region mask, or none.
Normalisation subject_normalisation(const Hemisphere (&hemis)[2], const SubjectInputs& in, const RunOptions& options,
                                    const io::Volume& pet, const io::Volume* mask) {
  Normalisation norm;
  if (options.normalize == "global") {
    // Both hemispheres' cortex together: one global mean for the subject.
    const int nl = hemis[0].white.mesh.num_vertices();
    MatrixXd V(nl + hemis[1].white.mesh.num_vertices(), 3);
    V << hemis[0].white.mesh.V, hemis[1].white.mesh.V;
    MatrixXi F(hemis[0].cortex_faces.rows() + hemis[1].cortex_faces.rows(), 3);
    F << hemis[0].cortex_faces, (hemis[1].cortex_faces.array() + nl).matrix();
    VectorXd values(V.rows());
    values << hemis[0].pet, hemis[1].pet;
    try {
      norm = global_cortical_mean(values, V, F);
    } catch (const InputError& e) {
      throw InputError(in.pet + ": " + e.what());
    }
  } else if (mask) {
    norm = reference_region_mean(pet, *mask);
  }
  return norm;
}

// The PET's coverage of one hemisphere's cortex (its vertices on the pial surface, Vw in the
// PET's world): counted into h, and a warning (log, --json, report) when part of it has no value.
void note_cortex_coverage(Hemisphere& h, const io::Volume& pet, const MatrixXd& Vw, RunSummary& summary) {
  std::vector<bool> in_cortex(static_cast<std::size_t>(Vw.rows()), false);
  for (const int v : h.cortex) in_cortex[static_cast<std::size_t>(v)] = true;
  SamplingOptions count_only;
  count_only.max_outside_fraction = 1.0;  // the refusal above has run on the whole surface
  SamplingResult coverage;
  check_field_of_view(pet, Vw, in_cortex, count_only, coverage);
  h.cortex_vertices = coverage.vertices_checked;
  h.cortex_outside = coverage.vertices_outside;
  h.cortex_no_value = 0;
  for (const int v : h.cortex) h.cortex_no_value += !std::isfinite(h.pet[v]);
  if (h.cortex_no_value == 0 && h.cortex_outside == 0) return;
  std::ostringstream w;
  w.precision(3);
  w << h.name << " hemisphere: ";
  if (h.cortex_outside > 0)
    w << h.cortex_outside << " of the cortex's " << h.cortex_vertices << " vertices (" << 100.0 * h.cortex_outside / h.cortex_vertices
      << " %) lie outside the PET's field of view" << (h.cortex_no_value > 0 ? ", " : "");
  if (h.cortex_no_value > 0)
    w << h.cortex_no_value << (h.cortex_outside > 0 ? "" : " of the cortex's " + std::to_string(h.cortex_vertices) + " vertices")
      << " have no PET value (outside, part of their sampling segment outside, or on NaN voxels; elements average the rest)";
  w << ": check the scan's coverage";
  summary.warnings.push_back(w.str());
}

// Step 3. PET by normal projection from the pial surface inward (Zou et al. 2011, section 5.2),
// then normalised. Sets `registration` for the report's quality flags.
Normalisation sample_and_normalise(Hemisphere (&hemis)[2], const SubjectInputs& in, const RunOptions& options,
                                   const LoadedInputs& inputs, StepLog& log, RunSummary& summary, std::string& registration) {
  log.begin("PET sampling");
  SamplingOptions so;
  so.depth_mm = options.depth_mm;
  so.alignment_hint = "its alignment with the subject's surfaces (FreeSurfer c_ras; --t1 registers the PET to the subject's T1)";
  const Eigen::Matrix4d t1_to_pet = register_pet_to_t1(in, inputs.pet, log, registration);
  for (Hemisphere& h : hemis) {
    const MatrixXd Vw = transform_points(t1_to_pet * h.pial.to_scanner, h.pial.mesh.V);
    h.sampling = sample_normal_projection(inputs.pet, Vw, h.pial.mesh.F, so);
    h.pet = h.sampling.values;
    for (const std::string& n : h.sampling.notes) log.note(h.name + " pial surface: " + n);
    note_cortex_coverage(h, inputs.pet, Vw, summary);
  }
  log.note_new_warnings(summary.warnings);
  const Normalisation norm = subject_normalisation(hemis, in, options, inputs.pet, inputs.mask.get());
  for (Hemisphere& h : hemis) apply_normalisation(h.pet, norm);
  log.note(hemis[0].sampling.method + "; normalisation: " + (norm.description.empty() ? "none" : norm.description));
  log.end(summary);
  return norm;
}

// Step 4. Equal-area elements of both hemispheres, as one table.
ElementTable elements_step(Hemisphere (&hemis)[2], const SubjectInputs& in, const RunOptions& options, const Normalisation& norm,
                           const std::string& pet_units, const std::string& correspondence, StepLog& log, RunSummary& summary) {
  log.begin("equal-area elements");
  ElementTable table;
  table.grid = element_grid(Domain::square(), options.k);
  table.normalisation = to_string(norm.kind);
  table.units = !norm.units.empty() ? norm.units : !pet_units.empty() ? pet_units : "PET units";  // as `sample` says it
  table.subject_id = in.id;
  table.age = in.age > 0 ? in.age : std::numeric_limits<double>::quiet_NaN();
  table.metadata["software"] = software_version();
  table.metadata["sampling"] = hemis[0].sampling.method;
  if (norm.kind == NormalisationKind::ReferenceRegion && !norm.mask_path.empty())
    table.metadata[kReferenceMaskKey] = io::sha256_file(norm.mask_path);  // compare refuses SUVRs of another region
  table.metadata["correspondence"] = correspondence;
  for (Hemisphere& h : hemis) {
    const ElementMap m = prepare_element_map(h.white.mesh.V, h.cortex_faces, h.map.UV, h.map.F, h.pet, Domain::square(),
                                             h.name + " square map");
    h.elements = compute_elements(m, table.grid, h.white.to_scanner);
    h.elements.block.hemisphere = h.name;
    table.blocks.push_back(h.elements.block);
  }
  log.end(summary);
  return table;
}

// Step 5. Comparison with the normative reference: z per element, clusters, warnings.
Comparison compare_step(const NormativeReference& reference, const ElementTable& table, const SubjectInputs& in,
                        const RunOptions& options, StepLog& log, RunSummary& summary) {
  log.begin("normative comparison");
  CompareOptions co;
  co.reference_name = in.normative;
  co.threshold = options.z_threshold;
  co.rescale = options.rescale;
  Comparison cmp = compare_to_reference(reference, table, co);
  const int dropped = drop_small_clusters(cmp, options.min_cluster_elements);
  if (dropped > 0)
    log.note(std::to_string(dropped) + " clusters of fewer than " + std::to_string(options.min_cluster_elements) + " elements not reported");
  // Each note qualifies every z-score (the subject is one of the controls; z not age adjusted and
  // why, issue 15: up to 1.2 in z at 75 years): warnings, so they reach stderr, the JSON and the
  // report, not only the log.
  for (const std::string& n : cmp.notes) summary.warnings.push_back(n);
  log.note_new_warnings(summary.warnings);
  summary.abnormal_elements = cmp.num_hypo + cmp.num_hyper;
  summary.clusters = static_cast<int>(cmp.clusters.size());
  summary.clusters_json = clusters_json(cmp.clusters);
  log.end(summary);
  return cmp;
}

// One JSON sidecar per BIDS base name (x.nii.gz and x.png share x.json, which lists both); each
// file added is also listed in the run's summary.
class Sidecars {
 public:
  Sidecars(json common, RunSummary& summary) : common_(std::move(common)), summary_(summary) {}
  void add(const std::string& file, const json& extra) {
    const std::string base = file.substr(0, file.find('.'));
    json& j = sidecars_[base];
    if (j.is_null()) j = common_;
    j["files"].push_back(file);
    j.update(extra);
    summary_.files.push_back(file);
  }
  void write(const fs::path& stage) const {
    for (const auto& [base, j] : sidecars_) io::write_file_atomically((stage / (base + ".json")).string(), j.dump(2) + "\n");
  }

 private:
  json common_;
  RunSummary& summary_;
  std::map<std::string, json> sidecars_;
};

// What every output-writing step shares: where files go, how they are named, their sidecars and
// the Workbench spec (sub-<id>_workbench.spec: the files wb_view opens together).
struct OutputSink {
  const fs::path& stage;
  const SubjectFiles& names;
  Sidecars& sidecars;
  std::vector<io::SpecEntry>& spec;
};

// The run's parameters as every sidecar records them.
json run_parameters(const Hemisphere (&hemis)[2], const RunOptions& options, const Normalisation& norm, bool compare,
                    const Comparison& cmp, const std::string& correspondence) {
  json j = {{"k", options.k},
            {"depth_mm", options.depth_mm},
            {"sampling", hemis[0].sampling.method},
            {"normalisation", norm.description.empty() ? "none" : norm.description},
            {"correspondence", correspondence}};
  if (compare) {  // without a reference there are no z-scores for these to describe
    j["z_threshold"] = options.z_threshold;
    j["z_age_adjusted"] = cmp.age_adjusted;
    j["rescale_to_reference"] = options.rescale;
  }
  return j;
}

// The subject's white and pial surfaces and its flat map (scaled so 1 mm^2 flat = 1 mm^2 cortex
// on average). Returns the flat map's write options, which the other per-hemisphere files reuse.
io::SurfaceWriteOptions write_hemisphere_surfaces(const Hemisphere& h, const SubjectInputs& in, OutputSink& out) {
  const double area = face_areas(h.map.V, h.map.F).sum();
  TriMesh flat;
  flat.V = MatrixXd::Zero(h.map.UV.rows(), 3);
  flat.V.leftCols(2) = h.map.UV * std::sqrt(area);
  flat.F = h.map.F;
  io::SurfaceWriteOptions wo;
  wo.anatomical_structure = h.left ? "CortexLeft" : "CortexRight";
  wo.geometric_type = "Flat";
  wo.metadata = {{"units", "mm"}, {"space", "authalic square map scaled to cortical area (mm^2 flat = mm^2 cortex)"}};
  // The subject's own surfaces, which every per-vertex file below pairs with (Workbench spec).
  for (const auto& [surface, kind, source] : {std::tuple<const io::Surface*, std::string, std::string>{&h.white, "white", h.left ? in.lh_white : in.rh_white},
                                               {&h.pial, "pial", h.left ? in.lh_pial : in.rh_pial}}) {
    const std::string name = out.names.surface(h.tag, kind);
    write_anatomical_surface((out.stage / name).string(), *surface, wo.anatomical_structure, kind);
    out.sidecars.add(name, {{"description", "the subject's " + kind + " surface in scanner RAS (mm), as read from " + source},
                            {"units", "mm"},
                            {"space", "scanner RAS"}});
    out.spec.push_back({wo.anatomical_structure, "SURFACE", name});
  }
  const std::string flat_name = out.names.flat(h.tag);
  io::write_surface((out.stage / flat_name).string(), flat, wo);
  // Per-vertex files show on the flat map in Workbench when it has the surface's vertices: always,
  // unless a dividing edge could not be flipped and was split (core/conformal_map.h, step 3).
  if (flat.num_vertices() == h.white.mesh.num_vertices()) out.spec.push_back({wo.anatomical_structure, "SURFACE", flat_name});
  out.sidecars.add(flat_name, {{"description", "authalic flat map; square side sqrt(cortical area) mm"},
                               {"units", "mm"},
                               {"space", wo.metadata.at("space")},
                               {"metrics", {{"flips", h.metrics.flips}, {"element_area_cv", h.metrics.element_cv}}}});
  return wo;
}

// This hemisphere's part of the whole-brain 2:1 rectangle, in mm (the rectangle's area equals
// both hemispheres' cortical area).
void write_rectangle_part(const Hemisphere& h, const HemisphereRectangles& rect, const MapMetrics& rect_metrics,
                          const RunOptions& options, const io::SurfaceWriteOptions& wo, OutputSink& out) {
  const RectanglePart& part = h.left ? rect.left : rect.right;
  const double total = face_areas(rect.left.V, rect.left.F).sum() + face_areas(rect.right.V, rect.right.F).sum();
  TriMesh rflat;
  rflat.V = MatrixXd::Zero(part.UV.rows(), 3);
  rflat.V.leftCols(2) = part.UV * std::sqrt(total / 2.0);
  rflat.F = part.F;
  io::SurfaceWriteOptions ro = wo;
  ro.metadata["space"] = "authalic whole-brain 2:1 rectangle scaled to the cortical area of both hemispheres (mm)";
  ro.metadata[kSeamMmKey] = seam_text(rect.split * std::sqrt(total / 2.0));  // in the file's units (mm), as `rectangle --flat` records it
  const std::string rect_name = out.names.rectangle_flat(h.tag);
  io::write_surface((out.stage / rect_name).string(), rflat, ro);
  if (rflat.num_vertices() == h.white.mesh.num_vertices()) out.spec.push_back({wo.anatomical_structure, "SURFACE", rect_name});
  out.sidecars.add(rect_name, {{"description", "this hemisphere's part of the whole-brain 2:1 rectangle (left part x in [0, w_L], "
                                               "right part [w_L, 2] before scaling by sqrt(total cortical area / 2) mm)"},
                               {"units", "mm"},
                               {"space", ro.metadata.at("space")},
                               {"seam_x_mm", rect.split * std::sqrt(total / 2.0)},
                               {"metrics", {{"flips", rect_metrics.flips}, {"element_area_cv", rect_metrics.element_cv},
                                            {"element_grid", {2 * options.k, options.k}}, {"left_part_width", rect.split}}}});
}

// The hemisphere's PET per vertex, its element values (NIfTI and picture) and each vertex's element.
void write_hemisphere_pet(const Hemisphere& h, const ElementTable& table, int K, const io::SurfaceWriteOptions& wo,
                          OutputSink& out) {
  io::FuncWriteOptions fo;
  fo.column_names = {"pet"};
  fo.anatomical_structure = wo.anatomical_structure;
  fo.metadata = {{"normalisation", table.normalisation}, {"units", table.units}, {"sampling", h.sampling.method}};
  const std::string pet_name = out.names.pet(h.tag);
  io::write_per_vertex((out.stage / pet_name).string(), h.pet, fo);
  out.spec.push_back({wo.anatomical_structure, "METRIC", pet_name});
  out.sidecars.add(pet_name, {{"description", std::string("PET per vertex (normal projection)") +
                                                  (table.normalisation == "none" ? ", not normalised" : ", normalised: " + table.normalisation)},
                              {"units", table.units}});
  const std::string img_name = out.names.pet_elements(h.tag, ".nii.gz");
  write_element_nifti((out.stage / img_name).string(), element_image(h.elements.block, table.grid), table.grid, 1,
                      mean_element_area(h.elements.block), ElementImageKind::kValues, "authalic PET elements " + h.name);
  out.sidecars.add(img_name, {{"description", "element PET values, K x K (i = column, j = row from the bottom)"}, {"units", table.units},
                              {"space", element_space_note(mean_element_area(h.elements.block))}});
  ScalarColouring c;
  const auto range = robust_range(h.pet);
  c.vmin = range.first;
  c.vmax = range.second;
  c.label = table.units;
  const std::string png_name = out.names.pet_elements(h.tag, ".png");
  io::write_png((out.stage / png_name).string(),
                render_element_grid(block_values(h.elements.block), K, K, c, 12, h.name + " PET elements"));
  out.sidecars.add(png_name, {{"description", "element PET values"}});
  const std::string labels_name = out.names.element_labels(h.tag);
  write_element_labels((out.stage / labels_name).string(), h.elements, table.grid, h.elements.block.hemisphere);
  out.spec.push_back({wo.anatomical_structure, "LABEL", labels_name});
  out.sidecars.add(labels_name, {{"description", "each vertex's equal-area element: key = element id + 1 (id = row x K + column), 0 = "
                                                 "in no element; pairs with the white and pial surfaces (the input's vertices)"},
                                 {"units", "element key (no unit)"},
                                 {"element_grid", {K, K}}});
}

// One hemisphere's z-scores: element NIfTI and picture, and per vertex.
void write_hemisphere_zscores(const Hemisphere& h, const std::vector<double>& z, const Comparison& cmp, const ElementTable& table,
                              int K, OutputSink& out) {
  ElementBlock zb = h.elements.block;
  for (std::size_t i = 0; i < zb.elements.size(); ++i) zb.elements[i].value = z[i];
  const std::string zimg = out.names.zscore_elements(h.tag, ".nii.gz");
  write_element_nifti((out.stage / zimg).string(), element_image(zb, table.grid), table.grid, 1, mean_element_area(zb),
                      ElementImageKind::kZScore, "authalic z " + h.name);
  out.sidecars.add(zimg, {{"description", "element z-scores, z = (factor x patient - reference mean) / (reference SD x sqrt(1 + 1/n)); "
                                          "factor: the patient's rescaling to the reference over its normal elements (1 = none)"},
                          {"units", "z (standard deviations of the reference controls)"},
                          {"space", element_space_note(mean_element_area(zb))},
                          {"rescale_factor", cmp.scale},
                          {"rescale_elements", cmp.scale_elements}});
  ScalarColouring zc;
  zc.colormap = "coolwarm";
  zc.vmin = -4;
  zc.vmax = 4;
  zc.label = "z";
  const std::string zpng = out.names.zscore_elements(h.tag, ".png");
  io::write_png((out.stage / zpng).string(), render_element_grid(z, K, K, zc, 12, h.name + " z-scores"));
  out.sidecars.add(zpng, {{"description", "element z-scores"}});
  io::FuncWriteOptions zo;
  zo.column_names = {"z"};
  zo.anatomical_structure = h.left ? "CortexLeft" : "CortexRight";
  zo.intent = 5;  // NIFTI_INTENT_ZSCORE, as the element z image
  zo.metadata = {{"description", "z of each vertex's equal-area element (NaN: in no element)"}, {"units", "z"}};
  const std::string zfunc = out.names.zscore(h.tag);
  io::write_per_vertex((out.stage / zfunc).string(), element_values_at_vertices(h.elements.vertex_element, z.data(),
                                                                               static_cast<int>(z.size())), zo);
  out.sidecars.add(zfunc, {{"description", "per-vertex z: the z of the vertex's element; pairs with the white and pial surfaces"},
                           {"units", "z (standard deviations of the reference controls)"}});
  out.spec.push_back({zo.anatomical_structure, "METRIC", zfunc});
}

// Both hemispheres' z-scores and the clusters table.
void write_comparison(const Hemisphere (&hemis)[2], const Comparison& cmp, const ElementTable& table, const RunOptions& options,
                      OutputSink& out) {
  for (int b = 0; b < 2; ++b) {
    const std::vector<double> z(cmp.z.begin() + b * table.grid.num_elements(), cmp.z.begin() + (b + 1) * table.grid.num_elements());
    write_hemisphere_zscores(hemis[b], z, cmp, table, options.k, out);
  }
  const std::string clusters_name = out.names.clusters();
  io::write_file_atomically((out.stage / clusters_name).string(), clusters_tsv(cmp.clusters));
  out.sidecars.add(clusters_name, clusters_tsv_sidecar(options.z_threshold));
}

// Everything a run computed, for the output steps.
struct RunResults {
  const HemisphereRectangles& rect;
  const MapMetrics& rect_metrics;
  const ElementTable& table;
  const Comparison& cmp;
  bool compare;
  const json& params;
  const json& checksums;
};

// Step 6. The data files, staged in a hidden folder (renamed into place at the end). Returns the stage.
fs::path write_outputs(const Hemisphere (&hemis)[2], const SubjectInputs& in, const RunOptions& options, const SubjectFiles& names,
                       const RunResults& r, StepLog& log, RunSummary& summary) {
  log.begin("write outputs");
  fs::create_directories(options.out_dir);
  const fs::path stage = staging_folder(options, in.id);
  fs::remove_all(stage);
  fs::create_directories(stage);
  // The subject as BIDS participants.tsv describes one (null: not given).
  const json participant = {{"participant_id", "sub-" + in.id},
                            {"age", in.age > 0 ? json(in.age) : json(nullptr)},
                            {"sex", in.sex.empty() ? json(nullptr) : json(in.sex)}};
  json common = {{"software", software_version()}, {"parameters", r.params}, {"inputs", r.checksums}, {"participant", participant}};
  if (!options.command_line.empty()) common["command_line"] = options.command_line;
  Sidecars sidecars(std::move(common), summary);
  std::vector<io::SpecEntry> spec;
  OutputSink out{stage, names, sidecars, spec};
  for (const Hemisphere& h : hemis) {
    const io::SurfaceWriteOptions wo = write_hemisphere_surfaces(h, in, out);
    if (options.rectangle) write_rectangle_part(h, r.rect, r.rect_metrics, options, wo, out);
    write_hemisphere_pet(h, r.table, options.k, wo, out);
  }
  const std::string table_name = names.element_table();
  write_element_table((stage / table_name).string(), r.table);
  summary.files.push_back(table_name);
  if (r.compare) write_comparison(hemis, r.cmp, r.table, options, out);
  const std::string spec_name = names.workbench_spec();
  io::write_workbench_spec((stage / spec_name).string(), spec);
  summary.files.push_back(spec_name);
  sidecars.write(stage);
  log.end(summary);
  return stage;
}

// The report (HTML and PDF), into the stage.
void report_step(const Hemisphere (&hemis)[2], const SubjectInputs& in, const RunOptions& options, const SubjectFiles& names,
                 const RunResults& r, const NormativeReference& reference, const std::string& registration,
                 const fs::path& stage, StepLog& log, RunSummary& summary) {
  log.begin("report (HTML and PDF)");
  const ReportData rd = report_data(in, options, hemis, r.rect, r.table, r.compare ? &r.cmp : nullptr, reference, r.params, summary,
                                    registration);
  const ReportFigures figures = report_figures(rd);  // drawn once for both
  write_report((stage / names.report()).string(), rd, figures);
  write_report_pdf((stage / names.report_pdf()).string(), rd, figures);
  summary.files.push_back(names.report());
  summary.files.push_back(names.report_pdf());
  log.end(summary);
}

// Swap the finished folder into place (replacing a previous run's, under --force).
void swap_into_place(const fs::path& stage, const fs::path& final_dir, const RunOptions& options, const std::string& id) {
  if (fs::exists(final_dir)) {
    const fs::path old = fs::path(options.out_dir) / (".sub-" + id + ".old-" + std::to_string(::getpid()));
    fs::rename(final_dir, old);
    fs::rename(stage, final_dir);
    fs::remove_all(old);
  } else {
    fs::rename(stage, final_dir);
  }
}

}  // namespace

std::string correspondence_mode(const SubjectInputs& in, const RunOptions& options) {
  if (options.atlas_dir.empty()) return kPerSubjectCorrespondence;
  const bool registered = in.lh_sphere_reg.empty() || in.rh_sphere_reg.empty();
  return std::string(registered ? "registration" : "atlas") + " " + atlas_identity(atlas_files_from_dir(options.atlas_dir, "lh")) +
         "+" + atlas_identity(atlas_files_from_dir(options.atlas_dir, "rh"));
}

RunSummary run_subject(const SubjectInputs& in, const RunOptions& options, const ProgressFn& progress) {
  check_id(in.id);
  if (options.out_dir.empty()) throw InputError("--out: no output folder given");
  const fs::path final_dir = fs::path(options.out_dir) / ("sub-" + in.id);
  io::check_inputs_outside({in.lh_white, in.lh_pial, in.rh_white, in.rh_pial, in.lh_cortex, in.rh_cortex, in.pet, in.t1, in.normative,
                            in.lh_annot, in.rh_annot, in.lh_sphere_reg, in.rh_sphere_reg},
                           final_dir.string(), options.force ? "--force would replace" : "is the subject's output folder");
  const OutFolder out_folder(options.out_dir);
  // The whole run holds the subject's lock: a second run on the same OUT/sub-<id> is refused
  // instead of racing this one to the final rename.
  const io::LockFile lock((fs::path(options.out_dir) / (".sub-" + in.id + ".lock")).string(), final_dir.string());
  remove_dead_staging(options.out_dir, in.id);
  if (fs::exists(final_dir) && !options.force)
    throw InputError(final_dir.string() + ": output folder exists; pass --force to replace it or choose another --out");

  RunSummary summary;
  StepLog log(progress);
  const SubjectFiles names{in.id};
  Hemisphere hemis[2];
  const LoadedInputs inputs = load_and_check_inputs(hemis, in, options, log, summary);
  const std::string correspondence =
      correspondence_step(hemis, in, options, inputs.compare ? &inputs.reference : nullptr, log, summary, progress);
  map_hemispheres(hemis, in, options, log, summary, progress);
  HemisphereRectangles rect;
  MapMetrics rect_metrics;
  if (options.rectangle) rect_metrics = rectangle_step(hemis, options, log, summary, rect);
  std::string registration;  // for the report's quality flags
  const Normalisation norm = sample_and_normalise(hemis, in, options, inputs, log, summary, registration);
  const ElementTable table = elements_step(hemis, in, options, norm, inputs.pet.units, correspondence, log, summary);
  Comparison cmp;
  if (inputs.compare) cmp = compare_step(inputs.reference, table, in, options, log, summary);
  const json params = run_parameters(hemis, options, norm, inputs.compare, cmp, correspondence);
  const RunResults results{rect, rect_metrics, table, cmp, inputs.compare, params, inputs.checksums};
  const StagingGuard staging(staging_folder(options, in.id));
  const fs::path stage = write_outputs(hemis, in, options, names, results, log, summary);
  if (options.report) report_step(hemis, in, options, names, results, inputs.reference, registration, stage, log, summary);
  io::write_file_atomically((stage / names.log()).string(), software_version() + "\nsubject sub-" + in.id + "\n" + log.text());
  summary.files.push_back(names.log());
  swap_into_place(stage, final_dir, options, in.id);
  write_dataset_description(options.out_dir);
  summary.subject_dir = final_dir.string();
  summary.flips_left = hemis[0].metrics.flips;
  summary.flips_right = hemis[1].metrics.flips;
  summary.element_cv_left = hemis[0].metrics.element_cv;
  summary.element_cv_right = hemis[1].metrics.element_cv;
  return summary;
}

}  // namespace authalic::analysis

// `authalic sample VOLUME SURFACE OUT.func.gii`: PET on the cortex (normal projection, ribbon or
// vertex values), optionally normalised, as GIFTI func plus a PNG. See analysis/sampling.h.
#include <chrono>
#include <ctime>
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "analysis/elements.h"
#include "analysis/render.h"
#include "analysis/report.h"
#include "analysis/sampling.h"
#include "app/command.h"
#include "core/error.h"
#include "core/version.h"
#include "io/checksum.h"
#include "io/image_io.h"
#include "io/registration.h"
#include "io/surface_io.h"
#include "io/volume_io.h"
#include "io/file_roles.h"

namespace authalic::app {
namespace {

struct SampleArgs {
  std::string volume, surface, out;
  std::string ribbon;
  double depth = 10.0;
  double step = 0.0;
  std::string stat = "mean";
  bool trilinear = false;
  bool outward = false;
  std::string normalize = "none";
  std::string cortex;  // the region --normalize global averages over
  std::string surface_to_volume;
  std::string register_t1;
  std::string map;
  std::string png;
  int frame = -1;
  bool sum_frames = false;
};

std::string matrix_text(const Eigen::Matrix4d& T) {
  std::ostringstream s;
  s.precision(10);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) s << T(r, c) << (c == 3 ? (r == 3 ? "" : "; ") : " ");
  return s.str();
}

std::string png_path_for(const std::string& out) {
  for (const std::string ext : {".func.gii", ".shape.gii", ".gii"})
    if (out.size() > ext.size() && out.compare(out.size() - ext.size(), ext.size(), ext) == 0)
      return out.substr(0, out.size() - ext.size()) + ".png";
  return out + ".png";
}

// Combinations of options that cannot work, refused before any file is read.
void check_sample_options(const SampleArgs& a) {
  if (a.trilinear && !a.ribbon.empty()) throw InputError("--trilinear and --ribbon: choose one sampling mode");
  if (a.stat != "mean" && a.stat != "max") throw InputError("--stat: '" + a.stat + "' is not mean or max");
  if (!a.register_t1.empty() && !a.surface_to_volume.empty())
    throw InputError("--register and --surface-to-volume: give one (the registration computes the transform)");

  // The whole surface includes the medial wall (fsaverage5: 4,002 of 10,242 vertices), whose
  // values are not cortex: the global mean is taken over the cortex region, as `run` does.
  if (a.normalize == "global" && a.cortex.empty())
    throw InputError("--normalize global: give the cortex region of " + a.surface +
                     " with --cortex (a FreeSurfer label such as lh.cortex.label, a GIFTI label or a mask); the mean over "
                     "the whole surface would include the medial wall");
}

// The surface -> volume world transform and where it came from (the surface's own footer, a
// --surface-to-volume matrix, or --register's rigid registration of the PET to the T1).
struct SurfaceToVolume {
  Eigen::Matrix4d T;
  std::string source;
  io::RigidRegistration registration;
};

SurfaceToVolume surface_to_volume(const SampleArgs& a, const io::Surface& surface, const io::Volume& volume) {
  SurfaceToVolume s;
  s.T = surface.to_scanner;
  s.source = surface.has_volume_geometry ? "FreeSurfer footer (tkregister RAS + c_ras)"
             : surface.format == "freesurfer"
                 ? "identity: a FreeSurfer surface (tkregister RAS) without a valid volume-geometry footer, taken as scanner RAS "
                   "(c_ras unknown, assumed 0)"
                 : "identity (surface in scanner RAS)";
  if (!a.surface_to_volume.empty()) {
    std::ifstream in(a.surface_to_volume);
    if (!in) throw InputError(a.surface_to_volume + ": cannot read the surface-to-volume matrix");
    std::stringstream buf;
    buf << in.rdbuf();
    s.T = analysis::parse_affine_text(buf.str(), a.surface_to_volume);
    s.source = a.surface_to_volume;
  }
  if (!a.register_t1.empty()) {
    // The surface is in the T1's scanner RAS; the PET is not co-registered: register the PET to the
    // T1 (rigid, Mattes MI) and carry the surface into the PET's world coordinates.
    const io::Volume t1 = io::read_volume(a.register_t1);
    s.registration = io::register_rigid(t1, volume);
    s.T = s.registration.t1_to_pet * s.T;
    s.source = "rigid registration of " + a.volume + " to " + a.register_t1 + " (ITK v4, Mattes MI, final metric " +
               std::to_string(s.registration.metric) + ", " + s.registration.stop_condition + ")";
    info("sample: registered the PET to " + a.register_t1 + ": Mattes MI " + std::to_string(s.registration.metric) + " after " +
         std::to_string(s.registration.iterations) + " iterations; T1 RAS -> PET RAS:\n" + matrix_text(s.registration.t1_to_pet));
  }
  return s;
}

// The PET at the vertices: trilinear at the vertex, over the ribbon to a second surface, or by
// normal projection (the default).
analysis::SamplingResult sample_volume(const SampleArgs& a, const io::Volume& volume, const MatrixXd& V_world,
                                       const MatrixXi& F, const SurfaceToVolume& to_volume) {
  analysis::SamplingOptions so;
  so.depth_mm = a.depth;
  so.step_mm = a.step;
  so.outward = a.outward;
  so.statistic = a.stat == "max" ? analysis::SamplingStatistic::Max : analysis::SamplingStatistic::Mean;
  if (a.trilinear) return analysis::sample_at_vertices(volume, V_world, F, so);
  if (!a.ribbon.empty()) {
    const io::Surface other = io::read_surface(a.ribbon);
    Eigen::Matrix4d other_to_volume = a.surface_to_volume.empty() ? other.to_scanner : to_volume.T;
    if (!a.register_t1.empty()) other_to_volume = to_volume.registration.t1_to_pet * other.to_scanner;
    return analysis::sample_ribbon(volume, V_world, analysis::transform_points(other_to_volume, other.mesh.V), F, so);
  }
  return analysis::sample_normal_projection(volume, V_world, F, so);
}

// Intensity normalisation: the global mean over the --cortex region, a reference-region mask, or none.
analysis::Normalisation sample_normalisation(const SampleArgs& a, const io::Volume& volume, const io::Surface& surface,
                                             const MatrixXd& V_world, const VectorXd& values) {
  analysis::Normalisation norm;
  norm.units = volume.units.empty() ? "PET units" : volume.units;
  norm.description = "none: values in the PET's units";
  if (a.normalize == "global") {
    std::vector<bool> in_cortex(static_cast<std::size_t>(surface.mesh.num_vertices()), false);
    io::require_vertex_numbering(surface, a.surface, a.cortex);
    for (int v : io::read_region_vertices(a.cortex, surface.mesh)) in_cortex[static_cast<std::size_t>(v)] = true;
    const Submesh cortex = submesh_from_vertices(TriMesh{V_world, surface.mesh.F}, in_cortex);
    if (cortex.mesh.F.rows() == 0)
      throw InputError(a.cortex + ": no triangle of " + a.surface + " has all its vertices in this region; give the cortex label of this surface");
    VectorXd cortex_values(cortex.vertex_to_parent.size());
    for (Eigen::Index i = 0; i < cortex_values.size(); ++i) cortex_values[i] = values[cortex.vertex_to_parent[i]];
    try {
      norm = analysis::global_cortical_mean(cortex_values, cortex.mesh.V, cortex.mesh.F);
    } catch (const InputError& e) {
      throw InputError(a.volume + " on " + a.surface + ": " + e.what());
    }
  } else if (a.normalize != "none") {
    io::Volume mask = io::read_volume(a.normalize);
    norm = analysis::reference_region_mean(volume, mask);
  }
  return norm;
}

// The per-vertex output with its provenance (transform, sampling, normalisation) in the metadata.
void write_sampled_values(const SampleArgs& a, const io::Volume& volume, const std::string& hemisphere,
                          const analysis::SamplingResult& result, const SurfaceToVolume& to_volume,
                          const analysis::Normalisation& norm) {
  io::FuncWriteOptions fo;
  fo.column_names = {"pet"};
  if (hemisphere == "left") fo.anatomical_structure = "CortexLeft";
  if (hemisphere == "right") fo.anatomical_structure = "CortexRight";
  fo.metadata = {{"software", software_version()},
                 {"volume", a.volume},
                 {"surface", a.surface},
                 {"sampling", result.method},
                 {"surface_to_volume", matrix_text(to_volume.T)},
                 {"surface_to_volume_source", to_volume.source},
                 {"normalisation", analysis::to_string(norm.kind)},
                 {"normalisation_detail", norm.description},
                 {"normalisation_reference_value", std::to_string(norm.reference_value)},
                 {"units", norm.units}};
  if (!volume.source_series.empty()) fo.metadata["volume_series"] = volume.source_series;  // which DICOM series
  fo.metadata["volume_orientation"] = volume.orientation_source;  // which affine placed the voxels (sform, qform, ...)
  if (a.frame >= 0) fo.metadata["volume_frame"] = std::to_string(a.frame) + " (0-based)";
  if (a.sum_frames) fo.metadata["volume_frame"] = "sum of all frames (unweighted)";
  if (!a.ribbon.empty()) fo.metadata["ribbon_surface"] = a.ribbon;
  if (a.normalize == "global") fo.metadata["normalisation_region"] = a.cortex;
  if (norm.kind == analysis::NormalisationKind::ReferenceRegion && !norm.mask_path.empty())
    fo.metadata["normalisation_mask_sha256"] = io::sha256_file(norm.mask_path);
  io::write_per_vertex(a.out, result.values, fo);
}

// Picture: the flat map when given, else lateral and medial views of the surface.
void write_sample_png(const SampleArgs& a, const std::string& png, const io::Surface& surface, const MatrixXd& V_world,
                      const std::string& hemisphere, const VectorXd& values, const std::string& units) {
  analysis::ScalarColouring c;
  c.values = values;
  c.colormap = "viridis";
  c.label = units;
  std::tie(c.vmin, c.vmax) = analysis::robust_range(values);
  io::RgbImage picture;
  if (!a.map.empty()) {
    const io::Surface map = io::read_surface(a.map);
    if (map.mesh.num_vertices() < surface.mesh.num_vertices())
      throw InputError(a.map + ": the map has fewer vertices than the surface; give the map of this surface");
    c.values = VectorXd::Constant(map.mesh.num_vertices(), std::nan(""));
    c.values.head(values.size()) = values;
    analysis::FlatRenderOptions o;
    o.x0 = map.mesh.V.col(0).minCoeff();
    o.y0 = map.mesh.V.col(1).minCoeff();
    o.domain_width = std::max(1e-12, map.mesh.V.col(0).maxCoeff() - o.x0);
    o.domain_height = std::max(1e-12, map.mesh.V.col(1).maxCoeff() - o.y0);
    o.title = "PET on the flat map";
    picture = analysis::render_flat(map.mesh.V, map.mesh.F, c, o);
  } else {
    analysis::SurfaceRenderOptions o;
    o.left_hemisphere = hemisphere != "right";
    o.title = "PET on the surface";
    picture = analysis::render_surface_views(V_world, surface.mesh.F, c, {analysis::View::Lateral, analysis::View::Medial}, o);
  }
  io::write_png(png, picture);
}

int run_sample(const SampleArgs& a) {
  const auto start = std::chrono::steady_clock::now();
  io::check_file_roles({a.volume, a.surface, a.ribbon, a.surface_to_volume, a.register_t1, a.map, a.cortex},
                       {a.out, a.png.empty() ? png_path_for(a.out) : a.png});
  io::check_per_vertex_output_name(a.out);  // before minutes of sampling
  check_sample_options(a);

  io::VolumeReadOptions vo;
  vo.frame = a.frame;
  vo.sum_frames = a.sum_frames;
  const io::Volume volume = io::read_volume(a.volume, vo);
  const io::Surface surface = io::read_surface(a.surface);
  if (surface.mesh.num_faces() == 0) throw InputError(a.surface + ": the surface has no triangles");
  const SurfaceToVolume to_volume = surface_to_volume(a, surface, volume);
  const MatrixXd V_world = analysis::transform_points(to_volume.T, surface.mesh.V);

  const auto sampling_start = std::chrono::steady_clock::now();
  const std::clock_t sampling_cpu_start = std::clock();
  analysis::SamplingResult result = sample_volume(a, volume, V_world, surface.mesh.F, to_volume);
  if (surface.format == "freesurfer" && !surface.has_volume_geometry && a.surface_to_volume.empty() && a.register_t1.empty())
    result.notes.push_back(a.surface + " is a FreeSurfer surface (tkregister RAS) without a valid volume-geometry footer: its c_ras "
                           "is unknown and taken as 0; if the subject's orig.mgz has another c_ras, give --surface-to-volume");
  const double sampling_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - sampling_start).count();
  // CPU time of all threads: the step's cost on an idle machine, whatever the load of a shared one.
  const double sampling_cpu_seconds = double(std::clock() - sampling_cpu_start) / CLOCKS_PER_SEC;

  const analysis::Normalisation norm = sample_normalisation(a, volume, surface, V_world, result.values);
  analysis::apply_normalisation(result.values, norm);

  const std::string hemisphere = analysis::hemisphere_of(surface.metadata, a.surface);
  write_sampled_values(a, volume, hemisphere, result, to_volume, norm);
  const std::string png = a.png.empty() ? png_path_for(a.out) : a.png;
  write_sample_png(a, png, surface, V_world, hemisphere, result.values, norm.units);

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const auto& n : result.notes) info("authalic sample: note: " + n);
  info("authalic sample: " + result.method + "; " + std::to_string(result.vertices_checked) + " vertices, " +
       std::to_string(result.nan_vertices) + " NaN; normalisation " + norm.description + "; wrote " + a.out + " and " + png);
  if (global_options().json) {
    nlohmann::json j;
    j["output"] = a.out;
    j["png"] = png;
    j["method"] = result.method;
    j["step_mm"] = result.step_mm;
    j["samples_per_vertex"] = result.samples_per_vertex;
    j["vertices"] = result.vertices_checked;
    j["vertices_outside_fov"] = result.vertices_outside;
    j["outside_fraction"] = result.outside_fraction;
    j["nan_vertices"] = result.nan_vertices;
    j["volume_orientation"] = volume.orientation_source;
    if (!volume.source_series.empty()) j["volume_series"] = volume.source_series;
    j["partial_vertices"] = result.partial_vertices;
    j["normals_flipped"] = result.normals_flipped;
    j["normalisation"] = analysis::to_string(norm.kind);
    j["normalisation_reference_value"] = norm.reference_value;
    j["units"] = norm.units;
    j["notes"] = result.notes;
    j["sampling_seconds"] = sampling_seconds;
    j["sampling_cpu_seconds"] = sampling_cpu_seconds;
    j["seconds"] = seconds;
    std::cout << j.dump(2) << '\n';
  }
  return 0;
}

const bool registered = register_command({40, [](CLI::App& parent) {
  auto a = std::make_shared<SampleArgs>();
  CLI::App* sub = parent.add_subcommand(
      "sample",
      "Sample a PET volume on a cortical surface (Zou et al. 2011 section 5.2): by default the mean of trilinear "
      "samples along the inverse vertex normal from the surface inward over --depth mm. Coordinates: the volume's "
      "sform/qform world (scanner RAS mm; radiological files included); FreeSurfer surfaces are moved from tkregister "
      "RAS to scanner RAS with their c_ras, or by --surface-to-volume. A surface mostly outside the volume is refused. "
      "Writes OUT (GIFTI func, one value per vertex, normalisation in its metadata) and a PNG beside it. NaN voxels are "
      "left out of the interpolation; a vertex whose sampling segment leaves the field of view or meets only NaN voxels "
      "somewhere is NaN (a value from part of the segment would lean toward one end of it).");
  sub->add_option("VOLUME", a->volume, "PET volume: NIfTI (.nii/.nii.gz), MGH/MGZ, or a DICOM series folder")->required();
  sub->add_option("SURFACE", a->surface, "Cortical surface (FreeSurfer, GIFTI, VTK, ...), mm")->required();
  sub->add_option("OUT", a->out,
                  "Output per-vertex values: .func.gii (GIFTI), .txt/.csv (one value a line) or a FreeSurfer curv name "
                  "(lh.pet, x.curv)")
      ->required();
  sub->add_option("--ribbon", a->ribbon,
                  "Ribbon mode: the other surface of the cortical ribbon (white with pial, same vertices); the value is "
                  "the mean along the segment between corresponding vertices (at least 11 samples)");
  sub->add_option("--depth", a->depth, "Normal projection depth (mm)")->capture_default_str()->check(in_range(0.0, 100.0));
  sub->add_option("--step", a->step, "Sampling step (mm, 0.05 to 10); default and maximum: half the smallest voxel size")
      ->check(in_range(0.05, 10.0));
  sub->add_option("--stat", a->stat, "Statistic along the segment: mean, or max (as 3D-SSP)")
      ->check(CLI::IsMember({"mean", "max"}))
      ->capture_default_str();
  sub->add_flag("--trilinear", a->trilinear, "The trilinear value at the vertex itself (no projection)");
  sub->add_flag("--outward", a->outward, "Project along the outward normal instead of inward");
  sub->add_option("--normalize,--normalise", a->normalize,
                  "Intensity normalisation: none, global (divide by the area-weighted mean over the --cortex region), or a "
                  "NIfTI mask of a reference region (e.g. cerebellum, pons; value > 0.5 inside) giving SUV ratios")
      ->capture_default_str();
  sub->add_option("--cortex", a->cortex,
                  "Cortex region of SURFACE for --normalize global (required there): FreeSurfer label (lh.cortex.label), "
                  "GIFTI label or mask; the medial wall is left out of the mean, as in `run`");
  sub->add_option("--surface-to-volume", a->surface_to_volume,
                  "Text file with a 4x4 matrix (row by row) taking the surface's coordinates to the volume's world (scanner "
                  "RAS mm); default: the surface's own (FreeSurfer c_ras, else identity)");
  sub->add_option("--register", a->register_t1,
                  "T1 volume (NIfTI/MGZ) the surface belongs to: rigidly register the PET to it (ITK v4, Mattes mutual "
                  "information) and sample through that transform; without it the PET is assumed co-registered");
  sub->add_option("--map", a->map, "Flat map of SURFACE (e.g. from `authalic flatten`) for the PNG; default: 3D views");
  sub->add_option("--png", a->png, "PNG path (default: OUT with .png)");
  sub->add_option("--frame", a->frame, "4D PET: the frame to sample (0-based)")->check(in_range(0, 100000));
  sub->add_flag("--sum-frames", a->sum_frames, "4D PET: sum all frames (unweighted: frames of equal duration give a static image "
                                               "in the frames' units times their number)");
  add_common_options(*sub);
  sub->callback([a]() { set_exit_code(run_sample(*a)); });
}});

}  // namespace
}  // namespace authalic::app

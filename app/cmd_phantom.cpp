// `authalic phantom OUT_DIR`: writes a phantom cohort (controls and patients with a planted
// hypometabolic region) that the rest of the tool chain can analyse end to end.
#include <unistd.h>

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "analysis/phantom.h"
#include "app/command.h"
#include "core/error.h"

namespace fs = std::filesystem;

namespace authalic::app {
namespace {

// ../shared/data beside the source checkout that holds this executable (build/authalic ->
// <checkout>/build -> <checkout>/../shared/data); empty when there is none.
std::string default_shared_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  for (fs::path dir = exe.parent_path(); !dir.empty() && dir != dir.root_path(); dir = dir.parent_path()) {
    const fs::path candidate = dir.parent_path() / "shared" / "data";
    if (fs::exists(dir / "CMakeLists.txt", ec) && fs::exists(candidate / "spm" / "PET.nii", ec)) {
      return fs::weakly_canonical(candidate, ec).string();
    }
  }
  return {};
}

struct PhantomArgs {
  std::string out_dir;
  analysis::PhantomOptions options;
  std::string shared;
  long long seed = 1;
};

// The cohort is written into a hidden sibling folder and its entries (surf/, label/, truth/,
// sub-*/, cohort.csv, phantom.json) are moved into OUT_DIR only when all are complete, each by one
// rename: a killed or failed run leaves OUT_DIR as it was. Other files in OUT_DIR (a README) stay;
// the subjects of a cohort written there before that the new one lacks go.
analysis::PhantomResult write_staged(const std::string& out_dir, const analysis::PhantomOptions& o) {
  const fs::path out = fs::absolute(out_dir).lexically_normal();
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_directory(out, ec))
    throw InputError(out_dir + ": exists and is not a folder; give a folder for the cohort");
  const fs::path stage = out.parent_path() / ("." + out.filename().string() + ".partial-" + std::to_string(::getpid()));
  analysis::PhantomResult r;
  try {
    fs::remove_all(stage, ec);
    r = analysis::write_phantom(stage.string(), o, terminal_progress());
    fs::create_directories(out);
    // A cohort written here before (its phantom.json) is replaced whole: its subjects that the new
    // one does not have would stay beside it, listed in no cohort.csv.
    if (fs::exists(out / "phantom.json"))
      for (const auto& old : fs::directory_iterator(out)) {
        const std::string name = old.path().filename().string();
        if (old.is_directory() && name.rfind("sub-", 0) == 0 && !fs::exists(stage / name)) fs::remove_all(old.path());
      }
    for (const auto& entry : fs::directory_iterator(stage)) {
      const fs::path target = out / entry.path().filename();
      fs::remove_all(target);
      fs::rename(entry.path(), target);
    }
    fs::remove(stage);
  } catch (...) {
    fs::remove_all(stage, ec);
    throw;
  }
  r.cohort_csv = (out / fs::path(r.cohort_csv).filename()).string();
  return r;
}

void setup(CLI::App& parent) {
  auto args = std::make_shared<PhantomArgs>();
  CLI::App* sub = parent.add_subcommand(
      "phantom",
      "Write a phantom cohort: N control and M patient PET scans (NIfTI, Bq/mL) on known cortical surfaces, patients "
      "with a planted hypometabolic region (default -25% over a posterior-parietal/precuneus patch of 22 mm radius), "
      "the ground truth, and cohort.csv. Uses ../shared/data (fsaverage5 + spm/PET.nii) when present, else a built-in "
      "synthetic folded hemisphere (4002 vertices, pial 2.5 mm outside white) and a tissue-model PET.");
  sub->add_option("OUT_DIR", args->out_dir, "Output folder (created)")->required();
  sub->add_option("--controls", args->options.controls, "Number of control subjects")->check(in_range(0, 2000))
      ->capture_default_str();
  sub->add_option("--patients", args->options.patients, "Number of patients (planted region)")->check(in_range(0, 2000))
      ->capture_default_str();
  sub->add_option("--seed", args->seed, "Random seed: the same seed gives byte-identical files")->capture_default_str();
  sub->add_flag("--synthetic", args->options.synthetic, "Use the built-in synthetic hemisphere and PET even when shared data exist");
  sub->add_option("--shared", args->shared, "Folder with fsaverage5/ and spm/PET.nii (default: ../shared/data beside the checkout)");
  sub->add_flag("--anatomical-variability", args->options.anatomical_variability,
                "Every subject gets its own anatomy: a smooth random variant of fsaverage5 (sphere warp, folding change, "
                "3D deformation; local area changes up to about --area-change) with its sphere.reg (the exact "
                "correspondence), its PET and lesion carried by the same deformation, and the template as OUT/atlas "
                "(for run --atlas); needs the shared data");
  sub->add_option("--area-change", args->options.area_change, "Anatomical variability: local area change scale (0.15 = 15 %)")
      ->check(in_range(0.0, 0.5))->capture_default_str();
  sub->add_option("--deformation-wavelength", args->options.deformation_wavelength_mm,
                  "Anatomical variability: wavelength of the area changes (mm)")
      ->check(in_range(10.0, 1000.0))->capture_default_str();
  sub->add_option("--fold-change", args->options.fold_change,
                  "Anatomical variability: folding change, normal offset per mm of sulcal depth (at most)")
      ->check(in_range(0.0, 0.5))->capture_default_str();
  sub->add_option("--voxel-size", args->options.voxel_mm, "Synthetic PET voxel size (mm)")->check(in_range(1.0, 10.0))
      ->capture_default_str();
  sub->add_option("--radius", args->options.region_radius_mm, "Planted region radius along the white surface (mm)")
      ->check(in_range(2.0, 80.0))->capture_default_str();
  sub->add_option("--depth", args->options.region_depth, "Planted reduction as a fraction (0.25 = -25%)")
      ->check(in_range(0.01, 0.95))->capture_default_str();
  add_common_options(*sub);
  sub->callback([args]() {
    analysis::PhantomOptions o = args->options;
    o.seed = static_cast<std::uint64_t>(args->seed);
    o.shared_dir = args->shared.empty() ? default_shared_dir() : args->shared;
    if (!args->shared.empty() && !o.synthetic && !fs::exists(args->shared + "/spm/PET.nii")) {
      throw InputError(args->shared + ": no spm/PET.nii and fsaverage5/ here; give the shared data folder or use --synthetic");
    }
    analysis::PhantomResult r = write_staged(args->out_dir, o);
    int region_vertices = 0;
    for (bool b : r.region.left_mask) region_vertices += b;
    if (global_options().json) {
      nlohmann::json j = {{"out_dir", fs::absolute(args->out_dir).lexically_normal().string()},
                          {"source", r.source},
                          {"cohort_csv", r.cohort_csv},
                          {"controls", o.controls},
                          {"patients", o.patients},
                          {"seed", o.seed},
                          {"region_depth_fraction", r.region.depth},
                          {"region_radius_mm", r.region.radius_mm},
                          {"region_vertices_per_hemisphere", region_vertices},
                          {"region_area_mm2_per_hemisphere", r.region_area_mm2}};
      std::cout << j.dump(2) << '\n';
    } else {
      info("phantom: " + std::to_string(r.subjects.size()) + " subjects (" + r.source + ") in " + args->out_dir);
      info("phantom: planted region -" + std::to_string(static_cast<int>(100 * r.region.depth + 0.5)) + "%, " +
           std::to_string(region_vertices) + " vertices, " + std::to_string(static_cast<int>(r.region_area_mm2 + 0.5)) +
           " mm^2 per hemisphere; cohort table " + r.cohort_csv);
    }
  });
}

const bool registered = register_command({60, setup});

}  // namespace
}  // namespace authalic::app

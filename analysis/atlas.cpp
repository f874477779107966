#include "analysis/atlas.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "analysis/cortex_region.h"
#include "core/error.h"
#include "io/checksum.h"
#include "io/surface_io.h"

namespace fs = std::filesystem;

namespace authalic::analysis {

AtlasFiles atlas_files_from_dir(const std::string& dir, const std::string& hemi) {
  if (!fs::is_directory(dir))
    throw InputError(dir + ": --atlas is not a folder; give an atlas subject folder in FreeSurfer layout (e.g. "
                     "$FREESURFER_HOME/subjects/fsaverage)");
  auto need = [&](const std::string& rel) {
    const fs::path p = fs::path(dir) / rel;
    if (!fs::exists(p))
      throw InputError(p.string() + ": missing from the atlas folder; an atlas needs surf/?h.white, surf/?h.sphere and "
                       "label/?h.cortex.label (FreeSurfer layout)");
    return p.string();
  };
  return {need("surf/" + hemi + ".white"), need("surf/" + hemi + ".sphere"), need("label/" + hemi + ".cortex.label")};
}

std::string atlas_identity(const AtlasFiles& f) {
  return io::sha256_bytes(io::sha256_file(f.white) + io::sha256_file(f.sphere) + io::sha256_file(f.cortex)).substr(0, 16);
}

std::string atlas_mode(const AtlasFiles& files) { return "atlas " + atlas_identity(files); }
std::string registration_mode(const AtlasFiles& files) { return "registration " + atlas_identity(files); }

Atlas load_atlas(const AtlasFiles& files, const ProgressFn& progress) {
  Atlas A;
  A.files = files;
  A.identity = atlas_identity(files);
  const io::Surface white = io::read_surface(files.white);
  const io::Surface sphere = io::read_surface(files.sphere);
  if (sphere.mesh.num_vertices() != white.mesh.num_vertices())
    throw InputError(files.sphere + ": has " + std::to_string(sphere.mesh.num_vertices()) + " vertices but the atlas surface " +
                     files.white + " has " + std::to_string(white.mesh.num_vertices()) +
                     "; give the sphere of the same atlas hemisphere");
  CortexRegion region = read_cortex_region(white.mesh, files.white, files.cortex, "atlas");
  A.note = region.note;
  try {
    SquareMapOptions options;
    options.surface_faces = &white.mesh.F;
    A.square = atlas_square_map(white.mesh.V, sphere.mesh.V, region.F, options, progress);
  } catch (const InputError& e) {
    throw InputError(files.white + " (atlas, " + files.cortex + "): " + e.what());
  }
  return A;
}

double same_element_share(const MatrixXd& UV, const MatrixXd& atlas_UV_at, const MatrixXd& V, const MatrixXi& F, int k,
                          double* median_shift) {
  const VectorXd area = barycentric_vertex_areas(V, F);
  auto cell = [k](double x) { return std::clamp(static_cast<int>(std::floor(x * k)), 0, k - 1); };
  double same = 0, total = 0;
  std::vector<std::pair<double, double>> shift;  // (elements, area)
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    if (!(area[v] > 0)) continue;
    total += area[v];
    if (cell(UV(v, 0)) == cell(atlas_UV_at(v, 0)) && cell(UV(v, 1)) == cell(atlas_UV_at(v, 1))) same += area[v];
    shift.push_back({(UV.row(v) - atlas_UV_at.row(v)).norm() * k, area[v]});
  }
  if (median_shift) {
    std::sort(shift.begin(), shift.end());
    double acc = 0;
    *median_shift = shift.empty() ? 0 : shift.back().first;
    for (const auto& [d, a] : shift)
      if ((acc += a) >= total / 2) {
        *median_shift = d;
        break;
      }
  }
  return total > 0 ? same / total : 0;
}

}  // namespace authalic::analysis

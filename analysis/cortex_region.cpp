#include "analysis/cortex_region.h"

#include <filesystem>
#include <iomanip>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "core/region.h"
#include "io/surface_io.h"

namespace authalic::analysis {

CortexRegion read_cortex_region(const TriMesh& white, const std::string& white_path, const std::string& cortex_path,
                                const std::string& name) {
  const int n = white.num_vertices();
  const io::RegionFile file = io::read_region_file(cortex_path, white);
  CortexRegion region;
  if (file.is_face_set) {
    if (file.face_set_vertices != n)
      throw InputError(cortex_path + ": has " + std::to_string(file.face_set_vertices) + " vertices but " + white_path + " has " +
                       std::to_string(n) + "; a cortex face set must be on the white surface's vertices");
    region.F = file.faces;
    try {
      region.topology = require_disk(white.V, region.F, cortex_path + ": the cortex region on " + white_path);
    } catch (const InputError& e) {
      throw InputError(std::string(e.what()) + "; e.g. FreeSurfer's ?h.cortex.label is one");
    }
    return region;
  }
  std::vector<bool> in(static_cast<std::size_t>(n), false);
  for (int v : file.vertices) in[static_cast<std::size_t>(v)] = true;
  const RegionCleanup c = region_faces_from_vertices(white.V, white.F, in);
  if (c.F.rows() == 0)
    throw InputError(cortex_path + ": the label's " + std::to_string(file.vertices.size()) + " vertices contain no whole triangle of " +
                     white_path + "; check that the label belongs to this surface");
  // A damaged surface shows in the region as holes and loops: say what is wrong with it instead.
  if (!c.surface_damage.empty()) throw InputError(white_path + ": " + c.surface_damage);
  if (!c.is_disk())
    throw InputError(cortex_path + " on " + white_path + ": " + c.problem() +
                     "; the map needs a region with one boundary loop, e.g. FreeSurfer's ?h.cortex.label");
  if (const std::string pieces = c.pieces_problem(); !pieces.empty()) throw InputError(cortex_path + " on " + white_path + ": " + pieces);
  region.F = c.F;
  region.topology = c.topology;
  std::ostringstream line;
  line << name << " cortex " << std::filesystem::path(cortex_path).filename().string() << ": " << file.vertices.size()
       << " label vertices, " << c.F.rows() << " faces, " << std::fixed << std::setprecision(1) << c.area_mm2 << " mm^2; "
       << c.summary();
  region.note = line.str();
  return region;
}

}  // namespace authalic::analysis

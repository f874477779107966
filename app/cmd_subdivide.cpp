// `authalic subdivide IN OUT [--times N] [--faces-from FILE]`: midpoint (1-to-4) subdivision of a
// surface. The input's vertices stay first, in order, so per-vertex data and maps of the coarse
// mesh still index the fine one (benchmarks B3/S3 and the resolution-independence check use this).
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/command.h"
#include "core/error.h"
#include "core/mesh.h"
#include "io/surface_io.h"
#include "io/file_roles.h"

namespace authalic::app {
namespace {

struct SubdivideArgs {
  std::string in, out, faces_from;
  int times = 1;
};

void setup(CLI::App& parent) {
  auto a = std::make_shared<SubdivideArgs>();
  CLI::App* sub = parent.add_subcommand(
      "subdivide",
      "Midpoint (1-to-4) subdivision of a surface, N times (vertices x ~4^N). The input's vertices come first, in "
      "their order; new vertices are edge midpoints (mm, same space as the input).");
  sub->add_option("IN", a->in, "Input surface (GIFTI, FreeSurfer, VTK, PLY, OBJ, MNI .obj, STL)")->required();
  sub->add_option("OUT", a->out, "Output surface, format by extension: .surf.gii, .vtk, .vtp, .ply, .obj, .stl, else FreeSurfer binary (lh.white)")->required();
  sub->add_option("--times", a->times, "Number of subdivisions")->check(in_range(1, 6))->capture_default_str();
  sub->add_option("--faces-from", a->faces_from,
                  "Subdivide this face set's triangles (same vertices as IN, e.g. a cortex patch such as flat_left.gii.gz): OUT has "
                  "the vertices of `subdivide IN`, so the two pair for `flatten --faces-from`");
  add_common_options(*sub);
  sub->callback([a]() {
    io::check_file_roles({a->in, a->faces_from}, {a->out});
    io::check_surface_output_name(a->out);
    const io::Surface s = io::read_surface(a->in);
    if (s.mesh.num_faces() == 0) throw InputError(a->in + ": has no triangles to subdivide");
    TriMesh fine = subdivide_midpoint(s.mesh, a->times);
    if (!a->faces_from.empty()) {
      // The face set subdivided on the whole surface's fine vertex list, so that OUT pairs with
      // `subdivide IN` as flatten --faces-from expects.
      const io::Surface other = io::read_surface(a->faces_from);
      if (other.mesh.num_vertices() != s.mesh.num_vertices())
        throw InputError(a->faces_from + ": has " + std::to_string(other.mesh.num_vertices()) + " vertices but " + a->in +
                         " has " + std::to_string(s.mesh.num_vertices()) + "; --faces-from needs the same vertices");
      try {
        fine.F = subdivide_midpoint_region(s.mesh, other.mesh.F, a->times);
      } catch (const InputError& e) {
        throw InputError(a->faces_from + " on " + a->in + ": " + e.what());
      }
    }
    io::write_surface(a->out, fine, io::same_space_write_options(s, a->in));
    info("subdivide: " + a->out + ": " + std::to_string(fine.num_vertices()) + " vertices, " +
         std::to_string(fine.num_faces()) + " faces");
    if (global_options().json)
      std::cout << nlohmann::json{{"output", a->out}, {"vertices", fine.num_vertices()}, {"faces", fine.num_faces()}, {"times", a->times}}.dump(2)
                << '\n';
  });
}

const bool registered = register_command({95, setup});

}  // namespace
}  // namespace authalic::app

// Reference for bench/bench_flatten.sh only (not part of the product): CGAL 5.5's discrete
// authalic parameterisation (Desbrun et al.) with an arc-length square border, on a disk mesh.
//   cgal_authalic IN.off OUT.txt      (OUT: one "u v" line per vertex, in IN's order)
// Built by the benchmark when Debian's libcgal-dev is installed.
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_parameterization/Discrete_authalic_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/Square_border_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/parameterize.h>

#include <fstream>
#include <iostream>

using Kernel = CGAL::Simple_cartesian<double>;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
using Vertex = boost::graph_traits<Mesh>::vertex_descriptor;
using Halfedge = boost::graph_traits<Mesh>::halfedge_descriptor;
namespace SMP = CGAL::Surface_mesh_parameterization;

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: cgal_authalic IN.off OUT.txt\n";
    return 2;
  }
  Mesh mesh;
  std::ifstream in(argv[1]);
  if (!(in >> mesh)) {
    std::cerr << argv[1] << ": not a valid OFF mesh\n";
    return 2;
  }
  const Halfedge border = CGAL::Polygon_mesh_processing::longest_border(mesh).first;
  auto uv = mesh.add_property_map<Vertex, Kernel::Point_2>("v:uv").first;
  using Border = SMP::Square_border_arc_length_parameterizer_3<Mesh>;
  using Parameterizer = SMP::Discrete_authalic_parameterizer_3<Mesh, Border>;
  const SMP::Error_code err = SMP::parameterize(mesh, Parameterizer(), border, uv);
  if (err != SMP::OK) {
    std::cerr << "CGAL: " << SMP::get_error_message(err) << "\n";
    return 1;
  }
  std::ofstream out(argv[2]);
  out.precision(17);
  for (Vertex v : vertices(mesh)) out << uv[v].x() << ' ' << uv[v].y() << '\n';
  return 0;
}

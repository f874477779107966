// `authalic render OUT.png MAP [MAP ...]`: pictures of flat maps without a display, e.g. to look at
// a map from `authalic flatten --uv`, or to put an authalic map beside a conformal one.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <tuple>

#include "analysis/render.h"
#include "analysis/report.h"
#include "app/command.h"
#include "core/error.h"
#include "core/sulcal_depth.h"
#include "io/image_io.h"
#include "io/surface_io.h"
#include "io/file_roles.h"

namespace authalic::app {
namespace {

struct RenderArgs {
  std::string out;
  std::vector<std::string> maps;
  std::vector<std::string> captions;
  std::string values;
  std::string sulcal_depth_surface;
  std::string colormap = "gray_r";
  std::vector<double> range;
  std::string label;
  int grid = 0;
  std::string domain = "square";
  int width = 600;
  std::string title;
};

// The bounding box of the map's triangles' corners (x, y, z).
struct MapExtent {
  Eigen::Vector3d lo, hi;
};
MapExtent map_extent(const MatrixXd& V, const MatrixXi& F) {
  MapExtent e{Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()),
              Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity())};
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d p = V.row(F(f, k)).head<3>().transpose();
      e.lo = e.lo.cwiseMin(p);
      e.hi = e.hi.cwiseMax(p);
    }
  return e;
}

// A picture of a 3D surface, or of a map in mm drawn on the unit square, would be a blank or
// cropped image given as success: refuse both, saying which option draws the file.
void require_drawable(const MapExtent& e, const std::string& domain, double domain_width, const std::string& path) {
  auto span = [](double lo, double hi) { return "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]"; };
  const double xy = std::max(e.hi.x() - e.lo.x(), e.hi.y() - e.lo.y());
  if (e.hi.z() - e.lo.z() > 1e-3 * xy)
    throw InputError(path + ": not a flat map (z spans " + span(e.lo.z(), e.hi.z()) +
                     "); render draws flat maps, e.g. `authalic flatten --uv` or its mm-scaled flat surface (--domain fit)");
  if (domain == "fit") return;
  const double tolerance = 1e-3 * domain_width;
  if (e.lo.x() < -tolerance || e.lo.y() < -tolerance || e.hi.x() > domain_width + tolerance || e.hi.y() > 1.0 + tolerance)
    throw InputError(path + ": the map's x, y span " + span(e.lo.x(), e.hi.x()) + " x " + span(e.lo.y(), e.hi.y()) +
                     ", outside the " + domain + (domain == "square" ? " [0,1]^2" : " [0,2] x [0,1]") +
                     "; for a flat surface in mm or a FreeSurfer flat patch use --domain fit" +
                     (domain == "square" && e.hi.x() <= 2.0 + tolerance && e.lo.x() >= -tolerance ? ", for a 2:1 rectangle map --domain rectangle" : ""));
}

void setup(CLI::App& parent) {
  auto a = std::make_shared<RenderArgs>();
  CLI::App* sub = parent.add_subcommand(
      "render",
      "Draw one or more flat maps (surfaces whose x,y are the map, e.g. the --uv output of `authalic flatten`) side by "
      "side into a PNG, coloured by a per-vertex file, with the element grid. No display needed.");
  sub->add_option("OUT", a->out, "Output PNG")->required();
  sub->add_option("MAP", a->maps, "Flat map surface(s) (GIFTI, FreeSurfer, ...): x,y in the domain")->required();
  sub->add_option("--values", a->values, "Per-vertex values (GIFTI func/shape, FreeSurfer curv/sulc) for the colours");
  sub->add_option("--sulcal-depth", a->sulcal_depth_surface,
                  "Colour by a sulcal-depth proxy (mm) of this 3D surface (same vertices as the maps; extra map vertices, "
                  "e.g. inserted by the flattening, take their neighbours' colour)");
  sub->add_option("--colormap", a->colormap, "gray, viridis, coolwarm, hot (append _r to reverse)")->capture_default_str();
  sub->add_option("--range", a->range, "Colour range: LO HI (default: 2nd-98th percentile)")->expected(2);
  sub->add_option("--colorbar-label,--label", a->label, "Colour-bar label with units, e.g. 'sulc (mm)'");
  sub->add_option("--element-grid,--grid", a->grid, "Draw the K x K element grid (2K x K on the rectangle)")->check(in_range(0, 512));
  sub->add_option("--domain", a->domain, "square ([0,1]^2), rectangle ([0,2] x [0,1]) or fit (the map's bounding box, "
                                         "e.g. a flat surface in mm or a FreeSurfer flat patch)")
      ->check(CLI::IsMember({"square", "rectangle", "fit"}))
      ->capture_default_str();
  sub->add_option("--caption", a->captions, "Caption under each map (repeat, in order)");
  sub->add_option("--title", a->title, "Title over each map");
  sub->add_option("--width", a->width, "Width of each map picture (pixels)")->check(in_range(100, 4000))->capture_default_str();
  add_common_options(*sub);
  sub->callback([a]() {
    analysis::colormap(a->colormap, 0.0);  // an unknown name is an input error before any work
    std::vector<std::string> inputs = a->maps;
    inputs.push_back(a->values);
    inputs.push_back(a->sulcal_depth_surface);
    io::check_file_roles(inputs, {a->out});
    if (!a->values.empty() && !a->sulcal_depth_surface.empty()) {
      throw InputError("render: give --values or --sulcal-depth, not both");
    }
    if (a->range.size() == 2 && !(a->range[0] < a->range[1]))
      throw InputError("--range: LO must be below HI (got " + std::to_string(a->range[0]) + " " + std::to_string(a->range[1]) + ")");
    VectorXd depth;
    if (!a->sulcal_depth_surface.empty()) {
      const io::Surface s = io::read_surface(a->sulcal_depth_surface);
      depth = sulcal_depth_proxy(s.mesh.V, s.mesh.F);
    }
    std::vector<io::RgbImage> pictures;
    for (const auto& path : a->maps) {
      const io::Surface map = io::read_surface(path);
      if (map.mesh.num_faces() == 0) throw InputError(path + ": the map has no triangles; give a flat surface");
      analysis::ScalarColouring c;
      if (!a->values.empty() || depth.size() > 0) {
        if (depth.size() > 0) {
          if (depth.size() > map.mesh.num_vertices()) {
            throw InputError(a->sulcal_depth_surface + ": " + std::to_string(depth.size()) + " vertices but the map " + path +
                             " has " + std::to_string(map.mesh.num_vertices()) + "; give the map's own surface");
          }
          c.values = VectorXd::Constant(map.mesh.num_vertices(), std::nan(""));
          c.values.head(depth.size()) = depth;
          if (a->label.empty()) a->label = "sulcal depth (mm)";
        } else {
          c.values = io::read_per_vertex(a->values, map.mesh.num_vertices());
        }
        c.colormap = a->colormap;
        c.label = a->label;
        if (a->range.size() == 2) {
          c.vmin = a->range[0];
          c.vmax = a->range[1];
        } else {
          std::tie(c.vmin, c.vmax) = analysis::robust_range(c.values);
        }
      }
      analysis::FlatRenderOptions o;
      o.width = a->width;
      o.domain_width = a->domain == "rectangle" ? 2.0 : 1.0;
      const MapExtent e = map_extent(map.mesh.V, map.mesh.F);
      require_drawable(e, a->domain, o.domain_width, path);
      if (a->domain == "fit") {
        const Eigen::Vector2d lo = e.lo.head<2>(), hi = e.hi.head<2>();
        o.x0 = lo.x();
        o.y0 = lo.y();
        o.domain_width = std::max(hi.x() - lo.x(), 1e-9);
        o.domain_height = std::max(hi.y() - lo.y(), 1e-9);
      }
      o.grid_cols = a->domain == "rectangle" ? 2 * a->grid : a->grid;
      o.grid_rows = a->grid;
      o.title = a->title;
      o.draw_colour_bar = c.values.size() > 0;
      pictures.push_back(analysis::render_flat(map.mesh.V, map.mesh.F, c, o));
    }
    const io::RgbImage out = pictures.size() == 1 && a->captions.empty()
                                 ? pictures.front()
                                 : analysis::compose_horizontal(pictures, 16, a->captions);
    io::write_png(a->out, out);
    info("render: " + a->out + " (" + std::to_string(out.width) + " x " + std::to_string(out.height) + " pixels)");
    if (global_options().json)
      std::cout << nlohmann::json{{"output", a->out}, {"width_px", out.width}, {"height_px", out.height}, {"maps", pictures.size()}}.dump(2)
                << '\n';
  });
}

const bool registered = register_command({90, setup});

}  // namespace
}  // namespace authalic::app

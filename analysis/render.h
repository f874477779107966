#pragma once
// Pictures without a display: flat maps, sphere and 3D surface views are rasterised in software
// straight into an RgbImage (io::write_png writes it). No VTK rendering, no X server.
#include <array>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "io/image_io.h"

namespace authalic::analysis {

using Rgb = std::array<unsigned char, 3>;

// Colour maps: "gray" (sulcal shading), "viridis" (sequential, PET), "coolwarm" (diverging, z),
// "hot". t in [0,1].
Rgb colormap(const std::string& name, double t);

// Per-vertex scalar colouring with a range; values outside are clamped, NaN -> nan_colour.
struct ScalarColouring {
  VectorXd values;                // per vertex (#V), or empty for a plain light gray
  double vmin = 0.0, vmax = 1.0;  // colour range
  std::string colormap = "viridis";
  Rgb nan_colour{200, 200, 200};
  std::string label;              // colour-bar label with units, e.g. "SUVR" or "z"
};

struct FlatRenderOptions {
  int width = 800;                 // pixels; height follows the domain aspect
  double x0 = 0, y0 = 0, domain_width = 1, domain_height = 1;  // the domain drawn
  int grid_cols = 0, grid_rows = 0;  // element grid lines drawn when > 0
  bool draw_colour_bar = true;
  std::string title;
};
// Flat map UV (#V x >=2) coloured per vertex (Gouraud interpolation), element grid overlaid.
io::RgbImage render_flat(const MatrixXd& UV, const MatrixXi& F, const ScalarColouring& colouring,
                         const FlatRenderOptions& options);

// Element image (rows x cols values, row 0 = bottom of the domain), cells as flat colour blocks,
// NaN cells drawn as nan_colour, with a colour bar and title.
io::RgbImage render_element_grid(const std::vector<double>& values, int rows, int cols, const ScalarColouring& colouring,
                                 int cell_pixels, const std::string& title);

enum class View { Lateral, Medial, Superior, Inferior, Anterior, Posterior };
struct SurfaceRenderOptions {
  int width = 500, height = 400;
  bool left_hemisphere = true;     // decides which side "lateral" looks from (RAS: left = -x)
  std::string title;
  bool draw_colour_bar = true;
};
// A 3D surface (RAS mm) seen from one or more standard views, side by side, z-buffered with
// Lambert shading; per-vertex colours from `colouring`. Optional per-vertex integer labels draw
// the element-grid boundaries (edges between different labels) in black.
io::RgbImage render_surface_views(const MatrixXd& V, const MatrixXi& F, const ScalarColouring& colouring,
                                  const std::vector<View>& views, const SurfaceRenderOptions& options,
                                  const VectorXi* boundary_labels = nullptr);

// Histogram(s) as a PNG: one panel per series, e.g. the distortion metrics Υ and Λ.
io::RgbImage render_histograms(const std::vector<std::vector<double>>& series, const std::vector<std::string>& titles,
                               int bins, int width, int height);

}  // namespace authalic::analysis

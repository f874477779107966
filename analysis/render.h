#pragma once
// Pictures without a display, as io::RgbImage (io::write_png writes them). Text, frames, grids,
// colour bars, histograms and layout are drawn with Cairo (analysis/canvas.h); the data layers
// (a scalar interpolated across each triangle, then mapped through the colour map) and the 3D
// views are scan-converted here (analysis/render_surface.cpp says why the 3D part is ours). The
// drawing order is fixed, so the same input gives the same bytes.
#include <array>
#include <string>
#include <vector>

#include "analysis/canvas.h"
#include "core/mesh.h"
#include "io/image_io.h"

namespace authalic::analysis {

// Colour maps from their published control points, linear in between: "gray" (sulcal shading),
// "viridis" (sequential, PET; van der Walt & Smith's matplotlib table, 17 of its 256 entries),
// "coolwarm" (diverging, z; Moreland 2009, his 33-point table), "hot" (matplotlib/MATLAB
// segments). A "_r" suffix reverses. t in [0,1] (clamped). Unknown name -> InputError.
Rgb colormap(const std::string& name, double t);

// Per-vertex scalar colouring with a range; values outside are clamped, NaN -> nan_colour.
struct ScalarColouring {
  VectorXd values;                // per vertex (#V), or empty for a plain light gray
  double vmin = 0.0, vmax = 1.0;  // colour range
  std::string colormap = "viridis";
  Rgb nan_colour{200, 200, 200};
  std::string label;              // colour-bar label with units, e.g. "SUVR" or "z"
  // Thresholded display (3D-SSP): values with |value| < threshold are not coloured; 0 = off.
  double threshold = 0.0;
  // Per vertex gray level in [0,1] shown where a value is not coloured (NaN or under the
  // threshold): sulcal shading. Empty: nan_colour.
  VectorXd background;
  // Per vertex (#V, or empty): the vertex should have a value but has none (no PET there, or no z:
  // too few controls): drawn in no_value_colour, so that it is not read as "within normal limits".
  std::vector<char> no_value;
  Rgb no_value_colour{220, 0, 220};  // magenta: in neither coolwarm nor viridis
};

struct FlatRenderOptions {
  int width = 800;                 // pixels; height follows the domain aspect
  double x0 = 0, y0 = 0, domain_width = 1, domain_height = 1;  // the domain drawn
  int grid_cols = 0, grid_rows = 0;  // element grid lines drawn when > 0
  bool draw_colour_bar = true;
  std::string title;
  double font_size = 13.0;         // labels, px (the title is 16/13 of it)
};
// Where render_flat / render_element_grid put the domain: the pixel rectangle
// [left, left + plot_width) x [top, top + plot_height) of an image width x height. Domain x maps
// to column left + (x - x0) / domain_width * plot_width, domain y grows upwards; element-grid
// line c (0 < c < grid_cols) is the pixel column floor(left + c * plot_width / grid_cols).
struct FlatLayout {
  int width = 0, height = 0;
  int left = 0, top = 0, plot_width = 0, plot_height = 0;
};
FlatLayout flat_layout(const FlatRenderOptions& options, const ScalarColouring& colouring);

// The colour of one value under a colouring: clamped to [vmin, vmax], NaN -> nan_colour.
Rgb colour_of(const ScalarColouring& colouring, double value);

// Flat map UV (#V x >=2) coloured per vertex (Gouraud interpolation), element grid overlaid.
// The scalar is interpolated across each triangle and then mapped through the colour map (so a
// diverging map never shows colours between its ends that the data do not have); a triangle
// with a NaN vertex takes its nearest vertex's colour.
io::RgbImage render_flat(const MatrixXd& UV, const MatrixXi& F, const ScalarColouring& colouring,
                         const FlatRenderOptions& options);

// Element image (rows x cols values, row 0 = bottom of the domain), cells as flat colour blocks,
// NaN cells drawn as nan_colour, with a colour bar and title. Cell (r, c) covers the pixels
// [left + c*cell, +cell) x [top + (rows-1-r)*cell, +cell) of element_grid_layout(...).
FlatLayout element_grid_layout(int rows, int cols, const ScalarColouring& colouring, int cell_pixels,
                               const std::string& title);
io::RgbImage render_element_grid(const std::vector<double>& values, int rows, int cols, const ScalarColouring& colouring,
                                 int cell_pixels, const std::string& title);

enum class View { Lateral, Medial, Superior, Inferior, Anterior, Posterior };
// "lateral", "medial", ... (panel captions).
std::string view_name(View view);

// An orthographic camera in RAS: screen right, screen up, and the direction toward the viewer
// (depth grows toward the viewer). Lateral of a left hemisphere looks from -x (anterior on the
// screen's left); medial from +x; superior from +z with anterior up; anterior from +y.
struct ViewBasis {
  Eigen::Vector3d right, up, toward_viewer;
};
ViewBasis view_basis(View view, bool left_hemisphere);
struct SurfaceRenderOptions {
  int width = 500, height = 400;   // of each view panel; panels sit side by side
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
// width x height is the whole image; each panel gets width / #series. Non-finite values are
// left out and counted in the panel's caption (n, mean, median).
io::RgbImage render_histograms(const std::vector<std::vector<double>>& series, const std::vector<std::string>& titles,
                               int bins, int width, int height);

// The eight standard views of NEUROSTAT/3D-SSP (Minoshima et al. 1995) in one figure, laid out
// as 3D-SSP does: right lateral, left lateral, superior, inferior (top row); anterior,
// posterior, right medial, left medial (bottom row). Lateral and medial views show one
// hemisphere, the others both; one scale (mm per pixel) for all panels; one colour bar.
struct HemisphereSurface {
  MatrixXd V;          // RAS mm
  MatrixXi F;
  bool left = true;
  VectorXd values;     // per vertex, coloured through the figure's ScalarColouring
  VectorXd background; // per vertex gray level (sulcal shading), may be empty
  std::vector<char> no_value;  // per vertex, may be empty: ScalarColouring::no_value
};
struct StandardViewsOptions {
  int panel_width = 280, panel_height = 220;
  std::string title;
  double font_size = 13.0;  // captions and colour-bar labels, px (the title is 16/13 of it)
};
// colouring: range, map, threshold and label (its values/background are ignored: each
// hemisphere brings its own).
io::RgbImage render_standard_views(const std::vector<HemisphereSurface>& hemispheres, const ScalarColouring& colouring,
                                   const StandardViewsOptions& options);

// Per vertex sulcal shading for HemisphereSurface::background: the depth of each vertex below
// (dark) or above (light) a heavily smoothed copy of the surface along its normal, the idea of
// FreeSurfer's "sulc", mapped to gray levels in [0.45, 0.8] over its 2nd-98th percentiles.
VectorXd sulcal_shading(const MatrixXd& V, const MatrixXi& F);

// Images side by side (top-aligned) with `gap` pixels between them, and an optional caption
// under each (empty = none); the background fills the rest.
io::RgbImage compose_horizontal(const std::vector<io::RgbImage>& images, int gap, const std::vector<std::string>& captions = {},
                                Rgb background = {255, 255, 255});

}  // namespace authalic::analysis

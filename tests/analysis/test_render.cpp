// Software renderer: colour maps against their published values, pixel-exact flat maps and
// element images, z-buffer visibility, camera conventions, label boundaries, histograms, text.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "analysis/render.h"
#include "common/test_data.h"
#include "core/error.h"

namespace {

using authalic::MatrixXd;
using authalic::MatrixXi;
using authalic::VectorXd;
using authalic::VectorXi;
using authalic::analysis::Rgb;
using authalic::io::RgbImage;
namespace an = authalic::analysis;

Rgb pixel(const RgbImage& img, int x, int y) {
  const auto* p = img.pixel(x, y);
  return {p[0], p[1], p[2]};
}

void expect_near_rgb(const Rgb& got, const Rgb& want, int tol) {
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], tol) << "channel " << c;
}

long count_colour(const RgbImage& img, const Rgb& colour, int x0 = 0, int y0 = 0, int x1 = -1, int y1 = -1) {
  if (x1 < 0) x1 = img.width;
  if (y1 < 0) y1 = img.height;
  long n = 0;
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) n += pixel(img, x, y) == colour;
  }
  return n;
}

TEST(Colormap, EndpointsMatchPublishedValues) {
  // matplotlib viridis: #440154 ... #21918c (middle) ... #fde725.
  EXPECT_EQ(an::colormap("viridis", 0.0), (Rgb{68, 1, 84}));
  EXPECT_EQ(an::colormap("viridis", 1.0), (Rgb{253, 231, 37}));
  expect_near_rgb(an::colormap("viridis", 0.5), Rgb{33, 145, 140}, 1);
  // Moreland cool-warm: (59,76,192), (221,221,221), (180,4,38).
  EXPECT_EQ(an::colormap("coolwarm", 0.0), (Rgb{59, 76, 192}));
  EXPECT_EQ(an::colormap("coolwarm", 0.5), (Rgb{221, 221, 221}));
  EXPECT_EQ(an::colormap("coolwarm", 1.0), (Rgb{180, 4, 38}));
  // hot: dark red (0.0416) to white; pure red at t = 0.365079.
  EXPECT_EQ(an::colormap("hot", 0.0), (Rgb{11, 0, 0}));
  EXPECT_EQ(an::colormap("hot", 0.365079), (Rgb{255, 0, 0}));
  EXPECT_EQ(an::colormap("hot", 1.0), (Rgb{255, 255, 255}));
  EXPECT_EQ(an::colormap("gray", 0.5), (Rgb{128, 128, 128}));
  EXPECT_EQ(an::colormap("gray", 0.0), (Rgb{0, 0, 0}));
}

TEST(Colormap, ClampsReversesAndRejectsUnknownNames) {
  EXPECT_EQ(an::colormap("viridis", -3.0), an::colormap("viridis", 0.0));
  EXPECT_EQ(an::colormap("viridis", 7.0), an::colormap("viridis", 1.0));
  EXPECT_EQ(an::colormap("coolwarm_r", 0.0), an::colormap("coolwarm", 1.0));
  EXPECT_THROW(an::colormap("jet", 0.5), authalic::InputError);
  an::ScalarColouring c;
  c.vmin = -2;
  c.vmax = 2;
  c.colormap = "coolwarm";
  EXPECT_EQ(an::colour_of(c, 0.0), (Rgb{221, 221, 221}));
  EXPECT_EQ(an::colour_of(c, -100.0), (Rgb{59, 76, 192}));
  EXPECT_EQ(an::colour_of(c, std::nan("")), c.nan_colour);
}

TEST(Colormap, ViridisIsMonotoneInLightness) {
  // Perceptually ordered: the luma of viridis rises along the map.
  double previous = -1;
  for (int i = 0; i <= 20; ++i) {
    const Rgb c = an::colormap("viridis", i / 20.0);
    const double luma = 0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2];
    EXPECT_GT(luma, previous) << "t=" << i / 20.0;
    previous = luma;
  }
}

// Unit square as two triangles with their own vertices: lower-right = 0, upper-left = 1.
void two_triangle_square(MatrixXd* V, MatrixXi* F, VectorXd* values) {
  V->resize(6, 2);
  *V << 0, 0, 1, 0, 1, 1,  // lower-right triangle
      0, 0, 1, 1, 0, 1;    // upper-left triangle
  F->resize(2, 3);
  *F << 0, 1, 2, 3, 4, 5;
  values->resize(6);
  *values << 0, 0, 0, 1, 1, 1;
}

TEST(RenderFlat, TwoTrianglesHaveTheirColoursAtKnownPixels) {
  MatrixXd V;
  MatrixXi F;
  an::ScalarColouring c;
  two_triangle_square(&V, &F, &c.values);
  c.colormap = "gray";
  an::FlatRenderOptions o;
  o.width = 400;
  o.title = "two triangles";
  const RgbImage img = an::render_flat(V, F, c, o);
  const an::FlatLayout L = an::flat_layout(o, c);
  ASSERT_EQ(img.width, L.width);
  ASSERT_EQ(img.height, L.height);
  EXPECT_EQ(L.plot_width, L.plot_height);  // square domain, square plot
  const int px = L.left, py = L.top, w = L.plot_width, h = L.plot_height;
  // Bottom-right region is value 0 (black), top-left is value 1 (white), y grows upwards.
  EXPECT_EQ(pixel(img, px + w * 9 / 10, py + h * 9 / 10), (Rgb{0, 0, 0}));
  EXPECT_EQ(pixel(img, px + w / 10, py + h / 10), (Rgb{255, 255, 255}));
  EXPECT_EQ(pixel(img, px + w * 3 / 4, py + h / 2 + h / 8), (Rgb{0, 0, 0}));
  EXPECT_EQ(pixel(img, px + w / 4, py + h / 2 - h / 8), (Rgb{255, 255, 255}));
  // The frame is drawn just outside the plot, the margin is background.
  EXPECT_EQ(pixel(img, px - 1, py + h / 2), (Rgb{0, 0, 0}));
  EXPECT_EQ(pixel(img, px + w / 2, py + h), (Rgb{0, 0, 0}));
  EXPECT_EQ(pixel(img, 1, img.height - 2), (Rgb{255, 255, 255}));
  // Every plot pixel is covered by one of the two triangles: no holes along the diagonal.
  EXPECT_EQ(count_colour(img, {0, 0, 0}, px, py, px + w, py + h) + count_colour(img, {255, 255, 255}, px, py, px + w, py + h),
            static_cast<long>(w) * h);
}

TEST(RenderFlat, InterpolatesValuesAcrossATriangle) {
  // Value = u on the square: the middle column has the middle gray.
  MatrixXd V(4, 2);
  V << 0, 0, 1, 0, 1, 1, 0, 1;
  MatrixXi F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  an::ScalarColouring c;
  c.values.resize(4);
  c.values << 0, 1, 1, 0;
  c.colormap = "gray";
  an::FlatRenderOptions o;
  o.width = 300;
  o.draw_colour_bar = false;
  const RgbImage img = an::render_flat(V, F, c, o);
  const an::FlatLayout L = an::flat_layout(o, c);
  for (int i : {0, L.plot_width / 4, L.plot_width / 2, L.plot_width - 1}) {
    const double u = (i + 0.5) / L.plot_width;
    const Rgb got = pixel(img, L.left + i, L.top + L.plot_height / 3);
    EXPECT_NEAR(got[0], 255.0 * u, 1.0) << "column " << i;
  }
}

TEST(RenderFlat, ElementGridLinesAtTheExpectedColumnsAndRows) {
  MatrixXd V(4, 2);
  V << 0, 0, 1, 0, 1, 1, 0, 1;
  MatrixXi F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  an::ScalarColouring c;
  c.values = VectorXd::Constant(4, 0.5);
  c.colormap = "gray";
  an::FlatRenderOptions o;
  o.width = 500;
  o.grid_cols = 4;
  o.grid_rows = 4;
  const RgbImage img = an::render_flat(V, F, c, o);
  const an::FlatLayout L = an::flat_layout(o, c);
  const int y = L.top + L.plot_height / 8;  // inside the top row of cells
  std::vector<int> line_columns;
  for (int x = L.left; x < L.left + L.plot_width; ++x) {
    if (pixel(img, x, y)[0] < 100) line_columns.push_back(x);  // lines are much darker than the 128 gray
  }
  ASSERT_EQ(line_columns.size(), 3u);
  for (int k = 1; k <= 3; ++k) {
    EXPECT_EQ(line_columns[k - 1], L.left + static_cast<int>(std::floor(k * L.plot_width / 4.0)));
  }
  std::vector<int> line_rows;
  const int x = L.left + L.plot_width / 8;
  for (int yy = L.top; yy < L.top + L.plot_height; ++yy) {
    if (pixel(img, x, yy)[0] < 100) line_rows.push_back(yy);
  }
  EXPECT_EQ(line_rows.size(), 3u);
  // Between lines the surface colour is untouched.
  EXPECT_NEAR(pixel(img, line_columns[0] + 2, y)[0], 128, 1);
}

TEST(RenderFlat, NanVerticesAndPlainSurface) {
  MatrixXd V;
  MatrixXi F;
  an::ScalarColouring c;
  two_triangle_square(&V, &F, &c.values);
  c.values(3) = c.values(4) = c.values(5) = std::nan("");
  c.nan_colour = {1, 2, 3};
  an::FlatRenderOptions o;
  o.width = 300;
  const RgbImage img = an::render_flat(V, F, c, o);
  const an::FlatLayout L = an::flat_layout(o, c);
  EXPECT_EQ(pixel(img, L.left + L.plot_width / 10, L.top + L.plot_height / 10), (Rgb{1, 2, 3}));
  // No values: light gray, no colour bar, so the plot takes more of the width.
  an::ScalarColouring plain;
  const RgbImage img2 = an::render_flat(V, F, plain, o);
  const an::FlatLayout L2 = an::flat_layout(o, plain);
  EXPECT_GT(L2.plot_width, L.plot_width);
  EXPECT_EQ(pixel(img2, L2.left + L2.plot_width / 2, L2.top + L2.plot_height / 3), (Rgb{210, 210, 210}));
}

TEST(RenderFlat, RectangleDomainKeepsAspectAndRejectsBadInput) {
  MatrixXd V(4, 2);
  V << 0, 0, 2, 0, 2, 1, 0, 1;
  MatrixXi F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  an::ScalarColouring c;
  an::FlatRenderOptions o;
  o.width = 600;
  o.domain_width = 2;
  const an::FlatLayout L = an::flat_layout(o, c);
  EXPECT_NEAR(L.plot_width, 2 * L.plot_height, 1);
  MatrixXi bad(1, 3);
  bad << 0, 1, 9;
  EXPECT_THROW(an::render_flat(V, bad, c, o), std::invalid_argument);
  c.values = VectorXd::Zero(3);
  EXPECT_THROW(an::render_flat(V, F, c, o), std::invalid_argument);
}

TEST(RenderElementGrid, CellsRowZeroAtTheBottomAndNan) {
  const int rows = 2, cols = 3;
  std::vector<double> values = {0, 1, 2, 3, 4, std::nan("")};  // row 0 = {0,1,2}, row 1 = {3,4,NaN}
  an::ScalarColouring c;
  c.colormap = "viridis";
  c.vmin = 0;
  c.vmax = 4;
  c.nan_colour = {9, 9, 9};
  c.label = "SUVR";
  const int cell = 12;
  const RgbImage img = an::render_element_grid(values, rows, cols, c, cell, "elements");
  const an::FlatLayout L = an::element_grid_layout(rows, cols, c, cell, "elements");
  ASSERT_EQ(img.width, L.width);
  ASSERT_EQ(img.height, L.height);
  for (int r = 0; r < rows; ++r) {
    for (int col = 0; col < cols; ++col) {
      const int x = L.left + col * cell + cell / 2, y = L.top + (rows - 1 - r) * cell + cell / 2;
      EXPECT_EQ(pixel(img, x, y), an::colour_of(c, values[r * cols + col])) << r << "," << col;
    }
  }
  EXPECT_THROW(an::render_element_grid(values, 3, 3, c, cell, ""), std::invalid_argument);
}

TEST(RenderElementGrid, ColourBarShowsTheRangeEnds) {
  std::vector<double> values(16, 0.0);
  an::ScalarColouring c;
  c.colormap = "coolwarm";
  c.vmin = -3;
  c.vmax = 3;
  c.label = "z";
  const RgbImage img = an::render_element_grid(values, 4, 4, c, 20, "z");
  // Both ends of the diverging map appear (in the bar) although the data are all 0.
  EXPECT_GT(count_colour(img, an::colormap("coolwarm", 0.0)), 0);
  EXPECT_GT(count_colour(img, an::colormap("coolwarm", 1.0)), 0);
}

// Two parallel triangles facing x: `near_x` in front of `far_x` for a camera at -x.
void stacked_triangles(bool far_first, MatrixXd* V, MatrixXi* F, VectorXd* values) {
  V->resize(6, 3);
  // Big triangle at x = -10 (value 0); small one at x = 0 (value 1), hidden behind it from -x.
  *V << -10, -50, -50, -10, 50, -50, -10, 0, 50,  //
      0, -10, -10, 0, 10, -10, 0, 0, 10;
  F->resize(2, 3);
  if (far_first) {
    *F << 3, 4, 5, 0, 1, 2;
  } else {
    *F << 0, 1, 2, 3, 4, 5;
  }
  values->resize(6);
  *values << 0, 0, 0, 1, 1, 1;
}

TEST(RenderSurfaceViews, NearerTriangleWinsWhateverTheDrawingOrder) {
  an::SurfaceRenderOptions o;
  o.width = 200;
  o.height = 200;
  o.draw_colour_bar = false;
  o.left_hemisphere = true;
  const Rgb near_colour = an::colormap("viridis", 0.0), far_colour = an::colormap("viridis", 1.0);
  for (bool far_first : {false, true}) {
    MatrixXd V;
    MatrixXi F;
    an::ScalarColouring c;
    stacked_triangles(far_first, &V, &F, &c.values);
    // Lateral of a left hemisphere looks from -x: the x = -10 triangle is in front.
    const RgbImage lateral = an::render_surface_views(V, F, c, {an::View::Lateral}, o);
    EXPECT_GT(count_colour(lateral, near_colour), 1000);
    EXPECT_EQ(count_colour(lateral, far_colour), 0) << "far_first=" << far_first;
    // Medial looks from +x: now the small triangle is in front and visible.
    const RgbImage medial = an::render_surface_views(V, F, c, {an::View::Medial}, o);
    EXPECT_GT(count_colour(medial, far_colour), 100) << "far_first=" << far_first;
  }
}

TEST(RenderSurfaceViews, CameraConventionsInRas) {
  const auto lat_l = an::view_basis(an::View::Lateral, true);
  EXPECT_EQ(lat_l.toward_viewer, Eigen::Vector3d(-1, 0, 0));  // camera on the left (-x)
  EXPECT_EQ(lat_l.right, Eigen::Vector3d(0, -1, 0));          // anterior on the screen's left
  EXPECT_EQ(lat_l.up, Eigen::Vector3d(0, 0, 1));
  const auto lat_r = an::view_basis(an::View::Lateral, false);
  EXPECT_EQ(lat_r.toward_viewer, Eigen::Vector3d(1, 0, 0));
  EXPECT_EQ(an::view_basis(an::View::Medial, true).toward_viewer, Eigen::Vector3d(1, 0, 0));
  const auto sup = an::view_basis(an::View::Superior, true);
  EXPECT_EQ(sup.toward_viewer, Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(sup.up, Eigen::Vector3d(0, 1, 0));  // anterior at the top
  EXPECT_EQ(sup.right, Eigen::Vector3d(1, 0, 0));
  for (auto v : {an::View::Lateral, an::View::Medial, an::View::Superior, an::View::Inferior, an::View::Anterior,
                 an::View::Posterior}) {
    const auto b = an::view_basis(v, true);
    EXPECT_NEAR(b.right.cross(b.up).dot(b.toward_viewer), 1.0, 1e-12) << an::view_name(v);  // right-handed
  }
}

// A planar grid in the plane x = 0, y and z in [-50, 50], n x n vertices.
void plane_grid(int n, MatrixXd* V, MatrixXi* F) {
  V->resize(n * n, 3);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) V->row(j * n + i) << 0.0, -50.0 + 100.0 * i / (n - 1), -50.0 + 100.0 * j / (n - 1);
  }
  F->resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      F->row(f++) << a, b, d;
      F->row(f++) << a, d, c;
    }
  }
}

TEST(RenderSurfaceViews, LateralViewOfALeftHemisphereShowsAnteriorOnTheLeft) {
  MatrixXd V;
  MatrixXi F;
  plane_grid(11, &V, &F);
  an::ScalarColouring c;
  c.colormap = "gray";
  c.values = (V.col(1).array() > 0).cast<double>();  // anterior half white, posterior black
  an::SurfaceRenderOptions o;
  o.width = 200;
  o.height = 200;
  o.draw_colour_bar = false;
  const RgbImage img = an::render_surface_views(V, F, c, {an::View::Lateral}, o);
  // Brightness of the left and right quarters of the panel at mid height.
  const int y = img.height / 2;
  const Rgb left = pixel(img, 200 / 4, y), right = pixel(img, 3 * 200 / 4, y);
  EXPECT_EQ(left, (Rgb{255, 255, 255}));
  EXPECT_EQ(right, (Rgb{0, 0, 0}));
}

TEST(RenderSurfaceViews, LabelBoundariesAreDrawnInBlack) {
  MatrixXd V;
  MatrixXi F;
  plane_grid(21, &V, &F);
  an::ScalarColouring c;  // plain gray surface
  an::SurfaceRenderOptions o;
  o.width = 300;
  o.height = 300;
  VectorXi labels = (V.col(2).array() > 0).cast<int>();  // superior half vs inferior half
  const RgbImage without = an::render_surface_views(V, F, c, {an::View::Lateral}, o);
  const RgbImage with = an::render_surface_views(V, F, c, {an::View::Lateral}, o, &labels);
  const long black_without = count_colour(without, {0, 0, 0}, 0, 20, 300, 300);
  const long black_with = count_colour(with, {0, 0, 0}, 0, 20, 300, 300);
  // A horizontal line across the plane (about 280 px wide).
  EXPECT_GT(black_with - black_without, 200);
  VectorXi wrong(3);
  EXPECT_THROW(an::render_surface_views(V, F, c, {an::View::Lateral}, o, &wrong), std::invalid_argument);
}

TEST(RenderSurfaceViews, PanelsSideBySideAndDeterministic) {
  MatrixXd V;
  MatrixXi F;
  plane_grid(6, &V, &F);
  an::ScalarColouring c;
  c.values = V.col(1);
  c.vmin = -50;
  c.vmax = 50;
  an::SurfaceRenderOptions o;
  o.width = 150;
  o.height = 120;
  o.title = "views";
  const auto views = std::vector<an::View>{an::View::Lateral, an::View::Medial, an::View::Superior};
  const RgbImage a = an::render_surface_views(V, F, c, views, o);
  const RgbImage b = an::render_surface_views(V, F, c, views, o);
  EXPECT_GE(a.width, 3 * 150);
  EXPECT_GT(a.height, 120);
  EXPECT_EQ(a.rgb, b.rgb);
}

// Two planar "hemispheres" 60 mm apart (left at x = -30, right at x = +30), values 0, grey 0.5.
void two_plane_hemispheres(an::HemisphereSurface* left, an::HemisphereSurface* right) {
  plane_grid(21, &left->V, &left->F);
  right->V = left->V;
  right->F = left->F;
  left->V.col(0).array() -= 30.0;
  right->V.col(0).array() += 30.0;
  right->left = false;
  left->values = right->values = VectorXd::Zero(left->V.rows());
  left->background = right->background = VectorXd::Constant(left->V.rows(), 0.5);
}

TEST(RenderStandardViews, EightPanelsThresholdedOverGreyAndOneScale) {
  // Only the left hemisphere has |z| above the threshold, on its anterior half.
  an::HemisphereSurface left, right;
  two_plane_hemispheres(&left, &right);
  left.values = (left.V.col(1).array() > 0).cast<double>() * -3.0;
  an::ScalarColouring c;
  c.colormap = "coolwarm";
  c.vmin = -5;
  c.vmax = 5;
  c.threshold = 2;
  c.label = "z";
  an::StandardViewsOptions o;
  const RgbImage img = an::render_standard_views({left, right}, c, o);
  EXPECT_GT(img.width, 4 * o.panel_width);
  EXPECT_GT(img.height, 2 * o.panel_height);
  auto coloured = [&](int x0, int x1, int y0, int y1) {
    long n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const Rgb p = pixel(img, x, y);
        n += p[2] > p[0] + 40;  // blue, not grey
      }
    return n;
  };
  const int W = o.panel_width, half = img.height / 2;
  EXPECT_EQ(coloured(0, W, 0, half), 0) << "right lateral shows only the right hemisphere (all below threshold)";
  EXPECT_GT(coloured(W, 2 * W, 0, half), 1000) << "left lateral shows the left hemisphere's abnormal half";
  // Grey below the threshold: r = g = b (sulcal shading), in the right lateral panel.
  EXPECT_EQ(pixel(img, W / 2, half / 2)[0], pixel(img, W / 2, half / 2)[2]);
  // The colour bar marks the threshold band in grey and the ends.
  EXPECT_THROW(an::render_standard_views({}, c, o), std::invalid_argument);
}

// Cortex without a value (no PET there, or no z) is drawn in its own colour: grey read as
// "within normal limits".
TEST(RenderStandardViews, CortexWithoutAValueIsMarkedNotShadedAsNormal) {
  an::HemisphereSurface left, right;
  two_plane_hemispheres(&left, &right);
  for (Eigen::Index v = 0; v < left.V.rows(); ++v)
    if (left.V(v, 1) > 0) left.values(v) = std::nan("");  // the anterior half has no value
  an::ScalarColouring c;
  c.colormap = "coolwarm";
  c.vmin = -5;
  c.vmax = 5;
  c.threshold = 2;
  an::StandardViewsOptions o;
  auto amber = [&](const RgbImage& img) {
    long n = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) n += pixel(img, x, y) == c.no_value_colour;
    return n;
  };
  EXPECT_EQ(amber(an::render_standard_views({left, right}, c, o)), 0) << "without the flags: grey, as before";
  left.no_value.assign(static_cast<std::size_t>(left.V.rows()), 0);
  for (Eigen::Index v = 0; v < left.V.rows(); ++v) left.no_value[static_cast<std::size_t>(v)] = std::isnan(left.values(v));
  EXPECT_GT(amber(an::render_standard_views({left, right}, c, o)), 1000);
}

TEST(RenderHistograms, BarHeightsFollowTheCounts) {
  std::vector<double> s(40, 0.0);
  for (int i = 10; i < 40; ++i) s[i] = 1.0;  // 10 zeros, 30 ones
  s.push_back(std::nan(""));
  const RgbImage img = an::render_histograms({s}, {"test"}, 2, 400, 300);
  EXPECT_EQ(img.width, 400);
  EXPECT_EQ(img.height, 300);
  const Rgb fill{70, 130, 180};
  // Tallest run of bar fill per column; two bars with heights 1:3.
  int left_height = 0, right_height = 0;
  for (int x = 0; x < img.width; ++x) {
    int h = 0;
    for (int y = 0; y < img.height; ++y) h += pixel(img, x, y) == fill;
    if (h == 0) continue;
    if (x < img.width / 2) {
      left_height = std::max(left_height, h);
    } else {
      right_height = std::max(right_height, h);
    }
  }
  ASSERT_GT(left_height, 0);
  EXPECT_NEAR(static_cast<double>(right_height) / left_height, 3.0, 0.1);
}

TEST(RenderHistograms, OnePanelPerSeries) {
  const RgbImage img = an::render_histograms({{1, 2, 3}, {}}, {"Υ", "Λ"}, 10, 800, 300);
  EXPECT_EQ(img.width, 800);
  const Rgb fill{70, 130, 180};
  EXPECT_GT(count_colour(img, fill, 0, 0, 400, 300), 0);
  EXPECT_EQ(count_colour(img, fill, 400, 0, 800, 300), 0);  // the empty series says "no data"
  EXPECT_THROW(an::render_histograms({}, {}, 10, 100, 100), std::invalid_argument);
}

TEST(Canvas, TextIsDrawnInARealFontAndMeasured) {
  // DejaVu Sans through Cairo: wider text measures wider, a 13 px line is about 15 px tall, and
  // the glyphs are anti-aliased (gray levels between ink and paper).
  EXPECT_GT(an::text_width("WWW", 13), an::text_width("iii", 13));
  EXPECT_NEAR(an::text_width("abc", 26), 2 * an::text_width("abc", 13), 1.0);
  EXPECT_GT(an::text_line_height(13), 13.0);
  EXPECT_LT(an::text_line_height(13), 18.0);
  an::Canvas cv(80, 30);
  an::TextStyle ts;
  ts.size = 20;
  cv.text(4, 2, "Hg", ts);
  const RgbImage img = cv.to_image();
  long ink = 0, grey = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const int v = pixel(img, x, y)[0];
      ink += v < 60;
      grey += v >= 60 && v < 200;
    }
  EXPECT_GT(ink, 40);
  EXPECT_GT(grey, 10);
  // Word wrap keeps every line within the width.
  for (const auto& line : an::wrap_text("Hypometabolism in left precuneus and posterior cingulate, peak z -4.9", 13, 150))
    EXPECT_LE(an::text_width(line, 13), 150.0) << line;
}

TEST(Canvas, NumbersForPeople) {
  EXPECT_EQ(an::format_fixed(61.8, 1), "61.8");
  EXPECT_EQ(an::format_fixed(-0.04, 1), "0.0");
  EXPECT_EQ(an::format_fixed(-4.94, 1, true), "\u22124.9");
  EXPECT_EQ(an::format_fixed(std::nan(""), 1), "n/a");
}

TEST(Raster, NiceTicks) {
  double step = 0;
  const auto t = an::nice_ticks(0, 1, 5, &step);
  ASSERT_EQ(t.size(), 6u);
  EXPECT_DOUBLE_EQ(step, 0.2);
  EXPECT_EQ(an::format_tick(t[2], step), "0.4");
  const auto z = an::nice_ticks(-3, 3, 5, &step);
  EXPECT_DOUBLE_EQ(step, 2.0);
  EXPECT_EQ(z, (std::vector<double>{-2, 0, 2}));
  EXPECT_EQ(an::format_tick(-2, step), "\u22122");  // a typeset minus
  EXPECT_EQ(an::format_tick(0.25, 0.25), "0.25");
  EXPECT_EQ(an::format_tick(1500, 500), "1500");
  // Constant values whose means differ in their last bits: one tick (it looped until memory ran
  // out: `authalic elements` on a constant map died with std::bad_alloc).
  EXPECT_EQ(an::nice_ticks(1.0, 1.0 + 2.2e-16, 5, &step), (std::vector<double>{1.0}));
  EXPECT_EQ(an::nice_ticks(-5.0, -5.0 * (1 + 1e-12), 5, &step).size(), 1u);
  EXPECT_EQ(an::nice_ticks(0.0, 1e-20, 5, &step).size(), 6u);  // tiny but real ranges keep their ticks
}

TEST(RenderPng, RoundTripsThroughWriteAndRead) {
  MatrixXd V;
  MatrixXi F;
  an::ScalarColouring c;
  two_triangle_square(&V, &F, &c.values);
  an::FlatRenderOptions o;
  o.width = 240;
  o.grid_cols = o.grid_rows = 4;
  o.title = "round trip";
  const RgbImage img = an::render_flat(V, F, c, o);
  const std::string path = authalic::test::temp_dir("render_png") + "/flat.png";
  authalic::io::write_png(path, img);
  const RgbImage back = authalic::io::read_png(path);
  EXPECT_EQ(back.width, img.width);
  EXPECT_EQ(back.height, img.height);
  EXPECT_EQ(back.rgb, img.rgb);
}

}  // namespace

// Maps a disk whose triangles differ in area (a planar grid stretched along x, so the areas span
// 1 : 3) onto the unit square with the installed core and checks the result: no flipped triangle
// and an element-area CV below 0.02 on a 4 x 4 grid (the conformal start alone is far from it);
// and the rectangle's seam rule for unequal hemispheres. Prints one line; exit 0 on success.
#include <authalic/core/domain.h>
#include <authalic/core/metrics.h>
#include <authalic/core/square_map.h>
#include <authalic/core/version.h>

#include <cstdio>

int main() {
  using namespace authalic;
  const int n = 16;
  MatrixXd V((n + 1) * (n + 1), 3);
  MatrixXi F(2 * n * n, 3);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double x = double(j) / n - 0.5, y = double(i) / n - 0.5;
      const double u = x + 0.5;
      V.row(i * (n + 1) + j) << 20 * (u + u * u), 40 * y, 0;
    }
  for (int i = 0, f = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = i * (n + 1) + j, b = a + 1, c = a + n + 1, d = c + 1;
      F.row(f++) << a, b, d;
      F.row(f++) << a, d, c;
    }
  SquareMapOptions options;
  options.flow.grid.resolution = 128;  // a 289-vertex patch: a coarse flow grid is enough, and quick
  options.anatomical_anchor = false;   // a grid has no frontal pole
  const SquareMapResult r = square_map(V, F, options);
  const MapMetrics m = map_metrics(r.V, r.UV, r.F, Domain::square(), 4);
  const Domain two_parts = Domain::rectangle(1.5);  // w_L = 1.5: column 5 of 8 (K = 4) is still left
  const bool seam_ok = two_parts.same_part(4, 0, 5) && !two_parts.same_part(4, 5, 6);
  std::printf("%s: %d faces, %d flips, element CV %.4f, seam rule %s\n", software_version().c_str(), m.faces, m.flips,
              m.element_cv, seam_ok ? "ok" : "WRONG");
  return m.flips == 0 && m.element_cv < 0.02 && seam_ok ? 0 : 1;
}

#pragma once
// Neumann Poisson problems on a regular cell-centred grid over a rectangle, solved exactly (for
// the 5-point stencil) by the discrete cosine transform.
//
// Why: the Lie-advection flow of Zou et al. 2011a, eq. 9-10 needs Δg = h_Ω − h_M with
// the Neumann condition ∂g/∂n = 0 (DLF eq. 3). Solved on the fixed rectangle instead
// of the degenerate flowing mesh (the moving mesh stalls on one thin triangle; measured), the DCT-II diagonalises
// the grid Laplacian with reflecting (Neumann) walls, so the solve is exact and O(n log n).
//
// Grid convention: a field on an nx by ny grid of cells of size hx by hy over [0, nx hx] x
// [0, ny hy] is an Eigen matrix with ny rows (y index, row 0 at y = 0) and nx columns (x index);
// cell (r, c) has its centre at ((c + 1/2) hx, (r + 1/2) hy).
//
// Discrete problem: with ghost cells mirroring the wall cells (g_{-1} = g_0, g_n = g_{n-1}),
//   (g_{r,c+1} − 2 g_{r,c} + g_{r,c−1}) / hx² + (g_{r+1,c} − 2 g_{r,c} + g_{r−1,c}) / hy² = f_{r,c}.
// Its eigenvectors are cos(π k (c + 1/2) / nx) cos(π l (r + 1/2) / ny) with eigenvalues
//   (2 cos(π k / nx) − 2) / hx² + (2 cos(π l / ny) − 2) / hy²,
// so g = IDCT(DCT(f) / eigenvalue), the constant mode (eigenvalue 0) set to zero: g has zero mean
// and the solve implicitly removes the mean of f (the compatibility condition of the Neumann problem).
#include <algorithm>
#include <vector>

#include "core/mesh.h"

namespace authalic {

// Unnormalised DCT-II of every column of X in place: X_k = sum_n x_n cos(π k (2n + 1) / (2N)),
// N = X.rows(). Power-of-two N uses an FFT (Makhoul 1980, O(N log N)); other N a cosine matrix.
// Columns are independent (OpenMP over columns, identical results for any thread count).
void dct2_columns(MatrixXd& X);
// Inverse of dct2_columns (a scaled DCT-III): x_n = (X_0 + 2 sum_{k>=1} X_k cos(π k (2n+1)/(2N))) / N.
void idct2_columns(MatrixXd& X);
// 2D transforms of a grid field (columns, then rows).
void dct2_2d(MatrixXd& X);
void idct2_2d(MatrixXd& X);

// A reusable solver for one grid size (precomputed eigenvalues).
class NeumannPoissonGrid {
 public:
  // nx by ny cells of size hx by hy (for the unit square at resolution n: n, n, 1/n, 1/n).
  NeumannPoissonGrid(int nx, int ny, double hx, double hy);

  int nx() const { return nx_; }
  int ny() const { return ny_; }
  double hx() const { return hx_; }
  double hy() const { return hy_; }

  // Solves Δ_h g = f − mean(f) (5-point stencil, Neumann walls); returns g with zero mean.
  // f: ny x nx.
  MatrixXd solve(const MatrixXd& f) const;

  // Gaussian smoothing with reflecting walls: multiplies the cosine coefficients by
  // exp(−σ² (ω_k² + ω_l²) / 2), ω_k = π k / (nx hx), i.e. convolution with a Gaussian of standard
  // deviation sigma (domain units) on the evenly extended field. Preserves the mean exactly.
  MatrixXd smooth(const MatrixXd& f, double sigma) const;

  // Both at once, sharing the forward transform: f_smooth = smooth(f, sigma) and
  // g solving Δ_h g = f_smooth − mean(f_smooth).
  void smooth_and_solve(const MatrixXd& f, double sigma, MatrixXd* f_smooth, MatrixXd* g) const;

 private:
  int nx_, ny_;
  double hx_, hy_;
  VectorXd eig_x_, eig_y_;  // (2 cos(π k / n) − 2) / h²
};

// Gradient of a cell-centred field on the staggered (MAC) grid that the 5-point Neumann
// Laplacian is the divergence of: gx (ny x (nx+1)) at the vertical cell faces x = c hx,
// gy ((ny+1) x nx) at the horizontal faces y = r hy. The wall values are exactly zero (Neumann),
// so a velocity interpolated from them has no normal component on the walls.
void staggered_gradient(const MatrixXd& g, double hx, double hy, MatrixXd* gx, MatrixXd* gy);

// Bilinear interpolation of a grid of samples at (x0 + c dx, y0 + r dy) (row r, column c of *m),
// clamped at the edges (constant extension beyond the outermost samples). For cell-centred fields
// x0 = dx / 2, y0 = dy / 2; for the staggered components of staggered_gradient x0 = 0 or y0 = 0.
struct GridBilinear {
  const MatrixXd* m;
  double x0, dx, y0, dy;
  double operator()(double x, double y) const {
    const int nc = static_cast<int>(m->cols()), nr = static_cast<int>(m->rows());
    int c0, r0;
    double tx, ty;
    locate((x - x0) / dx, nc, &c0, &tx);
    locate((y - y0) / dy, nr, &r0, &ty);
    const int c1 = std::min(c0 + 1, nc - 1), r1 = std::min(r0 + 1, nr - 1);
    const MatrixXd& a = *m;
    return (1 - ty) * ((1 - tx) * a(r0, c0) + tx * a(r0, c1)) + ty * ((1 - tx) * a(r1, c0) + tx * a(r1, c1));
  }
  static void locate(double f, int n, int* i0, double* t) {
    if (n == 1 || !(f > 0)) {
      *i0 = 0;
      *t = 0;
      return;
    }
    if (f >= n - 1) {
      *i0 = n - 2;
      *t = 1;
      return;
    }
    *i0 = static_cast<int>(f);
    *t = f - *i0;
  }
};

// One classical Runge-Kutta (RK4) step of the planar ODE d(x, y)/dt = vel(t, x, y) from t to
// t + dt; vel(t, x, y, &ux, &uy) writes the velocity. Used to follow the grid velocity fields of
// the flows (core/authalic_flow.h, core/optimal_transport.h).
template <class Velocity>
inline void rk4_step(const Velocity& vel, double t, double dt, double& x, double& y) {
  double k1x, k1y, k2x, k2y, k3x, k3y, k4x, k4y;
  vel(t, x, y, &k1x, &k1y);
  vel(t + 0.5 * dt, x + 0.5 * dt * k1x, y + 0.5 * dt * k1y, &k2x, &k2y);
  vel(t + 0.5 * dt, x + 0.5 * dt * k2x, y + 0.5 * dt * k2y, &k3x, &k3y);
  vel(t + dt, x + dt * k3x, y + dt * k3y, &k4x, &k4y);
  x += dt / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x);
  y += dt / 6.0 * (k1y + 2 * k2y + 2 * k3y + k4y);
}

}  // namespace authalic

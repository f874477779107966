// Incompressible demons on the flat rectangle (see flat_registration.h for the iteration).
#include "core/flat_registration.h"

#include <algorithm>
#include <cmath>

#include "core/conformal_map.h"
#include "core/error.h"
#include "core/poisson_dct.h"

namespace authalic {

namespace {

// A cell-centred grid over [0, width] x [0, 1] with square cells of side h.
struct Grid {
  int nx, ny;
  double h;
  NeumannPoissonGrid poisson;
  Grid(int cells_per_unit, double width)
      : nx(std::max(4, static_cast<int>(std::lround(width * cells_per_unit)))),
        ny(std::max(4, cells_per_unit)),
        h(1.0 / ny),
        poisson(nx, ny, h, h) {}
};

// Flat barycentric vertex areas (the weights: for an authalic map, each vertex's share of the cortex).
VectorXd flat_weights(const MatrixXd& UV, const MatrixXi& F) {
  MatrixXd P = MatrixXd::Zero(UV.rows(), 3);
  P.leftCols(2) = UV;
  return barycentric_vertex_areas(P, F);
}

// The feature standardised to weighted mean 0, SD 1 over the weighted vertices.
VectorXd standardise(const VectorXd& f, const VectorXd& w) {
  const double W = w.sum();
  if (!(W > 0)) throw ProcessingError("flat registration: the map has no area");
  const double mean = w.dot(f) / W;
  const double var = w.dot((f.array() - mean).square().matrix()) / W;
  if (!(var > 0)) throw ProcessingError("flat registration: the feature is constant; it cannot drive an alignment");
  return (f.array() - mean) / std::sqrt(var);
}

// Bilinear splat of values (per vertex, weighted by w) onto the cell centres; vertices with w = 0
// contribute nothing.
MatrixXd splat(const Grid& g, const MatrixXd& UV, const VectorXd& w, const VectorXd* values) {
  MatrixXd out = MatrixXd::Zero(g.ny, g.nx);
  for (Eigen::Index i = 0; i < UV.rows(); ++i) {
    if (!(w[i] > 0)) continue;
    const double m = w[i] * (values ? (*values)[i] : 1.0);
    int c0, r0;
    double tx, ty;
    GridBilinear::locate(UV(i, 0) / g.h - 0.5, g.nx, &c0, &tx);
    GridBilinear::locate(UV(i, 1) / g.h - 0.5, g.ny, &r0, &ty);
    const int c1 = std::min(c0 + 1, g.nx - 1), r1 = std::min(r0 + 1, g.ny - 1);
    out(r0, c0) += m * (1 - tx) * (1 - ty);
    out(r0, c1) += m * tx * (1 - ty);
    out(r1, c0) += m * (1 - tx) * ty;
    out(r1, c1) += m * tx * ty;
  }
  return out;
}

// A feature as an image at scale sigma by normalised convolution; *density: the smoothed weights
// (normalised to mean 1), the confidence of each cell.
MatrixXd feature_image(const Grid& g, const MatrixXd& UV, const VectorXd& w, const VectorXd& f, double sigma,
                       MatrixXd* density) {
  const MatrixXd num = g.poisson.smooth(splat(g, UV, w, &f), sigma);
  MatrixXd den = g.poisson.smooth(splat(g, UV, w, nullptr), sigma);
  const double floor = 1e-6 * den.maxCoeff();
  MatrixXd image = MatrixXd::Zero(g.ny, g.nx);
  for (int r = 0; r < g.ny; ++r)
    for (int c = 0; c < g.nx; ++c)
      if (den(r, c) > floor) image(r, c) = num(r, c) / den(r, c);
  if (density) *density = den / std::max(den.mean(), 1e-300);
  return image;
}

// Weighted mean squared difference of two images (weights: the subject's density).
double mismatch(const MatrixXd& S, const MatrixXd& A, const MatrixXd& density) {
  return (density.array() * (S - A).array().square()).sum() / std::max(density.sum(), 1e-300);
}

double correlation(const MatrixXd& S, const MatrixXd& A, const MatrixXd& density) {
  const double W = density.sum();
  const double ms = (density.array() * S.array()).sum() / W, ma = (density.array() * A.array()).sum() / W;
  const double cov = (density.array() * (S.array() - ms) * (A.array() - ma)).sum();
  const double vs = (density.array() * (S.array() - ms).square()).sum(), va = (density.array() * (A.array() - ma).square()).sum();
  return cov / std::sqrt(std::max(vs * va, 1e-300));
}

// Central differences (one-sided at the walls) of a cell-centred image.
void cell_gradient(const MatrixXd& I, double h, MatrixXd* gx, MatrixXd* gy) {
  const Eigen::Index ny = I.rows(), nx = I.cols();
  gx->resize(ny, nx);
  gy->resize(ny, nx);
  for (Eigen::Index c = 0; c < nx; ++c) {
    const Eigen::Index a = std::max<Eigen::Index>(c - 1, 0), b = std::min<Eigen::Index>(c + 1, nx - 1);
    gx->col(c) = (I.col(b) - I.col(a)) / ((b - a) * h);
  }
  for (Eigen::Index r = 0; r < ny; ++r) {
    const Eigen::Index a = std::max<Eigen::Index>(r - 1, 0), b = std::min<Eigen::Index>(r + 1, ny - 1);
    gy->row(r) = (I.row(b) - I.row(a)) / ((b - a) * h);
  }
}

// A divergence-free velocity with no flux through the walls, on the staggered grid:
// ux (ny x (nx+1)) at the vertical faces, uy ((ny+1) x nx) at the horizontal ones.
struct StaggeredVelocity {
  MatrixXd ux, uy;
};

// Step 4 of the header: the Leray projection of a cell-centred field (fx, fy).
StaggeredVelocity leray_projection(const Grid& g, const MatrixXd& fx, const MatrixXd& fy) {
  StaggeredVelocity v;
  v.ux.setZero(g.ny, g.nx + 1);
  v.uy.setZero(g.ny + 1, g.nx);
  for (int c = 1; c < g.nx; ++c) v.ux.col(c) = 0.5 * (fx.col(c - 1) + fx.col(c));
  for (int r = 1; r < g.ny; ++r) v.uy.row(r) = 0.5 * (fy.row(r - 1) + fy.row(r));
  MatrixXd div(g.ny, g.nx);
  for (int r = 0; r < g.ny; ++r)
    for (int c = 0; c < g.nx; ++c) div(r, c) = (v.ux(r, c + 1) - v.ux(r, c) + v.uy(r + 1, c) - v.uy(r, c)) / g.h;
  // The wall fluxes are 0, so div sums to 0 and Δφ = div is solvable exactly (Neumann).
  const MatrixXd phi = g.poisson.solve(div);
  MatrixXd gx, gy;
  staggered_gradient(phi, g.h, g.h, &gx, &gy);
  v.ux -= gx;
  v.uy -= gy;
  return v;
}

// The largest |∂u/∂x| of the staggered components (the strain that bounds a safe step).
double max_strain(const StaggeredVelocity& v, double h) {
  double s = 0;
  const Eigen::Index ny = v.ux.rows(), nx = v.uy.cols();
  for (Eigen::Index r = 0; r < ny; ++r)
    for (Eigen::Index c = 0; c < nx; ++c)
      s = std::max(s, std::abs(v.ux(r, c + 1) - v.ux(r, c)) / h);  // = |∂uy/∂y| too (divergence-free)
  for (Eigen::Index r = 0; r + 1 < ny; ++r)
    for (Eigen::Index c = 0; c <= nx; ++c) s = std::max(s, std::abs(v.ux(r + 1, c) - v.ux(r, c)) / h);
  for (Eigen::Index r = 0; r <= ny; ++r)
    for (Eigen::Index c = 0; c + 1 < nx; ++c) s = std::max(s, std::abs(v.uy(r, c + 1) - v.uy(r, c)) / h);
  return s;
}

// Moves the weighted vertices by one RK4 step of the (steady) velocity, kept in the rectangle.
MatrixXd advect(const Grid& g, const StaggeredVelocity& v, const MatrixXd& UV, const VectorXd& w, double dt, double width,
                double* largest) {
  const GridBilinear ux{&v.ux, 0.0, g.h, 0.5 * g.h, g.h}, uy{&v.uy, 0.5 * g.h, g.h, 0.0, g.h};
  auto vel = [&](double, double x, double y, double* vx, double* vy) {
    *vx = ux(x, y);
    *vy = uy(x, y);
  };
  MatrixXd out = UV;
  double moved = 0;
#pragma omp parallel for schedule(static) reduction(max : moved)
  for (Eigen::Index i = 0; i < UV.rows(); ++i) {
    if (!(w[i] > 0)) continue;
    double x = UV(i, 0), y = UV(i, 1);
    rk4_step(vel, 0.0, dt, x, y);
    x = std::clamp(x, 0.0, width);
    y = std::clamp(y, 0.0, 1.0);
    moved = std::max(moved, std::hypot(x - UV(i, 0), y - UV(i, 1)));
    out(i, 0) = x;
    out(i, 1) = y;
  }
  *largest = moved;
  return out;
}

// The largest vertex speed of a velocity (unit lengths per unit time).
double max_speed(const Grid& g, const StaggeredVelocity& v, const MatrixXd& UV, const VectorXd& w) {
  const GridBilinear ux{&v.ux, 0.0, g.h, 0.5 * g.h, g.h}, uy{&v.uy, 0.5 * g.h, g.h, 0.0, g.h};
  double s = 0;
  for (Eigen::Index i = 0; i < UV.rows(); ++i)
    if (w[i] > 0) s = std::max(s, std::hypot(ux(UV(i, 0), UV(i, 1)), uy(UV(i, 0), UV(i, 1))));
  return s;
}

// Step 2 of the header: the demons force on the cells.
void demons_force(const MatrixXd& S, const MatrixXd& A, const MatrixXd& density, double h, MatrixXd* fx, MatrixXd* fy) {
  MatrixXd gx, gy;
  cell_gradient(0.5 * (S + A), h, &gx, &gy);
  const Eigen::ArrayXXd diff = (S - A).array();
  const Eigen::ArrayXXd den = gx.array().square() + gy.array().square() + diff.square() / (h * h);
  const Eigen::ArrayXXd scale = (den > 1e-300).select(diff * density.array().min(1.0) / den, 0.0);
  *fx = (scale * gx.array()).matrix();
  *fy = (scale * gy.array()).matrix();
}

}  // namespace

MatrixXd register_flat_map(const MatrixXd& UV, const MatrixXi& F, const VectorXd& feature, const MatrixXd& atlas_UV,
                           const MatrixXi& atlas_F, const VectorXd& atlas_feature, double width,
                           const FlatRegistrationOptions& options, FlatRegistrationReport* report) {
  if (UV.cols() != 2 || feature.size() != UV.rows() || atlas_UV.cols() != 2 || atlas_feature.size() != atlas_UV.rows())
    throw ProcessingError("flat registration: a map and its feature differ in size");
  if (options.sigmas.empty() || options.grid < 8) throw ProcessingError("flat registration: needs a grid of >= 8 cells and a scale");
  const Grid g(options.grid, width);
  const VectorXd w = flat_weights(UV, F), aw = flat_weights(atlas_UV, atlas_F);
  const VectorXd f = standardise(feature, w), af = standardise(atlas_feature, aw);

  FlatRegistrationReport rep;
  MatrixXd X = UV;
  const int folded = count_flipped(UV, F);  // the input's (0 for an authalic map)
  auto finest_correlation = [&](const MatrixXd& P) {
    const double sigma = options.sigmas.back();
    MatrixXd dens;
    const MatrixXd S = feature_image(g, P, w, f, sigma, &dens);
    return correlation(S, feature_image(g, atlas_UV, aw, af, sigma, nullptr), dens);
  };
  rep.correlation_before = finest_correlation(X);

  for (const double sigma : options.sigmas) {
    const MatrixXd A = feature_image(g, atlas_UV, aw, af, sigma, nullptr);
    MatrixXd dens;
    MatrixXd S = feature_image(g, X, w, f, sigma, &dens);
    double E = mismatch(S, A, dens);
    int slow = 0;
    for (int it = 0; it < options.iterations && slow < 5; ++it) {
      MatrixXd fx, fy;
      demons_force(S, A, dens, g.h, &fx, &fy);
      const double fluid = options.fluid * sigma;
      const StaggeredVelocity v = leray_projection(g, g.poisson.smooth(fx, fluid), g.poisson.smooth(fy, fluid));
      const double speed = max_speed(g, v, X, w), strain = max_strain(v, g.h);
      if (!(speed > 0)) break;
      double dt = std::min({1.0, options.max_move * g.h / speed, options.max_strain / std::max(strain, 1e-300)});
      // A step may not fold a triangle (a smooth divergence-free flow does not, but the mesh's
      // straight edges see it only at their ends): halve it until it folds nothing.
      double moved = 0;
      MatrixXd Xn;
      for (int halving = 0; halving < 6; ++halving, dt *= 0.5) {
        Xn = advect(g, v, X, w, dt, width, &moved);
        if (count_flipped(Xn, F) <= folded) break;
        Xn.resize(0, 2);
      }
      if (Xn.rows() == 0) break;
      MatrixXd dn;
      MatrixXd Sn = feature_image(g, Xn, w, f, sigma, &dn);
      const double En = mismatch(Sn, A, dn);
      if (!(En < E)) break;  // the step no longer helps at this scale
      slow = (En > E * (1 - 1e-3)) ? slow + 1 : 0;
      X = std::move(Xn);
      S = std::move(Sn);
      dens = std::move(dn);
      E = En;
      ++rep.iterations;
    }
  }
  rep.correlation_after = finest_correlation(X);
  for (Eigen::Index i = 0; i < X.rows(); ++i) rep.max_move = std::max(rep.max_move, (X.row(i) - UV.row(i)).norm());
  if (report) *report = rep;
  return X;
}

}  // namespace authalic

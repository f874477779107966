// DCT-II/III by a radix-2 FFT (Makhoul 1980) or a cosine matrix, and the Neumann Poisson grid
// solver built on them (see poisson_dct.h for the discrete problem and its eigenvalues).
#include "core/poisson_dct.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>

namespace authalic {

namespace {

using cplx = std::complex<double>;

bool is_power_of_two(int n) { return n > 0 && (n & (n - 1)) == 0; }

// Precomputed tables for one transform length N.
struct DctPlan {
  int n = 0;
  bool fft = false;
  // FFT path: bit reversal, twiddles e^{-2πik/N} (k < N/2), and the DCT rotation e^{-iπk/(2N)}.
  std::vector<int> bitrev;
  std::vector<cplx> twiddle;
  std::vector<cplx> rotation;
  // Matrix path: C(k, j) = cos(π k (2j + 1) / (2N)).
  MatrixXd cosines;
};

std::shared_ptr<const DctPlan> make_plan(int n) {
  auto p = std::make_shared<DctPlan>();
  p->n = n;
  p->fft = is_power_of_two(n) && n >= 4;
  if (p->fft) {
    int bits = 0;
    while ((1 << bits) < n) ++bits;
    p->bitrev.resize(n);
    for (int i = 0; i < n; ++i) {
      int r = 0;
      for (int b = 0; b < bits; ++b)
        if (i & (1 << b)) r |= 1 << (bits - 1 - b);
      p->bitrev[i] = r;
    }
    p->twiddle.resize(n / 2);
    for (int k = 0; k < n / 2; ++k) p->twiddle[k] = std::polar(1.0, -2.0 * M_PI * k / n);
    p->rotation.resize(n);
    for (int k = 0; k < n; ++k) p->rotation[k] = std::polar(1.0, -M_PI * k / (2.0 * n));
  } else {
    p->cosines.resize(n, n);
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j) p->cosines(k, j) = std::cos(M_PI * k * (2.0 * j + 1.0) / (2.0 * n));
  }
  return p;
}

// Plans are cached per length; built under a lock before any parallel loop uses them.
std::shared_ptr<const DctPlan> plan_for(int n) {
  static std::mutex mutex;
  static std::map<int, std::shared_ptr<const DctPlan>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = cache.find(n);
  if (it != cache.end()) return it->second;
  auto p = make_plan(n);
  cache[n] = p;
  return p;
}

// In-place iterative radix-2 FFT; inverse = conjugate twiddles, no 1/N scaling. Complex
// products are written out (std::complex's operator* checks for infinities at -O2).
void fft_inplace(const DctPlan& p, cplx* data, bool inverse) {
  const int n = p.n;
  for (int i = 0; i < n; ++i)
    if (i < p.bitrev[i]) std::swap(data[i], data[p.bitrev[i]]);
  double* a = reinterpret_cast<double*>(data);  // interleaved re, im (std::complex layout)
  const double sign = inverse ? -1.0 : 1.0;
  for (int len = 2; len <= n; len <<= 1) {
    const int half = len / 2, stride = n / len;
    for (int start = 0; start < n; start += len) {
      for (int j = 0; j < half; ++j) {
        const double wr = p.twiddle[j * stride].real(), wi = sign * p.twiddle[j * stride].imag();
        double* u = a + 2 * (start + j);
        double* v = a + 2 * (start + j + half);
        const double vr = v[0] * wr - v[1] * wi, vi = v[0] * wi + v[1] * wr;
        v[0] = u[0] - vr;
        v[1] = u[1] - vi;
        u[0] += vr;
        u[1] += vi;
      }
    }
  }
}

// DCT-II of two real columns at once: packs them as real and imaginary parts of one complex FFT
// (the spectra separate by Hermitian symmetry). x2 may be null.
void dct2_pair_fft(const DctPlan& p, double* x1, double* x2, std::vector<cplx>& buf) {
  const int n = p.n, h = n / 2;
  for (int i = 0; i < h; ++i) {
    buf[i] = cplx(x1[2 * i], x2 ? x2[2 * i] : 0.0);
    buf[n - 1 - i] = cplx(x1[2 * i + 1], x2 ? x2[2 * i + 1] : 0.0);
  }
  fft_inplace(p, buf.data(), false);
  for (int k = 0; k < n; ++k) {
    const cplx z = buf[k], zc = std::conj(buf[(n - k) % n]);
    const cplx v1 = 0.5 * (z + zc);
    const cplx v2 = cplx(0, -0.5) * (z - zc);
    x1[k] = (p.rotation[k] * v1).real();
    if (x2) x2[k] = (p.rotation[k] * v2).real();
  }
}

// Inverse of dct2_pair_fft: V_k = e^{iπk/(2N)} (X_k − i X_{N−k}) (X_N = 0), v = IFFT(V) real, then
// un-interleaved. The two columns ride in one complex inverse FFT (both V are Hermitian).
void idct2_pair_fft(const DctPlan& p, double* x1, double* x2, std::vector<cplx>& buf) {
  const int n = p.n, h = n / 2;
  for (int k = 0; k < n; ++k) {
    const cplx rot = std::conj(p.rotation[k]);
    const double a1 = x1[k], b1 = k == 0 ? 0.0 : x1[n - k];
    const cplx v1 = rot * cplx(a1, -b1);
    cplx v2 = 0;
    if (x2) {
      const double a2 = x2[k], b2 = k == 0 ? 0.0 : x2[n - k];
      v2 = rot * cplx(a2, -b2);
    }
    buf[k] = v1 + cplx(0, 1) * v2;
  }
  fft_inplace(p, buf.data(), true);
  const double s = 1.0 / n;
  for (int i = 0; i < h; ++i) {
    x1[2 * i] = buf[i].real() * s;
    x1[2 * i + 1] = buf[n - 1 - i].real() * s;
    if (x2) {
      x2[2 * i] = buf[i].imag() * s;
      x2[2 * i + 1] = buf[n - 1 - i].imag() * s;
    }
  }
}

// A * B by fixed blocks of 16 columns: Eigen's own OpenMP product splits the rows by the thread
// count, which changes the rounding (measured 5e-14) with the number of threads.
template <class Lhs>
MatrixXd product_by_column_blocks(const Lhs& A, const MatrixXd& B) {
  MatrixXd out(A.rows(), B.cols());
  const Eigen::Index cols = B.cols();
#pragma omp parallel for schedule(static)
  for (Eigen::Index j = 0; j < cols; j += 16) {
    const Eigen::Index w = std::min<Eigen::Index>(16, cols - j);
    out.middleCols(j, w).noalias() = A * B.middleCols(j, w);
  }
  return out;
}

void transform_columns(MatrixXd& X, bool inverse) {
  const int n = static_cast<int>(X.rows());
  const int m = static_cast<int>(X.cols());
  if (n == 0 || m == 0) return;
  if (n == 1) return;  // the DCT of length 1 is the identity (X_0 = x_0, x_0 = X_0)
  const auto plan = plan_for(n);
  if (!plan->fft) {
    // Cosine-matrix path: X = C x (forward); x = C^T W X / N with W = diag(1, 2, 2, ...).
    if (!inverse) {
      X = product_by_column_blocks(plan->cosines, X);
    } else {
      MatrixXd W = X;
      W.bottomRows(n - 1) *= 2.0;
      X = product_by_column_blocks(plan->cosines.transpose(), W) / n;
    }
    return;
  }
  const int pairs = (m + 1) / 2;
#pragma omp parallel
  {
    std::vector<cplx> buf(n);
#pragma omp for schedule(static)
    for (int q = 0; q < pairs; ++q) {
      double* c1 = X.col(2 * q).data();
      double* c2 = 2 * q + 1 < m ? X.col(2 * q + 1).data() : nullptr;
      if (inverse)
        idct2_pair_fft(*plan, c1, c2, buf);
      else
        dct2_pair_fft(*plan, c1, c2, buf);
    }
  }
}

}  // namespace

void dct2_columns(MatrixXd& X) { transform_columns(X, false); }
void idct2_columns(MatrixXd& X) { transform_columns(X, true); }

void dct2_2d(MatrixXd& X) {
  dct2_columns(X);
  MatrixXd T = X.transpose();
  dct2_columns(T);
  X = T.transpose();
}

void idct2_2d(MatrixXd& X) {
  MatrixXd T = X.transpose();
  idct2_columns(T);
  X = T.transpose();
  idct2_columns(X);
}

NeumannPoissonGrid::NeumannPoissonGrid(int nx, int ny, double hx, double hy) : nx_(nx), ny_(ny), hx_(hx), hy_(hy) {
  if (nx < 1 || ny < 1 || !(hx > 0) || !(hy > 0))
    throw std::invalid_argument("NeumannPoissonGrid: grid size and cell size must be positive");
  eig_x_.resize(nx);
  for (int k = 0; k < nx; ++k) eig_x_[k] = (2.0 * std::cos(M_PI * k / nx) - 2.0) / (hx * hx);
  eig_y_.resize(ny);
  for (int l = 0; l < ny; ++l) eig_y_[l] = (2.0 * std::cos(M_PI * l / ny) - 2.0) / (hy * hy);
}

MatrixXd NeumannPoissonGrid::solve(const MatrixXd& f) const {
  MatrixXd g;
  smooth_and_solve(f, 0.0, nullptr, &g);
  return g;
}

MatrixXd NeumannPoissonGrid::smooth(const MatrixXd& f, double sigma) const {
  MatrixXd s;
  smooth_and_solve(f, sigma, &s, nullptr);
  return s;
}

void NeumannPoissonGrid::smooth_and_solve(const MatrixXd& f, double sigma, MatrixXd* f_smooth, MatrixXd* g) const {
  if (f.rows() != ny_ || f.cols() != nx_) throw std::invalid_argument("NeumannPoissonGrid: field size does not match the grid");
  MatrixXd F = f;
  dct2_2d(F);
  if (sigma > 0) {
    // Continuous Gaussian on the evenly extended field: exp(−σ²ω²/2) per cosine mode, which
    // factors into an x part and a y part.
    const double ax = M_PI / (nx_ * hx_), ay = M_PI / (ny_ * hy_);
    VectorXd gx(nx_), gy(ny_);
    for (int c = 0; c < nx_; ++c) gx[c] = std::exp(-0.5 * sigma * sigma * (ax * c) * (ax * c));
    for (int r = 0; r < ny_; ++r) gy[r] = std::exp(-0.5 * sigma * sigma * (ay * r) * (ay * r));
    for (int c = 0; c < nx_; ++c) F.col(c).array() *= gx[c] * gy.array();
  }
  if (f_smooth) {
    *f_smooth = F;
    idct2_2d(*f_smooth);
  }
  if (g) {
    for (int c = 0; c < nx_; ++c)
      for (int r = 0; r < ny_; ++r) F(r, c) = (r == 0 && c == 0) ? 0.0 : F(r, c) / (eig_x_[c] + eig_y_[r]);
    idct2_2d(F);
    *g = std::move(F);
  }
}

void staggered_gradient(const MatrixXd& g, double hx, double hy, MatrixXd* gx, MatrixXd* gy) {
  const Eigen::Index ny = g.rows(), nx = g.cols();
  if (gx) {
    gx->setZero(ny, nx + 1);
    for (Eigen::Index c = 1; c < nx; ++c) gx->col(c) = (g.col(c) - g.col(c - 1)) / hx;
  }
  if (gy) {
    gy->setZero(ny + 1, nx);
    for (Eigen::Index r = 1; r < ny; ++r) gy->row(r) = (g.row(r) - g.row(r - 1)) / hy;
  }
}

}  // namespace authalic

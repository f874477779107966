#include "core/sparse_cholesky.h"

#include <dlfcn.h>
#include <omp.h>

#include <Eigen/CholmodSupport>
#include <algorithm>
#include <limits>
#include <mutex>
#include <Eigen/SparseCholesky>

namespace authalic {

namespace {
// Eigen's CHOLMOD wrapper with one more way to analyse: with a given ordering
// (cholmod_analyze_p), which Eigen's analyzePattern does not offer.
class OrderedCholmod : public Eigen::CholmodDecomposition<SparseMatrix> {
 public:
  void analyze_with_ordering(const SparseMatrix& A, std::vector<int>& perm) {
    if (m_cholmodFactor) cholmod_free_factor(&m_cholmodFactor, &cholmod());
    cholmod_sparse view = viewAsCholmod(A.selfadjointView<Eigen::Lower>());
    const int ordering = cholmod().method[0].ordering;
    cholmod().method[0].ordering = CHOLMOD_GIVEN;
    m_cholmodFactor = cholmod_analyze_p(&view, perm.data(), nullptr, 0, &cholmod());
    cholmod().method[0].ordering = ordering;
    m_isInitialized = true;
    m_info = m_cholmodFactor ? Eigen::Success : Eigen::NumericalIssue;
    m_analysisIsOk = m_cholmodFactor != nullptr;
    m_factorizationIsOk = false;
  }
};

}  // namespace

std::mutex& metis_mutex() {
  static std::mutex m;
  return m;
}

std::mutex& blas_mutex() {
  static std::mutex m;
  return m;
}

BlasCall::BlasCall() : lock_(blas_mutex()), saved_levels_(omp_get_max_active_levels()) { omp_set_max_active_levels(0); }
BlasCall::~BlasCall() { omp_set_max_active_levels(saved_levels_); }

struct SpdSolver::Impl {
  OrderedCholmod cholmod;
  Eigen::SimplicialLDLT<SparseMatrix> fallback;
  bool use_fallback = false;
  bool ok = false;
  std::vector<SparseMatrix::StorageIndex> outer, inner;  // the pattern compute() analysed
  std::shared_future<std::vector<int>> vertex_order;     // order_by_vertices
};

SpdSolver::SpdSolver() : impl_(std::make_unique<Impl>()) {}
SpdSolver::SpdSolver(const SparseMatrix& A) : SpdSolver() { compute(A); }
SpdSolver::~SpdSolver() = default;
SpdSolver::SpdSolver(SpdSolver&&) noexcept = default;
SpdSolver& SpdSolver::operator=(SpdSolver&&) noexcept = default;

namespace {
// BLAS in one thread: a threaded OpenBLAS (the pthread or OpenMP build, if that is the machine's
// libblas) may block a factorisation differently for another thread count, and maps must not
// depend on it (README: deterministic). The serial build, which scripts/install_deps.sh
// installs, has no threads to set; reference BLAS has no such function.
void single_threaded_blas() {
  static std::once_flag once;
  std::call_once(once, [] {
    using SetThreads = void (*)(int);
    if (void* f = ::dlsym(RTLD_DEFAULT, "openblas_set_num_threads")) reinterpret_cast<SetThreads>(f)(1);
  });
}

// CHOLMOD's Perm for the n rows of a system from a vertex order: the rows of the vertices in
// that order, then the rows no vertex of it names, ascending.
std::vector<int> rows_in_vertex_order(const std::vector<int>& vertex_order, const std::vector<int>& row_of_vertex, Eigen::Index n) {
  std::vector<int> perm;
  perm.reserve(static_cast<std::size_t>(n));
  std::vector<char> placed(static_cast<std::size_t>(n), 0);
  for (int v : vertex_order) {
    if (v < 0 || static_cast<std::size_t>(v) >= row_of_vertex.size()) continue;
    const int r = row_of_vertex[static_cast<std::size_t>(v)];
    if (r < 0 || r >= n || placed[static_cast<std::size_t>(r)]) continue;
    placed[static_cast<std::size_t>(r)] = 1;
    perm.push_back(r);
  }
  for (Eigen::Index r = 0; r < n; ++r)
    if (!placed[static_cast<std::size_t>(r)]) perm.push_back(static_cast<int>(r));
  return perm;
}

bool same_pattern(const SparseMatrix& A, const std::vector<SparseMatrix::StorageIndex>& outer,
                  const std::vector<SparseMatrix::StorageIndex>& inner) {
  return A.isCompressed() && static_cast<std::size_t>(A.outerSize() + 1) == outer.size() &&
         static_cast<std::size_t>(A.nonZeros()) == inner.size() &&
         std::equal(outer.begin(), outer.end(), A.outerIndexPtr()) && std::equal(inner.begin(), inner.end(), A.innerIndexPtr());
}
}  // namespace

std::vector<int> mesh_vertex_ordering(const MatrixXi& F, int num_vertices) {
  // The vertex adjacency as a symmetric pattern (lower triangle), ordered by CHOLMOD's METIS
  // interface as the analyses below would order a system of this pattern.
  std::vector<Eigen::Triplet<double>> edges;
  edges.reserve(static_cast<std::size_t>(F.rows()) * 3 + static_cast<std::size_t>(num_vertices));
  for (int v = 0; v < num_vertices; ++v) edges.emplace_back(v, v, 1.0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = F(f, c), b = F(f, (c + 1) % 3);
      edges.emplace_back(std::max(a, b), std::min(a, b), 1.0);
    }
  SparseMatrix pattern(num_vertices, num_vertices);
  pattern.setFromTriplets(edges.begin(), edges.end());
  const SparseMatrix& P = pattern;
  cholmod_sparse view = Eigen::viewAsCholmod(P.selfadjointView<Eigen::Lower>());
  std::vector<int> perm(static_cast<std::size_t>(num_vertices));
  cholmod_common common;
  cholmod_start(&common);
  common.print = 0;
  bool ok;
  {
    const std::lock_guard<std::mutex> lock(metis_mutex());
    ok = cholmod_metis(&view, nullptr, 0, 1, perm.data(), &common) != 0;
  }
  cholmod_finish(&common);
  if (!ok) perm.clear();  // compute() then orders the system itself
  return perm;
}

void SpdSolver::order_by_vertices(std::shared_future<std::vector<int>> vertex_order) { impl_->vertex_order = std::move(vertex_order); }

bool SpdSolver::compute(const SparseMatrix& A, const std::vector<int>* row_of_vertex) {
  if (A.isCompressed()) {
    impl_->outer.assign(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
    impl_->inner.assign(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
  } else {
    impl_->outer.clear();
    impl_->inner.clear();
  }
  // One ordering, chosen by size (CHOLMOD's default tries AMD, then METIS when AMD's fill is
  // large: both analyses). Measured in the maps, one thread, supernodal (B3: 149k unknowns,
  // three factorisations and 29 solves; fs741 R1 148k, four and 30; B600 585k, four and 38):
  //   AMD:   analysis 0.09 / 0.14 / 0.52 s, factorisations 1.10 / 0.80 / 12.6 s, solves 1.04 /
  //          0.76 / 6.3 s, B600 peak 1.36 GB;
  //   METIS: analysis 0.90 / 1.10 / 4.6 s, factorisations 0.97 / 0.89 / 6.1 s, solves 0.84 /
  //          0.72 / 5.1 s, B600 peak 1.22 GB.
  // AMD's larger fill costs little while the supernodes are small (and its columns' bigger
  // supernodes suit the BLAS), and it needs no mutex (METIS's generator is global); at 600k its
  // fill doubles the factorisations. (Simplicial, AMD lost at 150k too: 1.3 s against 0.5 s.)
  // Supernodal: OpenBLAS's dense kernels pay from tens of thousands of unknowns (B3's three
  // factorisations 2.0 s simplicial against 0.8 s; S655's 585k unknowns refactorise in 2.9 s
  // against 7.3 s; B1 subdivided once, 40k unknowns: the map 1.7 s against 1.3 s with Eigen's
  // LDLᵀ). Below 20k Eigen's LDLᵀ stays (its own AMD ordering; about 10 ms at 10k unknowns).
  impl_->use_fallback = A.rows() <= kSpdLdltMaxUnknowns;
  impl_->cholmod.setMode(Eigen::CholmodSupernodalLLt);
  if (!impl_->use_fallback) {
    single_threaded_blas();
    const bool metis = A.rows() > kSpdMetisMinUnknowns;
    impl_->cholmod.cholmod().nmethods = 1;
    impl_->cholmod.cholmod().method[0].ordering = metis ? CHOLMOD_METIS : CHOLMOD_AMD;
    impl_->cholmod.cholmod().print = 0;  // quiet: a non-definite matrix falls back below
    std::vector<int> perm;
    if (metis && row_of_vertex && impl_->vertex_order.valid() && !impl_->vertex_order.get().empty())
      perm = rows_in_vertex_order(impl_->vertex_order.get(), *row_of_vertex, A.rows());
    if (!perm.empty()) {
      impl_->cholmod.analyze_with_ordering(A, perm);
    } else {
      std::unique_lock<std::mutex> lock(metis_mutex(), std::defer_lock);  // AMD keeps no global state
      if (metis) lock.lock();
      impl_->cholmod.analyzePattern(A);
    }
    if (impl_->cholmod.info() == Eigen::Success) {
      const BlasCall call;
      impl_->cholmod.factorize(A);
    }
    impl_->use_fallback = impl_->cholmod.info() != Eigen::Success;
  }
  if (impl_->use_fallback) impl_->fallback.compute(A);
  impl_->ok = impl_->use_fallback ? impl_->fallback.info() == Eigen::Success : true;
  return impl_->ok;
}

bool SpdSolver::refactor(const SparseMatrix& A, const std::vector<int>* row_of_vertex) {
  // Same pattern as the last compute(): keep its ordering and symbolic analysis (METIS on a 600k
  // mesh costs almost as much as three numeric factorisations).
  if (!impl_->ok || !same_pattern(A, impl_->outer, impl_->inner)) return compute(A, row_of_vertex);
  if (impl_->use_fallback) {
    impl_->fallback.factorize(A);
  } else {
    const BlasCall call;
    impl_->cholmod.factorize(A);
  }
  impl_->ok = (impl_->use_fallback ? impl_->fallback.info() : impl_->cholmod.info()) == Eigen::Success;
  if (!impl_->ok && !impl_->use_fallback) return compute(A, row_of_vertex);  // not definite for CHOLMOD: LDLᵀ
  return impl_->ok;
}

bool SpdSolver::ok() const { return impl_->ok; }

MatrixXd SpdSolver::solve(const MatrixXd& B) const {
  if (impl_->use_fallback) return impl_->fallback.solve(B);
  const BlasCall call;
  return impl_->cholmod.solve(B);
}

bool SpdSolver::solve_preconditioned(const SparseMatrix& A, const MatrixXd& B, MatrixXd& X, double tolerance,
                                     int max_iterations, int* iterations) const {
  // Preconditioned CG (Saad, Iterative Methods, Algorithm 9.1) on all columns at once: one
  // preconditioner application per iteration serves every column; each column keeps its own
  // step lengths and stops moving once converged.
  if (iterations) *iterations = 0;
  if (!impl_->ok || A.rows() != B.rows() || X.rows() != B.rows() || X.cols() != B.cols()) return false;
  const Eigen::Index nc = B.cols();
  MatrixXd R = B - A.selfadjointView<Eigen::Lower>() * X;
  const Eigen::ArrayXd r0_norm = R.colwise().norm().transpose().array();
  std::vector<char> done(static_cast<std::size_t>(nc), 0);
  auto converged = [&](Eigen::Index c) { return R.col(c).norm() <= tolerance * r0_norm[c]; };
  bool all = true;
  for (Eigen::Index c = 0; c < nc; ++c) all = all && (done[static_cast<std::size_t>(c)] = converged(c));
  if (all) return true;
  MatrixXd Z = solve(R), P = Z, AP(B.rows(), nc);
  Eigen::ArrayXd rz = (R.array() * Z.array()).colwise().sum().transpose();
  for (int it = 1; it <= max_iterations; ++it) {
    AP.noalias() = A.selfadjointView<Eigen::Lower>() * P;
    for (Eigen::Index c = 0; c < nc; ++c) {
      if (done[static_cast<std::size_t>(c)]) continue;
      const double alpha = rz[c] / P.col(c).dot(AP.col(c));
      X.col(c) += alpha * P.col(c);
      R.col(c) -= alpha * AP.col(c);
    }
    all = true;
    for (Eigen::Index c = 0; c < nc; ++c) all = all && (done[static_cast<std::size_t>(c)] = done[static_cast<std::size_t>(c)] || converged(c));
    if (iterations) *iterations = it;
    if (all) return true;
    Z = solve(R);
    for (Eigen::Index c = 0; c < nc; ++c) {
      if (done[static_cast<std::size_t>(c)]) continue;
      const double rz_new = R.col(c).dot(Z.col(c));
      P.col(c) = Z.col(c) + (rz_new / rz[c]) * P.col(c);
      rz[c] = rz_new;
    }
  }
  return false;
}

}  // namespace authalic

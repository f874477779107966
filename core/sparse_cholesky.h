#pragma once
// Sparse symmetric positive definite solves for the map cores: Eigen's simplicial LDLᵀ up to 20k
// unknowns, CHOLMOD's supernodal Cholesky above, ordered by AMD up to 250k unknowns and by nested
// dissection (METIS) beyond (falling back to LDLᵀ if CHOLMOD reports the matrix not positive
// definite). BLAS runs in one thread, so results do not depend on the OpenMP thread count.
#include <future>
#include <memory>
#include <mutex>
#include <vector>

#include "core/mesh.h"

namespace authalic {

// Locks for the libraries under CHOLMOD, which keep process-wide state. Hold metis_mutex() for
// any CHOLMOD analysis that may order with METIS (its random generator is global: two orderings
// at once came out different from run to run), and blas_mutex() for any supernodal
// factorisation or solve: Debian's serial OpenBLAS shares its work buffers between callers, so
// two supernodal solves on one factor run side by side came out different from the same solves
// one after the other (the two hemispheres of `run` are mapped side by side). SpdSolver takes
// them itself.
std::mutex& metis_mutex();
std::mutex& blas_mutex();

// For the span of a supernodal CHOLMOD call: holds blas_mutex() and makes this thread's OpenMP
// regions inactive. CHOLMOD opens a region per supernode (tens of thousands on a hemisphere) for
// its bookkeeping; with a second thread and passive waiting (app/main.cpp) each one woke a
// sleeping thread, and B3's factorisation took 0.43 s against 0.24 s in one thread. The BLAS is
// serial, so those regions gain nothing from a team.
class BlasCall {
 public:
  BlasCall();
  ~BlasCall();
  BlasCall(const BlasCall&) = delete;
  BlasCall& operator=(const BlasCall&) = delete;

 private:
  std::lock_guard<std::mutex> lock_;
  int saved_levels_;
};

// Up to this many unknowns SpdSolver factorises with Eigen's LDLᵀ (cheap: 10 ms at 10k), above
// with CHOLMOD.
inline constexpr Eigen::Index kSpdLdltMaxUnknowns = 20000;
// CHOLMOD orders systems of up to this many unknowns with AMD, larger ones with METIS (nested
// dissection), whose smaller fill pays for its slower analysis only on large meshes.
inline constexpr Eigen::Index kSpdMetisMinUnknowns = 250000;

// Nested-dissection ordering (METIS, through CHOLMOD) of a mesh's vertices by its edges: the
// vertex ids, first eliminated first (vertices F does not use come last). It orders any system
// whose unknowns are (most of) these vertices, and needs only the faces, so it can be computed
// while such a system is still being assembled (SpdSolver::order_by_vertices).
std::vector<int> mesh_vertex_ordering(const MatrixXi& F, int num_vertices);

class SpdSolver {
 public:
  SpdSolver();
  explicit SpdSolver(const SparseMatrix& A);  // factorises A (only its lower triangle is read)
  ~SpdSolver();
  SpdSolver(SpdSolver&&) noexcept;
  SpdSolver& operator=(SpdSolver&&) noexcept;

  // From now on, the CHOLMOD analyses of systems given with their rows' vertices (compute and
  // refactor with row_of_vertex) order the rows by `vertex_order` (mesh_vertex_ordering, which
  // may still be running) instead of running METIS on the system: rows without a vertex in it
  // come last. The order depends only on the mesh, so the result does not depend on whether it
  // was computed beforehand or at the analysis.
  void order_by_vertices(std::shared_future<std::vector<int>> vertex_order);
  // Factorises A; false if neither CHOLMOD nor the fallback succeeds. row_of_vertex (optional):
  // per mesh vertex, its row of A or a negative value (see order_by_vertices).
  bool compute(const SparseMatrix& A, const std::vector<int>* row_of_vertex = nullptr);
  // Factorises A reusing the ordering and symbolic analysis of the last compute() when A has its
  // sparsity pattern (checked; otherwise this is compute(A, row_of_vertex)). A
  // default-constructed solver computes on the first call, so one object can serve a sequence
  // of systems of one mesh.
  bool refactor(const SparseMatrix& A, const std::vector<int>* row_of_vertex = nullptr);
  bool ok() const;
  MatrixXd solve(const MatrixXd& B) const;
  // Solves A X = B by conjugate gradients, column by column, preconditioned with this solver's
  // factorisation of a nearby matrix of A's pattern (so a sequence of slowly changing systems,
  // like the stretch-energy iterations, needs one factorisation instead of one per system). X
  // holds the starting guess on entry. True, with X the solution, when every column's residual
  // has fallen to `tolerance` times its starting guess's within `max_iterations`; false leaves X
  // unspecified.
  bool solve_preconditioned(const SparseMatrix& A, const MatrixXd& B, MatrixXd& X, double tolerance, int max_iterations,
                            int* iterations = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace authalic

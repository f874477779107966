// run_beside: two independent pieces of work at once, on two OpenMP threads.
#pragma once

#include <exception>

#include <omp.h>

namespace authalic {

// Runs a() and b() at once on two threads when two are allowed (--threads 2 or more, not already
// inside a parallel region), else a() then b(). For work that is mostly serial, such as a sparse
// factorisation (its BLAS is serial and locked) beside a mesh pass: the two cores then both work.
// While both run, their own parallel loops run on one thread each (nested regions are inactive).
// a and b must not write what the other reads; results must not depend on the thread count (they
// do not in this project: every parallel loop is deterministic). An exception thrown by either is
// rethrown after both have finished, a's first.
template <class A, class B>
void run_beside(A&& a, B&& b) {
  std::exception_ptr error_a, error_b;
  const bool two = omp_get_max_threads() > 1 && !omp_in_parallel();
#pragma omp parallel sections num_threads(2) if (two)
  {
#pragma omp section
    {
      try {
        a();
      } catch (...) {
        error_a = std::current_exception();
      }
    }
#pragma omp section
    {
      try {
        b();
      } catch (...) {
        error_b = std::current_exception();
      }
    }
  }
  if (error_a) std::rethrow_exception(error_a);
  if (error_b) std::rethrow_exception(error_b);
}

}  // namespace authalic

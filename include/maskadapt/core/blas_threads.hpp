#pragma once
/// \file blas_threads.hpp
/// Control of OpenBLAS's own worker threads when Eigen forwards products to it (EIGEN_USE_BLAS).
///
/// maskadapt parallelises over envs on its own ThreadPool. OpenBLAS's threads then compete with it
/// for the same cores and spin while they wait: measured on 2 cores, a 32-env training iteration
/// ran 2.3× slower with OpenBLAS's default threading than with one BLAS thread (policy inference
/// went from 1–2% of the iteration to 25%). Trainers therefore call `limit_blas_threads(1)` at
/// start-up unless the user set OPENBLAS_NUM_THREADS; big-batch benchmarks may raise it.
#include <cstdlib>

#if defined(MASKADAPT_HAS_BLAS)
extern "C" void openblas_set_num_threads(int num_threads);
#endif

namespace maskadapt {

/// Sets OpenBLAS's thread count (no-op without BLAS). Returns true when a BLAS was configured.
inline bool set_blas_threads(int num_threads) {
#if defined(MASKADAPT_HAS_BLAS)
  openblas_set_num_threads(num_threads);
  return true;
#else
  (void)num_threads;
  return false;
#endif
}

/// `set_blas_threads(n)` unless the environment variable OPENBLAS_NUM_THREADS is set (the user's
/// choice wins).
inline void limit_blas_threads(int num_threads = 1) {
  if (const char* env = std::getenv("OPENBLAS_NUM_THREADS"); env && *env) return;
  set_blas_threads(num_threads);
}

}  // namespace maskadapt

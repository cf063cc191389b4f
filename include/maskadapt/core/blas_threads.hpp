#pragma once
/// \file blas_threads.hpp
/// Control of OpenBLAS's own worker threads when Eigen forwards products to it (EIGEN_USE_BLAS),
/// and the name of the kernel family it picked.
///
/// maskadapt parallelises over envs on its own ThreadPool. OpenBLAS's threads then compete with it
/// for the same cores and spin while they wait: measured on 2 cores, a 32-env training iteration
/// ran 2.3× slower with OpenBLAS's default threading than with one BLAS thread (policy inference
/// went from 1–2% of the iteration to 25%). Trainers therefore call `limit_blas_threads(1)` at
/// start-up unless the user set OPENBLAS_NUM_THREADS; big-batch benchmarks may raise it.
#include <cstdlib>

#include <string>

#if defined(MASKADAPT_HAS_BLAS)
extern "C" void openblas_set_num_threads(int num_threads);
extern "C" char* openblas_get_corename(void);
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

/// The kernel family OpenBLAS chose when it loaded (`openblas_get_corename()`: "Haswell",
/// "SkylakeX", "Cooperlake", "Prescott", …; OPENBLAS_CORETYPE overrides its choice at load time
/// only), or "none" without BLAS. Products, and so training figures and benchmark timings,
/// depend on it: record it next to every figure (docs/benchmarks.md, the trainers' log).
inline std::string blas_core_name() {
#if defined(MASKADAPT_HAS_BLAS)
  const char* name = openblas_get_corename();
  return name ? std::string(name) : std::string("unknown");
#else
  return "none";
#endif
}

}  // namespace maskadapt

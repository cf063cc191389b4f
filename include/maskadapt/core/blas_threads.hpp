#pragma once
/// \file blas_threads.hpp
/// Control of OpenBLAS's own worker threads when Eigen forwards products to it (EIGEN_USE_BLAS),
/// the name of the kernel family it picked, and which family to ask for when its own choice is a
/// fallback that leaves most of the CPU unused.
///
/// maskadapt parallelises over envs on its own ThreadPool. OpenBLAS's threads then compete with it
/// for the same cores and spin while they wait: measured on 2 cores, a 32-env training iteration
/// ran 2.3× slower with OpenBLAS's default threading than with one BLAS thread (policy inference
/// went from 1–2% of the iteration to 25%). Trainers therefore call `limit_blas_threads(1)` at
/// start-up unless the user set OPENBLAS_NUM_THREADS; big-batch benchmarks may raise it.
#include <cstdlib>

#include <fstream>
#include <set>
#include <sstream>
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

/// The CPU's feature flags as /proc/cpuinfo names them ("avx2", "fma", "avx512f", …); empty
/// where there is no /proc/cpuinfo.
inline std::set<std::string> cpu_flags() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("flags", 0) != 0) continue;
    std::istringstream words(line.substr(line.find(':') + 1));
    std::set<std::string> flags;
    for (std::string w; words >> w;) flags.insert(w);
    return flags;
  }
  return {};
}

/// The kernel family to request with OPENBLAS_CORETYPE when OpenBLAS loaded `current`, a family
/// without FMA (Prescott, Core2, Nehalem, Sandybridge, …), on a CPU with `flags` that has AVX2 +
/// FMA — e.g. Debian's OpenBLAS 0.3.21 on CPUs newer than it knows: "SkylakeX" where the CPU has AVX-512
/// (F, CD, BW, DQ, VL), else "Haswell". Empty when OpenBLAS's own choice should stand (it uses
/// FMA already, the user set OPENBLAS_CORETYPE, or there is no BLAS). Measured on an Emerald
/// Rapids Xeon that gets Prescott: SkylakeX runs the MLP's training products 4.5× faster
/// (docs/benchmarks.md). The choice must be made before OpenBLAS loads: the `maskadapt` tool
/// re-executes itself with the variable set; a program of your own can do the same in main().
inline std::string recommended_blas_core_for(const std::string& current, const std::set<std::string>& flags) {
  static const std::set<std::string> without_fma = {"Prescott", "Core2",       "Penryn",  "Dunnington", "Nehalem",
                                                    "Atom",     "Sandybridge", "Katmai",  "Coppermine", "Northwood",
                                                    "Banias",   "Barcelona",   "Bobcat"};
  if (!without_fma.count(current)) return "";
  auto has = [&](const char* x) { return flags.count(x) > 0; };
  if (!has("avx2") || !has("fma")) return "";
  if (has("avx512f") && has("avx512cd") && has("avx512bw") && has("avx512dq") && has("avx512vl")) return "SkylakeX";
  return "Haswell";
}

/// recommended_blas_core_for(what OpenBLAS loaded, this CPU's flags), or "" when the user set
/// OPENBLAS_CORETYPE or there is no BLAS.
inline std::string recommended_blas_core() {
  if (const char* env = std::getenv("OPENBLAS_CORETYPE"); env && *env) return "";
  const std::string current = blas_core_name();
  if (current == "none") return "";
  return recommended_blas_core_for(current, cpu_flags());
}

}  // namespace maskadapt

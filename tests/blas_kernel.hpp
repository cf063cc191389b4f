#pragma once
// The OpenBLAS kernel matrix of the determinism tests (tests/CMakeLists.txt,
// maskadapt_add_blas_matrix): each such test is run once per kernel family with
// OPENBLAS_CORETYPE=<family>. OpenBLAS silently falls back to another family when the CPU lacks
// the instructions, so a test run under a family the CPU cannot execute would test nothing: it
// skips with a message instead, and a family the CPU has but OpenBLAS did not load fails.
#include <maskadapt/core/blas_threads.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace maskadapt::testing {

/// Instructions OpenBLAS 0.3.21's kernel family `core` needs (cpuinfo names; "pni" is SSE3).
inline std::vector<std::string> flags_needed_by(const std::string& core) {
  if (core == "Prescott") return {"pni"};
  if (core == "Haswell" || core == "Zen") return {"avx2", "fma"};
  if (core == "SkylakeX") return {"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"};
  if (core == "Cooperlake") return {"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl", "avx512_bf16"};
  return {};
}

inline std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

/// Why this process cannot test the kernel family named by OPENBLAS_CORETYPE ("" when it can,
/// or when none is named). Sets *mismatch when the CPU has the instructions but OpenBLAS loaded
/// another family.
inline std::string blas_core_skip_reason(bool* mismatch) {
  *mismatch = false;
  const char* requested = std::getenv("OPENBLAS_CORETYPE");
  if (requested == nullptr || *requested == '\0') return "";
  const std::string core = requested;
  if (blas_core_name() == "none") return "built without BLAS: OPENBLAS_CORETYPE=" + core + " has nothing to select";
  const std::vector<std::string> needed = flags_needed_by(core);
  if (needed.empty()) return "no instruction list for OPENBLAS_CORETYPE=" + core + " (tests/blas_kernel.hpp)";
  const std::set<std::string> flags = ::maskadapt::cpu_flags();
  if (flags.empty()) return "no /proc/cpuinfo: cannot tell whether this CPU runs " + core + "'s kernels";
  for (const auto& f : needed)
    if (!flags.count(f)) return "this CPU lacks " + f + ", which OpenBLAS's " + core + " kernels need";
  if (lower(blas_core_name()) != lower(core)) {
    *mismatch = true;
    return "OPENBLAS_CORETYPE=" + core + " was requested and the CPU has its instructions, but OpenBLAS loaded " +
           blas_core_name();
  }
  return "";
}

}  // namespace maskadapt::testing

/// First statement of a determinism test: skips it (with the reason) when OPENBLAS_CORETYPE
/// names a kernel family this CPU cannot run, fails it when OpenBLAS ignored the request.
#define MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE()                                        \
  do {                                                                                 \
    bool blas_core_mismatch_ = false;                                                  \
    const std::string blas_skip_ = ::maskadapt::testing::blas_core_skip_reason(&blas_core_mismatch_); \
    if (blas_core_mismatch_) FAIL() << blas_skip_;                                     \
    if (!blas_skip_.empty()) GTEST_SKIP() << blas_skip_;                               \
  } while (0)

// Which OpenBLAS kernel family the `maskadapt` tool asks for (core/blas_threads.hpp).
#include <maskadapt/core/blas_threads.hpp>

#include <gtest/gtest.h>

#include <cstdlib>

using namespace maskadapt;

TEST(BlasCore, AFallbackWithoutFmaIsReplacedByTheWidestFamilyTheCpuRuns) {
  const std::set<std::string> avx512 = {"sse3", "avx", "avx2", "fma", "avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"};
  const std::set<std::string> avx2 = {"sse3", "avx", "avx2", "fma"};
  const std::set<std::string> avx512f_only = {"avx2", "fma", "avx512f"};  // e.g. Knights Landing: no BW/DQ/VL
  EXPECT_EQ(recommended_blas_core_for("Prescott", avx512), "SkylakeX");
  EXPECT_EQ(recommended_blas_core_for("Nehalem", avx512), "SkylakeX");
  EXPECT_EQ(recommended_blas_core_for("Prescott", avx2), "Haswell");
  EXPECT_EQ(recommended_blas_core_for("Prescott", avx512f_only), "Haswell");
  // OpenBLAS's own FMA choices stand, and a CPU without AVX2/FMA keeps what it has
  for (const char* fma_family : {"Haswell", "Zen", "SkylakeX", "Cooperlake"})
    EXPECT_EQ(recommended_blas_core_for(fma_family, avx512), "") << fma_family;
  EXPECT_EQ(recommended_blas_core_for("Prescott", {"sse3", "avx"}), "");
  EXPECT_EQ(recommended_blas_core_for("Sandybridge", {"sse3", "avx", "avx2"}), "");  // AVX2 without FMA
}

TEST(BlasCore, TheUsersOpenblasCoretypeWins) {
  const char* before = std::getenv("OPENBLAS_CORETYPE");
  const std::string saved = before ? before : "";
  ::setenv("OPENBLAS_CORETYPE", "Haswell", 1);
  EXPECT_EQ(recommended_blas_core(), "");
  ::unsetenv("OPENBLAS_CORETYPE");
  // Without the variable: either no advice, or advice for a CPU that has the instructions.
  const std::string advice = recommended_blas_core();
  if (!advice.empty()) {
    EXPECT_TRUE(cpu_flags().count("fma"));
    EXPECT_EQ(advice, recommended_blas_core_for(blas_core_name(), cpu_flags()));
  }
  if (before) ::setenv("OPENBLAS_CORETYPE", saved.c_str(), 1);
}

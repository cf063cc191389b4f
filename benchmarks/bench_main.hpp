#pragma once
// The common end of every benchmark binary's main(): Google Benchmark's flags, the OpenBLAS kernel
// family in the report's context (every product timing depends on the kernel OpenBLAS loaded,
// and OPENBLAS_CORETYPE picks another), the run.
#include <benchmark/benchmark.h>

#include "maskadapt/core/blas_threads.hpp"

namespace maskadapt::bench {

/// Parses the benchmark flags, records `openblas_core` and runs the registered benchmarks;
/// returns main()'s exit status (1 for an unrecognised flag).
inline int run_benchmarks(int& argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::AddCustomContext("openblas_core", maskadapt::blas_core_name());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace maskadapt::bench

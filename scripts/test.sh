#!/usr/bin/env bash
# The test command (README, .ci/run): set up, build, run the whole suite, then the same tests
# once more under AddressSanitizer + UndefinedBehaviorSanitizer in build-asan/, then the fuzzers
# for a bounded time.
#
#   scripts/test.sh           # everything (what CI runs)
#   scripts/test.sh --quick   # the inner loop: setup, Release build and ctest in build/ only (no
#                             # viewer setup, no sanitizer build, no fuzzers; docs/development.md)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)

quick=0
for arg in "$@"; do
  case "$arg" in
    --quick) quick=1 ;;
    *) echo "test.sh: unknown option '$arg' (known: --quick)" >&2; exit 2 ;;
  esac
done

# --with-mpi: OpenMPI, so that tests/mpi (2 ranks under mpirun, ~20 s) run too
bash scripts/setup.sh --with-mpi
# The web viewer (npm packages from its lock file, Debian's chromium for the e2e test). If this
# fails (no npm registry), the viewer e2e test skips with a message instead of failing.
# (--quick leaves it out: viewer_e2e then runs only where an earlier setup installed it.)
if [ "$quick" = 0 ]; then
  bash scripts/setup-viewer.sh --with-chromium --test || echo "test.sh: viewer setup failed; viewer_e2e will skip" >&2
fi
ctest --test-dir build --output-on-failure -j"$jobs"
if [ "$quick" = 1 ]; then
  exit 0
fi

echo "== sanitizers (address, undefined) =="
# (without MPI: OpenMPI's own allocations would swamp LeakSanitizer, and the code the MPI tests
# run is the trainer's, which the sanitizer build covers in tests/train)
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMASKADAPT_SANITIZE=ON \
  -DMASKADAPT_BUILD_EXAMPLES=OFF -DMASKADAPT_BUILD_BENCHMARKS=OFF -DMASKADAPT_WITH_MPI=OFF >/dev/null
cmake --build build-asan -j"$jobs"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j"$jobs" -LE slow

if [ -x scripts/fuzz.sh ]; then
  echo "== fuzzers (bounded) =="
  bash scripts/fuzz.sh --seconds "${MASKADAPT_FUZZ_SECONDS:-60}"
fi

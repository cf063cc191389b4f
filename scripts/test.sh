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

# Wall time of each stage, printed as they end and together at the end (docs/development.md,
# "Measured test times"). `timed NAME CMD…` runs CMD and records how long it took.
stage_times=()
timed() {
  local name=$1 t0=$SECONDS rc=0
  shift
  "$@" || rc=$?
  stage_times+=("$(printf '%-22s %5d s%s' "$name" $((SECONDS - t0)) "$([ "$rc" = 0 ] || echo " (failed: $rc)")")")
  return "$rc"
}
print_stage_times() {
  echo "== test.sh: wall time per stage (total $SECONDS s) =="
  for line in "${stage_times[@]}"; do echo "  $line"; done
}
trap print_stage_times EXIT

# --with-mpi: OpenMPI, so that tests/mpi (2 ranks under mpirun, ~20 s) run too
# (setup.sh also prints its own split: packages and checks vs the Release build)
timed "setup + Release build" bash scripts/setup.sh --with-mpi
# The web viewer (npm packages from its lock file, Debian's chromium for the e2e test). If this
# fails (no npm registry), the viewer e2e test skips with a message instead of failing.
# (--quick leaves it out: viewer_e2e then runs only where an earlier setup installed it.)
if [ "$quick" = 0 ]; then
  timed "viewer setup" bash scripts/setup-viewer.sh --with-chromium --test ||
    echo "test.sh: viewer setup failed; viewer_e2e will skip" >&2
fi
timed "ctest (Release)" ctest --test-dir build --output-on-failure -j"$jobs"
if [ "$quick" = 1 ]; then
  exit 0
fi

echo "== sanitizers (address, undefined) =="
# (without MPI: OpenMPI's own allocations would swamp LeakSanitizer, and the code the MPI tests
# run is the trainer's, which the sanitizer build covers in tests/train)
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMASKADAPT_SANITIZE=ON \
  -DMASKADAPT_BUILD_EXAMPLES=OFF -DMASKADAPT_BUILD_BENCHMARKS=OFF -DMASKADAPT_WITH_MPI=OFF >/dev/null
timed "sanitizer build" cmake --build build-asan -j"$jobs"
timed "sanitizer ctest" env ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j"$jobs" -LE slow

if [ -x scripts/fuzz.sh ]; then
  echo "== fuzzers (bounded) =="
  timed "fuzzers" bash scripts/fuzz.sh --seconds "${MASKADAPT_FUZZ_SECONDS:-60}"
fi

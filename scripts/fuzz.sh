#!/usr/bin/env bash
# Builds the libFuzzer targets of the BVH and npz readers with clang (address + undefined
# sanitizers), writes their seed inputs from the project's own code (tests/fuzz/make_seeds.cpp →
# build-fuzz/seeds/<target>), replays the seeds and every kept crash input
# (tests/fuzz/<target>/regressions), then fuzzes
# each target for a share of a bounded total time. New crash inputs are copied into
# tests/fuzz/<target>/regressions/ (commit them after fixing the crash; the gtest
# FuzzRegressions.* replays them too). Exit status 1 when any input crashes.
#
#   scripts/fuzz.sh                 # 60 s in total
#   scripts/fuzz.sh --seconds 300
#   scripts/fuzz.sh --replay-only   # only replay the kept inputs
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=60
replay_only=0
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds="$2"; shift 2 ;;
    --seconds=*) seconds="${1#*=}"; shift ;;
    --replay-only) replay_only=1; shift ;;
    *) echo "fuzz.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done

cxx=""
for c in clang++ clang++-14 clang++-15 clang++-16; do
  if command -v "$c" >/dev/null 2>&1; then cxx="$c"; break; fi
done
if [ -z "$cxx" ]; then
  echo "fuzz.sh: clang++ not found; skipping the fuzzers (install clang)" >&2
  exit 0
fi

out=build-fuzz
mkdir -p "$out"
eigen_inc=$(pkg-config --cflags-only-I eigen3 2>/dev/null || echo "-I/usr/include/eigen3")
targets=(bvh npz)
for t in "${targets[@]}"; do
  src="tests/fuzz/fuzz_${t}.cpp"
  bin="$out/fuzz_${t}"
  if [ ! -x "$bin" ] || [ "$src" -nt "$bin" ] || [ -n "$(find include/maskadapt/motion -newer "$bin" -print -quit)" ]; then
    echo "== building $bin"
    "$cxx" -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined \
      -Iinclude $eigen_inc "$src" -lz -o "$bin"
  fi
done
seeds_bin="$out/make_seeds"
if [ ! -x "$seeds_bin" ] || [ -n "$(find tests/fuzz include/maskadapt/motion include/maskadapt/humanoid -newer "$seeds_bin" -print -quit)" ]; then
  echo "== building $seeds_bin"
  "$cxx" -std=c++20 -O1 -Iinclude $eigen_inc tests/fuzz/make_seeds.cpp -lz -o "$seeds_bin"
fi
rm -rf "$out/seeds"
"$seeds_bin" "$out/seeds"

status=0
for t in "${targets[@]}"; do
  bin="$out/fuzz_${t}"
  kept=()
  for d in "$out/seeds/$t" "tests/fuzz/$t/regressions"; do
    [ -d "$d" ] && while IFS= read -r -d '' f; do kept+=("$f"); done < <(find "$d" -type f -print0)
  done
  echo "== replaying ${#kept[@]} kept inputs for $t"
  if [ "${#kept[@]}" -gt 0 ] && ! "$bin" -runs=0 "${kept[@]}" >"$out/replay_${t}.log" 2>&1; then
    echo "fuzz.sh: a kept input crashes fuzz_$t; see $out/replay_${t}.log" >&2
    tail -30 "$out/replay_${t}.log" >&2
    status=1
  fi
done
[ "$replay_only" = 1 ] && exit $status

per=$(( seconds / ${#targets[@]} ))
[ "$per" -lt 1 ] && per=1
for t in "${targets[@]}"; do
  bin="$out/fuzz_${t}"
  work="$out/corpus_${t}"
  art="$out/artifacts_${t}/"
  mkdir -p "$work" "$art"
  echo "== fuzzing $t for ${per}s"
  if ! "$bin" -max_total_time="$per" -max_len=65536 -rss_limit_mb=2048 -timeout=10 \
      -artifact_prefix="$art" "$work" "$out/seeds/$t" >"$out/fuzz_${t}.log" 2>&1; then
    status=1
    echo "fuzz.sh: fuzz_$t found a crash:" >&2
    tail -40 "$out/fuzz_${t}.log" >&2
  fi
  for f in "$art"*; do
    [ -f "$f" ] || continue
    dest="tests/fuzz/$t/regressions/$(basename "$f")"
    cp "$f" "$dest" && echo "fuzz.sh: kept $dest (fix the crash, then commit it)"
  done
  grep -E "^#[0-9]+.*DONE|stat::number_of_executed_units" "$out/fuzz_${t}.log" | tail -1 || true
done
exit $status

#!/usr/bin/env bash
# Whole-loop training throughput of two `maskadapt` binaries in one sitting (issue 13,
# docs/benchmarks.md "Whole training loop"): the cpu preset on `locomotion`, 30 iterations,
# alternating the binaries, at each thread count, REPS times; prints the mean of iterations 5–30
# of each run's log.jsonl (samples/s and the sim / inference / update (discriminator) split).
#
#   scripts/measure_throughput.sh BEFORE_BIN AFTER_BIN [OUT_DIR]    # env: REPS="1 2", THREADS="2 1"
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: $0 BEFORE_BIN AFTER_BIN [OUT_DIR]" >&2; exit 2; }
for b in "$1" "$2"; do [ -x "$b" ] || { echo "$0: '$b' is not an executable" >&2; exit 2; }; done
out=${3:-runs/throughput}
mkdir -p "$out"
for rep in ${REPS:-1 2}; do
  for T in ${THREADS:-2 1}; do
    for which in before after; do
      bin=$1; [ $which = after ] && bin=$2
      d=$out/${which}_t${T}_r$rep; rm -rf "$d"
      "$bin" train-base --preset cpu --motions locomotion --iterations 30 --threads "$T" --seed 1 \
          --checkpoint-every 1000 --out "$d" > "$d.txt" 2>&1
      python3 - "$d/log.jsonl" "$which" "$T" "$rep" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
sel = [r for r in rows if 5 <= r["iteration"] <= 30]
mean = lambda k: sum(r[k] for r in sel) / len(sel)
tot = mean("time_sim") + mean("time_inference") + mean("time_update")
print(f"{sys.argv[2]:6s} threads {sys.argv[3]} rep {sys.argv[4]}: {mean('samples_per_s'):7.0f} samples/s  "
      f"sim {mean('time_sim')/tot:.0%} inf {mean('time_inference')/tot:.0%} upd {mean('time_update')/tot:.0%} "
      f"(disc {mean('time_disc')/tot:.0%})  update {mean('time_update')*1000:.0f} ms  sim {mean('time_sim')*1000:.0f} ms")
PY
    done
  done
done

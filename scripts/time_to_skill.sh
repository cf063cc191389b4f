#!/usr/bin/env bash
# Time to skill (issue 40): a mask-invariant base trained from scratch (no resumed snapshot) with the
# cpu recipe, then the walking bar's evaluation of every kept checkpoint against wall time.
#
#   SEED=1 THREADS=2 MINUTES=40 scripts/time_to_skill.sh [extra train-base flags]
#
# 1. `train-base --preset cpu --motions bandai-walk --threads THREADS --seed SEED --minutes MINUTES
#    --checkpoint-every PERIOD --keep-checkpoints` (stops at the cpu preset's 7,800 iterations or at
#    MINUTES, whichever comes first); nothing else runs on the machine meanwhile, so its wall time is
#    the figure. A directory that already holds a log is not trained again.
# 2. After the run (so that evaluation does not slow training), every checkpoint_<it>.bin from
#    FROM_IT on: `eval-base --envs 32 --frames 300 --deterministic --masks none legs` (32 ten-second
#    episodes per mask and start, policy mean), the bar of issue "The base policy walks": <= 10 % falls with the null
#    mask and with both legs masked.
# 3. Prints one line per checkpoint: iteration, samples, wall time (log.jsonl's elapsed_s), falls and
#    mean episode length for both masks and both starts (RSI, one shared start), and the first
#    checkpoint that meets the bar. Writes OUT/time_to_skill.tsv.
#
# Docs: docs/results.md, "Time to skill".
set -euo pipefail
cd "$(dirname "$0")/.."

BIN=${BIN:-build/bin/maskadapt}
SEED=${SEED:-1}
THREADS=${THREADS:-2}
MINUTES=${MINUTES:-40}
PERIOD=${PERIOD:-300}
FROM_IT=${FROM_IT:-4800}
EVAL_THREADS=${EVAL_THREADS:-2}
BAR=${BAR:-0.10}
OUT=${OUT:-runs/tts/s${SEED}}

[ -x "$BIN" ] || { echo "time_to_skill.sh: no binary at $BIN (scripts/setup.sh --cli-only builds it)" >&2; exit 2; }
case "$SEED$THREADS$PERIOD$FROM_IT" in *[!0-9]*) echo "time_to_skill.sh: SEED, THREADS, PERIOD and FROM_IT must be integers" >&2; exit 2 ;; esac

if [ ! -s "$OUT/log.jsonl" ]; then
  mkdir -p "$OUT"
  "$BIN" train-base --preset cpu --motions bandai-walk --threads "$THREADS" --seed "$SEED" --minutes "$MINUTES" \
    --iterations 7800 --checkpoint-every "$PERIOD" --keep-checkpoints --out "$OUT" "$@" | tee "$OUT/train.txt"
else
  echo "time_to_skill.sh: $OUT/log.jsonl exists; evaluating its checkpoints only"
fi

for ckpt in "$OUT"/checkpoint_*.bin; do
  it=${ckpt##*_}; it=${it%.bin}
  [ "$it" -ge "$FROM_IT" ] || continue
  [ -s "$OUT/eval_$it.json" ] && continue
  "$BIN" eval-base "$ckpt" --envs 32 --frames 300 --deterministic --masks none legs --threads "$EVAL_THREADS" \
    --json "$OUT/eval_$it.json" > "$OUT/eval_$it.txt"
done

python3 - "$OUT" "$BAR" <<'EOF'
import json, glob, os, re, sys
out, bar = sys.argv[1], float(sys.argv[2])
log = {}
with open(os.path.join(out, "log.jsonl")) as f:
    for line in f:
        r = json.loads(line)
        log[r["iteration"]] = r
rows = []
for path in glob.glob(os.path.join(out, "eval_*.json")):
    it = int(re.search(r"eval_(\d+)\.json$", path).group(1))
    with open(path) as f:
        ev = json.load(f)
    masks = {m["mask"]: m for m in ev["masks"]}
    rows.append((it, masks["none"], masks["left_leg,right_leg"]))
rows.sort(key=lambda r: r[0])
head = "iteration\tsamples\twall_min\tfalls_none_rsi\tfalls_none_shared\tfalls_legs_rsi\tfalls_legs_shared\tlen_none_rsi_s\tlen_legs_rsi_s"
lines, first = [head], None
for it, none, legs in rows:
    r = log.get(it)
    if r is None:
        continue
    f = lambda m, s: m[s]["fall_rate"] if m[s]["fall_rate"] is not None else 0.0
    falls = [f(none, "rsi"), f(none, "shared"), f(legs, "rsi"), f(legs, "shared")]
    lines.append("%d\t%d\t%.1f\t%.3f\t%.3f\t%.3f\t%.3f\t%.2f\t%.2f" % (
        it, r["samples"], r["elapsed_s"] / 60, *falls,
        none["rsi"]["mean_episode_length"] or 0, legs["rsi"]["mean_episode_length"] or 0))
    if first is None and max(falls) <= bar:
        first = (it, r["samples"], r["elapsed_s"] / 60)
with open(os.path.join(out, "time_to_skill.tsv"), "w") as f:
    f.write("\n".join(lines) + "\n")
print("\n".join(lines))
if first:
    print("first checkpoint at the bar (<= %.0f %% falls, null mask and both legs masked, both starts): "
          "iteration %d, %.2f M samples, %.1f min" % (bar * 100, first[0], first[1] / 1e6, first[2]))
else:
    print("no checkpoint meets the bar (<= %.0f %% falls, null mask and both legs masked, both starts)" % (bar * 100))
EOF

#!/usr/bin/env bash
# Table 2 (issue 15): composition cases (a)–(c) × ours / CML-style × seeds on the frozen walking
# base, one run at a time, each at the same iteration budget, then eval-residual (10 envs × 1,000
# frames, H_norm at 0.1 m and at 0.3 m per body) and the frozen base as the control of each case.
#
#   scripts/table2_grid.sh                       # every cell, seeds 1 and 2; cells already evaluated are skipped
#   CELLS="b_ours b_cml" SEEDS="3 4" scripts/table2_grid.sh
#   ITERATIONS=1000 THREADS=1 OUT=runs/t2 BIN=build/bin/maskadapt scripts/table2_grid.sh
#   CELLS="a_ours a_cml" EXTRA_ARGS="--blend-resets 0.5" OUT=runs/t2br scripts/table2_grid.sh
#                                                # extra train-residual flags for every cell (own OUT)
#   CELLS="k_ours k_cml" SEEDS="1 2 3" scripts/table2_grid.sh
#                                                # case (a) with B cut down to the kick itself
#   CELLS="k_ours k_cml" BLEND_RESETS_K=0 OUT=runs/t2k0 scripts/table2_grid.sh   # …without the blend resets
#
# Resumable and extendable like scripts/table3_grid.sh: a cell whose checkpoint exists continues it
# (--resume, bit-exact) up to ITERATIONS; a cell with an eval_it<ITERATIONS>.txt is done.
#
# The cases, with what this machine has (no jumping base, no aiming clip; docs/results.md):
# (a) styles/kick on the lower body; (b) styles/swim on the arms (the arm-rotation stand-in), with the
# residual exploring at σ 0.15 (RESIDUAL_STD_B; at the base's σ the arms never reach the swim);
# (c) styles/SNEAKY on the lower body (the walking upper body stands in for aiming). The legs keep
# the base's σ: a wider one makes the walker fall in training (docs/composition.md).
# (k) is case (a) with B cut down to the kick (2.6–3.7 s of styles/kick: the step into the kick, the
# kick, the landing; imported once into $OUT/kick_cut.npz) and a share BLEND_RESETS_K (0.5) of the
# episodes started from its blends: the whole clip is 90 % standing and stepping, and with it
# neither method kicks (docs/results.md, case (a)).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/grid_lib.sh

BIN=${BIN:-build/bin/maskadapt}
BASE=${BASE:-models/table1/mask_mi03_s1.bin}
ITERATIONS=${ITERATIONS:-1000}
THREADS=${THREADS:-1}
SEEDS=${SEEDS:-"1 2"}
OUT=${OUT:-runs/t2}
RESIDUAL_STD_B=${RESIDUAL_STD_B:-0.15}
DATA=${MASKADAPT_DATA_DIR:-../shared/data}/motions
CELLS=${CELLS:-"a_ours a_cml b_ours b_cml c_ours c_cml"}
EXTRA_ARGS=${EXTRA_ARGS:-}
BLEND_RESETS_K=${BLEND_RESETS_K:-0.5}
KICK_CUT="$OUT/kick_cut.npz"

motion_for() {
  case "$1" in
    a) echo "$DATA/styles/kick.bvh" ;;
    b) echo "$DATA/styles/swim.bvh" ;;
    c) echo "$DATA/styles/SNEAKY.bvh" ;;
    k) echo "$KICK_CUT" ;;
    *) echo "table2_grid: unknown case '$1' in CELLS (a, b, c or k)" >&2; exit 2 ;;
  esac
}
mask_for() { [[ "$1" == b ]] && echo arms || echo lower_body; }
# the case's own train-residual flags: σ 0.15 on the arms of (b), the blend resets of (k)
case_args() {
  case "$1" in
    b) echo "--residual-std $RESIDUAL_STD_B" ;;
    k) echo "--blend-resets $BLEND_RESETS_K" ;;
  esac
}

# B of case (k): the kick alone, cut from styles/kick (written to a temporary name, then moved, so two
# grids started together never read half a file)
if [[ " $CELLS " == *" k_"* && ! -f "$KICK_CUT" ]]; then
  if [[ "$DRY_RUN" == 1 ]]; then
    cmd "$BIN" motion import "$DATA/styles/kick.bvh" --from 2.6 --to 3.7 --out "$KICK_CUT"
  else
    mkdir -p "$OUT"
    "$BIN" motion import "$DATA/styles/kick.bvh" --from 2.6 --to 3.7 --out "$KICK_CUT.$$.npz" >/dev/null
    mv "$KICK_CUT.$$.npz" "$KICK_CUT"
  fi
fi

# evaluate CHECKPOINT RESULT — both thresholds into one text file (written last: its presence means
# done), and each as JSON beside it (RESULT without .txt, + _0.1.json / _0.3.json: the per-frame visits
# of B, for `plot_results.py visits`).
evaluate() {
  if [[ "$DRY_RUN" == 1 ]]; then
    cmd "$BIN" eval-residual "$1" --task composition --envs 10 --frames 1000 --out "${2%.txt}_0.1.json"
    cmd "$BIN" eval-residual "$1" --task composition --envs 10 --frames 1000 --threshold 0.3 --out "${2%.txt}_0.3.json"
    return 0
  fi
  { "$BIN" eval-residual "$1" --task composition --envs 10 --frames 1000 --out "${2%.txt}_0.1.json"
    "$BIN" eval-residual "$1" --task composition --envs 10 --frames 1000 --threshold 0.3 --out "${2%.txt}_0.3.json"; } > "$2.tmp"
  mv "$2.tmp" "$2"
  cat "$2"
}

for cell in $CELLS; do
  case_=${cell%_*}
  method=${cell#*_}
  [[ "$method" == ours || "$method" == cml ]] || { echo "table2_grid: unknown method in '$cell' (ours or cml)" >&2; exit 2; }
  motion=$(motion_for "$case_")
  # the control: the frozen base with the same mask (one iteration: the residual's output is still zero)
  control="$OUT/${case_}_control"
  if [[ ! -f "$control/eval_it1.txt" ]]; then
    # shellcheck disable=SC2086
    quiet "$BIN" train-residual --task composition --method ours --base "$BASE" --new-motion $motion \
      --masks "$(mask_for "$case_")" --threads "$THREADS" --seed 1 --iterations 1 --out "$control"
    say "== ${case_}_control (the frozen base)"
    evaluate "$control/checkpoint.bin" "$control/eval_it1.txt"
  fi
  for seed in $SEEDS; do
    dir="$OUT/${cell}_s$seed"
    result="$dir/eval_it$ITERATIONS.txt"
    already_done "${cell}_s$seed" "$result" && continue
    say "== ${cell}_s$seed: $(date -u +%H:%M:%S) training to $ITERATIONS iterations in $dir"
    # shellcheck disable=SC2046
    train_or_resume "$dir" "$ITERATIONS" --task composition --method "$method" --base "$BASE" \
      --new-motion $motion --masks "$(mask_for "$case_")" $(case_args "$case_") $EXTRA_ARGS --threads "$THREADS" --seed "$seed"
    evaluate "$dir/checkpoint.bin" "$result"
  done
done

#!/usr/bin/env bash
# Table 3 (issue 16): the 3 tasks × 3 methods grid on a frozen walking base, one run at a time,
# each at the same iteration budget, then eval-residual over >= 200 trials on evaluation seed 1001.
#
#   scripts/table3_grid.sh                       # every cell, in order; cells already evaluated are skipped
#   CELLS="heading_ours heading_cml" scripts/table3_grid.sh
#   ITERATIONS=1500 THREADS=2 SEED=1 OUT=runs/t3 BIN=build/bin/maskadapt scripts/table3_grid.sh
#
# Resumable and extendable: a cell whose checkpoint exists continues it (--resume, bit-exact) up to
# ITERATIONS; a cell with an eval_it<ITERATIONS>.json is done. So a longer budget continues the same
# runs: ITERATIONS=4800 scripts/table3_grid.sh. Stop it at any time (Ctrl-C checkpoints first).
#
# Motions composed (B), masks and goal parts of each task: goal_cell_args in scripts/grid_lib.sh.
# FORMULATION=recipe (the default): train-residual's cpu preset, the stage-2 recipe of issue 39
# (train/goal_recipe.hpp); FORMULATION=paper: the paper's goal rewards (the shipped models/table3 cells).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/grid_lib.sh

BIN=${BIN:-build/bin/maskadapt}
BASE=${BASE:-models/mask_mi_walk_bandai.bin}
ITERATIONS=${ITERATIONS:-1500}
THREADS=${THREADS:-2}
SEED=${SEED:-1}
OUT=${OUT:-runs/t3}
TRIALS=${TRIALS:-200}
EVAL_SEED=${EVAL_SEED:-1001}   # no training run uses it
EVAL_ENVS=${EVAL_ENVS:-16}
DATA=${MASKADAPT_DATA_DIR:-../shared/data}/motions
FORMULATION=${FORMULATION:-recipe}
[[ "$FORMULATION" == paper || "$FORMULATION" == recipe ]] || { echo "table3_grid.sh: FORMULATION must be paper or recipe" >&2; exit 2; }
CELLS=${CELLS:-"location_ours location_cml location_adaptnet heading_ours heading_cml heading_adaptnet strike_ours strike_cml strike_adaptnet"}

for cell in $CELLS; do
  task=${cell%_*}
  method=${cell#*_}
  dir="$OUT/${cell}_s$SEED"
  result="$dir/eval_it$ITERATIONS.json"
  already_done "$cell" "$result" && continue
  say "== $cell: $(date -u +%H:%M:%S) training to $ITERATIONS iterations in $dir"
  # shellcheck disable=SC2046
  train_or_resume "$dir" "$ITERATIONS" --task "$task" --method "$method" --base "$BASE" \
    $(goal_cell_args "$task" "$DATA") \
    $([[ "$FORMULATION" == paper ]] && paper_formulation_args "$task" "$method" 1) \
    --threads "$THREADS" --seed "$SEED"
  cmd "$BIN" eval-residual "$dir/checkpoint.bin" --task "$task" --envs "$EVAL_ENVS" --trials "$TRIALS" --seed "$EVAL_SEED" --out "$result"
done

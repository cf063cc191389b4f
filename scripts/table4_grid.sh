#!/usr/bin/env bash
# Table 4 (issue 15, part 3): text-driven partial tracking, arms designated, with the shipped text
# generator (models/text_generator.bin, issue 19) — ours (mask-invariant base + residual), CML-style
# (the same base without its mask input + residual) and from scratch (no base) — one run at a time at
# the same iteration budget, then eval-residual: 10 prompts × 5 s × 3 repeats.
#
#   scripts/table4_grid.sh                       # every cell, in order; cells already evaluated are skipped
#   CELLS="ours cml" scripts/table4_grid.sh
#   ITERATIONS=1500 THREADS=2 SEED=1 OUT=runs/t4 BIN=build/bin/maskadapt scripts/table4_grid.sh
#
# Resumable and extendable like scripts/table3_grid.sh: a cell whose checkpoint exists continues it
# (--resume, bit-exact) up to ITERATIONS; a cell with an eval_it<ITERATIONS>.json is done.
#
# FORMULATION=recipe (the default): train-residual's cpu preset, whose tracking is the stage-2
# recipe of issue 39 (the goal weighted 0.9, σ 0.5 on the arms; train/goal_recipe.hpp);
# FORMULATION=paper: the paper's weights and the base's σ (the shipped models/table4 cells).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/grid_lib.sh

BIN=${BIN:-build/bin/maskadapt}
BASE=${BASE:-models/mask_mi_walk_bandai.bin}
GENERATOR=${GENERATOR:-models/text_generator.bin}
MOTIONS=${MOTIONS:-bandai-walk}   # scratch's imitation set: the base's own walks
ITERATIONS=${ITERATIONS:-1500}
THREADS=${THREADS:-2}
SEED=${SEED:-1}
OUT=${OUT:-runs/t4}
CELLS=${CELLS:-"ours cml scratch"}
FORMULATION=${FORMULATION:-recipe}
[[ "$FORMULATION" == paper || "$FORMULATION" == recipe ]] || { echo "table4_grid.sh: FORMULATION must be paper or recipe" >&2; exit 2; }

for method in $CELLS; do
  dir="$OUT/tracking_${method}_s$SEED"
  result="$dir/eval_it$ITERATIONS.json"
  already_done "$method" "$result" && continue
  say "== $method: $(date -u +%H:%M:%S) training to $ITERATIONS iterations in $dir"
  if [[ "$method" == scratch ]]; then base=(--motions "$MOTIONS"); else base=(--base "$BASE"); fi
  # shellcheck disable=SC2046
  train_or_resume "$dir" "$ITERATIONS" --task tracking --method "$method" "${base[@]}" --generator "$GENERATOR" \
    --designated arms --threads "$THREADS" --seed "$SEED" $([[ "$FORMULATION" == paper ]] && paper_formulation_args tracking "$method" 0)
  cmd "$BIN" eval-residual "$dir/checkpoint.bin" --task tracking --num-prompts 10 --seconds 5 --repeats 3 --out "$result"
done

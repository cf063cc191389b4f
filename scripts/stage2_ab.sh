#!/usr/bin/env bash
# Stage-2 recipe A/B runs (issue 39): one variant of a Table 3 cell (task × method; the composed
# motion and masks: goal_cell_args in scripts/grid_lib.sh) trained to a fixed sample budget, then evaluated with
# the policy mean over >= TRIALS trials on an evaluation seed no training run uses.
#
#   VARIANT=hold10 TASK=location METHOD=ours SEED=1 ITERATIONS=600 THREADS=1 \
#       scripts/stage2_ab.sh --noise-hold-steps 10        # extra train-residual flags after the script
#
# FORMULATION=paper (the default): each variant's flags on top of the paper's goal rewards, as every
# A/B table of docs/results.md measured them; FORMULATION=recipe: on top of the cpu preset's stage-2
# recipe (train-residual's own default since issue 39; train/goal_recipe.hpp).
#
# Writes runs/ab/<task>_<method>_<variant>_s<seed>/ (log.jsonl, checkpoint.bin, eval_it<N>.json/.txt).
# Resumable: a directory with a checkpoint continues it (--resume, bit-exact) to ITERATIONS; a
# variant with its eval file is skipped. Docs: docs/results.md, "Stage 2 recipe".
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/grid_lib.sh

BIN=${BIN:-build/bin/maskadapt}
BASE=${BASE:-models/mask_mi_walk_bandai.bin}
TASK=${TASK:-location}
METHOD=${METHOD:-ours}
VARIANT=${VARIANT:?set VARIANT to name this variant}
ITERATIONS=${ITERATIONS:-600}
THREADS=${THREADS:-1}
SEED=${SEED:-1}
EVAL_SEED=${EVAL_SEED:-1001}
TRIALS=${TRIALS:-200}
EVAL_ENVS=${EVAL_ENVS:-16}
OUT=${OUT:-runs/ab}
DATA=${MASKADAPT_DATA_DIR:-../shared/data}/motions
# the cell's composed motion, masks and goal parts (CELL_ARGS="--masks lower_body": the goal alone,
# with an imitation discriminator of the base's walks)
CELL_ARGS=${CELL_ARGS:-$(goal_cell_args "$TASK" "$DATA")}
FORMULATION=${FORMULATION:-paper}
case "$FORMULATION" in
  paper) composes=0; [[ " $CELL_ARGS " == *" --new-motion "* ]] && composes=1
         FORMULATION_ARGS=$(paper_formulation_args "$TASK" "$METHOD" "$composes" "$@") ;;
  recipe) FORMULATION_ARGS="" ;;
  *) echo "stage2_ab.sh: FORMULATION must be paper or recipe, not '$FORMULATION'" >&2; exit 2 ;;
esac

dir="$OUT/${TASK}_${METHOD}_${VARIANT}_s$SEED"
result="$dir/eval_it$ITERATIONS.json"
already_done "$dir" "$result" && exit 0
say "== $dir: $(date -u +%H:%M:%S) training to $ITERATIONS iterations"
# shellcheck disable=SC2046
train_or_resume "$dir" "$ITERATIONS" --task "$TASK" --method "$METHOD" --base "$BASE" \
  $CELL_ARGS $FORMULATION_ARGS --threads "$THREADS" --seed "$SEED" "$@"
if [[ "$DRY_RUN" == 1 ]]; then
  cmd "$BIN" eval-residual "$dir/checkpoint.bin" --task "$TASK" --envs "$EVAL_ENVS" --trials "$TRIALS" --seed "$EVAL_SEED" --out "$result"
else
  "$BIN" eval-residual "$dir/checkpoint.bin" --task "$TASK" --envs "$EVAL_ENVS" --trials "$TRIALS" --seed "$EVAL_SEED" \
    --out "$result" | tee "${result%.json}.txt"
fi

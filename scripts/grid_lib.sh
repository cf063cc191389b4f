# Shared by the table grids (scripts/table2_grid.sh, scripts/table3_grid.sh, scripts/table4_grid.sh); source it, with BIN set.
#
# DRY_RUN=1 (scripts/reproduce_results.sh passes it on): the grids print each maskadapt command they
# would run, one shell-quoted line on stdout, run none and write nothing; progress goes to stderr.
DRY_RUN=${DRY_RUN:-0}

# cmd ARGS... — runs ARGS, or under DRY_RUN=1 prints them as one line.
cmd() {
  if [[ "$DRY_RUN" == 1 ]]; then
    local line
    line=$(printf '%q ' "$@")
    echo "${line% }"
  else
    "$@"
  fi
}

# quiet ARGS... — cmd with the command's stdout discarded.
quiet() {
  if [[ "$DRY_RUN" == 1 ]]; then cmd "$@"; else "$@" >/dev/null; fi
}

# say TEXT... — a progress line: on stdout, or on stderr under DRY_RUN=1 (stdout then holds commands only).
say() {
  if [[ "$DRY_RUN" == 1 ]]; then echo "$*" >&2; else echo "$*"; fi
}

# train_or_resume DIR ITERATIONS TRAIN_RESIDUAL_ARGS... — trains the cell in DIR to ITERATIONS: a
# new run with the given arguments, or, when DIR already holds a checkpoint, that run continued
# (--resume, bit-exact; the arguments are then the checkpoint's own).
#
# A run stopped by a signal (SIGINT / SIGTERM) checkpoints and exits 0 before its budget, so the
# run's log is checked: if its last iteration is short of ITERATIONS, this fails (exit 3) and the
# caller evaluates nothing — an evaluation file named for ITERATIONS must hold that iteration's policy.
train_or_resume() {
  local dir="$1" iterations="$2"
  shift 2
  if [[ -f "$dir/checkpoint.bin" ]]; then
    cmd "$BIN" train-residual --resume "$dir/checkpoint.bin" --iterations "$iterations" --out "$dir"
  else
    cmd "$BIN" train-residual "$@" --iterations "$iterations" --out "$dir"
  fi
  [[ "$DRY_RUN" == 1 ]] && return 0
  local last
  last=$(tail -n 1 "$dir/log.jsonl" 2>/dev/null | grep -o '"iteration":[0-9]*' | cut -d: -f2)
  if [[ "${last:-0}" -lt "$iterations" ]]; then
    echo "train_or_resume: $dir stopped at iteration ${last:-0} of $iterations (a signal?); not evaluated — rerun to resume" >&2
    return 3
  fi
}

# already_done NAME RESULT — true, and says so, when the cell's result file exists (the grids skip it).
already_done() {
  [[ -f "$2" ]] || return 1
  say "== $1: done ($2)"
}

# goal_cell_args TASK DATA — the composed motion, mask and goal parts of a Table 3 cell (train-residual
# flags): location — styles/swim on the arms (the arm-rotation stand-in of Table 2 (b): no rotate-arms
# clip is in ../shared/data); heading — SNEAKY on the legs; strike — the Bandai punches on the arms.
# Where the composed motion is on the arms, the residual also moves the legs for the goal
# (--goal-parts lower_body): a residual on the arms alone cannot walk to a target or a box (measured:
# location 4 %). DATA is the motions folder (…/shared/data/motions).
goal_cell_args() {
  case "$1" in
    location) echo "--new-motion $2/styles/swim.bvh --masks arms --goal-parts lower_body" ;;
    heading) echo "--new-motion $2/styles/SNEAKY.bvh --masks lower_body" ;;
    strike) echo "--new-motion $2/bandai/actions/dataset-1_punch_normal_001.bvh $2/bandai/actions/dataset-1_punch_normal_002.bvh --masks arms --goal-parts lower_body" ;;
    *) echo "goal_cell_args: unknown task '$1' (location, heading or strike)" >&2; return 2 ;;
  esac
}

# paper_formulation_args TASK METHOD COMPOSES [FLAGS...] — the train-residual flags that give a goal-task
# or tracking run the paper's rewards (train/goal_recipe.hpp, preset "paper") at the cpu preset's settings, since
# train-residual's default (--preset cpu) is the stage-2 recipe: the paper's objective weights (ours
# composing B: 1 0.5; CML-style / AdaptNet composing B: 0.5 0.5 0.5; without B and tracking: 0.5 0.5), no
# shaping term, strike's one box per episode that any body may touch, and tracking's residual at the
# base's σ with the reward exp(−Σ angle²) ended below 0.05. COMPOSES is 1 when the run composes a motion B. Flags already among FLAGS (a
# variant's own) are left out, so that a variant changes one thing on top of the paper's formulation.
paper_formulation_args() {
  local task=$1 method=$2 composes=$3
  shift 3
  local given=" $* " out=""
  if [[ $given != *" --objective-weights "* ]]; then
    if [[ $composes == 1 && $method == ours ]]; then out="--objective-weights 1 0.5"
    elif [[ $composes == 1 ]]; then out="--objective-weights 0.5 0.5 0.5"
    else out="--objective-weights 0.5 0.5"; fi
  fi
  if [[ $task == location && $given != *" --location-facing-weight "* ]]; then out="$out --location-facing-weight 0"; fi
  if [[ $task == strike && $given != *" --strike-approach-weight "* ]]; then out="$out --strike-approach-weight 0"; fi
  # (the recipe's strike since round 5: a new box after each tilt, the foreign-contact end)
  if [[ $task == strike && $given != *" --strike-next-box "* ]]; then out="$out --strike-next-box 0"; fi
  if [[ $task == strike && $given != *"strike-end-on-foreign-contact "* ]]; then
    out="$out --no-strike-end-on-foreign-contact"
  fi
  # (the recipe's tracking since 2026-12-07: σ 0.5 on the designated parts; 0 is the base's σ)
  if [[ $task == tracking && $given != *" --residual-std "* && $given != *" --part-std "* ]]; then
    out="$out --residual-std 0"
  fi
  # (and since 2026-12-08: the reward exp(-2·Σ angle²), ended below 0.0025; the paper's k 1 and 0.05)
  if [[ $task == tracking && $given != *" --tracking-reward-scale "* ]]; then out="$out --tracking-reward-scale 1"; fi
  if [[ $task == tracking && $given != *" --term-threshold "* ]]; then out="$out --term-threshold 0.05"; fi
  echo "$out"
}

# Shared by the table grids (scripts/table2_grid.sh, scripts/table3_grid.sh, scripts/table4_grid.sh); source it, with BIN set.

# train_or_resume DIR ITERATIONS TRAIN_RESIDUAL_ARGS... — trains the cell in DIR to ITERATIONS: a
# new run with the given arguments, or, when DIR already holds a checkpoint, that run continued
# (--resume, bit-exact; the arguments are then the checkpoint's own).
train_or_resume() {
  local dir="$1" iterations="$2"
  shift 2
  if [[ -f "$dir/checkpoint.bin" ]]; then
    "$BIN" train-residual --resume "$dir/checkpoint.bin" --iterations "$iterations" --out "$dir"
  else
    "$BIN" train-residual "$@" --iterations "$iterations" --out "$dir"
  fi
}

# already_done NAME RESULT — true, and says so, when the cell's result file exists (the grids skip it).
already_done() {
  [[ -f "$2" ]] || return 1
  echo "== $1: done ($2)"
}

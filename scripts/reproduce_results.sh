#!/usr/bin/env bash
# Reproduces the results pages. stage1 and stage2 are the 2026-11-23 wave-1 runs, now in
# docs/history.md: the stage-1 ablation (AMP, masking without MI, λ_MI 0.1 and 1.0), its
# evaluation, and the short stage-2 composition and tracking comparisons. recipe is
# docs/results.md's "Stage 2 recipe (issue 39)". table2, table3 and table4 run the grids of
# docs/results.md's Tables 2–4 with the commands written there.
#
#   MINUTES=30 STAGE2_MINUTES=10 scripts/reproduce_results.sh [stage1|stage2|recipe|table2|table3|table4|all]
#
# Needs build/bin/maskadapt (scripts/setup.sh) and the CMU clips (MASKADAPT_DATA_DIR, default
# ../shared/data). Runs go to runs/; every process is single-threaded (--threads 1) so that several
# run side by side on a small machine. Budgets are wall-clock minutes per run.
set -euo pipefail
cd "$(dirname "$0")/.."
cli=${CLI:-build/bin/maskadapt}
export MASKADAPT_DATA_DIR=${MASKADAPT_DATA_DIR:-$(cd ../shared/data && pwd)}
D=$MASKADAPT_DATA_DIR/motions/cmu
MINUTES=${MINUTES:-30}
STAGE2_MINUTES=${STAGE2_MINUTES:-10}
what=${1:-all}
mkdir -p runs

stage1() {
  for v in amp mask_no_mi mi_0.1 mi_1.0; do
    "$cli" train-base --config configs/ablation/$v.json --minutes "$MINUTES" --threads 1 \
      --out runs/ablation/$v > runs/ablation_$v.out 2>&1 &
  done
  wait
  for v in amp mask_no_mi mi_0.1 mi_1.0; do
    "$cli" eval-base runs/ablation/$v/checkpoint.bin --envs 4 --frames 300 --threads 1 \
      --json runs/ablation/$v/hnorm.json > runs/ablation/$v/hnorm.txt &
    for mask in none left_leg,right_leg left_arm,right_arm; do
      "$cli" play runs/ablation/$v/checkpoint.bin --mask "$mask" --seconds 10 --seed 1 --deterministic \
        --bvh runs/ablation/$v/play_${mask//,/_}.bvh --csv runs/ablation/$v/root_${mask//,/_}.csv \
        --rollout runs/ablation/$v/play_${mask//,/_}.json > /dev/null
    done
  done
  wait
}

stage2() {
  local base=runs/ablation/mi_1.0/checkpoint.bin   # locomotion base with masking + MI
  local m=$STAGE2_MINUTES
  # Bases for cases (a) jump and (c) swordplay ("aim"-like upper body).
  "$cli" train-base --config configs/ablation/mi_1.0.json --motions "$D/02_04_jump.bvh" --minutes "$m" \
    --threads 1 --out runs/base_jump > runs/base_jump.out 2>&1 &
  "$cli" train-base --config configs/ablation/mi_1.0.json --motions "$D/02_07_swordplay.bvh" --minutes "$m" \
    --threads 1 --out runs/base_aim > runs/base_aim.out 2>&1 &
  "$cli" train-generator --minutes "$m" --out runs/gen.ckpt > runs/gen.out 2>&1 &
  for meth in ours cml; do   # case (b): locomotion + arm rotation / expressive arms on both arms
    "$cli" train-residual --task composition --method $meth --base $base --new-motion arms "$D/05_02_expressive_arms.bvh" \
      --masks arms --minutes "$m" --threads 1 --out runs/b_$meth > runs/b_$meth.out 2>&1 &
  done
  wait
  for meth in ours cml; do
    "$cli" train-residual --task composition --method $meth --base runs/base_jump/checkpoint.bin \
      --new-motion "$D/135_04_front_kick.bvh" "$D/05_05_leg_raise.bvh" kick --masks lower_body --minutes "$m" \
      --threads 1 --out runs/a_$meth > runs/a_$meth.out 2>&1 &
    "$cli" train-residual --task composition --method $meth --base runs/base_aim/checkpoint.bin \
      --new-motion "$D/09_12_navigate_walk.bvh" --masks lower_body --minutes "$m" \
      --threads 1 --out runs/c_$meth > runs/c_$meth.out 2>&1 &
  done
  for meth in ours cml; do
    "$cli" train-residual --task tracking --method $meth --base $base --generator runs/gen.ckpt --minutes "$m" \
      --threads 1 --out runs/track_$meth > runs/track_$meth.out 2>&1 &
  done
  "$cli" train-residual --task tracking --method scratch --motions locomotion --generator runs/gen.ckpt \
    --minutes "$m" --threads 1 --out runs/track_scratch > runs/track_scratch.out 2>&1 &
  wait
  for r in a_ours a_cml b_ours b_cml c_ours c_cml; do
    "$cli" eval-residual runs/$r/checkpoint.bin --task composition --out runs/$r/eval.json > runs/$r/eval.txt &
  done
  wait
  for r in track_ours track_cml track_scratch; do
    "$cli" eval-residual runs/$r/checkpoint.bin --task tracking --out runs/$r/eval.json > runs/$r/eval.txt &
  done
  wait
  "$cli" play-residual runs/b_ours/checkpoint.bin --mask-schedule "0:arms,5:none" --seconds 10 \
    --bvh runs/b_ours/switch.bvh --rollout runs/b_ours/switch.json
  "$cli" play-residual runs/track_ours/checkpoint.bin --text "0:wave hands,5:raise arms" --seconds 10 \
    --bvh runs/track_ours/play.bvh --rollout runs/track_ours/play.json
}

# docs/results.md, "Stage 2 recipe" (issue 39): every A/B run of the table, two at a time, 600
# iterations each (the best location variant continued to 1,500 iterations last).
recipe() {
  local ab=scripts/stage2_ab.sh
  (VARIANT=paper TASK=location SEED=1 $ab; VARIANT=paper TASK=location SEED=2 $ab
   VARIANT=hold10 TASK=location $ab --noise-hold-steps 10
   VARIANT=goalonly CELL_ARGS="--masks lower_body" TASK=location $ab
   VARIANT=face05 TASK=location $ab --location-facing-weight 0.5
   VARIANT=paper TASK=heading $ab; VARIANT=w19 TASK=heading $ab --objective-weights 0.1 0.9) &
  (VARIANT=w19 TASK=location $ab --objective-weights 0.1 0.9
   for seed in 1 2; do
     VARIANT=face05w19 TASK=location SEED=$seed $ab --location-facing-weight 0.5 --objective-weights 0.1 0.9
     VARIANT=face05w37 TASK=location SEED=$seed $ab --location-facing-weight 0.5 --objective-weights 0.3 0.7
     VARIANT=face05w19std15 TASK=location SEED=$seed $ab --location-facing-weight 0.5 --objective-weights 0.1 0.9 \
       --residual-std 0.15
   done
   VARIANT=paper TASK=strike SEED=1 $ab; VARIANT=paper TASK=strike SEED=2 $ab
   VARIANT=appr04 TASK=strike $ab --strike-approach-weight 0.4
   for seed in 1 2; do
     VARIANT=appr04w19 TASK=strike SEED=$seed $ab --strike-approach-weight 0.4 --objective-weights 0.1 0.9
   done) &
  wait
  for seed in 1 2; do VARIANT=face05w19 TASK=location SEED=$seed ITERATIONS=1500 $ab & done
  wait
}

# docs/results.md, Tables 2–4: the grid scripts, one run at a time, resumable (a cell already
# evaluated is skipped). Hours of one core each; the BLAS kernel of the machine decides which sample
# a rerun draws (docs/results.md, "How to read it").
table2() {
  BIN=$cli scripts/table2_grid.sh                                              # (a)–(c), seeds 1 2, controls
  BIN=$cli SEEDS="3 4 5 6 7 8" CELLS="b_ours b_cml" scripts/table2_grid.sh     # (b), seeds 3–8
  BIN=$cli CELLS="k_ours k_cml" SEEDS="1 2 3" OUT=runs/t2 scripts/table2_grid.sh   # (a) with B cut to the kick
  BIN=$cli OUT=runs/t2 CELLS="b_ours b_cml" SEEDS="1 2 3 4 5 6 7 8" ITERATIONS=2000 scripts/table2_grid.sh   # (b) at 2 M
}
table3() {
  BIN=$cli scripts/table3_grid.sh                                              # ITERATIONS=1500 THREADS=2 SEED=1
}
table4() {
  BIN=$cli ITERATIONS=3000 SEED=1 scripts/table4_grid.sh
  BIN=$cli ITERATIONS=3000 SEED=2 CELLS="ours cml" scripts/table4_grid.sh
}

case "$what" in
  stage1) stage1 ;;
  stage2) stage2 ;;
  recipe) recipe ;;
  table2) table2 ;;
  table3) table3 ;;
  table4) table4 ;;
  all) stage1; stage2; recipe; table2; table3; table4 ;;
  *) echo "usage: $0 [stage1|stage2|recipe|table2|table3|table4|all]" >&2; exit 2 ;;
esac
echo "reproduce_results: outputs under runs/"

#!/usr/bin/env bash
# Quick start: install + build the `maskadapt` command (scripts/setup.sh --cli-only), a short
# stage-1 training run of the mask-invariant base policy on the embedded default motions (the CMU
# locomotion clips when MASKADAPT_DATA_DIR — or ../shared/data — has them, else the built-in
# synthetic walk), a few minutes on 2 cores; then the shipped mask-invariant base (models/) played
# with both legs masked and evaluated, and where everything went.
#
#   scripts/quickstart.sh                 # default: 4 minutes of training
#   QUICKSTART_MINUTES=10 scripts/quickstart.sh
set -euo pipefail
cd "$(dirname "$0")/.."
minutes="${QUICKSTART_MINUTES:-4}"
out="${QUICKSTART_OUT:-runs/quickstart}"

bash scripts/setup.sh --cli-only
cli=build/bin/maskadapt
[ -x "$cli" ] || { echo "quickstart: $cli was not built (is MuJoCo installed?)" >&2; exit 1; }

if [ -z "${MASKADAPT_DATA_DIR:-}" ] && [ -d ../shared/data/motions/cmu ]; then
  export MASKADAPT_DATA_DIR="$(cd ../shared/data && pwd)"
fi
if [ -n "${MASKADAPT_DATA_DIR:-}" ] && [ -d "$MASKADAPT_DATA_DIR/motions/cmu" ]; then
  echo "quickstart: training on the CMU locomotion clips in $MASKADAPT_DATA_DIR/motions/cmu"
else
  echo "quickstart: no CMU data found; training on the built-in synthetic walk"
fi

"$cli" train-base --preset cpu --motions locomotion --envs 32 --minutes "$minutes" --checkpoint-every 10 --out "$out"

"$cli" play "$out/checkpoint.bin" --mask left_leg,right_leg --seconds 10 --bvh "$out/legs_masked.bvh" \
    --csv "$out/root_xy_legs_masked.csv" --rollout "$out/legs_masked.json"
"$cli" play "$out/checkpoint.bin" --mask none --seconds 10 --bvh "$out/unmasked.bvh" \
    --csv "$out/root_xy_unmasked.csv" --rollout "$out/unmasked.json"

# The shipped mask-invariant base (models/README.md): trained for about two hours of one core on
# this kind of machine, it walks with both legs hidden from it.
model=models/mask_mi_walk_bandai.bin
echo
echo "quickstart: the shipped base $model (masking + MI loss; 7.1 M samples) for 10 s, both legs masked:"
"$cli" play "$model" --mask left_leg,right_leg --seconds 10 --deterministic --bvh "$out/shipped_legs_masked.bvh" \
    --csv "$out/root_xy_shipped.csv" --rollout "$out/shipped_legs_masked.json" | grep -E "root moved|BVH"
echo "quickstart: its fall rate and speed with no mask and with both legs masked:"
"$cli" eval-base "$model" --envs 4 --frames 300 --deterministic --json "$out/shipped_eval.json" \
    | grep -E "^(mask |none |left_leg,right_leg |speed in)"

cat <<MSG

quickstart: done.
  configuration   $out/config.json
  training log    $out/log.jsonl     (one JSON object per iteration; plot it in the viewer's Training logs tab)
  checkpoint      $out/checkpoint.bin (continue with: $cli train-base --resume $out/checkpoint.bin --minutes 30)
  BVH export      $out/legs_masked.bvh, $out/unmasked.bvh (10 s each, legs masked / no mask; Blender: File > Import > Motion Capture)
  root paths      $out/root_xy_legs_masked.csv, $out/root_xy_unmasked.csv (t,x,y in metres)
  viewer rollouts $out/legs_masked.json, $out/unmasked.json (open them in tools/viewer: per-frame masks and contacts)
  shipped base    $out/shipped_legs_masked.bvh, $out/shipped_legs_masked.json, $out/root_xy_shipped.csv, $out/shipped_eval.json
Next: the H_norm table of the paper (about a minute with these flags):
  $cli eval-base $out/checkpoint.bin --envs 4 --frames 300 --json $out/hnorm.json
See docs/training.md for every option.
MSG

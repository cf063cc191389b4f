#!/usr/bin/env bash
# Screenshots of the web viewer showing real run outputs, for docs/viewer.md. Takes them in
# headless Chromium (Debian's /usr/bin/chromium via playwright-core, tools/viewer/e2e/screenshot.mjs)
# and writes docs/images/results/*.png. Inputs that do not exist (yet) are skipped with a message.
#
#   scripts/screenshots.sh                  # RUNS=runs, OUT=docs/images/results
#   RUNS=/work/runs scripts/screenshots.sh
#
# Inputs (under $RUNS), as scripts/reproduce_results.sh writes them:
#   ablation/mi_1.0/play_left_leg_right_leg.json
#   ablation/mask_no_mi/play_left_leg_right_leg.json  → base_walk_legs_masked.png (with | without MI)
#   b_ours/switch.json                                → switch_before.png, switch_after.png
#   track_ours/play.json                              → tracking.png
#   ablation/{amp,mask_no_mi,mi_0.1,mi_1.0}/log.jsonl → training_logs.png (episode_length, mi_kl)
# and, from models/ with the built `maskadapt` (MASKADAPT_CLI), shipped_walker.png (SHIPPED_T, default 2 s)
# and fig5c_viewer_{before,after}.png (models/table2/sneak_ours_s1.bin, mask switched at 3 s), and
# fig5a_/fig5b_viewer_{before,after}.png (models/table2/{kick_cut,swim}_ours_s1.bin, likewise; after-pictures at
# 5.4 s and 5.0 s, where the kicking ankle and the swim's wrists are highest), and
# generator_switch_{walk,wave}.png (models/text_generator.bin, "0:walk,2:wave right hand" from a
# Bandai walk in $MASKADAPT_DATA_DIR), and g1_walker.png (models/g1_mask_mi_walk_bandai.bin, G1_T default 3 s),
# and goal_location.png, goal_strike_{before,after}.png (the recipe's location and strike policies of
# models/recipe/; LOCATION_T default 1.5 s, STRIKE_T default 7.0 s, STRIKE_MODEL).
# Times: WALK_T (default 0.6 s: the short CPU-trained bases fall after ≈1 s), SWITCH_T (the switch, default 5 s; pictures at SWITCH_T − 1 s and
# SWITCH_T + 1.5 s), TRACK_T (default 0.6 s, before the fall).
set -uo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
RUNS="${RUNS:-runs}"
OUT="${OUT:-$repo/docs/images/results}"
WALK_T="${WALK_T:-0.6}"
SWITCH_T="${SWITCH_T:-5}"
TRACK_T="${TRACK_T:-0.6}"
viewer="$repo/tools/viewer"
shot=(node "$viewer/e2e/screenshot.mjs")

if [[ ! -d "$viewer/node_modules" ]]; then
  echo "screenshots: $viewer/node_modules is missing: run scripts/setup-viewer.sh first" >&2
  exit 1
fi
if [[ ! -x "${MASKADAPT_CHROMIUM:-/usr/bin/chromium}" ]]; then
  echo "screenshots: Chromium not found (apt-get install chromium)" >&2
  exit 1
fi
# (Re)build the viewer when dist/ is missing or older than its sources.
if [[ ! -f "$viewer/dist/index.html" ]] ||
   [[ -n "$(find "$viewer/src" "$viewer/index.html" "$viewer/package-lock.json" -newer "$viewer/dist/index.html" -print -quit)" ]]; then
  echo "screenshots: building the viewer (tools/viewer/dist)"
  npm --prefix "$viewer" run build --silent >/dev/null || { echo "screenshots: viewer build failed" >&2; exit 1; }
fi
mkdir -p "$OUT"

made=0 skipped=0 failed=0
# have FILE... — true when every file exists, else prints what is missing.
have() {
  local f missing=()
  for f in "$@"; do [[ -f "$f" ]] || missing+=("$f"); done
  ((${#missing[@]} == 0)) && return 0
  echo "screenshots: skip $picture: missing ${missing[*]}"
  skipped=$((skipped + 1))
  return 1
}
# take PNG ARGS... — one screenshot.
take() {
  local png="$OUT/$1"
  shift
  if "${shot[@]}" --out "$png" "$@"; then made=$((made + 1)); else failed=$((failed + 1)); fi
}
# Prints the command stored in a rollout's metadata (for the docs).
command_of() {
  node -e 'const r = JSON.parse(require("fs").readFileSync(process.argv[1], "utf8"));
           console.log(`  ${process.argv[1]}: ${r.num_frames} frames, command: ${(r.metadata || {}).command || "?"}`)' "$1"
}

# (a) base policy walking with the legs masked: with vs without the MI loss (same seed).
picture=base_walk_legs_masked.png
a="$RUNS/ablation/mi_1.0/play_left_leg_right_leg.json"
b="$RUNS/ablation/mask_no_mi/play_left_leg_right_leg.json"
if have "$a" "$b"; then
  command_of "$a"; command_of "$b"
  take "$picture" --rollout "$a" --label "with MI (ablation/mi_1.0)" \
    --rollout2 "$b" --label2 "without MI (ablation/mask_no_mi)" --time "$WALK_T"
fi

# (b) composition switch: before and after the switch.
picture="switch_before.png, switch_after.png"
s="$RUNS/b_ours/switch.json"
if have "$s"; then
  command_of "$s"
  take switch_before.png --rollout "$s" --label "b_ours/switch.json" \
    --time "$(awk -v t="$SWITCH_T" 'BEGIN { print t - 1 }')"
  take switch_after.png --rollout "$s" --label "b_ours/switch.json" \
    --time "$(awk -v t="$SWITCH_T" 'BEGIN { print t + 1.5 }')"
fi

# (c) tracking: text command and goal targets.
picture=tracking.png
t="$RUNS/track_ours/play.json"
if have "$t"; then
  command_of "$t"
  take "$picture" --rollout "$t" --label "track_ours/play.json" --time "$TRACK_T"
fi

# (d) training logs of the ablation runs, overlaid.
picture=training_logs.png
logs=()
for run in amp mask_no_mi mi_0.1 mi_1.0; do
  f="$RUNS/ablation/$run/log.jsonl"
  if [[ -f "$f" ]]; then logs+=(--log "$f"); else echo "screenshots: training_logs.png without $f (missing)"; fi
done
if ((${#logs[@]} > 0)); then
  take "$picture" "${logs[@]}" --series episode_length --series mi_kl --height 520
else
  echo "screenshots: skip $picture: no ablation logs under $RUNS/ablation"
  skipped=$((skipped + 1))
fi

cli="${MASKADAPT_CLI:-$repo/build/bin/maskadapt}"
# rollout_of NAME COMMAND ARGS... — runs `maskadapt COMMAND ARGS... --rollout <tmp>/NAME.json` in the
# repository and sets $rollout to that file; when it fails, counts the failure for $picture.
rollout_of() {
  local name="$1"
  shift
  rollout="$(mktemp -d)/$name.json"
  if (cd "$repo" && "$cli" "$@" --rollout "$rollout" >/dev/null); then
    command_of "$rollout"
    return 0
  fi
  echo "screenshots: $picture: maskadapt $1 failed" >&2
  failed=$((failed + 1))
  return 1
}

# (e) the shipped mask-invariant base with both legs masked (README's first screen): 10 s of
# `play --deterministic` from seed 1.
picture=shipped_walker.png
if have "$repo/models/mask_mi_walk_bandai.bin" "$cli" &&
   rollout_of shipped_walker play models/mask_mi_walk_bandai.bin --mask left_leg,right_leg --deterministic --seconds 10 --seed 1; then
  take "$picture" --rollout "$rollout" --label "models/mask_mi_walk_bandai.bin, both legs masked, play --deterministic --seed 1" \
    --time "${SHIPPED_T:-2}"
fi

# (f) the shipped Table 2 case (c) policy with its mask switched mid-episode (the paper's Fig. 5c):
# no part masked for 3 s (the base walks), then the lower body (the legs sneak).
picture="fig5c_viewer_before.png, fig5c_viewer_after.png"
if have "$repo/models/table2/sneak_ours_s1.bin" "$cli" &&
   rollout_of fig5c play-residual models/table2/sneak_ours_s1.bin --mask-schedule "0:none,3:lower_body" --seconds 6 --seed 1; then
  take fig5c_viewer_before.png --rollout "$rollout" --label "models/table2/sneak_ours_s1.bin: no mask (the base walks)" --time 2
  take fig5c_viewer_after.png --rollout "$rollout" --label "models/table2/sneak_ours_s1.bin: lower body masked (sneak)" --time 4.5
fi

# (f2) the shipped Table 2 cases (a) and (b) (the paper's Fig. 5a, jump + kick, and 5b, locomotion +
# arm rotation; here walk + kick and walk + swim), mask switched at 3 s as in (f).
# 5a uses the kick-only B (kick_cut_*): with the whole kick clip as B no kick is learnt.
for fig in "fig5a kick_cut kick lower_body 5.4" "fig5b swim swim arms 5.0"; do
  read -r name file motion part t_after <<<"$fig"
  picture="${name}_viewer_before.png, ${name}_viewer_after.png"
  model="models/table2/${file}_ours_s1.bin"
  if have "$repo/$model" "$cli" &&
     rollout_of "$name" play-residual "$model" --mask-schedule "0:none,3:$part" --seconds 6 --seed 1; then
    take "${name}_viewer_before.png" --rollout "$rollout" --label "$model: no mask (the base walks)" --time 2
    take "${name}_viewer_after.png" --rollout "$rollout" --label "$model: $part masked ($motion)" --time "$t_after"
  fi
done

# (g) the shipped text generator (issue 19) switching from "walk" to "wave right hand" at 2 s, from a
# real Bandai walk (needs the shared data): kinematic frames, not a simulation.
picture="generator_switch_walk.png, generator_switch_wave.png"
walk="${MASKADAPT_DATA_DIR:-$repo/../shared/data}/motions/bandai/locomotion/dataset-1_walk_normal_001.bvh"
if have "$repo/models/text_generator.bin" "$cli" "$walk" &&
   rollout_of generator_switch generate --text "0:walk,2:wave right hand" --seconds 5 --seed 1 --from "$walk:2"; then
  take generator_switch_walk.png --rollout "$rollout" --label "models/text_generator.bin: 'walk' (1.5 s)" --time 1.5
  take generator_switch_wave.png --rollout "$rollout" --label "models/text_generator.bin: 'wave right hand' from 2 s (3.5 s)" --time 3.5
fi

# (h) the second character (issue 18): the G1-like robot's mask-invariant walker with both legs
# masked, 10 s of `play --deterministic` from seed 1 (the viewer draws the robot's 30 links).
picture=g1_walker.png
if have "$repo/models/g1_mask_mi_walk_bandai.bin" "$cli" &&
   rollout_of g1_walker play models/g1_mask_mi_walk_bandai.bin --mask left_leg,right_leg --deterministic --seconds 10 --seed 1; then
  take "$picture" --rollout "$rollout" --label "models/g1_mask_mi_walk_bandai.bin (the G1-like robot), both legs masked, play --deterministic --seed 1" \
    --time "${G1_T:-3}"
fi

# (i) the stage-2 recipe's goal tasks (issue 39) with their goals drawn: location (the target ring)
# and strike (the box, just before and after the hands knock it over), each 10 s of
# `play-residual` from seed 2 with the run's first training mask (the arms).
picture="goal_location.png"
model="models/recipe/location_face05w19_s2.bin"
if have "$repo/$model" "$cli" && rollout_of goal_location play-residual "$model" --seconds 10 --seed 2; then
  take goal_location.png --rollout "$rollout" --label "$model: turning to its target" --time "${LOCATION_T:-1.5}"
fi
picture="goal_strike_before.png, goal_strike_after.png"
model="${STRIKE_MODEL:-models/recipe/strike_foreign_next15_s1.bin}"
if have "$repo/$model" "$cli" && rollout_of goal_strike play-residual "$model" --seconds 10 --seed 2; then
  take goal_strike_before.png --rollout "$rollout" --label "$model: the strike" --time "${STRIKE_T:-7.0}"
  take goal_strike_after.png --rollout "$rollout" --label "$model: the box going over" \
    --time "$(awk -v t="${STRIKE_T:-7.0}" 'BEGIN { print t + 0.4 }')"
fi

echo "screenshots: $made written to $OUT, $skipped skipped, $failed failed"
((failed == 0))

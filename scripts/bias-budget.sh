#!/usr/bin/env bash
# The bias budget (README, "Bias budget"): per scene, GI's converged still image against the path
# tracer with the same primary visibility (pixel centres), for each preset and with each technique
# switched off in turn: how far it moves the image's mean, and what relMSE it costs. Writes every
# image and log under out/bias/ and the table to out/bias/table.md.
#
#   bash scripts/bias-budget.sh [WIDTH HEIGHT REFERENCE_SPP FRAMES AVERAGE] [scene files...]
#
# Each GI run renders FRAMES still frames and compares the mean of the last AVERAGE of them (the
# converged image, free of one frame's noise: `gi render --average-last`); AVERAGE 1 compares the
# last frame alone.
# Defaults: 160 90 1024 192 128, the repository's scenes, then the Bitterli interiors of
# ../shared/scenes/third-party/bitterli when they are there (skipped, saying so, when not).
# TECHNIQUES (space-separated `--no` names; `feedback` switches temporal feedback on, as the presets
# leave it off) narrows the switches; every one by default.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh >/dev/null
. scripts/env.sh
W=${1:-160}; H=${2:-90}; REF_SPP=${3:-1024}; FRAMES=${4:-192}; AVERAGE=${5:-128}
shift $(( $# < 5 ? $# : 5 ))
SCENES=("$@")
if [ ${#SCENES[@]} -eq 0 ]; then
  for s in cornell-box indirect-room many-lights textured light-leak; do SCENES+=("scenes/$s.gltf"); done
  B=../shared/scenes/third-party/bitterli
  if [ -d "$B" ]; then
    SCENES+=("$B/staircase/staircase.glb" "$B/bathroom/bathroom.glb" "$B/living-room/living-room.glb")
  else
    echo "bias-budget: $B not found: the Bitterli interiors are skipped" >&2
  fi
fi
TECHNIQUES=${TECHNIQUES-"multi-bounce feedback filter hysteresis guiding backup reprojection parallax patching jitter relaxed temporal spatial leak-fixes occlusion"}
cargo build --quiet --profile dev --workspace --all-targets
GI="$CARGO_TARGET_DIR/debug/gi"
OUT=out/bias; mkdir -p "$OUT"
# The environment a scene needs (the living room is lit by its sky).
extra() { case "$1" in *living-room*) echo "--environment $(dirname "$1")/sky-19.exr" ;; esac; }
field() { sed -n "s/.*$1 \([-+0-9.e]*%\{0,1\}\).*/\1/p" | tail -1; }
{
  echo "| scene | run | mean vs PT | dark half vs PT | relMSE | FLIP | mean moved by the switch |"
  echo "|---|---|---|---|---|---|---|"
} > "$OUT/table.md"
for scene in "${SCENES[@]}"; do
  s=$(basename "${scene%.*}")
  ref=$OUT/$s-ref-${W}x$H-${REF_SPP}spp-filtered.exr
  # shellcheck disable=SC2046
  [ -f "$ref" ] || "$GI" render "$scene" $(extra "$scene") --width "$W" --height "$H" \
    --spp "$REF_SPP" --pixel-centre --out "$ref" > "$OUT/$s-ref.log"
  base_mean=""
  for run in balanced quality fast $TECHNIQUES; do
    case "$run" in
      balanced|quality|fast) args=(--preset "$run") ;;
      # Temporal feedback is off in every preset: its row switches it on.
      feedback) args=(--preset balanced --feedback) ;;
      *) args=(--preset balanced --no "$run") ;;
    esac
    log=$OUT/$s-$run.log
    # shellcheck disable=SC2046
    "$GI" render "$scene" $(extra "$scene") "${args[@]}" --frames "$FRAMES" --width "$W" \
      --height "$H" --average-last "$AVERAGE" --reference "$ref" --out "$OUT/$s-$run.exr" > "$log"
    line=$(grep 'against reference' "$log")
    mean=$(echo "$line" | field mean); dark=$(echo "$line" | field half); rel=$(echo "$line" | field relMSE); flip=$(echo "$line" | field FLIP)
    moved="-"
    if [ "$run" = balanced ]; then
      base_mean=$mean
    elif [ -n "$base_mean" ] && [ "$run" != quality ] && [ "$run" != fast ]; then
      moved=$(awk -v a="${mean%\%}" -v b="${base_mean%\%}" 'BEGIN { printf "%+.1f pp", a - b }')
      if [ "$run" = feedback ]; then run="with feedback"; else run="no $run"; fi
    fi
    echo "| $s | $run | $mean | $dark | $rel | $flip | $moved |" >> "$OUT/table.md"
  done
  echo "$s done" >&2
done
cat "$OUT/table.md"

#!/usr/bin/env bash
# GI against the path tracer, per scene: GI's GPU time per frame (and per pass) on this device,
# its relMSE and FLIP against a high-spp path-traced reference, and the path tracer's samples per
# pixel and GPU time to reach the same relMSE. Writes every log and image under out/measure/ and
# a Markdown table to out/measure/table.md; then, on the first scene, one row per technique
# switched off (error and GPU ms) to out/measure/techniques.md.
#
#   bash scripts/measure-gi.sh [WIDTH HEIGHT REFERENCE_SPP FRAMES] [scenes...]
#
# Defaults: 320 180 1024 64, the repository's scenes. The reference's own noise (1024 spp) is part
# of every relMSE; the path tracer's spp search uses another seed than the reference and stops at
# PT_MAX_SPP (default: a quarter of the reference's).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh >/dev/null
. scripts/env.sh
W=${1:-320}; H=${2:-180}; REF_SPP=${3:-1024}; FRAMES=${4:-64}
shift $(( $# < 4 ? $# : 4 ))
SCENES=("$@")
[ ${#SCENES[@]} -eq 0 ] && SCENES=(cornell-box indirect-room many-lights textured light-leak)
cargo build --quiet --workspace --all-targets
GI="$CARGO_TARGET_DIR/debug/gi"
OUT=out/measure; mkdir -p "$OUT"
relmse() { sed -n 's/.*relMSE \([0-9.e+-]*\).*/\1/p' | tail -1; }
flip() { sed -n 's/.*FLIP \([0-9.]*\).*/\1/p' | tail -1; }
{
  echo "| scene | GI ms/frame | GI relMSE | GI FLIP | GI mean | PT spp for that relMSE | PT ms for it | PT ms / GI ms |"
  echo "|---|---|---|---|---|---|---|---|"
} > "$OUT/table.md"
for s in "${SCENES[@]}"; do
  scene=scenes/$s.gltf
  ref=$OUT/$s-ref-centre-filtered.exr
  [ -f "$ref" ] || "$GI" render "$scene" --width "$W" --height "$H" --spp "$REF_SPP" --pixel-centre --out "$ref" > "$OUT/$s-ref.log"
  "$GI" render "$scene" --method gi --width "$W" --height "$H" --frames "$FRAMES" --reference "$ref" \
    --out "$OUT/$s-gi.exr" --debug-views "$OUT/$s-debug" > "$OUT/$s-gi.log"
  gi_ms=$(awk '/^total/ && NF == 3 { print $3 }' "$OUT/$s-gi.log" | head -1)
  line=$(grep 'against reference' "$OUT/$s-gi.log")
  gi_rel=$(echo "$line" | relmse); gi_flip=$(echo "$line" | flip)
  gi_mean=$(echo "$line" | sed -n 's/.*mean \([-+0-9.]*%\).*/\1/p')
  # The path tracer: double the samples until its relMSE is at most GI's.
  max=${PT_MAX_SPP:-$((REF_SPP / 4))}
  spp=1; pt_spp=">$max"; pt_ms="-"
  while [ "$spp" -le "$max" ]; do
    "$GI" render "$scene" --width "$W" --height "$H" --spp "$spp" --seed 7 --pixel-centre --out "$OUT/$s-pt$spp.exr" > "$OUT/$s-pt$spp.log"
    rel=$("$GI" compare "$ref" "$OUT/$s-pt$spp.exr" | relmse)
    ms=$(sed -n 's/.*spp, [0-9]* bounces in .* s, \([0-9.]*\) Mpaths\/s GPU time.*/\1/p' "$OUT/$s-pt$spp.log" \
      | awk -v px=$((W * H * spp)) '{ printf "%.1f", px / $1 / 1e3 }')
    echo "$s: path tracer $spp spp: relMSE $rel, $ms ms GPU" >> "$OUT/pt-search.log"
    if awk -v a="$rel" -v b="$gi_rel" 'BEGIN { exit !(a <= b) }'; then pt_spp=$spp; pt_ms=$ms; break; fi
    spp=$((spp * 2))
  done
  ratio=$(awk -v a="$pt_ms" -v b="$gi_ms" 'BEGIN { if (a == "-" || b == 0) print "-"; else printf "%.1f", a / b }')
  echo "| $s | $gi_ms | $gi_rel | $gi_flip | $gi_mean | $pt_spp | $pt_ms | $ratio |" >> "$OUT/table.md"
  echo "$s done"
done
cat "$OUT/table.md"
# One technique off at a time, on the first scene.
s=${SCENES[0]}
{
  echo "| $s, ${W}x$H, $FRAMES frames | GI ms/frame | relMSE | FLIP | mean |"
  echo "|---|---|---|---|---|"
} > "$OUT/techniques.md"
for t in none reprojection parallax backup patching guiding hysteresis filter jitter relaxed temporal spatial feedback leak-fixes restir spawn-1 spawn-1/16; do
  case $t in
    none) args=() ;;
    restir) args=(--restir) ;;
    feedback) args=(--feedback) ;;
    spawn-*) args=(--spawn-rate "${t#spawn-}") ;;
    *) args=(--no "$t") ;;
  esac
  log=$OUT/$s-tech-${t//\//_}.log
  "$GI" render "scenes/$s.gltf" --method gi --width "$W" --height "$H" --frames "$FRAMES" \
    --reference "$OUT/$s-ref.exr" --out "$OUT/$s-tech.exr" "${args[@]}" > "$log"
  ms=$(awk '/^total/ && NF == 3 { print $3 }' "$log" | head -1)
  line=$(grep 'against reference' "$log")
  echo "| ${t/none/all on} ${args[*]:+(\`${args[*]}\`)} | $ms | $(echo "$line" | relmse) | $(echo "$line" | flip) | $(echo "$line" | sed -n 's/.*mean \([-+0-9.]*%\).*/\1/p') |" >> "$OUT/techniques.md"
done
cat "$OUT/techniques.md"

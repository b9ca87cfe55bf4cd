#!/usr/bin/env bash
# The pictures of docs/integration.md: the debug views of a healthy frame ("Debugging") and each
# GI-1.0 technique's failure beside the setting that mitigates it ("Failure modes"), rendered by
# `gi render` and `gi cache-view` at 128×128 (small PNGs, under 1 MiB in all; about 25 minutes on
# lavapipe on 2 cores shared with other builds).
# Every render's log, EXR and debug views go to out/docs-pictures/; the PNGs the guide shows are
# copied to docs/images/ under the names it uses.
#
#   bash scripts/docs-pictures.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh >/dev/null
. scripts/env.sh
cargo build --quiet --workspace --all-targets
GI="$CARGO_TARGET_DIR/debug/gi"
OUT=out/docs-pictures
IMG=docs/images
mkdir -p "$OUT" "$IMG"
SIZE=(--width 128 --height 128)

# gi_render NAME SCENE ARGS...: GI-1.0 frames of scenes/SCENE.gltf, the last one to docs/images/NAME.png.
gi_render() {
  local name=$1 scene=$2
  shift 2
  echo "gi render $scene $* -> $IMG/$name.png"
  "$GI" render "scenes/$scene.gltf" --method gi "${SIZE[@]}" --out "$OUT/$name.exr" "$@" > "$OUT/$name.log"
  cp "$OUT/$name.png" "$IMG/$name.png"
}
# gi_reference NAME SCENE SPP ARGS...: the path tracer's image, for comparison (kept once made).
gi_reference() {
  local name=$1 scene=$2 spp=$3
  shift 3
  echo "gi render $scene --spp $spp $* -> $IMG/$name.png"
  [ -f "$OUT/$name.exr" ] || "$GI" render "scenes/$scene.gltf" --spp "$spp" "${SIZE[@]}" --out "$OUT/$name.exr" "$@" > "$OUT/$name.log"
  cp "$OUT/$name.png" "$IMG/$name.png"
}
# cache_view NAME SCENE ARGS...: the world cache on its own (`gi cache-view`), with its debug views.
cache_view() {
  local name=$1 scene=$2
  shift 2
  echo "gi cache-view $scene $* -> $IMG/$name.png"
  "$GI" cache-view "scenes/$scene.gltf" "${SIZE[@]}" --out "$OUT/$name.exr" --debug-views "$OUT/$name-debug" "$@" > "$OUT/$name.log"
  cp "$OUT/$name.png" "$IMG/$name.png"
}
# view NAME VIEW: copies debug view VIEW of render NAME to docs/images/NAME-VIEW.png.
view() { cp "$OUT/$1-debug/$2.png" "$IMG/$1-$2.png"; }
# mean NAME: the last frame's relMSE, FLIP and mean against the reference, from the render's log.
mean() { echo "  $1: $(grep 'against reference' "$OUT/$1.log")"; }

# Debugging: every debug view of a healthy frame (Cornell box, a slow orbit, 32 frames).
gi_render debug cornell-box --camera-path orbit:1 --frames 32 --debug-views "$OUT/debug-debug"
for v in probe_atlas probe_mask spawn_and_patch_tiles ray_guiding_pdf blur_mask probe_age \
  irradiance_before_denoiser irradiance_after_denoiser cache_cells_by_hash cache_lod \
  cache_sample_count cache_cached_radiance; do
  view debug "$v"
done

# Disocclusion: indirect-room's camera still for 12 frames, then turned 10° at once (a camera
# path file: one camera per frame, the last line held). The last frame shows the jump: patching
# moves the spawns of tiles that still hold a probe to the disoccluded ones; without it, at a
# low spawn rate, the new tiles wait for their turn.
{
  for _ in $(seq 12); do echo "-2.6 1.6 2.6  -1.901464 1.444771 1.901464"; done
  echo "-2.6 1.6 2.6  -2.033376 1.444771 1.790777"
} > "$OUT/jump.path"
gi_render disocclusion indirect-room --camera-path "$OUT/jump.path" --frames 13 --exposure 2 \
  --debug-views "$OUT/disocclusion-debug"
gi_render disocclusion-unpatched indirect-room --camera-path "$OUT/jump.path" --frames 13 \
  --exposure 2 --spawn-rate 1/16 --no patching --debug-views "$OUT/disocclusion-unpatched-debug"
for n in disocclusion disocclusion-unpatched; do
  view "$n" spawn_and_patch_tiles
  view "$n" irradiance_before_denoiser
done

# Ghosting and hysteresis lag: the box of moving-box crosses the room. Without object motion the
# probes and the denoiser's history stay where the box was, and the hysteresis holds its shadow.
gi_render ghosting moving-box --frames 40 --debug-views "$OUT/ghosting-debug"
gi_render ghosting-no-object-motion moving-box --frames 40 --no object-motion \
  --debug-views "$OUT/ghosting-no-object-motion-debug"
for n in ghosting ghosting-no-object-motion; do view "$n" irradiance_after_denoiser; done
# Where the two differ (FLIP): the trail.
"$GI" compare "$OUT/ghosting.exr" "$OUT/ghosting-no-object-motion.exr" \
  --heat-map "$IMG/ghosting-difference.png" > "$OUT/ghosting-difference.log"

# Light leaks through a thin wall: light-leak's dark room beside a lit one, in the whole frame and
# in the world cache alone (where the leak fixes act).
gi_reference leak-reference light-leak 256
gi_render leak light-leak --reference "$OUT/leak-reference.exr"
gi_render leak-no-fixes light-leak --no leak-fixes --reference "$OUT/leak-reference.exr"
cache_view leak-cache light-leak --frames 32
cache_view leak-cache-no-fixes light-leak --frames 32 --no-leak-fixes
for n in leak leak-no-fixes leak-cache leak-cache-no-fixes; do
  "$GI" compare "$OUT/leak-reference.exr" "$OUT/$n.exr" --heat-map "$IMG/$n-flip.png" > "$OUT/$n-flip.log"
done

# Fireflies: single bright probe rays reach the image when the hysteresis is off (the denoiser
# off in both, to see the probes); FLIP against the path tracer shows where.
gi_reference cornell-reference cornell-box 256
gi_render fireflies cornell-box --frames 16 --no temporal,spatial
gi_render fireflies-no-hysteresis cornell-box --frames 16 --no hysteresis,temporal,spatial
for n in fireflies fireflies-no-hysteresis; do
  "$GI" compare "$OUT/cornell-reference.exr" "$OUT/$n.exr" --heat-map "$IMG/$n-flip.png" > "$OUT/$n-flip.log"
done

# Cell size: the cache's radiance at each pixel's cell, at 8, 32 (default) and 128 pixels.
for c in 8 32 128; do
  cache_view "cells-$c" cornell-box --frames 32 --cell-size-pixels "$c"
  view "cells-$c" cells_by_hash
  view "cells-$c" cached_radiance
done

# Overflow: a cache of 2 buckets × 4 tiles for a scene that needs hundreds of tiles.
cache_view overflow indirect-room --frames 32 --exposure 2 --buckets-log2 1 --tiles-per-bucket-log2 2
cache_view overflow-default indirect-room --frames 32 --exposure 2

# ReSTIR bias (the presets run without temporal feedback, where it shows most): reservoirs shared by hits that
# see different lights darken the closed indirect-room.
gi_reference restir-reference indirect-room 256 --exposure 2
gi_render restir-off indirect-room --exposure 2 --reference "$OUT/restir-reference.exr"
gi_render restir-on indirect-room --exposure 2 --restir --reference "$OUT/restir-reference.exr"

# Denoiser blur: young history under motion gets the widest spatial filter.
gi_render denoiser textured --camera-path orbit:1 --frames 8 --debug-views "$OUT/denoiser-debug"
for v in irradiance_before_denoiser irradiance_after_denoiser blur_mask; do
  view denoiser "$v"
done

# The probe filter's blur across probes: a bias (darker, smoother) traded for less noise.
gi_render filter cornell-box --reference "$OUT/cornell-reference.exr"
gi_render filter-off cornell-box --no filter --reference "$OUT/cornell-reference.exr"

echo "against the path tracer:"
for n in leak leak-no-fixes restir-off restir-on filter filter-off; do mean "$n"; done
echo "FLIP against the path tracer (gi compare):"
for n in leak leak-no-fixes leak-cache leak-cache-no-fixes fireflies fireflies-no-hysteresis; do
  echo "  $n: $(head -n 1 "$OUT/$n-flip.log")"
done
echo "  ghosting against no object motion: $(head -n 1 "$OUT/ghosting-difference.log")"
for n in overflow overflow-default; do
  echo "  $n: $(grep -E '^frame +31' "$OUT/$n.log" || tail -n 1 "$OUT/$n.log")"
done
du -ch "$IMG"/*.png | tail -n 1

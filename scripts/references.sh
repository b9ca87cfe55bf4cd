#!/usr/bin/env bash
# Regenerates the path-traced references the GI tests compare with (tests/data/reference/): the
# scene's own camera, 64×64, 4096 paths per pixel, seed 0, every path through its pixel's centre
# (the GI frame's primary visibility, so that the tests measure lighting, not edges). About a
# minute per scene on lavapipe.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh >/dev/null
. scripts/env.sh
cargo build --quiet --workspace --all-targets
for s in cornell-box indirect-room light-leak; do
  "$CARGO_TARGET_DIR/debug/gi" render "scenes/$s.gltf" --width 64 --height 64 --spp 4096 --pixel-centre \
    --out "tests/data/reference/$s-64.exr"
  rm -f "tests/data/reference/$s-64.png"
done

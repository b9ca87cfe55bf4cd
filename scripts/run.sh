#!/usr/bin/env bash
# The main command of README.md: installs what is missing, then runs `gi`. Without arguments it
# renders the Cornell box with GI-1.0 (64 frames) to out/cornell-box.exr and out/cornell-box.png;
# with arguments they go to `gi`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/env.sh
if [ "$#" -eq 0 ]; then
  set -- render scenes/cornell-box.gltf --method gi --out out/cornell-box.exr --width 320 --height 320
fi
# Built as part of the whole workspace, like the tests: another package selection would unify
# dependency features differently and rebuild rust-gpu's backend.
cargo build --quiet --workspace --all-targets
exec "$CARGO_TARGET_DIR/debug/gi" "$@"

#!/usr/bin/env bash
# The main command of README.md: installs what is missing, then runs `gi`. Without arguments it
# renders the Cornell box's G-buffer to out/cornell-box/*.png; with arguments they go to `gi`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/env.sh
if [ "$#" -eq 0 ]; then
  set -- gbuffer scenes/cornell-box.gltf --out out/cornell-box
fi
exec cargo run --quiet -p gi-host --bin gi -- "$@"

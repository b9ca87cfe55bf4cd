#!/usr/bin/env bash
# The release step of the shipped kernels: builds them from kernels/ with rust-gpu (the pinned
# nightly) and writes the modules and their manifest to host/kernels-spirv/, which builds of
# gi-host without its `build-kernels` feature embed (stable Rust, no rust-gpu).
#
# The same whole-workspace build as scripts/run.sh and the tests, so it reuses their rust-gpu
# backend; the test kernels::tests::shipped_kernels_are_the_ones_built_from_source then passes.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/env.sh
command -v jq >/dev/null || { echo "build-kernels: needs jq (apt-get install jq)" >&2; exit 1; }

# The build script of gi-host leaves the modules and manifest in <its OUT_DIR>/kernels-spirv.
out=$(cargo build --profile dev --workspace --all-targets --message-format=json-render-diagnostics |
  jq -r 'select(.reason == "build-script-executed" and (.package_id | test("[/#]gi-host[@#]")))
         | .out_dir' | sort -u)
if [ "$(printf '%s\n' "$out" | grep -c .)" -ne 1 ] || [ ! -f "$out/kernels-spirv/manifest.toml" ]; then
  echo "build-kernels: expected one build of gi-host's kernels, found: ${out:-none}" >&2
  exit 1
fi
mkdir -p host/kernels-spirv
cp "$out"/kernels-spirv/{software.spv,ray-query.spv,manifest.toml} host/kernels-spirv/
ls -l host/kernels-spirv
git status --short host/kernels-spirv

#!/usr/bin/env bash
# The GPU check: one command for a machine with a discrete GPU. It builds, renders one GI frame
# per preset for its per-pass GPU times and memory table, runs a presets-only `gi sweep` on the
# Cornell box and a Bitterli interior from ../shared, the tracing benchmark, and last the GPU
# tests (the `gi-tests` binaries, the long ignored ones included). Every step's output goes
# under one folder, with a summary (step, exit status, seconds) in summary.md. A failing step is
# recorded and the others still run; the exit status is non-zero when any failed.
#
#   bash scripts/gpu-check.sh [--small] [--out DIR] [--shared DIR] [--prebuilt DIR]
#   bash scripts/gpu-check.sh --bundle DIR
#
# --small       160x90 instead of 1920x1080 and fewer frames: the script's own test on lavapipe.
# --out DIR     the folder for everything (default out/gpu-check).
# --shared DIR  the reference material's folder (default ../shared beside the repository).
# --bundle DIR  build here, copy the binaries (stripped) into DIR, and stop: for a GPU machine
#               without Rust. The binaries read the repository (and ../shared) from the path
#               they were built at, so link that path to the checkout there.
# --prebuilt DIR  run DIR's binaries (from --bundle) instead of building.
# GI_DEVICE picks the device (index or part of its name; default: the discrete GPU).
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"

small=0
out=out/gpu-check
shared=$root/../shared
bundle=
prebuilt=
while [ "$#" -gt 0 ]; do
  case "$1" in
    --small) small=1 ;;
    --out) out=$2; shift ;;
    --shared) shared=$2; shift ;;
    --bundle) bundle=$2; shift ;;
    --prebuilt) prebuilt=$2; shift ;;
    *) echo "gpu-check: unknown argument $1 (see the comment at the top of $0)" >&2; exit 2 ;;
  esac
  shift
done

# Builds everything in one invocation, as scripts/run.sh does (another selection or profile would
# rebuild rust-gpu's backend), and prints the executables it needs, one per line as ROLE PATH:
# `gi`, `bench` (the tracing benchmark) and `test` (each integration-test binary of gi-tests).
build() {
  bash scripts/setup.sh >&2 || return 1
  . scripts/env.sh
  cargo build --workspace --all-targets --message-format=json-render-diagnostics | python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    exe, t = m.get("executable"), m.get("target", {})
    if not exe:
        continue
    kinds = t.get("kind", [])
    if t.get("name") == "gi" and "bin" in kinds and not m["profile"]["test"]:
        print("gi", exe)  # not its unit-test harness, which cargo also builds
    elif t.get("name") == "tracing" and "bench" in kinds:
        print("bench", exe)
    elif "test" in kinds and "#gi-tests@" in m.get("package_id", ""):
        print("test", exe)
'
}

if [ -n "$bundle" ]; then
  set -e
  mkdir -p "$bundle/tests"
  exes=$(build)
  cp "$(awk '$1 == "gi" { print $2; exit }' <<<"$exes")" "$bundle/gi"
  cp "$(awk '$1 == "bench" { print $2; exit }' <<<"$exes")" "$bundle/tracing"
  awk '$1 == "test" { print $2 }' <<<"$exes" | xargs -I{} cp {} "$bundle/tests/"
  strip "$bundle/gi" "$bundle/tracing" "$bundle"/tests/*
  echo "gpu-check: bundle in $bundle, built at $root ($(du -sh "$bundle" | cut -f1))"
  exit 0
fi

mkdir -p "$out"
out=$(cd "$out" && pwd)
summary=$out/summary.md
printf '| step | exit | seconds |\n|---|---|---|\n' >"$summary"
failed=0
# step NAME COMMAND...: runs COMMAND with its output in NAME.log (and on the terminal).
step() {
  local name=$1
  shift
  local t0=$SECONDS
  echo "== $name: $*" | tee "$out/$name.log"
  "$@" 2>&1 | tee -a "$out/$name.log"
  local rc=${PIPESTATUS[0]}
  printf '| %s | %s | %s |\n' "$name" "$rc" $((SECONDS - t0)) >>"$summary"
  [ "$rc" -eq 0 ] || failed=1
}

if [ -n "$prebuilt" ]; then
  bin=$(cd "$prebuilt" && pwd)
  gi=$bin/gi
  tests=("$bin"/tests/*)
  bench=$bin/tracing
else
  t0=$SECONDS
  if ! exes=$(build 2>"$out/build.log"); then
    cat "$out/build.log"
    echo "gpu-check: the build failed"
    exit 1
  fi
  printf '| build | 0 | %s |\n' $((SECONDS - t0)) >>"$summary"
  gi=$(awk '$1 == "gi" { print $2; exit }' <<<"$exes")
  bench=$(awk '$1 == "bench" { print $2; exit }' <<<"$exes")
  mapfile -t tests < <(awk '$1 == "test" { print $2 }' <<<"$exes")
fi

if [ "$small" -eq 1 ]; then
  size=(--width 160 --height 90)
  sweep_frames=(--frames 8 --motion-frames 4 --reference-spp 16)
  frames=8
else
  size=(--width 1920 --height 1080)
  sweep_frames=(--frames 32 --motion-frames 16 --reference-spp 256)
  frames=64
fi
interior=$shared/scenes/third-party/bitterli/staircase/staircase.glb

step info "$gi" info

scenes=(scenes/cornell-box.gltf)
if [ -f "$interior" ]; then
  scenes+=("$interior")
else
  echo "gpu-check: $interior absent: the Cornell box alone"
fi

# Per-pass GPU time and memory table of one GI frame per preset (gi render prints both).
frame_tables() {
  local rc=0
  for scene in "${scenes[@]}"; do
    for preset in fast balanced quality; do
      echo "--- $scene, $preset"
      "$gi" render "$scene" --preset "$preset" "${size[@]}" --frames "$frames" \
        --out "$out/frames/$(basename "${scene%.*}")-$preset.exr" || rc=1
    done
  done
  return $rc
}
step frame-tables frame_tables
step sweep "$gi" sweep "${scenes[@]}" --sweep presets "${size[@]}" "${sweep_frames[@]}" \
  --equal-time-max-spp 0 --out "$out/sweep"

if [ "$small" -eq 1 ]; then
  step tracing-bench "$bench" --bench cornell
else
  step tracing-bench "$bench" --bench
fi

# The GPU tests, each binary from the tests' folder as cargo runs them.
run_tests() {
  local rc=0
  for t in "${tests[@]}"; do
    (cd "$root/tests" && "$t" --include-ignored) || rc=1
  done
  return $rc
}
[ "$small" -eq 1 ] || step gpu-tests run_tests

cat "$summary"
exit "$failed"

#!/usr/bin/env bash
# Runs the libFuzzer targets of fuzz/ (cargo-fuzz), each for SECONDS (default 30), one after the
# other; installs cargo-fuzz if it is missing. Usage: scripts/fuzz.sh [SECONDS [TARGET...]]
#
# Seeds: the repository's scenes and test scenes (tests/data, tests/data/bad) for `scene`, the
# small files of fuzz/seeds/<target> for the image readers. New inputs go to fuzz/corpus/<target>
# (ignored by git), findings to fuzz/artifacts/<target>, and the run fails on the first one.
# An input that takes over 10 s, or a process over 4 GiB, counts as a finding.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-30}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(scene texture environment)

command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked

for target in "${targets[@]}"; do
    case $target in
    scene) seeds=(scenes tests/data tests/data/bad) ;;
    texture | environment) seeds=("fuzz/seeds/$target") ;;
    *)
        echo "unknown fuzz target $target (scene, texture, environment)" >&2
        exit 2
        ;;
    esac
    mkdir -p "fuzz/corpus/$target"
    echo "fuzz target $target: ${seconds} s"
    # Paths as seen from fuzz/, where cargo-fuzz runs the target.
    cargo fuzz run --fuzz-dir fuzz "$target" "fuzz/corpus/$target" "${seeds[@]}" -- \
        -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 -print_final_stats=1
done

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

# Build products: in the machine's persistent target directory when one is set (scripts/env.sh),
# under fuzz/ otherwise. Every crate is built with sanitizer flags, so none is shared with the
# workspace's own builds.
target_dir=${CARGO_TARGET_DIR:+$CARGO_TARGET_DIR/fuzz}
target_dir=${target_dir:-fuzz/target}
# One build of every target, then the binaries themselves: `cargo fuzz run` builds again on each
# call (twice), and gi-host's build script reruns whenever ../shared/scenes/third-party is absent.
cargo fuzz build --fuzz-dir fuzz --target-dir "$target_dir"
bin="$target_dir/$(rustc -vV | sed -n 's/^host: //p')/release"

for target in "${targets[@]}"; do
    case $target in
    scene) seeds=(scenes tests/data tests/data/bad) ;;
    texture | environment) seeds=("fuzz/seeds/$target") ;;
    *)
        echo "unknown fuzz target $target (scene, texture, environment)" >&2
        exit 2
        ;;
    esac
    mkdir -p "fuzz/corpus/$target" "fuzz/artifacts/$target"
    echo "fuzz target $target: ${seconds} s"
    "$bin/$target" -artifact_prefix="fuzz/artifacts/$target/" -max_total_time="$seconds" \
        -timeout=10 -rss_limit_mb=4096 -print_final_stats=1 \
        "fuzz/corpus/$target" "${seeds[@]}"
done

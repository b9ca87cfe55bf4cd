# Sourced by the scripts: one persistent cargo target directory per machine, so the ~7-minute
# first build of rust-gpu's backend (rustc_codegen_spirv) is paid once, not once per clone.
# Set CARGO_TARGET_DIR yourself to use another.
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-${HOME:-/root}/.cache/gi/target}"
mkdir -p "$CARGO_TARGET_DIR"

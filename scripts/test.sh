#!/usr/bin/env bash
# The test command of README.md (and of CI): installs what is missing, then runs every test in two
# groups: CPU tests (the shared crate's math, the host's unit tests) and GPU tests (kernels on the
# Vulkan device, lavapipe here, with the validation layer on; any validation message fails).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/env.sh

count() { # sums cargo's "test result:" lines of a log: passed failed
  awk '/^test result:/ { p += $4; f += $6 } END { print p + 0, f + 0 }' "$1"
}
cpu_log=$(mktemp) gpu_log=$(mktemp)
trap 'rm -f "$cpu_log" "$gpu_log"' EXIT
status=0
echo "== CPU tests (gi-shared, gi-host)"
cargo test -p gi-shared -p gi-host "$@" 2>&1 | tee "$cpu_log" || status=1
echo "== GPU tests (gi-tests, on the Vulkan device)"
cargo test -p gi-tests "$@" 2>&1 | tee "$gpu_log" || status=1
read -r cp cf < <(count "$cpu_log")
read -r gp gf < <(count "$gpu_log")
echo "CPU tests: $cp passed, $cf failed"
echo "GPU tests: $gp passed, $gf failed"
echo "all: $((cp + gp)) passed, $((cf + gf)) failed"
exit "$status"

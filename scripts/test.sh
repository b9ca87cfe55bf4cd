#!/usr/bin/env bash
# The test command of README.md (and of CI): installs what is missing, then runs every test of the
# workspace in one cargo invocation and reports two groups: CPU tests (the shared crate's math, the
# host's unit and integration tests) and GPU tests (the `gi-tests` package: kernels on the Vulkan
# device, lavapipe here, with the validation layer on; any validation message fails).
#
# One invocation over the whole workspace, in the `dev` profile, matters: cargo unifies dependency
# features over the packages it builds and keys build dependencies by profile, so another
# selection or the `test` profile would rebuild rust-gpu's backend (7 minutes) beside the one
# `scripts/run.sh` and clippy use.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/env.sh

start=$SECONDS
log=$(mktemp)
trap 'rm -f "$log"' EXIT
status=0
cargo test --profile dev --workspace "$@" 2>&1 | tee "$log" || status=1
# cargo prints "Running <target> (<path of the test binary>)" before each binary's results; the
# binaries of gi-tests live under a path naming their package.
# Each binary's time ("finished in 12.34s") follows its name; the slowest are listed.
awk '
  /^ *(Running|Doc-tests) / { gpu = ($0 ~ /gi[-_]tests/); name = $2; if (name == "unittests") name = name " " $3 }
  /^test result:/ {
    if (gpu) { gp += $4; gf += $6 } else { cp += $4; cf += $6 }
    t = $NF; sub(/s$/, "", t); times[name] += t
  }
  END {
    printf "CPU tests: %d passed, %d failed\n", cp, cf
    printf "GPU tests: %d passed, %d failed\n", gp, gf
    printf "all: %d passed, %d failed\n", cp + gp, cf + gf
    n = 0
    for (b in times) { names[++n] = b }
    for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++)
      if (times[names[j]] > times[names[i]]) { x = names[i]; names[i] = names[j]; names[j] = x }
    print "slowest test binaries (s):"
    for (i = 1; i <= n && i <= 8; i++) printf "  %7.1f  %s\n", times[names[i]], names[i]
  }' "$log"
echo "test command: $((SECONDS - start)) s"
exit "$status"

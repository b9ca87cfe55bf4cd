#!/usr/bin/env bash
# The long checks that do not belong in the README's test command (each runs hundreds of GI
# frames on lavapipe): the GI furnace (tests/tests/gi_furnace.rs), the 1000-moving-frame
# NaN/inf checks of the GI frame and the cache (gi_frame.rs, radiance_cache.rs) and a whole tiny
# sweep (sweep.rs), #[ignore]d in the fast suite for that reason. .ci/run calls this after the
# fast suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/env.sh
cargo test --profile dev --workspace --test gi_furnace --test gi_frame --test radiance_cache --test sweep \
  -- --ignored --nocapture --test-threads 1 "$@"
# The GPU check (scripts/gpu-check.sh, for machines with a GPU) at its small size: it keeps working
# between the sessions that have a GPU (about a minute).
bash scripts/gpu-check.sh --small --out out/gpu-check-small

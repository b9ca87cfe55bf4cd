#!/usr/bin/env bash
# The main command of README.md: installs what is missing, then runs `gi` (arguments pass through).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/env.sh
exec cargo run --quiet -p gi-host --bin gi -- "$@"

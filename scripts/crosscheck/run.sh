#!/usr/bin/env bash
# Cross-check of `gi render` against Mitsuba 3 (see crosscheck.py's docstring); run by hand, not
# in CI. Sets up a Python venv with Mitsuba 3.9.1 and numpy in ~/.cache/gi/crosscheck-venv (or
# $GI_CROSSCHECK_VENV) and libllvm19 for Mitsuba's fast LLVM variant when apt-get can install it,
# then runs crosscheck.py with the arguments given (--help lists them).
set -euo pipefail
cd "$(dirname "$0")/../.."
venv="${GI_CROSSCHECK_VENV:-$HOME/.cache/gi/crosscheck-venv}"
if ! ldconfig -p | grep -q 'libLLVM.so.19\|libLLVM-19'; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get install -y libllvm19 >/dev/null ||
    echo "libllvm19 not installed: Mitsuba falls back to its slow scalar_rgb variant"
fi
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c 'import mitsuba, numpy' 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet mitsuba==3.9.1 numpy
fi
# -B: no __pycache__ in the tree.
exec "$venv/bin/python" -B scripts/crosscheck/crosscheck.py "$@"

#!/usr/bin/env bash
# The benchmarks' Python environment: bench/.venv with numpy, scipy and pyyaml (from PyPI).
# Made once; a no-op when it already imports all three. Used by run.sh and by the docs test,
# which runs every benchmark block of docs/benchmarks/ (quick, BENCH_QUICK=1) in CI.
# Usage: bash bench/venv.sh
set -euo pipefail

BENCH=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
VENV=$BENCH/.venv
PY=$VENV/bin/python

if [ ! -x "$PY" ]; then
    if ! python3 -m venv "$VENV" >/dev/null 2>&1; then
        rm -rf "$VENV"
        echo "venv.sh: 'python3 -m venv' failed: the venv module (with ensurepip) is missing." >&2
        echo "         On Debian/Ubuntu: apt-get update && apt-get install -y python3-venv" >&2
        exit 1
    fi
fi
if ! "$PY" -c 'import numpy, scipy, yaml' 2>/dev/null; then
    "$PY" -m pip install --quiet --disable-pip-version-check --upgrade pip
    "$PY" -m pip install --quiet --disable-pip-version-check numpy scipy pyyaml
fi

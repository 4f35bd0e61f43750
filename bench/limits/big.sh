#!/usr/bin/env bash
# Issue 50, items 8 and 9: the 7-joint all-unknown models under time and memory limits
# (docs/benchmarks/resources.md, session 23). Usage, from the repository's root:
#   bash bench/limits/big.sh              (LINCAL=path, default `lincal` on PATH)
# 9: `calibrate --start linear` on a sphere, K = 2187, 2300 poses (about 45 s, 610 MB);
# 8: `basis --max-terms 10000000` of the measured-pose model under a 2 GiB address-space limit.
# BENCH_QUICK=1 (CI) leaves out the 45 s calibration (its linear start needs K - 1 = 2186
# poses, so it cannot be made smaller); the basis runs are run in full.
set -euo pipefail
L=${LINCAL:-lincal}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# GNU time's peak memory when it is installed, the shell's wall time otherwise.
timed() {
    if [ -x /usr/bin/time ]; then /usr/bin/time -f "%e s, %M kB peak" "$@"; else time "$@"; fi
}

if [ "${BENCH_QUICK:-0}" != 1 ]; then
    "$L" simulate "$here/arm7_all_unknown_sphere.yaml" --poses 2300 --seed 3 --noise-track 1e-5 \
        > "$work/arm7_sphere.csv"
    timed "$L" calibrate "$here/arm7_all_unknown_sphere.yaml" "$work/arm7_sphere.csv" --start linear
else
    echo "big.sh: BENCH_QUICK=1: the 2300-pose linear calibration (about 45 s) is left out" >&2
fi
prlimit --as=$((2 * 1024 * 1024 * 1024)) "$L" basis "$here/arm7_all_unknown_pose.yaml" \
    --max-terms 10000000 > "$work/basis.txt"
timed "$L" basis "$here/arm7_all_unknown_pose.yaml" --max-terms 10000000 --format json > /dev/null

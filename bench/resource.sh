#!/usr/bin/env bash
# Resource check (not part of CI; memory targets live in benchmarks): a million measured PUMA
# poses through `lincal simulate` (streamed) and `lincal calibrate --refine`, wall time and peak
# memory of each, against the stated bounds. Exit 1 when a bound is crossed.
#   bash bench/resource.sh            (LINCAL=/path/to/lincal to use another binary)
set -euo pipefail
# LINCAL relative to where this was called from, or a command on PATH
case ${LINCAL:-} in
    "") LINCAL=$(cd "$(dirname "$0")/.." && pwd)/target/release/lincal ;;
    /*) ;;
    */*) LINCAL=$PWD/$LINCAL ;;
    *) LINCAL=$(command -v "$LINCAL" || echo "$LINCAL") ;;
esac
cd "$(dirname "$0")"
N=${N:-1000000}
SIM_MB=${SIM_MB:-100}        # simulate streams: memory must not grow with N
CAL_MB=${CAL_MB:-100}        # issue 9's target; the readings alone are 72 MB at 10^6
CAL_S=${CAL_S:-10}           # issue 9's target: under 10 s end to end
if [ "${BENCH_QUICK:-0}" = 1 ]; then
    # CI runs this beside other tests on its two cores: the memory bound holds there, the
    # time is not a measurement (three times the bound still catches a regression like 16 s).
    CAL_S=30
fi
command -v /usr/bin/time >/dev/null || { echo "needs GNU time (/usr/bin/time)" >&2; exit 2; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
spec=specs/puma560_mdh_measured.yaml
"$LINCAL" simulate "$spec" --poses 1 --seed 1 --truth-out "$out/truth.yaml" >/dev/null
/usr/bin/time -f "%e %M" -o "$out/sim.t" "$LINCAL" simulate "$spec" --poses "$N" --seed 4 \
    --noise-measure 50e-6 --truth "$out/truth.yaml" >"$out/data.csv"
/usr/bin/time -f "%e %M" -o "$out/cal.t" "$LINCAL" calibrate "$spec" "$out/data.csv" --refine \
    --format json >"$out/cal.json"
read -r st sk <"$out/sim.t"
read -r ct ck <"$out/cal.t"
sm=$((sk / 1024)); cm=$((ck / 1024))
printf '| step | poses | time | peak memory | bound |\n|---|---|---|---|---|\n'
printf '| simulate | %s | %s s | %s MB | %s MB |\n' "$N" "$st" "$sm" "$SIM_MB"
printf '| calibrate --refine | %s | %s s | %s MB | %s MB, %s s |\n' "$N" "$ct" "$cm" "$CAL_MB" "$CAL_S"
fail=0
[ "$sm" -le "$SIM_MB" ] || { echo "simulate: $sm MB > $SIM_MB MB" >&2; fail=1; }
[ "$cm" -le "$CAL_MB" ] || { echo "calibrate: $cm MB > $CAL_MB MB" >&2; fail=1; }
awk -v t="$ct" -v b="$CAL_S" 'BEGIN { exit !(t <= b) }' || { echo "calibrate: $ct s > $CAL_S s" >&2; fail=1; }
exit $fail

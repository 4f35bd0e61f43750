#!/usr/bin/env bash
# lincal side by side with a plain scipy Levenberg-Marquardt peer (bench/peer_lm.py).
# Usage: bash bench/run.sh            (BENCH_BIG=1 adds PUMA at 1 000 000 poses, lincal only)
#        LINCAL=/path/to/lincal bash bench/run.sh
set -euo pipefail

BENCH=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
cd "$BENCH"
LINCAL=${LINCAL:-$BENCH/../target/release/lincal}
OUT=$BENCH/out
VENV=$BENCH/.venv
PY=$VENV/bin/python
mkdir -p "$OUT"

[ -x "$LINCAL" ] || { echo "run.sh: no lincal binary at $LINCAL (cargo build --release, or set LINCAL)" >&2; exit 1; }

# 1. the Python environment ----------------------------------------------------------------
if [ ! -x "$PY" ]; then
    if ! python3 -m venv "$VENV" >/dev/null 2>&1; then
        rm -rf "$VENV"
        echo "run.sh: 'python3 -m venv' failed: the venv module (with ensurepip) is missing." >&2
        echo "        On Debian/Ubuntu: apt-get update && apt-get install -y python3-venv" >&2
        exit 1
    fi
fi
if ! "$PY" -c 'import numpy, scipy, yaml' 2>/dev/null; then
    "$PY" -m pip install --quiet --upgrade pip
    "$PY" -m pip install --quiet numpy scipy pyyaml
fi

# timing: the whole process, wall time and peak resident memory -----------------------------
# Each side is run REPS times (default 3) and the median wall time is reported, so one
# unlucky run (a cold cache, a background job) does not decide a ratio either way.
REPS=${REPS:-3}
# timed NAME CMD...: the median of REPS runs of timed_once; the last run's files are kept.
timed() {
    local name=$1; shift
    local walls=() i
    for ((i = 0; i < REPS; i++)); do
        timed_once "$name" "$@"
        walls+=("$(cut -d' ' -f1 "$OUT/$name.time")")
        [ "$(cat "$OUT/$name.rc")" = 0 ] || break
    done
    local median
    median=$(printf '%s\n' "${walls[@]}" | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}')
    echo "$median $(cut -d' ' -f2 "$OUT/$name.time")" >"$OUT/$name.time"
}
# timed_once NAME CMD...: stdout > out/NAME.out, stderr > out/NAME.err, "wall_s maxrss_kB" >
# out/NAME.time, exit status > out/NAME.rc. Never fails.
timed_once() {
    local name=$1; shift
    local rc=0
    if [ -x /usr/bin/time ]; then
        local t0 t1
        t0=$(date +%s.%N)
        /usr/bin/time -f '%M' -o "$OUT/$name.mem" "$@" >"$OUT/$name.out" 2>"$OUT/$name.err" || rc=$?
        t1=$(date +%s.%N)
        echo "$(awk -v a="$t0" -v b="$t1" 'BEGIN{printf "%.3f", b-a}') $(tail -n 1 "$OUT/$name.mem")" >"$OUT/$name.time"
    else
        "$PY" - "$OUT/$name" "$@" <<'EOF' || rc=$?
import resource, subprocess, sys, time
base, cmd = sys.argv[1], sys.argv[2:]
t0 = time.perf_counter()
with open(base + ".out", "wb") as o, open(base + ".err", "wb") as e:
    rc = subprocess.call(cmd, stdout=o, stderr=e)
wall = time.perf_counter() - t0
kb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss  # kB on Linux
open(base + ".time", "w").write(f"{wall:.3f} {kb}\n")
sys.exit(rc)
EOF
    fi
    echo "$rc" >"$OUT/$name.rc"
    return 0
}
wall() { cut -d' ' -f1 "$OUT/$1.time"; }
mem_mb() { awk '{printf "%.0f MB", $2/1024}' "$OUT/$1.time"; }
rc() { cat "$OUT/$1.rc"; }
# the first line of stderr that reports the error (lines starting "lincal:" or "Error" first)
first_err() {
    local f=$OUT/$1.err line
    line=$({ grep -m1 -E '^(lincal:|Error|Traceback|peer_lm:)|error' "$f" || grep -m1 -v '^Command exited with non-zero status' "$f" || true; } | head -n 1)
    printf '%s' "$line" | tr '|' '/' | cut -c1-140
}

# 2. the data -------------------------------------------------------------------------------
SIM() { "$LINCAL" simulate "$@"; }
A=specs/puma560_mdh_measured.yaml
B6=specs/panda_points6.yaml
B1=specs/panda_point.yaml
echo "simulating ..." >&2
SIM $A --poses 100 --seed 1 --noise-measure 50e-6 --truth-out "$OUT/truth_puma.yaml" >"$OUT/puma_100.csv"
SIM $A --poses 1000 --seed 2 --noise-measure 50e-6 --truth "$OUT/truth_puma.yaml" >"$OUT/puma_1000.csv"
SIM $A --poses 10000 --seed 3 --noise-measure 50e-6 --truth "$OUT/truth_puma.yaml" >"$OUT/puma_10000.csv"
SIM $A --poses 1000 --seed 1000 --truth "$OUT/truth_puma.yaml" >"$OUT/puma_val.csv"
if [ "${BENCH_BIG:-0}" = 1 ]; then
    SIM $A --poses 1000000 --seed 4 --noise-measure 50e-6 --truth "$OUT/truth_puma.yaml" >"$OUT/puma_1000000.csv"
fi
SIM $B6 --poses 180 --seed 1 --noise-track 50e-6 --truth-out "$OUT/truth_points6.yaml" >"$OUT/points6_180.csv"
SIM $B6 --poses 180 --seed 1000 --truth "$OUT/truth_points6.yaml" >"$OUT/points6_val.csv"
SIM $B1 --poses 60 --seed 1 --noise-track 50e-6 --truth-out "$OUT/truth_point.yaml" >"$OUT/point_60.csv"
SIM $B1 --poses 60 --seed 1000 --truth "$OUT/truth_point.yaml" >"$OUT/point_val.csv"

# 3. the runs -------------------------------------------------------------------------------
ROWS=()
# bench_case LABEL SPEC DATA VALDATA TAG RUN_PEER [TRUTH (point cases: adds the aligned error)]
bench_case() {
    local label=$1 spec=$2 data=$3 val=$4 tag=$5 peer=$6 truth=${7:-}
    local n; n=$(($(grep -vc '^#' "$data") - 1))
    echo "$label, $n poses: lincal ..." >&2
    timed "lincal_$tag" "$LINCAL" calibrate "$spec" "$data" --refine --format json
    local lt lv lm ratio st sv
    if [ "$(rc "lincal_$tag")" = 0 ]; then
        lt="$(wall "lincal_$tag") s"
        lv=$("$PY" peer_lm.py validate "$spec" "$val" "$OUT/lincal_$tag.out" $truth 2>&1 | tail -n 1)
    else
        lt="refused (exit $(rc "lincal_$tag")): $(first_err "lincal_$tag")"
        lv="—"
    fi
    lm=$(mem_mb "lincal_$tag")
    if [ "$peer" = 1 ]; then
        echo "$label, $n poses: scipy ..." >&2
        timed "scipy_$tag" "$PY" peer_lm.py fit "$spec" "$data" "$OUT/scipy_$tag.json"
        if [ "$(rc "scipy_$tag")" = 0 ]; then
            st="$(wall "scipy_$tag") s"
            sv=$("$PY" peer_lm.py validate "$spec" "$val" "$OUT/scipy_$tag.json" $truth 2>&1 | tail -n 1)
            if [ "$(rc "lincal_$tag")" = 0 ]; then
                ratio=$(awk -v s="$(wall "scipy_$tag")" -v l="$(wall "lincal_$tag")" 'BEGIN{printf "%.2f", s/l}')
            else
                ratio="—"
            fi
        else
            st="failed (exit $(rc "scipy_$tag")): $(first_err "scipy_$tag")"; sv="—"; ratio="—"
        fi
        st="$st ($(mem_mb "scipy_$tag"))"
    else
        st="not run"; sv="—"; ratio="—"
    fi
    ROWS+=("| $label | $n | $lt | $st | $ratio | $lv | $sv | $lm |")
}

bench_case "A: PUMA 560 MDH, measured" $A "$OUT/puma_100.csv" "$OUT/puma_val.csv" puma_100 1
bench_case "A: PUMA 560 MDH, measured" $A "$OUT/puma_1000.csv" "$OUT/puma_val.csv" puma_1000 1
bench_case "A: PUMA 560 MDH, measured" $A "$OUT/puma_10000.csv" "$OUT/puma_val.csv" puma_10000 1
if [ "${BENCH_BIG:-0}" = 1 ]; then
    bench_case "A: PUMA 560 MDH, measured" $A "$OUT/puma_1000000.csv" "$OUT/puma_val.csv" puma_1000000 0
fi
bench_case "B: Panda, 6 unknown points" $B6 "$OUT/points6_180.csv" "$OUT/points6_val.csv" points6_180 1 "$OUT/truth_points6.yaml"
bench_case "B: Panda, 1 unknown point" $B1 "$OUT/point_60.csv" "$OUT/point_val.csv" point_60 1 "$OUT/truth_point.yaml"

BROWS=()
for spec in $A $B6 $B1; do
    tag=basis_$(basename "$spec" .yaml)
    echo "basis $spec ..." >&2
    timed "$tag" "$LINCAL" basis "$spec" --format json
    if [ "$(rc "$tag")" = 0 ]; then
        info=$("$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); print(len(d["params"]), d["basis_size"], d["identifiable_count"], sep=" | ")' "$OUT/$tag.out")
        BROWS+=("| $(basename "$spec") | $(wall "$tag") s | $(mem_mb "$tag") | $info |")
    else
        BROWS+=("| $(basename "$spec") | failed (exit $(rc "$tag")): $(first_err "$tag") | $(mem_mb "$tag") | | | |")
    fi
done

# 4. the tables -----------------------------------------------------------------------------
{
    echo "## lincal vs scipy least_squares(method='lm')"
    echo
    echo "$("$LINCAL" --version 2>/dev/null || true), $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores. Times are whole processes"
    echo "(\`lincal calibrate --refine --format json\`; \`python peer_lm.py fit\`, imports included),"
    echo "the median of $REPS runs each (peak memory: the last run; a failing run ends its repeats)."
    echo "Validation, metres: (A) RMS tip error on 1000 noise-free poses of the same truth; (B) RMS spread"
    echo "of the predicted tips about each point's mean on noise-free poses of the same truth, then"
    echo "after '/' the RMS tip error on 1000 free poses (uniform in [-pi, pi]) against the true arm after"
    echo "the best similarity transform (the spread alone cannot see an arm collapsed onto its point)."
    echo "Noise: A 50 um per measured coordinate, B 50 um tracking; validation sets noise-free."
    echo
    echo "| case | poses | lincal time | scipy time (peak mem) | ratio scipy/lincal | lincal validation RMS | scipy validation RMS | lincal peak memory |"
    echo "|---|---|---|---|---|---|---|---|"
    printf '%s\n' "${ROWS[@]}"
    echo
    echo "### \`lincal basis SPEC --format json\`"
    echo
    echo "| spec | time | peak memory | params | K (basis_size) | identifiable_count |"
    echo "|---|---|---|---|---|---|"
    printf '%s\n' "${BROWS[@]}"
} | tee "$OUT/results.md"

#!/usr/bin/env bash
# lincal side by side with a Ceres Solver peer (bench/ceres/peer_ceres) and a plain scipy
# Levenberg-Marquardt peer (bench/peer_lm.py).
# Usage: bash bench/run.sh            (BENCH_BIG=1 adds PUMA at 1 000 000 poses, lincal only)
#        LINCAL=/path/to/lincal bash bench/run.sh
#        CERES=0 bash bench/run.sh    (without the Ceres peer; REPS=5 for 5 runs a side;
#                                      CERES_ARGS="--tolerance 1e-8": tighter Ceres tolerances)
#        BENCH_QUICK=1 bash bench/run.sh   (one round, PUMA at 100 poses and the Panda on one
#                                      point: proves the commands run, as CI does; its times
#                                      are not measurements)
set -euo pipefail

BENCH=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
LINCAL=${LINCAL:-$BENCH/../target/release/lincal}
# LINCAL relative to where run.sh was called from, or a command on PATH
case $LINCAL in
    /*) ;;
    */*) LINCAL=$PWD/$LINCAL ;;
    *) LINCAL=$(command -v "$LINCAL" || echo "$LINCAL") ;;
esac
cd "$BENCH"
OUT=$BENCH/out
VENV=$BENCH/.venv
PY=$VENV/bin/python
mkdir -p "$OUT"
rm -f "$OUT"/*.rc   # a status is this run's, never an earlier one's

[ -x "$LINCAL" ] || { echo "run.sh: no lincal binary at $LINCAL (cargo build --release, or set LINCAL)" >&2; exit 1; }

# 1. the Python environment (bench/.venv: numpy, scipy, pyyaml) ------------------------------
bash "$BENCH/venv.sh"

# 1b. the Ceres peer (C++; bench/ceres/build.sh installs libceres-dev with apt-get if missing) --
CERES=${CERES:-1}
CERES_BIN=${CERES_BIN:-$BENCH/ceres/peer_ceres}
# extra options for every Ceres run, e.g. CERES_ARGS="--tolerance 1e-8" (default: Ceres' defaults)
read -r -a CERES_EXTRA <<<"${CERES_ARGS:-}"
# extra options for every lincal calibrate run, e.g. LINCAL_ARGS="--prior off" (default: none)
read -r -a LINCAL_EXTRA <<<"${LINCAL_ARGS:-}"
CERES_SKIP=""
if [ "$CERES" != 1 ]; then
    CERES_SKIP="CERES=$CERES"
elif [ "$CERES_BIN" != "$BENCH/ceres/peer_ceres" ]; then
    [ -x "$CERES_BIN" ] || CERES_SKIP="no binary at CERES_BIN=$CERES_BIN"
elif [ ! -x "$CERES_BIN" ] || [ "$BENCH/ceres/peer_ceres.cpp" -nt "$CERES_BIN" ]; then
    echo "run.sh: building the Ceres peer (bash bench/ceres/build.sh) ..." >&2
    if ! bash "$BENCH/ceres/build.sh" || [ ! -x "$CERES_BIN" ]; then
        CERES_SKIP="no binary at $CERES_BIN and bench/ceres/build.sh failed"
    fi
fi
if [ -n "$CERES_SKIP" ]; then
    echo "run.sh: the Ceres peer is skipped ($CERES_SKIP); lincal and scipy only." >&2
fi

# timing: the whole process, wall time and peak resident memory -----------------------------
# Each side is run REPS times (default 3) and the median wall time is reported, so one
# unlucky run (a cold cache, a background job) does not decide a ratio either way.
REPS=${REPS:-3}
QUICK=${BENCH_QUICK:-0}
if [ "$QUICK" = 1 ]; then
    REPS=1
    echo "run.sh: BENCH_QUICK=1: one round, PUMA at 100 poses and the Panda on one point; the times are not measurements" >&2
fi
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
# timed NAME CMD...: the median of REPS runs of timed_once; the last run's files are kept.
timed() {
    local name=$1; shift
    local walls=() i
    for ((i = 0; i < REPS; i++)); do
        timed_once "$name" "$@"
        walls+=("$(cut -d' ' -f1 "$OUT/$name.time")")
        [ "$(cat "$OUT/$name.rc")" = 0 ] || break
    done
    echo "$(median "${walls[@]}") $(cut -d' ' -f2 "$OUT/$name.time")" >"$OUT/$name.time"
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
    line=$({ grep -m1 -E '^(lincal:|Error|Traceback|peer_lm:|peer_ceres:)|error' "$f" || grep -m1 -v '^Command exited with non-zero status' "$f" || true; } | head -n 1)
    printf '%s' "$line" | tr '|' '/' | cut -c1-140
}

# 2. the data -------------------------------------------------------------------------------
SIM() { "$LINCAL" simulate "$@"; }
A=specs/puma560_mdh_measured.yaml
B6=specs/panda_points6.yaml
B1=specs/panda_point.yaml
SPECS=($A $B6 $B1)
[ "$QUICK" != 1 ] || SPECS=($A $B1)
echo "simulating ..." >&2
SIM $A --poses 100 --seed 1 --noise-measure 50e-6 --truth-out "$OUT/truth_puma.yaml" >"$OUT/puma_100.csv"
if [ "$QUICK" != 1 ]; then
    SIM $A --poses 1000 --seed 2 --noise-measure 50e-6 --truth "$OUT/truth_puma.yaml" >"$OUT/puma_1000.csv"
    SIM $A --poses 10000 --seed 3 --noise-measure 50e-6 --truth "$OUT/truth_puma.yaml" >"$OUT/puma_10000.csv"
fi
SIM $A --poses 1000 --seed 1000 --truth "$OUT/truth_puma.yaml" >"$OUT/puma_val.csv"
if [ "${BENCH_BIG:-0}" = 1 ] && [ "$QUICK" != 1 ]; then
    SIM $A --poses 1000000 --seed 4 --noise-measure 50e-6 --truth "$OUT/truth_puma.yaml" >"$OUT/puma_1000000.csv"
fi
if [ "$QUICK" != 1 ]; then
    SIM $B6 --poses 180 --seed 1 --noise-track 50e-6 --truth-out "$OUT/truth_points6.yaml" >"$OUT/points6_180.csv"
    SIM $B6 --poses 180 --seed 1000 --truth "$OUT/truth_points6.yaml" >"$OUT/points6_val.csv"
fi
SIM $B1 --poses 60 --seed 1 --noise-track 50e-6 --truth-out "$OUT/truth_point.yaml" >"$OUT/point_60.csv"
SIM $B1 --poses 60 --seed 1000 --truth "$OUT/truth_point.yaml" >"$OUT/point_val.csv"

# the Ceres peer's problem files (untimed): the spec as plain text, and the parameters lincal
# holds (`lincal basis SPEC --format json`: held) fixed at their nominals, as lincal fixes them
if [ -z "$CERES_SKIP" ]; then
    for spec in "${SPECS[@]}"; do
        if ! "$PY" ceres/prepare.py "$spec" "$LINCAL" "$OUT/ceres_$(basename "$spec" .yaml).problem"; then
            CERES_SKIP="bench/ceres/prepare.py failed on $spec"
            echo "run.sh: the Ceres peer is skipped ($CERES_SKIP)." >&2
            break
        fi
    done
fi

# 3. the runs -------------------------------------------------------------------------------
# run_side SIDE TAG SPEC DATA: one timed run of one side (out/SIDE_TAG.*)
run_side() {
    local side=$1 tag=$2 spec=$3 data=$4
    local prob=$OUT/ceres_$(basename "$spec" .yaml).problem
    case $side in
        # lincal at its default options (the product users run): its prior's strength is
        # chosen from the data and fades as poses are added. LINCAL_ARGS adds options (for
        # a side study only: a benchmark that changes a default measures another product).
        lincal) timed_once "lincal_$tag" "$LINCAL" calibrate "$spec" "$data" --refine --format json ${LINCAL_EXTRA[@]+"${LINCAL_EXTRA[@]}"} ;;
        ceres) timed_once "ceres_$tag" "$CERES_BIN" "$prob" "$data" "$OUT/ceres_$tag.json" --threads 1 ${CERES_EXTRA[@]+"${CERES_EXTRA[@]}"} ;;
        ceres2) timed_once "ceres2_$tag" "$CERES_BIN" "$prob" "$data" "$OUT/ceres2_$tag.json" --threads 2 ${CERES_EXTRA[@]+"${CERES_EXTRA[@]}"} ;;
        scipy) timed_once "scipy_$tag" "$PY" peer_lm.py fit "$spec" "$data" "$OUT/scipy_$tag.json" ;;
    esac
}
# interleaved TAG SPEC DATA SIDES...: REPS rounds, each round runs every side once in the
# order given (so a change of load hits all sides alike); the median wall time of each side
# goes to out/SIDE_TAG.time, with the last run's peak memory. A failing run ends that side's
# repeats.
interleaved() {
    local tag=$1 spec=$2 data=$3; shift 3
    local side i
    local -A walls=() stop=()
    for ((i = 0; i < REPS; i++)); do
        for side in "$@"; do
            [ -z "${stop[$side]:-}" ] || continue
            echo "  round $((i + 1))/$REPS: $side" >&2
            run_side "$side" "$tag" "$spec" "$data"
            walls[$side]+="$(wall "${side}_$tag") "
            [ "$(rc "${side}_$tag")" = 0 ] || stop[$side]=1
        done
    done
    for side in "$@"; do
        # shellcheck disable=SC2086
        echo "$(median ${walls[$side]}) $(cut -d' ' -f2 "$OUT/${side}_$tag.time")" >"$OUT/${side}_$tag.time"
    done
}

LOAD0=$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo "?")
CERES_VERSION=$(dpkg-query -W -f='${Version}' libceres-dev 2>/dev/null || echo "?")
[ -z "$CERES_SKIP" ] || CERES_VERSION="$CERES_VERSION, skipped: $CERES_SKIP"
# ratio SIDE TAG: the side's median time over lincal's ("—" when either failed)
ratio() {
    if [ "$(rc "lincal_$2")" = 0 ] && [ "$(rc "$1_$2")" = 0 ]; then
        awk -v s="$(wall "$1_$2")" -v l="$(wall "lincal_$2")" 'BEGIN{printf "%.2f", s/l}'
    else
        echo "—"
    fi
}
ROWS=()
# bench_case LABEL SPEC DATA VALDATA TAG RUN_PEERS [TRUTH (point cases: adds the aligned error)]
bench_case() {
    local label=$1 spec=$2 data=$3 val=$4 tag=$5 peer=$6 truth=${7:-}
    local n; n=$(($(grep -vc '^#' "$data") - 1))
    local sides=(lincal)
    if [ "$peer" = 1 ]; then
        [ -n "$CERES_SKIP" ] || sides+=(ceres ceres2)
        sides+=(scipy)
    fi
    echo "$label, $n poses: ${sides[*]}, interleaved, $REPS rounds ..." >&2
    interleaved "$tag" "$spec" "$data" "${sides[@]}"
    local lt lv lm st sv sr ct c2t cv cr
    if [ "$(rc "lincal_$tag")" = 0 ]; then
        lt="$(wall "lincal_$tag") s"
        lv=$("$PY" peer_lm.py validate "$spec" "$val" "$OUT/lincal_$tag.out" $truth 2>&1 | tail -n 1)
    else
        lt="refused (exit $(rc "lincal_$tag")): $(first_err "lincal_$tag")"
        lv="—"
    fi
    lm=$(mem_mb "lincal_$tag")
    if [ "$peer" = 1 ] && [ -z "$CERES_SKIP" ]; then
        if [ "$(rc "ceres_$tag")" = 0 ]; then
            ct="$(wall "ceres_$tag") s ($(mem_mb "ceres_$tag"))"
            cv=$("$PY" peer_lm.py validate "$spec" "$val" "$OUT/ceres_$tag.json" $truth 2>&1 | tail -n 1)
        else
            ct="failed (exit $(rc "ceres_$tag")): $(first_err "ceres_$tag")"; cv="—"
        fi
        if [ "$(rc "ceres2_$tag")" = 0 ]; then
            c2t="$(wall "ceres2_$tag") s"
            local c2v
            c2v=$("$PY" peer_lm.py validate "$spec" "$val" "$OUT/ceres2_$tag.json" $truth 2>&1 | tail -n 1)
            [ "$c2v" = "$cv" ] || cv="$cv (2 threads: $c2v)"
        else
            c2t="failed (exit $(rc "ceres2_$tag")): $(first_err "ceres2_$tag")"
        fi
        cr="$(ratio ceres "$tag") / $(ratio ceres2 "$tag")"
    elif [ "$peer" = 1 ]; then
        ct="skipped ($CERES_SKIP)"; c2t="—"; cv="—"; cr="—"
    else
        ct="not run"; c2t="—"; cv="—"; cr="—"
    fi
    if [ "$peer" = 1 ]; then
        if [ "$(rc "scipy_$tag")" = 0 ]; then
            st="$(wall "scipy_$tag") s"
            sv=$("$PY" peer_lm.py validate "$spec" "$val" "$OUT/scipy_$tag.json" $truth 2>&1 | tail -n 1)
        else
            st="failed (exit $(rc "scipy_$tag")): $(first_err "scipy_$tag")"; sv="—"
        fi
        st="$st ($(mem_mb "scipy_$tag"))"
        sr=$(ratio scipy "$tag")
    else
        st="not run"; sv="—"; sr="—"
    fi
    ROWS+=("| $label | $n | $lt | $ct | $c2t | $st | $cr | $sr | $lv | $cv | $sv | $lm |")
}

bench_case "A: PUMA 560 MDH, measured" $A "$OUT/puma_100.csv" "$OUT/puma_val.csv" puma_100 1
if [ "$QUICK" != 1 ]; then
    bench_case "A: PUMA 560 MDH, measured" $A "$OUT/puma_1000.csv" "$OUT/puma_val.csv" puma_1000 1
    bench_case "A: PUMA 560 MDH, measured" $A "$OUT/puma_10000.csv" "$OUT/puma_val.csv" puma_10000 1
fi
if [ "${BENCH_BIG:-0}" = 1 ] && [ "$QUICK" != 1 ]; then
    bench_case "A: PUMA 560 MDH, measured" $A "$OUT/puma_1000000.csv" "$OUT/puma_val.csv" puma_1000000 0
fi
if [ "$QUICK" != 1 ]; then
    bench_case "B: Panda, 6 unknown points" $B6 "$OUT/points6_180.csv" "$OUT/points6_val.csv" points6_180 1 "$OUT/truth_points6.yaml"
fi
bench_case "B: Panda, 1 unknown point" $B1 "$OUT/point_60.csv" "$OUT/point_val.csv" point_60 1 "$OUT/truth_point.yaml"

BROWS=()
for spec in "${SPECS[@]}"; do
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
LOAD1=$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo "?")
{
    echo "## lincal vs Ceres and scipy least_squares(method='lm')"
    echo
    echo "$("$LINCAL" --version 2>/dev/null || true), $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, load average (1, 5, 15 min) $LOAD0 before the runs, $LOAD1 after."
    echo "Times are whole processes (\`lincal calibrate --refine --format json\` at its default options ${LINCAL_ARGS:-}; \`peer_ceres PROBLEM DATA OUT\`"
    echo "with 1 and with 2 threads${CERES_ARGS:+, options $CERES_ARGS}, Ceres $CERES_VERSION; \`python peer_lm.py fit\`, imports included),"
    echo "the median of $REPS runs each, the sides interleaved (every round runs each side once);"
    echo "peak memory: the last run; a failing run ends its repeats. Ratios: median time over lincal's"
    echo "(Ceres: 1 thread / 2 threads)."
    echo "Validation, metres: (A) RMS tip error on 1000 noise-free poses of the same truth; (B) RMS spread"
    echo "of the predicted tips about each point's mean on noise-free poses of the same truth, then"
    echo "after '/' the RMS tip error on 1000 free poses (uniform in [-pi, pi]) against the true arm after"
    echo "the best similarity transform (the spread alone cannot see an arm collapsed onto its point)."
    echo "Noise: A 50 um per measured coordinate, B 50 um tracking; validation sets noise-free."
    echo
    echo "| case | poses | lincal time | Ceres time, 1 thread (peak mem) | Ceres time, 2 threads | scipy time (peak mem) | Ceres/lincal | scipy/lincal | lincal validation RMS | Ceres validation RMS | scipy validation RMS | lincal peak memory |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
    printf '%s\n' "${ROWS[@]}"
    echo
    echo "### \`lincal basis SPEC --format json\`"
    echo
    echo "| spec | time | peak memory | params | K (basis_size) | identifiable_count |"
    echo "|---|---|---|---|---|---|"
    printf '%s\n' "${BROWS[@]}"
} | tee "$OUT/results.md"

# A failed lincal run fails the bench (CI runs it, quick); a peer's failure is in the table.
failed=$(grep -lv '^0$' "$OUT"/lincal_*.rc "$OUT"/basis_*.rc 2>/dev/null || true)
if [ -n "$failed" ]; then
    echo "run.sh: lincal failed in: $(echo "$failed" | xargs -n1 basename | tr '\n' ' ')" >&2
    exit 1
fi

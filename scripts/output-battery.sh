#!/usr/bin/env bash
# Output battery: runs a broad, fixed set of `lincal` commands and stores every command's
# stdout, stderr, exit code and the files it writes, so that two binaries (before and after a
# refactor) can be compared byte for byte:
#
#   scripts/output-battery.sh /tmp/lincal-old /tmp/battery-old
#   scripts/output-battery.sh target/release/lincal /tmp/battery-new
#   diff -r /tmp/battery-old /tmp/battery-new        # empty when every output is identical
#
# Layout of OUTDIR: one folder per command, named by what it runs (the same names on every run),
# holding `cmd` (the command line), `stdout`, `stderr`, `rc` and, when the command wrote files
# (--write-spec, --write-urdf, --report, --truth-out), `files/`. `OUTDIR/index` lists the
# folders in run order.
#
# Determinism:
# - Every input is copied into the fixed work dir /tmp/lincal-battery-work (wiped at start) and
#   every command runs there with relative paths, so the strings lincal echoes (file names in
#   messages, the HTML report's command line and input table, the absolute URDF path that
#   `import` records in a spec) are the same for both runs whatever OUTDIR is. Two batteries
#   must therefore not run at the same time.
# - BIN is copied to the work dir as `bin/lincal` and run by that name, so clap's usage
#   messages (which print the program name) do not depend on BIN's file name.
# - Seeds are fixed; nothing is normalised (no timestamps, elapsed times or temp paths appear
#   in any output; progress bars are drawn only on a terminal and stderr is a file here).
# - The fits split large pose sets (>= 4096 poses) over min(cores, 8) threads in fixed chunks:
#   compare runs made on the same machine (same core count).
set -u

if [ $# -ne 2 ]; then
    echo "usage: $0 BIN OUTDIR" >&2
    exit 64
fi
BIN=$(realpath "$1") || exit 64
[ -x "$BIN" ] || { echo "$0: $1 is not an executable" >&2; exit 64; }
mkdir -p "$2" && OUT=$(realpath "$2") || exit 64
if [ -n "$(ls -A "$OUT")" ]; then
    echo "$0: $OUT is not empty" >&2
    exit 64
fi
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
SHARED=${LINCAL_SHARED:-$(cd "$REPO/../shared" && pwd)}

W=/tmp/lincal-battery-work
[ -e "$W" ] && chmod -R u+w "$W" && rm -rf "$W"
mkdir -p "$W"/{bin,specs/tests,specs/models,urdf,data,o}
cp "$BIN" "$W/bin/lincal"
cp "$REPO"/tests/specs/*.yaml "$W/specs/tests/"
cp "$REPO"/lincal-models/specs/*.yaml "$W/specs/models/"
cp "$REPO"/tests/urdf/*.urdf "$W/urdf/"
for c in "$SHARED"/cases/*/; do
    c=$(basename "$c")
    mkdir -p "$W/cases/$c"
    cp "$SHARED/cases/$c/spec.yaml" "$SHARED/cases/$c/data.csv" "$W/cases/$c/"
done
chmod -R u+w "$W"
cd "$W" || exit 1

export PATH="$W/bin:$PATH" LC_ALL=C
unset RUST_BACKTRACE RUST_LIB_BACKTRACE RUST_LOG
START=$SECONDS
N=0

# run NAME ARG...: runs `lincal ARG...` in the work dir. `@O@` in an argument is replaced by
# o/NAME, the command's own directory for the files it writes (copied to OUTDIR/NAME/files).
run() {
    local name=$1 a
    shift
    local d="$OUT/$name" args=()
    if [ -e "$d" ]; then
        echo "$0: duplicate command name $name" >&2
        exit 70
    fi
    mkdir -p "$d" "o/$name"
    for a in "$@"; do args+=("${a//@O@/o/$name}"); done
    {
        printf 'lincal'
        printf ' %q' "${args[@]}"
        printf '\n'
    } >"$d/cmd"
    timeout 60 lincal "${args[@]}" >"$d/stdout" 2>"$d/stderr" </dev/null
    echo $? >"$d/rc"
    if [ -n "$(ls -A "o/$name")" ]; then cp -r "o/$name" "$d/files"; fi
    echo "$name" >>"$OUT/index"
    N=$((N + 1))
}

# keep NAME DEST: the stdout of command NAME as a work file (data for later commands).
keep() { cp "$OUT/$1/stdout" "$2"; }

# corrupt IN OUT: every 25th pose with 0.5 added to its second joint reading (gross errors).
corrupt() {
    awk -F, -v OFS=, -v CONVFMT=%.17g 'NR > 1 && (NR - 1) % 25 == 0 { $2 = $2 + 0.5 } { print }' "$1" >"$2"
}

is_measured() { grep -Eq '^ *(- )?measured|constraint: *measured|measured: *\{' "$1"; }

# ---------------------------------------------------------------------------------------------
# 1. The command line itself.
run help --help
run version --version
run help_subcommand help calibrate
for s in basis calibrate simulate demo import predict; do run "help_$s" "$s" --help; done
run demo demo

# ---------------------------------------------------------------------------------------------
# 2. Every spec: basis, simulated data, calibrations, predictions.
SPECS=()
for f in specs/tests/*.yaml; do SPECS+=("$f"); done
for f in specs/models/*.yaml; do SPECS+=("$f"); done

for f in "${SPECS[@]}"; do
    s=$(basename "$f" .yaml)
    case $f in specs/tests/*) s="t_$s" ;; *) s="m_$s" ;; esac
    if is_measured "$f"; then noise=(--noise-measure 1e-5); else noise=(--noise-track 1e-5); fi

    run "basis_${s}_text" basis "$f"
    run "basis_${s}_json" basis "$f" --format json

    run "sim_${s}_clean" simulate "$f" --poses 60 --seed 2 --truth-out @O@/truth.yaml
    keep "sim_${s}_clean" "data/$s.clean.csv"
    run "sim_${s}_noisy" simulate "$f" --poses 200 --seed 5 "${noise[@]}"
    keep "sim_${s}_noisy" "data/$s.noisy.csv"

    run "cal_${s}_clean_json" calibrate "$f" "data/$s.clean.csv" --format json
    run "cal_${s}_text" calibrate "$f" "data/$s.noisy.csv"
    run "cal_${s}_json" calibrate "$f" "data/$s.noisy.csv" --format json
    keep "cal_${s}_json" "data/$s.result.json"
    run "cal_${s}_refine_json" calibrate "$f" "data/$s.noisy.csv" --refine --format json
    run "cal_${s}_nominal_json" calibrate "$f" "data/$s.noisy.csv" --start nominal --format json
    run "cal_${s}_huber_json" calibrate "$f" "data/$s.noisy.csv" --robust huber --format json
    run "cal_${s}_report" calibrate "$f" "data/$s.noisy.csv" --refine \
        --report @O@/report.html --write-spec @O@/calibrated.yaml

    run "predict_${s}_params" predict "$f" --params "data/$s.result.json" "data/$s.clean.csv"
    run "predict_${s}_nominal" predict "$f" --nominal "data/$s.clean.csv"
done

# Options on a subset: the linear start forced (exit 1 where K is beyond the data), Cauchy.
for f in specs/tests/plane_spatial.yaml specs/models/adept_one.yaml specs/models/ur10_tracker.yaml \
    specs/models/kuka_iiwa14_point.yaml specs/models/puma560_sphere.yaml; do
    s=$(basename "$f" .yaml)
    case $f in specs/tests/*) s="t_$s" ;; *) s="m_$s" ;; esac
    run "cal_${s}_linear_json" calibrate "$f" "data/$s.noisy.csv" --start linear --format json
    run "cal_${s}_cauchy_refine_text" calibrate "$f" "data/$s.noisy.csv" --robust cauchy --refine
    run "cal_${s}_linear_refine_text" calibrate "$f" "data/$s.clean.csv" --start linear --refine
done

# Encoder noise, and the written spec calibrated again / predicted with its nominals.
for s in t_plane_spatial t_measured_spatial m_adept_one m_scara_plane; do
    case $s in t_*) f=specs/tests/${s#t_}.yaml ;; *) f=specs/models/${s#m_}.yaml ;; esac
    run "sim_${s}_encoder" simulate "$f" --poses 120 --seed 23 --noise-encoder 2e-5
    keep "sim_${s}_encoder" "data/$s.encoder.csv"
    run "cal_${s}_encoder_json" calibrate "$f" "data/$s.encoder.csv" --refine --format json
    run "predict_${s}_written_spec" predict "o/cal_${s}_report/calibrated.yaml" --nominal "data/$s.clean.csv"
    run "cal_${s}_written_spec" calibrate "o/cal_${s}_report/calibrated.yaml" "data/$s.noisy.csv"
done

# ---------------------------------------------------------------------------------------------
# 3. Bad rows: every 25th pose off by 0.5 rad in q2.
for s in m_adept_one t_plane_spatial t_measured_spatial t_lines_list m_puma560_sphere t_circle_planar3; do
    case $s in t_*) f=specs/tests/${s#t_}.yaml ;; *) f=specs/models/${s#m_}.yaml ;; esac
    corrupt "data/$s.noisy.csv" "data/$s.bad.csv"
    run "bad_${s}_text" calibrate "$f" "data/$s.bad.csv"
    run "bad_${s}_reject_json" calibrate "$f" "data/$s.bad.csv" --reject-outliers --format json
    run "bad_${s}_reject_text" calibrate "$f" "data/$s.bad.csv" --reject-outliers --refine
    run "bad_${s}_huber_json" calibrate "$f" "data/$s.bad.csv" --robust huber --format json
    run "bad_${s}_cauchy_refine_json" calibrate "$f" "data/$s.bad.csv" --robust cauchy --refine --format json
    run "bad_${s}_report" calibrate "$f" "data/$s.bad.csv" --reject-outliers --report @O@/report.html
done

# ---------------------------------------------------------------------------------------------
# 4. The shared reference cases.
for c in cases/*/; do
    c=${c%/}
    n=c_$(basename "$c")
    run "basis_${n}_json" basis "$c/spec.yaml" --format json
    run "cal_${n}_text" calibrate "$c/spec.yaml" "$c/data.csv"
    run "cal_${n}_json" calibrate "$c/spec.yaml" "$c/data.csv" --format json
    keep "cal_${n}_json" "data/$n.result.json"
    run "cal_${n}_refine_json" calibrate "$c/spec.yaml" "$c/data.csv" --refine --format json
    run "cal_${n}_nominal_text" calibrate "$c/spec.yaml" "$c/data.csv" --start nominal
    run "cal_${n}_reject_huber_json" calibrate "$c/spec.yaml" "$c/data.csv" --reject-outliers --robust huber --format json
    run "cal_${n}_report" calibrate "$c/spec.yaml" "$c/data.csv" --refine \
        --report @O@/report.html --write-spec @O@/calibrated.yaml
    run "predict_${n}_params" predict "$c/spec.yaml" --params "data/$n.result.json" "$c/data.csv"
    run "predict_${n}_nominal" predict "$c/spec.yaml" --nominal "$c/data.csv"
done

# ---------------------------------------------------------------------------------------------
# 5. Truth files: written by hand (numbers and expressions), a --truth-out round trip, a spec.
cat >data/adept_truth.yaml <<'EOF'
a1: 0.375
a2: 0.42496
th1: 0.01
th2: pi/70
b1: -1.79
b2: -0.56
EOF
run sim_truth_adept_hand simulate specs/models/adept_one.yaml --poses 150 --seed 5 \
    --truth data/adept_truth.yaml --noise-track 2e-5 --truth-out @O@/truth.yaml
keep sim_truth_adept_hand data/truth_adept.csv
run cal_truth_adept_hand calibrate specs/models/adept_one.yaml data/truth_adept.csv --refine --format json
run sim_truth_roundtrip simulate specs/tests/sphere_mdh.yaml --poses 100 --seed 99 \
    --truth o/sim_t_sphere_mdh_clean/truth.yaml --truth-out @O@/truth.yaml
keep sim_truth_roundtrip data/truth_sphere.csv
run cal_truth_roundtrip calibrate specs/tests/sphere_mdh.yaml data/truth_sphere.csv --format json
run sim_truth_spec simulate specs/tests/point_planar3.yaml --poses 50 --seed 4 \
    --truth specs/tests/point_planar3.yaml
run sim_truth_partial simulate specs/models/planar3_line.yaml --poses 50 --seed 4 \
    --truth data/adept_truth.yaml
run sim_default_seed simulate specs/models/planar3_line.yaml --poses 40
run sim_all_noise simulate specs/tests/measured_spatial.yaml --poses 80 --seed 3 \
    --noise-measure 1e-4 --noise-encoder 1e-4 --noise-track 1e-4

# ---------------------------------------------------------------------------------------------
# 6. Lists of constraints: one file per constraint, headerless logs.
awk -F, 'NR == 1 { next } $3 == 0 { print $1 "," $2 }' data/t_lines_list.noisy.csv >data/lines_0.raw
awk -F, 'NR == 1 { next } $3 == 1 { print $1 "," $2 }' data/t_lines_list.noisy.csv >data/lines_1.raw
{ echo q1,q2; cat data/lines_0.raw; } >data/lines_0.csv
{ echo q1,q2; cat data/lines_1.raw; } >data/lines_1.csv
run list_two_files_text calibrate specs/tests/lines_list.yaml data/lines_0.csv data/lines_1.csv
run list_two_files_json calibrate specs/tests/lines_list.yaml data/lines_0.csv data/lines_1.csv --format json
run list_headerless_json calibrate specs/tests/lines_list.yaml data/lines_0.raw data/lines_1.raw \
    --no-header --columns q1,q2 --format json
run list_headerless_refine calibrate specs/tests/lines_list.yaml data/lines_0.raw data/lines_1.raw \
    --no-header --columns q1,q2 --refine
run err_list_too_many_files calibrate specs/tests/lines_list.yaml data/lines_0.csv data/lines_1.csv data/lines_0.csv
run predict_headerless predict specs/tests/lines_list.yaml --nominal data/lines_0.raw \
    --no-header --columns q1,q2
for k in 0 1 2; do
    awk -F, -v k=$k 'NR == 1 { next } $8 == k { print $1 "," $2 "," $3 "," $4 "," $5 "," $6 "," $7 }' \
        data/m_franka_panda_sockets.noisy.csv >data/socket_$k.raw
done
run list_sockets_headerless calibrate specs/models/franka_panda_sockets.yaml \
    data/socket_0.raw data/socket_1.raw data/socket_2.raw \
    --no-header --columns q1,q2,q3,q4,q5,q6,q7 --format json
awk -F, -v OFS=, 'NR == 1 { print "_time", $2, $1, "_note" ; next } { print NR * 0.5, $2, $1, "x" }' \
    data/m_adept_one.noisy.csv >data/adept_reordered.csv
{ echo "# a comment line"; head -1 data/m_adept_one.noisy.csv; echo "# another"; tail -n +2 data/m_adept_one.noisy.csv; } \
    >data/adept_comments.csv
run csv_reordered_underscore calibrate specs/models/adept_one.yaml data/adept_reordered.csv --format json
run csv_comments calibrate specs/models/adept_one.yaml data/adept_comments.csv
run cal_single_spec_two_files calibrate specs/models/adept_one.yaml data/lines_0.raw data/lines_0.raw \
    --no-header --columns q1,q2
awk -F, -v OFS=, 'NR == 1 { next } { print $1, $2, NR }' data/m_adept_one.noisy.csv >data/adept_extra.raw
run csv_columns_underscore calibrate specs/models/adept_one.yaml data/adept_extra.raw \
    --no-header --columns q1,q2,_t --format json

# ---------------------------------------------------------------------------------------------
# 7. Relations between constraints (a known distance fixes the scale).
cat >data/two_points.yaml <<'EOF'
# Planar 3R arm pinned at two unknown points.
name: two_points
dim: 2
joints:
  - {type: revolute, a: a1, home: th1}
  - {type: revolute, a: a2, home: th2}
  - {type: revolute, a: a3, home: th3}
params:
  a1: {nominal: 0.4}
  th1: {nominal: 0}
  a2: {nominal: 0.3}
  th2: {nominal: 0}
  a3: {nominal: 0.2}
  th3: {nominal: 0}
  x1: {nominal: 0.5}
  y1: {nominal: 0.2}
  x2: {nominal: 0.45}
  y2: {nominal: 0.25}
constraints:
  - point: {p: [x1, y1]}
  - point: {p: [x2, y2]}
EOF
{ cat data/two_points.yaml; printf 'relations:\n  - {distance: [0, 1], value: 0.0707}\n'; } >data/two_points_related.yaml
cat >data/two_lines_related.yaml <<'EOF'
name: two_lines_related
dim: 3
joints:
  - {type: revolute, a: 0, alpha: pi/2, d: d1, home: th1}
  - {type: revolute, a: a2, home: th2, limits: [-3.0, 3.0]}
  - {type: revolute, a: a3, home: th3, limits: [-3.0, 3.0]}
params:
  d1: {nominal: 0.3}
  th1: {nominal: 0.0}
  a2: {nominal: 0.4}
  th2: {nominal: 0.0}
  a3: {nominal: 0.35}
  th3: {nominal: 0.0}
  b1: {nominal: -1.5}
  b2: {nominal: -0.8}
  b3: {nominal: 0.6}
  e1: {nominal: -1.4}
  e2: {nominal: -0.75}
  e3: {nominal: 0.55}
constraints:
  - plane: {b: [b1, b2, b3]}
  - plane: {b: [e1, e2, e3]}
relations:
  - {same_normal: [0, 1]}
  - {offset: [0, 1], value: 0.05}
EOF
for r in two_points two_points_related two_lines_related; do
    run "rel_${r}_basis_text" basis "data/$r.yaml"
    run "rel_${r}_basis_json" basis "data/$r.yaml" --format json
    run "rel_${r}_sim" simulate "data/$r.yaml" --poses 80 --seed 3 --noise-track 1e-5 --truth-out @O@/truth.yaml
    keep "rel_${r}_sim" "data/$r.csv"
    run "rel_${r}_cal_json" calibrate "data/$r.yaml" "data/$r.csv" --format json
    run "rel_${r}_cal_refine_text" calibrate "data/$r.yaml" "data/$r.csv" --refine
done

# ---------------------------------------------------------------------------------------------
# 8. Large data: >= 4096 poses take the fits' multi-threaded path.
run big_sim_adept simulate specs/models/adept_one.yaml --poses 5000 --seed 3 --noise-track 1e-5
keep big_sim_adept data/big_adept.csv
run big_cal_adept_refine calibrate specs/models/adept_one.yaml data/big_adept.csv --refine --format json
run big_cal_adept_nominal calibrate specs/models/adept_one.yaml data/big_adept.csv --start nominal --robust huber --format json
run big_sim_measured simulate specs/tests/measured_spatial.yaml --poses 5000 --seed 3 --noise-measure 1e-5
keep big_sim_measured data/big_measured.csv
run big_cal_measured_refine calibrate specs/tests/measured_spatial.yaml data/big_measured.csv --refine --robust cauchy --format json
run big_sim_plane simulate specs/tests/plane_spatial.yaml --poses 5000 --seed 4 --noise-track 1e-5
keep big_sim_plane data/big_plane.csv
corrupt data/big_plane.csv data/big_plane_bad.csv
run big_cal_plane_reject calibrate specs/tests/plane_spatial.yaml data/big_plane_bad.csv --reject-outliers --refine --report @O@/report.html

# ---------------------------------------------------------------------------------------------
# 9. URDF import, calibration of imported specs, --write-urdf.
U=urdf/ur5_rail.urdf
I=urdf/iiwa14.urdf
run imp_ur5_world_ee_dh import $U --base world --tip ee_link
keep imp_ur5_world_ee_dh data/ur5_measured.yaml
run imp_ur5_world_ee_mdh import $U --base world --tip ee_link --convention mdh
keep imp_ur5_world_ee_mdh data/ur5_mdh.yaml
run imp_ur5_base_tool0_dh import $U --base base_link --tip tool0 --tool 0.03,-0.02,0.11
run imp_ur5_base_tool0_mdh import $U --base base_link --tip tool0 --tool 0.03,-0.02,0.11 --convention mdh
run imp_ur5_carriage_upper import $U --base carriage --tip upper_arm_link --tool 0.1,0.2,0.3
for k in point plane sphere line; do
    run "imp_ur5_$k" import $U --base base_link --tip ee_link --constraint $k
    keep "imp_ur5_$k" "data/ur5_$k.yaml"
done
run imp_ur5_wrist3_tool import $U --base base_link --tip wrist_3_link --tool 0,0.1,0.05
keep imp_ur5_wrist3_tool data/ur5_wrist3.yaml
run imp_iiwa_point import $I --base world --tip iiwa_link_ee --tool 0,0,0.03 --constraint point
keep imp_iiwa_point data/iiwa_point.yaml
run imp_iiwa_measured_mdh import $I --base world --tip iiwa_link_ee --convention mdh
keep imp_iiwa_measured_mdh data/iiwa_mdh.yaml
# (A few only: the basis of an imported 6-7 joint chain is 10-60 MB of output.)
run imp_basis_ur5_measured_json basis data/ur5_measured.yaml --format json
run imp_basis_ur5_point_json basis data/ur5_point.yaml --format json
run imp_basis_ur5_plane_text basis data/ur5_plane.yaml

# The measured UR5 on its rail: exact data, write spec and URDF, predict three ways, re-import.
run imp_sim_ur5 simulate data/ur5_measured.yaml --poses 150 --seed 11 --truth-out @O@/truth.yaml
keep imp_sim_ur5 data/ur5_measured.csv
run imp_cal_ur5_write calibrate data/ur5_measured.yaml data/ur5_measured.csv --format json \
    --write-spec @O@/calibrated.yaml --write-urdf @O@/calibrated.urdf
keep imp_cal_ur5_write data/ur5_result.json
run imp_predict_ur5_params predict data/ur5_measured.yaml --params data/ur5_result.json data/ur5_measured.csv
run imp_predict_ur5_written_spec predict o/imp_cal_ur5_write/calibrated.yaml --nominal data/ur5_measured.csv
run imp_reimport_ur5 import o/imp_cal_ur5_write/calibrated.urdf --base world --tip ee_link
keep imp_reimport_ur5 data/ur5_back.yaml
run imp_predict_ur5_reimported predict data/ur5_back.yaml --nominal data/ur5_measured.csv
run imp_cal_ur5_again calibrate o/imp_cal_ur5_write/calibrated.yaml data/ur5_measured.csv \
    --write-urdf @O@/again.urdf
# Noisy data on the other imported specs.
for y in ur5_mdh ur5_plane ur5_sphere ur5_point iiwa_point iiwa_mdh; do
    if is_measured "data/$y.yaml"; then noise=(--noise-measure 1e-5); else noise=(--noise-track 1e-5); fi
    run "imp_sim_$y" simulate "data/$y.yaml" --poses 200 --seed 13 "${noise[@]}"
    keep "imp_sim_$y" "data/$y.csv"
    run "imp_cal_${y}_write" calibrate "data/$y.yaml" "data/$y.csv" --format json \
        --write-urdf @O@/calibrated.urdf --write-spec @O@/calibrated.yaml
done
run imp_cal_ur5_plane_report calibrate data/ur5_plane.yaml data/ur5_plane.csv --refine --report @O@/report.html
# Errors of import and --write-urdf.
run imp_sim_ur5_wrist3 simulate data/ur5_wrist3.yaml --poses 80 --seed 5
keep imp_sim_ur5_wrist3 data/ur5_wrist3.csv
run err_write_urdf_wrist3 calibrate data/ur5_wrist3.yaml data/ur5_wrist3.csv --write-urdf @O@/x.urdf
run err_write_urdf_not_imported calibrate specs/tests/plane_spatial.yaml data/t_plane_spatial.clean.csv \
    --write-urdf @O@/x.urdf
run err_import_no_link import $U --base world --tip nowhere
run err_import_not_ancestor import $U --base ee_link --tip base_link
run err_import_floating import $U --base base_link --tip target_object
run err_import_planar import $U --base world --tip cart
run err_import_bad_tool import $U --base world --tip ee_link --tool 1,2
run err_import_missing_file import urdf/none.urdf --base a --tip b
printf '<robot name="r"><link name="a"/>' >data/broken.urdf
run err_import_broken import data/broken.urdf --base a --tip a
run err_import_bad_constraint import $U --base world --tip ee_link --constraint circle

# ---------------------------------------------------------------------------------------------
# 10. Errors: the messages and exit statuses must stay the same too.
A=specs/models/adept_one.yaml
AD=data/m_adept_one.noisy.csv
run err_spec_missing basis specs/none.yaml
run err_data_missing calibrate $A data/none.csv
run err_predict_data_missing predict $A --nominal data/none.csv
awk -F, -v OFS=, 'NR == 4 { $2 = "abc" } { print }' $AD >data/bad_cell.csv
run err_csv_bad_cell calibrate $A data/bad_cell.csv
awk -F, -v OFS=, 'NR == 5 { $0 = $0 ",0.1" } { print }' $AD >data/extra_cell.csv
run err_csv_too_many_cells calibrate $A data/extra_cell.csv
awk -F, -v OFS=, 'NR == 6 { $0 = $1 } { print }' $AD >data/short_row.csv
run err_csv_too_few_cells calibrate $A data/short_row.csv
awk -F, -v OFS=, 'NR == 3 { $1 = "NaN" } { print }' $AD >data/nan.csv
run err_csv_nan calibrate $A data/nan.csv
awk -F, -v OFS=, 'NR == 3 { $1 = "inf" } { print }' $AD >data/inf.csv
run err_csv_inf predict $A --nominal data/inf.csv
awk -F, -v OFS=, 'NR == 1 { $0 = "q1" } NR > 1 { $0 = $1 } { print }' $AD >data/missing_column.csv
run err_csv_missing_column calibrate $A data/missing_column.csv
awk -F, -v OFS=, 'NR == 1 { $0 = $0 ",extra" } NR > 1 { $0 = $0 ",1" } { print }' $AD >data/unknown_column.csv
run err_csv_unknown_column calibrate $A data/unknown_column.csv
tr , ';' <$AD >data/semicolon.csv
run err_csv_semicolon calibrate $A data/semicolon.csv
head -1 $AD >data/header_only.csv
run err_csv_header_only calibrate $A data/header_only.csv
head -4 $AD >data/three_rows.csv
run err_too_few_poses calibrate $A data/three_rows.csv
awk -F, -v OFS=, 'NR > 1 { $2 = "0.3" } { print }' $AD >data/frozen.csv
run err_frozen_joint calibrate $A data/frozen.csv
awk 'NR == 1 || NR == 2 { print } NR == 2 { for (i = 0; i < 30; i++) print }' $AD >data/identical.csv
run err_identical_poses calibrate $A data/identical.csv --format json
awk -F, -v OFS=, -v CONVFMT=%.17g 'NR > 1 { $1 = $1 * 57.29577951308232; $2 = $2 * 57.29577951308232 } { print }' $AD >data/degrees.csv
run warn_degrees calibrate $A data/degrees.csv --format json
run err_columns_mismatch calibrate $A data/lines_0.raw --no-header --columns q1,q2,q3
sed 's/type: revolute/type: Revolute/' specs/tests/plane_spatial.yaml >data/bad_case.yaml
run err_spec_case basis data/bad_case.yaml
sed 's/^dim: 3/dim: 3\ncolour: red/' specs/tests/plane_spatial.yaml >data/bad_key.yaml
run err_spec_unknown_key basis data/bad_key.yaml
sed '/^  b3:/d' specs/tests/plane_spatial.yaml >data/bad_missing_param.yaml
run err_spec_missing_param basis data/bad_missing_param.yaml
sed 's/^  b3: {nominal: 0.6}/  b3: {nominal: 0.6}\n  zz: {nominal: 1}/' specs/tests/plane_spatial.yaml >data/bad_unused_param.yaml
run err_spec_unused_param calibrate data/bad_unused_param.yaml data/t_plane_spatial.clean.csv
sed 's/^  d1: {nominal: 0.3}/  d1: {nominal: 1e400}/' specs/tests/plane_spatial.yaml >data/bad_number.yaml
run err_spec_absurd_number basis data/bad_number.yaml
sed 's/radius: r}/radius: -0.2}/' specs/tests/circle_planar3.yaml >data/bad_radius.yaml
run err_spec_negative_radius basis data/bad_radius.yaml
printf 'name: x\ndim: 2\n---\nname: y\n' >data/two_docs.yaml
run err_spec_two_documents basis data/two_docs.yaml
printf 'a1: 0.375\nzz: 3\n' >data/bad_truth.yaml
run err_truth_unknown_param simulate $A --poses 20 --truth data/bad_truth.yaml
run err_max_terms basis specs/models/puma560_sphere.yaml --max-terms 1000
run err_max_terms_calibrate calibrate specs/models/puma560_plane.yaml data/m_puma560_plane.noisy.csv --max-terms 500
run err_noise_negative simulate $A --poses 20 --noise-track -1e-3
run err_noise_absurd simulate $A --poses 20 --noise-encoder 5
run err_sim_no_poses simulate $A
run err_sim_zero_poses simulate $A --poses 0
run err_sim_unreachable simulate specs/models/scara_plane.yaml --poses 60 --seed 11
run err_unknown_subcommand frobnicate
run err_unknown_option calibrate $A $AD --bogus
run err_bad_format basis $A --format yaml
run err_bad_robust calibrate $A $AD --robust tukey
run err_report_missing_dir calibrate $A $AD --report data/no/such/dir/r.html
run err_report_is_dir calibrate $A $AD --report data
run err_predict_no_params predict $A $AD
run err_predict_both predict $A --nominal --params data/m_adept_one.result.json $AD
run err_predict_wrong_params predict specs/tests/plane_spatial.yaml \
    --params data/m_adept_one.result.json data/t_plane_spatial.clean.csv
run err_predict_params_missing predict $A --params data/none.json $AD
run err_measured_no_xyz calibrate specs/tests/measured_spatial.yaml data/t_plane_spatial.clean.csv
run err_list_no_constraint_column calibrate specs/tests/lines_list.yaml data/lines_0.csv --format json

# ---------------------------------------------------------------------------------------------
echo "$N commands in $((SECONDS - START)) s; outputs in $OUT" >&2

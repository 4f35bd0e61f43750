#!/usr/bin/env bash
# A UR5 with a touch probe, touching four planes: the table, the top of a 50 mm gauge block
# standing on it, and two of the block's side faces. Only the joint readings at each trigger
# are logged, one file per plane. Run from this folder: bash run.sh
set -euo pipefail

# The spec is shipped: spec.yaml is import's output turned into a list of four planes, with the
# block's known height as a relation (its header says what was edited and why). No import here.

# 1. Calibrate: one log per plane, in the order of `constraints:`. The summary gives each plane's
#    residual (nominal -> calibrated), the 50 mm achieved and every plane unit-normalised.
#    --write-spec: the spec again with the calibrated values as nominals, comments kept.
lincal calibrate spec.yaml plane_0.csv plane_1.csv plane_2.csv plane_3.csv \
    --write-urdf calibrated.urdf --write-spec calibrated.yaml --report report.html

# 2. The same fit as JSON (for `evaluate`, `predict`, `compensate` and the check below).
lincal calibrate spec.yaml plane_0.csv plane_1.csv plane_2.csv plane_3.csv --format json > result.json

# 3. Simulated data only: the calibrated values against the truth they were simulated from.
echo
python3 ../vs_truth.py result.json truth.yaml

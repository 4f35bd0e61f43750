#!/usr/bin/env bash
# A UR5 on a ball bar: a bar of known length (150 mm) between a ball on the flange and a
# magnetic cup on the table; the ball is moved over the sphere around the cup.
# Only joint readings are logged. Run from this folder: bash run.sh
set -euo pipefail

# The spec is shipped: spec.yaml is import's output with the bar's length made known and the
# cup's position from the drawing (its header says what was edited and why). No import here.

# 1. Calibrate on the joint log: the centre is fitted, the radius held at 0.150 m.
lincal calibrate spec.yaml ballbar.csv --write-urdf calibrated.urdf --report report.html

# 2. The same fit as JSON (for `evaluate`, `predict`, `compensate` and the check below).
lincal calibrate spec.yaml ballbar.csv --format json > result.json

# 3. Simulated data only: the calibrated values against the truth they were simulated from.
echo
python3 ../vs_truth.py result.json truth.yaml

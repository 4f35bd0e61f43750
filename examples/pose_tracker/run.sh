#!/usr/bin/env bash
# A UR5 measured by a 6-DOF tracker (position and orientation of a probe on the flange).
# Run from this folder: bash run.sh   (needs `lincal` on PATH; python3 for the last step)
set -euo pipefail

# 1. The spec: as for a laser tracker, but `measured_pose` makes the tool a frame
#    (tool_x..tool_yaw: the probe's frame on the flange, roughly 30 mm off axis and 50 mm out).
lincal import ../robot/ur5.urdf --base base_link --tip tool0 --tool 0.03,0,0.05 \
    --constraint measured_pose > spec.yaml

# 2. Calibrate on the log: joints by URDF name, x,y,z (m) and qw,qx,qy,qz (unit quaternion).
#    The noise levels of positions and orientations are estimated from the data (reported).
#    The calibrated URDF leaves the tracker's registration (the spec's base:) out.
lincal calibrate spec.yaml poses.csv --write-urdf calibrated.urdf --urdf-base urdf \
    --report report.html

# 3. The same fit as JSON, for the commands below.
lincal calibrate spec.yaml poses.csv --format json > result.json

# 4. 30 poses the fit did not see: position and orientation errors, nominal -> calibrated.
echo
lincal evaluate spec.yaml --params result.json holdout.csv

# 5. The calibrated model's tool frames at the held-out joints (x,y,z,qw,qx,qy,qz).
echo
lincal predict spec.yaml --params result.json holdout.csv > predicted.csv
head -n 3 predicted.csv

# 6. Simulated data only: the calibrated values against the truth they were simulated from.
echo
python3 ../vs_truth.py result.json truth.yaml

#!/usr/bin/env bash
# A UR5 measured by a laser tracker: URDF + tracker log -> calibrated URDF + HTML report.
# Run from this folder: bash run.sh   (needs `lincal` on PATH; python3 for the last step)
set -euo pipefail

# 1. The spec: the chain base_link -> tool0 of the URDF as a DH table whose every entry is a
#    parameter, plus the tracker's frame (base_*, unknown: nominal 0) and the reflector's
#    position (tool_*, roughly 40 mm off the flange axis and 30 mm out: --tool, in tool0's frame).
#    Notes on the parallel shoulder/elbow/wrist axes go to stderr.
lincal import ../robot/ur5.urdf --base base_link --tip tool0 --tool 0.04,0,0.03 > spec.yaml

# 2. Calibrate on the tracker log (its joint columns are headed by the URDF joint names).
#    The summary goes to stdout; the calibrated URDF (in the robot's own base frame: the
#    tracker's registration left out) and a self-contained HTML report beside it.
lincal calibrate spec.yaml tracker.csv --write-urdf calibrated.urdf --urdf-base urdf \
    --report report.html

# 3. The same fit as JSON, which `evaluate`, `predict` and `compensate` read.
lincal calibrate spec.yaml tracker.csv --format json > result.json

# 4. Judge it on 40 poses the fit did not see: the tracker's error with the calibrated model
#    (the nominal's is metres: it does not know where the tracker stands).
echo
lincal evaluate spec.yaml --params result.json holdout.csv

# 5. A program for a controller that keeps its nominal model: the joints that put the real
#    tool where the nominal model would (the filtered x,y,z in the controller's frame). The
#    spec's base is the tracker's frame, so the nominal arm is placed where the calibration
#    found it (--intended-base calibrated).
echo
lincal compensate spec.yaml --params result.json targets.csv --intended-base calibrated 2>/dev/null

# 6. Simulated data only: the calibrated values against the truth they were simulated from.
echo
python3 ../vs_truth.py result.json truth.yaml

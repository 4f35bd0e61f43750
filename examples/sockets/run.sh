#!/usr/bin/env bash
# A UR5 with a ball on its flange, pinned in three sockets of a printed part, 100 mm apart.
# No measuring instrument: only joint readings. Run from this folder: bash run.sh
set -euo pipefail

# 1. The spec: three unknown pinned points (p0*, p1*, p2*, one per socket) and, as
#    `relations:`, the known 100 mm between consecutive sockets, which fixes the scale
#    (without a known length, pinned points give the arm's shape but not its size).
lincal import ../robot/ur5.urdf --base base_link --tip tool0 --tool 0.03,0,0.04 \
    --points 3 --distance 0.1 > spec.yaml

# 2. Calibrate: one joint log per socket, in the order of the points. The summary shows each
#    socket's spread of tips (nominal -> calibrated) and the distances achieved.
lincal calibrate spec.yaml socket_0.csv socket_1.csv socket_2.csv \
    --write-urdf calibrated.urdf --report report.html

# 3. The same fit as JSON (for `evaluate`, `predict`, `compensate` and the check below).
lincal calibrate spec.yaml socket_0.csv socket_1.csv socket_2.csv --format json > result.json

# 4. Simulated data only: the calibrated values against the truth they were simulated from.
echo
python3 ../vs_truth.py result.json truth.yaml

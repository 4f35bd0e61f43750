"""Calibrating the AdeptOne (joints 1-2) on an unknown laser line, from Python.

A notebook-style walk through lincal's Python API (run it as a script, or cell by cell):
simulate an experiment, look at what the line can identify, calibrate from the joint readings
alone, and plot the residuals before and after.

    python examples/calibrate_adept.py [--out adept.png] [--poses 200] [--show]

The plot needs matplotlib (``pip install matplotlib``); without it the script prints its
numbers and skips the figure.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import lincal

HERE = Path(__file__).resolve().parent
SPEC = HERE.parent.parent / "lincal-models" / "specs" / "adept_one.yaml"

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--spec", type=Path, default=SPEC, help="the spec (default: AdeptOne)")
parser.add_argument("--poses", type=int, default=200, help="poses to simulate")
parser.add_argument("--out", type=Path, default=Path("calibrate_adept.png"), help="figure file")
parser.add_argument("--show", action="store_true", help="also open a window")
args = parser.parse_args()

# %% The spec: a planar 2R arm, its tip held on a line b·x + 1 = 0 whose b is unknown.
spec = lincal.Spec.from_yaml(args.spec)
print(spec)
basis = spec.basis()
print(f"K = {basis.basis_size} basis functions: {basis.basis}")
print(f"{basis.identifiable_count} identifiable combinations; gauge directions:")
for g in basis.gauge:
    print("   ", " + ".join(f"{c:.3g}·{name}" for name, c in g.items()))

# %% An experiment: the paper's true arm (a2/a1 = 1.13323, th2 = 0.0446 rad), a tracker that
# holds the tip within 30 µm of the line.
truth = {"a1": 0.375, "a2": 0.375 * 1.13323, "th1": 0.0, "th2": 0.0446}
sim = lincal.simulate(spec, args.poses, seed=1993, truth=truth, noise_track=30e-6)
print(f"\nsimulated {sim.q.shape[0]} poses, q of shape {sim.q.shape}")

# %% Calibrate: one linear solve, no initial guess; then refined on the geometric residual.
cal = lincal.calibrate(spec, sim.q)
refined = lincal.calibrate(spec, sim.q, refine=True)
print(cal)
for w in cal.warnings:
    print("warning:", w)

# %% The identifiable combinations against the truth (held parameters are gauge choices).
def combinations(v: dict[str, float]) -> dict[str, float]:
    return {
        "a2/a1": v["a2"] / v["a1"],
        "th2": v["th2"],
        "beta+th1": math.atan2(v["b2"], v["b1"]) + v["th1"],
        "a1*|b|": v["a1"] * math.hypot(v["b1"], v["b2"]),
    }


true_values = dict(sim.truth)
rows = [("truth", combinations(true_values)), ("nominal", combinations(spec.nominal)),
        ("linear", combinations(cal.values)), ("refined", combinations(refined.values))]
print(f"\n{'':10}" + "".join(f"{k:>14}" for k in rows[0][1]))
for label, c in rows:
    print(f"{label:10}" + "".join(f"{v:14.6f}" for v in c.values()))
print("\nparameter        value          std  held")
for name, p in refined.params.items():
    std = "-" if p["std"] is None else f"{p['std']:.2e}"
    print(f"{name:8} {p['value']:12.6f} {std:>12}  {p['held']}")

# %% Residuals: the distance of each tip from the line, before (nominal model) and after.
before = spec.residuals(sim.q)  # nominal parameters
after = refined.residuals
print(f"\nrms distance from the line: nominal {np.sqrt(np.mean(before**2)) * 1e3:.3f} mm, "
      f"calibrated {refined.residual_rms * 1e6:.2f} µm")

# %% Plot (skipped without matplotlib).
try:
    import matplotlib

    if not args.show:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no figure (pip install matplotlib)")
    raise SystemExit(0)

fig, ax = plt.subplots(1, 3, figsize=(14, 4.2))
tips = spec.tip(sim.q, refined)
nominal_tips = spec.tip(sim.q)
ax[0].plot(nominal_tips[:, 0], nominal_tips[:, 1], ".", ms=3, label="nominal model")
ax[0].plot(tips[:, 0], tips[:, 1], ".", ms=3, label="calibrated model")
b = np.array([refined.values["b1"], refined.values["b2"]])
t = np.linspace(tips[:, 0].min() - 0.05, tips[:, 0].max() + 0.05, 2)
ax[0].plot(t, -(1 + b[0] * t) / b[1], "k-", lw=0.8, label="calibrated line")
ax[0].set(title="tips", xlabel="x (m)", ylabel="y (m)")
ax[0].set_aspect("equal", adjustable="datalim")
ax[0].legend(fontsize=8)
ax[1].plot(before * 1e3, ".", ms=3, label="nominal")
ax[1].plot(after * 1e3, ".", ms=3, label="calibrated")
ax[1].set(title="distance from the line per pose", xlabel="pose", ylabel="mm")
ax[1].legend(fontsize=8)
ax[2].hist(after * 1e6, bins=30, color="C1")
ax[2].set(title="calibrated residuals", xlabel="µm", ylabel="poses")
fig.suptitle(f"{spec.name}: {len(sim.q)} poses, K = {basis.basis_size}, "
             f"rms {refined.residual_rms * 1e6:.1f} µm after calibration")
fig.tight_layout()
fig.savefig(args.out, dpi=110)
print(f"figure: {args.out}")
if args.show:
    plt.show()

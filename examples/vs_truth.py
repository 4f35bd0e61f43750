"""Compares `lincal calibrate --format json` with the truth the example was simulated from.

Usage: python3 ../vs_truth.py result.json truth.yaml
z = (calibrated - truth) / std: with honest standard deviations most |z| are below 2, and
nearly all below 3 (angles compared modulo a turn). Parameters the gauge rule holds, and known ones, are listed, not judged.
The truth must hold those at their nominals too (as the examples' truth.yaml files do): a truth
that moves a held parameter (`lincal simulate --truth-out` without `--truth` perturbs every
estimated one) is the same arm as another parameter set, the one the fit finds, and then the
z of the others measures the gauge, not the fit; the script says so.
"""
import json
import math
import sys

result = json.load(open(sys.argv[1]))["params"]
truth = {}
for line in open(sys.argv[2]):
    line = line.split("#", 1)[0].strip()
    if line:
        name, value = line.split(":", 1)
        truth[name.strip()] = float(value)

print(f"calibrated vs {sys.argv[2]} (z = (calibrated - truth) / std)")
print(f"  {'parameter':<12}{'truth':>16}{'calibrated':>16}{'std':>11}{'z':>7}")
zs = []
moved_held = []
for name, p in result.items():
    t = truth[name]
    if p["known"] or p.get("held") or p["std"] is None:
        why = "known" if p["known"] else "held by the gauge rule"
        print(f"  {name:<12}{t:>16.9f}{p['value']:>16.9f}   ({why})")
        if p.get("held") and abs(p["value"] - t) > 1e-12:
            moved_held.append(name)
        continue
    d = p["value"] - t
    if abs(d) > math.pi:  # an angle printed a turn away (pi + e against -pi + e)
        d = (d + math.pi) % (2 * math.pi) - math.pi
    z = d / p["std"]
    zs.append((abs(z), name))
    print(f"  {name:<12}{t:>16.9f}{p['value']:>16.9f}{p['std']:>11.2e}{z:>7.2f}")
worst, name = max(zs)
beyond = sum(1 for z, _ in zs if z > 3)
print(f"{len(zs)} estimated parameters, {beyond} beyond 3 std; largest |z| = {worst:.2f} ({name})")
if moved_held:
    print(
        f"note: the truth moves {', '.join(moved_held)}, which the gauge rule holds at the "
        "nominal: the fit finds the same arm with those at their nominals and the others "
        "moved to match, so these z do not judge the fit; compare predicted tips "
        "(lincal predict) or give a truth that holds them at their nominals"
    )

#!/usr/bin/env python3
"""Untimed preparation for bench/ceres/peer_ceres: a lincal spec -> a plain text problem file.

    prepare.py SPEC LINCAL OUT.txt

Reads the spec with bench/peer_lm.py's parser and asks `LINCAL basis SPEC --format json` which
parameters lincal holds at their nominals (its gauge rule: `held`); the spec's known parameters
are fixed as well. The file, one item a line (a slot is a parameter name or `=VALUE`):

    convention mdh|dh
    kind measured|point
    param NAME NOMINAL free|known|held        (every spec parameter, spec order)
    joint revolute A ALPHA D HOME             (prismatic: A ALPHA THETA OFFSET)
    tool X Y Z
    base X Y Z ROLL PITCH YAW                 (only when the spec has a base)
    point X Y Z                               (point constraints, in order)
"""
import json
import os
import subprocess
import sys

sys.dont_write_bytecode = True  # no __pycache__ in bench/
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from peer_lm import Model  # noqa: E402


def main(spec, lincal, out):
    m = Model(spec)
    basis = json.loads(subprocess.run([lincal, "basis", spec, "--format", "json"], check=True,
                                      stdout=subprocess.PIPE).stdout)
    held = set(basis.get("held", []))
    known = m.known | set(basis.get("known", []))

    def slot(s):
        return s if isinstance(s, str) else f"={s!r}"

    lines = [f"# ceres peer problem for {spec} (bench/ceres/prepare.py)",
             f"convention {m.conv}", f"kind {m.kind}"]
    for n in m.names:
        flag = "known" if n in known else "held" if n in held else "free"
        lines.append(f"param {n} {m.nominal[n]!r} {flag}")
    for j in m.joints:
        if j["prismatic"]:
            s = [j["a"], j["alpha"], j["theta"], j["offset"]]
        else:
            s = [j["a"], j["alpha"], j["d"], j["home"]]
        lines.append(" ".join(["joint", "prismatic" if j["prismatic"] else "revolute"]
                              + [slot(v) for v in s]))
    lines.append("tool " + " ".join(slot(v) for v in m.tool))
    if m.base is not None:
        lines.append("base " + " ".join(slot(m.base[k]) for k in
                                        ("x", "y", "z", "roll", "pitch", "yaw")))
    if m.kind == "point":
        for p in m.points:
            lines.append("point " + " ".join(slot(v) for v in p))
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")
    free = sum(1 for n in m.names if n not in known and n not in held)
    print(f"prepare: {spec}: {len(m.names)} parameters, held {sorted(held)}, "
          f"known {sorted(known)}, {free} free", file=sys.stderr)


if __name__ == "__main__":
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    main(*sys.argv[1:])

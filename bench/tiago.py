#!/usr/bin/env python3
"""lincal against FIGAROH's held-out figures on FIGAROH's public TIAGo motion-capture data
(issue 47's target: motion capture of an arm behind a prismatic joint).

The data are in thanhndv212/figaroh-examples, `examples/tiago` (the URDF in `urdf/`, the
recordings in `data/calibration/mocap/`). That repository has no licence, so nothing of it
is copied into this one: the script takes the directory that holds the files and finds each
by name anywhere under it (the repository's `examples/tiago`, or a flat copy). Needed:

    tiago_48_schunk.urdf                           the robot (base_footprint .. wrist_ft_tool_link)
    qualisys_2021-11-30_static_postures.csv        training      (37 postures, 2021-11-30 15:44)
    qualisys_2021-11-26_static_postures.csv        validation    (62 postures)
    qualisys_2021-11-30-1403_static_postures.csv   confirmation  (63 postures)
    qualisys_2021-11-30-1504_static_postures.csv   confirmation  (59 postures)

The roles and sha256 of the four recordings are those of FIGAROH's frozen protocol
(docs/development/tiago-mocap-heldout-protocol.md in that repository, protocol v1,
2026-10-05); a missing file or another hash exits 2 naming the file. Its rules, kept here:
fit on the training session only (base, tool and joints alike), re-estimate nothing on the
held-out sets (one marker frame, the Qualisys `base_frame` body, on all four days), and make
no choice by looking at the confirmation sets (validation was consulted once by FIGAROH, so
the confirmation sets are the independent check). The observation is one point of the hand
body, BL (`x1,y1,z1`, metres, in the base body's frame); the joints are torso_lift_joint (m)
and arm_1_joint..arm_7_joint (rad). The flow a new user runs, with default options:

    lincal import tiago_48_schunk.urdf --base base_footprint --tip wrist_ft_tool_link --convention dh
    lincal calibrate SPEC train.csv --refine --format json           (header q1..q8,x,y,z)
    lincal predict SPEC --params RESULT.json SET.csv                 (each of the four sets)

then the protocol's metric: the norm RMSE of the BL position error (mm), per axis and the
maximum, and the RMSE per posture group relative to the training postures (over the 8
joints): `repeated`, every joint within 0.01 of one training posture; `out_of_range`, some
joint beyond the training range by more than 0.05 (and not repeated); `new`, the rest.
FIGAROH's published figures (the protocol's results table) are printed beside, with the ratio
lincal / full_params (the best published model); target: at most 1.05 on every held-out set.

Usage: python3 bench/tiago.py DATA_DIR [--lincal BIN] [--convention dh|mdh|urdf]
       [--calibrate-args "..."] [--json OUT.json] [--skip-missing]
`--skip-missing`: when the data directory or a file is absent, print one line and exit 0 (CI).
Standard library only.
"""
import argparse
import atexit
import csv
import hashlib
import json
import math
import os
import shlex
import shutil
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.dont_write_bytecode = True  # no bench/__pycache__ left behind
from mukca import run, tips  # noqa: E402  (one reader of lincal's CSV output for both benches)

URDF = "tiago_48_schunk.urdf"
BASE, TIP = "base_footprint", "wrist_ft_tool_link"
JOINTS = ["torso_lift_joint"] + [f"arm_{i}_joint" for i in range(1, 8)]
POINT = ["x1", "y1", "z1"]

# key, role, file, sha256 (protocol v1)
SETS = [
    ("training", "training", "qualisys_2021-11-30_static_postures.csv",
     "b6c0051e20c6a077a6d2cf64ba912996945bbb85d6860cd6cea7d8ff65b1b9af"),
    ("validation 11-26", "validation", "qualisys_2021-11-26_static_postures.csv",
     "7c986df711757c4d31d8bb6db34b354f72318a78673dac280fd3a14abc5460a0"),
    ("confirmation 14:03", "confirmation", "qualisys_2021-11-30-1403_static_postures.csv",
     "e44c678fbbc1fbc852107b0fe6793470dbf3a7cef77ddf5faa25c9e4ff4cb503"),
    ("confirmation 15:04", "confirmation", "qualisys_2021-11-30-1504_static_postures.csv",
     "cc19eaa74fe8b74be28d758424ef4acd18f516dc59e40754b37d87f8592fbb84"),
]

# FIGAROH's published norm RMSE (mm), protocol results table, in the order of SETS.
PEER = {
    "registration only (9)": [3.37, 4.87, 4.58, 4.22],
    "joint_offset (14)": [2.88, 4.23, 4.09, 3.83],
    "full_params (31, macOS arm64)": [1.64, 3.07, 2.83, 2.44],
    "full_params (30, Linux x86-64)": [1.68, 3.22, 3.00, 2.56],
}
BEST = "full_params (31, macOS arm64)"
LINUX = "full_params (30, Linux x86-64)"
# By posture group on the held-out sets (validation, 14:03, 15:04).
PEER_GROUPS = {
    "full_params": {"repeated": [2.34, 2.03, 1.91], "new": [2.84, 2.75, 2.64],
                    "out_of_range": [5.31, 5.01, 3.77]},
    "joint_offset": {"repeated": [3.31, 3.08, 2.84], "new": [4.47, 4.29, 4.13],
                     "out_of_range": [6.53, 6.61, 6.21]},
}
GROUPS = ["repeated", "new", "out_of_range"]
TARGET = 1.05


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 16), b""):
            h.update(chunk)
    return h.hexdigest()


def find(root, names):
    """Every path under root of each wanted name (deterministic walk order)."""
    found = {n: [] for n in names}
    for d, dirs, files in os.walk(root):
        dirs.sort()
        for n in sorted(files):
            if n in found:
                found[n].append(os.path.join(d, n))
    return found


def locate(root):
    """(paths by name, problem): the URDF and the four recordings, hashes checked.

    problem is None, or ("missing", message) or ("mismatch", message)."""
    if not os.path.isdir(root):
        return None, ("missing", f"no data directory {root}")
    found = find(root, [URDF] + [s[2] for s in SETS])
    missing = [n for n, p in found.items() if not p]
    if missing:
        return None, ("missing", f"not found under {root}: {', '.join(missing)}")
    paths = {URDF: found[URDF][0]}
    for _, _, name, digest in SETS:
        ok = [p for p in found[name] if sha256(p) == digest]
        if not ok:
            return None, ("mismatch", f"{found[name][0]}: sha256 {sha256(found[name][0])}, "
                                      f"protocol v1 wants {digest} for {name}")
        paths[name] = ok[0]
    return paths, None


def read_set(path):
    """Joints (8 per posture, floats), measured BL points, and the rows of a lincal data CSV."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        absent = [c for c in JOINTS + POINT if c not in (reader.fieldnames or [])]
        if absent:
            raise ValueError(f"{path}: no column {', '.join(absent)}")
        rows = [[r[c] for c in JOINTS + POINT] for r in reader]
    q = [[float(v) for v in r[:8]] for r in rows]
    p = [[float(v) for v in r[8:]] for r in rows]
    return q, p, rows


def write_set(path, rows):
    with open(path, "w") as f:
        f.write(",".join([f"q{i + 1}" for i in range(8)] + ["x", "y", "z"]) + "\n")
        for r in rows:
            f.write(",".join(r) + "\n")


def groups_of(q, q_train, tol=0.01, margin=0.05):
    """FIGAROH's posture groups of each posture, relative to the training postures."""
    lo = [min(t[j] for t in q_train) - margin for j in range(8)]
    hi = [max(t[j] for t in q_train) + margin for j in range(8)]
    out = []
    for x in q:
        nearest = min(max(abs(a - b) for a, b in zip(x, t)) for t in q_train)
        if nearest < tol:
            out.append("repeated")
        elif any(v < lo[j] or v > hi[j] for j, v in enumerate(x)):
            out.append("out_of_range")
        else:
            out.append("new")
    return out


def rmse(values):
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else None


def figures(pred, meas, groups):
    err = [[(a - b) * 1e3 for a, b in zip(pp, mm)] for pp, mm in zip(pred, meas)]
    norm = [math.sqrt(sum(e * e for e in v)) for v in err]
    return {
        "n": len(norm),
        "rmse_mm": rmse(norm),
        "rmse_xyz_mm": [rmse([v[k] for v in err]) for k in range(3)],
        "max_mm": max(norm),
        "groups": {g: {"n": sum(1 for x in groups if x == g),
                       "rmse_mm": rmse([e for e, x in zip(norm, groups) if x == g])}
                   for g in GROUPS},
    }


def fmt(v, spec=".2f"):
    return "–" if v is None else format(v, spec)


def main():
    ap = argparse.ArgumentParser(description="lincal against FIGAROH's TIAGo mocap held-out figures")
    ap.add_argument("data", nargs="?", default=None,
                    help="the directory holding the data (figaroh-examples' examples/tiago, or a copy)")
    ap.add_argument("--lincal", default=os.path.join(HERE, "..", "target", "release", "lincal"))
    ap.add_argument("--convention", default="dh", choices=["dh", "mdh", "urdf"],
                    help="the table `lincal import` writes (default dh; urdf: joint origins)")
    ap.add_argument("--calibrate-args", default="", help="extra calibrate options (shell-quoted)")
    ap.add_argument("--json", default="")
    ap.add_argument("--skip-missing", action="store_true",
                    help="a missing data directory or file skips the bench (exit 0)")
    args = ap.parse_args()

    if args.data is None:
        paths, problem = None, ("missing", "no data directory given")
    else:
        paths, problem = locate(args.data)
    if problem:
        kind, msg = problem
        if kind == "missing" and args.skip_missing:
            print(f"tiago.py: skipped: FIGAROH's TIAGo mocap data absent ({msg}); "
                  "they are not vendored (figaroh-examples has no licence)")
            return 0
        print(f"tiago.py: {msg}", file=sys.stderr)
        return 2

    if not (os.path.isfile(args.lincal) and os.access(args.lincal, os.X_OK)):
        print(f"tiago.py: no lincal binary at {args.lincal} (build it, or pass --lincal)", file=sys.stderr)
        return 2
    work = tempfile.mkdtemp(prefix="lincal-tiago-")
    atexit.register(shutil.rmtree, work, True)

    def shown(cmd):
        return shlex.join(cmd).replace(work, "$WORK")

    commands = {}
    spec = os.path.join(work, "spec.yaml")
    cmd = [args.lincal, "import", paths[URDF], "--base", BASE, "--tip", TIP,
           "--convention", args.convention]
    commands["import"] = shown(cmd)
    r = run(cmd)
    if r.returncode != 0:
        print(f"tiago.py: lincal import failed (exit {r.returncode}):\n{r.stderr.strip()}", file=sys.stderr)
        return 1
    import_notes = r.stderr.strip()
    with open(spec, "w") as f:
        f.write(r.stdout)

    sets = []
    for key, role, name, _ in SETS:
        try:
            q, p, rows = read_set(paths[name])
        except ValueError as e:
            print(f"tiago.py: {e}", file=sys.stderr)
            return 2
        csv_path = os.path.join(work, name.removeprefix("qualisys_").removesuffix("_static_postures.csv") + ".csv")
        write_set(csv_path, rows)
        sets.append({"key": key, "role": role, "file": name, "csv": csv_path, "q": q, "p": p})
    q_train = sets[0]["q"]

    result_path = os.path.join(work, "result.json")
    cmd = [args.lincal, "calibrate", spec, sets[0]["csv"], "--refine", "--format", "json"] \
        + shlex.split(args.calibrate_args)
    commands["calibrate"] = shown(cmd)
    t0 = time.perf_counter()
    r = run(cmd)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        print(f"tiago.py: lincal calibrate failed (exit {r.returncode}):\n{r.stderr.strip()}", file=sys.stderr)
        return 1
    with open(result_path, "w") as f:
        f.write(r.stdout)
    result = json.loads(r.stdout)

    failures = []
    commands["predict"] = []
    for s in sets:
        cmd = [args.lincal, "predict", spec, "--params", result_path, s["csv"]]
        commands["predict"].append(shown(cmd))
        r = run(cmd)
        pred = tips(r.stdout) if r.returncode == 0 else []
        if r.returncode != 0 or len(pred) != len(s["p"]):
            failures.append((s["key"], r.returncode, f"{len(pred)} rows for {len(s['p'])} postures",
                             r.stderr.strip()[:300]))
            s["figures"] = None
            continue
        s["figures"] = figures(pred, s["p"], groups_of(s["q"], q_train))

    prior = result.get("prior") or {}
    selection = prior.get("selection") or {}
    summary = {
        "rule": selection.get("rule"),
        "tolerance": selection.get("tolerance"),
        "identifiable_count": result.get("identifiable_count"),
        "residual_rms_m": result.get("residual_rms"),
        "calibrate_wall_s": wall,
    }
    rows = summarize(sets, failures, summary, args.convention)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({
                "convention": args.convention,
                "calibrate_args": args.calibrate_args,
                "commands": commands,
                "import_notes": import_notes,
                "files": {n: paths[n] for n in paths},
                "prior_selection": {"rule": summary["rule"], "tolerance": summary["tolerance"]},
                "identifiable_count": summary["identifiable_count"],
                "residual_rms_m": summary["residual_rms_m"],
                "calibrate_wall_s": wall,
                "sets": rows["sets"],
                "worst_heldout_ratio": rows["worst"],
                "target": TARGET,
                "peer": PEER, "peer_groups": PEER_GROUPS,
                "failures": failures,
            }, f, indent=1)
    # A failed prediction fails the run.
    return 1 if failures else 0


def summarize(sets, failures, summary, convention):
    tol = summary["tolerance"]
    res = summary["residual_rms_m"]
    print(f"convention: {convention}; calibrate --refine wall time: {summary['calibrate_wall_s']:.3f} s")
    print(f"prior selection: rule {summary['rule'] if summary['rule'] is not None else 'null'}, tolerance {fmt(tol, '.4g') if tol is not None else 'null'}; "
          f"identifiable parameters: {summary['identifiable_count']}; "
          f"residual RMS (training): {fmt(res * 1e3 if res is not None else None, '.3f')} mm")
    print(f"failures: {len(failures)}")
    for f in failures:
        print("  FAILED", f)
    print()
    print("Norm RMSE of the BL point (mm); FIGAROH's published figures, protocol v1.")
    print()
    print("| set | role | n | lincal RMSE | x / y / z | max | registration only (9) | joint_offset (14) "
          "| full_params (31, macOS) | lincal / full_params | full_params (30, Linux) | lincal / Linux |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    out, worst = [], None
    for i, s in enumerate(sets):
        f = s["figures"]
        peer = {k: v[i] for k, v in PEER.items()}
        row = {"set": s["key"], "role": s["role"], "file": s["file"], "figures": f, "peer": peer,
               "ratio_best": None, "ratio_linux": None}
        if f is not None:
            row["ratio_best"] = f["rmse_mm"] / peer[BEST]
            row["ratio_linux"] = f["rmse_mm"] / peer[LINUX]
            if s["role"] != "training":
                worst = row["ratio_best"] if worst is None else max(worst, row["ratio_best"])
            xyz = " / ".join(fmt(v) for v in f["rmse_xyz_mm"])
            print(f"| {s['key']} | {s['role']} | {f['n']} | {f['rmse_mm']:.2f} | {xyz} | {f['max_mm']:.2f} "
                  f"| {peer['registration only (9)']:.2f} | {peer['joint_offset (14)']:.2f} "
                  f"| {peer[BEST]:.2f} | {row['ratio_best']:.3f} | {peer[LINUX]:.2f} | {row['ratio_linux']:.3f} |")
        else:
            print(f"| {s['key']} | {s['role']} | – | failed | | | {peer['registration only (9)']:.2f} "
                  f"| {peer['joint_offset (14)']:.2f} | {peer[BEST]:.2f} | | {peer[LINUX]:.2f} | |")
        out.append(row)
    print()
    print(f"worst held-out ratio to the best published figure: {fmt(worst, '.3f')} (target ≤ {TARGET:.2f})")
    print()
    print("By posture group, held-out sets (mm): lincal vs FIGAROH's full_params (and joint_offset).")
    print()
    print("| set | group | n | lincal RMSE | full_params | lincal / full_params | joint_offset |")
    print("|---|---|---|---|---|---|---|")
    for i, (s, row) in enumerate(zip(sets[1:], out[1:])):
        f = s["figures"]
        row["group_ratio_best"] = {}
        for g in GROUPS:
            fp, jo = PEER_GROUPS["full_params"][g][i], PEER_GROUPS["joint_offset"][g][i]
            if f is None:
                print(f"| {s['key']} | {g} | – | failed | {fp:.2f} | | {jo:.2f} |")
                continue
            gg = f["groups"][g]
            ratio = gg["rmse_mm"] / fp if gg["rmse_mm"] is not None else None
            row["group_ratio_best"][g] = ratio
            print(f"| {s['key']} | {g} | {gg['n']} | {fmt(gg['rmse_mm'])} | {fp:.2f} | {fmt(ratio, '.3f')} | {jo:.2f} |")
    return {"sets": out, "worst": worst}


if __name__ == "__main__":
    sys.exit(main())

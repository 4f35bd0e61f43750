#!/usr/bin/env python3
"""lincal against MUKCa on MUKCa's own public socket data (issue 22's targets).

The data and URDFs are in platonics-delft/kinematics_calibration (MIT), `data/` and `urdf/`,
copied into bench/mukca/ (the default checkout);
MUKCa's own figures for ten data sets are in `../shared/reference/mukca/mukca_spreads.json`.
For every robot and every placement P, the flow a new user runs, with default options:

    lincal import URDF --base ROOT --tip ball_link --convention mdh --points 2 --distance 0.05
    lincal calibrate SPEC P/hole_0.csv P/hole_1.csv --no-header --columns q1,...,qn --refine --format json
    lincal predict SPEC --params RESULT.json Q/hole_i.csv        (every placement Q)

then the metric of mukca_spreads.json: the two sockets pooled, sqrt((n0 s0^2 + n1 s1^2)/(n0+n1)),
s_i the RMS distance of socket i's predicted balls from their mean; and |mean0 - mean1| - 50 mm.
With `--reversed`, every calibration is run a second time on the same spec with `params:`
in reverse order and the largest spread difference is reported (target: 1 um).

Usage: python3 bench/mukca.py [MUKCA_CHECKOUT] [--lincal BIN] [--robots a,b] [--reversed]
       [--json OUT.json] [--convention dh|mdh|urdf] [--calibrate-args "..."]
Standard library only.
"""
import argparse
import atexit
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REFERENCE = os.path.join(HERE, "..", "..", "shared", "reference", "mukca", "mukca_spreads.json")

# Robots of the data set that the reference file does not list: URDF model and root link.
MODELS = {
    "kuka_14": ("iiwa14", "base_link"),
    "dinova_1": ("gen3lite", "world"),
    "panda_1_with_sensor": ("panda_plus_bota", "panda_link0"),
}


def model_of(robot, reference):
    if robot in reference:
        return reference[robot]["model"], reference[robot]["root"]
    if robot in MODELS:
        return MODELS[robot]
    if robot.startswith("panda"):
        return "panda", "panda_link0"
    return None


def family(robot):
    if robot.startswith("panda"):
        return "panda"
    if robot.startswith("kuka"):
        return "iiwa"
    return "kinova"


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, **kw)


def joints_of(path):
    with open(path) as f:
        first = f.readline()
    return len(first.strip().split(","))


def tips(text):
    out = []
    for line in text.splitlines():
        if not line or line[0].isalpha() or line.startswith("#"):
            continue
        out.append([float(v) for v in line.split(",")])
    return out


def spread(sockets):
    """Pooled RMS distance from the socket means, and |mean0 - mean1|."""
    means, num, den = [], 0.0, 0
    for pts in sockets:
        m = [sum(p[k] for p in pts) / len(pts) for k in range(3)]
        s2 = sum(sum((p[k] - m[k]) ** 2 for k in range(3)) for p in pts) / len(pts)
        means.append(m)
        num += len(pts) * s2
        den += len(pts)
    d = math.dist(means[0], means[1]) if len(means) == 2 else float("nan")
    return math.sqrt(num / den), d


def reverse_params(spec_text):
    """The same spec with its `params:` entries in reverse order (same YAML map)."""
    lines = spec_text.splitlines()
    i = lines.index("params:")
    j = i + 1
    while j < len(lines) and lines[j].startswith("  "):
        j += 1
    return "\n".join(lines[: i + 1] + lines[i + 1 : j][::-1] + lines[j:]) + "\n"


def placements(root, robot):
    d = os.path.join(root, "data", robot)
    out = []
    for p in sorted(os.listdir(d)):
        h0, h1 = (os.path.join(d, p, f"hole_{i}.csv") for i in (0, 1))
        if os.path.isfile(h0) and os.path.isfile(h1):
            out.append((p, h0, h1))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mukca", nargs="?", default=os.path.join(HERE, "mukca"),
                    help="a MUKCa checkout (default: the copy in bench/mukca)")
    ap.add_argument("--lincal", default=os.path.join(HERE, "..", "target", "release", "lincal"))
    ap.add_argument("--robots", default="")
    ap.add_argument("--reversed", action="store_true")
    ap.add_argument("--json", default="")
    ap.add_argument("--calibrate-args", default="", help="extra calibrate options, space-separated")
    ap.add_argument("--convention", default="mdh", choices=["dh", "mdh", "urdf"],
                    help="the table `lincal import` writes (default mdh; urdf: joint origins)")
    args = ap.parse_args()
    with open(REFERENCE) as f:
        reference = json.load(f)["robots"]
    if not args.robots and os.environ.get("BENCH_QUICK") == "1":
        # CI's run of the documented command: one Panda and the Kinova; not the full figures.
        args.robots = "panda_1,dinova_1"
        print("mukca.py: BENCH_QUICK=1: panda_1 and dinova_1 only; not the full figures", file=sys.stderr)
    robots = args.robots.split(",") if args.robots else sorted(os.listdir(os.path.join(args.mukca, "data")))
    work = tempfile.mkdtemp(prefix="lincal-mukca-")
    atexit.register(shutil.rmtree, work, True)
    rows, failures, times, worst_reorder = [], [], [], 0.0
    for robot in robots:
        if not os.path.isdir(os.path.join(args.mukca, "data", robot)):
            continue
        m = model_of(robot, reference)
        if m is None:
            continue
        model, root = m
        urdf = os.path.join(args.mukca, "urdf", model + ".urdf")
        spec = os.path.join(work, robot + ".yaml")
        r = run([args.lincal, "import", urdf, "--base", root, "--tip", "ball_link", "--convention",
                 args.convention, "--points", "2", "--distance", "0.05"])
        if r.returncode != 0:
            failures.append((robot, "import", r.returncode, r.stderr.strip()[:300]))
            continue
        with open(spec, "w") as f:
            f.write(r.stdout)
        specs = [spec]
        if args.reversed:
            rev = os.path.join(work, robot + ".reversed.yaml")
            with open(rev, "w") as f:
                f.write(reverse_params(r.stdout))
            specs.append(rev)
        places = placements(args.mukca, robot)
        n = joints_of(places[0][1])
        cols = ",".join(f"q{i + 1}" for i in range(n))
        for p, h0, h1 in places:
            got = []
            for s in specs:
                res = os.path.join(work, f"{robot}.{p}.{len(got)}.json")
                t0 = time.perf_counter()
                r = run([args.lincal, "calibrate", s, h0, h1, "--no-header", "--columns", cols,
                         "--refine", "--format", "json"] + args.calibrate_args.split())
                dt = time.perf_counter() - t0
                if r.returncode != 0:
                    failures.append((robot, p, r.returncode, r.stderr.strip()[:300]))
                    break
                with open(res, "w") as f:
                    f.write(r.stdout)
                if s == spec:
                    times.append((dt, robot, p))
                per_q = {}
                for q, g0, g1 in places:
                    sockets = []
                    for h in (g0, g1):
                        r = run([args.lincal, "predict", s, "--params", res, h, "--no-header",
                                 "--columns", cols])
                        if r.returncode != 0:
                            failures.append((robot, p, q, r.returncode, r.stderr.strip()[:300]))
                            break
                        sockets.append(tips(r.stdout))
                    if len(sockets) == 2:
                        per_q[q] = spread(sockets)
                got.append(per_q)
            if not got:
                continue
            if len(got) == 2:
                for q in got[0]:
                    if q in got[1]:
                        worst_reorder = max(worst_reorder, abs(got[0][q][0] - got[1][q][0]))
            ref = reference.get(robot, {}).get("trained_on_P_evaluated_on_Q", {}).get(p, {})
            for q, (s, d) in got[0].items():
                mk = ref.get(q)
                rows.append({
                    "robot": robot, "family": family(robot), "P": p, "Q": q,
                    "in_sample": p == q, "spread_um": s * 1e6, "dist_err_um": (d - 0.05) * 1e6,
                    "mukca_spread_um": mk["spread_um"] if mk else None,
                    "ratio": s * 1e6 / mk["spread_um"] if mk else None,
                })
    summarize(rows, failures, times, worst_reorder, args.reversed)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows, "failures": failures, "times": times,
                       "worst_reorder_m": worst_reorder}, f, indent=1)
    # A failed import, calibration or prediction fails the run (CI runs this script).
    return 1 if failures else 0


def summarize(rows, failures, times, worst_reorder, reversed_):
    print(f"calibrations: {len(times)}, failures: {len(failures)}")
    for f in failures:
        print("  FAILED", f)
    if times:
        ts = sorted(t for t, _, _ in times)
        print(f"calibrate --refine wall time: median {statistics.median(ts):.3f} s, max {ts[-1]:.3f} s")
    if reversed_:
        print(f"params: reversed, largest spread difference: {worst_reorder * 1e6:.3f} um")
    print()
    print("| family | out-of-sample pairs | median lincal/MUKCa | worst | lincal worse on | in-sample median | in-sample worst |")
    print("|---|---|---|---|---|---|---|")
    for fam in ("panda", "iiwa", "kinova"):
        out = [r["ratio"] for r in rows if r["family"] == fam and not r["in_sample"] and r["ratio"]]
        ins = [r["ratio"] for r in rows if r["family"] == fam and r["in_sample"] and r["ratio"]]
        if not out:
            print(f"| {fam} | 0 (no MUKCa figures) | | | | | |")
            continue
        worse = sum(1 for x in out if x > 1.0)
        print(f"| {fam} | {len(out)} | {statistics.median(out):.3f} | {max(out):.2f} | {worse} of {len(out)} "
              f"| {statistics.median(ins):.3f} | {max(ins):.3f} |")
    print()
    print("Without MUKCa figures (lincal alone, um): robot P -> Q spread")
    for r in rows:
        if r["ratio"] is None:
            print(f"  {r['robot']} {r['P']} -> {r['Q']}: {r['spread_um']:.1f} (dist err {r['dist_err_um']:.1f})")


if __name__ == "__main__":
    sys.exit(main())

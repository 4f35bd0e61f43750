#!/usr/bin/env python3
"""Issue 49's targets for `lincal compensate`, measured through the command line only.

For each arm: draw a truth a few mm / mrad off the drawing and simulated measurements of it
(`lincal simulate --truth-out`), calibrate (`lincal calibrate --refine --format json`, default
options), compensate a seeded grid of joint targets (`lincal compensate --params CAL.json`),
drive the *true* robot to the compensated joints (`lincal predict --params TRUTH.json`, the
truth file turned into a result JSON `{params: {name: {value}}}`) and compare with the
intended tool `FK_nominal(q)` (`lincal predict --nominal`).

Reported per arm (seed 1, then over --seeds seeds):
  nominal error      true robot at q  vs FK_nominal(q)   (RMS over the grid, 3-D position)
  compensated error  true robot at q' vs FK_nominal(q)   (ok rows only)
  validation RMS     calibrated model vs truth at fresh joint readings drawn like the grid
  comp / val         target <= 1.1
  realised / sigma   RMS of the compensated error over RMS of the `sigma` column; the median
                     over the seeds, target 0.85-1.15
  orientation        likewise (rad) for the full-pose arm
  null-space part    redundant tasks (7R, or a 6R arm with a position tool): |N (q' - q0)| with
                     N the null-space projector of the calibrated model's position Jacobian
                     (central differences through `lincal predict`) at q0 and at q'; target 1e-3
  speed              whole-process wall time of `lincal compensate` on 1e5 targets (< 1 s)

BENCH_QUICK=1 (CI): one seed, a grid of 500 and 2 000 speed targets, to prove the command runs.

Usage: bench/.venv/bin/python bench/compensate.py [--lincal target/release/lincal]
       [--seeds 20] [--grid 10000] [--poses 100] [--noise 5e-5] [--speed 100000]
       [--arms puma,ur10,panda,puma_pose] [--work DIR]
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import yaml

BENCH = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(BENCH)

ARMS = {
    # key: (label, spec path, full pose?)
    "puma": ("PUMA 560 tracker bench (6R, tip measured)", "bench/specs/puma560_mdh_measured.yaml", False),
    "ur10": ("UR10, every twist unknown (6R, tracker frame unknown)", "lincal-models/specs/ur10_tracker.yaml", False),
    "panda": ("Panda 7R, flange ball measured (from franka_panda_sockets.yaml)", None, False),
    "puma_pose": ("PUMA 560 full pose, 6-DOF tracker", "lincal-models/specs/puma560_pose_tracker.yaml", True),
}


def run(cmd, out=None, check=True):
    """Runs a command; stdout to the file `out` (or captured), stderr captured."""
    if out is not None:
        with open(out, "w") as f:
            p = subprocess.run(cmd, stdout=f, stderr=subprocess.PIPE, text=True)
    else:
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if check and p.returncode != 0:
        sys.exit(f"compensate.py: {' '.join(cmd)} exited {p.returncode}:\n{p.stderr}")
    return p


def panda_measured_spec(path):
    """The Panda of franka_panda_sockets.yaml (limits, unknown tool) with its ball measured
    by a tracker in the base frame instead of seated in sockets: a 7R arm, position task."""
    src = os.path.join(ROOT, "lincal-models/specs/franka_panda_sockets.yaml")
    spec = yaml.safe_load(open(src))
    spec["name"] = "franka_panda_measured"
    spec["description"] = "Franka Panda, flange ball measured in the base frame (bench/compensate.py)"
    spec.pop("constraints", None)
    sockets = {"p1", "p2", "p3", "r1", "r2", "r3", "s1", "s2", "s3"}
    spec["params"] = {k: v for k, v in spec["params"].items() if k not in sockets}
    spec["constraint"] = {"measured": {}}
    with open(path, "w") as f:
        yaml.safe_dump(spec, f, sort_keys=False)
    return path


def limits_of(spec_path):
    spec = yaml.safe_load(open(spec_path))
    lim = []
    for j in spec["joints"]:
        l = j.get("limits")
        if l is None:
            lim.append((-np.pi, np.pi))
        else:
            lim.append(tuple(float(eval(str(v), {"pi": np.pi})) for v in l))
    return np.array(lim)


def write_joints(path, q):
    n = q.shape[1]
    np.savetxt(path, q, delimiter=",", header=",".join(f"q{i+1}" for i in range(n)),
               comments="", fmt="%.17g")


def read_csv(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    rows = np.genfromtxt(path, delimiter=",", skip_header=1, dtype=str)
    if rows.ndim == 1:
        rows = rows[None, :]
    return header, rows


def predict(lincal, spec, params, joints_csv, out):
    cmd = [lincal, "predict", spec, "--angles", "rad"] + (["--nominal"] if params is None else ["--params", params]) + [joints_csv]
    run(cmd, out=out)
    h, r = read_csv(out)
    return h, r.astype(float)


def quat_angle(qa, qb):
    """Angle (rad) between rotations given as unit quaternions (w, x, y, z), row-wise."""
    d = np.abs(np.sum(qa * qb, axis=1)) / (np.linalg.norm(qa, axis=1) * np.linalg.norm(qb, axis=1))
    return 2.0 * np.arccos(np.clip(d, 0.0, 1.0))


def stated_noise(spec, a):
    """A full-pose spec's noise levels: those its `measured_pose` states (the fit weighs and
    the covariance scales by them, so data of other levels would judge the bench's data, not
    lincal's sigma), else --noise and --noise-orientation."""
    c = yaml.safe_load(open(spec)).get("constraint", {})
    mp = c.get("measured_pose", {}) if isinstance(c, dict) else {}
    mp = mp if isinstance(mp, dict) else {}
    return float(mp.get("position_std", a.noise)), float(mp.get("orientation_std", a.noise_orientation))


def rms(v):
    v = np.asarray(v)
    return float(np.sqrt(np.mean(v ** 2))) if v.size else float("nan")


def one_seed(a, lincal, spec, pose, lim, seed, work, grid_q, val_q, grid_csv, val_csv, nom_grid, want_null):
    n = lim.shape[0]
    w = os.path.join(work, f"s{seed}")
    os.makedirs(w, exist_ok=True)
    truth_yaml, data, cal = (os.path.join(w, f) for f in ("truth.yaml", "data.csv", "cal.json"))
    noise, noise_o = stated_noise(spec, a) if pose else (a.noise, None)
    sim = [lincal, "simulate", spec, "--poses", str(a.poses), "--seed", str(seed),
           "--noise-measure", str(noise), "--truth-out", truth_yaml]
    if pose:
        sim += ["--noise-orientation", str(noise_o)]
    run(sim, out=data)
    run([lincal, "calibrate", spec, data, "--refine", "--format", "json"], out=cal)
    calj = json.load(open(cal))
    truth = yaml.safe_load(open(truth_yaml))
    truth_json = os.path.join(w, "truth.json")
    # A result file is read only with the spec it names (`lincal predict` checks `name`).
    name = yaml.safe_load(open(spec))["name"]
    json.dump({"name": name, "params": {k: {"value": float(v)} for k, v in truth.items()}},
              open(truth_json, "w"))

    out = os.path.join(w, "out.csv")
    run([lincal, "compensate", spec, "--params", cal, grid_csv, "--allow-failed"], out=out)
    h, rows = read_csv(out)
    status = rows[:, h.index("status")]
    ok = status == "ok"
    qc = rows[:, :n].astype(float)
    sigma = rows[:, h.index("sigma")].astype(float)
    resid = rows[:, h.index("residual")].astype(float)
    qc_csv = os.path.join(w, "qc.csv")
    write_joints(qc_csv, qc)
    _, true_at_qc = predict(lincal, spec, truth_json, qc_csv, os.path.join(w, "true_qc.csv"))
    _, true_at_q = predict(lincal, spec, truth_json, grid_csv, os.path.join(w, "true_q.csv"))
    e_nom = np.linalg.norm(true_at_q[:, :3] - nom_grid[:, :3], axis=1)
    e_comp = np.linalg.norm(true_at_qc[:, :3] - nom_grid[:, :3], axis=1)[ok]
    _, cal_val = predict(lincal, spec, cal, val_csv, os.path.join(w, "cal_val.csv"))
    _, true_val = predict(lincal, spec, truth_json, val_csv, os.path.join(w, "true_val.csv"))
    e_val = np.linalg.norm(cal_val[:, :3] - true_val[:, :3], axis=1)
    r = {
        "seed": seed, "rows": len(status), "not_ok": int((~ok).sum()),
        "statuses": {str(s): int((status == s).sum()) for s in sorted(set(status))},
        "nominal_rms": rms(e_nom), "nominal_max": float(e_nom.max()),
        "comp_rms": rms(e_comp), "comp_max": float(e_comp.max()),
        "val_rms": rms(e_val), "sigma_rms": rms(sigma[ok]),
        "residual_max": float(resid[ok].max()),
        "covariance_in_json": "covariance" in calj,
    }
    r["comp_over_val"] = r["comp_rms"] / r["val_rms"]
    r["realised_over_sigma"] = r["comp_rms"] / r["sigma_rms"]
    if pose:
        o_nom = quat_angle(true_at_q[:, 3:7], nom_grid[:, 3:7])
        o_comp = quat_angle(true_at_qc[:, 3:7], nom_grid[:, 3:7])[ok]
        o_val = quat_angle(cal_val[:, 3:7], true_val[:, 3:7])
        r.update(nominal_rot_rms=rms(o_nom), comp_rot_rms=rms(o_comp), val_rot_rms=rms(o_val))
        r["comp_over_val_rot"] = r["comp_rot_rms"] / r["val_rot_rms"]
    if want_null:
        r["null_q0"], r["null_qc"] = null_space_part(lincal, spec, cal, grid_q, qc, ok, w)
    return r


def null_space_part(lincal, spec, cal, q0, qc, ok, w, m=200, h=1e-6):
    """Median and largest |N(q) (q' - q0)| over the first m ok targets, N the projector onto the null space
    of the calibrated position Jacobian (central differences via predict), at q0 and at q'."""
    idx = np.flatnonzero(ok)[:m]
    n = q0.shape[1]
    worst = []
    for base in (q0[idx], qc[idx]):
        worst.append([])
        rows = []
        for q in base:
            for j in range(n):
                for s in (+h, -h):
                    p = q.copy()
                    p[j] += s
                    rows.append(p)
        path = os.path.join(w, "jac.csv")
        write_joints(path, np.array(rows))
        _, x = predict(lincal, spec, cal, path, os.path.join(w, "jac_out.csv"))
        x = x[:, :3].reshape(len(idx), n, 2, 3)
        J = ((x[:, :, 0, :] - x[:, :, 1, :]) / (2 * h)).transpose(0, 2, 1)  # (m, 3, n)
        for k in range(len(idx)):
            d = qc[idx[k]] - q0[idx[k]]
            Jk = J[k]
            N = np.eye(n) - np.linalg.pinv(Jk) @ Jk
            worst[-1].append(float(np.linalg.norm(N @ d)))
    return [(float(np.median(v)), float(np.max(v)), float(np.mean(np.array(v) > 1e-3))) for v in worst]


def speed(a, lincal, spec, lim, work, reps=3):
    rng = np.random.default_rng(12345)
    q = lim[:, 0] + (lim[:, 1] - lim[:, 0]) * rng.random((a.speed, lim.shape[0]))
    path = os.path.join(work, "speed.csv")
    write_joints(path, q)
    cal = os.path.join(work, "s1", "cal.json")
    out = os.path.join(work, "speed_out.csv")
    times, cpu = [], []
    for _ in range(reps):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        run([lincal, "compensate", spec, "--params", cal, path, "--allow-failed"], out=out)
        times.append(time.perf_counter() - t0)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime)
    h, rows = read_csv(out)
    st = rows[:, h.index("status")]
    return {"times": times, "cpu": cpu, "load": os.getloadavg()[0], "median": statistics.median(times), "best": min(times),
            "not_ok": int((st != "ok").sum()),
            "statuses": {str(s): int((st == s).sum()) for s in sorted(set(st))}}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lincal", default=os.path.join(ROOT, "target/release/lincal"))
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--grid", type=int, default=10000)
    ap.add_argument("--poses", type=int, default=100)
    ap.add_argument("--noise", type=float, default=5e-5, help="measurement noise per coordinate, m")
    ap.add_argument("--noise-orientation", type=float, default=5e-5, help="full pose: rad per axis")
    ap.add_argument("--speed", type=int, default=100000)
    ap.add_argument("--arms", default="puma,ur10,panda,puma_pose")
    ap.add_argument("--work", default=None)
    ap.add_argument("--json", default=None, help="also write every number to this file")
    a = ap.parse_args()
    if os.environ.get("BENCH_QUICK") == "1":
        # CI's run of the documented command: one seed, small grids; numbers not measurements.
        a.seeds, a.grid, a.speed = 1, min(a.grid, 500), min(a.speed, 2000)
        print("compensate.py: BENCH_QUICK=1: 1 seed, grid 500, speed 2000; not measurements",
              file=sys.stderr)
    lincal = os.path.abspath(a.lincal)
    work = a.work or tempfile.mkdtemp(prefix="lincal-compensate-")
    os.makedirs(work, exist_ok=True)
    print(f"lincal: {lincal} ({time.strftime('%Y-%m-%d %H:%M:%S UTC', time.gmtime(os.path.getmtime(lincal)))}), "
          f"work: {work}", file=sys.stderr)

    results = {}
    for key in a.arms.split(","):
        label, rel, pose = ARMS[key]
        aw = os.path.join(work, key)
        os.makedirs(aw, exist_ok=True)
        spec = panda_measured_spec(os.path.join(aw, "spec.yaml")) if rel is None else os.path.join(ROOT, rel)
        lim = limits_of(spec)
        n = lim.shape[0]
        rng = np.random.default_rng(49)
        grid_q = lim[:, 0] + (lim[:, 1] - lim[:, 0]) * rng.random((a.grid, n))
        val_q = lim[:, 0] + (lim[:, 1] - lim[:, 0]) * rng.random((a.grid, n))
        grid_csv, val_csv = os.path.join(aw, "targets.csv"), os.path.join(aw, "val.csv")
        write_joints(grid_csv, grid_q)
        write_joints(val_csv, val_q)
        _, nom_grid = predict(lincal, spec, None, grid_csv, os.path.join(aw, "nominal.csv"))
        want_null = (not pose) and n > 3
        per = []
        for s in range(1, a.seeds + 1):
            t0 = time.perf_counter()
            per.append(one_seed(a, lincal, spec, pose, lim, s, aw, grid_q, val_q, grid_csv, val_csv,
                                nom_grid, want_null and s == 1))
            print(f"{key} seed {s}: comp {per[-1]['comp_rms']:.3e} val {per[-1]['val_rms']:.3e} "
                  f"ratio {per[-1]['comp_over_val']:.3f} real/sigma {per[-1]['realised_over_sigma']:.3f} "
                  f"not ok {per[-1]['not_ok']} ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
        sp = speed(a, lincal, spec, lim, aw) if a.speed else None
        results[key] = {"label": label, "spec": rel or "(generated) " + spec, "pose": pose, "seeds": per, "speed": sp,
                        "median_comp_over_val": statistics.median(r["comp_over_val"] for r in per),
                        "median_realised_over_sigma": statistics.median(r["realised_over_sigma"] for r in per),
                        "min_realised_over_sigma": min(r["realised_over_sigma"] for r in per),
                        "max_realised_over_sigma": max(r["realised_over_sigma"] for r in per)}
        if pose:
            results[key]["median_comp_over_val_rot"] = statistics.median(r["comp_over_val_rot"] for r in per)

    if a.json:
        json.dump(results, open(a.json, "w"), indent=1)
    print_table(a, lincal, results)


def mm(v):
    return f"{v * 1e3:.4f}"


def verdict(ok):
    return "met" if ok else "**missed**"


def print_table(a, lincal, results):
    print(f"Grid {a.grid} joint targets (uniform within limits, seed 49; +-pi where a joint has none); "
          f"{a.poses} simulated poses, {a.noise * 1e6:g} um noise per coordinate"
          f" ({a.noise_orientation * 1e6:g} urad per axis for the full pose, or the levels its spec's"
          f" measured_pose states); seeds 1..{a.seeds}. "
          f"Errors in mm (3-D position), RMS over the grid; seed 1, then over the seeds.\n")
    print("| arm | nominal err | compensated err | validation RMS | comp/val (seed 1) | comp/val median | "
          "≤ 1.1 | realised/σ median [min, max] | 0.85-1.15 | residual max (m) | not ok (seed 1) | null-space part at q0 / at q' (median, max rad; share > 1e-3) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for key, r in results.items():
        s1 = r["seeds"][0]
        med = r["median_realised_over_sigma"]
        ok_ratio = s1["comp_over_val"] <= 1.1 and r["median_comp_over_val"] <= 1.1
        nl = s1.get("null_q0")
        nc = s1.get("null_qc")
        null = "-" if nl is None else (f"{nl[0]:.1e}, {nl[1]:.1e}, {100 * nl[2]:.1f} % / "
                                       f"{nc[0]:.1e}, {nc[1]:.1e}, {100 * nc[2]:.1f} % {verdict(nc[1] <= 1e-3)}")
        print(f"| {r['label']} | {mm(s1['nominal_rms'])} | {mm(s1['comp_rms'])} | {mm(s1['val_rms'])} | "
              f"{s1['comp_over_val']:.3f} | {r['median_comp_over_val']:.3f} | {verdict(ok_ratio)} | "
              f"{med:.3f} [{r['min_realised_over_sigma']:.3f}, {r['max_realised_over_sigma']:.3f}] | "
              f"{verdict(0.85 <= med <= 1.15)} | {s1['residual_max']:.1e} | {s1['not_ok']} {s1['statuses']} | "
              f"{null} |")
    for key, r in results.items():
        if r["pose"]:
            s1 = r["seeds"][0]
            print(f"\nOrientation, {r['label']} (mrad): nominal {s1['nominal_rot_rms'] * 1e3:.4f}, compensated "
                  f"{s1['comp_rot_rms'] * 1e3:.4f}, validation {s1['val_rot_rms'] * 1e3:.4f}, comp/val seed 1 "
                  f"{s1['comp_over_val_rot']:.3f}, median {r['median_comp_over_val_rot']:.3f} "
                  f"({verdict(s1['comp_over_val_rot'] <= 1.1 and r['median_comp_over_val_rot'] <= 1.1)})")
    if any(r["speed"] for r in results.values()):
        print(f"\nSpeed: `lincal compensate SPEC --params CAL.json TARGETS.csv --allow-failed > OUT.csv`, "
              f"{a.speed} joint targets, whole-process wall time, 3 runs ({os.cpu_count()} cores):\n")
        print("| arm | median (s) | runs (s) | CPU user+sys (s) | load avg | < 1 s | rows not ok |")
        print("|---|---|---|---|---|---|---|")
        for key, r in results.items():
            sp = r["speed"]
            if sp:
                print(f"| {r['label']} | {sp['median']:.3f} | {', '.join(f'{t:.3f}' for t in sp['times'])} | "
                      f"{', '.join(f'{t:.2f}' for t in sp['cpu'])} | {sp['load']:.1f} | "
                      f"{verdict(sp['median'] < 1.0)} | {sp['not_ok']} {sp['statuses']} |")
    cov = {k: r["seeds"][0]["covariance_in_json"] for k, r in results.items()}
    print(f"\n`covariance` in calibrate's JSON: {cov}")


if __name__ == "__main__":
    main()

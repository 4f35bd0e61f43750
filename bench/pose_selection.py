"""The pose-selection benchmark of issue 24: `lincal select` against random picks of the
same pool, calibrated and judged against a known truth.

Per seed: a truth drawn with `simulate --truth-out`; a pool simulated on the TRUE robot with
noise; `select` choosing N rows of it from the spec's nominals only; the chosen rows and R
random N-sets of the same pool calibrated with `calibrate --refine`; each fit's tip error
on 1 000 fresh joint readings against the truth, after removing the gauge motions (the best
rigid motion of the predicted tips onto the true ones, Kabsch), and its largest predicted
parameter std (the fit's own `std`). Reports the medians over seeds of random/selected for
both, and on how many seeds the selection won.

Usage: LINCAL=target/release/lincal python3 bench/pose_selection.py [SEEDS]   (needs numpy)
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
LINCAL = os.environ.get("LINCAL", str(ROOT / "target" / "release" / "lincal"))
MODELS = ROOT / "lincal-models" / "specs"

# (name, spec, N, pool, noise option, noise, random sets per seed)
CASES = [
    ("PUMA 560, unknown plane", MODELS / "puma560_plane.yaml", 30, 10_000, "--noise-track", 1e-5),
    ("PUMA 560, unknown plane", MODELS / "puma560_plane.yaml", 20, 10_000, "--noise-track", 1e-5),
    ("KUKA iiwa, unknown point", MODELS / "kuka_iiwa14_point.yaml", 30, 10_000, "--noise-track", 1e-5),
    ("PUMA 560, measured tips (bench/)", ROOT / "bench" / "specs" / "puma560_mdh_measured.yaml", 30, 5_000,
     "--noise-measure", 5e-5),
]
RANDOM_SETS = 5


def run(*args: str) -> str:
    out = subprocess.run([LINCAL, *args], capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"lincal {' '.join(args)}: {out.stderr}")
    return out.stdout


def tips(spec: Path, params: Path, data: Path) -> np.ndarray:
    text = run("predict", str(spec), "--params", str(params), str(data))
    return np.loadtxt(text.splitlines()[1:], delimiter=",", ndmin=2)


def kabsch_rms(a: np.ndarray, b: np.ndarray) -> float:
    """RMS of a − b after the best rigid motion of a onto b."""
    ca, cb = a.mean(0), b.mean(0)
    h = (a - ca).T @ (b - cb)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1.0] * (a.shape[1] - 1) + [d]) @ u.T
    moved = (a - ca) @ r.T + cb
    return float(np.sqrt(((moved - b) ** 2).sum(1).mean()))


def truth_json(truth_yaml: Path, out: Path) -> None:
    values = {}
    for line in truth_yaml.read_text().splitlines():
        if ":" in line and not line.lstrip().startswith("#"):
            k, v = line.split(":", 1)
            try:
                values[k.strip()] = {"value": float(v)}
            except ValueError:
                pass
    out.write_text(json.dumps({"params": values}))


def judge(spec: Path, data: Path, work: Path, fresh: Path, true_tips: np.ndarray) -> tuple[float, float, float]:
    """The fit's tip error (rigid motion removed), largest std, and held-out residual: the RMS
    distance of the fresh poses of the true robot from their constraint as the fitted model
    predicts them, the constraint refitted (`evaluate`); gauge motions leave it unchanged."""
    fit = run("calibrate", str(spec), str(data), "--refine", "--format", "json")
    res = work / "fit.json"
    res.write_text(fit)
    stds = [p["std"] for p in json.loads(fit)["params"].values() if p.get("std") is not None]
    ev = json.loads(run("evaluate", str(spec), str(fresh), "--params", str(res), "--format", "json"))
    return kabsch_rms(tips(spec, res, fresh), true_tips), max(stds), ev["residual_rms"]


def one_seed(spec: Path, n: int, pool: int, noise: tuple[str, float], seed: int, work: Path) -> dict:
    truth = work / "truth.yaml"
    data = run("simulate", str(spec), "--poses", str(pool), "--seed", str(seed), noise[0], str(noise[1]),
               "--truth-out", str(truth))
    pool_csv = work / "pool.csv"
    pool_csv.write_text(data)
    t0 = time.perf_counter()
    chosen = run("select", str(spec), "-n", str(n), "--candidates", str(pool_csv), "--seed", str(seed),
                 noise[0], str(noise[1]))
    select_s = time.perf_counter() - t0
    chosen_csv = work / "chosen.csv"
    chosen_csv.write_text(chosen)
    fresh = work / "fresh.csv"
    fresh.write_text(run("simulate", str(spec), "--poses", "1000", "--seed", str(seed + 10_000),
                         "--truth", str(truth)))
    tj = work / "truth.json"
    truth_json(truth, tj)
    true_tips = tips(spec, tj, fresh)
    sel_tip, sel_std, sel_held = judge(spec, chosen_csv, work, fresh, true_tips)
    rows = data.splitlines()
    rng = np.random.default_rng(seed)
    rand_tip, rand_std, rand_held = [], [], []
    for _ in range(RANDOM_SETS):
        pick = rng.choice(len(rows) - 1, size=n, replace=False) + 1
        rc = work / "random.csv"
        rc.write_text("\n".join([rows[0]] + [rows[i] for i in pick]) + "\n")
        try:
            t, s, h = judge(spec, rc, work, fresh, true_tips)
        except RuntimeError:
            t, s, h = float("inf"), float("inf"), float("inf")
        rand_tip.append(t)
        rand_std.append(s)
        rand_held.append(h)
    return {
        "tip_ratio": float(np.median(rand_tip)) / sel_tip,
        "std_ratio": float(np.median(rand_std)) / sel_std,
        "held_ratio": float(np.median(rand_held)) / sel_held,
        "select_s": select_s,
    }


def main() -> None:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    print(f"| case | N | pool | seeds | random/selected tip (median) | random/selected max std (median) "
          f"| random/selected held-out residual | seeds won (held-out) | select time (median) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, spec, n, pool, opt, noise in CASES:
        results = []
        with tempfile.TemporaryDirectory() as d:
            for seed in range(1, seeds + 1):
                try:
                    results.append(one_seed(spec, n, pool, (opt, noise), seed, Path(d)))
                except RuntimeError as e:
                    print(f"  seed {seed}: {e}", file=sys.stderr)
        if not results:
            continue
        tip = np.median([r["tip_ratio"] for r in results])
        std = np.median([r["std_ratio"] for r in results])
        held = np.median([r["held_ratio"] for r in results])
        won = sum(r["held_ratio"] > 1.0 for r in results)
        t = np.median([r["select_s"] for r in results])
        print(f"| {name} | {n} | {pool} | {len(results)} | {tip:.2f}x | {std:.2f}x | {held:.2f}x "
              f"| {won}/{len(results)} | {t:.2f} s |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()

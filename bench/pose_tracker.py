"""The full-pose benchmark of issue 26: `lincal calibrate` on a 6-DOF tracker's measurements
(`measured_pose`) beside a plain scipy Levenberg-Marquardt fit of the same model.

Spec `lincal-models/specs/puma560_pose_tracker.yaml`: PUMA 560, standard DH, every a, alpha,
d and home unknown, the tracker (base) frame and the probe (tool) frame unknown, 36
parameters. Per seed:

1. `simulate` 100 poses (20 um per coordinate, 50 urad per axis) with `--truth-out`;
2. `calibrate --format json`, timed as a whole process (the median of REPS runs);
3. the peer: this script's `fit` mode, a numpy forward kinematics of the same model and
   `scipy.optimize.least_squares(method='lm')` (MINPACK, finite-difference Jacobian, default
   tolerances) over the same 36 parameters from the spec's nominals, the parameters lincal held
   by its gauge rule (`std: null`, not known) fixed at their nominals, residuals per pose
   `x - x_m` (m) and `w * log(R_m^T R)` (rotation vector, rad) with `w = position_std /
   orientation_std`, lincal's weights; timed both as the fit alone (`perf_counter` around
   `least_squares`) and as the whole Python process (imports included, median of PEER_REPS);
4. on 1 000 fresh joint readings (uniform inside the spec's joint limits), the predicted tool
   poses against the true ones: RMS position error (m) and RMS orientation error (rad, the
   angle of R_pred^T R_true); lincal's through `lincal predict`, scipy's through the numpy
   kinematics, which is first checked against `lincal predict --params truth.json` (to 1e-12)
   so the peer provably fits the same model;
5. a table per seed and the medians over seeds of lincal/scipy (error ratios; target <= 1.05),
   lincal's process time (target < 0.2 s), scipy's times and the speed-up.

Usage: LINCAL=target/release/lincal bench/.venv/bin/python bench/pose_tracker.py [SEEDS]
       (SEEDS: a count, default 5, seeds 1..SEEDS; env REPS (default 5) runs of calibrate per
       seed and PEER_REPS (default 1) runs of the scipy process per seed, median; needs numpy, scipy,
       pyyaml: the bench/.venv of bench/venv.sh has them; BENCH_QUICK=1 (CI): seed 1, one run a side)
       bench/.venv/bin/python bench/pose_tracker.py fit SPEC DATA.csv HELD OUT.json
       (the peer alone: HELD a comma-separated list of parameters fixed at nominal, or "-")
"""

from __future__ import annotations

import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parent.parent
LINCAL = os.environ.get("LINCAL", str(ROOT / "target" / "release" / "lincal"))
SPEC = ROOT / "lincal-models" / "specs" / "puma560_pose_tracker.yaml"
POSES = 100
NOISE_POS = 2e-5
NOISE_ORI = 5e-5
FRESH = 1000
REPS = int(os.environ.get("REPS", "5"))
PEER_REPS = int(os.environ.get("PEER_REPS", "1"))
# CI's run of the documented command: seed 1, one run a side; the numbers are not measurements.
QUICK = os.environ.get("BENCH_QUICK") == "1"
if QUICK:
    REPS = PEER_REPS = 1


# --- the model ------------------------------------------------------------------------------

def const_value(v) -> float:
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return float(v)
    s = str(v).strip()
    allowed = set("0123456789eE+-*/(). ")
    if not set(s.replace("pi", "")) <= allowed:
        raise ValueError(f"bad expression {s!r}")
    return float(eval(s, {"__builtins__": {}}, {"pi": math.pi}))


class Model:
    """A standard-DH revolute chain with a base frame and a tool frame, as lincal reads it:
    T = B A_1 ... A_n Tool, A_i = Rz(q_i - home_i) Tz(d_i) Tx(a_i) Rx(alpha_i),
    B and Tool = Tr(x, y, z) Rz(yaw) Ry(pitch) Rx(roll)."""

    def __init__(self, path: Path):
        spec = yaml.safe_load(Path(path).read_text())
        assert spec.get("convention", "dh") == "dh", "standard DH only"
        self.names = list(spec["params"])
        self.nominal = {n: const_value(p["nominal"]) for n, p in spec["params"].items()}
        self.known = {n for n, p in spec["params"].items() if p.get("known", False)}
        self.joints = []
        for j in spec["joints"]:
            assert j["type"] == "revolute", "revolute joints only"
            self.joints.append({k: j.get(k, 0) for k in ("a", "alpha", "d", "home")})
        self.limits = np.array([j["limits"] for j in spec["joints"]], dtype=float)
        self.tool = spec["tool"]
        self.base = spec["base"]
        c = spec["constraint"]["measured_pose"] or {}
        self.weight = c.get("position_std", 1.0) / c.get("orientation_std", 1.0)

    def slot(self, v, values):
        return values[v] if isinstance(v, str) and v in values else const_value(v)

    def frame(self, f, values) -> np.ndarray:
        g = lambda k: self.slot(f.get(k, 0), values)
        cy, sy = math.cos(g("yaw")), math.sin(g("yaw"))
        cp, sp = math.cos(g("pitch")), math.sin(g("pitch"))
        cr, sr = math.cos(g("roll")), math.sin(g("roll"))
        t = np.eye(4)
        t[:3, :3] = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]) @ \
            np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]]) @ \
            np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
        t[:3, 3] = [g("x"), g("y"), g("z")]
        return t

    def poses(self, values: dict, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tool positions (N x 3) and rotations (N x 3 x 3) for joint readings Q (N x n)."""
        N = Q.shape[0]
        T = np.broadcast_to(self.frame(self.base, values), (N, 4, 4)).copy()
        for i, j in enumerate(self.joints):
            a, al, d = (self.slot(j[k], values) for k in ("a", "alpha", "d"))
            th = Q[:, i] - self.slot(j["home"], values)
            ct, st = np.cos(th), np.sin(th)
            ca, sa = math.cos(al), math.sin(al)
            A = np.zeros((N, 4, 4))
            A[:, 0, 0], A[:, 0, 1], A[:, 0, 2], A[:, 0, 3] = ct, -st * ca, st * sa, a * ct
            A[:, 1, 0], A[:, 1, 1], A[:, 1, 2], A[:, 1, 3] = st, ct * ca, -ct * sa, a * st
            A[:, 2, 1], A[:, 2, 2], A[:, 2, 3] = sa, ca, d
            A[:, 3, 3] = 1.0
            T = T @ A
        T = T @ self.frame(self.tool, values)
        return T[:, :3, 3], T[:, :3, :3]


def read_data(path: Path, n: int):
    """Joint readings, and the measured positions and rotations when the file has them."""
    with open(path) as f:
        header = f.readline().strip().split(",")
    a = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, comments="#")
    col = {h: k for k, h in enumerate(header)}
    Q = a[:, [col[f"q{i + 1}"] for i in range(n)]]
    if "x" not in col:
        return Q, None, None
    X = a[:, [col["x"], col["y"], col["z"]]]
    if "qw" in col:
        R = Rotation.from_quat(a[:, [col["qw"], col["qx"], col["qy"], col["qz"]]], scalar_first=True)
    else:
        R = Rotation.from_rotvec(a[:, [col["rx"], col["ry"], col["rz"]]])
    return Q, X, R


# --- the scipy peer ---------------------------------------------------------------------------

def peer_fit(spec: Path, data: Path, held: list[str], out: Path) -> None:
    m = Model(spec)
    Q, Xm, Rm = read_data(data, len(m.joints))
    Rm_inv = Rm.inv()
    free = [n for n in m.names if n not in m.known and n not in held]
    w = m.weight

    def residual(x):
        v = dict(m.nominal)
        v.update(zip(free, x))
        X, R = m.poses(v, Q)
        phi = (Rm_inv * Rotation.from_matrix(R, assume_valid=True)).as_rotvec()  # log(R_m^T R)
        return np.hstack([X - Xm, w * phi]).ravel()

    x0 = np.array([m.nominal[n] for n in free])
    t0 = time.perf_counter()
    sol = least_squares(residual, x0, method="lm")
    fit_seconds = time.perf_counter() - t0
    r = sol.fun.reshape(-1, 6)
    values = dict(m.nominal)
    values.update(zip(free, sol.x))
    out.write_text(json.dumps({
        "params": {k: {"value": float(val)} for k, val in values.items()},
        "fit_seconds": fit_seconds, "nfev": int(sol.nfev), "status": int(sol.status),
        "cost": float(sol.cost), "free": len(free),
        "residual_rms": float(np.sqrt((r[:, :3] ** 2).sum(1).mean())),
        "orientation_rms": float(np.sqrt((r[:, 3:] ** 2).sum(1).mean())) / w,
    }))


def cost_of(m: Model, values: dict, data: Path) -> float:
    """0.5 * sum of squared weighted residuals (least_squares' cost) of given parameters."""
    Q, Xm, Rm = read_data(data, len(m.joints))
    X, R = m.poses(values, Q)
    phi = (Rm.inv() * Rotation.from_matrix(R)).as_rotvec()
    return 0.5 * float(((X - Xm) ** 2).sum() + ((m.weight * phi) ** 2).sum())


# --- the driver --------------------------------------------------------------------------------

def lincal(*args: str) -> str:
    out = subprocess.run([LINCAL, *map(str, args)], capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"{LINCAL} {' '.join(map(str, args))}: exit {out.returncode}: {out.stderr}")
    return out.stdout


def timed(cmd: list[str], reps: int) -> tuple[float, str]:
    """Median wall time of `reps` runs of a process, and the last run's stdout."""
    times, stdout = [], ""
    for _ in range(reps):
        t0 = time.perf_counter()
        out = subprocess.run(cmd, capture_output=True, text=True)
        times.append(time.perf_counter() - t0)
        if out.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)}: exit {out.returncode}: {out.stderr}")
        stdout = out.stdout
    return statistics.median(times), stdout


def predicted(spec: Path, params: Path, fresh: Path) -> tuple[np.ndarray, Rotation]:
    a = np.loadtxt(lincal("predict", spec, "--params", params, fresh).splitlines()[1:],
                   delimiter=",", ndmin=2)
    return a[:, :3], Rotation.from_quat(a[:, 3:7], scalar_first=True)


def errors(X, R: Rotation, Xt, Rt: Rotation) -> tuple[float, float]:
    pos = float(np.sqrt(((X - Xt) ** 2).sum(1).mean()))
    ang = (R.inv() * Rt).magnitude()
    return pos, float(np.sqrt((ang ** 2).mean()))


def one_seed(seed: int, work: Path, m: Model) -> dict:
    data, truth_yaml, truth_json = work / "data.csv", work / "truth.yaml", work / "truth.json"
    data.write_text(lincal("simulate", SPEC, "--poses", POSES, "--seed", seed, "--noise-measure",
                           NOISE_POS, "--noise-orientation", NOISE_ORI, "--truth-out", truth_yaml))
    truth = {k: float(v) for k, v in yaml.safe_load(truth_yaml.read_text()).items()}
    truth_json.write_text(json.dumps({"params": {k: {"value": v} for k, v in truth.items()}}))

    # lincal, the whole process
    t_lincal, out = timed([LINCAL, "calibrate", str(SPEC), str(data), "--format", "json"], REPS)
    res = json.loads(out)
    result = work / "lincal.json"
    result.write_text(out)
    held = sorted(n for n, p in res["params"].items() if p["std"] is None and not p["known"])
    assert held == sorted(n for n, p in res["params"].items() if p.get("held")), "held flags differ"

    # scipy, the whole process (this script's fit mode)
    peer = work / "scipy.json"
    t_scipy_proc, _ = timed([sys.executable, __file__, "fit", str(SPEC), str(data),
                             ",".join(held) or "-", str(peer)], PEER_REPS)
    sp = json.loads(peer.read_text())

    # fresh joint readings, uniform inside the limits
    rng = np.random.default_rng(10_000 + seed)
    lo, hi = m.limits[:, 0], m.limits[:, 1]
    Qf = lo + (hi - lo) * rng.random((FRESH, len(m.joints)))
    fresh = work / "fresh.csv"
    np.savetxt(fresh, Qf, delimiter=",", fmt="%.17g",
               header=",".join(f"q{i + 1}" for i in range(len(m.joints))), comments="")
    Qf = read_data(fresh, len(m.joints))[0]  # exactly the values lincal reads

    # the truth, and the numpy kinematics checked against lincal's
    Xt, Rt_m = m.poses(truth, Qf)
    Rt = Rotation.from_matrix(Rt_m)
    Xl_t, Rl_t = predicted(SPEC, truth_json, fresh)
    fk_pos = float(np.abs(Xl_t - Xt).max())
    fk_ang = float((Rl_t.inv() * Rt).magnitude().max())
    if fk_pos > 1e-12 or fk_ang > 1e-12:
        raise RuntimeError(f"seed {seed}: numpy FK differs from lincal predict: {fk_pos:.3g} m, {fk_ang:.3g} rad")

    Xl, Rl = predicted(SPEC, result, fresh)
    l_pos, l_ang = errors(Xl, Rl, Xt, Rt)
    # lincal without its weak-direction prior (`--prior off`): the plain least-squares fit
    off = work / "lincal_off.json"
    off.write_text(lincal("calibrate", SPEC, data, "--format", "json", "--prior", "off"))
    o_pos, o_ang = errors(*predicted(SPEC, off, fresh), Xt, Rt)
    ov = {k: p["value"] for k, p in json.loads(off.read_text())["params"].items()}
    sv = {k: p["value"] for k, p in sp["params"].items()}
    Xs, Rs_m = m.poses(sv, Qf)
    s_pos, s_ang = errors(Xs, Rotation.from_matrix(Rs_m), Xt, Rt)
    lv = {k: p["value"] for k, p in res["params"].items()}
    return {
        "seed": seed, "held": held, "fk_pos": fk_pos, "fk_ang": fk_ang,
        "l_pos": l_pos, "s_pos": s_pos, "l_ang": l_ang, "s_ang": s_ang,
        "r_pos": l_pos / s_pos, "r_ang": l_ang / s_ang,
        "t_lincal": t_lincal, "t_fit": sp["fit_seconds"], "t_proc": t_scipy_proc,
        "nfev": sp["nfev"], "status": sp["status"], "method": res.get("method"),
        "l_cost": cost_of(m, lv, data), "s_cost": sp["cost"],
        "l_rms": res["residual_rms"], "l_orms": res["orientation_rms"],
        "s_rms": sp["residual_rms"], "s_orms": sp["orientation_rms"],
        "warnings": res.get("warnings", []),
        "prior": (res.get("prior") or {}).get("applied", False), "weak": (res.get("prior") or {}).get("weak", []),
        "o_pos": o_pos / s_pos, "o_ang": o_ang / s_ang, "o_cost": cost_of(m, ov, data),
    }


def main(argv: list[str]) -> None:
    if argv and argv[0] == "fit":
        spec, data, held, out = argv[1:5]
        peer_fit(Path(spec), Path(data), [] if held == "-" else held.split(","), Path(out))
        return
    seeds = list(range(1, (1 if QUICK else int(argv[0]) if argv else 5) + 1))
    version = lincal("--version").strip()
    m = Model(SPEC)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            work = Path(tmp) / f"s{seed}"
            work.mkdir()
            r = one_seed(seed, work, m)
            rows.append(r)
            print(f"seed {seed}: held {','.join(r['held'])}; method {r['method']}; scipy nfev {r['nfev']} "
                  f"status {r['status']}; cost lincal {r['l_cost']:.6g} scipy {r['s_cost']:.6g}; "
                  f"train rms lincal {r['l_rms']:.4g} m {r['l_orms']:.4g} rad, scipy {r['s_rms']:.4g} m "
                  f"{r['s_orms']:.4g} rad; prior {'applied to ' + ','.join(r['weak']) if r['prior'] else 'not applied'}; "
                  f"--prior off: cost {r['o_cost']:.6g}, ratios {r['o_pos']:.4f} {r['o_ang']:.4f}; FK vs predict {r['fk_pos']:.1e} m {r['fk_ang']:.1e} rad"
                  + (f"; warnings {r['warnings']}" if r["warnings"] else ""), file=sys.stderr, flush=True)

    print(f"{version}, {time.strftime('%Y-%m-%dT%H:%MZ', time.gmtime())}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.2f}. {POSES} poses, noise {NOISE_POS * 1e6:g} um and "
          f"{NOISE_ORI * 1e6:g} urad per axis; errors on {FRESH} fresh joint readings against the truth.")
    print(f"lincal time: whole `calibrate` process, median of {REPS}; scipy: the `least_squares` call "
          f"alone, and the whole Python process (imports included, median of {PEER_REPS}).")
    print()
    print("| seed | lincal pos RMS | scipy pos RMS | ratio | lincal ori RMS | scipy ori RMS | ratio "
          "| lincal time | scipy fit | scipy process | scipy/lincal time (fit / process) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['seed']} | {r['l_pos'] * 1e6:.2f} µm | {r['s_pos'] * 1e6:.2f} µm | {r['r_pos']:.4f} "
              f"| {r['l_ang'] * 1e6:.2f} µrad | {r['s_ang'] * 1e6:.2f} µrad | {r['r_ang']:.4f} "
              f"| {r['t_lincal']:.3f} s | {r['t_fit']:.2f} s | {r['t_proc']:.2f} s "
              f"| {r['t_fit'] / r['t_lincal']:.0f}× / {r['t_proc'] / r['t_lincal']:.0f}× |")
    med = lambda k: statistics.median(r[k] for r in rows)
    sp_fit = statistics.median(r["t_fit"] / r["t_lincal"] for r in rows)
    sp_proc = statistics.median(r["t_proc"] / r["t_lincal"] for r in rows)
    print(f"| **median** | {med('l_pos') * 1e6:.2f} µm | {med('s_pos') * 1e6:.2f} µm | **{med('r_pos'):.4f}** "
          f"| {med('l_ang') * 1e6:.2f} µrad | {med('s_ang') * 1e6:.2f} µrad | **{med('r_ang'):.4f}** "
          f"| **{med('t_lincal'):.3f} s** | {med('t_fit'):.2f} s | {med('t_proc'):.2f} s "
          f"| {sp_fit:.0f}× / {sp_proc:.0f}× |")
    print()
    print("lincal `--prior off` (no weak-direction prior, the plain least-squares problem scipy solves), "
          "lincal/scipy error ratios, position / orientation: "
          + "; ".join(f"seed {r['seed']} {r['o_pos']:.4f} / {r['o_ang']:.4f}" for r in rows)
          + "; prior applied on seeds " + (", ".join(f"{r['seed']} ({','.join(r['weak'])})" for r in rows if r['prior']) or "none"))
    print()
    ok_err = max(med("r_pos"), med("r_ang")) <= 1.05
    ok_time = med("t_lincal") < 0.2
    print(f"targets: error ratios <= 1.05: {'met' if ok_err else 'MISSED'} "
          f"(worst seed {max(max(r['r_pos'], r['r_ang']) for r in rows):.4f}); "
          f"lincal process < 0.2 s: {'met' if ok_time else 'MISSED'} "
          f"(slowest seed {max(r['t_lincal'] for r in rows):.3f} s)")


if __name__ == "__main__":
    main(sys.argv[1:])

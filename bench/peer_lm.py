#!/usr/bin/env python3
"""A plain scipy peer of `lincal calibrate`: forward kinematics of a lincal spec and a
Levenberg-Marquardt fit (scipy.optimize.least_squares, method='lm') of every non-known
parameter from the nominals.

    peer_lm.py fit SPEC DATA.csv OUT.json        estimate -> {name: value}
    peer_lm.py validate SPEC VAL.csv EST.json [TRUTH.yaml]
        RMS tip error (measured), or for points the spread of predicted tips about each
        point's mean, and with TRUTH the RMS tip error on free poses after a similarity fit

Supported: dim 3, conventions dh / mdh, revolute and prismatic joints, tool, base, and the
constraint kinds `measured` and `point` (single `constraint:` or a `constraints:` list).
EST.json may be this script's {name: value} or lincal's JSON (params[name].value).
"""
import csv
import json
import math
import re
import sys

import numpy as np
import yaml
from scipy.optimize import least_squares

NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
EXPR = re.compile(r"^[0-9eE+\-*/(). ]*$")


def const_value(text):
    """A number or an exact expression such as pi/2, -pi/2, 2*pi/3, 0.5."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        return float(text)
    s = str(text).strip()
    if not EXPR.match(s.replace("pi", "")):
        raise ValueError(f"bad expression {s!r}")
    return float(eval(s, {"__builtins__": {}}, {"pi": math.pi}))


class Model:
    def __init__(self, path):
        with open(path) as f:
            spec = yaml.safe_load(f)
        if spec.get("dim", 3) != 3:
            raise SystemExit("peer_lm: only dim 3 is supported")
        self.conv = spec.get("convention", "dh")
        params = spec.get("params") or {}
        self.names = list(params)
        self.nominal = {n: const_value(p["nominal"]) for n, p in params.items()}
        self.known = {n for n, p in params.items() if p.get("known", False)}
        self.free = [n for n in self.names if n not in self.known]

        def slot(v):
            if isinstance(v, str) and NAME.match(v.strip()) and v.strip() in params:
                return v.strip()  # a parameter name
            return const_value(v)

        self.joints = []
        for j in spec["joints"]:
            prism = j["type"] == "prismatic"
            self.joints.append({
                "prismatic": prism,
                "a": slot(j.get("a", 0)),
                "alpha": slot(j.get("alpha", 0)),
                "d": slot(j.get("d", 0)),
                "home": slot(j.get("home", 0)),
                "theta": slot(j.get("theta", 0)),
                "offset": slot(j.get("offset", 0)),
            })
        self.tool = [slot(v) for v in (spec.get("tool") or [0, 0, 0])]
        base = spec.get("base")
        self.base = None if base is None else {k: slot(base.get(k, 0)) for k in
                                               ("x", "y", "z", "roll", "pitch", "yaw")}
        cons = spec.get("constraints")
        if cons is None:
            cons = [spec["constraint"]]
        self.kinds = []
        self.points = []
        for c in cons:
            (kind, fields), = c.items()
            if kind == "measured":
                self.kinds.append("measured")
                self.points.append(None)
            elif kind == "point":
                self.kinds.append("point")
                self.points.append([slot(v) for v in fields["p"]])
            else:
                raise SystemExit(f"peer_lm: constraint kind {kind!r} not supported")
        if len(set(self.kinds)) != 1:
            raise SystemExit("peer_lm: mixed constraint kinds not supported")
        self.kind = self.kinds[0]

    def values(self, x=None, over=None):
        v = dict(self.nominal)
        if over:
            v.update(over)
        if x is not None:
            v.update(zip(self.free, x))
        return v

    def tips(self, v, Q):
        """Tip positions (N x 3) for joint readings Q (N x n), parameter values v."""
        g = lambda s: v[s] if isinstance(s, str) else s
        N = Q.shape[0]
        px = np.full(N, g(self.tool[0]))
        py = np.full(N, g(self.tool[1]))
        pz = np.full(N, g(self.tool[2]))
        # x = B A_1 ... A_n tool: apply A_n first.
        for i in range(len(self.joints) - 1, -1, -1):
            j = self.joints[i]
            a, al = g(j["a"]), g(j["alpha"])
            if j["prismatic"]:
                th, d = g(j["theta"]), Q[:, i] + g(j["offset"])
            else:
                th, d = Q[:, i] - g(j["home"]), g(j["d"])
            ct, st = np.cos(th), np.sin(th)
            ca, sa = math.cos(al), math.sin(al)
            if self.conv == "mdh":  # Rx(al) Tx(a) Rz(th) Tz(d)
                pz = pz + d
                px, py = ct * px - st * py, st * px + ct * py
                px = px + a
                py, pz = ca * py - sa * pz, sa * py + ca * pz
            else:  # Rz(th) Tz(d) Tx(a) Rx(al)
                py, pz = ca * py - sa * pz, sa * py + ca * pz
                px = px + a
                pz = pz + d
                px, py = ct * px - st * py, st * px + ct * py
        if self.base is not None:  # Tr Rz(yaw) Ry(pitch) Rx(roll)
            b = {k: g(s) for k, s in self.base.items()}
            c, s = math.cos(b["roll"]), math.sin(b["roll"])
            py, pz = c * py - s * pz, s * py + c * pz
            c, s = math.cos(b["pitch"]), math.sin(b["pitch"])
            px, pz = c * px + s * pz, -s * px + c * pz
            c, s = math.cos(b["yaw"]), math.sin(b["yaw"])
            px, py = c * px - s * py, s * px + c * py
            px, py, pz = px + b["x"], py + b["y"], pz + b["z"]
        return np.stack([px, py, pz], axis=1)

    def point_array(self, v):
        g = lambda s: v[s] if isinstance(s, str) else s
        return np.array([[g(s) for s in p] for p in self.points])


def load_csv(path, n):
    with open(path) as f:
        rows = [r for r in csv.reader(l for l in f if not l.startswith("#"))]
    head = [h.strip() for h in rows[0]]
    data = np.array(rows[1:], dtype=float)
    col = {h: k for k, h in enumerate(head)}
    Q = data[:, [col[f"q{i + 1}"] for i in range(n)]]
    X = data[:, [col[c] for c in "xyz"]] if "x" in col else None
    C = data[:, col["constraint"]].astype(int) if "constraint" in col else np.zeros(len(data), int)
    return Q, X, C


def residual_fn(m, Q, X, C):
    if m.kind == "measured":
        return lambda x: (m.tips(m.values(x), Q) - X).ravel()

    def r(x):
        v = m.values(x)
        return (m.tips(v, Q) - m.point_array(v)[C]).ravel()
    return r


def fit(spec, data, out):
    m = Model(spec)
    Q, X, C = load_csv(data, len(m.joints))
    x0 = np.array([m.nominal[n] for n in m.free])
    sol = least_squares(residual_fn(m, Q, X, C), x0, method="lm")
    rms = float(np.sqrt(np.mean(sol.fun.reshape(-1, 3) ** 2) * 3))
    est = {n: float(v) for n, v in zip(m.free, sol.x)}
    est.update({n: m.nominal[n] for n in m.known})
    with open(out, "w") as f:
        json.dump({n: est[n] for n in m.names}, f, indent=1)
    print(f"peer_lm: {len(Q)} poses, {len(m.free)} parameters, nfev {sol.nfev}, "
          f"status {sol.status}, residual rms {rms:.3e} m", file=sys.stderr)


def rms(e):
    return float(np.sqrt(np.mean(np.sum(e ** 2, axis=1))))


def similarity_rms(A, B):
    """RMS of B - (s R A + t) after the best similarity transform (Umeyama)."""
    ma, mb = A.mean(axis=0), B.mean(axis=0)
    A0, B0 = A - ma, B - mb
    U, S, Vt = np.linalg.svd(B0.T @ A0 / len(A))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    R = U @ D @ Vt
    s = np.trace(np.diag(S) @ D) / np.mean(np.sum(A0 ** 2, axis=1))
    return rms(B0 - s * A0 @ R.T)


def validate(spec, data, est_path, truth_path=None):
    m = Model(spec)
    Q, X, C = load_csv(data, len(m.joints))
    with open(est_path) as f:
        est = json.load(f)
    if isinstance(est.get("params"), dict):  # lincal's JSON
        est = {n: p["value"] for n, p in est["params"].items()}
    v = m.values(over=est)
    T = m.tips(v, Q)
    if m.kind == "measured":
        print(f"{rms(T - X):.3e}")
        return
    # spread about each point's mean predicted tip
    e = np.empty_like(T)
    for k in np.unique(C):
        e[C == k] = T[C == k] - T[C == k].mean(axis=0)
    out = f"{rms(e):.3e}"
    if truth_path:
        # The spread cannot see a collapsed arm (tip fixed whatever q). Also compare tips on
        # 1000 unconstrained poses (uniform in [-pi, pi]) with the true tips, after the best
        # similarity transform (a point constraint cannot see the base frame or the scale).
        with open(truth_path) as f:
            truth = {k: const_value(x) for k, x in yaml.safe_load(f).items()}
        Qf = np.random.default_rng(0).uniform(-math.pi, math.pi, (1000, len(m.joints)))
        out += f" / {similarity_rms(m.tips(v, Qf), m.tips(m.values(over=truth), Qf)):.3e}"
    print(out)


if __name__ == "__main__":
    if not 5 <= len(sys.argv) <= 6 or sys.argv[1] not in ("fit", "validate"):
        raise SystemExit(__doc__)
    (fit if sys.argv[1] == "fit" else validate)(*sys.argv[2:])

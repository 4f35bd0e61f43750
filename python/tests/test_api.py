"""The API: round trips, agreement with the command line, every kind of data."""

from __future__ import annotations

import ast
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

import lincal
from conftest import MODELS, SPECS
from test_errors import TWO_LINK, TWO_LINK_DICT


@pytest.fixture(scope="module")
def adept():
    return lincal.Spec.from_yaml(MODELS / "adept_one.yaml")


def test_spec_attributes(adept):
    assert adept.dim == 2
    assert adept.joint_count == 2
    assert adept.estimated == adept.params  # nothing known
    assert set(adept.nominal) == set(adept.params)
    assert adept.constraints == ["line"]
    assert not adept.constraint_list and not adept.measured
    assert "adept" in repr(adept)


def test_from_dict_is_from_yaml():
    a = lincal.Spec.from_dict(TWO_LINK_DICT)
    b = lincal.Spec.from_str(TWO_LINK)
    assert a.basis().to_dict() == b.basis().to_dict()
    sim = lincal.simulate(b, 50, seed=4, noise_track=1e-5)
    assert sim.q.shape == (50, 2)
    assert lincal.calibrate(a, sim.q).to_dict() == lincal.calibrate(b, sim.q).to_dict()
    # numpy scalars, tuples and exact-expression strings are taken as in YAML.
    d = json.loads(json.dumps(TWO_LINK_DICT))
    d["dim"] = np.int64(2)
    d["params"]["a1"]["nominal"] = np.float32(0.375)
    d["joints"] = tuple(d["joints"])
    d["joints"][0]["alpha"] = "pi/2 - pi/2"
    lincal.Spec.from_dict(d)


def test_noise_free_round_trip_recovers_the_truth(adept):
    truth = {"a1": 0.375, "th1": 0.01, "a2": 0.4249, "th2": 0.0446, "b1": -1.79, "b2": -0.56}
    sim = lincal.simulate(adept, 100, seed=11, truth=truth)
    assert sim.truth == pytest.approx(truth)
    cal = lincal.calibrate(adept, sim.q)
    v = cal.values
    assert v["a2"] / v["a1"] == pytest.approx(truth["a2"] / truth["a1"], abs=1e-9)
    assert v["th2"] == pytest.approx(truth["th2"], abs=1e-9)
    assert math.atan2(v["b2"], v["b1"]) + v["th1"] == pytest.approx(
        math.atan2(truth["b2"], truth["b1"]) + truth["th1"], abs=1e-9
    )
    assert cal.residual_rms < 1e-9
    assert np.all(cal.residuals < 1e-8)
    # The truth's tips are on the line: b·x + 1 = 0.
    tips = adept.tip(sim.q, truth)
    assert tips.shape == (100, 2)
    assert np.allclose(tips @ np.array([truth["b1"], truth["b2"]]) + 1, 0, atol=1e-9)
    # Truth as a vector, as a file.
    again = lincal.simulate(adept, 100, seed=11, truth=[truth[k] for k in adept.estimated])
    assert np.array_equal(again.q, sim.q)


def test_truth_file(adept, tmp_path):
    path = tmp_path / "truth.yaml"
    path.write_text("a2: 0.43\nth2: 0.05\n")
    sim = lincal.simulate(adept, 10, seed=1, truth=path)
    assert sim.truth["a2"] == 0.43 and sim.truth["a1"] == adept.nominal["a1"]
    assert lincal.simulate(adept, 10, seed=1, truth=str(path)).truth == sim.truth


def test_result_fields(adept):
    sim = lincal.simulate(adept, 80, seed=5, noise_track=2e-5)
    cal = lincal.calibrate(adept, sim.q)
    d = cal.to_dict()
    for key in ["params", "identifiable_count", "basis_size", "poses", "rank", "residual_rms",
                "method", "warnings", "start", "condition", "worst_poses"]:
        assert key in d
    assert list(cal.params) == adept.params
    for name, p in cal.params.items():
        assert set(p) == {"value", "std", "identifiable", "known", "held"}
        assert p["value"] == cal.values[name]
        assert (p["std"] is None) == (p["held"] or p["known"])
    assert cal.basis_size == d["basis_size"] == 5
    assert cal.rank == d["rank"]
    assert cal.poses == 80
    assert cal.method == "linear" and cal.start == "linear"
    assert cal.warnings == d["warnings"]
    assert cal.worst_poses == d["worst_poses"]
    assert cal.worst_poses[0]["residual"] == pytest.approx(cal.residuals.max())
    assert cal.worst_poses[0]["pose"] == int(np.argmax(cal.residuals))
    assert cal.worst_poses[0]["line"] == 0  # no lines given
    assert not cal.residuals.flags.writeable
    assert json.loads(cal.to_json()) == d
    assert "Calibration(" in repr(cal)
    # residuals through the spec: at the estimate, and before (the nominals).
    assert np.allclose(adept.residuals(sim.q, cal), cal.residuals, rtol=0, atol=1e-15)
    before = adept.residuals(sim.q)
    assert before.shape == (80,) and np.sqrt(np.mean(before**2)) > cal.residual_rms
    assert np.array_equal(adept.tip(sim.q, cal), adept.tip(sim.q, cal.values))


def test_refine_robust_reject(adept):
    sim = lincal.simulate(adept, 120, seed=8, noise_track=1e-5)
    q = sim.q.copy()
    q[[3, 50], 1] += 0.5  # two bad rows
    refined = lincal.calibrate(adept, q, refine=True)
    assert refined.method == "linear+refine"
    assert any("robust standard deviations" in w for w in refined.warnings)
    robust = lincal.calibrate(adept, q, robust="huber")
    assert robust.to_dict()["robust"]["loss"] == "huber"
    rejected = lincal.calibrate(adept, q, reject_outliers=True, lines=np.arange(120) + 2)
    assert sorted(r["pose"] for r in rejected.rejected) == [3, 50]
    assert sorted(r["line"] for r in rejected.rejected) == [5, 52]
    assert rejected.residuals.shape == (120,)
    nominal = lincal.calibrate(adept, sim.q, start="nominal")
    assert nominal.start == "nominal"


def test_prior_options(adept):
    sim = lincal.simulate(adept, 80, seed=3, noise_track=1e-5)
    fit = lincal.calibrate(adept, sim.q)
    # The linear estimate alone stays when the data see every direction better than the
    # drawing's tolerance: the prior is on but not applied.
    assert fit.prior["applied"] is False
    assert fit.prior["weight"] is None and fit.prior["selection"] is None
    assert fit.prior["shape"] == "frames"
    # Refined, the prior joins, its strength chosen from the data (joint-space clusters).
    refined = lincal.calibrate(adept, sim.q, refine=True)
    assert refined.prior["applied"] is True
    sel = refined.prior["selection"]
    assert sel["rule"] in ("scale", "ard") and sel["grouping"] == "clusters"
    # White noise on a model that holds the data: no lack of fit beyond the test's threshold.
    assert sel["lack_of_fit"]["sigmas"] < 3 and 0.5 < sel["lack_of_fit"]["ratio"] < 1.5
    assert sel["folds"] == 5 and len(sel["curve"]) == 25
    assert all(c["rms"] > 0 for c in sel["curve"])
    # MUKCa's relative weight, as an override: tolerances sigma/sqrt(N*w).
    relative = lincal.calibrate(adept, sim.q, prior_weight=1e-4, refine=True)
    assert relative.prior["weight"] == 1e-4 and relative.prior["selection"] is None
    tau = relative.prior["sigma"] / math.sqrt(80 * 1e-4)
    assert relative.prior["length_tolerance"] == pytest.approx(tau, rel=1e-12)
    assert relative.prior["angle_tolerance"] == pytest.approx(tau, rel=1e-12)
    with pytest.raises(ValueError, match="tolerance_length"):
        lincal.calibrate(adept, sim.q, tolerance_length=1e-200)
    with pytest.raises(ValueError, match="prior_weight"):
        lincal.calibrate(adept, sim.q, prior_weight=1e300)
    fixed = lincal.calibrate(adept, sim.q, tolerance_length=0.02)
    assert fixed.prior["weight"] is None
    assert fixed.prior["length_tolerance"] == 0.02 and fixed.prior["angle_tolerance"] == 0.01
    with pytest.raises(ValueError, match="prior_weight"):
        lincal.calibrate(adept, sim.q, tolerance_length=0.02, prior_weight=1e-4)
    with pytest.raises(ValueError, match="prior_weight"):
        lincal.calibrate(adept, sim.q, prior_weight=-1.0)
    off = lincal.calibrate(adept, sim.q, prior=False)
    assert off.prior["length_tolerance"] is None and off.prior["shape"] is None
    assert lincal.calibrate(adept, sim.q, prior="off").prior["shape"] is None
    assert lincal.calibrate(adept, sim.q, prior="params").prior["shape"] == "params"
    with pytest.raises(ValueError, match="prior"):
        lincal.calibrate(adept, sim.q, prior="sometimes")
    # A tolerance far below the data's std makes every arm parameter weak: applied.
    tight = lincal.calibrate(adept, sim.q, tolerance_length=1e-9, tolerance_angle=1e-9)
    assert tight.prior["applied"] is True and tight.prior["weak"]
    with pytest.raises(ValueError, match="tolerance_length"):
        lincal.calibrate(adept, sim.q, tolerance_length=0.0)


def test_list_of_constraints():
    spec = lincal.Spec.from_yaml(SPECS / "lines_list.yaml")
    assert spec.constraint_list
    sim = lincal.simulate(spec, 120, seed=3)
    assert sim.constraint.dtype == np.int64
    assert list(sim.constraint[:4]) == [0, 1, 0, 1]
    assert sim.data().keys() == {"q", "constraint"}
    cal = lincal.calibrate(spec, **sim.data())
    assert cal.residual_rms < 1e-8


def test_measured_tips():
    spec = lincal.Spec.from_yaml(SPECS / "measured_spatial.yaml")
    assert spec.measured
    sim = lincal.simulate(spec, 60, seed=3, noise_measure=1e-6)
    assert sim.x.shape == (60, 3)
    cal = lincal.calibrate(spec, sim.q, x=sim.x)
    assert cal.residual_rms < 1e-5
    assert np.allclose(spec.tip(sim.q, cal), sim.x, atol=1e-5)


def test_simulate_is_the_clis(adept, cli):
    code, out, err = cli("simulate", MODELS / "adept_one.yaml", "--poses", 40, "--seed", 9,
                         "--noise-track", "3e-5", "--noise-encoder", "1e-5")
    assert code == 0, err
    q = np.loadtxt(io.StringIO(out), delimiter=",", skiprows=1)
    sim = lincal.simulate(adept, 40, seed=9, noise_track=3e-5, noise_encoder=1e-5)
    assert np.array_equal(sim.q, q)


def test_read_csv_and_file_order(tmp_path):
    spec = lincal.Spec.from_yaml(SPECS / "lines_list.yaml")
    path = tmp_path / "data.csv"
    path.write_text("# comment\nconstraint,q2,_note,q1\n1,0.2,x,0.1\n\n0,0.4,y,0.3\n")
    d = spec.read_csv(path)
    assert d["q"].tolist() == [[0.1, 0.2], [0.3, 0.4]]
    assert d["constraint"].tolist() == [1, 0]
    assert d["lines"].tolist() == [3, 5]
    assert d["x"] is None


def test_read_csv_reads_degrees_and_refuses_them_by_default(tmp_path):
    # TWO_LINK's joints are revolute, without limits.
    spec = lincal.Spec.from_str(TWO_LINK)
    rad = np.array([[0.5, -1.25], [2.5, 0.125]])
    path = tmp_path / "deg.csv"
    path.write_text("# in degrees\nq1,q2\n" + "".join(
        f"{float(a)!r},{float(b)!r}\n" for a, b in np.degrees(rad)))
    q = spec.read_csv(path, angles="deg")["q"]
    assert np.allclose(q, rad, rtol=1e-15, atol=0)
    with pytest.raises(lincal.DataError) as e:
        spec.read_csv(path)
    assert (e.value.line, e.value.field) == (3, "q1")
    assert "these look like degrees: pass --angles deg" in str(e.value)
    taken = spec.read_csv(path, angles="rad")["q"]
    assert np.array_equal(taken, np.degrees(rad))
    with pytest.raises(lincal.InputError) as e:
        spec.read_csv(path, angles="degrees")
    assert e.value.field == "angles"


def test_tip_of_a_two_link_arm():
    spec = lincal.Spec.from_str(TWO_LINK)
    q = np.array([[0.0, 0.0], [np.pi / 2, 0.0], [0.3, -1.1]])
    tips = spec.tip(q)
    a1, a2 = 0.375, 0.425
    expect = np.stack([a1 * np.cos(q[:, 0]) + a2 * np.cos(q.sum(1)),
                       a1 * np.sin(q[:, 0]) + a2 * np.sin(q.sum(1))], axis=1)
    assert np.allclose(tips, expect, atol=1e-15)
    assert tips.flags.c_contiguous and tips.dtype == np.float64


def test_gil_is_released_for_long_work(adept):
    import threading
    import time

    sim = lincal.simulate(adept, 100_000, seed=1, noise_track=1e-5)
    ticks = []
    done = threading.Event()

    def tick():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.005)

    t = threading.Thread(target=tick)
    t.start()
    start = time.perf_counter()
    lincal.calibrate(adept, sim.q, refine=True)
    elapsed = time.perf_counter() - start
    done.set()
    t.join()
    during = [x for x in ticks if start <= x <= start + elapsed]
    if elapsed > 0.2:
        assert len(during) >= 5, (elapsed, len(during))


def test_stub_lists_every_public_name_and_each_has_a_docstring():
    stub = Path(__file__).resolve().parents[1] / "lincal.pyi"
    tree = ast.parse(stub.read_text())
    stubbed = {
        n.name for n in tree.body if isinstance(n, (ast.ClassDef, ast.FunctionDef))
    } | {
        t.id
        for n in tree.body
        if isinstance(n, (ast.Assign, ast.AnnAssign))
        for t in (n.targets if isinstance(n, ast.Assign) else [n.target])
        if isinstance(t, ast.Name)
    }
    public = {
        n
        for n in dir(lincal)
        if not n.startswith("_") and type(getattr(lincal, n)).__name__ != "module"
    }
    assert public <= stubbed, public - stubbed
    for name in public:
        obj = getattr(lincal, name)
        if callable(obj):
            assert obj.__doc__, name
        if isinstance(obj, type):
            for attr, member in vars(obj).items():
                if not attr.startswith("_") and not isinstance(member, (str, tuple, type(None))):
                    assert member.__doc__, f"{name}.{attr}"


def test_stub_matches_the_module():
    """mypy's stubtest: every signature of lincal.pyi is the runtime's (when mypy is there)."""
    import importlib.util
    import subprocess
    import sys

    if importlib.util.find_spec("mypy") is None:
        pytest.skip("mypy is not installed")
    here = Path(__file__).resolve().parent
    p = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "lincal", "--allowlist",
         str(here / "stubtest-allowlist.txt")],
        capture_output=True, text=True, timeout=300, cwd=here,
    )
    assert p.returncode == 0, p.stdout + p.stderr


SOCKETS = """name: sockets_planar3
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-3.0, 3.0]}
  - {type: revolute, a: a2, home: th2, limits: [-3.0, 3.0]}
  - {type: revolute, a: a3, home: th3, limits: [-3.0, 3.0]}
params:
  a1: {nominal: 0.4}
  th1: {nominal: 0.0}
  a2: {nominal: 0.3}
  th2: {nominal: 0.0}
  a3: {nominal: 0.2}
  th3: {nominal: 0.0}
  p0x: {nominal: 0.45}
  p0y: {nominal: 0.2}
  p1x: {nominal: 0.45}
  p1y: {nominal: 0.25}
constraints:
  - point: {p: [p0x, p0y]}
  - point: {p: [p1x, p1y]}
relations:
  - {distance: [0, 1], value: 0.05}
"""


def test_evaluate_held_out_placement(tmp_path, cli):
    spec = lincal.Spec.from_str(SOCKETS)
    arm = {"a1": 0.41, "th2": 0.02}
    train = lincal.simulate(spec, 40, seed=3, truth=arm)
    moved = dict(arm, p0x=0.30, p0y=0.20, p1x=0.33, p1y=0.24)
    held = lincal.simulate(spec, 40, seed=4, truth=moved)
    fit = lincal.calibrate(spec, train.q, constraint=train.constraint, refine=True)
    e = spec.evaluate(held.q, fit, constraint=held.constraint)
    assert e["poses"] == 40
    assert e["residual_rms"] < 1e-9
    assert e["residual_rms_nominal"] > 1e-4
    assert abs(e["point_pairs"][0]["distance"] - 0.05) < 1e-9
    assert [c["refitted"] for c in e["constraints"]] == [["p0x", "p0y"], ["p1x", "p1y"]]
    # The same figures as `lincal evaluate --format json`.
    (tmp_path / "spec.yaml").write_text(SOCKETS)
    (tmp_path / "result.json").write_text(fit.to_json())
    rows = "\n".join(
        ",".join(repr(float(v)) for v in q) + f",{c}" for q, c in zip(held.q, held.constraint)
    )
    (tmp_path / "held.csv").write_text("q1,q2,q3,constraint\n" + rows + "\n")
    code, out, err = cli("evaluate", tmp_path / "spec.yaml", "--params",
                         tmp_path / "result.json", tmp_path / "held.csv", "--format", "json")
    assert code == 0, err
    assert math.isclose(json.loads(out)["residual_rms_nominal"], e["residual_rms_nominal"],
                        rel_tol=1e-9)


def test_evaluate_names_poses_beyond_the_calibrated_joint_ranges(tmp_path, cli):
    spec = lincal.Spec.from_str(SOCKETS)
    arm = {"a1": 0.41, "th2": 0.02}
    train = lincal.simulate(spec, 40, seed=3, truth=arm)
    fit = lincal.calibrate(spec, train.q, constraint=train.constraint, refine=True)
    ranges = fit.to_dict()["joint_ranges"]
    assert [r["min"] for r in ranges] == [float(v) for v in train.q.min(axis=0)]
    assert [r["max"] for r in ranges] == [float(v) for v in train.q.max(axis=0)]
    # The training poses are inside; one pose turned 0.2 rad beyond on joint 3 is not.
    inside = spec.evaluate(train.q, fit, constraint=train.constraint)
    assert inside["beyond_ranges"]["poses"] == 0
    q = train.q.copy()
    q[5, 2] = ranges[2]["max"] + 0.2
    out = spec.evaluate(q, fit, constraint=train.constraint)
    b = out["beyond_ranges"]
    assert (b["poses"], b["of"], b["farthest"]["pose"], b["farthest"]["joint"]) == (1, 40, 5, 3)
    # The nominals judge no extrapolation: no ranges to judge by.
    assert "beyond_ranges" not in spec.evaluate(q, None, constraint=train.constraint)
    # As `lincal evaluate --format json` says it.
    (tmp_path / "spec.yaml").write_text(SOCKETS)
    (tmp_path / "result.json").write_text(fit.to_json())
    rows = "\n".join(
        ",".join(repr(float(v)) for v in row) + f",{c}" for row, c in zip(q, train.constraint)
    )
    (tmp_path / "held.csv").write_text("q1,q2,q3,constraint\n" + rows + "\n")
    code, out_text, err = cli("evaluate", tmp_path / "spec.yaml", "--params",
                              tmp_path / "result.json", tmp_path / "held.csv", "--format", "json")
    assert code == 0, err
    cli_b = json.loads(out_text)["beyond_ranges"]
    assert (cli_b["poses"], cli_b["of"]) == (b["poses"], b["of"])
    assert {k: v for k, v in cli_b["farthest"].items() if k != "line"} == \
        {k: v for k, v in b["farthest"].items() if k != "line"}
    assert cli_b["farthest"]["line"] == 7
    assert "1 of 40 poses have a joint beyond the range" in err

"""Full-pose measurements (`measured_pose`, issue 26): the measured orientation in and out of
the Python API as quaternions (scalar first) or rotation vectors, recovery from exact and noisy
data, the refusals, and the command line's very numbers."""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest

import lincal
from conftest import MODELS, SPECS

PUMA = MODELS / "puma560_pose_tracker.yaml"
# Noise of the model's spec (stated there): 20 um per coordinate, 50 urad per axis.
SIGMA_P, SIGMA_O = 2e-5, 5e-5


@pytest.fixture(scope="module")
def puma():
    return lincal.Spec.from_yaml(PUMA)


@pytest.fixture(scope="module")
def puma_unstated():
    """The same arm, the noise levels left to the data (variance components)."""
    text = PUMA.read_text()
    stated = "  measured_pose: {position_std: 2.0e-5, orientation_std: 5.0e-5}\n"
    assert stated in text
    return lincal.Spec.from_str(text.replace("constraint:\n" + stated, "constraint: measured_pose\n"))


# -- rotations in numpy, independent of lincal ---------------------------------------------


def quat_to_rotvec(quat: np.ndarray) -> np.ndarray:
    """Rotation vectors (axis times angle) of unit quaternions, scalar first."""
    w = quat[:, :1]
    v = quat[:, 1:]
    s = np.linalg.norm(v, axis=1, keepdims=True)
    angle = 2.0 * np.arctan2(s, w)
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(s > 1e-12, angle / np.where(s > 0, s, 1.0), 2.0 / w)
    return k * v


def quat_to_matrix(quat: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotation matrices of unit quaternions, scalar first."""
    w, x, y, z = (quat / np.linalg.norm(quat, axis=1, keepdims=True)).T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )


def quat_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The angle (radians) of the rotation between unit quaternions a and b, row by row,
    accurate for tiny angles (2·asin of half the chord, the sign of q taken into account)."""
    chord = np.minimum(np.linalg.norm(a - b, axis=1), np.linalg.norm(a + b, axis=1))
    return 4.0 * np.arcsin(np.minimum(chord / 2.0, 1.0))


def orientation_form(sim, form: str) -> dict:
    """The calibrate keyword of the simulated orientation in `form`."""
    if form == "quaternion":
        return {"quaternion": sim.quaternion}
    return {"rotvec": quat_to_rotvec(sim.quaternion)}


def wrap(d: float) -> float:
    return math.remainder(d, 2 * math.pi)


def write_csv(path, q, x, quat=None, rotvec=None):
    n = q.shape[1]
    cols = [f"q{i + 1}" for i in range(n)] + ["x", "y", "z"]
    blocks = [q, x]
    if quat is not None:
        cols += ["qw", "qx", "qy", "qz"]
        blocks.append(quat)
    if rotvec is not None:
        cols += ["rx", "ry", "rz"]
        blocks.append(rotvec)
    rows = np.hstack(blocks)
    with open(path, "w") as f:
        f.write(",".join(cols) + "\n")
        for r in rows:
            f.write(",".join(repr(float(v)) for v in r) + "\n")


# -- the spec and the simulation ----------------------------------------------------------


def test_spec_says_measured_pose(puma):
    assert puma.constraints == ["measured_pose"]
    assert puma.measured and puma.measured_pose
    adept = lincal.Spec.from_yaml(MODELS / "adept_one.yaml")
    assert not adept.measured_pose
    measured = lincal.Spec.from_yaml(SPECS / "measured_spatial.yaml")
    assert measured.measured and not measured.measured_pose


def test_simulation_gives_positions_and_unit_quaternions(puma):
    sim = lincal.simulate(puma, 50, seed=4, noise_measure=SIGMA_P, noise_orientation=SIGMA_O)
    assert sim.x.shape == (50, 3)
    assert sim.quaternion.shape == (50, 4)
    assert np.allclose(np.linalg.norm(sim.quaternion, axis=1), 1.0, atol=1e-14)
    assert np.all(sim.quaternion[:, 0] >= 0)
    assert sim.data().keys() == {"q", "x", "quaternion"}
    assert "quaternion=(N, 4)" in repr(sim)
    # The measured poses are the true ones with noise of the stated size.
    x, quat = puma.tool_pose(sim.q, sim.truth)
    dx = sim.x - x
    assert np.sqrt(np.mean(dx**2)) == pytest.approx(SIGMA_P, rel=0.3)
    angles = quat_angle(sim.quaternion, quat)
    assert np.sqrt(np.mean(angles**2)) == pytest.approx(SIGMA_O * math.sqrt(3), rel=0.3)
    # Other specs have no orientation.
    measured = lincal.Spec.from_yaml(SPECS / "measured_spatial.yaml")
    assert lincal.simulate(measured, 5, seed=1).quaternion is None
    with pytest.warns(UserWarning, match="noise_orientation"):
        lincal.simulate(measured, 5, seed=1, noise_orientation=1e-4)


def test_simulate_is_the_clis(puma, cli):
    code, out, err = cli("simulate", PUMA, "--poses", 30, "--seed", 8, "--noise-measure",
                         "2e-5", "--noise-orientation", "5e-5", "--noise-encoder", "1e-6")
    assert code == 0, err
    header = out.splitlines()[0].split(",")
    assert header[6:] == ["x", "y", "z", "qw", "qx", "qy", "qz"]
    data = np.loadtxt(io.StringIO(out), delimiter=",", skiprows=1)
    sim = lincal.simulate(puma, 30, seed=8, noise_measure=2e-5, noise_orientation=5e-5,
                          noise_encoder=1e-6)
    assert np.array_equal(sim.q, data[:, :6])
    assert np.array_equal(sim.x, data[:, 6:9])
    assert np.array_equal(sim.quaternion, data[:, 9:13])


def test_tool_pose(puma):
    sim = lincal.simulate(puma, 20, seed=5)
    x, quat = puma.tool_pose(sim.q, sim.truth)
    assert x.shape == (20, 3) and quat.shape == (20, 4)
    # Its position is the tip; exact data are the truth's pose.
    assert np.allclose(x, puma.tip(sim.q, sim.truth), rtol=0, atol=1e-14)
    assert np.allclose(x, sim.x, rtol=0, atol=1e-12)
    assert np.all(quat_angle(quat, sim.quaternion) < 1e-12)
    planar = lincal.Spec.from_yaml(MODELS / "adept_one.yaml")
    with pytest.raises(lincal.InputError, match="tool frame"):
        planar.tool_pose(np.zeros((2, 2)))


# -- recovery -----------------------------------------------------------------------------


@pytest.mark.parametrize("form", ["quaternion", "rotvec"])
def test_exact_data_recover_the_truth(puma, form):
    sim = lincal.simulate(puma, 60, seed=3)
    cal = lincal.calibrate(puma, sim.q, x=sim.x, **orientation_form(sim, form))
    assert cal.residual_rms < 1e-12
    assert cal.orientation_rms is not None and cal.orientation_rms < 1e-12
    assert cal.pose_noise == {
        "position_std": SIGMA_P,
        "orientation_std": SIGMA_O,
        "weight": pytest.approx(SIGMA_P / SIGMA_O, rel=1e-15),
        "held_ratio": None,
        "estimated": [],
        "rounds": 0,
    }
    # Every identifiable combination: the tool poses at fresh readings are the truth's.
    fresh = lincal.simulate(puma, 500, seed=11, truth=sim.truth).q
    x, quat = puma.tool_pose(fresh, cal)
    x0, quat0 = puma.tool_pose(fresh, sim.truth)
    assert np.max(np.abs(x - x0)) < 1e-9
    assert np.max(quat_angle(quat, quat0)) < 1e-9
    # The parameters identifiable on their own are the truth's.
    truth = sim.truth
    identifiable = [k for k, v in cal.params.items() if v["identifiable"]]
    assert len(identifiable) >= 15
    for k in identifiable:
        d = wrap(cal.params[k]["value"] - truth[k])
        assert abs(d) < 1e-9, (k, cal.params[k]["value"], truth[k])


def test_both_encodings_give_the_same_fit(puma):
    sim = lincal.simulate(puma, 80, seed=6, noise_measure=SIGMA_P, noise_orientation=SIGMA_O)
    a = lincal.calibrate(puma, sim.q, x=sim.x, quaternion=sim.quaternion)
    b = lincal.calibrate(puma, sim.q, x=sim.x, rotvec=quat_to_rotvec(sim.quaternion))
    for k, v in a.values.items():
        assert b.values[k] == pytest.approx(v, rel=0, abs=1e-10), k
    assert b.orientation_rms == pytest.approx(a.orientation_rms, rel=1e-8)
    assert b.residual_rms == pytest.approx(a.residual_rms, rel=1e-8)


def test_noisy_data_residuals_near_the_noise(puma):
    n = 200
    sim = lincal.simulate(puma, n, seed=21, noise_measure=SIGMA_P, noise_orientation=SIGMA_O)
    # The truth is checked: a fixed prior of the simulated perturbation's size (the default
    # is relative to the data and keeps its pull on 1-2 % truths; docs/03-calibrating.md, The prior).
    cal = lincal.calibrate(puma, **sim.data(), tolerance_length=0.01, tolerance_angle=0.01)
    # 3 components each, less the share of the 30 identifiable combinations.
    shrink = math.sqrt((6 * n - cal.identifiable_count) / (6 * n))
    assert cal.residual_rms == pytest.approx(SIGMA_P * math.sqrt(3) * shrink, rel=0.15)
    assert cal.orientation_rms == pytest.approx(SIGMA_O * math.sqrt(3) * shrink, rel=0.15)
    # The per-pose arrays are what the RMS sum.
    assert cal.residuals.shape == cal.orientation_residuals.shape == (n,)
    assert not cal.orientation_residuals.flags.writeable
    rms = float(np.sqrt(np.mean(cal.residuals**2)))
    assert rms == pytest.approx(cal.residual_rms, rel=1e-12)
    orms = float(np.sqrt(np.mean(cal.orientation_residuals**2)))
    assert orms == pytest.approx(cal.orientation_rms, rel=1e-12)
    assert "orientation_rms=" in repr(cal)
    # Through the spec: the same position errors.
    r = puma.residuals(sim.q, cal, x=sim.x, quaternion=sim.quaternion)
    assert np.allclose(r, cal.residuals, rtol=0, atol=1e-15)
    # The tool poses at fresh readings: errors of the noise's order, far below the nominal's.
    fresh = lincal.simulate(puma, 300, seed=12, truth=sim.truth).q
    x, quat = puma.tool_pose(fresh, cal)
    x0, quat0 = puma.tool_pose(fresh, sim.truth)
    xn, quatn = puma.tool_pose(fresh)
    err = np.linalg.norm(x - x0, axis=1).max()
    assert err < 10 * SIGMA_P < np.linalg.norm(xn - x0, axis=1).max()
    assert quat_angle(quat, quat0).max() < 10 * SIGMA_O < quat_angle(quatn, quat0).max()
    # The identifiable parameters within 4 standard deviations of the truth.
    for k, v in cal.params.items():
        if v["identifiable"] and v["std"]:
            d = v["value"] - sim.truth[k]
            assert abs(wrap(d)) <= 4 * v["std"], (k, d, v["std"])


@pytest.mark.parametrize("form", ["quaternion", "rotvec"])
def test_noise_levels_estimated_when_not_stated(puma_unstated, form):
    n = 250
    sim = lincal.simulate(puma_unstated, n, seed=31, noise_measure=SIGMA_P,
                          noise_orientation=SIGMA_O)
    cal = lincal.calibrate(puma_unstated, sim.q, x=sim.x, **orientation_form(sim, form))
    noise = cal.pose_noise
    assert noise["estimated"] == ["position", "orientation"]
    assert noise["rounds"] >= 1
    assert noise["position_std"] == pytest.approx(SIGMA_P, rel=0.1)
    assert noise["orientation_std"] == pytest.approx(SIGMA_O, rel=0.1)
    assert noise["weight"] == pytest.approx(noise["position_std"] / noise["orientation_std"],
                                            rel=2e-3)
    shrink = math.sqrt((6 * n - cal.identifiable_count) / (6 * n))
    assert cal.orientation_rms == pytest.approx(SIGMA_O * math.sqrt(3) * shrink, rel=0.15)


def test_other_specs_have_no_orientation(puma):
    adept = lincal.Spec.from_yaml(MODELS / "adept_one.yaml")
    sim = lincal.simulate(adept, 40, seed=2)
    cal = lincal.calibrate(adept, sim.q)
    assert cal.orientation_rms is None
    assert cal.orientation_residuals is None
    assert cal.pose_noise is None
    assert "orientation_rms" not in cal.to_dict()


# -- refusals -----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def exact(puma):
    return lincal.simulate(puma, 40, seed=13)


def test_non_unit_quaternion_refused_naming_row(puma, exact):
    quat = exact.quaternion.copy()
    quat[7] *= 1.01
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(puma, exact.q, x=exact.x, quaternion=quat)
    assert isinstance(e.value, lincal.InputError)
    assert (e.value.field, e.value.pose) == ("quaternion", 7)
    assert "quaternion[7]" in str(e.value) and "norm" in str(e.value)
    # Within the tolerance (1e-3): normalised, the same fit.
    quat = exact.quaternion * (1 + 5e-4)
    a = lincal.calibrate(puma, exact.q, x=exact.x, quaternion=quat)
    b = lincal.calibrate(puma, exact.q, x=exact.x, quaternion=exact.quaternion)
    for k, v in a.values.items():
        assert b.values[k] == pytest.approx(v, rel=0, abs=1e-12)
    # A zero quaternion is not a rotation.
    quat = exact.quaternion.copy()
    quat[0] = 0
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(puma, exact.q, x=exact.x, quaternion=quat)
    assert (e.value.field, e.value.pose) == ("quaternion", 0)


@pytest.mark.parametrize("form, column, name", [("quaternion", 2, "qy"), ("rotvec", 0, "rx")])
def test_nan_orientation_refused_naming_row_and_column(puma, exact, form, column, name):
    value = orientation_form(exact, form)[form].copy()
    value[5, column] = np.nan
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(puma, exact.q, x=exact.x, **{form: value})
    assert (e.value.field, e.value.pose) == (name, 5)
    assert f"`{form}[5, {column}]`" in str(e.value)
    value[5, column] = np.inf
    with pytest.raises(lincal.DataError):
        lincal.calibrate(puma, exact.q, x=exact.x, **{form: value})


def test_orientation_forms_refused(puma, exact):
    q, x, quat = exact.q, exact.x, exact.quaternion
    rotvec = quat_to_rotvec(quat)
    # Both forms at once.
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(puma, q, x=x, quaternion=quat, rotvec=rotvec)
    assert e.value.field == "rotvec" and "quaternion" in str(e.value)
    # Neither.
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(puma, q, x=x)
    assert e.value.field == "quaternion" and "rotvec" in str(e.value)
    # No x.
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(puma, q, quaternion=quat)
    assert e.value.field == "x"
    # Wrong shapes: columns, rows, dimensions.
    for kw, bad in [
        ("quaternion", quat[:, :3]),
        ("quaternion", np.hstack([quat, quat[:, :1]])),
        ("quaternion", quat[:-1]),
        ("quaternion", quat[0]),
        ("rotvec", quat),
        ("rotvec", rotvec[:-2]),
    ]:
        with pytest.raises(lincal.DataError) as e:
            lincal.calibrate(puma, q, x=x, **{kw: bad})
        assert e.value.field == kw and f"`{kw}`" in str(e.value), (kw, bad.shape)
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(puma, q, x=x, quaternion=quat.astype(str))
    assert e.value.field == "quaternion"
    # An orientation for a spec without measured poses.
    measured = lincal.Spec.from_yaml(SPECS / "measured_spatial.yaml")
    sim = lincal.simulate(measured, 30, seed=2)
    for kw in ("quaternion", "rotvec"):
        with pytest.raises(lincal.DataError) as e:
            lincal.calibrate(measured, sim.q, x=sim.x, **{kw: np.zeros((30, 4 if kw == "quaternion" else 3))})
        assert e.value.field == kw and "measured_pose" in str(e.value)
    # The spec's own methods refuse the same.
    with pytest.raises(lincal.DataError):
        puma.residuals(q, x=x, quaternion=quat, rotvec=rotvec)
    with pytest.raises(lincal.DataError):
        puma.evaluate(q, x=x)


# -- the command line ---------------------------------------------------------------------


def assert_same_json(py: dict, cli: dict, tol: float = 1e-9):
    """The same fields and, number by number, the same values within tol (relative for
    large values), statistics of the fit to 1e-6 relative. A parameter's value may also
    differ by 1e-4 of its std: inputs rounded once more move where the fit stops (its cost
    test, 1e-12 relative, leaves a parameter free to about 1e-6·√m of its std), most along
    the weakest directions."""
    assert py.keys() == cli.keys()

    def same(a, b, path):
        if isinstance(a, dict) and isinstance(b, dict) and {"value", "std"} <= b.keys():
            assert a.keys() == b.keys(), path
            std = b["std"]
            if std is not None and a["value"] is not None and b["value"] is not None:
                slack = max(tol * max(1.0, abs(b["value"])), 1e-4 * std)
                assert abs(a["value"] - b["value"]) <= slack, (f"{path}.value", a["value"], b["value"], std)
                for k in a:
                    if k != "value":
                        same(a[k], b[k], f"{path}.{k}")
                return
        if isinstance(a, dict):
            assert isinstance(b, dict) and a.keys() == b.keys(), path
            for k in a:
                same(a[k], b[k], f"{path}.{k}")
        elif isinstance(a, list):
            assert isinstance(b, list) and len(a) == len(b), path
            for i, (u, v) in enumerate(zip(a, b)):
                same(u, v, f"{path}[{i}]")
        elif a is None or b is None:
            assert a is None and b is None, (path, a, b)
        elif isinstance(a, float) or isinstance(b, float):
            # Statistics of the end point (condition, standardized residuals) follow it to
            # 1e-6 relative.
            slack = max(tol * max(1.0, abs(b)), 1e-6 * abs(b))
            assert b is not None and abs(a - b) <= slack, (path, a, b)
        else:
            assert a == b, (path, a, b)

    same(py, cli, "")


@pytest.mark.parametrize("form", ["quaternion", "rotvec"])
def test_calibrate_is_the_clis(puma, cli, cli_json, tmp_path, form):
    sim = lincal.simulate(puma, 120, seed=17, noise_measure=SIGMA_P, noise_orientation=SIGMA_O)
    path = tmp_path / f"{form}.csv"
    if form == "quaternion":
        write_csv(path, sim.q, sim.x, quat=sim.quaternion)
    else:
        write_csv(path, sim.q, sim.x, rotvec=quat_to_rotvec(sim.quaternion))
    expected, out = cli_json("calibrate", PUMA, path, "--format", "json")
    assert "orientation_rms" in expected and "pose_noise" in expected
    # Read by the CLI's reader.
    d = puma.read_csv(path)
    assert d.keys() == {"q", "x", "quaternion", "constraint", "lines"}
    assert d["x"].shape == (120, 3) and d["quaternion"].shape == (120, 4)
    cal = lincal.calibrate(puma, **d)
    # Its quaternions are the file's rotations, rounded once more (1e-16): the fit stops a
    # hair away, so the values agree to 1e-9, the condition number (cond ~ 1e4) to 1e-6.
    got = cal.to_dict()
    assert got["condition"] == pytest.approx(expected["condition"], rel=1e-6)
    got["condition"] = expected["condition"]
    assert_same_json(got, expected)
    assert cal.orientation_rms == pytest.approx(expected["orientation_rms"], rel=1e-9)
    assert cal.pose_noise == expected["pose_noise"]
    # Read by numpy: the same numbers.
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    orientation = {"quaternion": table[:, 9:13]} if form == "quaternion" else {"rotvec": table[:, 9:12]}
    cal2 = lincal.calibrate(puma, table[:, :6], x=table[:, 6:9],
                            lines=np.arange(2, 122), **orientation)
    # The same rotations as the CLI's reader makes: the very JSON.
    assert cal2.to_dict() == expected
    assert cal2.to_json() + "\n" == out
    # `lincal predict` prints the tool pose Spec.tool_pose gives.
    result = tmp_path / "result.json"
    result.write_text(out)
    code, printed, err = cli("predict", PUMA, "--params", result, path)
    assert code == 0, err
    lines = printed.splitlines()
    assert lines[0] == "x,y,z,qw,qx,qy,qz"
    predicted = np.loadtxt(io.StringIO(printed), delimiter=",", skiprows=1)
    x, quat = puma.tool_pose(table[:, :6], cal2)
    assert np.allclose(predicted[:, :3], x, rtol=0, atol=1e-9)
    assert np.max(quat_angle(predicted[:, 3:], quat)) < 1e-9


def test_unstated_noise_is_the_clis(puma_unstated, cli_json, tmp_path):
    sim = lincal.simulate(puma_unstated, 100, seed=19, noise_measure=SIGMA_P,
                          noise_orientation=SIGMA_O)
    spec_path = tmp_path / "spec.yaml"
    text = PUMA.read_text().replace(
        "constraint:\n  measured_pose: {position_std: 2.0e-5, orientation_std: 5.0e-5}\n",
        "constraint: measured_pose\n")
    spec_path.write_text(text)
    path = tmp_path / "data.csv"
    write_csv(path, sim.q, sim.x, quat=sim.quaternion)
    expected, _ = cli_json("calibrate", spec_path, path, "--format", "json")
    assert expected["pose_noise"]["estimated"] == ["position", "orientation"]
    cal = lincal.calibrate(puma_unstated, **puma_unstated.read_csv(path))
    assert_same_json(cal.to_dict(), expected)


def test_read_csv_of_rotation_vectors(puma, tmp_path):
    sim = lincal.simulate(puma, 10, seed=23)
    path = tmp_path / "rv.csv"
    write_csv(path, sim.q, sim.x, rotvec=quat_to_rotvec(sim.quaternion))
    d = puma.read_csv(path)
    assert np.array_equal(d["x"], sim.x)
    assert np.max(quat_angle(d["quaternion"], sim.quaternion)) < 1e-14
    assert np.all(d["quaternion"][:, 0] >= 0)
    # A file holding both forms is refused, as by the CLI.
    both = tmp_path / "both.csv"
    write_csv(both, sim.q, sim.x, quat=sim.quaternion, rotvec=quat_to_rotvec(sim.quaternion))
    with pytest.raises(lincal.DataError, match="both"):
        puma.read_csv(both)


def rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def test_rotations_match_numpy(puma):
    # The quaternion convention (scalar first; the rotation's columns are the tool frame's
    # axes in the world) checked against independent formulas.
    sim = lincal.simulate(puma, 5, seed=29)
    level = dict(sim.truth, troll=0.0, tpitch=0.0, tyaw=0.0)
    _, quat = puma.tool_pose(sim.q, level)
    r0 = quat_to_matrix(quat)
    assert np.allclose(np.einsum("nij,nkj->nik", r0, r0), np.eye(3), atol=1e-14)
    # Without tool angles the tool's axes are the last link's: the tool offset moves the tip
    # along them.
    base = puma.tip(sim.q, level)
    for c, name in enumerate(["tx", "ty", "tz"]):
        moved = puma.tip(sim.q, dict(level, **{name: level[name] + 1e-3}))
        assert np.allclose((moved - base) / 1e-3, r0[:, :, c], rtol=0, atol=1e-9), name
    # The tool angles turn the tool frame by Rz(yaw)·Ry(pitch)·Rx(roll), in the link's frame.
    roll, pitch, yaw = 0.3, -0.2, 1.1
    _, quat = puma.tool_pose(sim.q, dict(level, troll=roll, tpitch=pitch, tyaw=yaw))
    r1 = quat_to_matrix(quat)
    turn = np.einsum("nji,njk->nik", r0, r1)
    assert np.allclose(turn, rz(yaw) @ ry(pitch) @ rx(roll), rtol=0, atol=1e-12)

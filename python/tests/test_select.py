"""lincal.select: the poses worth measuring, as `lincal select` chooses them."""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest

import lincal
from conftest import MODELS, SPECS


@pytest.fixture(scope="module")
def planar():
    return lincal.Spec.from_yaml(SPECS / "point_planar3.yaml")


@pytest.fixture(scope="module")
def adept():
    return lincal.Spec.from_yaml(MODELS / "adept_one.yaml")


def read_csv(text: str) -> np.ndarray:
    """The readings of `lincal simulate`'s CSV (header first)."""
    return np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, ndmin=2)


def test_indices_are_distinct_candidates_and_the_figures_are_the_clis(planar):
    sim = lincal.simulate(planar, 200, seed=7)
    sel = lincal.select(planar, 12, candidates=sim.q)
    idx = sel.indices
    assert idx.shape == (12,) and idx.dtype == np.int64
    assert len(set(idx.tolist())) == 12
    assert 0 <= idx.min() and idx.max() < 200
    np.testing.assert_array_equal(sel.q, sim.q[idx])
    assert sel.constraint is None
    assert sel.held == ["a1", "th1"]
    assert set(sel.params) == {"a2", "th2", "a3", "th3", "px", "py"}
    for v in sel.params.values():
        assert 0 < v["std"] < math.inf and 0 < v["random_std"] < math.inf
    assert sel.tip_rms <= sel.random_tip_rms
    assert sel.log_det >= sel.random_log_det
    assert sel.worth >= 12 and 0 < sel.efficiency_bound <= 1 and sel.condition >= 1
    assert sel.sigma == {"constraint": 1e-5, "measured": 1e-5, "orientation": 0.0, "encoder": 0.0}
    d = sel.to_dict()
    assert json.loads(sel.to_json()) == d
    assert [c["candidate"] for c in d["chosen"]] == idx.tolist()
    assert any("held by the gauge" in n for n in sel.notes)
    assert "lincal select: 12 poses of a pool of 200" in sel.summary()
    assert "Selection(poses=12" in repr(sel)


def free_jacobian(spec, q, names, nominal):
    """Rows ∂r/∂p over `names` of the AdeptOne's line residual r = (b·x + 1)/‖b‖, by central
    differences of the tips `spec.tip` gives: independent of lincal's own Jacobians."""

    def residual(p):
        x = spec.tip(q, p)
        b = np.array([p["b1"], p["b2"]])
        return (x @ b + 1.0) / np.linalg.norm(b)

    cols = []
    for name in names:
        h = 1e-6 * max(abs(nominal[name]), 1.0)
        up, down = dict(nominal), dict(nominal)
        up[name] += h
        down[name] -= h
        cols.append((residual(up) - residual(down)) / (2 * h))
    return np.column_stack(cols)


def test_the_chosen_set_has_more_information_than_random_sets(adept):
    # At the nominals alone (draws=0) the criterion is log det(JᵀJ) of the chosen rows,
    # which numpy computes here from the tips: it beats the median of random sets.
    sim = lincal.simulate(adept, 300, seed=2, truth=adept.nominal)
    n = 8
    sel = lincal.select(adept, n, candidates=sim.q, draws=0)
    names = list(sel.params)
    jac = free_jacobian(adept, sim.q, names, dict(adept.nominal))

    def logdet(rows):
        sign, value = np.linalg.slogdet(jac[rows].T @ jac[rows])
        return value if sign > 0 else -math.inf

    chosen = logdet(sel.indices)
    rng = np.random.default_rng(5)
    random = [logdet(rng.choice(300, n, replace=False)) for _ in range(31)]
    assert chosen >= np.median(random), (chosen, np.median(random))
    assert chosen >= max(random) - 1e-6, (chosen, max(random))


def test_given_and_pool_agree_with_the_command_line(planar, cli, cli_json, tmp_path):
    spec = SPECS / "point_planar3.yaml"
    _, pool_csv, _ = cli("simulate", spec, "--poses", "300", "--seed", "3")
    _, done_csv, _ = cli("simulate", spec, "--poses", "40", "--seed", "4")
    (tmp_path / "pool.csv").write_text(pool_csv)
    (tmp_path / "done.csv").write_text(done_csv)
    pool, done = read_csv(pool_csv), read_csv(done_csv)
    for extra, kwargs in [
        ([], {}),
        (["--given", tmp_path / "done.csv"], {"given": done}),
        (["--criterion", "tip", "--noise-encoder", "1e-4"], {"criterion": "tip", "noise_encoder": 1e-4}),
        (["--prior", "params", "--tolerance-length", "0.02"], {"prior": "params", "tolerance_length": 0.02}),
        (["--prior", "off"], {"prior": "off"}),
    ]:
        expect, _ = cli_json(
            "select", spec, "-n", "2" if extra[:1] == ["--given"] else "10",
            "--candidates", tmp_path / "pool.csv", "--format", "json", *extra,
        )
        sel = lincal.select(planar, expect["count"], candidates=pool, **kwargs)
        got = sel.to_dict()
        assert [c["candidate"] for c in got["chosen"]] == [c["candidate"] for c in expect["chosen"]]
        for a, b in zip(got["params"], expect["params"]):
            assert a["name"] == b["name"]
            assert a["std"] == pytest.approx(b["std"], rel=1e-9)
        for key in ["tip_rms", "random_tip_rms", "log_det", "random_log_det"]:
            assert got[key] == pytest.approx(expect[key], rel=1e-9), key
        assert got["sigma"] == expect["sigma"] and got["notes"] == expect["notes"]
        assert got["prior"] == expect["prior"] and sel.prior == got["prior"]
    # Two poses alone cannot see the free parameters; with the forty given they can.
    with pytest.raises(lincal.DegenerateError, match="unseen"):
        lincal.select(planar, 2, candidates=pool)
    # A generated pool: the same poses as the command line's.
    expect, _ = cli_json("select", spec, "-n", "10", "--pool", "300", "--seed", "9", "--format", "json")
    sel = lincal.select(planar, 10, pool=300, seed=9)
    assert sel.indices.tolist() == [c["candidate"] for c in expect["chosen"]]
    np.testing.assert_allclose(sel.q, [c["q"] for c in expect["chosen"]], rtol=0, atol=0)


def test_encoder_noise_alone_scales_every_std(planar):
    sim = lincal.simulate(planar, 300, seed=3)
    one = lincal.select(planar, 10, candidates=sim.q, noise_track=1e-12, noise_encoder=1e-4)
    two = lincal.select(planar, 10, candidates=sim.q, noise_track=1e-12, noise_encoder=2e-4)
    assert one.sigma["encoder"] == 1e-4
    assert one.indices.tolist() == two.indices.tolist()
    for name, v in one.params.items():
        assert two.params[name]["std"] == pytest.approx(2 * v["std"], rel=1e-6)


def test_bad_arguments_are_refused_by_name(planar, adept):
    sim = lincal.simulate(planar, 50, seed=7)
    q = sim.q

    def refused(cls, field, **kwargs):
        args = {"candidates": q, **kwargs}
        n = args.pop("n", 5)
        with pytest.raises(cls) as e:
            lincal.select(planar, n, **{k: v for k, v in args.items() if v is not None})
        assert isinstance(e.value, ValueError)
        assert e.value.field == field, (e.value.field, str(e.value))
        assert field in str(e.value)
        return e.value

    refused(lincal.InputError, "n", n=0)
    assert "51 poses asked from a pool of 50" in str(refused(lincal.InputError, "n", n=51))
    refused(lincal.InputError, "pool", pool=100)
    refused(lincal.InputError, "candidates", candidates=None)
    refused(lincal.InputError, "pool", candidates=None, pool=0)
    refused(lincal.InputError, "criterion", criterion="e")
    refused(lincal.InputError, "draws", draws=-1)
    for bad in [-1e-3, math.nan, math.inf]:
        refused(lincal.InputError, "noise_encoder", noise_encoder=bad)
    refused(lincal.InputError, "noise_track", noise_track=-1.0)
    refused(lincal.InputError, "max_off", max_off=0.0)
    refused(lincal.DataError, "candidates", candidates=q[:, :2])
    refused(lincal.DataError, "constraint", constraint=np.zeros(50, dtype=np.int64))
    refused(lincal.InputError, "given_constraint", given_constraint=np.zeros(3, dtype=np.int64))
    with pytest.raises(lincal.DataError, match="given"):
        lincal.select(planar, 5, candidates=q, given=np.full((3, 3), np.nan))
    with pytest.raises(lincal.DegenerateError, match="stay unseen"):
        lincal.select(planar, 2, candidates=q)


def test_repeated_candidates_are_blamed_not_n(planar):
    """A pool of one pose repeated: the candidates are named, never `n`, which cannot help."""
    q = lincal.simulate(planar, 5, seed=7).q
    pool = np.repeat(q[:2], 20, axis=0)
    with pytest.raises(lincal.DegenerateError) as e:
        lincal.select(planar, 10, candidates=pool)
    msg = str(e.value)
    assert "too few distinct poses" in msg and "only 2 distinct" in msg, msg
    assert "near-duplicates" in msg and "ask for more poses" not in msg, msg
    assert "-n" not in msg and "(n)" in msg, msg

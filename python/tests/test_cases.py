"""The shared reference cases through Python: the reference answers, and the very numbers the
command line prints."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import lincal
from conftest import case_names, cases_dir

CASES = case_names()
pytestmark = pytest.mark.skipif(not CASES, reason=f"no reference cases in {cases_dir()}")


def evaluate(expr: str, values: dict[str, float]) -> float:
    """An `expected.json` check expression over parameter values."""
    env = {
        "atan2": math.atan2,
        "hypot": math.hypot,
        "sqrt": math.sqrt,
        "sin": math.sin,
        "cos": math.cos,
        "abs": abs,
        "pi": math.pi,
    }
    env.update(values)
    return float(eval(expr, {"__builtins__": {}}, env))  # noqa: S307 (trusted test data)


def wrap(d: float) -> float:
    """An angle difference in (-pi, pi]."""
    w = math.remainder(d, 2 * math.pi)
    return math.pi if w == -math.pi else w


def load(name: str):
    d = cases_dir() / name
    return d, lincal.Spec.from_yaml(d / "spec.yaml"), json.loads((d / "expected.json").read_text())


@pytest.mark.parametrize("name", CASES)
def test_basis_matches_expected(name):
    _, spec, expected = load(name)
    b = spec.basis()
    assert b.basis_size == expected["basis_size"]
    assert b.identifiable_count == expected["identifiable_count"]
    assert len(b.basis) == b.basis_size


@pytest.mark.parametrize("refine", [False, True])
@pytest.mark.parametrize("name", CASES)
def test_checks_within_tolerance_from_numpy_arrays(name, refine):
    d, spec, expected = load(name)
    q = np.loadtxt(d / "data.csv", delimiter=",", skiprows=1, comments="#", ndmin=2)
    cal = lincal.calibrate(spec, q, refine=refine)
    assert cal.basis_size == expected["basis_size"]
    assert cal.identifiable_count == expected["identifiable_count"]
    assert cal.method == ("linear+refine" if refine else "linear")
    assert cal.residuals.shape == (q.shape[0],)
    values = cal.values
    for check in expected["checks"]:
        got = evaluate(check["expr"], values)
        diff = got - check["true"]
        if check["unit"] == "rad":
            diff = wrap(diff)
        assert abs(diff) <= check["tolerance"], (check["name"], got, check["true"])


@pytest.mark.parametrize("refine", [False, True])
@pytest.mark.parametrize("name", CASES)
def test_calibrate_json_is_the_clis(name, refine, cli):
    d, spec, _ = load(name)
    args = ["calibrate", d / "spec.yaml", d / "data.csv", "--format", "json"]
    if refine:
        args.append("--refine")
    code, out, err = cli(*args)
    assert code == 0, err
    # Read with the CLI's own CSV reader: the same rows and CSV lines.
    data = spec.read_csv(d / "data.csv")
    cal = lincal.calibrate(spec, data["q"], lines=data["lines"], refine=refine)
    assert cal.to_dict() == json.loads(out)
    assert cal.to_json() + "\n" == out
    # Read with numpy: the same numbers (both parsers round correctly), lines given.
    q = np.loadtxt(d / "data.csv", delimiter=",", skiprows=1, ndmin=2)
    assert np.array_equal(q, data["q"])
    cal2 = lincal.calibrate(spec, q, lines=np.arange(2, q.shape[0] + 2), refine=refine)
    assert cal2.to_dict() == json.loads(out)
    # The residuals are the rms the JSON reports.
    rms = float(np.sqrt(np.mean(cal.residuals**2)))
    assert rms == pytest.approx(json.loads(out)["residual_rms"], rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("name", CASES)
def test_basis_json_is_the_clis(name, cli):
    d, spec, _ = load(name)
    code, out, err = cli("basis", d / "spec.yaml", "--format", "json")
    assert code == 0, err
    b = spec.basis()
    assert b.to_dict() == json.loads(out)
    assert b.to_json() + "\n" == out
    cli_json = json.loads(out)
    assert b.gauge == cli_json["gauge"]
    assert b.identifiable == cli_json["identifiable"]
    assert b.basis == cli_json["basis"]

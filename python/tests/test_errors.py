"""Bad input raises a located Python exception (a ValueError for bad input), never crashes."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

import lincal
from conftest import MODELS, SPECS

TWO_LINK = """\
name: two_link
dim: 2
joints:
  - {type: revolute, a: a1, home: th1}
  - {type: revolute, a: a2, home: th2}
params:
  a1: {nominal: 0.375}
  a2: {nominal: 0.425}
  th1: {nominal: 0}
  th2: {nominal: 0}
  b1: {nominal: -1.8}
  b2: {nominal: -0.5}
constraint:
  line: {b: [b1, b2]}
"""

TWO_LINK_DICT = {
    "name": "two_link",
    "dim": 2,
    "joints": [
        {"type": "revolute", "a": "a1", "home": "th1"},
        {"type": "revolute", "a": "a2", "home": "th2"},
    ],
    "params": {
        "a1": {"nominal": 0.375},
        "a2": {"nominal": 0.425},
        "th1": {"nominal": 0},
        "th2": {"nominal": 0},
        "b1": {"nominal": -1.8},
        "b2": {"nominal": -0.5},
    },
    "constraint": {"line": {"b": ["b1", "b2"]}},
}


@pytest.fixture(scope="module")
def spec():
    return lincal.Spec.from_str(TWO_LINK)


@pytest.fixture(scope="module")
def q(spec):
    return lincal.simulate(spec, 60, seed=3).q


def test_hierarchy():
    for cls in (lincal.InputError, lincal.SpecError, lincal.DataError, lincal.DegenerateError):
        assert issubclass(cls, ValueError)
        assert issubclass(cls, lincal.Error)
    assert issubclass(lincal.SpecError, lincal.InputError)
    assert issubclass(lincal.DataError, lincal.InputError)
    assert issubclass(lincal.InternalError, RuntimeError)
    assert issubclass(lincal.ComputationError, RuntimeError)
    assert issubclass(lincal.ComputationError, lincal.Error)


def test_expansion_beyond_max_terms():
    # The spec loads (a fit needs no expansion); the basis, built on demand, refuses.
    spec = lincal.Spec.from_yaml(MODELS / "puma560_sphere.yaml", max_terms=100)
    assert spec.estimated
    with pytest.raises(lincal.ComputationError) as e:
        spec.basis()
    assert "max-terms" in str(e.value) or "max_terms" in str(e.value)


def test_yaml_file_error_names_file_line_and_field(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(TWO_LINK.replace("dim: 2", "dim: 4"))
    with pytest.raises(lincal.SpecError) as e:
        lincal.Spec.from_yaml(path)
    assert e.value.field == "dim"
    assert e.value.line == 2
    assert e.value.file == str(path)
    assert "bad.yaml:2:6: field `dim`" in str(e.value)


def test_every_problem_is_listed(tmp_path):
    text = TWO_LINK.replace("home: th2}", "home: th2, colour: red}").replace("a1: {nominal", "zz: {nominal")
    with pytest.raises(lincal.SpecError) as e:
        lincal.Spec.from_str(text)
    fields = [d["field"] for d in e.value.diagnostics]
    assert len(fields) >= 2, fields
    assert any("colour" in (f or "") for f in fields)
    assert all(d["line"] is not None for d in e.value.diagnostics)


def test_missing_file():
    with pytest.raises(lincal.SpecError) as e:
        lincal.Spec.from_yaml("/nonexistent/spec.yaml")
    assert e.value.file == "/nonexistent/spec.yaml"


def test_dict_error_names_the_field_without_a_line():
    d = copy.deepcopy(TWO_LINK_DICT)
    d["joints"][1]["home"] = [1, 2]
    with pytest.raises(lincal.SpecError) as e:
        lincal.Spec.from_dict(d)
    assert e.value.field == "joints[1].home"
    assert e.value.line is None and e.value.column is None
    assert "field `joints[1].home`" in str(e.value)


def test_dict_errors_match_yaml_errors():
    d = copy.deepcopy(TWO_LINK_DICT)
    d["dim"] = 4
    with pytest.raises(lincal.SpecError) as from_dict:
        lincal.Spec.from_dict(d)
    with pytest.raises(lincal.SpecError) as from_text:
        lincal.Spec.from_str(TWO_LINK.replace("dim: 2", "dim: 4"))
    assert [x["field"] for x in from_dict.value.diagnostics] == [
        x["field"] for x in from_text.value.diagnostics
    ]
    assert [x["message"] for x in from_dict.value.diagnostics] == [
        x["message"] for x in from_text.value.diagnostics
    ]


@pytest.mark.parametrize(
    "mutate, field",
    [
        (lambda d: d["params"].__setitem__("a1", {"nominal": float("nan")}), "params.a1.nominal"),
        (lambda d: d["params"].__setitem__("a1", {"nominal": 10**400}), "params.a1.nominal"),
        (lambda d: d["params"].__setitem__(3, {"nominal": 1.0}), "params"),
        (lambda d: d["params"]["a1"].__setitem__("nominal", object()), "params.a1.nominal"),
        (lambda d: d.__setitem__("extra", 1), "extra"),
        (lambda d: d.pop("constraint"), None),
    ],
)
def test_bad_dicts_raise_spec_errors(mutate, field):
    d = copy.deepcopy(TWO_LINK_DICT)
    mutate(d)
    with pytest.raises(lincal.SpecError) as e:
        lincal.Spec.from_dict(d)
    if field is not None:
        assert any(field in (x["field"] or "") for x in e.value.diagnostics), e.value.diagnostics


def test_self_referencing_dict_does_not_crash():
    d = copy.deepcopy(TWO_LINK_DICT)
    d["joints"][0]["a"] = d
    with pytest.raises(lincal.SpecError):
        lincal.Spec.from_dict(d)


def test_not_a_dict():
    with pytest.raises(lincal.InputError):
        lincal.Spec.from_dict([1, 2])


def test_wrong_column_count(spec, q):
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(spec, np.hstack([q, q[:, :1]]))
    assert e.value.field == "q"
    assert "3 column(s), expected 2 (q1, q2)" in str(e.value)


def test_wrong_ndim(spec, q):
    with pytest.raises(ValueError, match="2-D array"):
        lincal.calibrate(spec, q.ravel())


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, 1e300])
def test_non_finite_value_names_row_and_column(spec, q, bad):
    q = q.copy()
    q[5, 1] = bad
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(spec, q)
    assert e.value.pose == 5
    assert e.value.field == "q2"
    assert "q[5, 1]" in str(e.value)


@pytest.mark.parametrize(
    "convert",
    [
        lambda q: q.astype(np.complex128),
        lambda q: q.astype(str),
        lambda q: q.astype(object),
        lambda q: q > 0,
    ],
)
def test_bad_dtypes(spec, q, convert):
    with pytest.raises(lincal.DataError, match="dtype"):
        lincal.calibrate(spec, convert(q))


def test_ragged_list(spec):
    with pytest.raises(lincal.DataError):
        lincal.calibrate(spec, [[0.1, 0.2], [0.3]])


def test_other_dtypes_and_layouts_are_read(spec, q):
    ref = lincal.calibrate(spec, q).to_dict()
    assert lincal.calibrate(spec, q.tolist()).to_dict() == ref
    assert lincal.calibrate(spec, np.asfortranarray(q)).to_dict() == ref
    assert lincal.calibrate(spec, q.astype(">f8")).to_dict() == ref
    wide = np.zeros((q.shape[0], 4))
    wide[:, ::2] = q
    assert lincal.calibrate(spec, wide[:, ::2]).to_dict() == ref


def test_constraint_and_x_arguments(spec, q):
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(spec, q, constraint=np.zeros(len(q), dtype=int))
    assert e.value.field == "constraint"
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(spec, q, x=np.zeros((len(q), 2)))
    assert e.value.field == "x"


def test_list_needs_constraint_in_range():
    spec = lincal.Spec.from_yaml(SPECS / "lines_list.yaml")
    sim = lincal.simulate(spec, 40, seed=2)
    with pytest.raises(lincal.DataError, match="constraint"):
        lincal.calibrate(spec, sim.q)
    c = sim.constraint.copy()
    c[7] = 2
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(spec, sim.q, constraint=c)
    assert (e.value.field, e.value.pose) == ("constraint", 7)
    with pytest.raises(lincal.DataError):
        lincal.calibrate(spec, sim.q, constraint=c[:-1])
    with pytest.raises(lincal.DataError, match="dtype"):
        lincal.calibrate(spec, sim.q, constraint=c.astype(float))


def test_measured_needs_x():
    spec = lincal.Spec.from_yaml(SPECS / "measured_spatial.yaml")
    sim = lincal.simulate(spec, 30, seed=2)
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(spec, sim.q)
    assert e.value.field == "x"
    x = sim.x.copy()
    x[4, 2] = np.nan
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(spec, sim.q, x=x)
    assert (e.value.field, e.value.pose) == ("z", 4)


def test_too_few_poses_is_degenerate(spec, q):
    with pytest.raises(lincal.DegenerateError):
        lincal.calibrate(spec, q[:3])
    with pytest.raises(lincal.DegenerateError):
        lincal.calibrate(spec, np.zeros((0, 2)))
    frozen = q.copy()
    frozen[:, 1] = 0.3
    with pytest.raises(lincal.DegenerateError):
        lincal.calibrate(spec, frozen)


def test_options(spec, q):
    with pytest.raises(lincal.InputError) as e:
        lincal.calibrate(spec, q, robust="tukey")
    assert e.value.field == "robust"
    with pytest.raises(lincal.InputError) as e:
        lincal.calibrate(spec, q, start="middle")
    assert e.value.field == "start"
    with pytest.raises(lincal.InputError) as e:
        lincal.simulate(spec, 10, noise_track=-1.0)
    assert e.value.field == "noise_track"
    with pytest.raises(lincal.InputError):
        lincal.simulate(spec, 0)
    with pytest.raises(lincal.InputError) as e:
        lincal.simulate(spec, -5)
    assert e.value.field == "n"
    with pytest.warns(UserWarning, match="noise_measure"):
        lincal.simulate(spec, 5, noise_measure=1e-6)


def test_params_mapping_errors(spec, q):
    with pytest.raises(lincal.InputError) as e:
        spec.tip(q, {"zz": 1.0})
    assert e.value.field == "zz"
    with pytest.raises(lincal.InputError):
        spec.tip(q, [1.0, 2.0])
    with pytest.raises(lincal.InputError):
        spec.tip(q, {"a1": "abc"})
    with pytest.raises(lincal.InputError):
        spec.tip(q, [0.375, 0, 0.425, float("nan"), -1.8, -0.5])


def test_csv_errors_name_line_and_column(tmp_path, spec):
    path = tmp_path / "data.csv"
    path.write_text("q1,q2\n0.1,0.2\n0.3,abc\n")
    with pytest.raises(lincal.DataError) as e:
        spec.read_csv(path)
    assert (e.value.line, e.value.field) == (3, "q2")
    with pytest.raises(lincal.DataError):
        spec.read_csv(tmp_path / "missing.csv")


def test_second_attack_classes(spec, q):
    """The CLI's rules hold in Python too: a prior strength with the prior off, parameter
    values beyond 1e9 and rotation vectors in degrees are refused by name."""
    with pytest.raises(lincal.InputError) as e:
        lincal.calibrate(spec, q, prior="off", prior_weight=1e3)
    assert e.value.field == "prior_weight"
    with pytest.raises(lincal.InputError) as e:
        lincal.calibrate(spec, q, prior=False, tolerance_angle=1e-3)
    assert e.value.field == "tolerance_angle"
    values = [1e300] * len(spec.params)
    with pytest.raises(lincal.InputError):
        spec.tip(q, values)
    name = next(iter(spec.params))
    with pytest.raises(lincal.InputError):
        spec.tip(q, {name: 1e300})
    pose = lincal.Spec.from_yaml(MODELS / "puma560_pose_tracker.yaml")
    sim = lincal.simulate(pose, 40, seed=3)
    rotvec = np.tile([0.0, 120.0, 0.0], (40, 1))
    with pytest.raises(lincal.DataError) as e:
        lincal.calibrate(pose, sim.q, x=sim.x, rotvec=rotvec)
    assert e.value.field == "rotvec" and "degrees" in str(e.value)


@pytest.mark.parametrize(
    "call, field, value",
    [
        (lambda s, q: lincal.simulate(s, 5, seed=-1), "seed", "-1"),
        (lambda s, q: lincal.simulate(s, 5, seed=2**64), "seed", str(2**64)),
        (lambda s, q: lincal.simulate(s, 10**30), "n", str(10**30)),
        (lambda s, q: lincal.select(s, 5, candidates=q, seed=-1), "seed", "-1"),
        (lambda s, q: lincal.select(s, 10**30, candidates=q), "n", str(10**30)),
        (lambda s, q: lincal.select(s, 5, pool=-(10**30)), "pool", str(-(10**30))),
        (lambda s, q: lincal.select(s, 5, candidates=q, draws=10**20), "draws", str(10**20)),
        (lambda s, q: lincal.Spec.from_str(TWO_LINK, max_terms=-1), "max_terms", "-1"),
    ],
)
def test_integer_arguments_out_of_range_name_the_argument(spec, q, call, field, value):
    """An integer beyond what the argument takes (a negative seed, 10**30 poses) is an
    InputError naming the argument and its range, never a raw OverflowError."""
    with pytest.raises(lincal.InputError) as e:
        call(spec, q)
    assert isinstance(e.value, ValueError) and not isinstance(e.value, OverflowError)
    assert e.value.field == field, (e.value.field, str(e.value))
    msg = str(e.value)
    assert f"`{field}` must be an integer from" in msg and value in msg, msg
    # The largest seed is accepted, and a non-integer is still a TypeError.
    lincal.simulate(spec, 3, seed=2**64 - 1)
    with pytest.raises(TypeError):
        lincal.simulate(spec, 3, seed=1.5)


def test_a_calibration_of_another_spec_is_refused(spec, q):
    """A Calibration of a spec of another name is refused by name even when the parameter
    names match (as the CLI refuses such a result file); its values as a dict are read."""
    cal = lincal.calibrate(spec, q)
    other = lincal.Spec.from_str(TWO_LINK.replace("name: two_link", "name: other_robot"))
    for use in (lambda: other.tip(q, cal), lambda: lincal.compensate(other, cal, q)):
        with pytest.raises(lincal.InputError) as e:
            use()
        assert e.value.field == "params"
        assert "`two_link`" in str(e.value) and "`other_robot`" in str(e.value), str(e.value)
    spec.tip(q, cal)
    assert ".values" in str(e.value)
    other.tip(q, cal.values)


def test_a_result_dict_is_held_to_a_result_files_checks(spec, q):
    """A result's dict (`to_dict()`, or a `calibrate --format json` file loaded) passed as
    `params` is checked as `predict --params` checks the file: another spec's name, another
    structure, or a missing estimated value is an InputError, where another robot's values
    passed for this one's and a missing value took its nominal."""
    d = lincal.calibrate(spec, q).to_dict()
    spec.tip(q, d)  # the same spec's result is read
    other = lincal.Spec.from_str(TWO_LINK.replace("name: two_link", "name: other_robot"))
    with pytest.raises(lincal.InputError) as e:
        other.tip(q, d)
    assert e.value.field == "params.name" and "`other_robot`" in str(e.value), str(e.value)
    changed = json.loads(json.dumps(d))
    changed["structure"] = "0000000000000000"
    with pytest.raises(lincal.InputError) as e:
        spec.tip(q, changed)
    assert e.value.field == "params.structure", str(e.value)
    first = next(n for n, p in d["params"].items() if not p["known"])
    missing = json.loads(json.dumps(d))
    del missing["params"][first]
    with pytest.raises(lincal.InputError) as e:
        spec.tip(q, missing)
    assert e.value.field == f"params.params.{first}" and "missing" in str(e.value), str(e.value)
    # A plain name -> value dict may still leave parameters at their nominals.
    spec.tip(q, {first: d["params"][first]["value"]})


def test_residuals_that_are_not_finite_raise(spec, q):
    """A line whose normal is zero at the given values has no distance to it: `residuals`
    raises DegenerateError naming the pose and the constraint, where it returned inf."""
    for b in ({"b1": 0.0, "b2": 0.0}, {"b1": 1e-160, "b2": 0.0}):
        with pytest.raises(lincal.DegenerateError) as e:
            spec.residuals(q, b)
        assert "pose 0" in str(e.value) and "constraint 0 (line)" in str(e.value), str(e.value)
    assert np.isfinite(spec.residuals(q)).all()

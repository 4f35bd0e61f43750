"""`Spec.read_csv` reads data files as `lincal calibrate` reads them: several files (one per
constraint of a list), and a URDF import's joint names as the joint columns' headers."""

from __future__ import annotations

import numpy as np
import pytest

import lincal
from conftest import REPO

SOCKETS = REPO / "examples" / "sockets"
FILES = [SOCKETS / f"socket_{i}.csv" for i in range(3)]


@pytest.fixture(scope="module")
def ur5_sockets(tmp_path_factory, cli):
    """The sockets example's spec, imported from the UR5's URDF as its run.sh does."""
    code, out, err = cli("import", REPO / "examples" / "robot" / "ur5.urdf", "--base",
                         "base_link", "--tip", "tool0", "--tool", "0.03,0,0.04", "--points",
                         "3", "--distance", "0.1")
    assert code == 0, err
    path = tmp_path_factory.mktemp("sockets") / "spec.yaml"
    path.write_text(out)
    return path


def test_urdf_joint_names_are_headers_and_files_are_constraints(ur5_sockets, cli_json):
    # The example's files name the UR5's joints (shoulder_pan_joint, ...), one per socket.
    assert FILES[0].read_text().startswith("shoulder_pan_joint,")
    spec = lincal.Spec.from_yaml(ur5_sockets)
    d = spec.read_csv(FILES)
    counts = [sum(1 for line in f.read_text().splitlines()[1:] if line.strip()) for f in FILES]
    assert len(d["q"]) == sum(counts)
    assert d["constraint"].tolist() == [k for k, n in enumerate(counts) for _ in range(n)]
    # The first pose is the first file's first row, in the URDF's joint order.
    first = [float(v) for v in FILES[0].read_text().splitlines()[1].split(",")]
    assert d["q"][0].tolist() == first
    # And the fit is the command line's on the same files.
    fit = lincal.calibrate(spec, **d)
    want, _ = cli_json("calibrate", ur5_sockets, *FILES, "--format", "json")
    got = fit.to_dict()["params"]
    for name, p in want["params"].items():
        assert got[name]["value"] == pytest.approx(p["value"], rel=1e-9, abs=1e-12), name


def test_one_file_of_a_list_without_a_constraint_column_is_refused(ur5_sockets):
    spec = lincal.Spec.from_yaml(ur5_sockets)
    with pytest.raises(lincal.DataError):
        spec.read_csv(FILES[0])
    with pytest.raises(lincal.DataError):
        spec.read_csv(FILES[:2])
    with pytest.raises(lincal.InputError) as e:
        spec.read_csv([])
    assert e.value.field == "path"


def test_a_spec_from_text_takes_its_urdf_record_too(ur5_sockets):
    spec = lincal.Spec.from_str(ur5_sockets.read_text())
    d = spec.read_csv(FILES)
    assert np.isfinite(d["q"]).all()


def test_a_tip_beyond_a_robots_reach_is_refused_as_predict_refuses_it():
    spec = lincal.Spec.from_yaml(REPO / "tests" / "specs" / "lines_list.yaml")
    q = np.zeros((2, spec.joint_count))
    # Each length within the values a parameter may take, their sum beyond 10^9 m.
    huge = {"a1": 9e8, "a2": 9e8}
    with pytest.raises(lincal.InputError) as e:
        spec.tip(q, huge)
    assert e.value.field == "params"
    assert "not a robot's" in str(e.value)
    assert np.isfinite(spec.tip(q)).all()

"""Shared fixtures: the repository, the shared reference cases and the `lincal` CLI binary.

Environment:
- ``LINCAL_CASES``: the reference cases folder (default ``<repo>/../shared/cases``);
- ``LINCAL_BIN``: the ``lincal`` binary to compare with (default
  ``$CARGO_TARGET_DIR/release/lincal``, then ``<repo>/target/release/lincal``);
- ``LINCAL_REQUIRE_CLI=1``: fail, rather than skip, the comparisons when there is no binary
  (``ci.sh`` sets it).
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SPECS = REPO / "tests" / "specs"
MODELS = REPO / "lincal-models" / "specs"


def cases_dir() -> Path:
    return Path(os.environ.get("LINCAL_CASES", REPO.parent / "shared" / "cases"))


def case_names() -> list[str]:
    d = cases_dir()
    if not d.is_dir():
        return []
    return sorted(p.name for p in d.iterdir() if (p / "spec.yaml").is_file())


def cli_path() -> Path | None:
    candidates = []
    if os.environ.get("LINCAL_BIN"):
        candidates.append(Path(os.environ["LINCAL_BIN"]))
    if os.environ.get("CARGO_TARGET_DIR"):
        candidates.append(Path(os.environ["CARGO_TARGET_DIR"]) / "release" / "lincal")
    candidates.append(REPO / "target" / "release" / "lincal")
    for c in candidates:
        if c.is_file() and os.access(c, os.X_OK):
            return c
    return None


@pytest.fixture(scope="session")
def cli():
    """Runs the `lincal` binary: ``cli("calibrate", spec, data, "--format", "json")`` returns
    (exit status, stdout, stderr)."""
    path = cli_path()
    if path is None:
        if os.environ.get("LINCAL_REQUIRE_CLI") == "1":
            pytest.fail("no lincal binary (set LINCAL_BIN or build with cargo build --release)")
        pytest.skip("no lincal binary (set LINCAL_BIN or build with cargo build --release)")

    def run(*args: object) -> tuple[int, str, str]:
        p = subprocess.run(
            [str(path), *map(str, args)], capture_output=True, text=True, timeout=600
        )
        return p.returncode, p.stdout, p.stderr

    return run


@pytest.fixture(scope="session")
def cli_json(cli):
    """The JSON the binary prints for its arguments (exit status 0 required)."""

    def run(*args: object):
        code, out, err = cli(*args)
        assert code == 0, err
        return json.loads(out), out

    return run

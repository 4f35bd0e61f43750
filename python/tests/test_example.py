"""The example runs (with matplotlib it writes its figure; without, it says so and exits 0)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "calibrate_adept.py"


def test_example_runs(tmp_path):
    out = tmp_path / "adept.png"
    p = subprocess.run(
        [sys.executable, str(EXAMPLE), "--out", str(out), "--poses", "120"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert p.returncode == 0, p.stderr
    assert "a2/a1" in p.stdout
    if importlib.util.find_spec("matplotlib") is not None:
        assert out.is_file() and out.stat().st_size > 10_000
    else:
        assert "matplotlib is not installed" in p.stdout

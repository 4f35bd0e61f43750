"""Every ```python block of README.md, docs/ and examples/*/README.md runs (issue 51), as the
Rust harness (tests/e2e/docs.rs) runs the shell blocks: each file's blocks in order, in one
fresh directory holding copies of the repository's examples/ and lincal-models/specs/, so the
guide's Python cannot drift from the package.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from conftest import REPO


def python_blocks(text: str) -> list[tuple[int, str]]:
    """(line of the opening fence, code) of every ```python block."""
    out, code, start = [], None, 0
    for i, line in enumerate(text.splitlines(), 1):
        stripped = line.lstrip()
        if code is None:
            if stripped.startswith("```python"):
                code, start = [], i
        elif stripped.startswith("```"):
            out.append((start, "\n".join(code) + "\n"))
            code = None
        else:
            code.append(line)
    return out


def doc_files() -> list[Path]:
    files = [REPO / "README.md"]
    files += sorted((REPO / "docs").rglob("*.md"))
    files += sorted((REPO / "examples").glob("*/README.md"))
    return [f for f in files if python_blocks(f.read_text(encoding="utf-8"))]


def test_the_harness_finds_blocks():
    assert python_blocks("a\n```python\nx = 1\n```\n```sh\nls\n```\n") == [(2, "x = 1\n")]
    assert doc_files(), "no ```python block in the docs"


@pytest.mark.parametrize("path", doc_files(), ids=lambda p: str(p.relative_to(REPO)))
def test_every_python_block_runs(path, tmp_path, monkeypatch):
    for tree in ("examples", "lincal-models/specs"):
        shutil.copytree(REPO / tree, tmp_path / tree)
    monkeypatch.chdir(tmp_path)
    scope: dict = {"__name__": "__doc__"}
    for line, code in python_blocks(path.read_text(encoding="utf-8")):
        try:
            exec(compile(code, f"{path.name}:{line}", "exec"), scope)
        except Exception as e:  # the block and its place, then the error
            pytest.fail(f"{path.relative_to(REPO)}:{line}: {type(e).__name__}: {e}")

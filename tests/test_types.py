"""The public API passes mypy with the settings in pyproject.toml ([tool.mypy])."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CONFIG = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]

needs_mypy = pytest.mark.skipif(importlib.util.find_spec("mypy") is None,
                                reason="mypy is not installed (it is in the 'test' extra: pip install -e '.[test]')")


def _mypy(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mypy", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=600)


def test_every_checked_path_exists():
    """A renamed or moved module drops out of the check silently unless its entry is updated."""
    missing = [f for f in CONFIG["files"] if not (ROOT / f).exists()]
    assert not missing, f"[tool.mypy] files lists paths that do not exist: {missing}"


@pytest.mark.slow
@needs_mypy
def test_mypy_passes_on_the_public_api():
    res = _mypy()
    errors = [line for line in res.stdout.splitlines() if ": error:" in line]
    assert res.returncode == 0, f"{len(errors)} mypy errors:\n" + "\n".join(errors) + "\n" + res.stderr


@pytest.mark.slow
@needs_mypy
def test_the_settings_catch_a_wrong_optional(tmp_path):
    """The configuration is read and checks bodies: a None passed where a float is declared fails."""
    bad = tmp_path / "bad.py"
    bad.write_text("def half(x: float) -> float:\n    return x / 2\n\n\n"
                   "def f(y: float | None) -> float:\n    return half(y)\n")
    res = _mypy("--config-file", str(ROOT / "pyproject.toml"), "--no-incremental", str(bad), cwd=tmp_path)
    assert res.returncode == 1, res.stdout + res.stderr
    assert "[arg-type]" in res.stdout, res.stdout

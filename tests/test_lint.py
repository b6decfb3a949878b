"""The code passes ruff with the rules in pyproject.toml ([tool.ruff])."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(importlib.util.find_spec("ruff") is None,
                    reason="ruff is not installed (it is in the 'test' extra: pip install -e '.[test]')")
def test_ruff_passes_on_src_and_tests():
    res = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "src", "tests"],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr


@pytest.mark.skipif(importlib.util.find_spec("ruff") is None, reason="ruff is not installed")
def test_the_rules_catch_an_unused_import_and_a_long_line(tmp_path):
    """The configuration is read and selects rules: a file breaking two of them fails."""
    bad = tmp_path / "bad.py"
    bad.write_text("import os\n\nX = '" + "x" * 130 + "'\n")
    res = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "--config",
                          str(ROOT / "pyproject.toml"), str(bad)], capture_output=True, text=True, timeout=300)
    assert res.returncode == 1, res.stdout + res.stderr
    assert "F401" in res.stdout and "E501" in res.stdout, res.stdout

"""A first ``roadbank reproduce`` says that it compiles, times what is left from the first finished
cell on, and its report states the whole command's wall time."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.cli.reproduce import _CellProgress
from roadbank.report import coldstart

SRC = Path(__file__).resolve().parents[1] / "src"


def test_reproduce_says_it_compiles_and_reports_the_whole_wall_time(tmp_path, monkeypatch):
    monkeypatch.setattr(coldstart, "is_cold", lambda family: True)      # as on a first run
    res = CliRunner().invoke(main, ["reproduce", "-o", str(tmp_path), "--scenarios", "const-bank", "-j", "1",
                                    "--estimators", "dfc,pif-modified"])
    assert res.exit_code == 0, res.output
    want = coldstart.compile_estimate_s(["plant", "lpv", "dfc"])
    assert f"compiling the kernels once (about {want:.0f} s" in res.output
    assert "plant, lpv, dfc" in res.output
    head = (tmp_path / "report.md").read_text()[:2000]
    m = re.search(r"in ([0-9.]+) s wall time from the command's start \(the cells ([0-9.]+) s", head)
    assert m, head
    total = float(re.search(r"\(total ([0-9.]+) s\)", res.output).group(1))
    assert float(m.group(2)) <= float(m.group(1)) <= total + 0.05


def test_warm_kernels_say_nothing(tmp_path, monkeypatch):
    monkeypatch.setattr(coldstart, "is_cold", lambda family: False)
    res = CliRunner().invoke(main, ["reproduce", "-o", str(tmp_path), "--scenarios", "const-bank", "-j", "1",
                                    "--estimators", "dfc"])
    assert res.exit_code == 0, res.output
    assert "compiling" not in res.output


@pytest.mark.slow
def test_cold_cache_detected_in_a_fresh_process(tmp_path):
    """An empty numba cache is cold; after one run it is not, in this process nor in the next."""
    code = textwrap.dedent("""
        import numpy as np
        from roadbank import Signals, estimators
        from roadbank.report.coldstart import cold_families, is_cold
        print(cold_families(["dfc"], simulate=False))
        n = 50
        s = Signals(np.arange(n) * 0.01, np.full(n, 20.0), np.full(n, 0.5), np.full(n, 0.01), np.full(n, 0.002))
        estimators.make("dfc", v_max=30.0).run(s)
        print(is_cold("dfc"))
    """)
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(SRC), "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
           "ROADBANK_CACHE_DIR": str(tmp_path / "designs"), "OPENBLAS_NUM_THREADS": "1"}
    first = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert first.returncode == 0, first.stderr
    assert first.stdout.split("\n")[:2] == ["['dfc']", "False"]
    again = subprocess.run([sys.executable, "-c", "from roadbank.report.coldstart import cold_families;"
                            "print(cold_families(['dfc'], simulate=False))"], env=env, capture_output=True,
                           text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert again.stdout.strip() == "[]"


class _Bar:
    def __init__(self):
        self.updates = []

    def update(self, n, text):
        self.updates.append(text)


class _Cell:
    def __init__(self, seconds):
        self.seconds = seconds


def test_time_left_only_from_the_second_cell(monkeypatch):
    clock = iter([30.0, 31.0, 32.0, 33.0])            # the first cell ends at 30 s (compiling)
    monkeypatch.setattr("roadbank.cli.reproduce.time.perf_counter", lambda: next(clock))
    bar = _Bar()
    progress = _CellProgress(bar, 4)
    for _ in range(4):
        progress(_Cell(30.0))
    assert bar.updates[0] == "first cell in 30.0 s"
    # from the first cell's end: 1 s per cell, so 2 then 1 cells left
    assert bar.updates[1:] == ["00:02 left", "00:01 left", "done"]

"""Imports sit at module level; an import inside a function is one of the deferred kinds below.

Deferred on purpose: the optional dependencies (a missing extra fails only the call that needs
it), matplotlib (its backend is chosen before pyplot loads, and only a drawing pays for it), and
a few imports that keep a light module light for start-up (each listed with its reason)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "roadbank"

#: the modules held to the rule (the others join once their rewrites are done)
SCOPE = ("signals.py", "params.py", "constants.py", "units.py", "cache.py", "defaults.py", "vehicle", "estimators",
         "evaluation", "mapping", "report", "sim", "models", "identification", "campaign", "validation", "tuning",
         "io", "faults", "export", "fleet")
NOT_YET: tuple[str, ...] = ()

#: top-level packages whose imports may always be deferred
OPTIONAL = {"asammdf", "can", "cantools", "rosbags", "mcap", "dask", "distributed", "pandas", "sympy", "matplotlib"}

#: module (relative to src/roadbank) -> imports it defers, and why
DEFERRED = {
    # roadbank estimate never loads scipy.signal (which pulls in scipy.stats): only pole placement needs it
    "estimators/synthesis.py": {"scipy.signal"},
    # scipy.signal (about a second) only for a log on a uniform grid: a KITTI drive's workers never load it
    "validation/scoring.py": {"scipy.signal"},
    # `roadbank validate --help` imports report.html: the markdown parser loads when a page is written
    "report/html.py": {"markdown_it"},
    # the numba dispatcher of the one kernel family asked about
    "report/coldstart.py": {"..sim.integrate", "..estimators"},
    # report.figures loads matplotlib: a study without figures does not
    "report/reproduce.py": {".figures"},
    # loading a car (load_vehicle, --vehicle) loads neither the estimators nor the simulator (numba)
    "vehicle/conditions.py": {"..estimators", "..estimators.pif"},
    "vehicle/file.py": {"..estimators", "..sim", "..sim.params"},
    "vehicle/plausibility.py": {"..estimators"},
    "vehicle/sensors.py": {"..estimators.pif", "..sim.sensors"},
    # pyarrow (0.1-0.15 s) loads when a Parquet file is read or written: `import roadbank.io` and the
    # KITTI, comma2k19 and text readers do without it
    "io/readers.py": {"pyarrow", "pyarrow.parquet", "pyarrow.compute"},
    "io/sources.py": {"pyarrow", "pyarrow.parquet", ".can", ".ros"},     # .can, .ros: optional extras
    "io/writers.py": {"pyarrow", "pyarrow.parquet"},
    # asammdf (optional) behind its import shim
    "io/files.py": {".mdfimport"},
    # the robustness table's simulated drive (numba) only when it is asked for
    "faults/table.py": {"..sim"},
    # a Dask session: the campaign's runner (the simulator) loads only when workers are asked for
    "fleet/cluster.py": {"..campaign.execute"},
    # a plot of the estimate (matplotlib) only when one is asked for
    "fleet/process.py": {"..report.timeseries"},
    # the warm-up log and the benchmark's logs are written with pyarrow; the benchmark's drive is simulated
    "fleet/run.py": {"pyarrow", "pyarrow.parquet"},
    "fleet/bench.py": {"..sim", "pyarrow", "pyarrow.parquet", "pyarrow.csv"},
}


def _files() -> list[Path]:
    out = []
    for entry in SCOPE:
        p = SRC / entry
        out += sorted(p.rglob("*.py")) if p.is_dir() else [p]
    return [p for p in out if p.relative_to(SRC).as_posix() not in NOT_YET]


def in_function_imports(path: Path) -> list[tuple[int, str]]:
    """``(line, module)`` of each import inside a function of ``path``; a relative module keeps its
    dots (``..estimators``; ``from . import x`` gives ``.x``)."""
    found = set()
    for fn in ast.walk(ast.parse(path.read_text())):
        if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for node in ast.walk(fn):
                if isinstance(node, ast.Import):
                    found.update((node.lineno, a.name) for a in node.names)
                elif isinstance(node, ast.ImportFrom) and node.module:
                    found.add((node.lineno, "." * node.level + node.module))
                elif isinstance(node, ast.ImportFrom):     # from .. import x: the module ..x
                    found.update((node.lineno, "." * node.level + a.name) for a in node.names)
    return sorted(found)


def _allowed(rel: str, module: str) -> bool:
    return module.split(".")[0] in OPTIONAL or module in DEFERRED.get(rel, set())


def test_the_scope_exists():
    missing = [e for e in SCOPE + NOT_YET if not (SRC / e).exists()]
    assert not missing, missing


@pytest.mark.parametrize("path", _files(), ids=lambda p: p.relative_to(SRC).as_posix())
def test_imports_inside_functions_are_deferred_kinds(path):
    rel = path.relative_to(SRC).as_posix()
    bad = [f"{rel}:{line}: {module}" for line, module in in_function_imports(path) if not _allowed(rel, module)]
    assert not bad, ("imports inside functions: move them to module level, or list them in DEFERRED "
                     "with the reason:\n" + "\n".join(bad))


def test_the_check_sees_a_deferred_import(tmp_path):
    bad = tmp_path / "x.py"
    bad.write_text("import math\n\n\ndef f():\n    import numpy as np\n    from ..sim import run\n"
                   "    import matplotlib.pyplot as plt\n    from .. import estimators\n"
                   "    return np, run, plt, math, estimators\n")
    mods = [m for _, m in in_function_imports(bad)]
    assert mods == ["numpy", "..sim", "matplotlib.pyplot", "..estimators"]
    assert [m for m in mods if not _allowed("x.py", m)] == ["numpy", "..sim", "..estimators"]


@pytest.mark.slow
def test_loading_a_car_loads_no_estimator_or_simulator():
    """The reason the vehicle package defers its estimator and simulator imports holds."""
    code = ("import sys; from roadbank.vehicle import load_vehicle; load_vehicle('sedan'); "
            "print(sorted(m for m in sys.modules if m.startswith(('roadbank.estimators', 'roadbank.sim', 'numba'))))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env={"PYTHONPATH": str(SRC.parent), "PATH": "/usr/bin:/bin"})
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "[]", res.stdout

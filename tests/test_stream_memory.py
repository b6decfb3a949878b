"""What a streamed ``roadbank estimate`` loads and holds: no module it does not use, sympy only
when an MDF4 formula needs it, one MDF4 channel-group window at a time, Arrow on the C allocator.

Truth: the modules a fresh ``roadbank estimate`` process has loaded (``sys.modules``), numpy's
``abs`` for an algebraic MDF4 conversion, and the whole-file reader (``load_log``, itself tested
against hand-made files in test_io_readers.py) for windows that cross MDF4 data blocks.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from roadbank.defaults import ESTIMATOR
from roadbank.io import LogError, load_log
from roadbank.io.stream import stream_log

asammdf = pytest.importorskip("asammdf")
from asammdf import MDF, Signal  # noqa: E402

N = 1500                                         # 15 s at 100 Hz


def _drive(n=N):
    t = np.arange(n) * 0.01
    return {"t": t, "vx": 20.0 + 0.1 * np.sin(t), "ay": 0.8 * np.sin(0.7 * t), "r": 0.04 * np.sin(0.7 * t),
            "delta_f": 0.02 * np.sin(0.7 * t)}


def _write_mdf4(p, cols, conversions=None, **save):
    mdf = MDF(version="4.10")
    conv = conversions or {}
    mdf.append([Signal(cols[c], cols["t"], name=c, conversion=conv.get(c)) for c in ("vx", "ay", "r", "delta_f")])
    mdf.save(p, overwrite=True, **save)
    mdf.close()
    return p


def _run(code: str, env: dict | None = None) -> dict:
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, **(env or {})))
    assert res.returncode == 0, res.stderr[-3000:]
    return json.loads(res.stdout.strip().splitlines()[-1])


_ESTIMATE = r"""
import json, sys
from roadbank.cli import main
seen = {}
for log, out in zip(sys.argv[1::2], sys.argv[2::2]):
    try:
        main(["estimate", log, "-o", out], standalone_mode=False)
    except SystemExit as exc:
        assert not exc.code, exc.code
    seen[log] = sorted(m for m in sys.modules if m.split(".")[0] in
                       ("matplotlib", "dask", "distributed", "pandas", "sympy", "asammdf", "PIL", "scipy"))
import pyarrow
seen["pool"] = pyarrow.default_memory_pool().backend_name
print(json.dumps(seen))
"""


@pytest.fixture(scope="module")
def estimated(tmp_path_factory):
    """One fresh process runs ``roadbank estimate`` on a Parquet log, then on an MDF4 log."""
    d = tmp_path_factory.mktemp("lean")
    cols = _drive()
    pq.write_table(pa.table(cols), d / "a.parquet")
    _write_mdf4(d / "b.mf4", cols)
    code = _ESTIMATE.replace("sys.argv[1::2], sys.argv[2::2]",
                             repr([str(d / "a.parquet"), str(d / "b.mf4")]) + ", "
                             + repr([str(d / "a.out.parquet"), str(d / "b.out.parquet")]))
    seen = _run(code)
    return d, seen


@pytest.mark.slow
def test_streamed_estimate_loads_no_plotting_dask_or_pandas(estimated):
    d, seen = estimated
    parquet_mods = seen[str(d / "a.parquet")]
    for unused in ("matplotlib", "dask", "distributed", "PIL", "pandas", "sympy", "asammdf",
                   "scipy.signal", "scipy.stats", "scipy.optimize"):
        assert unused not in parquet_mods, unused
    mdf_mods = seen[str(d / "b.mf4")]
    assert "asammdf" in mdf_mods                       # the MDF4 log was really read with asammdf
    for unused in ("matplotlib", "dask", "distributed", "sympy"):
        assert unused not in mdf_mods, unused
    for name in ("a", "b"):                              # and estimated: a complete table each
        tab = pq.read_table(d / f"{name}.out.parquet")
        assert tab.num_rows > 0.99 * N and f"{ESTIMATOR}.phi_b" in tab.column_names      # the default estimator


@pytest.mark.slow
def test_roadbank_command_puts_arrow_on_the_c_allocator_unless_told_otherwise(estimated):
    assert estimated[1]["pool"] == "system"
    code = ("import json, os, roadbank.cli; "
            "print(json.dumps({'pool': os.environ['ARROW_DEFAULT_MEMORY_POOL']}))")
    assert _run(code, {"ARROW_DEFAULT_MEMORY_POOL": "jemalloc"})["pool"] == "jemalloc"   # the user's choice wins


def test_deferred_module_loads_on_first_call_and_is_the_real_one_afterwards(tmp_path):
    # the mechanism of roadbank.io.mdfimport without sympy: 'user' takes two names from 'heavy'
    # in a try (as asammdf takes lambdify/symbols from sympy); 'heavy' records that it was imported
    (tmp_path / "heavy.py").write_text("import builtins\n"
                                       "builtins.HEAVY_LOADS = getattr(builtins, 'HEAVY_LOADS', 0) + 1\n"
                                       "def double(x):\n    return 2 * x\n"
                                       "def name():\n    return __name__\nCONST = 7\n")
    (tmp_path / "user.py").write_text("try:\n    from heavy import double, name\nexcept ImportError:\n"
                                      "    double = name = None\n")
    code = f"""
import builtins, json, sys
sys.path.insert(0, r"{tmp_path}")
from roadbank.io.mdfimport import import_deferring
user = import_deferring("user", {{"heavy": ("double", "name")}})
res = {{"loaded_at_import": getattr(builtins, "HEAVY_LOADS", 0), "in_modules": "heavy" in sys.modules}}
res["double"] = user.double(21)
res["loaded_after_call"] = builtins.HEAVY_LOADS
res["name"] = user.name()
import heavy
res["real"] = heavy.CONST == 7 and heavy.double is not user.double
res["loads"] = builtins.HEAVY_LOADS
print(json.dumps(res))
"""
    assert _run(code) == {"loaded_at_import": 0, "in_modules": False, "double": 42, "loaded_after_call": 1,
                          "name": "heavy", "real": True, "loads": 1}


@pytest.mark.slow
def test_mdf4_formula_loads_sympy_on_demand_and_converts(tmp_path):
    # 'Abs(X)' is an algebraic conversion numexpr cannot parse: asammdf evaluates it with sympy
    # (optional for asammdf and not among roadbank's dependencies: where it is missing asammdf
    # cannot evaluate the formula at all, deferred or not)
    pytest.importorskip("sympy")
    cols = _drive()
    raw = dict(cols, ay=cols["ay"] - 0.3)                    # negative and positive raw values
    formula = _write_mdf4(tmp_path / "formula.mf4", raw, {"ay": {"formula": "Abs(X)"}})
    truth = _write_mdf4(tmp_path / "truth.mf4", dict(raw, ay=np.abs(raw["ay"])))   # numpy's abs, no conversion
    plain = _write_mdf4(tmp_path / "plain.mf4", cols)
    code = f"""
import json, sys
import numpy as np
from roadbank.io.stream import stream_log
from roadbank.io import load_log
ay = lambda p: np.concatenate([c.signals.ay for c in stream_log(p, chunk_rows=400)])
ay(r"{plain}")
res = {{"after_plain": "sympy" in sys.modules}}
got, want, whole = ay(r"{formula}"), ay(r"{truth}"), load_log(r"{formula}").signals.ay
res["same_as_numpy_abs"] = bool(np.array_equal(got, want))
res["same_as_whole"] = bool(np.array_equal(got, whole))
res["negative"] = bool((got < 0).any())
import sympy
res["real_sympy"] = hasattr(sympy, "Symbol") and sympy.__spec__ is not None
print(json.dumps(res))
"""
    res = _run(code)
    assert res == {"after_plain": False, "same_as_numpy_abs": True, "same_as_whole": True, "negative": False,
                   "real_sympy": True}


def test_mdf4_windows_across_compressed_data_blocks_equal_whole(tmp_path):
    cols = _drive()
    mdf = MDF(version="4.10")
    mdf.configure(write_fragment_size=3000)             # small data blocks: windows cross block borders
    mdf.append([Signal(cols[c], cols["t"], name=c) for c in ("ay", "r")])
    mdf.append([Signal(cols["vx"][::2], cols["t"][::2] + 0.003, name="vx")])        # 50 Hz, own clock
    mdf.append([Signal(cols["delta_f"][::5], cols["t"][::5], name="delta_f")])     # 20 Hz
    p = tmp_path / "blocks.mf4"
    mdf.save(p, compression=2)                          # transposed + deflate (DZ blocks)
    mdf.close()
    with MDF(p) as check:
        assert len(check.groups[0].data_blocks) > 3        # really several blocks
    full = load_log(p)
    for chunk in (61, 500):
        chunks = list(stream_log(p, chunk_rows=chunk))
        assert len(chunks) > 1
        for k in ("t", "vx", "ay", "r", "delta_f"):
            np.testing.assert_array_equal(np.concatenate([getattr(c.signals, k) for c in chunks]),
                                          getattr(full.signals, k), err_msg=f"{k}, chunk {chunk}")


def test_mdf4_group_channels_are_read_in_one_pass_per_window(tmp_path, monkeypatch):
    cols = _drive()
    mdf = MDF(version="4.10")
    mdf.append([Signal(cols[c], cols["t"], name=c) for c in ("vx", "ay", "r")])     # one group, 3 channels
    mdf.append([Signal(cols["delta_f"][::2], cols["t"][::2], name="delta_f")])     # 750 records
    p = tmp_path / "two.mf4"
    mdf.save(p)
    mdf.close()
    calls = []
    real = MDF.select

    def counting(self, channels, *a, **kw):
        calls.append((len(channels), kw.get("record_offset")))
        return real(self, channels, *a, **kw)

    monkeypatch.setattr(MDF, "select", counting)
    chunks = list(stream_log(p, chunk_rows=300))
    assert sum(len(c) for c in chunks) == len(load_log(p))
    wide = [c for c in calls if c[0] == 3]
    assert [o for _, o in wide] == [0, 300, 600, 900, 1200]          # ceil(1500/300) windows, each once
    assert [o for n, o in calls if n == 1] == [0, 300, 600]           # the 750-record group


def test_mdf4_channel_in_several_groups_is_named(tmp_path):
    cols = _drive()
    mdf = MDF(version="4.10")
    mdf.append([Signal(cols[c], cols["t"], name=c) for c in ("vx", "ay", "r", "delta_f")])
    mdf.append([Signal(cols["ay"], cols["t"] + 0.005, name="ay")])
    p = tmp_path / "twice.mf4"
    mdf.save(p)
    mdf.close()
    with pytest.raises(LogError) as err:
        list(stream_log(p))
    msg = str(err.value)
    assert str(p) in msg and "'lateral_acceleration'" in msg and "'ay'" in msg and "2 channel groups" in msg

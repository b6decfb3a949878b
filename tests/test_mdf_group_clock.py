"""An MDF4 file whose channels to read all lie in one channel group (a logger's raster: every channel on the group's
time stamps) is read on those stamps, as a CSV or Parquet table is on its clock: values as stored, nothing
interpolated. Channels of several groups keep their own clocks and are interpolated (tests/test_load_equals_stream.py).

Truth: the arrays written into the file, and the same log written as CSV (every float to the last bit).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from roadbank.io import load_log
from roadbank.io.assemble import concat_logs
from roadbank.io.stream import stream_log
from roadbank.signals import held_copies
from roadbank.vehicle import log_conditions

asammdf = pytest.importorskip("asammdf", reason="optional extra 'mdf' (asammdf) not installed")

KITTI_0070 = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts" / "2011_09_26_drive_0070"
SIG = ("t", "vx", "ay", "r", "p")

MAP = """
[resample]
time_base = "{tb}"

[channels]
speed = {{ column = "vx", unit = "m/s" }}
lateral_acceleration = {{ column = "ay", unit = "m/s^2" }}
yaw_rate = {{ column = "r", unit = "rad/s" }}
roll_rate = {{ column = "p", unit = "rad/s" }}
"""


def _mdf(path, t, cols: dict, groups=None):
    """``cols`` (name -> array) on stamps ``t`` in one channel group, or in ``groups`` (lists of names)."""
    mdf = asammdf.MDF(version="4.10")
    for names in groups or [list(cols)]:
        mdf.append([asammdf.Signal(np.asarray(cols[c], dtype=np.float64), t, name=c) for c in names])
    mdf.save(path, overwrite=True)
    return path


def _csv(path, t, cols: dict):
    """The same log as a CSV table, every float written to the last bit (``repr``)."""
    with open(path, "w") as fh:
        fh.write(",".join(["t", *cols]) + "\n")
        for i in range(len(t)):
            fh.write(",".join(repr(float(x)) for x in (t[i], *(cols[c][i] for c in cols))) + "\n")
    return path


def _streamed(path, chunk_rows, **kw):
    return concat_logs(list(stream_log(path, chunk_rows=chunk_rows, **kw)))


def _held(jitter_s: float):
    """KITTI 0070's 10 Hz INS frames held on a 100 Hz raster (each frame written until the next), the raster's
    stamps with a logger's jitter: (t, columns)."""
    s = load_log(KITTI_0070).signals
    t10 = s.t - s.t[0]
    raster = np.arange(0.0, t10[-1], 0.01)
    k = np.searchsorted(t10, raster + 1e-9, side="right") - 1
    t = raster + np.random.default_rng(5).uniform(-jitter_s, jitter_s, raster.size)
    return t, {"vx": s.vx[k], "ay": s.ay[k], "r": s.r[k], "p": s.p[k]}


@pytest.mark.skipif(not KITTI_0070.is_dir(), reason="../shared/data/kitti-oxts is not here")
@pytest.mark.parametrize("jitter_s", [0.0, 20e-6])
def test_a_held_mdf4_reads_as_the_held_csv(tmp_path, jitter_s):
    """The held log as one channel group reads to the held CSV's signals, whole and streamed: every value as stored
    (before: interpolated onto t0 + k/100 s, which differs from the stamps by a rounding unit, so a value like
    -0.22000000000000033 leaked next to -0.22 at each frame change, every change blended with 20 us of jitter, and
    the log was not read as held), so it is read at its source's rate as the CSV is."""
    t, cols = _held(jitter_s)
    want = load_log(_csv(tmp_path / "held.csv", t, cols)).signals
    p = _mdf(tmp_path / "held.mf4", t, cols)
    assert log_conditions(want).get("log_held") == 1.0                   # (the CSV is read as held)
    for got in (load_log(p).signals, _streamed(p, 333).signals, _streamed(p, 20000).signals):
        assert len(got) == len(want) == len(t)
        np.testing.assert_allclose(got.t, want.t, rtol=0, atol=1e-9)
        np.testing.assert_allclose(got.t, t, rtol=0, atol=1e-9)           # the stamps as stored
        for k in SIG[1:]:
            np.testing.assert_array_equal(getattr(got, k), getattr(want, k), err_msg=k)
        np.testing.assert_array_equal(got.ay, cols["ay"])
        assert held_copies(got).mean() == held_copies(want).mean() > 0.85
        assert log_conditions(got).get("log_held") == 1.0


def test_one_group_keeps_its_stamps_unless_the_map_asks_otherwise(tmp_path):
    """A 50 Hz raster with 20 us of jitter in one group: "auto" and "clock" read its stamps and values as stored,
    whole and streamed; "uniform" interpolates onto the 100 Hz grid from the first stamp as before; the same
    channels in two groups (identical stamps) keep their own clocks, interpolated as before."""
    rng = np.random.default_rng(3)
    n = 1500
    t = 5.0 + np.arange(n) / 50.0 + rng.uniform(-20e-6, 20e-6, n)
    cols = {"vx": 15.0 + np.sin(t / 4), "ay": 0.5 * np.sin(t) + 0.02 * rng.standard_normal(n),
            "r": 0.03 * np.cos(t) + 0.002 * rng.standard_normal(n), "p": 0.01 * np.sin(t / 2)}
    one = _mdf(tmp_path / "one.mf4", t, cols)
    two = _mdf(tmp_path / "two.mf4", t, cols, groups=[["vx"], ["ay", "r", "p"]])
    for tb in ("auto", "clock"):
        (tmp_path / f"{tb}.toml").write_text(MAP.format(tb=tb))
        for got in (load_log(one, channels=tmp_path / f"{tb}.toml").signals,
                    _streamed(one, 97, channels=tmp_path / f"{tb}.toml").signals, load_log(one).signals):
            np.testing.assert_array_equal(got.t, t)
            for k in cols:
                np.testing.assert_array_equal(getattr(got, k), cols[k], err_msg=(tb, k))
    (tmp_path / "uniform.toml").write_text(MAP.format(tb="uniform"))
    for p, m in ((one, "uniform.toml"), (two, "auto.toml"), (two, "uniform.toml")):
        for got in (load_log(p, channels=tmp_path / m).signals, _streamed(p, 97, channels=tmp_path / m).signals):
            np.testing.assert_allclose(got.t, t[0] + np.arange(len(got)) / 100.0, rtol=0, atol=1e-9, err_msg=m)
            assert len(got) == int((t[-1] - t[0]) * 100.0) + 1
            np.testing.assert_allclose(got.ay, np.interp(got.t, t, cols["ay"]), rtol=0, atol=1e-12, err_msg=m)


@pytest.mark.parametrize("at", [96, 97, 98, 500])
def test_one_groups_damaged_stamp_is_repaired_as_a_tables_clock(tmp_path, at):
    """A stamp of the group repeated (at a chunk boundary of 97 records, or inside one): repaired as a table's clock
    is, whole and streamed alike -- both samples of the pair flagged, the repair counted once (one clock), every
    other sample on its stamp with its value as stored."""
    n = 1000
    t = np.arange(n) / 100.0
    t[at] = t[at - 1]
    cols = {"vx": 15.0 + np.sin(t), "ay": 0.5 * np.sin(t), "r": 0.03 * np.cos(t), "p": 0.01 * np.sin(t)}
    p = _mdf(tmp_path / "dup.mf4", t, cols)
    whole = load_log(p)
    parts = list(stream_log(p, chunk_rows=97))
    got = concat_logs(parts)
    for k in SIG:
        np.testing.assert_array_equal(getattr(got.signals, k), getattr(whole.signals, k), err_msg=k)
    assert whole.time_repairs["duplicate"] == 1
    assert sum(c.time_repairs.get("duplicate", 0) for c in parts) == 1
    s = whole.signals
    kept = np.isfinite(s.ay)
    assert (~kept).sum() <= 2                                        # the pair, flagged
    np.testing.assert_array_equal(s.ay[kept], np.interp(s.t[kept], np.delete(t, at), np.delete(cols["ay"], at)))
    np.testing.assert_array_equal(np.sort(np.unique(s.t)), np.unique(t))

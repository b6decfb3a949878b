"""``load_log`` is the concatenation of ``stream_log``: for every format both read, the signals of the
whole-file read equal the chunks' signals put end to end (every channel, NaN where NaN), at two chunk
sizes, on the shipped real drives and on files written here from seeded random draws (rates, jitter,
gaps, missing values, damaged time stamps that the time-stamp repair fixes).

Truth is the whole-file path, itself tested against hand-made files in test_io_readers.py and
test_timestamps.py; the streamed path must reproduce it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from roadbank.io import load_log
from roadbank.io.stream import stream_log

SIG = ("t", "vx", "ay", "r", "delta_f")
DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
KITTI = sorted((DATA / "kitti-oxts").glob("*/oxts")) if (DATA / "kitti-oxts").is_dir() else []
#: every shipped drive, the validation drives and the training ones
DRIVES = sorted(DATA.glob("kitti-oxts*/*/oxts"))
COMMA = DATA / "comma2k19-example"
CHUNKS = (61, 1000)


def assert_stream_equals_load(path, chunk_rows, channels=None, format=None, more=(), counts=True):
    """The chunks of ``stream_log`` put end to end equal ``load_log`` (to 1e-12, NaN where NaN) on every
    signal channel, every truth column and on ``more``: names of ``reference_roll`` / ``extra[...]``
    entries to compare too; with ``counts``, the chunks' time-stamp repair counts add up to the whole file's."""
    whole = load_log(path, channels=channels, format=format)
    chunks = list(stream_log(path, channels=channels, format=format, chunk_rows=chunk_rows))
    assert chunks, path
    for k in SIG:
        got = np.concatenate([getattr(c.signals, k) for c in chunks])
        want = getattr(whole.signals, k)
        assert got.shape == want.shape, (k, got.shape, want.shape)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12, equal_nan=True, err_msg=k)
    for name in more:
        part = (lambda c: c.reference_roll) if name == "reference_roll" else (lambda c, n=name: c.extra[n])
        np.testing.assert_allclose(np.concatenate([part(c) for c in chunks]), part(whole), rtol=0, atol=1e-12,
                                   equal_nan=True, err_msg=name)
    for name in whole.truth:                 # truth columns too, on the table clock or resampled
        assert all(name in c.truth for c in chunks), name
        np.testing.assert_allclose(np.concatenate([c.truth[name] for c in chunks]), whole.truth[name], rtol=0,
                                   atol=1e-12, equal_nan=True, err_msg=name)
    total: dict = {}
    for c in chunks:
        for kind, v in c.time_repairs.items():
            total[kind] = total.get(kind, 0) + v
    assert not counts or {k: v for k, v in total.items() if v} == {k: v for k, v in whole.time_repairs.items() if v}
    return whole, chunks


# ------------------------------------------------------------------ the shipped real drives

needs_kitti = pytest.mark.skipif(not KITTI, reason=f"KITTI oxts drives absent at {DATA / 'kitti-oxts'}")


@needs_kitti
@pytest.mark.parametrize("chunk", CHUNKS)
@pytest.mark.parametrize("drive", DRIVES, ids=lambda d: d.parent.name)
def test_kitti_drive(drive, chunk):
    """A drive is streamed in frames (several chunks at 61 frames): the chunks end to end are the
    whole drive bit for bit (the frames' own clock, nothing interpolated), and the whole drive is
    what ``load_kitti_oxts`` reads."""
    from roadbank.io.kitti import load_kitti_oxts
    whole, chunks = assert_stream_equals_load(drive.parent, chunk,
                                              more=("reference_roll", "lat_deg", "lon_deg", "vl_mps"))
    assert len(chunks) == -(-len(whole) // chunk)          # one chunk per chunk_rows frames
    for k in SIG:
        np.testing.assert_array_equal(np.concatenate([getattr(c.signals, k) for c in chunks]),
                                      getattr(whole.signals, k))
    np.testing.assert_array_equal(np.concatenate([c.reference_roll for c in chunks]), whole.reference_roll)
    assert [w for c in chunks for w in c.warnings] == whole.warnings
    direct = load_kitti_oxts(drive)
    for k in SIG:
        np.testing.assert_array_equal(getattr(direct.signals, k), getattr(whole.signals, k))
    assert direct.metadata == whole.metadata and direct.extra.keys() == whole.extra.keys()


@pytest.mark.skipif(not COMMA.is_dir(), reason=f"comma2k19 example segment absent at {COMMA}")
@pytest.mark.parametrize("chunk", CHUNKS)
def test_comma2k19_segment(chunk):
    """A segment is one chunk whatever ``chunk_rows``, and ``load_comma2k19`` reads the same log."""
    from roadbank.io.comma2k19 import load_comma2k19
    whole, chunks = assert_stream_equals_load(COMMA, chunk, more=("reference_roll", "lat_deg", "lon_deg"))
    assert len(chunks) == 1
    direct = load_comma2k19(COMMA)
    for k in SIG:
        np.testing.assert_array_equal(getattr(direct.signals, k), getattr(whole.signals, k))
    np.testing.assert_array_equal(direct.reference_roll, whole.reference_roll)


REAL_MAP = """
[channels]
time = { column = "t", unit = "s" }
speed = { column = "vf", unit = "m/s" }
lateral_acceleration = { column = "ay", unit = "m/s^2" }
yaw_rate = { column = "wz", unit = "rad/s" }
road_wheel_angle = { column = "delta", unit = "rad" }
reference_roll = { column = "roll", unit = "rad" }
latitude = { column = "lat", unit = "deg" }
longitude = { column = "lon", unit = "deg" }
"""


def _kitti_columns(drive):
    """The real drive's samples as roadbank-readable columns (its own, irregular, clock); the steering
    angle, which KITTI does not log, a smooth made-up one."""
    log = load_log(drive.parent)
    s = log.signals
    return {"t": s.t, "vf": s.vx, "ay": s.ay, "wz": s.r, "delta": 0.02 * np.sin(0.3 * s.t),
            "roll": log.reference_roll, "lat": log.extra["lat_deg"], "lon": log.extra["lon_deg"]}


@needs_kitti
@pytest.mark.parametrize("chunk", (37, 250))
def test_kitti_values_as_parquet(tmp_path, chunk):
    cols = _kitti_columns(KITTI[0])
    p = tmp_path / "kitti.parquet"
    pq.write_table(pa.table(cols), p)
    (tmp_path / "m.toml").write_text(REAL_MAP)
    whole, chunks = assert_stream_equals_load(p, chunk, channels=tmp_path / "m.toml",
                                              more=("reference_roll", "lat_deg", "lon_deg"))
    assert len(chunks) > 1
    np.testing.assert_array_equal(whole.signals.t, cols["t"])          # the table clock is kept


@needs_kitti
@pytest.mark.parametrize("chunk", (37, 250))
def test_kitti_values_as_mdf4(tmp_path, chunk):
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal
    cols = _kitti_columns(KITTI[-1])
    t = cols.pop("t")
    mdf = MDF(version="4.10")
    mdf.append([Signal(cols[c], t, name=c) for c in ("ay", "wz", "roll")])
    mdf.append([Signal(cols[c], t, name=c) for c in ("vf", "delta", "lat", "lon")])
    p = tmp_path / "kitti.mf4"
    mdf.save(p)
    (tmp_path / "m.toml").write_text(REAL_MAP)
    _, chunks = assert_stream_equals_load(p, chunk, channels=tmp_path / "m.toml",
                                          more=("reference_roll", "lat_deg", "lon_deg"))
    assert len(chunks) > 1


# ------------------------------------------------------------------ written files, seeded draws

def _damage(t, rng, n_each, missing=True):
    """Damage a clock as loggers do (duplicates, swapped pairs, isolated late / early stamps, missing
    stamps unless ``missing=False``) at random rows, and a pause; the time-stamp repair can undo all of it."""
    t = t.copy()
    n = len(t)
    rows = rng.choice(np.arange(10, n - 10, 7), size=5 * n_each, replace=False).reshape(5, n_each)  # 7 apart
    t[rows[0]] = t[rows[0] - 1]                               # duplicated stamps
    for i in rows[1]:
        t[i], t[i + 1] = t[i + 1], t[i]                       # swapped pairs
    t[rows[2]] += 5.0                                         # isolated late stamps
    t[rows[3]] -= 4.0                                         # isolated early stamps
    if missing:
        t[rows[4]] = np.nan                                   # missing stamps
    t[n // 2:] += 1.5                                         # the logger paused: a gap, kept
    return t


def _table(seed, mixed):
    """Columns t, vx, ay, r, delta_f, reference roll and truth: one clock (``mixed=False``) or channels
    at their own rates on the union of their stamps, NaN between (``mixed=True``)."""
    rng = np.random.default_rng(seed)
    rate = float(rng.choice([20.0, 50.0, 100.0, 200.0]))
    n = int(rng.integers(600, 2500))
    t = 3.0 + np.arange(n) / rate + rng.uniform(-0.1, 0.1, n) / rate
    t.sort()
    wave = {"vx": 15.0 + 3 * np.sin(0.1 * t), "ay": 0.8 * np.sin(0.4 * t) + 0.02 * rng.standard_normal(n),
            "r": 0.05 * np.sin(0.4 * t + 0.2), "delta_f": 0.01 * np.sin(0.4 * t - 0.1),
            "roll": 0.03 * np.sin(0.05 * t), "true_phi_b": 0.02 * np.cos(0.05 * t)}
    cols = {"t": t}
    for k, v in wave.items():
        v = v.copy()
        if mixed and k in ("vx", "delta_f"):     # slower channels: every 2nd / 5th row only
            v[np.arange(n) % (2 if k == "vx" else 5) != 0] = np.nan
        v[rng.random(n) < 0.01] = np.nan         # scattered missing values
        cols[k] = v
    return cols


MAP = """
[resample]
time_base = "{tb}"
rate_hz = {rate}
max_gap_s = {gap}

[channels]
time = {{ column = "t", unit = "s" }}
speed = {{ column = "vx", unit = "m/s" }}
lateral_acceleration = {{ column = "ay", unit = "m/s^2" }}
yaw_rate = {{ column = "r", unit = "rad/s" }}
road_wheel_angle = {{ column = "delta_f", unit = "rad" }}
reference_roll = {{ column = "roll", unit = "rad" }}
"""

CASES = [(seed, mixed, damaged, tb) for seed, (mixed, damaged, tb) in enumerate(
    [(False, False, "auto"), (False, True, "auto"), (True, False, "auto"), (True, True, "auto"),
     (False, True, "uniform"), (True, True, "uniform"), (False, True, "lateral_acceleration"),
     (True, True, "lateral_acceleration"), (False, True, "auto"), (True, True, "uniform")])]


@pytest.mark.parametrize("chunk", CHUNKS)
@pytest.mark.parametrize("seed,mixed,damaged,tb", CASES,
                         ids=[f"{s}-{'mixed' if m else 'one-rate'}-{'damaged' if d else 'clean'}-{tb}"
                              for s, m, d, tb in CASES])
@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_written_table(tmp_path, monkeypatch, suffix, seed, mixed, damaged, tb, chunk):
    from roadbank.io import csvtable
    from roadbank.io.writers import write_table
    monkeypatch.setattr(csvtable, "CSV_WHOLE_BYTES", 0)      # streamed whatever its size (a CSV of 600-2500 lines)
    rng = np.random.default_rng(1000 + seed)
    cols = _table(seed, mixed)
    if damaged:
        cols["t"] = _damage(cols["t"], rng, 3)
    p = tmp_path / f"log{suffix}"
    write_table(p, cols)
    (tmp_path / "m.toml").write_text(MAP.format(tb=tb, rate=float(rng.choice([25.0, 100.0])),
                                                gap=float(rng.choice([0.2, 0.5]))))
    whole, chunks = assert_stream_equals_load(p, chunk, channels=tmp_path / "m.toml", more=("reference_roll",))
    if damaged:
        assert whole.time_repairs.get("duplicate", 0) > 0 and whole.time_repairs.get("flagged", 0) > 0
    if chunk < len(cols["t"]) // 2:
        assert len(chunks) > 1


def test_auto_time_base_is_decided_on_the_whole_log(tmp_path):
    """One clock, 50 Hz with jitter; the speed sensor gives every 3rd sample only during the first second:
    the first chunk alone would be resampled onto the uniform grid, the whole log keeps the table clock."""
    from roadbank.io.writers import write_table
    rng = np.random.default_rng(7)
    n = 2000
    t = np.arange(n) / 50.0 + rng.uniform(-0.002, 0.002, n)
    vx = 15.0 + np.sin(0.1 * t)
    vx[:60][np.arange(60) % 3 != 0] = np.nan
    cols = {"t": t, "vx": vx, "ay": 0.5 * np.sin(0.4 * t), "r": 0.03 * np.sin(0.4 * t), "delta_f": 0.01 * np.sin(t)}
    p = tmp_path / "log.parquet"
    write_table(p, cols)
    whole = load_log(p)
    np.testing.assert_array_equal(whole.signals.t, t)                     # the whole file: the table clock
    assert_stream_equals_load(p, 200)


def test_sample_after_a_dropped_stamp_stays_flagged_across_the_held_rows(tmp_path):
    """An isolated early stamp on the row just before the rows a chunk holds back for the next one: the
    sample after it is flagged not valid (NaN) by the whole file's repair, and so in the stream."""
    from roadbank.io.stream import HOLD_ROWS
    from roadbank.io.writers import write_table
    n, chunk = 400, 61
    t = np.arange(n) / 100.0
    row = chunk - HOLD_ROWS - 1
    t[row] -= 0.3
    cols = {"t": t, "vx": 15.0 + np.sin(t), "ay": 0.5 * np.sin(t), "r": 0.03 * np.cos(t), "delta_f": 0.01 * t}
    p = tmp_path / "log.parquet"
    write_table(p, cols)
    whole, chunks = assert_stream_equals_load(p, chunk)
    assert np.isnan(whole.signals.vx[row]) and whole.time_repairs["flagged"] == 1   # the row after the dropped one
    assert len(chunks) > 1


MDF_MAP = MAP                # (the time channel is not used for MDF4: each channel has its own clock)


@pytest.mark.parametrize("chunk", CHUNKS)
@pytest.mark.parametrize("seed", range(6))
def test_written_mdf4(tmp_path, seed, chunk):
    """MDF4, every channel group on its own clock (rates, offsets, jitter), one clock damaged."""
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal
    rng = np.random.default_rng(seed)
    dur = float(rng.uniform(8.0, 30.0))
    groups = {}
    for names in (("ay", "r"), ("vx",), ("delta_f", "roll")):
        rate = float(rng.choice([10.0, 20.0, 50.0, 100.0, 200.0]))
        n = int(dur * rate)
        t = float(rng.uniform(0.0, 0.3)) + np.arange(n) / rate + rng.uniform(-0.05, 0.05, n) / rate
        t.sort()
        groups[names] = t
    damaged = list(groups)[seed % 3]
    # (no missing stamps: asammdf rewrites a master channel holding NaN when the group is appended)
    groups[damaged] = _damage(groups[damaged], rng, 2, missing=False)
    mdf = MDF(version="4.10")
    for names, t in groups.items():
        sig = {"ay": 0.8 * np.sin(0.4 * t), "r": 0.05 * np.sin(0.4 * t + 0.2), "vx": 15.0 + 3 * np.sin(0.1 * t),
               "delta_f": 0.01 * np.sin(0.4 * t - 0.1), "roll": 0.03 * np.sin(0.05 * t)}
        mdf.append([Signal(sig[c], t, name=c) for c in names])
    p = tmp_path / "log.mf4"
    mdf.save(p)
    tb = ["auto", "uniform", "lateral_acceleration"][seed % 3]
    (tmp_path / "m.toml").write_text(MDF_MAP.format(tb=tb, rate=float(rng.choice([25.0, 100.0])), gap=0.5))
    whole, chunks = assert_stream_equals_load(p, chunk, channels=tmp_path / "m.toml", more=("reference_roll",))
    assert whole.time_repairs.get("flagged", 0) > 0


def test_mdf4_repairs_after_the_common_span_are_counted(tmp_path):
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal
    t = np.arange(1000) / 100.0
    ts = np.arange(1200) / 100.0          # the speed channel runs 2 s longer than the others
    ts[1150] = ts[1149]                   # a duplicate stamp in that last part
    mdf = MDF(version="4.10")
    mdf.append([Signal(0.5 * np.sin(t), t, name="ay"), Signal(0.03 * np.cos(t), t, name="r"),
                Signal(0.01 * t, t, name="delta_f"), Signal(0.0 * t, t, name="roll")])
    mdf.append([Signal(15.0 + np.sin(ts), ts, name="vx")])
    p = tmp_path / "log.mf4"
    mdf.save(p)
    (tmp_path / "m.toml").write_text(MDF_MAP.format(tb="uniform", rate=100.0, gap=0.5))
    whole = load_log(p, channels=tmp_path / "m.toml")
    assert whole.time_repairs["duplicate"] == 1
    assert_stream_equals_load(p, 100, channels=tmp_path / "m.toml")


@pytest.mark.parametrize("bad", [False, True])
def test_mdf4_text_channel_is_read_alike_whole_and_streamed(tmp_path, bad):
    """An MDF4 channel stored as text: its numbers read the same whole and streamed, and a sample
    that is no number is the same error (naming the channel and the sample) either way."""
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal

    from roadbank.io import LogError
    t = np.arange(500) / 100.0
    vx = [f"{15.0 + np.sin(x):.6f}".encode() for x in t]
    if bad:
        vx[321] = b"n/a?"
    mdf = MDF(version="4.10")
    mdf.append([Signal(0.5 * np.sin(t), t, name="ay"), Signal(0.03 * np.cos(t), t, name="r"),
                Signal(0.01 * t, t, name="delta_f")])
    mdf.append([Signal(np.array(vx), t, name="vx", encoding="utf-8")])
    p = tmp_path / "text.mf4"
    mdf.save(p)
    if not bad:
        whole, _ = assert_stream_equals_load(p, 100)
        np.testing.assert_allclose(whole.signals.vx[:3], 15.0 + np.sin(whole.signals.t[:3]), atol=1e-6)
        return
    with pytest.raises(LogError) as whole:
        load_log(p)
    with pytest.raises(LogError) as streamed:
        list(stream_log(p, chunk_rows=100))
    assert str(whole.value) == str(streamed.value)
    assert "'speed'" in str(whole.value) and "sample 321" in str(whole.value)


# ------------------------------------------------------------------ checks decided on the log's start

def test_consistency_is_decided_on_the_turns_after_a_straight(tmp_path):
    """Speed logged in km/h but declared m/s (54 "m/s" at 15 m/s, plausible on its own): the first 30 s
    run straight, so the first chunks hold no turning sample and cannot tell; the turns that follow
    do, whole and streamed alike (streamed, the error comes with the chunk where the turns start)."""
    from roadbank.io import LogError
    from roadbank.io.writers import write_table
    rng = np.random.default_rng(3)
    n = 6000
    t = np.arange(n) / 100.0
    r = np.where(t < 30.0, 0.0, 0.3 + 0.02 * np.sin(t)) + 0.001 * rng.standard_normal(n)
    v = 15.0 + 0.1 * np.sin(0.1 * t)
    cols = {"t": t, "vx": 3.6 * v, "ay": v * r + 0.05 * rng.standard_normal(n), "r": r, "delta_f": 0.01 * r}
    p = tmp_path / "kmh.parquet"
    write_table(p, cols)
    with pytest.raises(LogError, match="channel 'speed' .*looks like km/h"):
        load_log(p)
    got = []
    with pytest.raises(LogError, match="channel 'speed' .*looks like km/h"):
        for c in stream_log(p, chunk_rows=1000):
            got.append(c)
    assert sum(len(c) for c in got) <= 3000            # nothing of the turns was given


def test_a_consistent_log_streams_as_it_loads_when_the_turns_come_late(tmp_path):
    """The same drive with the speed in m/s: no error, and the chunks are the whole log."""
    from roadbank.io.writers import write_table
    rng = np.random.default_rng(3)
    n = 6000
    t = np.arange(n) / 100.0
    r = np.where(t < 30.0, 0.0, 0.3 + 0.02 * np.sin(t)) + 0.001 * rng.standard_normal(n)
    v = 15.0 + 0.1 * np.sin(0.1 * t)
    cols = {"t": t, "vx": v, "ay": v * r + 0.05 * rng.standard_normal(n), "r": r, "delta_f": 0.01 * r}
    p = tmp_path / "ok.parquet"
    write_table(p, cols)
    whole, chunks = assert_stream_equals_load(p, 1000)
    assert whole.warnings == [] and len(chunks) > 3


@pytest.mark.parametrize("chunk", (2, 3, 61))
def test_time_unit_is_checked_on_small_chunks(tmp_path, chunk):
    """Time stamps in ms declared s (a 10 s "period"): refused whole and streamed, also when the first
    chunk holds too few stamps for a median period (two rows)."""
    from roadbank.io import LogError
    from roadbank.io.writers import write_table
    n = 400
    t = np.arange(n) * 10.0
    cols = {"t": t, "vx": 15.0 + np.sin(t), "ay": 0.5 * np.sin(t), "r": 0.03 * np.cos(t), "delta_f": 0.01 * np.sin(t)}
    p = tmp_path / "ms.parquet"
    write_table(p, cols)
    with pytest.raises(LogError, match="median sample period 10 s"):
        load_log(p)
    with pytest.raises(LogError, match="median sample period 10 s"):
        list(stream_log(p, chunk_rows=chunk))


CLOCK_MAP = MAP.format(tb="clock", rate=100.0, gap=0.5)


@pytest.mark.parametrize("chunk", CHUNKS)
def test_clock_time_base_keeps_the_table_clock(tmp_path, chunk):
    """``time_base = "clock"``: the table's own stamps whatever the channels' rates (the speed every 3rd
    row only, which "auto" would resample), values as stored, NaN where NaN."""
    from roadbank.io.writers import write_table
    cols = _table(5, mixed=True)
    vx = cols["vx"].copy()
    vx[np.arange(len(vx)) % 3 != 0] = np.nan
    cols["vx"] = vx
    p = tmp_path / "log.parquet"
    write_table(p, cols)
    (tmp_path / "m.toml").write_text(CLOCK_MAP)
    whole, _ = assert_stream_equals_load(p, chunk, channels=tmp_path / "m.toml", more=("reference_roll",))
    np.testing.assert_array_equal(whole.signals.t, cols["t"])
    np.testing.assert_array_equal(whole.signals.vx, cols["vx"])
    np.testing.assert_array_equal(whole.reference_roll, cols["roll"])
    (tmp_path / "a.toml").write_text(MAP.format(tb="auto", rate=100.0, gap=0.5))
    assert len(load_log(p, channels=tmp_path / "a.toml")) != len(cols["t"])     # (auto: resampled)


def test_clock_time_base_needs_a_table(tmp_path):
    """MDF4 channels in two channel groups have no one clock: "clock" refused. (Channels of one group share its
    stamps, a table's clock: there "clock" keeps them, test_mdf4_of_one_group_is_read_on_its_clock.)"""
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal

    from roadbank.io import LogError
    t = np.arange(500) / 100.0
    mdf = MDF(version="4.10")
    mdf.append([Signal(0.5 * np.sin(t), t, name="ay"), Signal(0.03 * np.cos(t), t, name="r"),
                Signal(0.01 * t, t, name="delta_f"), Signal(0.0 * t, t, name="roll")])
    mdf.append([Signal(15.0 + t, t, name="vx")])
    p = tmp_path / "log.mf4"
    mdf.save(p)
    (tmp_path / "m.toml").write_text(CLOCK_MAP)
    with pytest.raises(LogError, match=r"log\.mf4: resample\.time_base 'clock' needs a table"):
        load_log(p, channels=tmp_path / "m.toml")


@pytest.mark.parametrize("version", ["4.10", "3.30"])
def test_mdf_invalidation_bits_are_dropouts_whole_and_streamed(tmp_path, version):
    """Samples an MDF4 file flags invalid (invalidation bits) hold garbage: read as missing (NaN at their time
    stamps, bridged as any short dropout, the same whole and streamed), never as data. MDF 3 (no invalidation
    bits) streams as it reads whole (it failed on a missing block field)."""
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal
    t = np.arange(1000) / 100.0
    r = 0.03 * np.cos(t)
    bad = np.zeros(t.size, dtype=bool)
    if version.startswith("4"):
        bad[400:406] = True
        r[bad] = 32.767                     # what a sensor's "invalid" raw value decodes to
    mdf = MDF(version=version)
    mdf.append([Signal(15.0 + np.sin(t), t, name="vx"), Signal(0.5 * np.sin(t), t, name="ay"),
                Signal(r, t, name="r", invalidation_bits=bad if bad.any() else None),
                Signal(0.01 * t, t, name="delta_f"), Signal(0.0 * t, t, name="roll")])
    p = tmp_path / ("log.mf4" if version.startswith("4") else "log.mdf")
    mdf.save(p)
    (tmp_path / "m.toml").write_text(MDF_MAP.format(tb="uniform", rate=100.0, gap=0.5))
    whole, _ = assert_stream_equals_load(p, 61, channels=tmp_path / "m.toml")
    s = whole.signals
    assert np.nanmax(np.abs(s.r)) < 0.031                       # the garbage never read ...
    at = np.isin(np.round(s.t, 6), np.round(t[bad], 6))
    assert at.sum() == bad.sum()
    np.testing.assert_allclose(s.r[at], 0.03 * np.cos(s.t[at]), atol=3e-5)   # ... a short dropout, bridged


@pytest.mark.parametrize("fmt", ["parquet", "mdf4"])
@pytest.mark.parametrize("at", [99, 100, 101])
def test_stamp_repeated_across_a_chunk_boundary(tmp_path, fmt, at):
    """A stamp repeated as the first sample of a chunk (the chunk before it ending cleanly): both samples flagged,
    as in the whole file's repair, whatever the chunking (the first of the pair had been passed on unflagged)."""
    t = np.arange(1000) / 100.0
    t[at] = t[at - 1]
    cols = {"t": t, "vx": 15.0 + np.sin(t), "ay": 0.5 * np.sin(t), "r": 0.03 * np.cos(t), "delta_f": 0.01 * t,
            "roll": 0.0 * t}
    if fmt == "parquet":
        p = tmp_path / "log.parquet"
        pq.write_table(pa.table(cols), p)
    else:
        pytest.importorskip("asammdf")
        from asammdf import MDF, Signal
        mdf = MDF(version="4.10")
        mdf.append([Signal(v, t, name=k) for k, v in cols.items() if k != "t"])
        p = tmp_path / "log.mf4"
        mdf.save(p)
    (tmp_path / "m.toml").write_text(MAP.format(tb="uniform", rate=100.0, gap=0.5))
    whole, _ = assert_stream_equals_load(p, 50, channels=tmp_path / "m.toml", more=("reference_roll",))
    assert whole.time_repairs["duplicate"] >= 1
    assert whole.time_repairs["flagged"] >= 1

"""Tables whose rows do not each carry every channel: "long" tables (each channel, or each bus message, on
its own rows, blank elsewhere) and channels slower than the resampler's gap.

Truth: the functions the synthetic logs are sampled from (a constant 2 deg bank: ay = vx r + g sin(bank),
so the bank estimate must read 2 deg), the samples written (each one must be read), the damage and pauses
put in by hand (a duplicated stamp, a 2 s pause, a lost GNSS fix), and the whole-file read for the stream.
"""

from __future__ import annotations

import numpy as np
import pytest

from roadbank import estimators
from roadbank.constants import G
from roadbank.defaults import ESTIMATOR
from roadbank.io import load_log
from roadbank.io.stream import stream_log
from roadbank.io.writers import write_table

BANK = np.radians(2.0)
N = 6000                                          # 60 s at 100 Hz


def vx_of(t):
    return 15.0 + np.sin(t / 7.0)


def r_of(t):
    return 0.1 * np.sin(t / 3.0)


def ay_of(t):
    return vx_of(t) * r_of(t) + G * np.sin(BANK)


def _rows(t, **channels):
    """Rows at stamps ``t`` carrying ``channels`` (name -> function of t), blank in the other columns."""
    return {"t": t, **{c: (channels[c](t) if c in channels else np.full(len(t), np.nan)) for c in ("vx", "ay", "r")}}


def _long(*parts):
    """The rows of ``parts`` in one table, sorted by stamp (stable: equal stamps keep the parts' order)."""
    cols = {c: np.concatenate([p[c] for p in parts]) for c in ("t", "vx", "ay", "r")}
    order = np.argsort(cols["t"], kind="stable")
    return {c: a[order] for c, a in cols.items()}


def _stamps(n=N, rate=100.0):
    return np.round(np.arange(n) / rate, 6)


def _bank_deg(log):
    res = estimators.make(ESTIMATOR).run(log.signals)
    return float(np.degrees(np.median(res.theta[res.valid]))), float(np.mean(res.valid))


def _assert_truth(log, tol):
    """Every channel on the log's time base equals the function it was sampled from (to ``tol``)."""
    s = log.signals
    assert np.isfinite(s.vx).all() and np.isfinite(s.ay).all() and np.isfinite(s.r).all()
    for got, f in ((s.vx, vx_of), (s.ay, ay_of), (s.r, r_of)):
        np.testing.assert_allclose(got, f(s.t), rtol=0, atol=tol)


def _stream_equals_load(p, chunk):
    whole = load_log(p)
    chunks = list(stream_log(p, chunk_rows=chunk))
    for k in ("t", "vx", "ay", "r"):
        np.testing.assert_array_equal(np.concatenate([getattr(c.signals, k) for c in chunks]),
                                      getattr(whole.signals, k), err_msg=k)
    total: dict = {}
    for c in chunks:
        for kind, v in c.time_repairs.items():
            total[kind] = total.get(kind, 0) + v
    assert {k: v for k, v in total.items() if v} == {k: v for k, v in whole.time_repairs.items() if v}
    assert sum(1 for c in chunks for w in c.warnings if "sampled every" in w) == \
        sum(1 for w in whole.warnings if "sampled every" in w)
    return whole, chunks


# ------------------------------------------------------------------ long tables: rows of one instant

def same_stamp_table():
    """ay and r on their own rows at the same 100 Hz stamps; the speed on its own rows 5 ms later."""
    t = _stamps()
    return _long(_rows(t, ay=ay_of), _rows(t, r=r_of), _rows(t + 0.005, vx=vx_of))


def imu_and_speed_table(speed_first: bool):
    """IMU rows (ay, r) at 100 Hz and speed rows at 10 Hz on the same clock: each speed stamp is an IMU stamp."""
    t = _stamps()
    imu, spd = _rows(t, ay=ay_of, r=r_of), _rows(t[::10], vx=vx_of)
    return _long(spd, imu) if speed_first else _long(imu, spd)


LONG = {"same-stamp": same_stamp_table, "imu-first": lambda: imu_and_speed_table(False),
        "speed-first": lambda: imu_and_speed_table(True)}


@pytest.mark.parametrize("layout", list(LONG))
def test_long_table_keeps_every_sample_and_reads_the_bank(tmp_path, layout):
    cols = LONG[layout]()
    assert len(np.unique(cols["t"])) < len(cols["t"])             # (rows do share stamps)
    p = tmp_path / "long.csv"
    write_table(p, cols)
    log = load_log(p)
    assert not any(log.time_repairs.get(k, 0) for k in ("duplicate", "flagged", "out_of_order", "gaps"))
    # the 100 Hz grid over the overlap: the same stamps as the IMU's (or 5 ms later), every one valid
    assert len(log) == (5999 if layout == "same-stamp" else 5991)
    _assert_truth(log, 1e-4)                       # linear interpolation of 10 Hz / 100 Hz samples of smooth waves
    bank, valid = _bank_deg(log)
    assert valid > 0.99 and bank == pytest.approx(2.0, abs=0.05)


@pytest.mark.parametrize("chunk", [2, 3, 61, 1000])
@pytest.mark.parametrize("layout", list(LONG))
def test_long_table_streamed_equals_whole(tmp_path, layout, chunk):
    """Chunk boundaries fall between rows of one instant (chunks of 2 and 3 rows split most of them)."""
    p = tmp_path / "long.parquet"
    write_table(p, LONG[layout]())
    whole, chunks = _stream_equals_load(p, chunk)
    assert len(chunks) > 1 and np.isfinite(whole.signals.ay).all()


def test_a_stamp_repeated_for_the_same_channel_is_still_a_duplicate(tmp_path):
    """In a long table, an IMU row written twice (and a speed row at the same stamp): one duplicate dropped and
    the instant flagged, as in a table with every channel on every row. The repeated row's ay is 5 m/s^2 off:
    flagged, it is not used (a gap on the uniform grid, bridged from its neighbours; NaN on the table clock)."""
    cols = imu_and_speed_table(False)
    k = int(np.flatnonzero(cols["t"] == 12.3)[0])          # the IMU row at 12.3 s (a speed stamp too)
    assert np.isfinite(cols["ay"][k]) and np.isfinite(cols["vx"][k + 1])
    cols["ay"][k] += 5.0
    long = {c: np.insert(a, k + 1, a[k]) for c, a in cols.items()}          # IMU row, IMU row again, speed row
    t = _stamps()
    wide = {"t": t, "vx": vx_of(t), "ay": ay_of(t), "r": r_of(t)}
    wide["ay"][1230] += 5.0
    wide = {c: np.insert(a, 1230, a[1230]) for c, a in wide.items()}
    for name, table in (("long", long), ("wide", wide)):
        p = tmp_path / f"{name}.parquet"
        write_table(p, table)
        log = load_log(p)
        assert log.time_repairs["duplicate"] == 1 and log.time_repairs["flagged"] == 1, name
        assert any("1 duplicate stamp dropped" in w for w in log.warnings), name
        s = log.signals
        at = int(np.flatnonzero(np.isclose(s.t, 12.3))[0])
        if name == "long":          # channels at different rates: the uniform grid
            np.testing.assert_allclose(s.ay[at], ay_of(s.t[at]), rtol=0, atol=1e-4)
        else:                       # one rate: the table clock as it is
            assert np.isnan(s.ay[at]) and np.isfinite(np.delete(s.ay, at)).all()
        for chunk in (61, 1000):
            _stream_equals_load(p, chunk)


def test_a_blank_row_at_a_channels_stamp_adds_nothing(tmp_path):
    """A row whose every channel is blank (a bus message the map does not read) at an IMU row's stamp."""
    t = _stamps()
    cols = _long(_rows(t, ay=ay_of, r=r_of), _rows(t[::10], vx=vx_of), _rows(t[5::50]))
    p = tmp_path / "blank.csv"
    write_table(p, cols)
    log = load_log(p)
    assert not log.time_repairs.get("duplicate") and not log.time_repairs.get("flagged")
    _assert_truth(log, 1e-4)


# ------------------------------------------------------------------ gaps of a long table

def interleaved_table(pause: bool):
    """ay, r and the speed each at 100 Hz on its own rows, 1 ms apart (no shared stamp): the step between
    rows (1, 1, 8 ms) is no channel's period. ``pause``: the logger stops for 2 s at 30 s."""
    t = _stamps()
    if pause:
        t = t + 2.0 * (t >= 30.0)
    return _long(_rows(t, ay=ay_of), _rows(t + 0.001, r=r_of), _rows(t + 0.002, vx=vx_of))


@pytest.mark.parametrize("pause", [False, True])
def test_long_table_gaps_are_counted_on_the_channels_period(tmp_path, pause):
    p = tmp_path / "interleaved.parquet"
    write_table(p, interleaved_table(pause))
    log = load_log(p)
    assert log.time_repairs.get("gaps", 0) == (1 if pause else 0)
    _stream_equals_load(p, 500)


# ------------------------------------------------------------------ channels slower than max_gap_s

def slow_table(slow: str, every: int, drop=()):
    """ay, r and the speed at 100 Hz on every row, ``slow`` only every ``every``-th row (blank between);
    the rows of ``drop`` lose their ``slow`` value too (a lost GNSS fix)."""
    t = _stamps(12000)
    cols = {"t": t, "vx": vx_of(t), "ay": ay_of(t), "r": r_of(t)}
    v = np.full(len(t), np.nan)
    v[::every] = cols[slow][::every]
    v[list(drop)] = np.nan
    cols[slow] = v
    return cols


def test_speed_at_1_hz_is_interpolated_across_its_own_steps(tmp_path):
    p = tmp_path / "gnss_speed.csv"
    write_table(p, slow_table("vx", 100))
    log = load_log(p)
    # a straight line between samples 1 s apart: off by at most (1 s)^2 / 8 max|vx''| = 1/(8 * 49) m/s
    _assert_truth(log, 1.0 / (8 * 49) + 1e-9)
    bank, valid = _bank_deg(log)
    assert valid > 0.99 and bank == pytest.approx(2.0, abs=0.05)
    note = [w for w in log.warnings if "sampled every" in w]
    assert len(note) == 1 and "gnss_speed.csv" in note[0] and "channel 'speed' (column 'vx')" in note[0]
    assert "every 1 s" in note[0] and "max_gap_s = 0.5 s" in note[0] and "up to 1.5 s" in note[0]


def test_a_lost_fix_of_a_1_hz_speed_stays_a_gap(tmp_path):
    """Two 1 Hz samples 2 s apart (the one between lost) are not bridged: NaN between, not a straight line."""
    p = tmp_path / "lost_fix.csv"
    write_table(p, slow_table("vx", 100, drop=[5000]))            # the sample at 50 s
    s = load_log(p).signals
    between = (s.t > 49.0) & (s.t < 51.0)
    assert np.isnan(s.vx[between]).all() and np.isfinite(s.vx[~between]).all()


@pytest.mark.parametrize("slow,every", [("vx", 300), ("ay", 100)])
def test_a_slow_channel_that_is_not_bridged_is_named(tmp_path, slow, every):
    """A speed every 3 s (beyond 2 s) or ay at 1 Hz (it carries the turns: never bridged) is NaN between its
    samples, and the warning names the file, the channel, its period, max_gap_s and the way to bridge it."""
    p = tmp_path / "slow.csv"
    write_table(p, slow_table(slow, every))
    log = load_log(p)
    s = log.signals
    got = s.vx if slow == "vx" else s.ay
    assert np.isnan(got).mean() > 0.95
    role = {"vx": "speed", "ay": "lateral_acceleration"}[slow]
    note = [w for w in log.warnings if "sampled every" in w]
    assert len(note) == 1 and "slow.csv" in note[0] and f"channel '{role}' (column '{slow}')" in note[0]
    assert f"every {every / 100:g} s" in note[0] and "not estimated" in note[0] and "max_gap_s above" in note[0]


def test_a_speed_at_100_hz_with_a_dropout_is_not_bridged(tmp_path):
    """The bridge is for a channel's own slow sampling: a 1 s dropout of a 100 Hz speed stays NaN, no warning."""
    cols = slow_table("vx", 1)
    cols["vx"][3000:3100] = np.nan
    cols["ay"][::2] = np.nan                         # (ay at 50 Hz: the log goes onto the uniform grid)
    p = tmp_path / "dropout.csv"
    write_table(p, cols)
    log = load_log(p)
    s = log.signals
    assert np.isnan(s.vx[(s.t > 29.995) & (s.t < 31.0)]).all()
    assert not [w for w in log.warnings if "sampled every" in w]


def test_a_map_max_gap_bridges_a_slow_channel(tmp_path):
    """The warning's way out works: ``max_gap_s`` above ay's period in a channel map interpolates across it."""
    p = tmp_path / "slow_ay.csv"
    write_table(p, {**slow_table("ay", 100), "delta_f": np.zeros(12000)})
    m = tmp_path / "m.toml"
    m.write_text('[resample]\nmax_gap_s = 1.2\n\n[channels]\ntime = { column = "t", unit = "s" }\n'
                 'speed = { column = "vx", unit = "m/s" }\nlateral_acceleration = { column = "ay", unit = "m/s^2" }\n'
                 'yaw_rate = { column = "r", unit = "rad/s" }\n'
                 'road_wheel_angle = { column = "delta_f", unit = "rad" }\n')
    log = load_log(p, channels=m)
    assert np.isfinite(log.signals.ay).all() and not [w for w in log.warnings if "sampled every" in w]


@pytest.mark.parametrize("chunk", [61, 1000, 5000])
def test_slow_speed_streamed_equals_whole(tmp_path, chunk):
    """The speed's period is decided on its first samples, whole and streamed alike (a chunk of 61 rows holds
    no speed sample at all most of the time)."""
    p = tmp_path / "gnss_speed.parquet"
    write_table(p, slow_table("vx", 100, drop=[5000]))
    whole, chunks = _stream_equals_load(p, chunk)
    assert len(chunks) > 1 and np.isfinite(whole.signals.vx).mean() > 0.97

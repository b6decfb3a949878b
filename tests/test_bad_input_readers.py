"""Bad input at the readers: each test builds the bad file in tmp_path and checks the outcome against what
was written (the seconds in a timestamp column, the rows of one part of a drive) or the exact message
fragments naming the file, the channel or the map key.

Covers the robustness sweep's rows 1 (Arrow timestamps), 5 (a channel map not in UTF-8), 8 and 9 (time
stamp and comma2k19 messages, a non-numeric map value), 10 (a truncated MDF4 file), 11 (a clock that
restarts part-way) and 13 (an absurd resample rate); also boolean columns mapped to a channel and a time
unit declared for a column whose type carries its own.
"""

from __future__ import annotations

import gc
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.io import LogError, load_log, read_channel_map
from roadbank.io.channels import RATE_HZ_RANGE, ChannelMap, default_channel_map
from roadbank.io.readers import arrow_column_floats
from roadbank.io.stream import stream_log
from roadbank.io.timebase import repair_time

DT = 0.01
EPOCH_S = 1_700_000_000            # 2023-11-14 22:13:20 UTC
TICKS = {"s": 1, "ms": 10**3, "us": 10**6, "ns": 10**9}


def _signals(n: int, vx: float = 20.0) -> dict:
    """Plausible SI / ISO signal columns (no time column), n rows."""
    k = np.arange(n) * DT
    return {"vx": vx + 0.01 * np.arange(n), "ay": 0.5 * np.sin(k), "r": 0.05 * np.cos(k),
            "delta_f": 0.01 * np.sin(2 * k)}


def _write_csv(path, cols: dict):
    names = list(cols)
    rows = [",".join(names)] + [",".join(repr(float(cols[c][i])) for c in names)
                                for i in range(len(cols[names[0]]))]
    path.write_text("\n".join(rows) + "\n")
    return path


MAP = """
[channels]
time = {{ column = "t", unit = "{unit}" }}
speed = {{ column = "vx", unit = "m/s" }}
lateral_acceleration = {{ column = "ay", unit = "m/s^2" }}
yaw_rate = {{ column = "r", unit = "rad/s" }}
road_wheel_angle = {{ column = "delta_f", unit = "rad" }}
"""


# ------------------------------------------------------------------ row 1: Arrow timestamp / duration columns
@pytest.mark.parametrize("unit", ["ms", "us", "ns"])
@pytest.mark.parametrize("tz", [None, "UTC", "Europe/Berlin"])
def test_parquet_timestamp_column_gives_epoch_seconds(tmp_path, unit, tz):
    n = 300
    per = TICKS[unit]
    ticks = [EPOCH_S * per + k * per // 100 for k in range(n)]     # 100 Hz, exact in every unit
    p = tmp_path / f"ts_{unit}.parquet"
    pq.write_table(pa.table({"t": pa.array(ticks, type=pa.timestamp(unit, tz=tz)), **_signals(n)}), p)
    truth = EPOCH_S + np.arange(n) / 100.0                            # the seconds written
    whole = load_log(p)
    assert len(whole) == n
    np.testing.assert_allclose(whole.signals.t, truth, rtol=0, atol=1e-6)     # float64 resolution at 1.7e9 s
    np.testing.assert_allclose(np.concatenate([c.signals.t for c in stream_log(p, chunk_rows=70)]), truth,
                               rtol=0, atol=1e-6)


@pytest.mark.parametrize("unit", ["s", "ms", "us", "ns"])
def test_arrow_timestamp_and_duration_of_every_unit(unit):
    per = TICKS[unit]
    ticks = [EPOCH_S * per, EPOCH_S * per + per // 2 if per > 1 else EPOCH_S + 2, None]
    want = [EPOCH_S, EPOCH_S + (0.5 if per > 1 else 2.0)]
    for tz in (None, "America/New_York"):
        got = arrow_column_floats("x.parquet", "t", "column 't'", pa.chunked_array(
            [pa.array(ticks, type=pa.timestamp(unit, tz=tz))]))
        assert got[:2].tolist() == want and np.isnan(got[2])
    dur = arrow_column_floats("x.parquet", "t", "column 't'", pa.array([3 * per, None], type=pa.duration(unit)))
    assert dur[0] == 3.0 and np.isnan(dur[1])


def test_parquet_duration_column_is_seconds(tmp_path):
    n = 200
    p = tmp_path / "dur.parquet"
    pq.write_table(pa.table({"t": pa.array([10 * k for k in range(n)], type=pa.duration("ms")), **_signals(n)}), p)
    np.testing.assert_allclose(load_log(p).signals.t, np.arange(n) * DT, rtol=0, atol=1e-12)


def test_parquet_int64_ns_epoch_beyond_2_53(tmp_path):
    # an int64 epoch in ns (> 2^53) declared as ns: read, not refused as "not in range"
    n = 200
    ticks = [EPOCH_S * 10**9 + k * 10**7 for k in range(n)]
    assert ticks[0] > 2**53
    p = tmp_path / "ns.parquet"
    pq.write_table(pa.table({"t": pa.array(ticks, type=pa.int64()), **_signals(n)}), p)
    (tmp_path / "ns.toml").write_text(MAP.format(unit="ns"))
    t = load_log(p, channels=tmp_path / "ns.toml").signals.t
    np.testing.assert_allclose(t, EPOCH_S + np.arange(n) * DT, rtol=0, atol=1e-6)


def test_declared_time_unit_of_a_timestamp_column_is_ignored_with_a_warning(tmp_path):
    # the column carries its own unit (read in s): the map's "ms" on top would make the log 1000 times shorter
    n = 300
    p = tmp_path / "ts_ms.parquet"
    pq.write_table(pa.table({"t": pa.array([EPOCH_S * 10**6 + k * 10**4 for k in range(n)], type=pa.timestamp("us")),
                             **_signals(n)}), p)
    m = tmp_path / "ms.toml"
    m.write_text(MAP.format(unit="ms"))
    plain = load_log(p)                                  # the default map: t in s
    assert not [w for w in plain.warnings if "ignored" in w]
    whole, chunks = load_log(p, channels=m), list(stream_log(p, channels=m, chunk_rows=70))
    np.testing.assert_array_equal(whole.signals.t, plain.signals.t)
    np.testing.assert_array_equal(np.concatenate([c.signals.t for c in chunks]), plain.signals.t)
    for warns in (whole.warnings, [w for c in chunks for w in c.warnings]):
        w = [x for x in warns if "ignored" in x]
        assert w == [f"{p}: channel 'time' (column 't'): the map's unit 'ms' is ignored: the column is "
                     "timestamp[us], which carries its own unit (read in s)"], warns


# ------------------------------------------------------------------ boolean columns mapped to a channel
def test_boolean_column_of_a_channel_is_refused_naming_it(tmp_path):
    n = 300
    sig = _signals(n)
    p = tmp_path / "bool_r.parquet"
    pq.write_table(pa.table({"t": np.arange(n) * DT, **sig, "r": sig["r"] > 0}), p)
    for read in (lambda: load_log(p), lambda: list(stream_log(p, chunk_rows=70))):
        with pytest.raises(LogError) as err:
            read()
        assert str(err.value).startswith(f"{p}: channel 'yaw_rate' (column 'r'): holds booleans"), str(err.value)
        assert "not numbers" in str(err.value)
    q = tmp_path / "bool_r.csv"        # as pandas writes a bool column
    q.write_text("t,vx,ay,r,delta_f\n" + "".join(f"{k * DT},{sig['vx'][k]},{sig['ay'][k]},{sig['r'][k] > 0},"
                                                 f"{sig['delta_f'][k]}\n" for k in range(n)))
    with pytest.raises(LogError, match=r"bool_r\.csv: channel 'yaw_rate' \(column 'r'\): holds booleans"):
        load_log(q)
    res = CliRunner().invoke(main, ["estimate", str(p), "-o", str(tmp_path / "o.csv")])
    assert res.exit_code != 0 and "Traceback" not in res.output, res.output
    lines = [x for x in res.output.splitlines() if "holds booleans" in x]
    assert len(lines) == 1 and "column 'r'" in lines[0], res.output


def test_boolean_column_not_mapped_to_a_channel_is_read(tmp_path):
    n = 300
    p = tmp_path / "flag.parquet"
    cols = {"t": np.arange(n) * DT, **_signals(n), "brake": np.arange(n) % 7 == 0, "true_flag": np.arange(n) % 2 == 0}
    pq.write_table(pa.table(cols), p)
    log = load_log(p)
    assert len(log) == n and log.truth["true_flag"].tolist() == (np.arange(n) % 2 == 0).tolist()


# ------------------------------------------------------------------ row 5: a channel map that is not UTF-8
@pytest.mark.parametrize("content, byte", [
    (MAP.format(unit="s").replace("[channels]", "# bank in \xb0 (Latin-1)\n[channels]").encode("latin-1"), "0xb0"),
    (bytes([0x9A, 0x01, 0xFF, 0x00, 0x42]) * 20, "0x9a"),
])
def test_channel_map_not_utf8_is_one_line_error(tmp_path, content, byte):
    m = tmp_path / "map_bad.toml"
    m.write_bytes(content)
    _write_csv(tmp_path / "own.csv", {"t": np.arange(50) * DT, **_signals(50)})
    for call in (lambda: read_channel_map(m), lambda: load_log(tmp_path / "own.csv", channels=m)):
        with pytest.raises(LogError) as err:
            call()
        msg = str(err.value)
        assert msg.startswith(f"{m}: not a valid TOML channel map (not UTF-8 text: byte {byte} at position")
        assert "\n" not in msg


# ------------------------------------------------------------------ rows 9 and 13: map values
@pytest.mark.parametrize("extra, pattern", [
    ('steering_ratio = "sixteen"\n', "m.toml: steering_ratio must be a number, got 'sixteen'"),
    ('steering_ratio = true\n', "m.toml: steering_ratio must be a number, got True"),
    ('[resample]\nrate_hz = 1e9\n', "m.toml: resample.rate_hz = 1e+09 is implausible: the grid's rate must be 1 to "
                                    "10000 Hz"),
    ('[resample]\nrate_hz = 2e6\n', "m.toml: resample.rate_hz = 2e+06 is implausible"),
    ('[resample]\nrate_hz = 0.5\n', "m.toml: resample.rate_hz = 0.5 is implausible"),
    ('[resample]\nrate_hz = 0\n', "m.toml: resample.rate_hz = 0 is implausible"),
    ('[resample]\nrate_hz = nan\n', "m.toml: resample.rate_hz = nan is implausible"),
    ('[resample]\nrate_hz = "fast"\n', "m.toml: resample.rate_hz must be a number, got 'fast'"),
    ('[resample]\nmax_gap_s = "long"\n', "m.toml: resample.max_gap_s must be a number, got 'long'"),
])
def test_map_value_errors_name_the_file_and_key(tmp_path, extra, pattern):
    m = tmp_path / "m.toml"
    text = MAP.format(unit="s")
    m.write_text(extra + text if not extra.startswith("[") else text + extra)
    with pytest.raises(LogError) as err:
        read_channel_map(m)
    assert str(err.value).startswith(f"{tmp_path}/") and pattern in str(err.value), str(err.value)


def test_rate_bounds_themselves_are_accepted():
    ch = default_channel_map().channels
    for rate in RATE_HZ_RANGE:
        assert ChannelMap(ch, rate_hz=rate, source="m.toml").rate_hz == rate
    assert RATE_HZ_RANGE == (1.0, 10_000.0)


# ------------------------------------------------------------------ row 8: time-stamp messages
def test_one_row_says_fewer_than_two_stamps(tmp_path):
    p = _write_csv(tmp_path / "rows1.csv", {"t": [0.0], **{k: v[:1] for k, v in _signals(1).items()}})
    with pytest.raises(LogError, match=r"rows1\.csv: channel 'time' \(column 't'\): no increasing time base: "
                                       r"fewer than two distinct stamps \(1 line\)"):
        load_log(p)
    q = tmp_path / "rows1.parquet"
    pq.write_table(pa.table({"t": [0.0], **{k: v[:1] for k, v in _signals(1).items()}}), q)
    with pytest.raises(LogError, match=r"rows1\.parquet: channel 'time' \(column 't'\): no increasing time base: "
                                       r"fewer than two distinct stamps \(1 row\)"):
        list(stream_log(q, chunk_rows=100))


@pytest.mark.parametrize("how", ["every row twice", "a 20 ms clock at 100 Hz"])
def test_every_stamp_repeated_is_refused_clearly(tmp_path, how):
    n = 600
    sig = _signals(n)
    if how == "every row twice":
        cols = {"t": np.repeat(np.arange(n // 2) * DT, 2), **{k: np.repeat(v[: n // 2], 2) for k, v in sig.items()}}
    else:
        cols = {"t": np.repeat(np.arange(n // 2) * 2 * DT, 2), **sig}
    p = _write_csv(tmp_path / "dup.csv", cols)
    with pytest.raises(LogError, match=r"dup\.csv: channel 'time' \(column 't'\): no increasing time base: "
                                       r"every stamp is repeated"):
        load_log(p)


@pytest.mark.parametrize("scale, unit", [(1e3, "ms"), (1e6, "us"), (1e9, "ns")])
def test_time_unit_hint_names_the_unit_that_fits(tmp_path, scale, unit):
    n = 200
    for t0 in (0.0, EPOCH_S * scale):
        # (an epoch in ns as float64 steps by 256 ns: the period read is 0.01 s to 3e-8 relative)
        p = _write_csv(tmp_path / f"t_{unit}.csv", {"t": t0 + np.arange(n) * DT * scale, **_signals(n)})
        with pytest.raises(LogError, match=rf"t_{unit}\.csv: channel 'time' \(column 't'\): median sample period "
                                           rf".* \(is the unit {unit}\? that gives a period of 0\.01\d* s\)"):
            load_log(p)
    # and the other way: stamps in s declared as ns
    (tmp_path / "ns.toml").write_text(MAP.format(unit="ns"))
    p = _write_csv(tmp_path / "s_as_ns.csv", {"t": np.arange(n) * DT, **_signals(n)})
    with pytest.raises(LogError, match=r"\(is the unit s\? that gives a period of 0\.01 s\)"):
        load_log(p, channels=tmp_path / "ns.toml")


@pytest.mark.parametrize("scale, unit", [(1e3, "ms"), (1e9, "ns")])
@pytest.mark.parametrize("streamed", [False, True])
def test_mdf_master_in_another_unit_names_it(tmp_path, scale, unit, streamed):
    """An MDF4 master written in ms or ns (read as seconds): the channel and the unit that fits are named, whole
    and streamed (it was "fewer than 2 samples on the common time base")."""
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal

    from roadbank.io.stream import stream_log
    n = 300
    t = np.arange(n) * DT * scale
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.asarray(v), t, name=k) for k, v in _signals(n).items()])
    p = tmp_path / "master.mf4"
    mdf.save(p)
    with pytest.raises(LogError, match=rf"master\.mf4: channel '(lateral_acceleration|yaw_rate)' \(column '\w+'\): "
                                       rf"its time stamps: median sample period .* \(is the unit {unit}\? that gives a "
                                       r"period of 0\.01\d* s\)"):
        list(stream_log(p, chunk_rows=50)) if streamed else load_log(p)


def test_mdf_channel_in_two_groups_is_named_whole_streamed_and_by_channels(tmp_path):
    """An MDF4 file with its yaw rate 'r' in two channel groups: reading it whole or streamed names the channel and
    its groups alike, and `roadbank channels` says why it proposes no yaw rate (it said 'no column named like it')."""
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal
    from click.testing import CliRunner

    from roadbank.cli import main
    from roadbank.io.stream import stream_log
    n = 300
    t = np.arange(n) * DT
    sig = _signals(n)
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.asarray(v), t, name=k) for k, v in sig.items()])
    mdf.append([Signal(np.asarray(sig["r"]), t + 0.005, name="r")])
    p = tmp_path / "two.mf4"
    mdf.save(p)
    said = r"two\.mf4: channel 'yaw_rate' \(column 'r'\): cannot read channel 'r': it is in 2 channel groups \[0, 1\]"
    with pytest.raises(LogError, match=said):
        load_log(p)
    with pytest.raises(LogError, match=said):
        list(stream_log(p, chunk_rows=50))
    res = CliRunner().invoke(main, ["channels", str(p), "-o", str(tmp_path / "m.toml")])
    assert "note: column 'r' not read, so not proposed: " in res.output
    assert "it is in 2 channel groups [0, 1]" in res.output and "Traceback" not in res.output


# ------------------------------------------------------------------ row 9: comma2k19 messages
def _save(path, arr):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as fh:          # comma2k19 stores arrays without the .npy suffix
        np.save(fh, np.asarray(arr))


def _segment(root, speed_n: int = 100, gyro_shape: tuple = (100, 3)):
    n = 100
    t = np.arange(n) * DT
    for rel, cols in (("processed_log/IMU/accelerometer", (n, 3)), ("processed_log/IMU/gyro", gyro_shape),
                      ("processed_log/CAN/speed", (speed_n,)), ("processed_log/CAN/steering_angle", (n,))):
        _save(root / rel / "t", t[: cols[0]])
        _save(root / rel / "value", np.zeros(cols))
    _save(root / "global_pose/frame_times", t[::5])
    _save(root / "global_pose/frame_positions", np.tile([4.0e6, 0.0, 4.9e6], (20, 1)))
    _save(root / "global_pose/frame_orientations", np.tile([1.0, 0.0, 0.0, 0.0], (20, 1)))
    return root


def test_comma2k19_empty_array_and_imu_shape_are_named(tmp_path):
    seg = _segment(tmp_path / "c_speed_empty", speed_n=0)
    with pytest.raises(LogError) as err:
        load_log(seg)
    assert str(err.value) == (f"{seg}: channel 'speed': comma2k19 'processed_log/CAN/speed': no samples (t and value "
                              "are empty)")
    seg = _segment(tmp_path / "c_gyro_1d", gyro_shape=(100,))
    with pytest.raises(LogError) as err:
        load_log(seg)
    assert str(err.value) == (f"{seg}: channels 'yaw_rate', 'roll_rate', 'pitch_rate': comma2k19 "
                              "'processed_log/IMU/gyro/value': IMU array of shape (100,), need (n, 3) (forward, right, "
                              "down)")


# ------------------------------------------------------------------ row 10: a truncated MDF4 file
def test_truncated_mdf4_gives_the_error_only(tmp_path, monkeypatch):
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal
    t = np.arange(2000) * DT
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.full(len(t), 20.0), t, name="vx"), Signal(np.zeros(len(t)), t, name="ay"),
                Signal(np.zeros(len(t)), t, name="r"), Signal(np.zeros(len(t)), t, name="delta_f")])
    good = tmp_path / "good.mf4"
    mdf.save(good)
    raw = good.read_bytes()
    unraisable = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)
    for cut in (len(raw) // 2, 200):
        p = tmp_path / f"trunc_{cut}.mf4"
        p.write_bytes(raw[:cut])
        with pytest.raises(LogError, match=rf"trunc_{cut}\.mf4: not a readable MDF file"):
            load_log(p)
        with pytest.raises(LogError, match=rf"trunc_{cut}\.mf4: not a readable MDF file"):
            list(stream_log(p, chunk_rows=100))
        gc.collect()
    assert not unraisable, [u.exc_value for u in unraisable]       # no "Exception ignored in MDF4.__del__"
    assert len(load_log(good)) > 1000                                 # the good file still reads


# ------------------------------------------------------------------ row 11: the logger's clock restarts
def _restart_log(n_a: int, n_b: int, back_to: float = 0.0):
    """A log whose clock runs 0 .. (n_a - 1) DT, then restarts at ``back_to`` for n_b samples (stamps
    accumulated, so they differ from the first part's by float noise, as a logger's do). The two parts
    hold different values (vx 20 and 15 m/s), so a splice is seen in the data."""
    t_b = back_to + np.cumsum(np.full(n_b, DT)) - DT
    a, b = _signals(n_a, 20.0), _signals(n_b, 15.0)
    cols = {"t": np.concatenate([np.arange(n_a) * DT, t_b]), **{k: np.concatenate([a[k], b[k]]) for k in a}}
    return cols, t_b, b


@pytest.mark.parametrize("n_a, n_b, back_to, keep_b", [
    (1000, 1501, 0.0, True),        # the report's clock_reset_40: restart at 0, the later part longer
    (1800, 701, 0.0, False),        # the earlier part longer: kept, the restart named
    (1200, 1301, 11.0, True),       # the clock steps back 1 s (a clock step, not a restart at 0)
])
def test_clock_restart_keeps_one_part_never_spliced(tmp_path, n_a, n_b, back_to, keep_b):
    cols, t_b, b = _restart_log(n_a, n_b, back_to)
    p = _write_csv(tmp_path / "reset.csv", cols)
    log = load_log(p)
    s = log.signals
    if keep_b:                       # the later part, whole: its values as written, its first sample flagged
        np.testing.assert_array_equal(s.t, t_b)
        np.testing.assert_array_equal(s.vx[1:], b["vx"][1:])
        assert np.isnan(s.vx[0])
        kept = f"line {n_a + 2} to line {n_a + n_b + 1} ({t_b[0]:.3f} to {t_b[-1]:.3f} s)"
    else:                            # the earlier part, whole, untouched
        np.testing.assert_array_equal(s.t, np.arange(n_a) * DT)
        np.testing.assert_array_equal(s.vx, _signals(n_a, 20.0)["vx"])
        kept = f"line 2 to line {n_a + 1} (0.000 to {(n_a - 1) * DT:.3f} s)"
    assert np.all(np.diff(s.t) > 0.5 * DT)                     # never two stamps 1e-15 s apart
    assert log.time_repairs["out_of_order"] == min(n_a, n_b)
    warn = [w for w in log.warnings if "restarts" in w]
    assert len(warn) == 1 and warn[0].startswith(f"{p}: channel 'time' (column 't'): time stamps repaired: ")
    assert (f"the logger's clock restarts at line {n_a + 2} (from {(n_a - 1) * DT:.3f} s back to {back_to:.3f} s)"
            in warn[0]) and kept in warn[0] and "; " not in warn[0], warn[0]


def test_clock_restart_streamed_is_refused_or_matches_whole(tmp_path):
    cols, t_b, _ = _restart_log(1000, 1501)
    p = tmp_path / "reset.parquet"
    pq.write_table(pa.table(cols), p)
    # the restart in the first chunk: as read whole
    np.testing.assert_array_equal(np.concatenate([c.signals.t for c in stream_log(p, chunk_rows=5000)]), t_b)
    # after it: the part before was passed on already
    for rows in (300, 333, 500):
        with pytest.raises(LogError, match=r"reset\.parquet: channel 'time' \(column 't'\): no increasing time base: "
                                           r"the clock restarts at row 1000 \(from 9\.990 s back to 0\.000 s\)"):
            list(stream_log(p, chunk_rows=rows))


def test_short_jump_repair_keeps_no_near_duplicate_stamps():
    # three samples go back by two periods, their stamps a hair off the first ones: the longest run
    # could join 1.01 and 1.0100000001; the later of such a pair is dropped as a duplicate
    t = [0.97, 0.98, 0.99, 1.00, 1.01, 1.02, 1.03, 1.0100000001, 1.0200001, 1.0300001, 1.04, 1.05]
    rep = repair_time(t)
    kept = np.asarray(t)[rep.keep]
    assert np.all(np.diff(kept) > 0.005) and len(kept) >= len(t) - 4
    assert not rep.restarts
    # a replayed run shorter than GAP_PERIODS stays a plain out-of-order repair
    t2 = list(range(20)) + [15, 16, 17] + list(range(20, 30))
    rep2 = repair_time(np.asarray(t2, float))
    assert rep2.counts["out_of_order"] == 3 and not rep2.restarts

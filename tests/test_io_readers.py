"""Readers: unit conversions, sign conventions, resampling and corrupt input.

Expected values are computed by hand from the known synthetic data written in
each test (independent of roadbank's conversion code).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from roadbank import VehicleParams
from roadbank.io import LogError, load_log, read_channel_map
from roadbank.io.resample import interpolate, uniform_grid

N = 200
DT = 0.01


def _sim_columns(n=N):
    """roadbank-simulate-like table in SI/ISO with known values."""
    t = np.arange(n) * DT
    return {
        "t": t,
        "vx": 20.0 + 0.01 * np.arange(n),
        "ay": 0.5 * np.sin(t),
        "r": 0.05 * np.cos(t),
        "delta_f": 0.01 * np.sin(2 * t),
        "steering_wheel_angle": 0.16 * np.sin(2 * t),
        "true_phi_b": np.full(n, 0.1),
    }


def _write_csv(path: Path, cols: dict, fmt="{!r}"):
    names = list(cols)
    lines = [",".join(names)]
    for i in range(len(cols[names[0]])):
        lines.append(",".join(repr(float(cols[c][i])) for c in names))
    path.write_text("\n".join(lines) + "\n")
    return path


def _write_map(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


# ------------------------------------------------------------ default map
def test_simulate_csv_and_parquet_read_without_map(tmp_path):
    cols = _sim_columns()
    csv_p = _write_csv(tmp_path / "sim.csv", cols)
    table = pa.table(cols).replace_schema_metadata({"scenario": "const-bank", "seed": "3"})
    pq_p = tmp_path / "sim.parquet"
    pq.write_table(table, pq_p)
    for p in (csv_p, pq_p):
        log = load_log(p)
        s = log.signals
        np.testing.assert_array_equal(s.t, cols["t"])          # own clock, no resampling
        np.testing.assert_allclose(s.vx, cols["vx"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(s.ay, cols["ay"], atol=1e-12)
        np.testing.assert_allclose(s.r, cols["r"], atol=1e-12)
        np.testing.assert_allclose(s.delta_f, cols["delta_f"], atol=1e-12)  # delta_f preferred
        np.testing.assert_allclose(log.truth["true_phi_b"], 0.1)
        assert log.reference_roll is None
    assert load_log(pq_p).metadata["scenario"] == "const-bank"


def test_a_log_without_steering_reads_with_the_default_map_and_estimates(tmp_path):
    """An IMU/INS-style table (t, vx, ay, r; no steering column) reads with the default map: delta_f NaN and
    a warning naming the file and the channel, the other channels as written; `roadbank estimate` with no
    option writes the default's estimate (it does not read the steering angle), every sample at speed
    valid; an estimator that reads it gives no valid sample. A map the user wrote that names a steering
    column the file lacks is still refused."""
    from click.testing import CliRunner

    from roadbank.cli import main

    cols = {k: v for k, v in _sim_columns(3000).items() if k in ("t", "vx", "ay", "r")}
    p = _write_csv(tmp_path / "imu.csv", cols)
    from roadbank.io.stream import stream_log

    log = load_log(p)
    assert np.isnan(log.signals.delta_f).all()
    np.testing.assert_allclose(log.signals.ay, cols["ay"], atol=1e-12)
    note = "imu.csv: channel 'steering': no column 'delta_f' or 'steering_wheel_angle'"
    assert sum(note in w for w in log.warnings) == 1, log.warnings
    pq.write_table(pa.table(cols), tmp_path / "imu.parquet")
    chunks = list(stream_log(tmp_path / "imu.parquet", chunk_rows=700))     # streamed: the warning once
    assert len(chunks) > 1 and sum(note.replace(".csv", ".parquet") in w for c in chunks for w in c.warnings) == 1
    res = CliRunner().invoke(main, ["estimate", str(p), "-o", str(tmp_path / "out.csv")])
    assert res.exit_code == 0, res.output
    import pandas as pd
    out = pd.read_csv(tmp_path / "out.csv")
    assert out.filter(like="valid").to_numpy().all()
    res = CliRunner().invoke(main, ["estimate", str(p), "-e", "uio", "-o", str(tmp_path / "uio.csv")])
    assert res.exit_code == 0, res.output
    assert not pd.read_csv(tmp_path / "uio.csv").filter(like="valid").to_numpy().any()
    m = _write_map(tmp_path / "map.toml", """
[channels]
time = { column = "t", unit = "s" }
speed = { column = "vx", unit = "m/s" }
lateral_acceleration = { column = "ay", unit = "m/s^2" }
yaw_rate = { column = "r", unit = "rad/s" }
steering_wheel_angle = { column = "swa", unit = "deg" }
""")
    with pytest.raises(LogError, match=r"imu.csv.*'steering'.*missing: no column 'swa'"):
        load_log(p, channels=read_channel_map(m))


def test_default_map_falls_back_to_steering_wheel_over_ratio(tmp_path):
    cols = _sim_columns()
    del cols["delta_f"]
    p = _write_csv(tmp_path / "sim.csv", cols)
    log = load_log(p, params=VehicleParams(steering_ratio=16.0))
    np.testing.assert_allclose(log.signals.delta_f, 0.16 * np.sin(2 * cols["t"]) / 16.0, atol=1e-12)


# ------------------------------------------------------------ units and signs
MAP_FRD = """
convention = "FRD"
steering_ratio = 12.5
[channels]
time = { column = "ts", unit = "ms" }
speed = { column = "v", unit = "km/h" }
lateral_acceleration = { column = "acc_y", unit = "g" }
yaw_rate = { column = "gyro_z", unit = "deg/s" }
steering_wheel_angle = { column = "swa", unit = "deg" }
reference_roll = { column = "roll", unit = "deg" }
"""


def test_units_and_frd_signs_converted_by_hand(tmp_path):
    n = 50
    cols = {
        "ts": 1000.0 + 10.0 * np.arange(n),   # ms, 100 Hz
        "v": np.full(n, 72.0),                # km/h -> 20 m/s
        "acc_y": np.full(n, 0.1),             # g, to the right (FRD) -> -0.981 m/s^2 ISO
        "gyro_z": np.full(n, 5.0),            # deg/s, turning right (FRD z down) -> -0.087266 rad/s
        "swa": np.full(n, 90.0),              # deg, to the right -> -pi/2 / 12.5 rad road wheel
        "roll": np.full(n, 2.0),              # deg, right side down = ISO positive, no flip
    }
    p = _write_csv(tmp_path / "car.csv", cols)
    m = _write_map(tmp_path / "car.toml", MAP_FRD)
    log = load_log(p, channels=m)
    s = log.signals
    np.testing.assert_allclose(s.t, 1.0 + 0.01 * np.arange(n), atol=1e-12)
    np.testing.assert_allclose(s.vx, 20.0, atol=1e-12)
    np.testing.assert_allclose(s.ay, -0.981, atol=1e-12)
    np.testing.assert_allclose(s.r, -5.0 * math.pi / 180.0, atol=1e-12)
    np.testing.assert_allclose(s.delta_f, -(math.pi / 2) / 12.5, atol=1e-12)
    np.testing.assert_allclose(log.reference_roll, 2.0 * math.pi / 180.0, atol=1e-12)


def test_per_channel_convention_and_invert(tmp_path):
    n = 20
    cols = {"t": np.arange(n) * 0.01, "vx": np.full(n, 10.0), "ay": np.full(n, 1.0),
            "r": np.full(n, 0.1), "d": np.full(n, 0.02)}
    p = _write_csv(tmp_path / "a.csv", cols)
    m = _write_map(tmp_path / "m.toml", """
[channels]
time = { column = "t", unit = "s" }
speed = { column = "vx", unit = "mph" }
lateral_acceleration = { column = "ay", unit = "m/s^2", convention = "FRD" }
yaw_rate = { column = "r", unit = "rad/s" }
road_wheel_angle = { column = "d", unit = "rad", invert = true }
""")
    s = load_log(p, channels=m).signals
    np.testing.assert_allclose(s.vx, 10.0 * 0.44704)
    np.testing.assert_allclose(s.ay, -1.0)   # FRD override flips y
    np.testing.assert_allclose(s.r, 0.1)     # map default ISO: unchanged
    np.testing.assert_allclose(s.delta_f, -0.02)


# ------------------------------------------------------------ resampling
def test_multi_rate_channels_resampled_on_uniform_grid(tmp_path):
    # speed at 50 Hz, others at 200 Hz, merged on one time column with blanks (multi-rate CSV)
    t = np.round(np.arange(0, 2.0 + 1e-9, 0.005), 6)
    lines = ["t,vx,ay,r,delta_f"]
    for i, ti in enumerate(t):
        ti = float(ti)
        v = repr(10.0 + 2.0 * ti) if i % 4 == 0 else ""
        lines.append(f"{ti!r},{v},{0.3 * ti!r},0.01,0.0")
    p = tmp_path / "mr.csv"
    p.write_text("\n".join(lines) + "\n")
    log = load_log(p)
    s = log.signals
    # uniform 100 Hz over the overlap [0, 2.0]
    np.testing.assert_allclose(np.diff(s.t), 0.01, atol=1e-9)
    assert s.t[0] == pytest.approx(0.0) and s.t[-1] == pytest.approx(2.0)
    # linear signals are reproduced exactly by linear interpolation
    np.testing.assert_allclose(s.vx, 10.0 + 2.0 * s.t, atol=1e-9)
    np.testing.assert_allclose(s.ay, 0.3 * s.t, atol=1e-9)


def test_interpolate_never_extrapolates_and_leaves_long_gaps_nan():
    tc = np.array([0.0, 0.1, 0.2, 1.5, 1.6])
    vc = np.array([0.0, 1.0, 2.0, 15.0, 16.0])
    tn = np.array([-0.05, 0.05, 0.2, 0.8, 1.55, 1.7])
    out = interpolate(tc, vc, tn, max_gap_s=0.5)
    assert np.isnan(out[0]) and np.isnan(out[-1])       # outside the channel's span
    assert out[1] == pytest.approx(0.5)
    assert out[2] == pytest.approx(2.0)
    assert np.isnan(out[3])                              # 1.3 s gap not bridged
    assert out[4] == pytest.approx(15.5)


def test_uniform_grid_stays_inside_overlap():
    g = uniform_grid(0.003, 0.05, 100.0)
    np.testing.assert_allclose(g, 0.003 + 0.01 * np.arange(5))
    assert g[-1] <= 0.05


def test_channels_on_different_clocks_use_overlap(tmp_path):
    # parquet can't hold ragged columns; emulate two clocks via NaN rows and check the overlap
    t = np.arange(0, 3.0, 0.01)
    vx = np.where(t >= 1.0, 15.0, np.nan)   # speed starts late
    cols = {"t": t, "vx": vx, "ay": np.zeros_like(t), "r": np.zeros_like(t), "delta_f": np.zeros_like(t)}
    cols["vx"][::2] = np.nan                 # and is sampled at half rate
    cols["vx"][t < 1.0] = np.nan
    p = tmp_path / "late.parquet"
    pq.write_table(pa.table(cols), p)
    s = load_log(p).signals
    assert s.t[0] >= 1.0 - 1e-12 and s.t[0] == pytest.approx(t[t >= 1.0][1], abs=1e-9)   # the first speed stamp
    np.testing.assert_array_equal(s.vx, 15.0)


# ------------------------------------------------------------ corrupt input
def _good_csv(tmp_path, name="good.csv"):
    return _write_csv(tmp_path / name, _sim_columns(20))


def test_empty_file(tmp_path):
    p = tmp_path / "empty.csv"
    p.write_text("")
    with pytest.raises(LogError, match=r"empty\.csv: file is empty"):
        load_log(p)
    q = tmp_path / "empty.parquet"
    q.write_bytes(b"")
    with pytest.raises(LogError, match="empty"):
        load_log(q)


def test_header_only(tmp_path):
    p = tmp_path / "h.csv"
    p.write_text("t,vx,ay,r,delta_f\n")
    with pytest.raises(LogError, match="no data rows"):
        load_log(p)


def test_truncated_csv(tmp_path):
    p = _good_csv(tmp_path)
    data = p.read_text()
    p.write_text(data[: len(data) - 30])   # cut in the middle of the last row
    with pytest.raises(LogError, match=r"line 21 has \d field\(s\) but the header has 7 \(truncated"):
        load_log(p)


def test_truncated_parquet(tmp_path):
    p = tmp_path / "x.parquet"
    pq.write_table(pa.table(_sim_columns()), p)
    b = p.read_bytes()
    p.write_bytes(b[: len(b) // 2])
    with pytest.raises(LogError, match=r"x\.parquet: not a readable Parquet file"):
        load_log(p)


def test_missing_channel_named(tmp_path):
    cols = _sim_columns(20)
    del cols["r"]
    p = _write_csv(tmp_path / "nor.csv", cols)
    with pytest.raises(LogError, match=r"nor\.csv: channel 'yaw_rate' \(column 'r'\): column not found"):
        load_log(p)


def test_text_in_numeric_column_names_line(tmp_path):
    p = _good_csv(tmp_path)
    lines = p.read_text().splitlines()
    f = lines[17].split(",")
    f[3] = "abc"                      # column 'r' of data row 17 = file line 18
    lines[17] = ",".join(f)
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogError, match=r"channel 'yaw_rate' \(column 'r'\): non-numeric value 'abc' at line 18"):
        load_log(p)


def test_text_in_parquet_string_column(tmp_path):
    cols = {k: list(v) for k, v in _sim_columns(10).items()}
    cols["ay"] = [str(x) for x in cols["ay"]]
    cols["ay"][4] = "oops"
    p = tmp_path / "s.parquet"
    pq.write_table(pa.table(cols), p)
    with pytest.raises(LogError, match=r"'lateral_acceleration' \(column 'ay'\): non-numeric value 'oops' at row 4"):
        load_log(p)


@pytest.mark.parametrize("stamp, kinds", [("2026-12-06 10:00:00.010", "date-times"), ("10:00:00.010", "times of day")])
@pytest.mark.parametrize("chunk_rows", [None, 4])
def test_time_stamps_as_text_in_parquet_say_how_to_store_them(tmp_path, stamp, kinds, chunk_rows):
    """A Parquet time column of date-times or times of day written as text (not a timestamp): refused naming the
    channel, the column, what it holds and how to store it (before: "non-numeric value" only), whole and streamed."""
    from roadbank.io.stream import stream_log

    cols = {k: list(v) for k, v in _sim_columns(10).items()}
    cols["t"] = [None, " "] + [stamp] * 8
    p = tmp_path / "s.parquet"
    pq.write_table(pa.table(cols), p)
    with pytest.raises(LogError, match=rf"channel 'time' \(column 't'\): holds {kinds} as text \('{stamp}', Arrow "
                                       r"type string\), which a Parquet log stores as a timestamp column"):
        load_log(p) if chunk_rows is None else list(stream_log(p, chunk_rows=chunk_rows))


def test_blank_values_are_missing_samples_not_errors(tmp_path):
    p = _good_csv(tmp_path)
    lines = p.read_text().splitlines()
    f = lines[5].split(",")
    f[2] = ""
    lines[5] = ",".join(f)
    p.write_text("\n".join(lines) + "\n")
    s = load_log(p).signals
    assert np.isnan(s.ay[4]) and np.isfinite(s.ay[5])


@pytest.mark.parametrize("unit_line, pattern", [
    ('speed = { column = "v", unit = "m/s" }', r"channel 'speed' \(column 'v'\).*probably km/h"),
    ('speed = { column = "v", unit = "deg" }', r"channel 'speed' \(column 'v'\): unit 'deg' is not a speed unit"),
])
def test_wrong_units_detected(tmp_path, unit_line, pattern):
    n = 30
    cols = {"t": np.arange(n) * 0.01, "v": np.full(n, 110.0), "ay": np.zeros(n), "r": np.zeros(n),
            "d": np.zeros(n)}
    p = _write_csv(tmp_path / "u.csv", cols)
    m = _write_map(tmp_path / "u.toml", f"""
[channels]
time = {{ column = "t", unit = "s" }}
{unit_line}
lateral_acceleration = {{ column = "ay", unit = "m/s^2" }}
yaw_rate = {{ column = "r", unit = "rad/s" }}
road_wheel_angle = {{ column = "d", unit = "rad" }}
""")
    with pytest.raises(LogError, match=pattern):
        load_log(p, channels=m)


def test_yaw_rate_in_deg_declared_rad(tmp_path):
    n = 100
    cols = _sim_columns(n)
    cols["r"] = 20.0 * np.sin(np.arange(n) * 0.1)   # deg/s values
    p = _write_csv(tmp_path / "y.csv", cols)
    with pytest.raises(LogError, match=r"'yaw_rate' \(column 'r'\).*probably deg/s"):
        load_log(p)


def test_steering_in_deg_declared_rad(tmp_path):
    cols = _sim_columns()
    del cols["delta_f"]
    cols["steering_wheel_angle"] = np.degrees(cols["steering_wheel_angle"]) * 40  # up to ~370 "rad"
    p = _write_csv(tmp_path / "s.csv", cols)
    with pytest.raises(LogError, match=r"'steering_wheel_angle'.*probably deg"):
        load_log(p)


def test_time_backwards_once_is_repaired(tmp_path):
    # one stamp back in time (an isolated bad stamp): the sample is dropped, the next one flagged
    cols = _sim_columns(20)
    cols["t"][10] = cols["t"][8]          # data row index 10 = file line 12 (header is line 1)
    p = _write_csv(tmp_path / "tb.csv", cols)
    log = load_log(p)
    assert len(log) == 19 and 0.10 not in np.round(log.signals.t, 9)
    assert log.time_repairs["out_of_order"] == 1 and log.time_repairs["flagged"] == 1
    assert np.isnan(log.signals.r[10]) and np.isfinite(log.signals.r[9])     # the sample after it
    assert any("time stamps repaired: 1 out-of-order stamp dropped (first at line 12)" in w
               for w in log.warnings), log.warnings


def test_time_running_backwards_is_refused(tmp_path):
    cols = _sim_columns(20)
    cols["t"] = cols["t"][::-1].copy()    # no increasing time base at all
    p = _write_csv(tmp_path / "tb.csv", cols)
    with pytest.raises(LogError, match=r"tb\.csv: channel 'time' \(column 't'\): no increasing time base"):
        load_log(p)


def test_bad_channel_map(tmp_path):
    p = _good_csv(tmp_path)
    m = _write_map(tmp_path / "bad.toml", '[channels]\ntime = { column = "t", unit = "s" }\n')
    with pytest.raises(LogError, match=r"bad\.toml: channel map has no 'speed'"):
        load_log(p, channels=m)
    m2 = _write_map(tmp_path / "bad2.toml", "this is = = not toml")
    with pytest.raises(LogError, match="not a valid TOML"):
        read_channel_map(m2)
    # NED (PX4-style body axes) is accepted as FRD, FLU (ROS REP-103) as ISO: see test_io_ros.py
    m3 = _write_map(tmp_path / "bad3.toml", MAP_FRD.replace('convention = "FRD"', 'convention = "XYZ"'))
    with pytest.raises(LogError, match="convention must be one of"):
        read_channel_map(m3)


def test_unknown_suffix(tmp_path):
    p = tmp_path / "x.bin"
    p.write_bytes(b"123")
    with pytest.raises(LogError, match="cannot tell the format"):
        load_log(p)


def test_mdf4_reader(tmp_path):
    pytest.importorskip("asammdf", reason="optional extra 'mdf' (asammdf) not installed")
    from asammdf import MDF, Signal

    t_fast = np.arange(0, 2.0, 0.005)
    t_slow = np.arange(0, 2.0, 0.02)
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.full(len(t_slow), 36.0), t_slow, name="VehSpd", unit="km/h")])
    mdf.append([Signal(-0.2 * t_fast, t_fast, name="AccY", unit="m/s^2"),
                Signal(np.full(len(t_fast), 0.01), t_fast, name="YawRate", unit="rad/s"),
                Signal(np.full(len(t_fast), 0.0), t_fast, name="SWA", unit="deg")])
    p = tmp_path / "log.mf4"
    mdf.save(p)
    m = _write_map(tmp_path / "m.toml", """
convention = "FRD"
[channels]
time = { column = "unused", unit = "s" }
speed = { column = "VehSpd", unit = "km/h" }
lateral_acceleration = { column = "AccY", unit = "m/s^2" }
yaw_rate = { column = "YawRate", unit = "rad/s" }
steering_wheel_angle = { column = "SWA", unit = "deg" }
""")
    s = load_log(p, channels=m).signals
    np.testing.assert_allclose(np.diff(s.t), 0.01, atol=1e-9)
    np.testing.assert_allclose(s.vx, 10.0)
    np.testing.assert_allclose(s.ay, 0.2 * s.t, atol=1e-9)   # FRD flip of -0.2 t
    np.testing.assert_allclose(s.r, -0.01)

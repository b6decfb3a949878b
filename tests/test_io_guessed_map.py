"""A table log read without a channel map whose columns are not roadbank's own (roadbank.io.mapchoice).

Where the default map (t, vx, ay, r, SI) misses a required column, the log is read with the map
``roadbank channels`` guesses, if every required channel's guess is ``high``; else it is refused as before, the
message naming the file, what the guess found and why it was not trusted. Where the default map reads the log, a
column named like a roll rate (longitudinal acceleration, pitch rate) under another name is read too, and so are a
GNSS position named ``lat``/``lon`` (both, in degrees) and a steering angle named otherwise (``SWA``, where its guess
is high): ``roadbank map`` and ``roadbank identify`` then give what they give with a map naming them.

Truth: a real drive (KITTI 2011_10_03_drive_0047: its INS's speed, ay, yaw rate and roll rate) written with roadbank's
own column names and read with the default map. The same columns under other names in the same units give the same
output to the bit; in other units (km/h) the same to rounding; with a mirrored yaw rate (which the guess inverts) to
the bit. Streamed in chunks, the same as read whole.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.identification.check import SimCase, simulate_case
from roadbank.io import LogError, csvtable, load_log, mapchoice, read_channel_map
from roadbank.io.assemble import concat_logs
from roadbank.io.guess import named_as
from roadbank.io.kitti import load_kitti_oxts
from roadbank.io.stream import stream_log
from roadbank.io.writers import write_table

DRIVE = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts" / "2011_10_03_drive_0047"
SIG = ("t", "vx", "ay", "r", "delta_f", "p", "ax", "q")
PIN = "roadbank channels {} -o map.toml, then --channels map.toml"


@pytest.fixture(scope="module")
def drive():
    if not DRIVE.is_dir():
        pytest.skip(f"shared KITTI drive not found at {DRIVE}")
    return load_kitti_oxts(DRIVE)


def _own(s) -> dict:
    """The drive under roadbank's own column names (what the default map reads)."""
    return {"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "p": s.p}


def _renamed(s) -> dict:
    return {"time": s.t, "speed": s.vx, "lat_acc": s.ay, "yaw_rate": s.r, "roll_rate": s.p}


def _write(path: Path, cols: dict) -> Path:
    if path.suffix == ".parquet":
        pq.write_table(pa.table({k: np.asarray(v, dtype=np.float64) for k, v in cols.items()}), path)
    else:
        write_table(path, cols)
    return path


def _estimate(log: Path, tmp_path: Path, *args) -> tuple[bytes, str]:
    """``roadbank estimate LOG`` (no map): the output table's bytes and what it said on stderr."""
    out = tmp_path / f"{log.stem}.out.csv"
    res = CliRunner().invoke(main, ["estimate", str(log), "-o", str(out), *args])
    assert res.exit_code == 0, res.output
    return out.read_bytes(), res.stderr


def _same_signals(got, want, exact: bool = True):
    for k in SIG:
        a, b = getattr(got.signals, k), getattr(want.signals, k)
        assert (a is None) == (b is None), k
        if a is None:
            continue
        if exact:
            np.testing.assert_array_equal(a, b, err_msg=k)
        else:
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15, equal_nan=True, err_msg=k)


# ------------------------------------------------------------------ the same output as under roadbank's own names
@pytest.mark.parametrize("kind", ["roll_rate.csv", "guessed.csv", "guessed.parquet"])
def test_renamed_columns_give_the_output_of_roadbanks_own_names_to_the_bit(drive, tmp_path, kind):
    """``roll_rate.csv``: t, vx, ay, r and the roll rate as ``roll_rate`` (before: not read, so the default was the ESP
    blend, not the gyro-aided filter); ``guessed``: every column named otherwise (before: refused, vx not found)."""
    s = drive.signals
    want, said = _estimate(_write(tmp_path / "own.csv", _own(s)), tmp_path)
    assert "kinematic-pif is kinematic-gyro (the log has a roll rate)" in said
    cols = ({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "roll_rate": s.p} if kind == "roll_rate.csv"
            else _renamed(s))
    log = _write(tmp_path / kind, cols)
    got, said = _estimate(log, tmp_path)
    assert got == want
    assert "kinematic-pif is kinematic-gyro (the log has a roll rate)" in said, said
    if kind == "roll_rate.csv":
        assert ("channel 'roll_rate' (column 'roll_rate'): read as the roll rate in rad/s, sign as stored (the "
                "default channel map's column 'p' is not in the file") in said, said
        assert PIN.format(kind) in said
    else:
        line = next(w for w in said.splitlines() if "read with the channel map guessed" in w)
        assert line.startswith(f"warning: {log}: no column 'vx' (the default channel map's speed): read with")
        for part in ("time <- 'time' (s)", "speed <- 'speed' (m/s, sign as stored)",
                     "lateral_acceleration <- 'lat_acc' (m/s^2, sign as stored: positive to the left assumed",
                     "yaw_rate <- 'yaw_rate' (rad/s, sign as stored)", "roll_rate <- 'roll_rate' (rad/s",
                     "no steering angle", PIN.format(kind)):
            assert part in line, (part, line)
    _same_signals(load_log(log), load_log(tmp_path / "own.csv"))


def test_a_speed_in_kmh_named_so_is_read_in_kmh(drive, tmp_path):
    s = drive.signals
    cols = {"time": s.t, "speed_kmh": s.vx * 3.6, "lat_acc": s.ay, "yaw_rate": s.r, "roll_rate": s.p}
    log = load_log(_write(tmp_path / "kmh.csv", cols))
    assert log.channel_map.channels["speed"].unit == "km/h"
    assert "speed <- 'speed_kmh' (km/h, sign as stored)" in log.warnings[0]
    _same_signals(log, load_log(_write(tmp_path / "own.csv", _own(s))), exact=False)


def test_a_mirrored_yaw_rate_is_inverted_as_the_guess_reads_it(drive, tmp_path):
    """The yaw rate's sign against ay's in turns: opposite, so the guess inverts it and the log reads as the
    original, to the bit (a sign flip is exact)."""
    s = drive.signals
    own = _write(tmp_path / "own.csv", _own(s))
    cols = dict(_renamed(s), yaw_rate=-s.r)
    log = _write(tmp_path / "mirrored.csv", cols)
    read = load_log(log)
    assert read.channel_map.channels["yaw_rate"].invert
    assert "yaw_rate <- 'yaw_rate' (rad/s, sign inverted: opposite to ay in turns)" in read.warnings[0]
    _same_signals(read, load_log(own))
    assert _estimate(log, tmp_path)[0] == _estimate(own, tmp_path)[0]


def test_a_mirrored_roll_rate_is_read_and_left_to_the_estimators_check(drive, tmp_path):
    """The guess does not check a roll rate's sign: the default's own check (it must follow the roll that ay shows)
    finds it mirrored, says so and does not use it: the output is that of the log without it."""
    s = drive.signals
    without = {k: v for k, v in _renamed(s).items() if k != "roll_rate"}
    want, _ = _estimate(_write(tmp_path / "none.csv", without), tmp_path)
    got, said = _estimate(_write(tmp_path / "mirrored.csv", dict(_renamed(s), roll_rate=-s.p)), tmp_path)
    assert "its roll rate does not follow the roll in its ay" in said and "so it is not used" in said, said
    assert got == want


# ------------------------------------------------------------------ refused where the guess is not sure
def test_a_guess_that_is_not_sure_is_refused_naming_the_file_and_what_it_found(drive, tmp_path):
    """A speed in mph named VehSpd: over this drive's turns mph and km/h both give a slope of ay on vx r that real
    roads give, so the guess is low (it cannot tell), and the log is not read with it."""
    s = drive.signals
    p = _write(tmp_path / "mph.csv", {"time": s.t, "VehSpd": s.vx / 0.44704, "lat_acc": s.ay, "yaw_rate": s.r})
    with pytest.raises(LogError) as err:
        load_log(p)
    msg = str(err.value)
    assert msg.startswith(f"{p}: channel 'speed' (column 'vx'): column not found in the file (it has: time, VehSpd, "
                          "lat_acc, yaw_rate); the guess from its columns' names and data is not sure enough"), msg
    assert "speed: 'VehSpd' in mph (low: ay = vx r in turns cannot tell mph" in msg
    assert "yaw_rate: 'yaw_rate' in rad/s (high)" in msg
    assert msg.endswith("(`roadbank channels mph.csv -o map.toml` writes one for these columns)")
    res = CliRunner().invoke(main, ["estimate", str(p), "-o", str(tmp_path / "o.csv")])
    assert res.exit_code == 1 and f"FAILED {p}: channel 'speed'" in res.stderr, res.output


def test_names_the_guess_does_not_know_and_gentle_turns_are_refused(tmp_path):
    n = 2000
    t = np.arange(n) * 0.01
    p = _write(tmp_path / "names.csv", {"c0": t, "c1": np.full(n, 20.0), "c2": np.zeros(n), "c3": np.zeros(n)})
    with pytest.raises(LogError, match=r"names\.csv: channel 'speed' \(column 'vx'\): column not found .* speed: not "
                                       r"found \(no column named like it\)"):
        load_log(p)
    # named well, but the turns too gentle to tell the units: medium, not trusted
    r = 0.02 * np.sin(t / 5.0)
    q = _write(tmp_path / "gentle.csv", {"time": t, "speed": np.full(n, 10.0), "lat_acc": 10.0 * r, "yaw_rate": r})
    with pytest.raises(LogError, match=r"gentle\.csv: .*speed: 'speed' in m/s \((medium|low): "):
        load_log(q)


@pytest.mark.parametrize("name, role, named", [
    ("roll_rate", "roll_rate", True), ("gyro_x", "roll_rate", True), ("RollRate", "roll_rate", True),
    ("IMU.RollRate", "roll_rate", True), ("roll_rate_dps", "roll_rate", True),
    ("AccX", "longitudinal_acceleration", True),
    ("RollRateQuality", "roll_rate", False), ("Brake_p", "roll_rate", False), ("p", "pitch_rate", False)])
def test_what_counts_as_named_like_an_optional_channel(name, role, named):
    assert named_as(role, name) is named


def test_a_column_that_only_starts_like_a_roll_rate_is_not_read(drive, tmp_path):
    s = drive.signals
    cols = {"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "RollRateQuality": np.ones(len(s.t))}
    log = load_log(_write(tmp_path / "q.csv", cols))
    assert log.signals.p is None and not any("RollRateQuality" in w for w in log.warnings)


def test_a_roll_rate_in_deg_s_is_read_in_deg_s(drive, tmp_path):
    s = drive.signals
    cols = {"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "gyro_x": np.degrees(s.p), "AccX": s.ax}
    log = load_log(_write(tmp_path / "deg.parquet", cols))
    assert log.channel_map.channels["roll_rate"].unit == "deg/s"
    assert log.channel_map.channels["longitudinal_acceleration"].unit == "m/s^2"
    np.testing.assert_allclose(log.signals.p, s.p, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(log.signals.ax, s.ax)


# ------------------------------------------------------------------ streamed = whole
@pytest.mark.parametrize("kind", ["roll_rate.csv", "guessed.csv", "guessed.parquet"])
def test_chunks_put_end_to_end_equal_the_whole_log(drive, tmp_path, monkeypatch, kind):
    """The guess reads the log's first rows whatever the chunks (here 700, and the CSV streamed in blocks of lines
    as a long file is), so the chunks read with the same map as the whole log."""
    monkeypatch.setattr(mapchoice, "GUESS_ROWS", 700)          # of its 837 rows
    monkeypatch.setattr(csvtable, "CSV_WHOLE_BYTES", 0)
    s = drive.signals
    cols = ({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "roll_rate": s.p} if kind == "roll_rate.csv"
            else _renamed(s))
    p = _write(tmp_path / kind, cols)
    whole = load_log(p)
    for rows in (61, 1000):
        chunks = list(stream_log(p, chunk_rows=rows))
        assert all(c.channel_map == whole.channel_map for c in chunks)
        _same_signals(concat_logs(chunks), whole)
        assert chunks[0].warnings == whole.warnings


# ------------------------------------------------------------------ every command, and MDF4
def test_map_reads_the_guessed_log_as_with_the_map_channels_writes(drive, tmp_path):
    """``roadbank map`` on a log with its own names and a GNSS position (lat, lon): without a map, as with the one
    ``roadbank channels`` writes for it."""
    s = drive.signals
    cols = dict(_renamed(s), lat=drive.extra["lat_deg"], lon=drive.extra["lon_deg"])
    log = _write(tmp_path / "gnss.csv", cols)
    m = tmp_path / "m.toml"
    assert CliRunner().invoke(main, ["channels", str(log), "-o", str(m)]).exit_code == 0
    outs = []
    for args in ([], ["--channels", str(m)]):
        out = tmp_path / f"map{len(args)}.parquet"
        res = CliRunner().invoke(main, ["map", str(log), "-o", str(out), *args])
        assert res.exit_code == 0, res.output
        outs.append(pq.read_table(out))
    assert outs[0].num_rows > 0 and outs[0].schema.equals(outs[1].schema)
    for c in outs[0].column_names:                  # (a cell's NaN spread, where it has one sample, is NaN in both)
        np.testing.assert_array_equal(outs[0][c].to_numpy(), outs[1][c].to_numpy(), err_msg=c)


@pytest.mark.parametrize("command", [["identify"], ["export", "c", "--roll-rate"]])
def test_identify_and_export_read_the_guessed_log_and_say_so(drive, tmp_path, command):
    log = _write(tmp_path / "guessed.csv", _renamed(drive.signals))
    out = tmp_path / ("car.toml" if command[0] == "identify" else "c")
    args = [*command, str(log)] if command[0] == "identify" else [*command, "--log", str(log)]
    res = CliRunner().invoke(main, [*args, "-o", str(out)])
    assert "Traceback" not in res.output and "FAILED" not in res.output, res.output
    assert f"warning: {log}: no column 'vx' (the default channel map's speed): read with the channel map guessed" \
        in res.stderr, res.stderr
    assert out.exists()


def test_an_mdf4_log_with_its_own_channel_names(drive, tmp_path):
    asammdf = pytest.importorskip("asammdf", reason="optional extra 'mdf' (asammdf) not installed")
    s = drive.signals

    def mdf(path, cols):
        f = asammdf.MDF(version="4.10")
        f.append([asammdf.Signal(np.asarray(v, dtype=np.float64), s.t, name=c) for c, v in cols.items()])
        f.save(path, overwrite=True)
        return path

    own = mdf(tmp_path / "own.mf4", {k: v for k, v in _own(s).items() if k != "t"})
    guessed = mdf(tmp_path / "guessed.mf4", {"VehicleSpeed": s.vx, "LatAcc": s.ay, "YawRate": s.r, "RollRate": s.p})
    log = load_log(guessed)
    assert "speed <- 'VehicleSpeed' (m/s" in log.warnings[0], log.warnings
    _same_signals(log, load_log(own))
    _same_signals(concat_logs(list(stream_log(guessed, chunk_rows=100))), log)


# ------------------------------------------------------------------ a GNSS position under the default map
def _gnss(drive, **more) -> dict:
    """The drive under roadbank's own names with its GNSS position as ``lat``, ``lon`` (deg)."""
    s = drive.signals
    return {"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "lat": drive.extra["lat_deg"], "lon": drive.extra["lon_deg"],
            **more}


def _map(log: Path, out: Path, *args) -> tuple[int, str]:
    res = CliRunner().invoke(main, ["map", str(log), "-o", str(out), *args])
    assert "Traceback" not in res.output, res.output
    return res.exit_code, res.stderr


GNSS_MAP = """[channels]
time = { column = "t", unit = "s" }
speed = { column = "vx", unit = "m/s" }
lateral_acceleration = { column = "ay", unit = "m/s^2" }
yaw_rate = { column = "r", unit = "rad/s" }
latitude = { column = "lat", unit = "deg" }
longitude = { column = "lon", unit = "deg" }
"""


def test_map_reads_lat_lon_beside_roadbanks_own_names_as_with_a_map(drive, tmp_path):
    """t, vx, ay, r, lat, lon: before, ``roadbank map`` without a map failed (no GNSS position: the default map found
    t, vx, ay, r and read nothing more); now the pair is read, and the bank map is the one a map naming it gives, to the
    byte."""
    log = _write(tmp_path / "gnss.csv", _gnss(drive))
    m = tmp_path / "m.toml"
    m.write_text(GNSS_MAP)
    code, said = _map(log, tmp_path / "guessed.parquet")
    assert code == 0, said
    assert code == _map(log, tmp_path / "pinned.parquet", "--channels", str(m))[0]
    assert (tmp_path / "guessed.parquet").read_bytes() == (tmp_path / "pinned.parquet").read_bytes()
    assert pq.read_table(tmp_path / "guessed.parquet").num_rows > 0
    assert (f"warning: {log}: channels 'latitude', 'longitude' (columns 'lat', 'lon'): read as a GNSS position in deg "
            "(the default channel map has none") in said, said
    assert PIN.format("gnss.csv") in said
    read = load_log(log)
    np.testing.assert_allclose(read.extra["lat_deg"], drive.extra["lat_deg"], rtol=1e-15)
    np.testing.assert_allclose(read.extra["lon_deg"], drive.extra["lon_deg"], rtol=1e-15)
    _same_signals(read, load_log(log, channels=m))
    # estimate does not read the position: its output is that of the log without it
    without = _write(tmp_path / "plain.csv", {k: v for k, v in _gnss(drive).items() if k not in ("lat", "lon")})
    assert _estimate(log, tmp_path)[0] == _estimate(without, tmp_path)[0]


@pytest.mark.parametrize("names", [("latitude", "longitude"), ("gps_lat", "gps_lon"), ("lat_deg", "lon_deg")])
def test_other_spellings_of_the_pair_are_read(drive, tmp_path, names):
    cols = _gnss(drive)
    cols[names[0]], cols[names[1]] = cols.pop("lat"), cols.pop("lon")
    read = load_log(_write(tmp_path / "gnss.parquet", cols))
    assert {read.channel_map.channels[r].column for r in ("latitude", "longitude")} == set(names)
    np.testing.assert_allclose(read.extra["lat_deg"], drive.extra["lat_deg"], rtol=1e-15)


def test_one_coordinate_alone_is_not_read(drive, tmp_path):
    """``lat`` without a longitude: no half position (``lat`` may be anything else, too), said by ``roadbank map``,
    which finds none; the log reads as without it."""
    cols = {k: v for k, v in _gnss(drive).items() if k != "lon"}
    log = _write(tmp_path / "lat.csv", cols)
    read = load_log(log)
    assert "lat_deg" not in read.extra and "latitude" not in read.channel_map.channels
    assert not any("'lat'" in w for w in read.warnings), read.warnings
    code, said = _map(log, tmp_path / "o.parquet")
    assert code != 0 and f"FAILED {log}: no GNSS position" in said, said


@pytest.mark.parametrize("scaled", ["lat", "lon"])
def test_a_pair_beyond_the_earths_degrees_is_not_read_and_said(drive, tmp_path, scaled):
    """A coordinate as a scaled integer (deg x 1e7, as many receivers log it) is not degrees: the pair is not read,
    and a warning names the column, the value and how to read it."""
    cols = _gnss(drive)
    cols[scaled] = np.round(cols[scaled] * 1e7)
    log = _write(tmp_path / "e7.csv", cols)
    read = load_log(log)
    assert "lat_deg" not in read.extra and "latitude" not in read.channel_map.channels
    (w,) = [w for w in read.warnings if "GNSS" in w]
    limit = {"lat": "the latitude's 90 deg", "lon": "the longitude's 180 deg"}[scaled]
    assert w.startswith(f"{log}: columns 'lat', 'lon' are named like a GNSS position, not read as one: '{scaled}' "
                        "reaches "), w
    assert f"beyond {limit} (a scaled integer, or another unit)" in w and PIN.format("e7.csv") in w, w
    code, said = _map(log, tmp_path / "o.parquet")
    assert code != 0 and f"FAILED {log}: no GNSS position" in said, said


def test_a_pair_that_leaves_the_earth_after_the_rows_guessed_is_no_position_there_and_said(drive, tmp_path,
                                                                                            monkeypatch):
    """The guess reads the first rows; a latitude beyond 90 deg later (a logger's fill value on a lost fix) is not taken
    silently, nor does it lose the log, whose estimate does not need the position: those samples are no position
    (NaN) and a warning names the channel and how many, whole or streamed; the estimate is the log's without the pair.
    A map the user wrote that names the channel still fails the read there."""
    monkeypatch.setattr(mapchoice, "GUESS_ROWS", 700)
    cols = _gnss(drive)
    cols["lat"] = cols["lat"].copy()
    cols["lat"][800:] *= 1e7
    log = _write(tmp_path / "late.csv", cols)
    read = load_log(log)
    lat = read.extra["lat_deg"]
    assert np.isnan(lat[800:]).all() and np.isfinite(lat[:800]).all()
    said = [w for w in read.warnings if "channel 'latitude' (column 'lat'): |value| beyond 90 deg" in w]
    assert len(said) == 1 and f"in {len(lat) - 800} sample(s)" in said[0]
    chunks = list(stream_log(log, chunk_rows=100))
    assert np.array_equal(np.concatenate([c.extra["lat_deg"] for c in chunks]), lat, equal_nan=True)
    assert any("beyond 90 deg" in w for c in chunks for w in c.warnings)
    assert np.array_equal(read.signals.ay, load_log(_write(tmp_path / "plain.csv", _gnss(drive))).signals.ay)
    (tmp_path / "map.toml").write_text(GNSS_MAP)
    with pytest.raises(LogError, match=r"channel 'latitude' \(column 'lat'\): \|value\| beyond 90 deg"):
        load_log(log, channels=read_channel_map(tmp_path / "map.toml"))


def test_a_guessed_log_whose_pair_is_not_degrees_says_so(drive, tmp_path):
    """The same rule where the whole map is guessed: a pair not read is said, not passed over."""
    cols = dict(_renamed(drive.signals), lat=drive.extra["lat_deg"], lon=np.round(drive.extra["lon_deg"] * 1e7))
    read = load_log(_write(tmp_path / "g.csv", cols))
    assert "latitude" not in read.channel_map.channels and "lat_deg" not in read.extra
    assert any("are named like a GNSS position, not read as one: 'lon' reaches" in w for w in read.warnings)


@pytest.mark.parametrize("kind", ["gnss.csv", "gnss.parquet"])
def test_the_position_streamed_equals_the_position_read_whole(drive, tmp_path, monkeypatch, kind):
    monkeypatch.setattr(mapchoice, "GUESS_ROWS", 700)
    monkeypatch.setattr(csvtable, "CSV_WHOLE_BYTES", 0)
    p = _write(tmp_path / kind, _gnss(drive))
    whole = load_log(p)
    assert {"latitude", "longitude"} <= set(whole.channel_map.channels)
    for rows in (61, 1000):
        chunks = list(stream_log(p, chunk_rows=rows))
        assert all(c.channel_map == whole.channel_map for c in chunks)
        joined = concat_logs(chunks)
        _same_signals(joined, whole)
        for k in ("lat_deg", "lon_deg"):
            np.testing.assert_array_equal(joined.extra[k], whole.extra[k], err_msg=k)
        assert chunks[0].warnings == whole.warnings


# ------------------------------------------------------------------ a steering angle under another name
@pytest.fixture(scope="module")
def sim():
    """A simulated SUV drive with steering (identification.check's case: offsets on every sensor) and its steering
    ratio."""
    case = SimCase()
    log, _ = simulate_case(case)
    return log.signals, case.params.steering_ratio


def _steer_cols(sim, name: str, unit: str = "deg") -> dict:
    s, ratio = sim
    swa = s.delta_f * ratio
    return {"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, name: np.degrees(swa) if unit == "deg" else swa}


def _pinned(tmp_path: Path, name: str, unit: str = "deg") -> Path:
    m = tmp_path / "steer.toml"
    m.write_text(GNSS_MAP.split("latitude")[0] + f'steering_wheel_angle = {{ column = "{name}", unit = "{unit}" }}\n')
    return m


def test_identify_reads_a_steering_angle_named_swa_as_with_a_map(sim, tmp_path):
    """t, vx, ay, r, SWA (deg): before, the steering was NaN (the default map's delta_f and steering_wheel_angle not
    in the file) and identify refused Cf, Cr, Kus and the steering offset; now the column is read (its guess high:
    name, size against L r / vx and sign agree), and identify gives what it gives with a map naming it."""
    log = _write(tmp_path / "swa.csv", _steer_cols(sim, "SWA"))
    m = _pinned(tmp_path, "SWA")
    outs, said = [], ""
    for args in ([], ["--channels", str(m)]):
        res = CliRunner().invoke(main, ["identify", str(log), "--json", "-o", str(tmp_path / f"c{len(args)}.toml"),
                                        *args])
        assert res.exit_code == 0 and "Traceback" not in res.output, res.output
        outs.append(res.stdout)
        said = said or res.stderr
    assert outs[0] == outs[1]
    assert set(json.loads(outs[0])["quantities"]) >= {"Cf", "Cr", "Kus", "steering_offset"}
    assert all("refused" not in q for q in json.loads(outs[0])["quantities"].values())
    assert (f"warning: {log}: channel 'steering_wheel_angle' (column 'SWA'): read as the steering wheel angle in deg, "
            "sign as stored (the default channel map's columns 'delta_f' and 'steering_wheel_angle' are not in the "
            "file; this one is named like it and its guess is high") in said, said
    assert "no column 'delta_f'" not in said.replace("columns 'delta_f'", "")


@pytest.mark.parametrize("name, unit", [("SWA", "deg"), ("steer_deg", "deg"), ("SteeringWheelAngle", "deg")])
def test_a_steering_angle_named_otherwise_reads_as_with_a_map(sim, tmp_path, name, unit):
    log = _write(tmp_path / "s.parquet", _steer_cols(sim, name, unit))
    read = load_log(log)
    assert read.channel_map.channels["steering_wheel_angle"].column == name
    assert "road_wheel_angle" not in read.channel_map.channels
    _same_signals(read, load_log(log, channels=_pinned(tmp_path, name, unit)))


def test_a_steering_angle_whose_guess_is_not_high_is_left_out_and_said(sim, tmp_path):
    """A steering-wheel angle in rad: against L r / vx (x32 here, the SUV understeers) its size fits a road-wheel
    angle in deg as well, so the guess is medium: not read, the steering NaN as before, with today's warning and one
    that says why."""
    log = _write(tmp_path / "rad.csv", _steer_cols(sim, "SteeringWheelAngle", "rad"))
    read = load_log(log)
    assert np.isnan(read.signals.delta_f).all()
    (why,) = [w for w in read.warnings if "'SteeringWheelAngle'" in w]
    assert why.startswith(f"{log}: channel 'steering_wheel_angle' (column 'SteeringWheelAngle'): not read as the "
                          "steering angle, its guess is medium (not high: "), why
    assert PIN.format("rad.csv") + ", check its unit and sign" in why
    assert any("channel 'steering': no column 'delta_f' or 'steering_wheel_angle', so the steering angle is NaN" in w
               for w in read.warnings), read.warnings
    # the same log under a map naming the column in rad reads it
    pinned = load_log(log, channels=_pinned(tmp_path, "SteeringWheelAngle", "rad"))
    assert np.isfinite(pinned.signals.delta_f).all()


def test_a_steering_column_that_is_not_a_spelling_is_not_guessed(sim, tmp_path):
    """``steer_rate`` only starts like a steering angle: not read, and no guess is made for it."""
    cols = _steer_cols(sim, "steer_rate")
    read = load_log(_write(tmp_path / "rate.csv", cols))
    assert np.isnan(read.signals.delta_f).all() and not any("steer_rate" in w for w in read.warnings)


def test_the_steering_streamed_equals_the_steering_read_whole(sim, tmp_path, monkeypatch):
    monkeypatch.setattr(mapchoice, "GUESS_ROWS", 5000)          # of its 18 321 rows
    monkeypatch.setattr(csvtable, "CSV_WHOLE_BYTES", 0)
    p = _write(tmp_path / "swa.csv", _steer_cols(sim, "SWA"))
    whole = load_log(p)
    assert whole.channel_map.channels["steering_wheel_angle"].column == "SWA"
    for rows in (777, 20_000):
        chunks = list(stream_log(p, chunk_rows=rows))
        assert all(c.channel_map == whole.channel_map for c in chunks)
        _same_signals(concat_logs(chunks), whole)
        assert chunks[0].warnings == whole.warnings

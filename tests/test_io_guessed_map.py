"""A table log read without a channel map whose columns are not roadbank's own (roadbank.io.mapchoice).

Where the default map (t, vx, ay, r, SI) misses a required column, the log is read with the map
``roadbank channels`` guesses, if every required channel's guess is ``high``; else it is refused as before, the
message naming the file, what the guess found and why it was not trusted. Where the default map reads the log, a
column named like a roll rate (longitudinal acceleration, pitch rate) under another name is read too.

Truth: a real drive (KITTI 2011_10_03_drive_0047: its INS's speed, ay, yaw rate and roll rate) written with roadbank's
own column names and read with the default map. The same columns under other names in the same units give the same
output to the bit; in other units (km/h) the same to rounding; with a mirrored yaw rate (which the guess inverts) to
the bit. Streamed in chunks, the same as read whole.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.io import LogError, csvtable, load_log, mapchoice
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

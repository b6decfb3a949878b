"""A CSV export with a units row under its header (CANape, CANoe, INCA, DEWESoft and spreadsheets write one): read
in the units it states where the channel map is roadbank's default, named where a user's map says otherwise, and
guessed from by ``roadbank channels``."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.io import LogError, load_log
from roadbank.io.readers import read_csv
from roadbank.sim import run_scenario

G = 9.81


@pytest.fixture(scope="module")
def drive():
    return run_scenario("s-curve").signals


def _write(path, df: pd.DataFrame, units: str, sep: str = ",", decimal: str = "."):
    lines = df.to_csv(index=False, sep=sep, decimal=decimal, float_format="%.10g").splitlines()
    path.write_text("\n".join([lines[0], units] + lines[1:]) + "\n")
    return path


def _theta(path) -> np.ndarray:
    return pd.read_csv(path)["kinematic-pif.theta"].to_numpy()


def test_the_default_map_reads_the_units_the_row_states(tmp_path, drive):
    """t, vx, ay, r in s, km/h, g and deg/s with a units row: the estimate is that of the same log in SI (within
    the rounding of the written digits), each replaced unit said once; an SI units row says nothing."""
    si = pd.DataFrame({"t": drive.t, "vx": drive.vx, "ay": drive.ay, "r": drive.r})
    si.to_csv(tmp_path / "si.csv", index=False, float_format="%.10g")
    other = pd.DataFrame({"t": drive.t, "vx": drive.vx * 3.6, "ay": drive.ay / G, "r": np.degrees(drive.r)})
    _write(tmp_path / "kmh.csv", other, "[s],[km/h],[g],[deg/s]")
    _write(tmp_path / "same.csv", si, "s,m/s,m/s^2,rad/s")
    runs = {}
    for name in ("si", "kmh", "same"):
        res = CliRunner().invoke(main, ["estimate", str(tmp_path / f"{name}.csv"), "-o",
                                        str(tmp_path / f"{name}.o.csv")])
        assert res.exit_code == 0, res.output
        runs[name] = (res.output, _theta(tmp_path / f"{name}.o.csv"))
    np.testing.assert_array_equal(runs["same"][1], runs["si"][1])
    np.testing.assert_allclose(runs["kmh"][1], runs["si"][1], rtol=0, atol=1e-8)
    said = [ln for ln in runs["kmh"][0].splitlines() if "the unit the file states" in ln]
    assert len(said) == 3 and all("kmh.csv" in ln for ln in said), said
    assert any("channel 'speed' (column 'vx'): read in 'km/h'" in ln and "assumes 'm/s'" in ln for ln in said)
    assert "the file states" not in runs["same"][0] and "the unit the file states" not in runs["same"][0]


def test_line_numbers_count_the_units_row_and_a_row_that_is_not_units_is_data(tmp_path, drive):
    """The units row is line 2: a bad value on the file's line 6 is named as line 6, read whole or by the fast path;
    a second header line of words without a unit (a description) is data, refused as not a number."""
    df = pd.DataFrame({"t": drive.t[:50], "vx": drive.vx[:50], "ay": drive.ay[:50], "r": drive.r[:50]})
    path = _write(tmp_path / "bad.csv", df, "s,m/s,m/s^2,rad/s")
    lines = path.read_text().splitlines()
    assert read_csv(path, {"t": "time"}).rownums[:2] == [3, 4]
    assert read_csv(path, {"t": "time"}).units == {"t": "s", "vx": "m/s", "ay": "m/s^2", "r": "rad/s"}
    lines[5] = lines[5].replace(lines[5].split(",")[2], "oops", 1)
    path.write_text("\n".join(lines) + "\n")
    res = CliRunner().invoke(main, ["estimate", str(path), "-o", str(tmp_path / "x.csv")])
    assert res.exit_code == 1 and "non-numeric value 'oops' at line 6" in res.output, res.output
    words = _write(tmp_path / "words.csv", df, "time,vehicle speed,lateral acceleration,yaw rate")
    assert read_csv(words, {}).units == {}
    res = CliRunner().invoke(main, ["estimate", str(words), "-o", str(tmp_path / "y.csv")])
    assert res.exit_code == 1 and "non-numeric value 'time' at line 2" in res.output, res.output


def test_a_users_map_wins_and_a_different_row_is_named(tmp_path, drive):
    """A channel map the user wrote declares m/s where the row says km/h: read in m/s, with a warning naming both;
    a row unit of another kind (deg under the speed) is said and the map's kept."""
    df = pd.DataFrame({"time": drive.t, "speed": drive.vx, "acc": drive.ay, "yaw": drive.r})
    _write(tmp_path / "log.csv", df, "s,km/h,m/s^2,rad/s")
    _write(tmp_path / "kind.csv", df, "s,deg,m/s^2,rad/s")
    (tmp_path / "m.toml").write_text('[channels]\ntime = { column = "time", unit = "s" }\n'
                                     'speed = { column = "speed", unit = "m/s" }\n'
                                     'lateral_acceleration = { column = "acc", unit = "m/s^2" }\n'
                                     'yaw_rate = { column = "yaw", unit = "rad/s" }\n')
    for name, words in (("log", "the file states 'km/h', the channel map 'm/s': read in 'm/s'"),
                        ("kind", "the file states 'deg', not a unit of its kind (speed): read in 'm/s'")):
        log = load_log(tmp_path / f"{name}.csv", channels=tmp_path / "m.toml")
        np.testing.assert_allclose(log.signals.vx, drive.vx, rtol=1e-9)
        said = [w for w in log.warnings if "the file states" in w]
        assert len(said) == 1 and words in said[0] and "channel 'speed' (column 'speed')" in said[0], said


def test_channels_guesses_from_the_units_row_of_a_tools_export(tmp_path, drive):
    """A tool's export (';', decimal commas, a units row with degree signs, names without units): the guessed map
    takes the row's units, says so, and reads the log as the same log in SI."""
    df = pd.DataFrame({"Time": drive.t, "VehSpd": drive.vx * 3.6, "LatAcc": drive.ay / G,
                       "YawRate": np.degrees(drive.r), "SteerAngle": np.degrees(drive.delta_f * 16.0)})
    path = _write(tmp_path / "export.csv", df, "[s];[km/h];[g];[°/s];[°]", sep=";", decimal=",")
    res = CliRunner().invoke(main, ["channels", str(path), "-o", str(tmp_path / "m.toml")])
    assert res.exit_code == 0, res.output
    for role, unit in (("speed", "km/h"), ("lateral_acceleration", "g"), ("yaw_rate", "deg/s"),
                       ("steering_wheel_angle", "deg")):
        line = next(ln for ln in res.output.splitlines() if ln.startswith(role))
        assert f" in {unit}" in line and "high" in line, line
    assert "unit the file states" in res.output
    log = load_log(path, channels=tmp_path / "m.toml")
    np.testing.assert_allclose(log.signals.vx, drive.vx, rtol=1e-9)
    np.testing.assert_allclose(log.signals.r, drive.r, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("chunk_rows", [None, 300])
def test_an_mdf4_channels_own_unit_is_read_whole_or_streamed(tmp_path, drive, chunk_rows):
    """MDF4 channels named as roadbank's default map names them, in km/h, g and deg/s by their own units: read in
    those units, whole or streamed, each said once; channels guesses them as stated."""
    asammdf = pytest.importorskip("asammdf", reason="asammdf (the mdf extra) is not installed")
    from roadbank.io.stream import stream_log

    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(drive.vx * 3.6, drive.t, name="vx", unit="km/h"),
                asammdf.Signal(drive.ay / G, drive.t, name="ay", unit="g"),
                asammdf.Signal(np.degrees(drive.r), drive.t, name="r", unit="°/s")])
    path = tmp_path / "log.mf4"
    mdf.save(path, overwrite=True)
    logs = [load_log(path)] if chunk_rows is None else list(stream_log(path, chunk_rows=chunk_rows))
    vx = np.concatenate([log.signals.vx for log in logs])
    t = np.concatenate([log.signals.t for log in logs])
    np.testing.assert_allclose(vx, np.interp(t, drive.t, drive.vx), rtol=1e-9)
    said = [w for log in logs for w in log.warnings if "the unit the file states" in w]
    assert len(said) == 3 and any("(column 'r'): read in '°/s'" in w for w in said), said
    if chunk_rows is None:
        res = CliRunner().invoke(main, ["channels", str(path), "-o", str(tmp_path / "m.toml")])
        assert res.exit_code == 0 and "'vx' in km/h" in res.output and "'r' in deg/s" in res.output, res.output


@pytest.mark.parametrize("kind, spelling, canonical", [
    ("speed", "m/sec", "m/s"), ("speed", "KPH", "kph"), ("acceleration", "m/s/s", "m/s^2"),
    ("acceleration", "m s-2", "m/s^2"), ("acceleration", "m/s²", "m/s^2"), ("angular_rate", "dps", "deg/s"),
    ("angular_rate", "°/sec", "deg/s"), ("angle", "°", "deg"), ("time", "µs", "us")])
def test_the_spellings_tools_write_are_units(kind, spelling, canonical):
    """Units as tools and units rows spell them read as the channel map's own spelling, with its factor."""
    from roadbank.units import FACTORS, factor, normalise_unit

    assert normalise_unit(spelling) == canonical and factor(kind, spelling) == FACTORS[kind][canonical]


def test_a_recorders_preamble_before_the_header_is_left_out(tmp_path, drive):
    """Lines a recorder writes before the table (``Recorder: DEWE-43``, a blank line, ``Date;06.12.2026``): read as a
    preamble, said once with the lines, the estimate that of the file without them. A header short of a name (three
    names over four fields) is not taken for one: refused as before, naming the line."""
    df = pd.DataFrame({"t": drive.t, "vx": drive.vx, "ay": drive.ay, "r": drive.r})
    df.to_csv(tmp_path / "plain.csv", index=False, float_format="%.10g")
    table = (tmp_path / "plain.csv").read_text()
    (tmp_path / "pre.csv").write_text("Recorder: DEWE-43\n\nDate;06.12.2026\n" + table)
    for name in ("plain", "pre"):
        res = CliRunner().invoke(main, ["estimate", str(tmp_path / f"{name}.csv"), "-o",
                                        str(tmp_path / f"{name}.o.csv")])
        assert res.exit_code == 0, res.output
    said = [ln for ln in res.output.splitlines() if "preamble" in ln]
    assert len(said) == 1 and "lines 1-3 before the header (line 4)" in said[0] and "'Recorder: DEWE-43'" in said[0]
    np.testing.assert_array_equal(_theta(tmp_path / "pre.o.csv"), _theta(tmp_path / "plain.o.csv"))
    short = table.replace("t,vx,ay,r", "t,vx,ay", 1)
    (tmp_path / "short.csv").write_text(short)
    res = CliRunner().invoke(main, ["estimate", str(tmp_path / "short.csv"), "-o", str(tmp_path / "s.o.csv")])
    assert res.exit_code == 1 and "line 2 has 4 field(s) but the header has 3" in res.output, res.output


def test_a_windows_export_is_read_as_windows_1252(tmp_path, drive):
    """A tool's export written in Windows-1252 (the degree sign of its units row one byte, 0xB0): read, said once;
    a file with a NUL byte is still no text."""
    df = pd.DataFrame({"Time": drive.t, "VehSpd": drive.vx * 3.6, "LatAcc": drive.ay, "YawRate": np.degrees(drive.r)})
    utf8 = _write(tmp_path / "utf8.csv", df, "s;km/h;m/s²;°/s", sep=";", decimal=",")
    cp = tmp_path / "cp1252.csv"
    cp.write_bytes(utf8.read_text(encoding="utf-8").encode("cp1252"))
    assert b"\xb0/s" in cp.read_bytes()
    got, want = (read_csv(f, {"VehSpd": "speed", "YawRate": "yaw_rate"}) for f in (cp, utf8))
    assert got.units == want.units == {"Time": "s", "VehSpd": "km/h", "LatAcc": "m/s²", "YawRate": "°/s"}
    np.testing.assert_array_equal(got.data["YawRate"], want.data["YawRate"])
    assert [w for w in got.warnings if "read as Windows-1252" in w and "0xB2" in w]
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"t,vx\n0,\xff\x00\n")
    with pytest.raises(LogError, match="not a text"):
        read_csv(binary, {"t": "time"})

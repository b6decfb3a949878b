"""Channel maps and ``roadbank channels`` on real drives: a log without a steering channel, the speed's unit
among m/s, km/h and mph, and the sign convention the data cannot tell.

Truth: KITTI raw drives (``roadbank.io.kitti``, SI and ISO 8855 as the INS records them) written as another
logger would (own column names, the speed in another unit, the signs mirrored); the guessed or hand-written
map must read them back into the drive's own signals, and ``roadbank estimate`` must give the drive's own
estimate. Where the data cannot decide, the guess must not claim to be sure.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from roadbank.constants import G
from roadbank.cli import main
from roadbank.io import LogError, load_log, read_channel_map
from roadbank.io.channels import ChannelMap, ChannelSpec, channel_map_from_dict
from roadbank.io.guess import guess_channels
from roadbank.io.kitti import load_kitti_oxts
from roadbank.io.writers import write_table

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
SHARED = ("2011_10_03_drive_0047", "2011_09_26_drive_0070")
#: speed units and their SI factors, written here (1 mph = 0.44704 m/s exactly, 1 km/h = 1/3.6 m/s)
TO_SI = {"m/s": 1.0, "km/h": 1.0 / 3.6, "mph": 0.44704}
#: the slopes of ay on vx r real roads give (1 on a flat road; bank lowers it, body roll raises it)
ROAD_SLOPES = (0.7, 1.3)
#: the estimators that read the steering angle (docs/io.md)
STEERING_READERS = ("dfc", "uio", "pio-original", "pif-original", "kalman")


def _drive_dir(name: str) -> Path:
    for folder in ("kitti-oxts", "kitti-oxts-extra"):
        p = DATA / folder / name
        if (p / "oxts").is_dir():
            return p
    pytest.skip(f"KITTI drive {name} absent under {DATA} (kitti-oxts, kitti-oxts-extra)")


def _all_drives() -> list[str]:
    found = sorted({p.parent.name for folder in ("kitti-oxts", "kitti-oxts-extra")
                    for p in (DATA / folder).glob("2011_*/oxts")})
    return found or ["(no KITTI drive)"]


_CACHE: dict[str, object] = {}


def _signals(name: str):
    if name not in _CACHE:
        _CACHE[name] = load_kitti_oxts(_drive_dir(name))
    return _CACHE[name]


def _columns(name: str, unit: str = "m/s", speed_col: str = "VehSpd", steering: bool = False,
             mirrored: bool = False) -> dict:
    """The drive as a logger with its own names writes it: the speed in ``unit``; optionally a steering-wheel angle
    in deg (the kinematic one, ratio 16, wheelbase 2.7 m); ``mirrored``: ay, yaw rate and steering positive right.
    The INS's roll rate in deg/s (the same about the forward axis in either convention), its longitudinal
    acceleration in g and its pitch rate in deg/s (``mirrored``: positive nose up, as about a right axis)."""
    s = _signals(name).signals
    sign = -1.0 if mirrored else 1.0
    cols = {"timestamp": s.t, speed_col: s.vx / TO_SI[unit], "LatAcc": sign * s.ay, "YawRate": sign * s.r,
            "RollRate": np.degrees(s.p), "LongAcc": s.ax / G, "PitchRate": sign * np.degrees(s.q)}
    if steering:
        cols["SWA"] = sign * np.degrees(16.0 * 2.7 * s.r / np.maximum(s.vx, 2.0))
    return cols


def _slope(name: str) -> float:
    """Least-squares slope of ay on vx r (SI) over the drive's turns (|r| > 0.03 rad/s, vx > 5 m/s,
    |vx r| >= 1 m/s^2), as the drive stores them."""
    s = _signals(name).signals
    vr = s.vx * s.r
    sel = (np.abs(s.r) > 0.03) & (s.vx > 5.0) & (np.abs(vr) >= 1.0) & np.isfinite(vr) & np.isfinite(s.ay)
    return float(np.dot(s.ay[sel], vr[sel]) / np.dot(vr[sel], vr[sel]))


def _speed_guess(cols: dict):
    return {g.role: g for g in guess_channels(list(cols), cols)}


def _estimate(args: list[str]) -> tuple[str, pd.DataFrame | None]:
    res = CliRunner().invoke(main, ["estimate", *args])
    assert res.exit_code == 0, res.output
    out = Path(args[args.index("-o") + 1])
    return res.output, pd.read_csv(out)


def _rows(output: str, estimator: str) -> str:
    """The summary row of ``estimator`` without its log name."""
    line = next(ln for ln in output.splitlines() if f" {estimator} " in f" {ln} ")
    return line.split(estimator, 1)[1].strip()


# ------------------------------------------------------------------ a log without a steering channel
HAND_MAP = """
convention = "ISO"
[channels]
time = { column = "timestamp", unit = "s" }
speed = { column = "VehSpd", unit = "m/s" }
lateral_acceleration = { column = "LatAcc", unit = "m/s^2" }
yaw_rate = { column = "YawRate", unit = "rad/s" }
"""
#: the drive's roll rate and longitudinal acceleration, for a map that reads them
IMU = ('roll_rate = { column = "RollRate", unit = "deg/s", unbiased = true }\n'
       'longitudinal_acceleration = { column = "LongAcc", unit = "g", unbiased = true }\n'
       'pitch_rate = { column = "PitchRate", unit = "deg/s", unbiased = true }\n')


def test_map_without_steering_reads_and_estimates_as_the_kitti_drive(tmp_path):
    """A hand-written map with no steering channel is valid: the log reads with the steering angle NaN and
    the other channels as the drive stores them (the roll and pitch rates given in deg/s, in rad/s; ax in g, in
    m/s^2; all marked ``unbiased`` as the KITTI reader marks its INS's channels);
    `roadbank estimate` gives
    the drive's own estimate with the default estimator, and an estimator that reads the steering angle the same
    summary (no valid sample)."""
    name = SHARED[0]
    drive = _drive_dir(name)
    log_csv = write_table(tmp_path / "ins.csv", _columns(name))
    (tmp_path / "map.toml").write_text(HAND_MAP + IMU)
    cmap = read_channel_map(tmp_path / "map.toml")
    assert cmap.no_steering
    got, want = load_log(log_csv, channels=cmap), _signals(name)
    assert np.isnan(got.signals.delta_f).all()
    for k in ("t", "vx", "ay", "r", "p", "ax", "q"):
        np.testing.assert_allclose(getattr(got.signals, k), getattr(want.signals, k), rtol=1e-12, atol=1e-12)
    out_csv, theta_csv = _estimate([str(log_csv), "--channels", str(tmp_path / "map.toml"),
                                    "-o", str(tmp_path / "csv_out.csv")])
    out_kitti, theta_kitti = _estimate([str(drive), "-o", str(tmp_path / "kitti_out.csv")])
    np.testing.assert_allclose(theta_csv["kinematic-pif.theta"], theta_kitti["kinematic-pif.theta"],
                               rtol=1e-9, atol=1e-12)
    assert theta_csv["kinematic-pif.valid"].mean() > 0.9
    est = ",".join(("kinematic-pif",) + STEERING_READERS)
    out_csv, got_csv = _estimate([str(log_csv), "--channels", str(tmp_path / "map.toml"), "-e", est,
                                  "-o", str(tmp_path / "csv_all.csv")])
    out_kitti, _ = _estimate([str(drive), "-e", est, "-o", str(tmp_path / "kitti_all.csv")])
    for e in STEERING_READERS:
        assert _rows(out_csv, e) == _rows(out_kitti, e)
        assert "0.0%" in _rows(out_csv, e) and not got_csv[f"{e}.valid"].any()


def test_map_naming_a_steering_column_still_needs_it(tmp_path):
    """Leaving steering out is the way to say 'none': a map that names a steering column the file lacks is
    still refused, naming the column; a map built in code without steering must say no_steering."""
    cols = _columns(SHARED[0])
    log_csv = write_table(tmp_path / "ins.csv", cols)
    (tmp_path / "map.toml").write_text(HAND_MAP + 'steering_wheel_angle = { column = "SWA", unit = "deg" }\n')
    with pytest.raises(LogError, match=r"ins\.csv.*'steering'.*no column 'SWA'"):
        load_log(log_csv, channels=read_channel_map(tmp_path / "map.toml"))
    with_steer = channel_map_from_dict({"channels": {"time": "t", "speed": {"column": "v", "unit": "m/s"}}
                                        | {r: {"column": r, "unit": u} for r, u in (
                                            ("time", "s"), ("lateral_acceleration", "m/s^2"), ("yaw_rate", "rad/s"),
                                            ("road_wheel_angle", "rad"))}})
    assert not with_steer.no_steering
    specs = {r: ChannelSpec(r, r, u) for r, u in (("time", "s"), ("speed", "m/s"),
                                                  ("lateral_acceleration", "m/s^2"), ("yaw_rate", "rad/s"))}
    with pytest.raises(LogError, match="needs 'road_wheel_angle' or 'steering_wheel_angle'.*no_steering"):
        ChannelMap(specs)
    assert ChannelMap(specs, no_steering=True).no_steering


@pytest.mark.parametrize("nan_column", [False, True])
def test_channels_writes_a_map_without_steering_and_it_runs(tmp_path, nan_column):
    """`roadbank channels` on an INS log with no steering column (or one that is all NaN) writes a map
    without a steering channel, says so, exits 0; the map reads the drive's signals and estimates."""
    name = SHARED[0]
    cols = _columns(name)
    if nan_column:
        cols["SWA"] = np.full(len(cols["timestamp"]), np.nan)
    log_csv = write_table(tmp_path / "ins.csv", cols)
    m = tmp_path / "m.toml"
    res = CliRunner().invoke(main, ["channels", str(log_csv), "-o", str(m)])
    assert res.exit_code == 0, res.output
    assert "Traceback" not in res.output and "fill in" not in res.output
    steer_line = next(ln for ln in res.output.splitlines() if ln.startswith("steering "))
    assert "none" in steer_line and "kinematic-pif does not read it" in steer_line
    if nan_column:
        assert "'SWA' is named like a steering angle but holds no numbers" in steer_line
    cmap = read_channel_map(m)
    assert cmap.no_steering and not {"steering_wheel_angle", "road_wheel_angle"} & set(cmap.channels)
    assert "the map reads ins.csv" in res.output
    got = load_log(log_csv, channels=cmap).signals
    np.testing.assert_allclose(got.vx, _signals(name).signals.vx, rtol=1e-12)
    res = CliRunner().invoke(main, ["estimate", str(log_csv), "--channels", str(m), "-o", str(tmp_path / "o.csv")])
    assert res.exit_code == 0, res.output


# ------------------------------------------------------------------ the speed's unit
#: drives whose turns tell m/s, km/h and mph apart, or one from the others (the shared two first)
UNIT_DRIVES = SHARED + ("2011_09_30_drive_0018", "2011_09_30_drive_0034", "2011_09_26_drive_0036",
                        "2011_09_26_drive_0014", "2011_09_26_drive_0009", "2011_09_26_drive_0022")


@pytest.mark.parametrize("name", UNIT_DRIVES)
@pytest.mark.parametrize("unit", list(TO_SI))
def test_speed_unit_from_the_balance_with_a_neutral_name(name, unit):
    """The speed written in m/s, km/h or mph under a name without a unit (`VehSpd`) is guessed in its unit.
    'high' where the drive's slope of ay on vx r (computed here) puts no other unit's reading inside the
    slopes real roads give, never 'high' where another unit's reading lies well inside them."""
    g = _speed_guess(_columns(name, unit, steering=True))["speed"]
    assert g.unit == unit, g.reason
    slope = _slope(name)
    # stored speeds read in another unit u are TO_SI[u] / TO_SI[unit] times the true ones: the slope divides by it
    others = [slope * TO_SI[unit] / TO_SI[u] for u in TO_SI if u != unit]
    lo, hi = ROAD_SLOPES
    if all(not 0.93 * lo <= s <= 1.07 * hi for s in others):
        assert g.confidence == "high", g.reason
    if any(1.07 * lo <= s <= 0.93 * hi for s in others):
        assert g.confidence != "high", g.reason


def test_mph_on_a_drive_whose_balance_cannot_tell_mph_from_kmh():
    """Drive 0047 turns with a slope of 0.8 (banked turns): in mph its speed reads 0.8, as km/h 1.29 -- both
    slopes real roads give. The guess must not be 'high' and must name both units; a unit in the name
    (`VehSpd_mph`, `VehSpd_kmh`) decides it."""
    name = SHARED[0]
    slope = _slope(name)
    lo, hi = ROAD_SLOPES
    assert lo < slope < hi and lo < slope * TO_SI["mph"] / TO_SI["km/h"] < hi     # the premise, from the data
    g = _speed_guess(_columns(name, "mph"))["speed"]
    assert g.confidence != "high" and "mph" in g.reason and "km/h" in g.reason and "cannot tell" in g.reason
    assert g.unit == "mph"          # nearer the middle of the band, though not sure
    for unit, col in (("mph", "VehSpd_mph"), ("km/h", "VehSpd_kmh")):
        g = _speed_guess(_columns(name, unit, speed_col=col))["speed"]
        assert (g.unit, g.confidence) == (unit, "high"), g.reason
        assert "unit in the name" in g.reason


@pytest.mark.parametrize("name", _all_drives())
def test_a_wrong_speed_unit_is_never_high(name):
    """On every drive at hand, in every speed unit: the guessed unit is right, or the guess is not 'high'."""
    for unit in TO_SI:
        g = _speed_guess(_columns(name, unit, steering=True))["speed"]
        assert g.unit == unit or g.confidence != "high", (unit, g.unit, g.reason)


@pytest.mark.parametrize("name", SHARED)
def test_mph_log_guessed_and_estimated_as_the_drive(tmp_path, name):
    """A US car log (speed in mph under `VehSpd`, the rest SI, a steering-wheel angle, the INS's roll rate in deg/s
    and ax in g): the map `roadbank channels` writes reads the speed in mph and the roll rate and ax in their units,
    and `roadbank estimate` with it gives the estimate of the same log written in SI and read with a map written
    here."""
    log_csv = write_table(tmp_path / "us.csv", _columns(name, "mph", steering=True))
    m = tmp_path / "m.toml"
    res = CliRunner().invoke(main, ["channels", str(log_csv), "-o", str(m)])
    assert res.exit_code == 0, res.output
    guessed = read_channel_map(m).channels
    assert guessed["speed"].unit == "mph"
    assert (guessed["roll_rate"].column, guessed["roll_rate"].unit) == ("RollRate", "deg/s")
    assert (guessed["longitudinal_acceleration"].column, guessed["longitudinal_acceleration"].unit) == ("LongAcc", "g")
    _, got = _estimate([str(log_csv), "--channels", str(m), "-o", str(tmp_path / "us_out.csv")])
    si_csv = write_table(tmp_path / "si.csv", _columns(name, "m/s", steering=True))
    as_guessed = IMU.replace(", unbiased = true", "")          # a guessed map does not say so
    swa = 'steering_wheel_angle = { column = "SWA", unit = "deg" }\n'
    (tmp_path / "si.toml").write_text(HAND_MAP + as_guessed + swa)
    _, want = _estimate([str(si_csv), "--channels", str(tmp_path / "si.toml"), "-o", str(tmp_path / "si_out.csv")])
    np.testing.assert_allclose(got["kinematic-pif.theta"], want["kinematic-pif.theta"], rtol=1e-9, atol=1e-12)


# ------------------------------------------------------------------ the sign convention
def test_a_mirrored_convention_is_assumed_iso_and_said_so(tmp_path):
    """A log whose ay, yaw rate and steering are all positive to the right balances ay = vx r exactly as an
    ISO one does: the guessed maps of the two are the same, the guess says that the convention cannot be told
    from the data and is assumed ISO (no sign is claimed from the data), exit 0; and the FRD convention the
    note points to reads the mirrored log back into the drive's ISO signals."""
    name = SHARED[0]
    iso = write_table(tmp_path / "iso.csv", _columns(name, steering=True))
    mirrored = write_table(tmp_path / "mirrored.csv", _columns(name, steering=True, mirrored=True))
    texts = {}
    for p in (iso, mirrored):
        res = CliRunner().invoke(main, ["channels", str(p), "-o", str(tmp_path / f"{p.stem}.toml")])
        assert res.exit_code == 0, res.output
        conv = next(ln for ln in res.output.splitlines() if ln.startswith("convention "))
        assert "cannot be told from the data and is assumed ISO" in conv and 'convention = "FRD"' in conv
        assert "agrees" not in res.output
        texts[p.stem] = (tmp_path / f"{p.stem}.toml").read_text()
    strip = [ln for ln in texts["iso"].splitlines() if "guessed by" not in ln]
    assert strip == [ln for ln in texts["mirrored"].splitlines() if "guessed by" not in ln]
    g = _speed_guess(_columns(name, steering=True, mirrored=True))
    assert not g["yaw_rate"].invert and not g["steering_wheel_angle"].invert
    assert "assumed" in g["lateral_acceleration"].reason and "cannot tell" in g["lateral_acceleration"].reason
    assert "if ay is positive to the left (assumed)" in g["yaw_rate"].reason
    want = _signals(name).signals
    read_iso = load_log(mirrored, channels=read_channel_map(tmp_path / "mirrored.toml")).signals
    np.testing.assert_allclose(read_iso.ay, -want.ay, rtol=1e-12, atol=1e-12)      # as documented: mirrored
    frd = tmp_path / "frd.toml"
    frd.write_text(texts["mirrored"].replace('convention = "ISO"', 'convention = "FRD"'))
    back = load_log(mirrored, channels=read_channel_map(frd)).signals
    np.testing.assert_allclose(back.ay, want.ay, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(back.r, want.r, rtol=1e-12, atol=1e-12)
    kin = 2.7 * want.r / np.maximum(want.vx, 2.0)
    assert np.corrcoef(back.delta_f, kin)[0, 1] > 0.99


def test_a_map_says_which_channels_are_unbiased_and_refuses_it_elsewhere():
    """``unbiased = true`` on the roll rate, ax or pitch rate of a hand-written map marks them
    (``ChannelMap.unbiased``, hence ``Signals.unbiased``); on a required channel, or with another value, it is an
    error naming the channel."""
    cmap = channel_map_from_dict(tomllib.loads(HAND_MAP + IMU), "m.toml")
    assert cmap.unbiased == {"p", "ax", "q"}
    plain = channel_map_from_dict(tomllib.loads(HAND_MAP + IMU.replace(", unbiased = true", "")), "m.toml")
    assert plain.unbiased == frozenset()
    for bad in (HAND_MAP.replace('unit = "m/s^2" }', 'unit = "m/s^2", unbiased = true }'),
                HAND_MAP + IMU.replace("unbiased = true", 'unbiased = "yes"')):
        with pytest.raises(LogError, match="unbiased"):
            channel_map_from_dict(tomllib.loads(bad), "m.toml")

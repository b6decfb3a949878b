"""``roadbank channels``: a channel map guessed for a foreign log.

Truth: a simulated log whose columns are renamed, rescaled to other units and sign-flipped copies
of roadbank's own; the guessed map must read it back into the original signals.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.io import load_log, read_channel_map
from roadbank.io.guess import NAMES, guess_channels, name_match
from roadbank.io.writers import write_table

SIG = ("t", "vx", "ay", "r", "delta_f")


@pytest.fixture(scope="module")
def drive():
    from roadbank.sim import run_scenario
    return run_scenario("s-curve", seed=2).table()


def _foreign(tab, steer="swa"):
    """The log as another logger writes it: ms, km/h, g, deg/s with the opposite sign, and the
    steering-wheel angle in deg (ratio 16, roadbank's default) or the road-wheel angle in deg."""
    out = {"timestamp": tab["t"] * 1000.0, "VehSpd": tab["vx"] * 3.6, "LatAcc": tab["ay"] / 9.81,
           "YawRate": -np.degrees(tab["r"]), "gear": np.full(len(tab["t"]), 4.0)}
    if steer == "swa":
        out["SWA"] = np.degrees(tab["delta_f"]) * 16.0
    else:
        out["wheel_angle"] = -np.degrees(tab["delta_f"])      # road wheel, FRD sign
    return out


@pytest.mark.parametrize("name, role, hint", [("VehSpd", "speed", None), ("speed_kmh", "speed", "km/h"),
                                              ("YawRate", "yaw_rate", None), ("yaw_rate_dps", "yaw_rate", "deg/s"),
                                              ("wz", "yaw_rate", None), ("LatAcc", "lateral_acceleration", None),
                                              ("SteerAngle", "steering_wheel_angle", None),
                                              ("timestamp", "time", None), ("time_ms", "time", "ms")])
def test_name_spellings(name, role, hint):
    assert name_match(role, name) == (2, hint)
    assert name_match("speed" if role != "speed" else "yaw_rate", name)[0] == 0


@pytest.mark.parametrize("name, role", [("Geschwindigkeit", "speed"), ("Querbeschleunigung", "lateral_acceleration"),
                                        ("Gierrate", "yaw_rate"), ("Lenkradwinkel", "steering_wheel_angle"),
                                        ("Längsbeschleunigung", "longitudinal_acceleration"),
                                        ("Laengsbeschleunigung", "longitudinal_acceleration"),
                                        ("Wankrate", "roll_rate"), ("Nickrate", "pitch_rate"),
                                        ("Vitesse", "speed"), ("Vitesse de lacet", "yaw_rate"),
                                        ("Accélération latérale", "lateral_acceleration"),
                                        ("Angle volant", "steering_wheel_angle")])
def test_german_and_french_names(name, role):
    """A German or French export's names (before: only 'Zeit' was known, the rest left for the user to map)."""
    assert name_match(role, name)[0] == 2, name


@pytest.mark.parametrize("steer", ["swa", "road-wheel"])
def test_guessed_map_reads_the_original_signals(tmp_path, drive, steer):
    orig = tmp_path / "orig.csv"
    write_table(orig, {k: drive[k] for k in SIG})
    foreign = tmp_path / "foreign.csv"
    write_table(foreign, _foreign(drive, steer))
    # read without a map: the default map's columns are not there, and the guess is sure (every required channel
    # high), so the log is read with it (before: refused, a map to write), said in a warning
    plain = load_log(foreign)
    said = plain.warnings[0]
    assert "read with the channel map guessed" in said and "yaw_rate <- 'YawRate' (deg/s, sign inverted" in said
    assert said.endswith("to pin it: roadbank channels foreign.csv -o map.toml, then --channels map.toml"), said
    m = tmp_path / "map.toml"
    res = CliRunner().invoke(main, ["channels", str(foreign), "-o", str(m)])
    assert res.exit_code == 0, res.output
    assert "'VehSpd' in km/h" in res.output and "'YawRate' in deg/s, inverted   high:" in res.output, res.output
    cmap = read_channel_map(m)                                        # the existing loader
    assert cmap.channels["lateral_acceleration"].unit == "g"
    got, want = load_log(foreign, channels=cmap), load_log(orig)
    for k in SIG:
        np.testing.assert_allclose(getattr(got.signals, k), getattr(want.signals, k), rtol=1e-9, atol=1e-12,
                                   err_msg=k)
    # the plain read is the pinned map's, but for a steering angle whose guess is not high (the road-wheel angle
    # here: medium), which it leaves out and says so
    for k in SIG[:4]:
        np.testing.assert_array_equal(getattr(plain.signals, k), getattr(got.signals, k), err_msg=k)
    if steer == "swa":
        np.testing.assert_array_equal(plain.signals.delta_f, got.signals.delta_f)
    else:
        assert np.isnan(plain.signals.delta_f).all()
        assert any("'wheel_angle'): not read, its guess is medium" in w for w in plain.warnings), plain.warnings


def test_missing_channel_left_to_fill_in(tmp_path, drive):
    f = tmp_path / "f.csv"
    cols = _foreign(drive)
    del cols["YawRate"]
    write_table(f, cols)
    res = CliRunner().invoke(main, ["channels", str(f), "-o", str(tmp_path / "m.toml")])
    assert res.exit_code == 1 and "yaw_rate" in res.output and "not found" in res.output
    assert "# yaw_rate = " in (tmp_path / "m.toml").read_text()
    assert "Traceback" not in res.output


def test_straight_drive_says_it_is_unsure(drive):
    n = 1000
    data = {"speed": np.full(n, 80.0), "ay": np.zeros(n), "gyro_z": np.zeros(n), "t": np.arange(n) * 0.01,
            "swa": np.zeros(n)}
    g = {x.role: x for x in guess_channels(list(data), data)}
    assert g["speed"].unit == "km/h"                # 80 m/s is no car: km/h (range only)
    assert g["yaw_rate"].confidence == "low" and "sign not checked" in g["yaw_rate"].reason


@pytest.mark.parametrize("name, role", [("Yaw", "yaw_rate"), ("yaw_angle", "yaw_rate"), ("gear", "speed"),
                                        ("GyroY", "lateral_acceleration"), ("VehSpd", "time")])
def test_names_that_are_not_the_channel(name, role):
    assert name_match(role, name)[0] == 0          # a heading is no yaw rate, a pitch rate no ay


@pytest.mark.parametrize("names", [("RollRate", "AccX"), ("gyro_x_dps", "long_acc_g")])
def test_an_imu_logs_roll_rate_and_longitudinal_acceleration_are_guessed_by_name(tmp_path, drive, names):
    """Columns named like a roll rate (deg/s) and a longitudinal acceleration (g) go into the map, their units read
    from the name or the range; the map reads them back in SI. A log without such columns gets no such lines."""
    t = drive["t"]
    p = 0.05 * np.sin(0.7 * t)                                   # rad/s
    ax = 0.8 * np.cos(0.3 * t) - 0.3                             # m/s^2
    cols = {**_foreign(drive), names[0]: np.degrees(p), names[1]: ax / 9.81}
    f = tmp_path / "imu.csv"
    write_table(f, cols)
    m = tmp_path / "map.toml"
    res = CliRunner().invoke(main, ["channels", str(f), "-o", str(m)])
    assert res.exit_code == 0, res.output
    assert "roll_rate" in res.output and f"<- {names[0]!r} in deg/s" in res.output
    assert f"<- {names[1]!r} in g" in res.output
    got = load_log(f, channels=read_channel_map(m)).signals
    np.testing.assert_allclose(got.p, p, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(got.ax, ax, rtol=1e-9, atol=1e-9)
    roles = [g.role for g in guess_channels(list(_foreign(drive)), _foreign(drive))]
    assert "roll_rate" not in roles and "longitudinal_acceleration" not in roles


def test_a_gnss_position_is_guessed_for_the_map(tmp_path, drive):
    """Columns named lat / lon (degrees) go into the guessed map as latitude and longitude (before: never proposed,
    so every map user wrote them by hand); the map reads them as the positions. Values no degree can have (a scaled
    integer) are not proposed; LongAcc is the longitudinal acceleration, not a longitude."""
    from roadbank.io.guess import channel_map_toml, guess_channels

    n = len(drive["t"])
    cols = {**_foreign(drive), "lat": 48.1 + 1e-5 * np.arange(n), "lon": 11.5 + 1e-5 * np.arange(n),
            "LongAcc": np.zeros(n)}
    g = {x.role: x for x in guess_channels(list(cols), cols)}
    assert (g["latitude"].column, g["latitude"].unit) == ("lat", "deg")
    assert (g["longitude"].column, g["longitude"].unit) == ("lon", "deg")
    assert g["longitudinal_acceleration"].column == "LongAcc"
    (tmp_path / "map.toml").write_text(channel_map_toml(list(g.values()), "x.csv"))
    cmap = read_channel_map(tmp_path / "map.toml")
    assert cmap.channels["latitude"].column == "lat" and cmap.channels["longitude"].unit == "deg"
    scaled = {**cols, "lat": cols["lat"] * 1e7, "lon": cols["lon"] * 1e7}
    assert not {"latitude", "longitude"} & {x.role for x in guess_channels(list(scaled), scaled)}


KITTI_0070 = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts" / "2011_09_26_drive_0070"
#: a logger's export names a signal after its CAN message (or device): message, separator, signal (unit in brackets)
PREFIXED = {"underscore": ("Zeit", "ESP_VehSpeed[km/h]", "ESP_LatAcc", "ESP_YawRate[deg/s]", "IMU_RollRate[deg/s]"),
            "dot": ("time", "ESP_21.VehSpeed[km/h]", "ESP_21.LatAcc", "ESP_21.YawRate[deg/s]",
                    "IMU_03.RollRate[deg/s]"),
            "colon": ("time", "ESP:VehSpd[km/h]", "ESP:LatAcc", "ESP:YawRate[deg/s]", "IMU:RollRate[deg/s]"),
            "slash": ("time", "CAN1/ESP_21/VehSpd[km/h]", "CAN1/ESP_21/LatAcc", "CAN1/ESP_21/YawRate[deg/s]",
                      "CAN1/IMU/RollRate[deg/s]"),
            "space": ("time", "ESP VehSpeed[km/h]", "ESP LatAcc", "ESP YawRate[deg/s]", "IMU RollRate[deg/s]"),
            "german": ("Zeit", "ESP_Geschwindigkeit[km/h]", "ESP_Querbeschleunigung", "ESP_Gierrate[deg/s]",
                       "IMU_Wankrate[deg/s]")}


@pytest.mark.skipif(not KITTI_0070.is_dir(), reason="../shared/data/kitti-oxts is not here")
@pytest.mark.parametrize("form", list(PREFIXED))
def test_names_after_a_message_prefix_are_guessed(tmp_path, form):
    """KITTI 0070 written as a logger exports it (speed in km/h, yaw and roll rates in deg/s, the unit in brackets),
    every name after a message prefix (before: time alone found, speed, ay and yaw rate 'not found', exit 1): the
    guessed map reads the drive back, in SI, to the digits written."""
    s = load_log(KITTI_0070).signals
    names = PREFIXED[form]
    output = _guessed_and_read_back(tmp_path, s, names, (s.t, s.vx * 3.6, s.ay, np.degrees(s.r), np.degrees(s.p)),
                                    ("t", "vx", "ay", "r", "p"))
    for role, name, unit in [("speed", names[1], "km/h"), ("lateral_acceleration", names[2], "m/s^2"),
                             ("yaw_rate", names[3], "deg/s"), ("roll_rate", names[4], "deg/s")]:
        assert f"{role:<21} <- {name!r} in {unit}" in output, output


def _guessed_and_read_back(tmp_path, s, names, columns, channels) -> str:
    """``columns`` of the drive ``s`` written to a CSV under ``names``; ``roadbank channels`` guesses its map (exit 0),
    and the log read with that map gives ``channels`` of ``s`` back, in SI, to the digits written. Returns what
    ``channels`` printed."""
    f = tmp_path / "log.csv"
    write_table(f, dict(zip(names, columns)))
    m = tmp_path / "map.toml"
    res = CliRunner().invoke(main, ["channels", str(f), "-o", str(m)])
    assert res.exit_code == 0, res.output
    got = load_log(f, channels=read_channel_map(m)).signals
    for k in channels:
        np.testing.assert_allclose(getattr(got, k), getattr(s, k), rtol=1e-9, atol=1e-12, err_msg=k)
    return res.output


@pytest.mark.skipif(not KITTI_0070.is_dir(), reason="../shared/data/kitti-oxts is not here")
def test_vw_style_can_signal_names_are_guessed(tmp_path):
    """KITTI 0070 written with a VW-style ESP message's signal names, no unit in them (ESP_v_Signal: the speed in
    km/h; before: 'speed not found', exit 1): the guessed map takes the speed in km/h from the data, and reads the
    drive back in SI to the digits written."""
    s = load_log(KITTI_0070).signals
    names = ("Zeit", "ESP_v_Signal", "ESP_Querbeschleunigung", "ESP_Gierrate", "ESP_Laengsbeschl")
    output = _guessed_and_read_back(tmp_path, s, names, (s.t, s.vx * 3.6, s.ay, np.degrees(s.r), s.ax),
                                    ("t", "vx", "ay", "r", "ax"))
    for role, name, unit in [("speed", names[1], "km/h"), ("lateral_acceleration", names[2], "m/s^2"),
                             ("yaw_rate", names[3], "deg/s"), ("longitudinal_acceleration", names[4], "m/s^2")]:
        assert f"{role:<26} <- {name!r} in {unit}" in output, output


@pytest.mark.parametrize("name, role", [("ESP_LatAcc", "lateral_acceleration"),
                                        ("ESP_21.LatAcc", "lateral_acceleration"), ("ESP_YawRate", "yaw_rate"),
                                        ("ESP_Querbeschleunigung", "lateral_acceleration"),
                                        ("IMU_RollRate", "roll_rate"), ("ESP_21.VehSpeed[km/h]", "speed"),
                                        ("ESP_Gierrate", "yaw_rate"), ("ESP_Geschwindigkeit", "speed"),
                                        ("IMU_Wankrate", "roll_rate"), ("ESP_v_Signal", "speed"),
                                        ("ESP_21.ESP_v_Signal", "speed"),
                                        ("ESP_Laengsbeschl", "longitudinal_acceleration")])
def test_a_message_prefix_names_one_role(name, role):
    """A known spelling after a message prefix is that role's and no other's, ranked below the spelling alone."""
    assert name_match(role, name)[0] == 1, name
    assert [r for r in NAMES if r != role and name_match(r, name)[0]] == [], name


@pytest.mark.parametrize("name, role, today", [("LatAcc_YawRate", "yaw_rate", "lateral_acceleration"),
                                               ("ay_r", "yaw_rate", None), ("Brake_p", "roll_rate", None),
                                               ("Engine_Speed", "speed", None), ("Wheel_Speed", "speed", None),
                                               ("Lenkrad_Geschwindigkeit", "speed", None),
                                               ("ESP_v_Signal_Qualibit", "speed", None),
                                               ("Motor_v_Signal", "speed", None), ("ESP_p_Signal", "roll_rate", None),
                                               ("ESP_VL_Radgeschw_02", "speed", None)])
def test_a_prefix_that_names_a_signal_itself_is_no_message(name, role, today):
    """A name whose prefix is a signal too (LatAcc_YawRate could be either), a letter after a prefix (Brake_p: a
    pressure) or a speed of another part (an engine's, a wheel's, the steering wheel's) gets no role from its end:
    what its whole name matches stays as it was."""
    assert name_match(role, name)[0] == 0
    assert [r for r in NAMES if name_match(r, name)[0]] == ([today] if today else [])

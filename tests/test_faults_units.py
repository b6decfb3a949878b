"""Wrong units and sign conventions in logs are detected and the message names the channel.

Logs are simulated (roadbank.sim) and written as CSV in roadbank's own columns, then
one channel is written in the wrong unit while the (default) channel map still
declares SI: what a user gets with a mis-declared map.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from roadbank.cli.simulate import write_result
from roadbank.io import LogError, check_consistency, load_log
from roadbank.sim import SCENARIOS, run_scenario


@pytest.fixture(scope="module")
def scurve():
    return run_scenario("s-curve")


def _write(tmp_path, sim, **scale):
    path = tmp_path / "log.csv"
    write_result(sim, path)
    data = np.genfromtxt(path, delimiter=",", names=True)
    cols = list(data.dtype.names)
    arr = np.column_stack([data[c] * scale.get(c, 1.0) for c in cols])
    np.savetxt(path, arr, delimiter=",", header=",".join(cols), comments="", fmt="%.10g")
    return path


def test_speed_in_kmh_declared_ms_is_caught_even_below_the_per_channel_limit(tmp_path, scurve):
    # 60 km/h written as "60 m/s": plausible alone (< 70 m/s), impossible with ay and r
    path = _write(tmp_path, scurve, vx=3.6)
    with pytest.raises(LogError, match=r"channel 'speed' \(column 'vx'\): speed looks like km/h"):
        load_log(path)


def test_yaw_rate_in_degrees_declared_rad_is_caught(tmp_path, scurve):
    path = _write(tmp_path, scurve, r=180 / math.pi)
    with pytest.raises(LogError, match=r"channel 'yaw_rate' \(column 'r'\).*(deg/s|deg)"):
        load_log(path)


def test_inverted_ay_sign_is_caught(tmp_path, scurve):
    path = _write(tmp_path, scurve, ay=-1.0)
    with pytest.raises(LogError, match=r"channel 'lateral_acceleration'.*opposite sign"):
        load_log(path)


def test_steering_in_degrees_declared_rad_is_caught(tmp_path, scurve):
    path = _write(tmp_path, scurve, delta_f=180 / math.pi, steering_wheel_angle=180 / math.pi)
    with pytest.raises(LogError, match=r"channel '(road_wheel_angle|steering_wheel_angle)'.*deg"):
        load_log(path)


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_consistent_logs_raise_nothing_even_on_banked_track(name):
    for cond in ("nominal", "low-mu"):
        sim = run_scenario(name, cond)
        assert check_consistency(sim.signals) == []


def test_straight_driving_cannot_tell_and_says_nothing():
    sim = run_scenario("const-bank")
    s = sim.signals
    from roadbank import Signals
    assert check_consistency(Signals(s.t, s.vx * 3.6, s.ay, s.r, s.delta_f)) == []

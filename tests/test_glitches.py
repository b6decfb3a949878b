"""A sample beyond a car's physical limits (roadbank.constants: |ay| > 3 g, |r| > 5 rad/s, vx > 120 m/s; a CAN value
of all ones, a bit error) is held by every estimator as a NaN is, so the output is that of the log with the sample
missing. Before, a finite glitch went through: one ay of 655.35 m/s^2 left 28 samples valid and up to 25 deg off, one
of 1e300 valid garbage for 158 s, a yaw rate of 1e20 a state stuck at -3e283."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from roadbank import estimators
from roadbank.constants import AY_MAX, SPEED_MAX, YAW_RATE_MAX
from roadbank.estimators.base import NoSteeringWarning
from roadbank.signals import Signals
from roadbank.sim.scenarios import run_scenario

CAUSAL = [n for n in estimators.NAMES if n not in estimators.OFFLINE]


@pytest.fixture(scope="module")
def drive() -> Signals:
    return run_scenario("bank-lane-change", seed=2).signals


def _with(s: Signals, **changes) -> Signals:
    cols = {k: np.array(getattr(s, k), dtype=float) for k in ("t", "vx", "ay", "r", "delta_f")}
    for key, (k, value) in changes.items():
        cols[key.rstrip("_0123456789")][k] = value
    return Signals(cols["t"], cols["vx"], cols["ay"], cols["r"], cols["delta_f"])


def test_the_limits_are_a_cars():
    assert 2.5 * 9.81 < AY_MAX < 3.5 * 9.81 and 3.0 <= YAW_RATE_MAX <= 6.0 and 100.0 <= SPEED_MAX <= 150.0


@pytest.mark.parametrize("name", CAUSAL)
def test_a_glitch_beyond_the_limits_is_held_as_a_nan(name, drive):
    spikes = dict(ay=(700, 655.35), ay_2=(900, 1e300), r=(1100, 1e20), vx=(1300, 1e4), ay_3=(1500, -40.0))
    missing = {k: (i, np.nan) for k, (i, _) in spikes.items()}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        glitched = estimators.make(name).run(_with(drive, **spikes))
        held = estimators.make(name).run(_with(drive, **missing))
        learnt = estimators.with_online_offsets(estimators.make(name)).run(_with(drive, **spikes))
        learnt_nan = estimators.with_online_offsets(estimators.make(name)).run(_with(drive, **missing))
    np.testing.assert_array_equal(glitched.theta, held.theta)
    np.testing.assert_array_equal(glitched.valid, held.valid)
    assert not glitched.valid[[i for i, _ in spikes.values()]].any()
    np.testing.assert_array_equal(learnt.theta, learnt_nan.theta)
    assert np.all(np.isfinite(glitched.theta)) and np.max(np.abs(np.degrees(glitched.phi_b[glitched.valid]))) < 30


@pytest.mark.parametrize("name", [n for n in CAUSAL if estimators.make(n).uses[0]])
def test_an_estimator_that_reads_the_steering_says_so_on_a_log_without_one(name, drive):
    """dfc, uio, kalman, the original-model observers on a log without a steering angle: every sample invalid, and
    now a warning that says why (it had been silent: theta 0 everywhere for a caller that ignores valid)."""
    s = drive
    no_steer = Signals(s.t, s.vx, s.ay, s.r, np.full(len(s), np.nan))
    with pytest.warns(NoSteeringWarning, match="no steering angle"):
        e = estimators.make(name).run(no_steer)
    assert not e.valid.any()
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # with a steering angle: no such warning
        estimators.make(name).run(s)

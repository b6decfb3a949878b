"""Faults: each one injected into a log; what every estimator does through it.

Expected flags are derived here from the definition of a usable sample (finite
inputs the estimator reads, vx >= v_min, time after the last valid sample), not
from the estimators' outputs; accuracy is checked against the scipy linear plant
of conftest and the physics of a sensor bias.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from roadbank import Signals, VehicleParams
from roadbank import estimators as E
from roadbank.faults import FAULTS, Stream, apply, feed
from roadbank.faults.table import recovery_time

from conftest import linear_plant_run

P = VehicleParams()
ALL = list(E.NAMES)
G = 9.81


@pytest.fixture(scope="module")
def base():
    """Linear-plant log: 22.2 m/s, 5 deg bank, steering step at 2 s, 20 s at 100 Hz."""
    sig, w = linear_plant_run(P, T=20.0)
    return Stream.from_signals(sig), w


def expected_invalid(stream: Stream, uses, v_min=5.0) -> np.ndarray:
    """Independent statement of which samples an estimator cannot use."""
    chans = [stream.delta_f, stream.ay, stream.r]
    bad = ~np.isfinite(stream.vx) | (np.nan_to_num(stream.vx, nan=0.0) < v_min)
    for used, c in zip(uses, chans):
        if used:
            bad |= ~np.isfinite(c)
    last = -math.inf
    out = np.zeros(len(stream), bool)
    for k in range(len(stream)):
        if bad[k] or not stream.t[k] > last:
            out[k] = True
        else:
            last = stream.t[k]
    return out


def assert_held(e, invalid):
    for a in (e.w, e.theta, e.phi_b):
        assert np.all(np.isfinite(a))
        k = np.flatnonzero(invalid)
        k = k[k > 0]
        assert np.array_equal(a[k], a[k - 1])          # held value on every flagged sample


@pytest.mark.parametrize("fault", ["nan-samples", "inf-samples", "repeated-time", "decreasing-time",
                                   "speed-through-zero"])
@pytest.mark.parametrize("name", ALL)
def test_flagged_faults_are_held_exactly_where_a_sample_is_unusable(base, name, fault):
    stream, w = base
    fs = apply(stream, fault, 6.0, 7.0, seed=3)
    est = E.make(name)
    e = feed(est, fs)
    inv = expected_invalid(fs, est.uses, est.v_min)
    assert inv.any()
    assert np.array_equal(~e.valid, inv)
    assert_held(e, inv)
    # re-converges to the clean run after the fault
    clean = feed(E.make(name), stream)
    after = fs.t >= 7.0
    ref = np.interp(fs.t[after], clean.t, clean.phi_b)
    t_rec = recovery_time(fs.t[after], np.degrees(e.phi_b[after]), np.degrees(ref), 7.0, 0.5)
    assert t_rec <= 8.0, f"{name} did not return within 0.5 deg of the clean run"


def test_repeated_time_copy_carries_garbage_that_must_not_reach_the_state(base):
    stream, _ = base
    fs = apply(stream, "repeated-time", 6.0, 7.0)
    e = feed(E.make("pif-modified"), fs)
    clean = feed(E.make("pif-modified"), stream)
    keep = np.concatenate([[True], np.diff(fs.t) > 0])     # the first of each time stamp
    assert np.allclose(e.phi_b[keep], clean.phi_b, atol=1e-12, rtol=0)


@pytest.mark.parametrize("gap", [0.05, 0.5])
@pytest.mark.parametrize("name", ALL)
def test_short_dropouts_keep_the_state_and_the_bank(base, name, gap):
    stream, w = base
    fs = apply(stream, "dropout", 10.0, 10.0 + gap)
    assert fs.t[np.searchsorted(fs.t, 10.0)] - fs.t[np.searchsorted(fs.t, 10.0) - 1] >= gap
    e = feed(E.make(name), fs)
    assert e.valid.all() and np.all(np.isfinite(e.phi_b))
    clean = feed(E.make(name), stream)
    after = fs.t >= 10.0 + gap
    dev = np.abs(e.theta[after] - np.interp(fs.t[after], clean.t, clean.theta))
    assert np.degrees(dev.max()) < 0.5


@pytest.mark.parametrize("name", ALL)
def test_gap_longer_than_max_gap_reinitialises(base, name):
    stream, _ = base
    fs = apply(stream, "dropout", 10.0, 12.0)            # 2 s > max_gap = 1 s
    e = feed(E.make(name), fs)
    k = int(np.searchsorted(fs.t, 12.0))
    fresh = feed(E.make(name), fs.take(slice(k, None)))  # a new estimator started after the gap
    assert np.allclose(e.w[k:], fresh.w, atol=1e-12, rtol=0)


def test_irregular_sampling_pif_still_recovers_the_bank():
    sig, w = linear_plant_run(P, T=20.0)
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.005, 0.025, 1500))
    t = t[t < 19.9]
    s = Signals(t, *(np.interp(t, sig.t, getattr(sig, c)) for c in ("vx", "ay", "r", "delta_f")))
    e = E.make("pif-modified").run(s)
    assert e.valid.all()
    late = t > 12.0
    assert np.max(np.abs(e.w[late] - w)) < np.sin(np.radians(0.2))


def test_ay_bias_step_is_read_as_bank_by_the_physics_and_recovers():
    """A constant ay bias b is indistinguishable from sin(bank) + b/g in dvy/dt = ay - vx r - g w
    (the modified model): the PIF must settle at w + b/g, then return to w when the bias goes."""
    sig, w = linear_plant_run(P, T=40.0)
    b = 0.5
    fs = apply(Stream.from_signals(sig), "bias-step-ay", 5.0, 25.0)
    e = feed(E.make("pif-modified"), fs)
    during = (fs.t > 18.0) & (fs.t < 25.0)
    assert np.allclose(e.w[during], w + b / G, atol=0.15 * b / G)
    assert abs(e.w[-1] - w) < 0.15 * b / G


@pytest.mark.parametrize("fault", ["stuck-r", "stuck-ay", "bias-step-r", "saturation-ay", "extreme-steering"])
@pytest.mark.parametrize("name", ALL)
def test_plausible_faults_never_give_nonfinite_output_and_pif_recovers(base, name, fault):
    stream, _ = base
    fs = apply(stream, fault, 6.0, 7.0)
    e = feed(E.make(name), fs)
    assert np.all(np.isfinite(e.w)) and np.all(np.isfinite(e.theta)) and np.all(np.isfinite(e.phi_b))
    if name == "pif-modified":
        clean = feed(E.make(name), stream)
        after = fs.t >= 7.0
        t_rec = recovery_time(fs.t[after], np.degrees(e.phi_b[after]), np.degrees(clean.phi_b[after]), 7.0, 0.5)
        assert t_rec <= 5.0


def test_speed_reversing_is_flagged_and_never_divides_by_zero():
    t = np.arange(0, 10, 0.01)
    vx = 20.0 * np.cos(np.pi * t / 10.0)        # 20 m/s -> 0 -> -20 m/s (reversing)
    s = Signals(t, vx, np.full_like(t, 0.8), np.zeros_like(t), np.zeros_like(t))
    for name in ALL:
        est = E.make(name)
        e = est.run(s)
        assert np.array_equal(e.valid, vx >= est.v_min)
        assert np.all(np.isfinite(e.phi_b))


@pytest.mark.parametrize("name", ["uio", "pif-original"])
def test_impossible_w_is_flagged_not_valid(base, name):
    """|w| = |sin(theta)| > 1 has no angle (e.g. UIO w = -10.7 under 0.7 rad road-wheel steering):
    the output is flagged valid=False, never silent garbage."""
    stream, _ = base
    e = feed(E.make(name), apply(stream, "extreme-steering", 6.0, 7.0))
    impossible = np.abs(e.w) > 1.0
    assert impossible.any()          # the fault does drive the estimate there
    assert not e.valid[impossible].any()


def test_unknown_fault_and_bad_window():
    s = Stream(*(np.arange(3.0) for _ in range(5)))
    with pytest.raises(ValueError, match="unknown fault"):
        apply(s, "gremlins", 0, 1)
    with pytest.raises(ValueError, match="t1"):
        apply(s, "dropout", 1, 1)
    assert set(FAULTS) >= {"nan-samples", "dropout", "repeated-time", "decreasing-time", "irregular-sampling",
                           "stuck-r", "bias-step-ay", "saturation-ay", "speed-through-zero", "extreme-steering"}


def test_robustness_cli_writes_the_table(tmp_path):
    from click.testing import CliRunner

    from roadbank.cli import main

    out = tmp_path / "rob.md"
    res = CliRunner().invoke(main, ["robustness", "-o", str(out), "--estimators", "kinematic,pif-modified"])
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert "| dropout 2 s |" in text and "none** in any cell" in text
    res = CliRunner().invoke(main, ["robustness", "-o", str(out), "--scenario", "moon"])
    assert res.exit_code == 2 and "moon" in res.output and "Traceback" not in res.output

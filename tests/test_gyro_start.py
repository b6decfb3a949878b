"""The start's Kalman filter of ``kinematic-gyro`` (roadbank.estimators.gyro_start): its steady state against scipy's
Riccati solution, its first samples against the mean they should be, where it (re)starts against the compiled kernel,
and run(), step() and chunks as one run."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import solve_continuous_are

from roadbank.constants import G
from roadbank.estimators import layout as L
from roadbank.estimators.gyro import KinematicGyro
from roadbank.estimators.gyro_start import START_NOISE, first_restart, kalman_begin, kalman_next
from roadbank.signals import Signals

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
KITTI = DATA / "kitti-oxts" / "2011_09_26_drive_0070"
needs_kitti = pytest.mark.skipif(not KITTI.is_dir(), reason=f"shared KITTI data not found at {KITTI}")


@pytest.mark.parametrize("cutoff, bias_tau", [(0.15, 10.0), (0.05, 40.0), (0.3, 20.0)])
def test_the_densities_make_the_complementary_filter_the_steady_kalman_filter(cutoff, bias_tau):
    """The continuous filter Riccati equation of theta' = p - b, b' = 0, k = theta + v with the module's densities
    (scipy) gives the gains [w_c, -w_c/T_b]; the sampled filter's gain per second tends to them as the step falls."""
    wc, ki, R = 2 * math.pi * cutoff, 2 * math.pi * cutoff / bias_tau, 0.37
    P = solve_continuous_are(np.array([[0.0, 0.0], [-1.0, 0.0]]), np.array([[1.0], [0.0]]),
                             R * np.diag([wc ** 2 - 2 * ki, ki ** 2]), np.array([[R]]))
    np.testing.assert_allclose(P[:, 0] / R, [wc, -ki], rtol=1e-9)
    dt = 1e-3
    s = kalman_begin(0.0, 0.0, 0.0, math.radians(0.3))
    for n in range(1, int(round(8 * bias_tau / dt))):
        s = kalman_next(s, n * dt, 0.0, 0.0, cutoff, bias_tau)
    gain = s.P[:, 0] / (s.P[0, 0] + START_NOISE ** 2) / dt
    np.testing.assert_allclose(gain, [wc, -ki], rtol=0.02)


def test_its_first_samples_are_their_mean_where_the_offset_prior_is_small():
    """With no roll rate and an offset prior far below the noise, the state after n samples of a constant roll seen
    through noise is their mean within the few per cent that the process noise adds."""
    rng = np.random.default_rng(3)
    k = 0.02 + math.radians(1.0) * rng.standard_normal(8)
    s = kalman_begin(0.0, k[0], 0.0, 1e-9)
    for n in range(1, len(k)):
        s = kalman_next(s, 0.1 * n, k[n], 0.0, 0.15, 10.0)
        assert s.x == pytest.approx(np.mean(k[:n + 1]), abs=0.03 * math.radians(1.0))


def test_a_bad_first_sample_costs_the_kalman_start_less_than_the_steady_start():
    """A constant 2 deg roll, a bias-free gyro (p = 0) and an exact kinematic estimate but for its first sample,
    8 deg off: from 3 s to 30 s the Kalman start's error is below a third of the steady filter's started at that
    sample (whose offset state learns a part of the 8 deg and takes T_b to forget it; the Kalman filter knows the
    first sample is one)."""
    t = np.arange(0.0, 40.0, 0.1)
    roll = math.radians(2.0)
    k = np.full(t.size, math.sin(roll))
    k[0] += math.radians(8.0)
    s = Signals(t, np.full(t.size, 15.0), k * G, np.zeros(t.size), np.full(t.size, np.nan), p=np.zeros(t.size))
    late = (t >= 3.0) & (t < 30.0)
    errs = [np.degrees(np.sqrt(np.mean((est.run(s).theta[late] - roll) ** 2)))
            for est in (KinematicGyro(grade_window=0.0),
                        KinematicGyro(grade_window=0.0, start_span=20.0, start_offset=math.radians(0.3)))]
    assert errs[1] < errs[0] / 3.0


def test_first_restart_is_where_the_kernel_starts_again():
    """Samples with a NaN time, NaN inputs, a slow stretch, a repeated time and gaps longer than max_gap, stepped
    through the compiled kernel: first_restart finds the samples at which it (re)started (its offset state exactly
    zero there, the start's state, and not after the next used sample)."""
    t = np.array([0.0, 0.1, 0.2, 0.2, 0.3, np.nan, 5.0, 5.1, 20.0, 20.1, 20.2, 40.0])
    vx = np.array([0.5, np.nan, 8.0, 8.0, 8.0, 8.0, 8.0, 0.2, 9.0, 9.0, 9.0, 9.0])
    p = np.array([0.0, 0.0, 0.01, 0.01, np.nan, 0.0, 0.02, 0.0, 0.01, 0.0, 0.0, 0.0])
    ay = np.linspace(0.3, 0.8, t.size)
    r = np.full(t.size, 0.01)
    est = KinematicGyro(grade_window=0.0, max_gap=10.0)
    offset = []
    for i in range(t.size):
        est.step(t[i], vx[i], ay[i], r[i], math.nan, p[i])
        offset.append(est._mem[L.M_X + 1])
    restarts, a = [], 0
    started, last = False, math.nan
    while True:
        j = a + first_restart(t[a:], vx[a:], (p[a:], ay[a:], r[a:]), 1.0, 10.0, started, last)
        if j >= t.size:
            break
        restarts.append(j)
        started, last, a = True, t[j], j + 1
    assert restarts == [2, 8, 11]
    assert all(offset[j] == 0.0 for j in restarts) and offset[6] != 0.0 and offset[9] != 0.0


@needs_kitti
def test_the_kalman_start_is_one_run_in_steps_and_chunks():
    """start_span = 20 s on a KITTI drive: run(), step() and 7-sample chunks agree exactly; after the span the
    state is handed over (the offset moves on under the steady filter); bad options are refused."""
    from roadbank.io.kitti import load_kitti_oxts
    s = load_kitti_oxts(KITTI).signals
    opts = dict(start_span=20.0, start_offset=math.radians(0.3))
    whole = KinematicGyro(**opts).run(s)
    assert np.max(np.abs(whole.theta - KinematicGyro().run(s).theta)) > 1e-4
    stepper = KinematicGyro(**opts)
    stepped = [stepper.step(*(float(getattr(s, c)[i]) for c in ("t", "vx", "ay", "r", "delta_f", "p", "ax"))).theta
               for i in range(len(s))]
    np.testing.assert_array_equal(stepped, whole.theta)
    chunked = KinematicGyro(**opts)
    parts = [chunked.run(s[i:i + 7], reset=i == 0).theta for i in range(0, len(s), 7)]
    np.testing.assert_array_equal(np.concatenate(parts), whole.theta)
    for bad in (dict(start_span=-1.0), dict(start_offset=0.0), dict(start_span=5.0, start_hold=2.0)):
        with pytest.raises(ValueError, match="start_"):
            KinematicGyro(**bad)

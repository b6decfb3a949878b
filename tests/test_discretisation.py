"""Stability of the compiled discrete recursions for vx in [v_min, 70] m/s and 10-200 Hz."""

import numpy as np
import pytest

from roadbank import estimators as E

# include speeds between grid points of the schedule (step 0.25 m/s)
SPEEDS = np.concatenate([[5.0, 5.13, 7.77], np.linspace(8.0, 70.0, 17) + 0.11, [70.0]])
RATES = [10.0, 25.0, 50.0, 100.0, 200.0]
LINEAR = ["uio", "pio-original", "pio-modified", "pif-modified", "pif-original", "kalman"]


@pytest.mark.parametrize("name", LINEAR)
def test_discrete_error_dynamics_stable(name):
    est = E.make(name)
    worst = 0.0
    for vx in SPEEDS:
        for fs in RATES:
            phi = est.transition_matrix(vx, 1.0 / fs)
            worst = max(worst, np.abs(np.linalg.eigvals(phi)).max())
    assert worst < 1.0


@pytest.mark.parametrize("name", ["pif-modified", "uio", "pio-original"])
def test_discrete_modes_match_exact_discretisation(name):
    """Each discrete eigenvalue equals exp(lambda dt) within the trapezoidal rule's error
    bound |lambda h|^3 / 12 per substep (h <= max_substep)."""
    est = E.make(name)
    for vx in (6.0, 22.25, 60.0):          # grid speeds: no schedule interpolation involved
        lam = np.linalg.eigvals(est.error_dynamics(vx))
        for fs in (10.0, 100.0):
            dt = 1.0 / fs
            nsub = int(np.ceil(dt / est.max_substep - 1e-9))
            h = dt / nsub
            mu = np.linalg.eigvals(est.transition_matrix(vx, dt))
            for lm in lam:
                k = np.argmin(np.abs(mu - np.exp(lm * dt)))
                bound = nsub * np.abs(lm * h) ** 3 / 12 + 1e-9
                assert abs(mu[k] - np.exp(lm * dt)) <= bound


def test_forward_euler_would_fail_at_low_speed():
    """The reason for the A-stable scheme: forward Euler at 25 Hz is unstable near 3 m/s
    (pole about -150 1/s), the trapezoidal recursion is not."""
    est = E.make("pif-modified", v_min=2.5)
    F = est.error_dynamics(3.0)
    assert np.abs(np.linalg.eigvals(np.eye(3) + 0.04 * F)).max() > 1.0
    assert np.abs(np.linalg.eigvals(est.transition_matrix(3.0, 0.04))).max() < 1.0

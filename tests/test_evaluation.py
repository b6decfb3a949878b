"""Metrics and references against analytic results and scipy."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from roadbank.evaluation import error_metrics, first_order_lowpass, theta_reference


def test_metrics_of_known_error():
    t = np.arange(0, 10, 0.01)
    ref = np.zeros_like(t)
    est = np.deg2rad(np.where(t < 4, 2.0, 0.3) + 0.1 * np.sin(2 * np.pi * t))
    m = error_metrics(t, est, ref, settle=2.0, final_window=3.0, band_deg=0.5)
    scored = t >= 2
    e = np.rad2deg(est[scored])
    assert m.rms_deg == pytest.approx(np.sqrt(np.mean(e**2)))
    assert m.max_deg == pytest.approx(2.1, abs=1e-3)
    assert m.bias_deg == pytest.approx(np.mean(e))
    assert m.steady_deg == pytest.approx(0.3, abs=0.01)          # sine averages out over 3 periods
    assert m.t_conv_s == pytest.approx(4.0, abs=0.011)
    assert m.n == scored.sum()


def test_metrics_ignore_invalid_samples_and_report_never_converged():
    t = np.arange(0, 5, 0.1)
    est = np.full_like(t, np.deg2rad(1.0))
    valid = np.ones_like(t, bool)
    est[30] = np.deg2rad(50.0)
    valid[30] = False
    m = error_metrics(t, est, np.zeros_like(t), valid, settle=0.0)
    assert m.max_deg == pytest.approx(1.0) and np.isnan(m.t_conv_s)
    none = error_metrics(t, est, np.zeros_like(t), np.zeros_like(t, bool))
    assert none.n == 0 and np.isnan(none.rms_deg)


def test_lowpass_matches_scipy_lsim_for_piecewise_linear_input():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.03, 400))
    x = np.cumsum(rng.normal(size=400))
    tau = 2.0 / 3.0
    ours = first_order_lowpass(t, x, tau)
    sol = solve_ivp(lambda tt, y: (np.interp(tt, t, x) - y) / tau, (t[0], t[-1]), [x[0]],
                    t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.005)
    assert np.allclose(ours, sol.y[0], atol=1e-6 * np.abs(x).max())


def test_theta_reference_recovers_bank_without_filter():
    t = np.arange(0, 5, 0.01)
    theta = np.deg2rad(8.0) * np.ones_like(t)
    vx, r, dvy = np.full_like(t, 20.0), 0.1 * np.sin(t), 0.3 * np.cos(t)
    ay = dvy + vx * r + 9.81 * np.sin(theta)
    assert np.allclose(theta_reference(t, ay, dvy, vx, r, tau=None), theta, atol=1e-12)
    filtered = theta_reference(t, ay, dvy, vx, r)
    assert np.allclose(filtered, theta, atol=1e-12)    # constant input: filter starts in steady state

"""The fixed-rate path: exact discretisation, agreement with the general path, fallback, export.

"Agree within 0.01 deg" is tested as: the fixed-rate path (exact for a frozen
speed) and the general trapezoidal path refined until its own discretisation
error is negligible (``max_substep`` = 1 ms) give theta within 0.01 deg on every
valid sample of every paper scenario and of the comma2k19 segment, for every
scheduled linear observer with the dynamic roll model. With the default
general path (one 10 ms trapezoidal step per sample at 100 Hz) the paper's PIF
(Table 4 weights) and the PIOs agree within 0.01 deg too; the UIO, the Kalman
filter and the tuned default PIF have faster modes for which the trapezoidal
rule at 10 ms itself errs by up to ~0.12 deg (bounded separately).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from roadbank import Signals, VehicleParams
from roadbank import estimators as E
from roadbank.estimators.base import FIXED_RATE_KERNELS
from roadbank.estimators.discretise import foh
from roadbank.estimators.pif import TABLE4

SEGMENT = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "comma2k19-example"
LPV = [n for n in E.NAMES if E.make(n).kernel in FIXED_RATE_KERNELS]
TOL_DEG = 0.01


@pytest.fixture(scope="module")
def logs():
    """Every paper scenario (nominal) and, when present, the comma2k19 example segment."""
    from roadbank.sim import SCENARIOS, run_scenario
    out = {sc: run_scenario(sc).signals for sc in SCENARIOS}
    if SEGMENT.is_dir():
        from roadbank.io.comma2k19 import load_comma2k19
        seg = load_comma2k19(SEGMENT)
        out["comma2k19"] = getattr(seg, "signals", seg)
    return out


def _max_dtheta_deg(a, b):
    v = a.valid & b.valid
    assert v.sum() > 0.5 * len(v)
    return float(np.rad2deg(np.max(np.abs(a.theta[v] - b.theta[v]))))


def test_foh_is_the_exact_solution_for_inputs_linear_in_time():
    rng = np.random.default_rng(1)
    F = rng.normal(size=(3, 3)) - 4.0 * np.eye(3)
    G = rng.normal(size=(3, 3))
    x0, e0, e1, h = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3), 0.04
    Phi, G0, G1 = foh(F, G, h)
    sol = solve_ivp(lambda t, x: F @ x + G @ (e0 + (e1 - e0) * t / h), (0, h), x0, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(Phi @ x0 + G0 @ e0 + G1 @ e1, sol.y[:, -1], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", LPV)
def test_fixed_rate_agrees_with_the_refined_general_path(logs, name):
    worst = {}
    for label, s in logs.items():
        fixed = E.make(name, roll="dynamic").run(s)
        fine = E.make(name, roll="dynamic", sample_rate=None, max_substep=0.001).run(s)
        worst[label] = _max_dtheta_deg(fixed, fine)
    assert max(worst.values()) <= TOL_DEG, worst


@pytest.mark.parametrize("name", LPV)
def test_fixed_rate_vs_default_general_path(logs, name):
    """With the default general path (one 10 ms trapezoidal step at 100 Hz) the difference is
    that step's own error: < 0.2 deg even for the fastest observers (UIO, Kalman, tuned PIF)."""
    for label, s in logs.items():
        fixed = E.make(name).run(s)
        general = E.make(name, sample_rate=None).run(s)
        assert _max_dtheta_deg(fixed, general) <= 0.2, label


@pytest.mark.parametrize("name,tuning", [("pif-modified", TABLE4), ("pif-original", TABLE4),
                                         ("pio-modified", {}), ("pio-original", {})])
def test_paper_observers_agree_within_tolerance_at_default_settings(logs, name, tuning):
    """The paper's PIF (Table 4 weights) and the PIOs: slow enough modes that even the default
    general path agrees with the fixed-rate path within 0.01 deg."""
    for label, s in logs.items():
        fixed = E.make(name, **tuning).run(s)
        general = E.make(name, sample_rate=None, **tuning).run(s)
        assert _max_dtheta_deg(fixed, general) <= TOL_DEG, label


def _uniform_log(n=1500, fs=100.0, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    vx = 20.0 + 8.0 * np.sin(t / 3.0)
    ay = 2.0 * np.sin(t) + 0.05 * rng.normal(size=n)
    r = ay / vx + 0.002 * rng.normal(size=n)
    return Signals(t, vx, ay, r, 0.1 * r)


def test_rate_is_detected_and_step_equals_run():
    s = _uniform_log()
    est = E.make("pif-modified", roll="dynamic")
    batch = est.run(s)
    assert est.fixed_dt == pytest.approx(0.01, rel=1e-12)
    other = E.make("pif-modified", roll="dynamic")
    out = [other.step(s.t[k], s.vx[k], s.ay[k], s.r[k], s.delta_f[k]) for k in range(len(s))]
    assert np.array_equal(batch.w, [o.w for o in out])
    assert np.array_equal(batch.phi_b, [o.phi_b for o in out])
    assert np.array_equal(batch.settled, [o.settled for o in out]) and not out[0].settled and out[-1].settled
    # steps, then a run that continues them: one clock for the settled flags (it had restarted at the run)
    third = E.make("pif-modified", roll="dynamic")
    head = [third.step(s.t[k], s.vx[k], s.ay[k], s.r[k], s.delta_f[k]).settled for k in range(50)]
    rest = third.run(s[50:], reset=False)
    assert np.array_equal(np.concatenate([head, rest.settled]), batch.settled)
    general = E.make("pif-modified", roll="dynamic", sample_rate=None).run(s)
    assert not np.array_equal(batch.w, general.w)          # the fixed-rate path was used


@pytest.mark.parametrize("name", ["pif-modified", "uio", "kinematic-pif"])
def test_a_reset_detects_the_rate_again_and_a_set_rate_stays(name):
    """One object on a 10 Hz log, then on a 100 Hz one (run() resets), or reset() and stepped: what a fresh object
    gives, bit for bit (the 10 Hz tables were kept before); a rate set by set_sample_rate survives the reset."""
    fast = _uniform_log()
    slow = fast[::10]
    fresh = E.make(name).run(fast)
    est = E.make(name)
    est.run(slow)
    assert est.fixed_dt == pytest.approx(0.1, rel=1e-12)
    np.testing.assert_array_equal(est.run(fast).w, fresh.w)
    assert est.fixed_dt == pytest.approx(0.01, rel=1e-12)
    est.run(slow)
    est.reset()
    stepped = [est.step(fast.t[k], fast.vx[k], fast.ay[k], fast.r[k], fast.delta_f[k]).w for k in range(len(fast))]
    np.testing.assert_array_equal(stepped, fresh.w)
    fixed = E.make(name)
    fixed.set_sample_rate(10.0)
    fixed.run(fast)
    assert fixed.fixed_dt == pytest.approx(0.1, rel=1e-12)         # kept: not detected from the log


@pytest.mark.parametrize("late", [0, 1, 2, 300])
def test_rate_found_late_in_a_chunk_equals_step(late):
    """A log read in chunks whose first chunk is one sample (no interval yet) and whose second starts with ``late``
    samples no later than that one: run() sets the rate where step() does (it reads only the first two times of
    a chunk), and the outputs equal step()'s sample for sample."""
    s = _uniform_log()
    t0 = 10.0
    first = Signals([t0], s.vx[:1], s.ay[:1], s.r[:1], s.delta_f[:1])
    t = t0 + 0.01 * (np.arange(len(s)) - late)
    rest = Signals(t, s.vx, s.ay, s.r, s.delta_f)
    est = E.make("pif-modified")
    est.run(first)
    batch = est.run(rest, reset=False)
    other = E.make("pif-modified")
    other.step(t0, s.vx[0], s.ay[0], s.r[0], s.delta_f[0])
    out = [other.step(t[k], s.vx[k], s.ay[k], s.r[k], s.delta_f[k]) for k in range(len(s))]
    assert est.fixed_dt == other.fixed_dt == pytest.approx(0.01, rel=1e-9)
    assert np.array_equal(batch.w, [o.w for o in out])
    assert np.array_equal(batch.valid, [o.valid for o in out])
    assert not batch.valid[:late + 1].any() and batch.valid[late + 1:].all()


def test_jittered_samples_take_the_general_path():
    s = _uniform_log(seed=2)
    rng = np.random.default_rng(3)
    dt = 0.01 + rng.uniform(0.5e-3, 2e-3, len(s) - 1) * rng.choice([-1.0, 1.0], len(s) - 1)
    jit = Signals(np.concatenate([[0.0], np.cumsum(dt)]), s.vx, s.ay, s.r, s.delta_f)
    a = E.make("pio-modified", sample_rate=100.0).run(jit)
    b = E.make("pio-modified", sample_rate=None).run(jit)
    assert np.array_equal(a.w, b.w)


def test_gap_reinitialises_and_the_fixed_rate_path_resumes():
    s = _uniform_log(seed=4)
    t = s.t.copy()
    t[700:] += 2.0                                        # a gap longer than max_gap (1 s)
    gapped = Signals(t, s.vx, s.ay, s.r, s.delta_f)
    whole = E.make("pif-modified", sample_rate=100.0).run(gapped)
    first = E.make("pif-modified", sample_rate=100.0).run(gapped[:700])
    second = E.make("pif-modified", sample_rate=100.0).run(gapped[700:])
    assert np.array_equal(whole.w, np.concatenate([first.w, second.w]))
    assert not np.array_equal(second.w, E.make("pif-modified", sample_rate=None).run(gapped[700:]).w)


def test_discrete_tables_reproduce_run_with_the_documented_formula():
    """An independent numpy implementation of the per-sample formula (what an ECU runs)."""
    s = _uniform_log(800)
    est = E.make("pif-original", roll="dynamic", sample_rate=100.0)
    ref = est.run(s)
    T = est.discrete_tables(0.01)
    vg = T["vgrid"]

    def at(M, v):
        x = min(max((v - vg[0]) / (vg[1] - vg[0]), 0.0), len(vg) - 1.0)
        i = min(int(x), len(vg) - 2)
        return M[i] + (x - i) * (M[i + 1] - M[i])

    xi = z = eta_prev = ay_prev = None
    w = np.empty(len(s))
    phi_b = np.empty(len(s))
    for k in range(len(s)):
        eta = T["uses"] * np.array([s.delta_f[k], s.ay[k], s.r[k]])
        v = s.vx[k]
        if k == 0:
            xi, z = at(T["J"], v) @ eta, T["J_r"] * s.ay[k]
        else:
            xi = at(T["Phi"], v) @ xi + at(T["Gam0"], v) @ eta_prev + at(T["Gam1"], v) @ eta
            z = T["Phi_r"] @ z + T["Gam0_r"] * ay_prev + T["Gam1_r"] * s.ay[k]
        w[k] = at(T["H"], v) @ xi + at(T["D"], v) @ eta
        phi_b[k] = np.arcsin(np.clip(w[k], -1, 1)) - (T["H_r"] @ z + T["D_r"] * s.ay[k])
        eta_prev, ay_prev = eta, s.ay[k]
    np.testing.assert_allclose(w, ref.w, rtol=0, atol=1e-12)
    np.testing.assert_allclose(phi_b, ref.phi_b, rtol=0, atol=1e-12)
    for key in ("Phi", "Gam0", "Gam1", "H", "D", "J"):
        assert isinstance(T[key], np.ndarray) and T[key].shape[0] == len(vg)


def test_tables_follow_the_vehicle_and_the_tuning():
    heavy = VehicleParams(m=2200.0, Cf=90000.0)
    a = E.make("pif-original").discrete_tables(0.01)["Phi"]
    b = E.make("pif-original", heavy).discrete_tables(0.01)["Phi"]
    c = E.make("pif-original", Q=1.0).discrete_tables(0.01)["Phi"]
    assert not np.allclose(a, b) and not np.allclose(a, c)
    s = _uniform_log(600)
    for params, tuning in ((heavy, {}), (None, {"Q": 1.0})):
        fixed = E.make("pif-original", params, **tuning).run(s)
        fine = E.make("pif-original", params, sample_rate=None, max_substep=0.001, **tuning).run(s)
        assert _max_dtheta_deg(fixed, fine) <= TOL_DEG


def test_fixed_rate_tables_only_for_the_scheduled_observers():
    with pytest.raises(ValueError, match="dfc"):
        E.make("dfc").discrete_tables(0.01)
    with pytest.raises(ValueError, match="interval"):
        E.make("pif-modified").discrete_tables(0.0)


def test_tables_of_one_design_with_two_roll_models_are_not_mixed_up():
    static = E.make("pif-modified", roll="static").discrete_tables(0.01)
    dynamic = E.make("pif-modified", roll="dynamic").discrete_tables(0.01)
    assert static["Phi_r"].shape == (0, 0) and dynamic["Phi_r"].shape == (2, 2)
    assert np.array_equal(static["Phi"], dynamic["Phi"])      # the observer itself is shared

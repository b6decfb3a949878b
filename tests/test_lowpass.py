"""kinematic-lp / kinematic-ff: the low-passed kinematic estimate, against scipy and the real training drives."""

from __future__ import annotations

import dataclasses
import numpy as np
import pytest
from scipy.signal import lsim

from roadbank import Signals, estimators
from roadbank.estimators.lowpass import FF_CUTOFF_HZ, FF_KAPPA, LP_CUTOFF_HZ, KinematicLowPass
from roadbank.params import G

from pathlib import Path

DATA_DIR = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


def _drive(fs=100.0, T=20.0, vx=20.0):
    t = np.arange(0.0, T, 1.0 / fs)
    rng = np.random.default_rng(3)
    r = 0.1 * np.sin(2 * np.pi * 0.3 * t) + 0.05 * np.sin(2 * np.pi * 1.1 * t)
    ay = vx * r + G * np.sin(np.deg2rad(3.0)) + 0.3 * rng.standard_normal(len(t))
    return Signals(t, np.full_like(t, vx), ay, r, np.full_like(t, np.nan))


def _first_order(u, t, fc):
    tau = 1.0 / (2 * np.pi * fc)
    return lsim(([1.0], [tau, 1.0]), u, t, X0=[u[0] * tau])[1]


@pytest.mark.parametrize("fixed_rate", [True, False])
def test_kinematic_lp_is_a_first_order_lowpass_of_the_kinematic_estimate(fixed_rate):
    s = _drive()
    est = estimators.make("kinematic-lp", sample_rate="auto" if fixed_rate else None)
    out = est.run(s)
    kin = (s.ay - s.vx * s.r) / G
    if fixed_rate:
        # exact discretisation with the input linear between samples (first-order hold), as lsim does
        ref = _first_order(kin, s.t, LP_CUTOFF_HZ)
    else:
        # the general path: the trapezoidal rule, tau x' = u - x written out
        a = 0.5 * 0.01 * 2 * np.pi * LP_CUTOFF_HZ
        ref = np.empty_like(kin)
        ref[0] = kin[0]
        for k in range(1, len(kin)):
            ref[k] = ((1 - a) * ref[k - 1] + a * (kin[k - 1] + kin[k])) / (1 + a)
    assert np.max(np.abs(out.w - ref)) < 1e-9
    assert est.cutoff == LP_CUTOFF_HZ and est.kappa == 0.0


def test_kinematic_ff_adds_the_high_passed_centripetal_term():
    s = _drive()
    out = estimators.make("kinematic-ff").run(s)
    kin = (s.ay - s.vx * s.r) / G
    a = s.vx * s.r / G
    ref = _first_order(kin, s.t, FF_CUTOFF_HZ) + FF_KAPPA * (a - _first_order(a, s.t, FF_CUTOFF_HZ))
    assert np.max(np.abs(out.w - ref)) < 1e-6


@pytest.mark.parametrize("fixed_rate", [True, False])
def test_the_lead_is_a_zero_against_scipy_and_shortens_a_ramps_lag_by_itself(fixed_rate):
    """With ``lead`` the low-pass is (c tau s + 1)/(tau s + 1) (scipy's lsim of that transfer function, on
    a noisy drive). On a bank ramp its output lags by (1 - c) tau: with half a sample interval exactly
    the lag of the first-order filter of the samples (K = 1 - exp(-h/tau), run here in plain Python),
    about tau - lead for a small lead, and a lead beyond tau (a slow log) still filters (c < 1)."""
    from roadbank.estimators.lowpass import lead_share

    fc, h = 0.4, 0.1
    tau = 1.0 / (2 * np.pi * fc)
    s = _drive(fs=1.0 / h, T=60.0)
    kin = (s.ay - s.vx * s.r) / G
    out = estimators.make("kinematic-lp", cutoff=fc, lead=h / 2, sample_rate="auto" if fixed_rate else None).run(s)
    c = lead_share((h / 2) / tau)
    ref = lsim(([c * tau, 1.0], [tau, 1.0]), kin - kin[0], s.t)[1] + kin[0]    # from rest at the first value
    assert np.max(np.abs(out.w - ref)) < (1e-9 if fixed_rate else 2e-3 * np.std(kin))
    t = np.arange(0.0, 40.0, h)
    rate = np.deg2rad(0.5)                                     # bank rate (rad/s), no noise
    ramp = Signals(t, np.full_like(t, 20.0), G * np.sin(rate * t), np.zeros_like(t), np.full_like(t, np.nan))
    late = t > 30.0
    K = 1.0 - np.exp(-h / tau)
    sampled = np.empty_like(t)
    sampled[0] = ramp.ay[0] / G
    for k in range(1, len(t)):
        sampled[k] = sampled[k - 1] + K * (ramp.ay[k] / G - sampled[k - 1])

    def lag(w):                                                # seconds, to first order in the ramp's curvature
        return (np.sin(rate * t) - w)[late] / (rate * np.cos(rate * t[late]))

    assert np.allclose(lag(sampled), (1 - K) / K * h, atol=2e-3)            # the sampled filter's exact lag
    lags = {lead: lag(estimators.make("kinematic-lp", cutoff=fc, lead=lead).run(ramp).w) for lead in (0.0, h / 2, 0.01,
                                                                                                        0.5, 5.0)}
    assert np.allclose(lags[0.0], tau, atol=2e-3)
    assert np.allclose(lags[h / 2], (1 - K) / K * h, atol=2e-3) and np.allclose(lags[h / 2], lag(sampled), atol=1e-3)
    assert np.allclose(lags[0.01], tau - 0.01, atol=2e-3)
    for lead in (0.5, 5.0):                                    # beyond tau (0.40 s)
        c = lead_share(lead / tau)
        assert 0.5 < c < 1.0 and np.allclose(lags[lead], (1 - c) * tau, atol=2e-3)
    assert lead_share(0.0) == 0.0 and lead_share(1e-12) == pytest.approx(1e-12, rel=1e-6)


def test_steady_turn_on_a_bank_has_no_bias():
    t = np.arange(0.0, 30.0, 0.01)
    vx, r, bank = 15.0, 0.2, np.deg2rad(4.0)
    s = Signals(t, np.full_like(t, vx), np.full_like(t, vx * r + G * np.sin(bank)), np.full_like(t, r),
                np.full_like(t, np.nan))
    for name in ("kinematic-lp", "kinematic-ff"):
        out = estimators.make(name).run(s)
        assert np.allclose(out.theta, bank, atol=1e-12), name


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="cutoff must be > 0"):
        estimators.make("kinematic-lp", cutoff=0.0)
    with pytest.raises(ValueError, match="kappa must be finite"):
        estimators.make("kinematic-ff", kappa=float("nan"))
    with pytest.raises(ValueError, match="lead must be >= 0"):
        estimators.make("kinematic-ff", lead=-0.01)


needs_kitti = pytest.mark.skipif(not (DATA_DIR / "kitti-oxts-extra").is_dir(),
                                 reason="the shared KITTI drives (../shared/data/kitti-oxts*) are not here")


@pytest.mark.slow
@needs_kitti
def test_shipped_constants_are_where_the_rule_has_its_minimum():
    # the whole grid takes minutes (docs/estimators.md); here: the shipped point against its grid
    # neighbours, which the rule would have taken had they scored lower
    from roadbank.tuning.real import CUTOFFS_HZ, KAPPAS, fixed, objective, simulated_sets, training_logs

    logs, sims = training_logs(DATA_DIR), simulated_sets()
    assert len(logs) == 8

    def around(values, v):
        i = values.index(v)
        return [values[j] for j in (i - 1, i + 1) if 0 <= j < len(values)]

    at = objective(fixed(KinematicLowPass(cutoff=FF_CUTOFF_HZ, kappa=FF_KAPPA)), logs, sims)
    for fc, k in [(f, FF_KAPPA) for f in around(CUTOFFS_HZ, FF_CUTOFF_HZ)] + \
                 [(FF_CUTOFF_HZ, k) for k in around(KAPPAS, FF_KAPPA)]:
        assert objective(fixed(KinematicLowPass(cutoff=fc, kappa=k)), logs, sims) > at, (fc, k)
    lp = objective(fixed(KinematicLowPass(cutoff=LP_CUTOFF_HZ, kappa=0.0)), logs, sims)
    for fc in around(CUTOFFS_HZ, LP_CUTOFF_HZ):
        assert objective(fixed(KinematicLowPass(cutoff=fc, kappa=0.0)), logs, sims) > lp, fc
    # the feed-forward earns its place: the rule prefers it to the plain low-pass
    assert at < lp


def test_the_noise_scheduled_cutoff_is_where_lag_and_noise_weigh_least():
    """cutoff_for_noise against the error measured by running the filter: a bank that changes at a
    constant rate (a triangle wave, slope +-omega) seen through white noise of known density. The
    measured RMS error over a fine grid of fixed cut-offs is least within 12 % of the formula's, and
    there it is the analytic sqrt(q pi fc + omega^2 tau^2) within 5 %."""
    from roadbank.estimators.lowpass import cutoff_for_noise

    fs, omega, sigma = 100.0, np.radians(1.0), 0.05          # Hz, rad/s, m/s^2
    t = np.arange(0.0, 400.0, 1.0 / fs)
    period = 20.0
    phase = (t % period) / period
    theta = omega * period / 2 * np.where(phase < 0.5, phase, 1.0 - phase) * 2 - omega * period / 4
    rng = np.random.default_rng(11)
    ay = G * np.sin(theta) + sigma * rng.standard_normal(t.size)
    s = Signals(t, np.full_like(t, 20.0), ay, np.zeros_like(t), np.full_like(t, np.nan))
    q = sigma ** 2 / fs / G ** 2                                   # rad^2 s
    fc_rule = cutoff_for_noise(q, omega)
    grid = fc_rule * np.exp(np.linspace(np.log(0.4), np.log(2.5), 41))
    keep = t > 10.0

    def rms(fc):
        e = KinematicLowPass(cutoff=fc).run(s).w - np.sin(theta)
        return float(np.sqrt(np.mean(e[keep] ** 2)))

    errs = np.array([rms(fc) for fc in grid])
    assert grid[np.argmin(errs)] == pytest.approx(fc_rule, rel=0.12)
    tau = 1.0 / (2 * np.pi * fc_rule)
    assert rms(fc_rule) == pytest.approx(np.sqrt(q * np.pi * fc_rule + (omega * tau) ** 2), rel=0.05)
    # bounds, and no noise at all: the fastest filter
    assert cutoff_for_noise(1e-30, omega) == 5.0 and cutoff_for_noise(1.0, omega) == 0.05
    assert cutoff_for_noise(0.0, omega) == 5.0


def test_the_scheduled_cutoff_follows_the_speed_and_equals_a_fixed_filter_at_one_speed():
    from roadbank.estimators.lowpass import cutoff_for_noise

    q_ay, r, b = 4e-3, 1e-6, np.radians(0.6)
    est = estimators.make("kinematic-ff", bank_rate=b, Q_ay=q_ay, R=r)
    for vx in (5.0, 20.0, 40.0):
        fc = cutoff_for_noise((q_ay + vx ** 2 * r) / G ** 2, b)
        assert est.cutoff_at(vx) == pytest.approx(fc, rel=1e-12)
        assert est.observer(vx)[0][0, 0] == pytest.approx(-2 * np.pi * fc, rel=1e-12)
    assert est.cutoff_at(40.0) < est.cutoff_at(5.0)                # the yaw rate's noise grows with speed
    s = _drive(vx=20.0)
    fixed = estimators.make("kinematic-ff", cutoff=est.cutoff_at(20.0)).run(s)
    np.testing.assert_allclose(est.run(s).w, fixed.w, rtol=0, atol=1e-6)
    with pytest.raises(ValueError, match="bank_rate"):
        estimators.make("kinematic-ff", bank_rate=-1.0, Q_ay=q_ay)


@pytest.mark.parametrize("p", [0.5, 1.0])
def test_a_bank_prior_along_the_road_is_crossed_faster_at_speed(p):
    """With ``bank_speed_exp = 1`` the prior is a bank gradient along the road (rad/m): at ``vx`` its rate in time
    is ``gradient * vx``, and the cut-off is cutoff_for_noise's for that rate; 0.5 takes the geometric mean of the
    two priors. At BANK_SPEED_REF every exponent gives the same filter; 0 (the default) is a rate in time."""
    from roadbank.estimators.lowpass import BANK_SPEED_REF, cutoff_for_noise

    q_ay, r, b = 4e-3, 1e-6, np.radians(0.6)
    gradient = b / BANK_SPEED_REF                                 # rad/m: the same prior at 10 m/s
    est = estimators.make("kinematic-ff", bank_rate=b, Q_ay=q_ay, R=r, bank_speed_exp=p)
    for vx in (2.0, 5.0, 20.0, 35.0):
        along = gradient * vx
        assert est.cutoff_at(vx) == pytest.approx(cutoff_for_noise((q_ay + vx ** 2 * r) / G ** 2,
                                                                   along ** p * b ** (1.0 - p)), rel=1e-12)
    flat = estimators.make("kinematic-ff", bank_rate=b, Q_ay=q_ay, R=r)
    assert est.cutoff_at(BANK_SPEED_REF) == pytest.approx(flat.cutoff_at(BANK_SPEED_REF), rel=1e-12)
    assert est.cutoff_at(30.0) > flat.cutoff_at(30.0) and est.cutoff_at(3.0) < flat.cutoff_at(3.0)
    assert estimators.make("kinematic-pif").bank_speed_exp == 0.0
    with pytest.raises(ValueError, match="bank_speed_exp"):
        estimators.make("kinematic-ff", bank_rate=b, Q_ay=q_ay, bank_speed_exp=-1.0)


@pytest.mark.skipif(not (DATA_DIR / "kitti-oxts").is_dir(), reason="../shared/data/kitti-oxts not present")
def test_the_default_low_pass_is_slow_on_a_shaken_10hz_log_and_fast_on_a_quiet_100hz_one():
    """The command line's kinematic-pif (vehicle.for_log) reads the log's own noise."""
    from roadbank.io.kitti import load_kitti_oxts
    from roadbank.vehicle import for_log

    # the drive's ESP channels (with its roll rate the default is the gyro filter, which has no cut-off to schedule)
    kitti = dataclasses.replace(load_kitti_oxts(DATA_DIR / "kitti-oxts" / "2011_09_26_drive_0070").signals, p=None)
    t = np.arange(0.0, 60.0, 0.01)
    r = 0.1 * np.sin(2 * np.pi * 0.2 * t)                         # manoeuvres below the 1 Hz band
    vx = np.full_like(t, 20.0)
    quiet = Signals(t, vx, vx * r + 0.03 * np.random.default_rng(2).standard_normal(t.size), r, np.zeros_like(t))
    # the quiet log is kinematic-pif's quiet filter unless told otherwise: the blend's low-pass is tested here
    slow, fast = for_log("kinematic-pif", kitti).slow, for_log("kinematic-pif", quiet, quiet_ratio=0.0).slow
    assert slow.cutoff_at(20.0) < 0.8 < 1.5 < fast.cutoff_at(20.0)

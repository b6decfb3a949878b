"""kinematic-lp / kinematic-ff: the low-passed kinematic estimate, against scipy and the real training drives."""

from __future__ import annotations

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

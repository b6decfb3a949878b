"""The running noise estimate of a limited low-pass (kernels.sample.noise_update, the twelfth stage of
roadbank.tuning.real): the documented recursion, the gain it gives (the cut-off for the noise it reads), how
every command designs it for a log, and the rule's choice on the KITTI training drives."""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, optimize

from roadbank import Signals
from roadbank import estimators as E
from roadbank.estimators import layout as L
from roadbank.estimators.gated import KINEMATIC_PIF_LIMIT_TAU, KINEMATIC_PIF_NOISE_TAU
from roadbank.estimators.kernels.sample import NOISE_HUBER, NOISE_RATIO_MAX, NOISE_RATIO_MIN
from roadbank.signals import DIFF_NOISE_HUBER, diff_noise_std
from roadbank.vehicle import for_log, log_conditions

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
G = 9.81


def huber_fixed_point() -> float:
    """``c`` with ``c = E[min(z^2, 9 c)]``, z standard normal: the variance a Huber-limited mean square reads on
    white Gaussian noise of unit variance (scipy's quadrature and root finder)."""
    def mean_clipped(c):
        k = np.sqrt(NOISE_HUBER * c)
        inside = integrate.quad(lambda z: z * z * np.exp(-z * z / 2) / np.sqrt(2 * np.pi), -k, k)[0]
        return inside + NOISE_HUBER * c * 2 * (1 - 0.5 * (1 + math.erf(k / math.sqrt(2))))
    return optimize.brentq(lambda c: mean_clipped(c) - c, 0.5, 1.0)


def test_diff_noise_std_reads_white_noise_as_the_huber_fixed_point():
    """First differences of white noise of standard deviation sigma, halved and squared, are sigma^2 z^2: their
    Huber-limited mean is sigma^2 c (c from scipy, 0.995); masked and too-short series give NaN."""
    rng = np.random.default_rng(3)
    sigma = 0.2
    x = sigma * rng.standard_normal(400_000)
    c = huber_fixed_point()
    assert 0.99 < c < 1.0
    assert DIFF_NOISE_HUBER == NOISE_HUBER          # the design span's reference and the kernel's running value
    assert diff_noise_std(x) ** 2 / sigma ** 2 == pytest.approx(c, rel=0.01)
    # a few huge spikes barely move it (each counts at most 3 standard deviations)
    y = x.copy()
    y[::1000] += 50.0
    assert diff_noise_std(y) == pytest.approx(diff_noise_std(x), rel=0.03)
    valid = np.ones(len(x), bool)
    valid[: len(x) // 2] = False
    x[:10] = np.nan
    assert diff_noise_std(x, valid) ** 2 / sigma ** 2 == pytest.approx(c, rel=0.02)
    assert np.isnan(diff_noise_std(x[:20]))


def _loudening_log(rate=10.0, seconds=300.0, sigma=(0.1, 0.25), seed=0, jitter=0.2):
    """A drive at 15 m/s on a 3 deg bank whose ay noise steps from sigma[0] to sigma[1] (m/s^2) halfway, time
    steps jittered by +-``jitter`` of the interval, a slow stretch and a gap of 3 s."""
    rng = np.random.default_rng(seed)
    n = int(seconds * rate)
    t = np.cumsum(np.full(n, 1.0 / rate) * (1.0 + jitter * rng.uniform(-1, 1, n)))
    t[n // 3:] += 3.0
    vx = np.full(n, 15.0)
    vx[n // 5: n // 5 + 20] = 0.5
    noise = np.where(np.arange(n) < n // 2, sigma[0], sigma[1]) * rng.standard_normal(n)
    ay = G * np.sin(np.radians(3.0)) + noise
    return Signals(t, vx, ay, np.zeros(n), np.full(n, np.nan))


def reference_ratio(s, tau, ref, v_min, max_gap):
    """The ratio m after each sample (noise_update's docstring written out in plain Python): over the used
    samples (vx >= v_min), a = ay - vx r, m += dt / (tau + dt) (min(da^2 / (2 ref), H m) - m), clipped to its
    bounds; 1 at the first sample, kept over a restart (a gap longer than max_gap). The limit's shorter ratio is
    the same recursion with its own time constant."""
    out, m, a_prev, t_prev = [], 0.0, None, None
    for t, vx, ay, r in zip(s.t, s.vx, s.ay, s.r):
        if vx >= v_min:
            a = ay - vx * r
            if t_prev is None or t - t_prev > max_gap:
                m = m if m > 0 else 1.0
            else:
                dt = t - t_prev
                u = min((a - a_prev) ** 2 / (2 * ref), NOISE_HUBER * m)
                m = min(max(m + dt / (tau + dt) * (u - m), NOISE_RATIO_MIN), NOISE_RATIO_MAX)
            a_prev, t_prev = a, t
        out.append(m)
    return np.array(out)


@pytest.mark.parametrize("rate", [None, "auto"])
def test_the_running_ratio_is_the_documented_recursion(rate):
    """Sample by sample the kernel's ratio (in mem, layout.limit_states) is the recursion of its docstring, to
    1e-12, through jittered steps, a slow stretch and a restart; run() and step() give the same estimate."""
    s = _loudening_log()
    ref = 0.1 ** 2
    est = E.make("kinematic-lp", cutoff=0.3, clip=3.0, Q_ay=0.1 ** 2 / 10, R=0.0, noise_tau=10.0, noise_ref=ref,
                 limit_tau=2.0, sample_rate=rate)
    assert est.noise_tau == 10.0 and est.noise_ref == ref and est.limit_tau == 2.0
    ls = L.limit_states(est._nstate, est._roll[0].shape[0])
    est.reset()
    got, short, w = [], [], []
    for a in zip(s.t, s.vx, s.ay, s.r, s.delta_f):
        w.append(est.step(*a).w)
        got.append(est._mem[ls.NV])
        short.append(est._mem[ls.NS])
    want = reference_ratio(s, 10.0, ref, est.v_min, est.max_gap)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(short, reference_ratio(s, 2.0, ref, est.v_min, est.max_gap), rtol=0, atol=1e-12)
    n = len(s)
    assert 0.8 < np.median(want[n // 4: n // 2]) < 1.1 and 5.0 < np.median(want[-n // 4:]) < 7.0
    assert np.std(np.diff(short[n // 4:])) > 2 * np.std(np.diff(got[n // 4:]))      # the shorter one moves more
    np.testing.assert_allclose(est.run(s).w, w, rtol=0, atol=0)


def test_the_limit_reads_its_shorter_ratio():
    """With a shorter ratio for the limit, the ay the low-pass reads is limited at c sqrt(ns (Q_ay + vx^2 R) / dt)
    (limited_ay's docstring, with the ratio the kernel holds before the sample): written out here from the
    estimator's own state sample by sample, a burst of heavy vibration is clipped less than with the gain's ratio."""
    s = _loudening_log(sigma=(0.1, 0.1))
    ay = np.array(s.ay)
    ay[1500:1530] += 0.6 * np.random.default_rng(5).standard_normal(30)        # a burst of 3 s
    s = Signals(s.t, s.vx, ay, s.r, s.delta_f)
    q, ref = 0.1 ** 2 / 10, 0.1 ** 2
    outs = {}
    for ltau in (0.0, 2.0):
        est = E.make("kinematic-lp", cutoff=0.3, clip=3.0, Q_ay=q, R=0.0, noise_tau=60.0, noise_ref=ref,
                     limit_tau=ltau, sample_rate=None)
        ls = L.limit_states(est._nstate, est._roll[0].shape[0])
        est.reset()
        clipped = 0
        for k, a in enumerate(zip(s.t, s.vx, s.ay, s.r, s.delta_f)):
            m = est._mem[ls.NS if ltau > 0 else ls.NV]
            x, t_last, init = est._mem[L.M_X], est._mem[L.M_TLAST], est._mem[L.M_INIT]
            est.step(*a)
            dt = a[0] - t_last
            if init and a[1] >= est.v_min and 0 < dt <= est.max_gap:
                e = a[2] - (G * x + a[1] * a[3])
                lim = 3.0 * np.sqrt(q * m / dt)
                clipped += bool(abs(e) > lim) and 1500 <= k < 1530
                want = a[2] - (e - np.clip(e, -lim, lim))
                assert est._mem[L.M_ETA] == pytest.approx(want, abs=1e-12)     # the limited ay, as read
        outs[ltau] = clipped
    assert outs[2.0] < outs[0.0]


def test_the_gain_follows_the_cutoff_for_the_noise_it_reads():
    """A 100 Hz log whose noise variance grows 6.25 times: the ratio reads it (within 12 %), and the low-pass's
    output noise falls to m^(-1/6) = 0.74 of the same filter's without the running noise (the cut-off for m
    times the noise is m^(-1/3) times the designed one, cutoff_for_noise; the noise a slow first-order filter
    passes goes with its cut-off). The limit is held out of it (clip 50)."""
    s = _loudening_log(rate=100.0, seconds=400.0, sigma=(0.05, 0.125), jitter=0.0)
    quiet = np.asarray(s.t) < s.t[len(s) // 2]
    ref = diff_noise_std(np.asarray(s.ay)[quiet]) ** 2
    opts = dict(cutoff=0.3, clip=50.0, Q_ay=0.05 ** 2 / 100, R=0.0)
    run = E.make("kinematic-lp", noise_tau=5.0, noise_ref=ref, **opts)
    still = E.make("kinematic-lp", **opts)
    loud = np.arange(len(s)) > 0.75 * len(s)
    bank = np.sin(np.radians(3.0))
    m = reference_ratio(s, 5.0, ref, run.v_min, run.max_gap)
    assert np.median(m[loud]) == pytest.approx(6.25, rel=0.12)
    ratio = np.std(run.run(s).w[loud] - bank) / np.std(still.run(s).w[loud] - bank)
    assert ratio == pytest.approx(np.median(m[loud]) ** (-1 / 6), rel=0.05)


def test_every_command_designs_it_for_a_loud_log():
    """For a loud log (for_log: what roadbank estimate builds) kinematic-pif follows its running noise with the
    shipped time constant, relative to the noise of its design span (log_conditions' log_diff_noise, squared);
    built without a log it has none, and the stages before the twelfth (noise_tau=0) neither; a chunked run
    keeps the ratio (the same estimate as in one piece)."""
    s = _loudening_log()
    est = for_log("kinematic-pif", s)
    cond = log_conditions(s)
    assert est.name == "kinematic-pif" and est.limited
    assert est.noise_tau == KINEMATIC_PIF_NOISE_TAU > 0 and est.limit_tau == KINEMATIC_PIF_LIMIT_TAU > 0
    assert est.noise_ref == pytest.approx(cond["log_diff_noise"] ** 2)
    assert E.make("kinematic-pif").noise_tau == 0.0
    assert for_log("kinematic-pif", s, noise_tau=0.0).noise_tau == 0.0
    whole = est.run(s).w
    est.reset()
    parts = [est.run(s[a:a + 700], reset=False).w for a in range(0, len(s), 700)]
    np.testing.assert_allclose(np.concatenate(parts), whole, rtol=0, atol=0)
    with pytest.raises(ValueError, match="noise_tau >= 0"):
        E.make("kinematic-pif", noise_tau=-1.0)
    with pytest.raises(ValueError, match="limit_tau must be >= 0"):
        E.make("kinematic-pif", limit_tau=-1.0)
    assert E.make("kinematic-pif", noise_ref=0.01).limit_tau == KINEMATIC_PIF_LIMIT_TAU
    assert E.make("kinematic-pif", noise_ref=0.01, noise_tau=0.0).limit_tau == 0.0     # no running noise


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts-extra").is_dir(), reason="../shared/data/kitti-oxts-extra not present")
def test_the_shipped_time_constants_are_what_the_rule_picks():
    """The twelfth stage (roadbank.tuning.real.choose_noise_tau) on the KITTI training drives, one by one and
    put end to end in both orders: it picks the shipped time constant. A long drive no longer depends on the
    road it starts on (measured: 0.3886 / 0.4084 deg without, 0.3871 / 0.3899 with), at a cost below the rule's
    tie on the drives one by one (0.3853 -> 0.3867). The thirteenth (stage=13) picks the limit's shipped shorter
    ratio, which gains on both (0.3867 -> 0.3847 one by one, 0.3884 -> 0.3860 end to end)."""
    from roadbank.tuning.real import TIE_DEG, choose_noise_tau, long_logs, long_median, per_log, training_logs

    logs = training_logs(DATA)
    long = long_logs(logs)
    chosen, scores = choose_noise_tau(logs, long)
    assert chosen == KINEMATIC_PIF_NOISE_TAU, scores
    assert scores[chosen][1] < scores[0.0][1] - 0.01
    assert scores[chosen][0] < scores[0.0][0] + TIE_DEG
    fwd, rev = long
    build = per_log("kinematic-pif")
    assert abs(long_median(build, [fwd]) - long_median(build, [rev])) < 0.005
    chosen13, scores13 = choose_noise_tau(logs, long, stage=13)
    assert chosen13 == KINEMATIC_PIF_LIMIT_TAU, scores13
    assert scores13[0.0] == scores[chosen]              # the stage before it, as shipped then
    assert all(a < b for a, b in zip(scores13[chosen13], scores13[0.0]))


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts-extra").is_dir(), reason="../shared/data/kitti-oxts-extra not present")
def test_the_fourteenth_stage_keeps_the_bank_prior_a_rate_in_time():
    """The fourteenth stage (choose_noise_tau(..., stage=14)): a bank-rate prior that grows with speed
    (exponent 0.5, 1) is worse on the KITTI training drives by more than the tie, one by one and end to end
    (measured 0.3847 / 0.3883 / 0.3942 and 0.3860 / 0.3912 / 0.3985 deg), so the shipped exponent 0 stays; its
    first candidate is the stage before as shipped."""
    from roadbank.estimators.gated import KINEMATIC_PIF_BANK_SPEED_EXP
    from roadbank.tuning.real import TIE_DEG, choose_noise_tau, long_logs, training_logs

    logs = training_logs(DATA)
    chosen, scores = choose_noise_tau(logs, long_logs(logs), stage=14)
    assert chosen == KINEMATIC_PIF_BANK_SPEED_EXP == 0.0, scores
    assert all(sum(scores[p]) > sum(scores[0.0]) + TIE_DEG for p in (0.5, 1.0)), scores
    assert all(scores[1.0][i] > scores[0.5][i] > scores[0.0][i] for i in (0, 1)), scores

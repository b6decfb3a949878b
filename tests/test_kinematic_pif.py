"""kinematic-pif: its limits are kinematic-ff and the default PIF, its gate is pif-gated's formula, and
it keeps kinematic-ff's error on real roads while it follows the hard simulated transients."""

from pathlib import Path

import numpy as np
import pytest

from roadbank import Signals
from roadbank import estimators as E
from roadbank.estimators.gated import (KINEMATIC_PIF_BANK_RATE, KINEMATIC_PIF_CLIP, KINEMATIC_PIF_GATE,
                                      KINEMATIC_PIF_KAPPA, KINEMATIC_PIF_LEAD_SAMPLES)
from roadbank.vehicle import for_log

from test_gated import _gate_reference  # the gate written out in plain Python
from test_kinematic_smoother import limited_reference  # the limit written out in numpy

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
#: the rule's stages before the sixth ran without the sampled-data lead
NO_LEAD = {"lead_samples": 0.0, "car_margin": float("inf"), "clip": 0.0}   # stages 1-5: no lead, the static car
STATIC_CAR = {"car_margin": float("inf"), "clip": 0.0}                       # stages 1-7: the static car


@pytest.fixture(scope="module")
def lane_change():
    from roadbank.sim.scenarios import run_scenario
    return run_scenario("track-lane-change", "nominal", seed=0)


@pytest.mark.parametrize("rate", ["auto", None])
def test_gate_shut_is_kinematic_ff_and_gate_open_is_the_default_pif(lane_change, rate):
    """At the first sample the gate is shut (g = 0 at a start), so the open pair starts from its
    low-pass's output there: the kinematic estimate, up to the lead's share of the input
    interpolated entry by entry between grid speeds (the next test); the PIF's thereafter."""
    s = lane_change.signals
    shut = E.make("kinematic-pif", gate_on=1e9, clip=0.0, sample_rate=rate).run(s)
    opened = E.make("kinematic-pif", gate_on=-1e9, sample_rate=rate).run(s)
    ff = slow_filter(sample_rate=rate).run(s)
    pif = E.make("pif-modified", sample_rate=rate).run(s)
    for a, b in ((shut, ff), (opened, pif)):
        np.testing.assert_allclose(a.w[1:], b.w[1:], rtol=0, atol=1e-12)
        np.testing.assert_allclose(a.phi_b[1:], b.phi_b[1:], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(a.valid, b.valid)
    np.testing.assert_allclose(shut.w[0], ff.w[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(opened.w[0], pif.w[0], rtol=0, atol=1e-6)
    # the split low-pass: the kinematic estimate and the centripetal term low-passed apart
    np.testing.assert_allclose(shut.states["k_lp"] - KINEMATIC_PIF_KAPPA * shut.states["a_lp"], ff.states["w_lp"],
                               rtol=0, atol=1e-12)
    for k in ("vy", "r", "w"):
        np.testing.assert_allclose(opened.states[k], pif.states[k], rtol=0, atol=1e-12)


def test_a_steady_turn_on_a_bank_has_no_bias_at_any_speed():
    """The lead's share of the input is a product interpolated entry by entry between grid speeds: on a
    steady turn at speeds between grid points (0.25 m/s apart) the blend is the bank within 2e-5 rad
    (0.001 deg; 1e-5 rad measured at 7.13 m/s, 0.29 rad/s, with a 10 Hz log's lead), against errors of
    0.3 deg on real roads."""
    t = np.arange(0.0, 30.0, 0.01)
    bank = np.radians(4.0)
    for vx in (7.13, 15.0, 23.61):
        r = 2.0 / vx
        s = Signals(t, np.full_like(t, vx), np.full_like(t, vx * r + 9.81 * np.sin(bank)), np.full_like(t, r),
                    np.full_like(t, np.nan))
        est = E.make("kinematic-pif", gate_on=1e9, lead=0.05)
        assert np.max(np.abs(est.run(s).theta - bank)) < 2e-5, vx


def shut_roll():
    """The one roll model of the pair: the PIF's default tuning chose it."""
    return E.make("pif-modified").roll


def slow_filter(**kw):
    """kinematic-ff with the pair's roll model, kappa, lead (half an interval of the data sheet's 100 Hz) and
    the low-pass scheduled on the PIF's noise."""
    pif = E.make("pif-modified")
    return E.make("kinematic-ff", roll=pif.roll, kappa=KINEMATIC_PIF_KAPPA, bank_rate=KINEMATIC_PIF_BANK_RATE,
                  Q_ay=pif.Q_ay, R=pif.R[0, 0], lead=KINEMATIC_PIF_LEAD_SAMPLES / 100.0, **kw)


def _shaken(seed=0, n=3000, sigma=0.3, spikes=()):
    """A 100 Hz drive on a 3 deg bank through a turn, its ay shaken by white noise of ``sigma`` (m/s^2) and
    spikes ``(index, m/s^2)``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    vx = np.full(n, 20.0)
    r = 0.1 * np.clip((t - 10.0) / 2.0, 0.0, 1.0)
    ay = vx * r + 9.81 * np.sin(np.radians(3.0)) + sigma * rng.standard_normal(n)
    for k, a in spikes:
        ay[k] += a
    return Signals(t, vx, ay, r, np.full(n, np.nan)), np.radians(3.0)


def test_the_limit_is_the_documented_huber_update():
    """With ``clip`` the low-pass reads ay less what the kinematic estimate's innovation exceeds clip
    standard deviations of its designed noise by (kernels.sample.limited_ay), written out here from the
    blend's own states: the linear blend (clip 0) run on that ay gives the same estimate to 1e-12."""
    s, _ = _shaken(spikes=((1500, 8.0), (2200, -6.0)))
    est = E.make("kinematic-pif", gate_on=1e9, clip=3.0, Q_ay=0.3 ** 2 / 100.0)
    out = est.run(s)
    limited = limited_reference(s, out.states["k_lp"], 3.0, est.Q_ay, est.R[-1, -1], est.params.g)
    assert 0.001 < np.mean(limited != np.asarray(s.ay)) < 0.02     # the spikes and the tails of the noise
    lin = E.make("kinematic-pif", gate_on=1e9, clip=0.0, Q_ay=0.3 ** 2 / 100.0)
    ref = lin.run(Signals(s.t, s.vx, limited, s.r, s.delta_f))
    np.testing.assert_allclose(out.w, ref.w, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.states["k_lp"], ref.states["k_lp"], rtol=0, atol=1e-12)


def test_a_spike_moves_the_limited_low_pass_by_its_limit_and_white_noise_barely_at_all():
    """A pothole's spike of 40 standard deviations moves the linear low-pass 40 sigma x its gain and the
    limited one at most 3 sigma x its gain (a tenth); on white noise of the designed density the limit
    changes the bank error by less than 3 %, and a turn's entry (the centripetal term's step) not at all."""
    q = 0.3 ** 2 / 100.0
    lin = E.make("kinematic-pif", gate_on=1e9, clip=0.0, Q_ay=q)
    lim = E.make("kinematic-pif", gate_on=1e9, clip=3.0, Q_ay=q)
    quiet, bank = _shaken(sigma=0.0)
    hit, _ = _shaken(sigma=0.0, spikes=((1500, 12.0),))
    d_lin = np.abs(lin.run(hit).theta - lin.run(quiet).theta).max()
    d_lim = np.abs(lim.run(hit).theta - lim.run(quiet).theta).max()
    assert d_lim <= 0.1 * d_lin + 1e-12 and d_lin > 0.02
    np.testing.assert_allclose(lim.run(quiet).theta, lin.run(quiet).theta, rtol=0, atol=1e-12)   # the turn
    for seed in range(3):
        s, bank = _shaken(seed=seed)
        e_lin = np.sqrt(np.mean((lin.run(s).theta[500:] - bank) ** 2))
        e_lim = np.sqrt(np.mean((lim.run(s).theta[500:] - bank) ** 2))
        assert abs(e_lim / e_lin - 1.0) < 0.03, (seed, e_lin, e_lim)


def test_the_limit_is_refused_when_negative_and_off_at_zero():
    with pytest.raises(ValueError, match="clip must be >= 0"):
        E.make("kinematic-pif", clip=-1.0)
    assert E.make("kinematic-pif").clip == KINEMATIC_PIF_CLIP == 3.0
    assert E.make("kinematic-pif", clip=0.0)._cfg[E.layout.C_USE] == 0.0
    # an accelerometer without noise (Q_ay = 0) gives nothing to limit against: the linear low-pass, not a frozen one
    s, _ = _shaken(sigma=0.0)
    noiseless = E.make("kinematic-pif", Q_ay=0.0)
    assert noiseless.clip == 0.0
    np.testing.assert_array_equal(noiseless.run(s).w, E.make("kinematic-pif", Q_ay=0.0, clip=0.0).run(s).w)


def test_the_output_blends_by_the_documented_gate():
    n = 1500
    t = np.arange(n) * 0.01
    vx = np.full(n, 25.0)
    r = np.where(t > 3.0, 0.1, 0.0) + 0.05 * np.sin(2 * np.pi * 0.8 * t) * (t > 8.0) * (t < 11.0)
    s = Signals(t, vx, vx * r + 0.3, r, np.zeros(n))
    gated = E.make("kinematic-pif").run(s)
    slow = slow_filter().run(s)
    fast = E.make("pif-modified").run(s)
    d = fast.w - slow.w
    use = np.abs(d) > 1e-6
    g = _gate_reference(t, vx, r, KINEMATIC_PIF_GATE["gate_tf"], KINEMATIC_PIF_GATE["gate_release"],
                        KINEMATIC_PIF_GATE["gate_on"], KINEMATIC_PIF_GATE["gate_span"])
    assert use.sum() > 500 and 0.99 < g.max() and (g == 0).sum() > 300
    np.testing.assert_allclose(((gated.w - slow.w) / np.where(use, d, 1.0))[use], g[use], atol=1e-8)


def test_bad_gate_settings_are_refused():
    with pytest.raises(ValueError, match="kinematic-pif: need gate_tf"):
        E.make("kinematic-pif", gate_span=0.0)


@pytest.mark.skipif(not (DATA / "kitti-oxts").is_dir(), reason="../shared/data/kitti-oxts not present")
def test_on_real_roads_it_stays_with_kinematic_ff():
    """On the two shared drives (ordinary driving) the gate rarely opens: within 5 % of kinematic-ff."""
    from roadbank.io.kitti import load_kitti_oxts
    from roadbank.validation.kitti import KITTI_SCORING
    from roadbank.validation.scoring import masks

    for drive in ("2011_09_26_drive_0070", "2011_10_03_drive_0047"):
        log = load_kitti_oxts(DATA / "kitti-oxts" / drive)
        s, ref = log.signals, log.reference_roll
        m = masks(s.t, s.vx, KITTI_SCORING)[1]
        rms = {n: float(np.degrees(np.sqrt(np.mean((for_log(n, s).run(s).theta[m] - ref[m]) ** 2))))
               for n in ("kinematic-ff", "kinematic-pif", "pif-modified")}
        assert rms["kinematic-pif"] <= 1.05 * rms["kinematic-ff"] < rms["pif-modified"], (drive, rms)


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts-extra").is_dir(), reason="../shared/data/kitti-oxts-extra not present")
def test_the_shipped_gate_and_the_default_are_what_the_rule_picks():
    """Real roads first, simulated drives break ties (roadbank.tuning.real.choose_by_roads): the shipped
    gate against its grid neighbours and kinematic-ff (the gate held shut). The whole grid is in
    docs/estimators.md."""
    from roadbank.defaults import ESTIMATOR
    from roadbank.tuning.real import GATE_GRID, choose_by_roads, per_log, simulated_sets, training_logs

    logs, sims = training_logs(DATA), simulated_sets()
    g = dict(KINEMATIC_PIF_GATE)
    # the second stage ran before the third (the gate held open on quiet logs): quiet_ratio=0
    builds = {"kinematic-ff": per_log("kinematic-ff", car_margin=float("inf")),
              "shipped": per_log("kinematic-pif", **NO_LEAD, quiet_ratio=0.0)}
    for key in ("gate_on", "gate_span", "gate_release"):
        values = GATE_GRID[key]
        i = values.index(g[key])
        for j in (i - 1, i + 1):
            if 0 <= j < len(values):
                builds[(key, values[j])] = per_log("kinematic-pif", **NO_LEAD, **{key: values[j]})
    chosen, real, sim = choose_by_roads(builds, logs, sims)
    assert chosen == "shipped", (real, sim)
    assert ESTIMATOR == "kinematic-pif"
    # what the gate buys on simulated manoeuvres: the same pair with the gate held shut
    from roadbank.tuning.real import objective
    assert sim["shipped"] < objective(per_log("kinematic-pif", **NO_LEAD, gate_on=1e9), [], sims) - 0.03


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts-extra").is_dir(), reason="../shared/data/kitti-oxts-extra not present")
def test_the_shipped_bank_rate_and_kappa_are_what_the_rule_picks():
    """The first stage of the rule (roadbank.tuning.real.kinematic_pif_candidates(1)), over its whole grid
    (its tie window is measured from the grid's best, so neighbours alone would not do), and the fixed
    low-pass of kinematic-ff's constants, which the noise-scheduled one must beat on real training roads
    and simulated drives. Run as it ran, with the noise read before the twentieth to twenty-second stages
    (design_settings); with today's reading the rule would take the tied neighbour 0.7 deg/s, kappa 0.25."""
    from roadbank.tuning.real import TIE_DEG, choose_by_roads, design_settings, kinematic_pif_candidates, objective
    from roadbank.tuning.real import per_log, simulated_sets, training_logs

    logs, sims = training_logs(DATA), simulated_sets()
    b, k = float(np.degrees(KINEMATIC_PIF_BANK_RATE)), KINEMATIC_PIF_KAPPA
    with design_settings(noise_at_source="none", noise_octave="none"):
        chosen, real, sim = choose_by_roads(kinematic_pif_candidates(1), logs, sims)
        assert chosen == (b, k), ({c: v for c, v in real.items() if c in sim}, sim)
        # the scheduled cut-off beats the fixed one by more than the rule's tie (measured on the real drives,
        # the seconds after each stop scored: 0.4068 against 0.4256 deg; with them left out it was 0.3843
        # against 0.4184), and on the simulated drives by more than 0.02 deg
        fixed = per_log("kinematic-pif", **NO_LEAD, cutoff=0.6, kappa=0.2, quiet_ratio=0.0)
        assert real[(b, k)] < objective(fixed, logs, []) - 5 * TIE_DEG
        assert sim[(b, k)] < objective(fixed, [], sims) - 0.02


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts-extra").is_dir(), reason="../shared/data/kitti-oxts-extra not present")
def test_the_shipped_quiet_ratio_and_filter_are_what_the_rule_picks():
    """The third stage (kinematic_pif_candidates(3): the default PIF on a quiet log) chose the
    shipped ratio against its grid neighbours, in increasing order (exact ties go to the smaller);
    the fourth (kinematic_pif_candidates(4)) the shipped filter at that ratio against the other
    filters of the PIF family, in the stage's order. A quiet filter must not touch a real training
    drive (all are loud) and must gain on the simulated ones."""
    from roadbank.tuning.real import (QUIET_FILTERS, QUIET_RATIOS, choose_by_roads, per_log, simulated_sets,
                                      training_logs)
    from roadbank.vehicle import QUIET_FILTER, QUIET_RATIO

    logs, sims = training_logs(DATA), simulated_sets()
    i = QUIET_RATIOS.index(QUIET_RATIO)
    ratios = sorted({QUIET_RATIOS[j] for j in (0, i - 1, i, i + 1) if 0 <= j < len(QUIET_RATIOS)})
    third = {q: per_log("kinematic-pif", **NO_LEAD, quiet_ratio=q, quiet_filter="pif-modified") for q in ratios}
    chosen, real, sim = choose_by_roads(third, logs, sims)
    assert chosen == QUIET_RATIO, (real, sim)
    assert real[QUIET_RATIO] == real[0.0]
    assert sim[QUIET_RATIO] < sim[0.0] - 0.005
    fourth = {f: per_log("kinematic-pif", **NO_LEAD, quiet_filter=f) for f in QUIET_FILTERS if f.startswith("pif-")}
    chosen4, real4, sim4 = choose_by_roads(fourth, logs, sims)
    assert chosen4 == QUIET_FILTER, (real4, sim4)
    assert real4[QUIET_FILTER] == real[0.0]
    assert sim4["pif-modified"] == sim[QUIET_RATIO]        # the third stage's choice
    assert sim4[QUIET_FILTER] < sim4["pif-modified"] - 0.01


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts-extra").is_dir(), reason="../shared/data/kitti-oxts-extra not present")
def test_the_shipped_lowest_speed_is_what_the_rule_picks():
    """The fifth stage (kinematic_pif_candidates(5)): the shipped lowest speed against its grid
    neighbour and the former 5 m/s, the real drives scored with the seconds after each stop (the
    rule's scoring). It must gain there and change nothing where a warm-up after each start drops
    those seconds."""
    from roadbank.estimators.gated import KINEMATIC_PIF_V_MIN
    from roadbank.tuning.real import V_MINS, choose_by_roads, objective, per_log, simulated_sets, training_logs
    from roadbank.validation.kitti import KITTI_SCORING_EACH_START

    i = V_MINS.index(KINEMATIC_PIF_V_MIN)
    cands = sorted({V_MINS[j] for j in (0, i - 1, i, i + 1) if 0 <= j < len(V_MINS)}, reverse=True)
    builds = {v: per_log("kinematic-pif", **NO_LEAD, v_min=v) for v in cands}
    chosen, real, sim = choose_by_roads(builds, training_logs(DATA), simulated_sets())
    assert chosen == KINEMATIC_PIF_V_MIN, (real, sim)
    assert real[KINEMATIC_PIF_V_MIN] < real[5.0] - 0.02
    each_start = training_logs(DATA, KITTI_SCORING_EACH_START)
    assert objective(builds[KINEMATIC_PIF_V_MIN], each_start, []) == pytest.approx(
        objective(builds[5.0], each_start, []), abs=1e-3)


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts-extra").is_dir(), reason="../shared/data/kitti-oxts-extra not present")
def test_the_shipped_lead_is_what_the_rule_picks():
    """The sixth stage (kinematic_pif_candidates(6)): half a sample interval, the lag of the first-order
    filter of the samples, against the continuous-time filter (no lead) and its grid neighbours; it
    must gain on the real training drives, and a whole interval must not."""
    from roadbank.tuning.real import LEADS_SAMPLES, choose_by_roads, per_log, simulated_sets, training_logs

    i = LEADS_SAMPLES.index(KINEMATIC_PIF_LEAD_SAMPLES)
    cands = sorted({LEADS_SAMPLES[j] for j in (0, i - 1, i, i + 1) if 0 <= j < len(LEADS_SAMPLES)})
    builds = {n: per_log("kinematic-pif", lead_samples=n, **STATIC_CAR) for n in cands}
    chosen, real, sim = choose_by_roads(builds, training_logs(DATA), simulated_sets())
    assert chosen == KINEMATIC_PIF_LEAD_SAMPLES == 0.5, (real, sim)
    assert real[0.5] < real[0.0] - 0.01 and real[0.75] > real[0.5]


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts-extra").is_dir(), reason="../shared/data/kitti-oxts-extra not present")
def test_the_shipped_limit_is_what_the_rule_picks():
    """The tenth stage (kinematic_pif_candidates(10)): the limit of the low-pass's update against the linear
    low-pass and the rest of its grid. Every simulated training drive is quiet (the car's model, no low-pass),
    so the real training drives decide; the limit must gain there by more than the rule's tie (measured:
    0.3929 -> 0.3853 deg), and a limit twice as tight must lose (it clips the road's own bank changes)."""
    from roadbank.tuning.real import TIE_DEG, choose_by_roads, kinematic_pif_candidates, simulated_sets, training_logs

    chosen, real, sim = choose_by_roads(kinematic_pif_candidates(10), training_logs(DATA), simulated_sets())
    assert chosen == KINEMATIC_PIF_CLIP == 3.0, (real, sim)
    assert real[3.0] < real[0.0] - 3 * TIE_DEG
    assert real[1.5] > real[0.0]


def test_the_blend_gets_half_an_interval_of_the_logs_rate_as_its_lead(lane_change):
    """make_estimator gives the blend's low-pass the lead of the log's own rate (10 Hz: 0.05 s), keeps an
    explicit one, and the quiet filter, which has no low-pass, takes none."""
    s = lane_change.signals
    rng = np.random.default_rng(2)
    loud100 = Signals(s.t, s.vx, s.ay + 0.15 * rng.standard_normal(len(s.t)), s.r, s.delta_f)
    loud10 = loud100[::10]
    assert for_log("kinematic-pif", loud10).lead == pytest.approx(KINEMATIC_PIF_LEAD_SAMPLES / 10.0, rel=1e-6)
    assert for_log("kinematic-pif", loud100).lead == pytest.approx(KINEMATIC_PIF_LEAD_SAMPLES / 100.0, rel=1e-6)
    assert for_log("kinematic-pif", loud10, lead=0.0).lead == 0.0
    assert for_log("kinematic-pif", loud10, lead_samples=1.0).lead == pytest.approx(0.1, rel=1e-6)
    assert E.make("kinematic-pif").lead == KINEMATIC_PIF_LEAD_SAMPLES / 100.0     # the data sheet's rate
    assert not hasattr(for_log("kinematic-pif", s, described=True, lead=0.05), "lead")  # quiet: pif-adaptive


def test_a_quiet_log_gets_the_quiet_filter_and_a_loud_one_the_blend(lane_change):
    """The rule of roadbank.vehicle.is_quiet in every command's factory: on a log whose ay carries
    the data sheet's noise kinematic-pif is the quiet filter under its own name, its car described (here the car
    fitted to the log read as described); with the road noise of a real road, the blend; a car nobody described gets
    the blend on the quiet log too (the sixty-second stage)."""
    from roadbank.estimators.gated import KinematicPIF
    from roadbank.vehicle import QUIET_FILTER, SensorSpec, is_quiet, log_conditions

    s = lane_change.signals
    sheet = SensorSpec()
    cond = log_conditions(s)
    assert is_quiet(sheet, cond["log_rate"], cond["log_ay_noise"])
    rng = np.random.default_rng(1)
    loud = Signals(s.t, s.vx, s.ay + 0.15 * rng.standard_normal(len(s.t)), s.r, s.delta_f)
    lc = log_conditions(loud)
    assert not is_quiet(sheet, lc["log_rate"], lc["log_ay_noise"])
    assert not is_quiet(sheet, cond["log_rate"], float("nan")) and not is_quiet(sheet, 100.0, 0.0, ratio=0.0)
    quiet_est, loud_est = for_log("kinematic-pif", s, described=True), for_log("kinematic-pif", loud, described=True)
    assert quiet_est.name == loud_est.name == "kinematic-pif"
    assert not isinstance(quiet_est, KinematicPIF) and isinstance(loud_est, KinematicPIF)
    nobody = for_log("kinematic-pif", s)
    assert isinstance(nobody, KinematicPIF) and nobody.gate_on == for_log("kinematic-pif", s, quiet_ratio=0.0).gate_on
    got, ref = quiet_est.run(s), for_log(QUIET_FILTER, s).run(s)
    assert got.name == "kinematic-pif"
    np.testing.assert_array_equal(got.w, ref.w)
    np.testing.assert_array_equal(got.valid, ref.valid)
    # the low-pass's options do not reach the quiet filter; another quiet filter can be named
    np.testing.assert_array_equal(for_log("kinematic-pif", s, described=True, cutoff=0.3, kappa=0.1).run(s).w, ref.w)
    pif = for_log("kinematic-pif", s, described=True, quiet_filter="pif-modified").run(s)
    np.testing.assert_array_equal(pif.w, for_log("pif-modified", s).run(s).w)
    # an explicit gate, or quiet_ratio=0, keeps the blend
    assert for_log("kinematic-pif", s, gate_on=3.0).gate_on == 3.0
    assert for_log("kinematic-pif", s, quiet_ratio=0.0).gate_on == KINEMATIC_PIF_GATE["gate_on"]


def test_the_blend_runs_through_a_stop_instead_of_starting_again():
    """A car on a 2 deg bank stops and pulls away 15 times, its ay shaken as on a real road. The
    kinematic estimate holds at any speed, so the blend (lowest speed KINEMATIC_PIF_V_MIN) keeps
    filtering down to 1 m/s: in the second after the car passes 5 m/s again its error is about the
    steady one, while the same filter stopped at 5 m/s starts again from one noisy sample (its
    max_gap of 1 s has passed) and has about twice the error there."""
    from roadbank.estimators.gated import KINEMATIC_PIF_V_MIN

    t = np.arange(0.0, 450.0, 0.1)
    phase = t % 30.0
    vx = np.interp(phase, [0, 15, 20, 24, 30], [10, 10, 0, 0, 10])
    bank = np.radians(2.0)
    rng = np.random.default_rng(0)
    ay = 9.81 * np.sin(bank) + 0.2 * rng.standard_normal(t.size)
    s = Signals(t, vx, ay, np.zeros_like(t), np.full_like(t, np.nan))
    assert for_log("kinematic-pif", s).v_min == KINEMATIC_PIF_V_MIN == 1.0
    # the running noise held at the design's (noise_tau=0): its ratio remembers a minute, whose samples differ
    # between the two lowest speeds, and the steady errors below would differ by that (0.07 %)
    est = for_log("kinematic-pif", s, noise_tau=0.0)
    assert isinstance(est, E.KinematicPIF)                 # loud: the blend
    through, stopped = est.run(s), for_log("kinematic-pif", s, v_min=5.0, noise_tau=0.0).run(s)
    assert through.valid[(vx >= 1.0) & (t > 1.0)].all() and not stopped.valid[vx < 5.0].any()
    after = np.zeros(t.size, bool)
    for k in np.flatnonzero((vx[1:] >= 5.0) & (vx[:-1] < 5.0)) + 1:
        after[k:k + 10] = True
    steady = (phase > 5.0) & (phase < 15.0) & (t > 30.0)

    def rms(e, m):
        return float(np.degrees(np.sqrt(np.mean((e.theta[m] - bank) ** 2))))

    assert rms(through, steady) == pytest.approx(rms(stopped, steady), rel=1e-6)
    assert rms(through, after) < 1.5 * rms(through, steady)
    assert rms(stopped, after) > 1.5 * rms(through, after)
    # the quiet filter keeps its own lowest speed (its tyre model's limit)
    quiet = Signals(t, vx, 9.81 * np.sin(bank) + 0.01 * rng.standard_normal(t.size), s.r, s.delta_f)
    assert not isinstance(for_log("kinematic-pif", quiet, described=True), E.KinematicPIF)
    assert for_log("kinematic-pif", quiet, described=True).v_min == 5.0


def test_the_rules_tie_break_ignores_float_rounding(monkeypatch):
    """choose_by_roads: real medians within TIE_DEG tie, the simulated median decides, and simulated medians
    equal but for float rounding (1e-16) leave the choice to the candidates' order, not to the rounding."""
    from roadbank.tuning.real import esp as R       # the stage's module: where choose_by_roads finds objective

    table = {("a", "real"): 0.4000, ("b", "real"): 0.4005, ("c", "real"): 0.5,
             ("a", "sim"): 0.3 + 1e-16, ("b", "sim"): 0.3, ("c", "sim"): 0.1}
    monkeypatch.setattr(R, "objective", lambda build, logs, sims: table[(build, "real" if logs else "sim")])
    builds = {"a": "a", "b": "b", "c": "c"}
    chosen, real, sim = R.choose_by_roads(builds, ["one log"], [])
    assert chosen == "a" and set(sim) == {"a", "b"}                # c is not tied on real roads
    table[("b", "sim")] = 0.3 - 1e-6
    assert R.choose_by_roads(builds, ["one log"], [])[0] == "b"    # a real difference decides


def test_a_described_car_and_a_car_nobody_described_share_the_quiet_rule(lane_change):
    """A log 1.5-6 times as noisy as the data sheet gets the blend with or without the car's file (one
    quiet ratio, the rule's seventh stage); an explicit ratio wins; the clean log gets the car's model."""
    from roadbank.vehicle import QUIET_RATIO, SensorSpec, load_vehicle, log_conditions

    s = lane_change.signals
    rng = np.random.default_rng(5)
    mid = Signals(s.t, s.vx, s.ay + 0.05 * rng.standard_normal(len(s.t)), s.r, s.delta_f)
    cond, sheet = log_conditions(mid), SensorSpec()
    ratio = cond["log_ay_noise"] ** 2 / cond["log_rate"] / sheet.ay_noise_density(cond["log_rate"])
    assert QUIET_RATIO < ratio < 6.0, ratio
    car = load_vehicle("suv-paper")
    assert isinstance(for_log("kinematic-pif", mid), E.KinematicPIF)
    assert isinstance(for_log("kinematic-pif", mid, vehicle=car), E.KinematicPIF)
    assert not isinstance(for_log("kinematic-pif", mid, vehicle=car, quiet_ratio=6.0), E.KinematicPIF)
    assert isinstance(for_log("kinematic-smoother", mid, vehicle=car, quiet_ratio=6.0), E.PIFSmoother)
    assert not isinstance(for_log("kinematic-pif", s, vehicle=car), E.KinematicPIF)
    assert isinstance(for_log("kinematic-smoother", s, vehicle=car), E.PIFSmoother)


@pytest.mark.slow
def test_the_described_cars_quiet_ratio_is_what_the_rule_picks():
    """The seventh stage (tuning.real.choose_described_ratio) on the simulated training drives, each built
    for its own car: every simulated drive reads about its data sheet's noise, so the ratios from 1.5 up
    tie and the smallest, the undescribed car's, wins; the car's model on quiet logs gains over never."""
    from roadbank.tuning.real import EQUAL_DEG, choose_described_ratio, simulated_sets
    from roadbank.vehicle import QUIET_RATIO

    chosen, meds = choose_described_ratio(simulated_sets(), ratios=(0.0, QUIET_RATIO, 2.0, 6.0))
    assert chosen == QUIET_RATIO, meds
    assert abs(meds[6.0] - meds[QUIET_RATIO]) < EQUAL_DEG
    assert meds[QUIET_RATIO] < meds[0.0] - 0.03


@pytest.mark.slow
def test_the_described_cars_quiet_filter_is_what_the_rule_picks():
    """The fifteenth stage (tuning.real.choose_described_filter) on the simulated training drives, each built for
    its own car: the shipped quiet filter (pif-adaptive) stays, clearly ahead of the plain PIF and of the low-passes
    (the model is worth more than a low-pass on a quiet log of a known car)."""
    from roadbank.tuning.real import TIE_DEG, choose_described_filter, simulated_sets
    from roadbank.vehicle import QUIET_FILTER

    chosen, scores = choose_described_filter(simulated_sets(),
                                             filters=(QUIET_FILTER, "pif-modified", "pif-gated", "kinematic-ff"))
    assert chosen == QUIET_FILTER, scores
    median = {f: m for f, (m, _) in scores.items()}
    assert median[QUIET_FILTER] < min(median["pif-modified"], median["pif-gated"]) - TIE_DEG
    assert median["pif-modified"] < median["kinematic-ff"] - 0.05


def test_loud_sets_read_a_drive_at_10_hz_with_student_t_vibration_on_ay():
    from roadbank.tuning.manoeuvres import Drive
    from roadbank.tuning.real import LOUD_AY_NOISE, LOUD_RATE_HZ, loud_sets

    t = np.arange(0.0, 600.0, 0.01)
    s = Signals(t, np.full(t.size, 20.0), 0.3 * np.sin(0.1 * t), np.zeros(t.size), np.zeros(t.size))
    d = Drive("train", 0, "bank-step", {}, s, 0.01 * np.sin(0.1 * t))
    (loud,), = loud_sets([[d]])
    assert np.allclose(np.diff(loud.signals.t), 1.0 / LOUD_RATE_HZ)
    assert np.array_equal(loud.phi_b, d.phi_b[::10]) and np.array_equal(loud.signals.vx, s.vx[::10])
    noise = loud.signals.ay - s.ay[::10]
    assert np.sqrt(np.mean(noise ** 2)) == pytest.approx(LOUD_AY_NOISE, rel=0.1)
    assert np.mean(noise ** 4) / np.mean(noise ** 2) ** 2 > 4.0         # heavy tails (a Gaussian has 3)
    (again,), = loud_sets([[d]])
    assert np.array_equal(again.signals.ay, loud.signals.ay)              # one seed, the same drives


def test_gate_filter_sets_read_the_loud_drives_at_each_rate_from_one_seed():
    from roadbank.tuning.manoeuvres import Drive
    from roadbank.tuning.real import GATE_TF_RATES, LOUD_AY_NOISE, gate_filter_sets, loud_sets

    t = np.arange(0.0, 600.0, 0.01)
    s = Signals(t, np.full(t.size, 20.0), 0.3 * np.sin(0.1 * t), np.zeros(t.size), np.zeros(t.size))
    d = Drive("train", 0, "bank-step", {}, s, 0.01 * np.sin(0.1 * t))
    sets = gate_filter_sets([[d], [d]])
    assert len(sets) == 2 * len(GATE_TF_RATES)
    for i, rate in enumerate(GATE_TF_RATES):
        for drives in sets[2 * i:2 * i + 2]:
            assert np.allclose(np.diff(drives[0].signals.t), 1.0 / rate)
        noise = sets[2 * i][0].signals.ay - s.ay[::int(round(100.0 / rate))]
        assert np.sqrt(np.mean(noise ** 2)) == pytest.approx(LOUD_AY_NOISE, rel=0.1)
    ten, = [k for k, r in enumerate(GATE_TF_RATES) if r == 10.0]
    assert np.array_equal(sets[2 * ten][0].signals.ay, loud_sets([[d]])[0][0].signals.ay)   # the sixteenth's set


@pytest.mark.slow
def test_the_gate_on_loud_logs_is_what_the_rule_keeps():
    """The sixteenth stage (tuning.real.choose_loud_gate) between the shipped gate and no gate: they tie on the KITTI
    training drives; on the loud simulated drives no gate has the lower median but the higher mean (the hard
    transients it loses), so the mean guard keeps the gate."""
    from roadbank.tuning.real import (NO_GATE, TIE_DEG, choose_loud_gate, loud_gate_candidates, loud_sets,
                                      simulated_sets, training_logs)

    logs = training_logs(DATA)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")

    cands = loud_gate_candidates()
    shipped, none = next(iter(cands)), (NO_GATE, 1.0, 1.0)
    chosen, real, med = choose_loud_gate(logs, loud_sets(simulated_sets()), {k: cands[k] for k in (shipped, none)})
    assert chosen == shipped
    assert abs(real[none] - real[shipped]) <= TIE_DEG
    assert med[none] < med[shipped] - 0.01


@pytest.mark.slow
def test_the_gate_filter_is_what_the_rule_keeps():
    """The seventeenth stage (tuning.real.choose_gate_filter) between the shipped 0.05 s and 0.2 s: they tie on the
    KITTI training drives; on the loud simulated drives at 10 and 100 Hz the slower filter opens the gate later on the
    transients and loses by the median."""
    from roadbank.tuning.real import (GATE_TFS, TIE_DEG, choose_gate_filter, gate_filter_sets, simulated_sets,
                                      training_logs)

    logs = training_logs(DATA)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, real, med = choose_gate_filter(logs, gate_filter_sets(simulated_sets()), (GATE_TFS[0], 0.2))
    assert chosen == GATE_TFS[0]
    assert abs(real[0.2] - real[GATE_TFS[0]]) <= TIE_DEG
    assert med[0.2] > med[GATE_TFS[0]] + 0.02


@pytest.fixture(scope="module")
def training_drives():
    """The eight KITTI training drives (tuning.real.training_logs) and the same interpolated onto 100 Hz
    (upsampled_logs), as the eighteenth to twenty-first stages read them; skipped where they are not all there."""
    from roadbank.tuning.real import training_logs, upsampled_logs

    logs = training_logs(DATA)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    return logs, upsampled_logs(logs)


@pytest.mark.slow
def test_the_quiet_floor_rate_is_what_the_rule_keeps(training_drives):
    """The eighteenth stage (tuning.real.choose_quiet_floor_rate): reading the floor at 10 Hz calls no interpolated
    100 Hz KITTI training drive quiet and lowers the real median by far, but calls loud most simulated drives with the
    data sheet's sensors, whose manoeuvres fill the same band; the mean guard keeps the log's own rate."""
    from roadbank.tuning.real import QUIET_FLOOR_RATES, choose_quiet_floor_rate, simulated_sets

    chosen, real, sim = choose_quiet_floor_rate(*training_drives, simulated_sets())
    shipped, at10 = QUIET_FLOOR_RATES
    assert chosen == shipped
    assert real[shipped][:8] == real[at10][:8]                                   # 10 Hz logs: the same
    assert np.median(real[at10]) < np.median(real[shipped]) - 0.05
    assert np.mean(np.concatenate(sim[at10])) > np.mean(np.concatenate(sim[shipped])) + 0.02


@pytest.mark.slow
def test_the_quiet_floor_signal_is_what_the_rule_keeps(training_drives):
    """The nineteenth stage (tuning.real.choose_quiet_floor_signal): the floor of ay - vx r at the log's own rate
    decides as ay's does; read at 10 Hz it calls no interpolated KITTI training drive quiet, but still calls loud
    simulated drives with the data sheet's sensors (not the centripetal part fills their 1-5 Hz): the mean guard
    keeps ay at the log's own rate."""
    from roadbank.tuning.real import QUIET_FLOOR_READINGS, choose_quiet_floor_signal, simulated_sets

    chosen, real, sim = choose_quiet_floor_signal(*training_drives, simulated_sets())
    shipped, own, at10 = QUIET_FLOOR_READINGS
    assert chosen == shipped
    assert real[own] == real[shipped]
    assert np.median(real[at10]) < np.median(real[shipped]) - 0.05
    assert np.mean(np.concatenate(sim[at10])) > np.mean(np.concatenate(sim[shipped])) + 0.02


@pytest.mark.slow
def test_noise_at_the_source_rate_is_what_the_rule_chooses(training_drives):
    """The twentieth stage (tuning.real.choose_noise_at_source): every noise reading of a channel written faster
    than its sensor taken at the sensor's rate brings the interpolated KITTI training drives near their own 10 Hz
    error and changes nothing else (no simulated drive or 10 Hz drive is read otherwise); the quiet floor alone
    does half of it."""
    from roadbank.tuning.real import NOISE_AT_SOURCE_CHOICES, choose_noise_at_source, simulated_sets

    chosen, real, sim = choose_noise_at_source(*training_drives, simulated_sets())
    none, floor, every = NOISE_AT_SOURCE_CHOICES
    assert chosen == every
    assert real[every][:8] == real[none][:8]                                     # 10 Hz logs: the same
    assert np.median(real[every][8:]) < np.median(real[floor][8:]) - 0.1 < np.median(real[none][8:]) - 0.3
    assert np.median(real[every][8:]) < 1.1 * np.median(real[every][:8])
    assert sim[every] == sim[none]                                               # no simulated drive read otherwise


@pytest.mark.slow
def test_the_noise_octave_is_what_the_rule_chooses(training_drives):
    """The twenty-first stage (tuning.real.choose_noise_octave): reading the noise density in the octave above the
    dynamics band brings the KITTI training drives resampled onto 100 Hz without aliasing (called quiet before) near
    their own 10 Hz error; at every rate ("all") it leads the real median by more than the tie, the simulated drives
    move by less than 0.01 deg, and the mean guard passes."""
    from roadbank.tuning.real import (NOISE_OCTAVES, TIE_DEG, cars_median, choose_noise_octave, resampled_logs,
                                      simulated_sets)

    logs, up = training_drives
    chosen, real, sim = choose_noise_octave(logs, up, resampled_logs(logs), simulated_sets())
    none, fast, every = NOISE_OCTAVES
    assert chosen == every
    assert np.median(real[none][16:]) > 0.7 > 0.5 > np.median(real[every][16:])     # resampled drives
    assert real[fast][:16] == real[none][:16]                                       # 10 Hz and interpolated: as before
    assert np.median(real[every]) < np.median(real[fast]) - TIE_DEG
    assert abs(np.median(real[every][:8]) - np.median(real[none][:8])) < TIE_DEG     # the 10 Hz drives: within the tie
    assert abs(cars_median(sim[every]) - cars_median(sim[none])) < 0.01
    mean = {k: np.mean(np.concatenate([real[k], *v])) for k, v in sim.items()}
    assert mean[every] < mean[none]


@pytest.mark.slow
def test_the_band_width_is_what_the_rule_chooses(training_drives):
    """The twenty-second stage (tuning.real.choose_octave_top): the band the noise is read in ends at 1.5 times its
    lower edge. It leads the octave (2) on the real median by more than the tie, by the resampled drives (whose
    polyphase filter already rolls off at 4-5 Hz of the 10 Hz source), wider bands lose, and the mean guard
    passes; the 10 Hz drives move by less than the tie."""
    from roadbank.tuning.real import NOISE_OCTAVE_TOPS, TIE_DEG, choose_octave_top, resampled_logs, simulated_sets

    logs, up = training_drives
    chosen, real, sim = choose_octave_top(logs, up, resampled_logs(logs), simulated_sets())
    octave, narrow, three, four = NOISE_OCTAVE_TOPS
    assert chosen == narrow
    assert np.median(real[narrow]) < np.median(real[octave]) - TIE_DEG < np.median(real[three]) - TIE_DEG
    assert np.median(real[three]) < np.median(real[four])
    assert np.median(real[narrow][16:]) < np.median(real[octave][16:]) - 0.01
    assert abs(np.median(real[narrow][:8]) - np.median(real[octave][:8])) < TIE_DEG
    mean = {k: np.mean(np.concatenate([real[k], *v])) for k, v in sim.items()}
    assert mean[narrow] < mean[octave]


@pytest.mark.slow
def test_the_bank_rate_and_kappa_again_are_what_the_rule_keeps(training_drives):
    """The twenty-third stage (tuning.real.choose_prior_again): the first stage's pair chosen again with every later
    choice in place. Its whole grid ran once (tuning.real's docstring); here the shipped pair and the grid's best on
    the real median (0.5 deg/s, kappa 0.25), which fixes the tie window. That pair leads the real median by more
    than the tie, by the resampled drives, and loses the 10 Hz drives, the loud simulated ones and the mean of every
    score judged: the guard keeps the shipped pair."""
    from roadbank.tuning.real import (TIE_DEG, cars_median, choose_prior_again, loud_sets, prior_candidates,
                                      resampled_logs, simulated_sets)

    logs, up = training_drives
    shipped, best = (round(float(np.degrees(KINEMATIC_PIF_BANK_RATE)), 6), KINEMATIC_PIF_KAPPA), (0.5, 0.25)
    cands = {k: b for k, b in prior_candidates().items() if k in (shipped, best)}
    assert list(cands) == [shipped, best]                       # the shipped pair first
    chosen, real, sim = choose_prior_again(logs, up, resampled_logs(logs), loud_sets(simulated_sets()), cands)
    assert chosen == shipped
    assert np.median(real[best]) < np.median(real[shipped]) - TIE_DEG
    assert np.median(real[best][16:]) < np.median(real[shipped][16:]) - 0.01          # resampled drives
    assert np.median(real[best][:8]) > np.median(real[shipped][:8]) + TIE_DEG          # 10 Hz drives
    assert cars_median(sim[best]) > cars_median(sim[shipped]) + 0.03
    mean = {k: np.mean(np.concatenate([real[k], *v])) for k, v in sim.items()}
    assert mean[best] > mean[shipped]


@pytest.mark.slow
def test_the_gate_at_the_yaw_rates_source_is_what_the_rule_chooses(training_drives):
    """The fifty-third stage (tuning.real.choose_gate_at_source): on the KITTI training drives written held at 50 and
    100 Hz and interpolated at 100 Hz, the gate filtering the yaw rate over its source's interval (B) lowers the
    median by more than the rule's 0.005 deg (measured 0.5888 -> 0.4655) and loses more than 0.02 deg on at most 4 of
    the 24 logs (1); the drives as recorded get the same outputs under both (the function's guard)."""
    from roadbank.tuning.real import HELD_RATES_HZ, choose_gate_at_source, held_logs
    from roadbank.vehicle.conditions import GATE_AT_SOURCE

    logs, up = training_drives
    forms = held_logs(logs, HELD_RATES_HZ[0]) + held_logs(logs, HELD_RATES_HZ[1]) + up
    chosen, errs = choose_gate_at_source(logs, forms)
    assert chosen is True and GATE_AT_SOURCE is True
    a, b = np.array(errs[False]), np.array(errs[True])
    assert np.median(b) < np.median(a) - 0.05
    held = held_logs(logs[:1], 100.0)[0][0]                   # a held yaw rate's steps: 10 samples each
    assert np.count_nonzero(np.diff(held.r)) <= len(held.r) // 9


@pytest.mark.slow
def test_a_held_log_read_at_its_sources_rate_is_what_the_rule_chooses(training_drives):
    """The fifty-fifth stage (tuning.real.choose_read_at_source): on the KITTI training drives written held at 50 and
    100 Hz, reading them at their source's rate (B) lowers the ESP forms' median by more than the rule's 0.005 deg
    (measured 0.5060 -> 0.4213), keeps the gyro-aided forms' within 0.005 (0.1942 -> 0.1957) and loses more than
    0.02 deg on none of the 32 logs (the rule allows 4); the drives as recorded are read the same (the guard)."""
    from roadbank.tuning.real import HELD_RATES_HZ, choose_read_at_source, held_logs, training_logs
    from roadbank.vehicle.conditions import READ_AT_SOURCE

    logs, _ = training_drives
    gyro = training_logs(DATA, roll_rate=True, pitch_rate=True)
    esp_forms = held_logs(logs, HELD_RATES_HZ[0]) + held_logs(logs, HELD_RATES_HZ[1])
    gyro_forms = held_logs(gyro, HELD_RATES_HZ[0]) + held_logs(gyro, HELD_RATES_HZ[1])
    chosen, errs = choose_read_at_source(logs, gyro, esp_forms, gyro_forms)
    assert chosen is True and READ_AT_SOURCE is True
    (a1, a2), (b1, b2) = errs[False], errs[True]
    assert np.median(b1) < np.median(a1) - 0.05
    assert np.median(b2) <= np.median(a2) + 0.005
    assert int(np.sum(np.array(b1 + b2) > np.array(a1 + a2) + 0.02)) == 0


@pytest.mark.slow
def test_a_rounded_interpolated_log_read_at_its_sources_rate_is_what_the_rule_chooses(training_drives):
    """The fifty-seventh stage (tuning.real.choose_source_rounding): on the KITTI training drives interpolated to 100 Hz
    and written with few decimals, the rounding tolerance (B) lowers the ESP forms' median by more than the rule's
    0.005 deg (measured 0.4187 -> 0.3967, the unrounded forms' 0.396), keeps the gyro-aided forms' (0.1882 both) and
    loses more than 0.02 deg on 2 of the 32 logs (the rule allows 4); the drives as recorded, interpolated unrounded,
    held, and the simulated quantised drives at the data sheet's noise and half of it are read the same (the guard)."""
    from roadbank.tuning.real import (ROUNDINGS, SOURCE_ROUNDING_SIM_NOISE, choose_source_rounding, held_logs,
                                      quiet_noise_sets, rounded_logs, training_logs)
    from roadbank.vehicle.conditions import SOURCE_ROUNDING

    logs, up = training_drives
    gyro = training_logs(DATA, roll_rate=True)
    esp_forms = [f for steps in ROUNDINGS for f in rounded_logs(logs, steps)]
    gyro_forms = [f for steps in ROUNDINGS for f in rounded_logs(gyro, steps)]
    guard = [up, rounded_logs(gyro, {}), held_logs(logs, 100.0), held_logs(gyro, 100.0)]
    chosen, errs = choose_source_rounding(logs, gyro, esp_forms, gyro_forms, guard,
                                          [quiet_noise_sets(k) for k in SOURCE_ROUNDING_SIM_NOISE])
    assert chosen is True and SOURCE_ROUNDING is True
    (a1, a2), (b1, b2) = errs[False], errs[True]
    assert np.median(b1) < np.median(a1) - 0.015
    assert np.median(b2) <= np.median(a2) + 0.005
    assert int(np.sum(np.array(b1 + b2) > np.array(a1 + a2) + 0.02)) <= 4


@pytest.mark.slow
def test_a_log_whose_roads_turn_loud_is_handed_over_as_the_rules_choose(training_drives):
    """The fifty-eighth and fifty-ninth stages (tuning.real.choose_road_change, choose_road_change_gyro): on long logs
    of the KITTI training drives after a smooth start, handing a log designed quiet to the design of its first loud
    stretch lowers the ESP logs' median by more than the rule's 0.05 deg (measured 1.1173 -> 0.5276), the logs with
    the roll rate' too (1.1173 -> 0.5510), leaves the long quiet simulated logs as they were; with 2 s between the
    drives the hand-over to the gyro-aided filter stays (0.5383 against 1.1173 without it); the drives as recorded,
    the simulated drives one by one and the ESP long logs are the guards."""
    from roadbank.tuning.real import (RESTART_GAP_S, choose_road_change, choose_road_change_gyro, long_quiet_sets,
                                      simulated_sets, smooth_start_logs, training_logs)
    from roadbank.vehicle.conditions import ROAD_CHANGE

    logs, _ = training_drives
    gyro = training_logs(DATA, roll_rate=True)
    sims = simulated_sets()
    chosen, errs = choose_road_change(logs, gyro, smooth_start_logs(logs), smooth_start_logs(gyro), sims,
                                      long_quiet_sets(sims))
    assert chosen is True
    (a1, a2, a3), (b1, b2, b3) = errs[False], errs[True]
    assert np.median(b1) < np.median(a1) - 0.3 and np.median(b2) < np.median(a2) - 0.3
    assert a3 == b3
    chosen, errs = choose_road_change_gyro(smooth_start_logs(logs, RESTART_GAP_S),
                                           smooth_start_logs(gyro, RESTART_GAP_S))
    assert chosen is True and ROAD_CHANGE is True
    assert np.median(errs[True]) < np.median(errs["esp"]) - 0.3


@pytest.mark.slow
def test_a_quiet_log_with_an_ins_roll_rate_reads_it_as_the_rule_chooses():
    """The sixtieth stage (tuning.real.choose_quiet_ins): on the KITTI training drives made a smooth road (quiet), a
    roll rate documented free of offset (the INS's) makes the default the gyro-aided filter: median 0.6527 -> 0.1761
    deg (the rule asks 0.005); the drives as recorded (loud) and the fifty-sixth stage's ESP-class gyro sims (not
    documented free of offset) are read the same (the guard)."""
    from roadbank.tuning.real import (QUIET_GYRO_OFFSETS, choose_quiet_ins, gyro_sim_sets, smooth_road_logs,
                                      training_logs)
    from roadbank.vehicle import SensorSpec, log_conditions
    from roadbank.vehicle.conditions import QUIET_READS_ROLL_RATE, is_quiet

    gyro = training_logs(DATA, roll_rate=True)
    if len(gyro) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    smooth = smooth_road_logs(gyro)
    for s, _, _ in smooth:          # the set is what it says: quiet, with an INS's roll rate
        c = log_conditions(s)
        assert is_quiet(SensorSpec(), c["log_rate"], c["log_ay_noise"], log_ay_floor=c["log_ay_floor"])
        assert "p" in s.unbiased
    chosen, errs = choose_quiet_ins(gyro, smooth, [gyro_sim_sets(o) for o in QUIET_GYRO_OFFSETS])
    assert chosen == "unbiased" and QUIET_READS_ROLL_RATE == "unbiased"
    assert np.median(errs["unbiased"]) < np.median(errs[False]) - 0.3


@pytest.mark.slow
def test_a_quiet_log_with_a_roll_rate_keeps_the_cars_model_as_the_rule_chooses():
    """The fifty-sixth stage (tuning.real.choose_quiet_gyro), a negative result: on the quiet simulated training drives
    of the four cars with an ESP-class roll-rate gyro, the gyro-aided default (B) loses to the car's model (A) by more
    than the rule's 0.005 deg (measured 0.2553 against 0.2960); the KITTI drives are read the same (the guard)."""
    from roadbank.tuning.real import QUIET_GYRO_OFFSETS, choose_quiet_gyro, gyro_sim_sets, training_logs
    from roadbank.vehicle.conditions import QUIET_READS_ROLL_RATE

    gyro = training_logs(DATA, roll_rate=True, pitch_rate=True)
    if len(gyro) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj, _ = choose_quiet_gyro(gyro, [gyro_sim_sets(o) for o in QUIET_GYRO_OFFSETS])
    # (an ESP-class gyro, as here, still keeps the car's model: the sixtieth stage reads only an INS's roll rate so)
    assert chosen is False and QUIET_READS_ROLL_RATE in (False, "unbiased")
    assert obj[True] > obj[False] + 0.02


@pytest.mark.slow
def test_a_loud_design_is_not_handed_back_as_the_rule_chooses(training_drives):
    """The sixty-first stage (tuning.real.choose_road_change_back), a negative result: handing the loud design back to
    the car's model where a stretch reads quiet loses on the KITTI training drives as recorded and as a smooth road in
    one log (median 0.4264 -> 0.6692 deg; the rule asks a gain of 0.02), though it gains on the simulated cars (0.5598
    -> 0.4662): the car's model, of a car nobody described, does worse than the blend on the real smooth road."""
    from roadbank.tuning.real import (choose_road_change_back, gyro_sim_sets, loud_and_quiet_logs,
                                      loud_then_quiet_sets, simulated_sets, smooth_road_logs, training_logs)
    from roadbank.vehicle.conditions import ROAD_CHANGE_BACK

    logs, _ = training_drives
    gyro = training_logs(DATA, roll_rate=True)
    sims = simulated_sets()
    loud_quiet, quiet_loud_quiet = loud_and_quiet_logs(logs, smooth_road_logs(logs))
    chosen, errs = choose_road_change_back(logs, gyro, loud_quiet, quiet_loud_quiet, sims, loud_then_quiet_sets(sims),
                                           loud_then_quiet_sets(gyro_sim_sets(0.0)))
    assert chosen is False and ROAD_CHANGE_BACK is False
    (a1, a2, _, _), (b1, b2, _, _) = errs[False], errs[True]
    assert np.median(b1) > np.median(a1) + 0.1
    assert a2 == b2                 # the drives as recorded: no stretch reads quiet


@pytest.mark.slow
def test_a_quiet_log_of_a_car_nobody_described_is_designed_loud_as_the_rules_choose(training_drives):
    """The sixty-second and sixty-third stages (tuning.real.choose_undescribed_quiet): on the KITTI training drives as
    two smooth roads
    (quiet) the car's model of a car nobody described reads 0.6827 deg, the loud design 0.3089; on the quiet simulated
    drives of the four cars the car's model does better (0.2552 against 0.2906), but the objective, real plus
    simulated, falls 0.9381 -> 0.5998 deg (the rule asks 0.02): B ships. A loud log and a car described are read the
    same (the guard)."""
    from roadbank.tuning.real import (QUIET_GYRO_OFFSETS, SIM_CARS, STEEP_ROAD_CUTOFF_HZ, STEEP_ROAD_ORDER,
                                      choose_undescribed_quiet, gyro_sim_sets, simulated_sets, smooth_road_logs,
                                      training_logs)
    from roadbank.vehicle import SensorSpec, log_conditions
    from roadbank.vehicle.conditions import UNDESCRIBED_KEEPS_MODEL, UNDESCRIBED_SMOOTHER_KEEPS_MODEL, is_quiet

    logs, _ = training_drives
    gyro = training_logs(DATA, roll_rate=True)
    steep = smooth_road_logs(logs, STEEP_ROAD_ORDER, STEEP_ROAD_CUTOFF_HZ)
    for s, _, _ in steep:           # the steep smooth road is what it says: quiet
        c = log_conditions(s)
        assert is_quiet(SensorSpec(), c["log_rate"], c["log_ay_noise"], log_ay_floor=c["log_ay_floor"])
    sims = simulated_sets()
    gs = [gyro_sim_sets(o) for o in QUIET_GYRO_OFFSETS]
    pooled = [list(sims[k]) + [d for g in gs for d in g[k]] for k in range(len(sims))]
    kept = [s for s, _, _ in logs + gyro + smooth_road_logs(gyro)
            + smooth_road_logs(gyro, STEEP_ROAD_ORDER, STEEP_ROAD_CUTOFF_HZ)]
    chosen, obj, errs = choose_undescribed_quiet(smooth_road_logs(logs) + steep, pooled, kept,
                                                 list(zip(SIM_CARS, sims)))
    assert chosen is False and UNDESCRIBED_KEEPS_MODEL is False
    assert obj[False] < obj[True] - 0.3
    assert np.median(errs[False][0]) < np.median(errs[True][0]) - 0.3
    # the sixty-third: the map's offline smoother likewise (objective 0.9149 -> 0.4899, real 0.6692 -> 0.2455)
    chosen, obj, errs = choose_undescribed_quiet(smooth_road_logs(logs) + steep, pooled, kept,
                                                 list(zip(SIM_CARS, sims)), name="kinematic-smoother",
                                                 setting="undescribed_smoother_keeps_model")
    assert chosen is False and UNDESCRIBED_SMOOTHER_KEEPS_MODEL is False
    assert obj[False] < obj[True] - 0.3


@pytest.mark.slow
def test_the_sixty_sixth_stage_keeps_the_blends_gate_at_every_speed(training_drives):
    """The sixty-sixth stage's candidates on the training drive 0034 as the plain command reads its ESP channels
    (the stage itself, tuning.real.choose_blend_gate_speed, takes three minutes: its numbers are in
    docs/estimators.md): the gate counted only from 10 m/s leaves the drive's tight turn at 5-14 m/s to the low-pass,
    and the causal blend does worse there (0.624 -> 0.642 deg), unlike the two-way smoother; the seven other drives
    are within 0.001 deg (0018: 0.4134 -> 0.4131, six the same). The shipped default counts the gate at every speed."""
    from roadbank.estimators import with_online_offsets
    from roadbank.estimators.gated import KINEMATIC_PIF_GATE_V_MIN
    from roadbank.tuning.real import design_settings, log_errors, per_log
    from roadbank.vehicle.conditions import BLEND_GATE_V_MIN

    logs, _ = training_drives
    build = per_log("kinematic-pif", described=False)

    def online(s):
        return with_online_offsets(build(s))

    errs = {}
    for v in (0.0, 10.0):
        with design_settings(blend_gate_v_min=v):
            errs[v] = log_errors(online, logs)
    assert errs[0.0][:6] == errs[10.0][:6] and abs(errs[0.0][6] - errs[10.0][6]) < 0.001
    assert errs[10.0][7] > errs[0.0][7] + 0.01
    assert KINEMATIC_PIF_GATE_V_MIN == 0.0 and BLEND_GATE_V_MIN is None

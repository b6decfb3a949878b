"""kinematic-pif: its limits are kinematic-ff and the default PIF, its gate is pif-gated's formula, and
it keeps kinematic-ff's error on real roads while it follows the hard simulated transients."""

from pathlib import Path

import numpy as np
import pytest

from roadbank import Signals
from roadbank import estimators as E
from roadbank.estimators.gated import KINEMATIC_PIF_BANK_RATE, KINEMATIC_PIF_GATE, KINEMATIC_PIF_KAPPA
from roadbank.vehicle import for_log

from test_gated import _gate_reference  # the gate written out in plain Python

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


@pytest.fixture(scope="module")
def lane_change():
    from roadbank.sim.scenarios import run_scenario
    return run_scenario("track-lane-change", "nominal", seed=0)


@pytest.mark.parametrize("rate", ["auto", None])
def test_gate_shut_is_kinematic_ff_and_gate_open_is_the_default_pif(lane_change, rate):
    s = lane_change.signals
    shut = E.make("kinematic-pif", gate_on=1e9, sample_rate=rate).run(s)
    opened = E.make("kinematic-pif", gate_on=-1e9, sample_rate=rate).run(s)
    ff = slow_filter(sample_rate=rate).run(s)
    pif = E.make("pif-modified", sample_rate=rate).run(s)
    for a, b in ((shut, ff), (opened, pif)):
        np.testing.assert_allclose(a.w, b.w, rtol=0, atol=1e-12)
        np.testing.assert_allclose(a.phi_b, b.phi_b, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(a.valid, b.valid)
    np.testing.assert_allclose(shut.states["w_lp"], ff.states["w_lp"], rtol=0, atol=1e-12)
    for k in ("vy", "r", "w"):
        np.testing.assert_allclose(opened.states[k], pif.states[k], rtol=0, atol=1e-12)


def shut_roll():
    """The one roll model of the pair: the PIF's default tuning chose it."""
    return E.make("pif-modified").roll


def slow_filter(**kw):
    """kinematic-ff with the pair's roll model, kappa and the low-pass scheduled on the PIF's noise."""
    pif = E.make("pif-modified")
    return E.make("kinematic-ff", roll=pif.roll, kappa=KINEMATIC_PIF_KAPPA, bank_rate=KINEMATIC_PIF_BANK_RATE,
                  Q_ay=pif.Q_ay, R=pif.R[0, 0], **kw)


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
    builds = {"kinematic-ff": per_log("kinematic-ff"), "shipped": per_log("kinematic-pif")}
    for key in ("gate_on", "gate_span", "gate_release"):
        values = GATE_GRID[key]
        i = values.index(g[key])
        for j in (i - 1, i + 1):
            if 0 <= j < len(values):
                builds[(key, values[j])] = per_log("kinematic-pif", **{key: values[j]})
    chosen, real, sim = choose_by_roads(builds, logs, sims)
    assert chosen == "shipped", (real, sim)
    assert ESTIMATOR == "kinematic-pif"
    # what the gate buys on simulated manoeuvres: the same pair with the gate held shut
    from roadbank.tuning.real import objective
    assert sim["shipped"] < objective(per_log("kinematic-pif", gate_on=1e9), [], sims) - 0.03


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts-extra").is_dir(), reason="../shared/data/kitti-oxts-extra not present")
def test_the_shipped_bank_rate_and_kappa_are_what_the_rule_picks():
    """The first stage of the rule (roadbank.tuning.real.kinematic_pif_candidates): the shipped road
    bank rate and kappa against their grid neighbours, and the fixed low-pass of kinematic-ff's
    constants, which the noise-scheduled one must beat on real training roads and simulated drives."""
    from roadbank.tuning.real import BANK_RATES_DEG, KAPPAS, choose_by_roads, objective, per_log, simulated_sets
    from roadbank.tuning.real import training_logs

    logs, sims = training_logs(DATA), simulated_sets()
    b, k = float(np.degrees(KINEMATIC_PIF_BANK_RATE)), KINEMATIC_PIF_KAPPA
    builds = {"shipped": per_log("kinematic-pif")}
    for grid, key in ((BANK_RATES_DEG, "b"), (KAPPAS, "k")):
        i = grid.index(b if key == "b" else k)
        for j in (i - 1, i + 1):
            if 0 <= j < len(grid):
                bb, kk = (grid[j], k) if key == "b" else (b, grid[j])
                builds[(bb, kk)] = per_log("kinematic-pif", bank_rate=float(np.radians(bb)), kappa=kk)
    chosen, real, sim = choose_by_roads(builds, logs, sims)
    assert chosen == "shipped", (real, sim)
    fixed = per_log("kinematic-pif", cutoff=0.6, kappa=0.2)
    assert real["shipped"] < objective(fixed, logs, []) - 0.02
    assert objective(per_log("kinematic-pif"), [], sims) < objective(fixed, [], sims) - 0.02

"""pif-gated: its limits are the two filters it switches between, its gate is the documented
formula, and what the switch buys on the simulator's truth and on real drives (no weight or gate
setting was chosen on these)."""

from pathlib import Path

import numpy as np
import pytest

from roadbank import Signals
from roadbank import estimators as E
from roadbank.estimators.gated import GATED_TUNING
from roadbank.evaluation.compare import usable_samples
from roadbank.evaluation.metrics import error_metrics

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


@pytest.fixture(scope="module")
def lane_change():
    from roadbank.sim.scenarios import run_scenario
    return run_scenario("bank-lane-change", "nominal", seed=0)


def _fast(**kw):
    return E.make("pif-rate", Q=GATED_TUNING["fast_Q"], Q_rate=GATED_TUNING["fast_Q_rate"],
                  th=GATED_TUNING["fast_th"], **kw)


@pytest.mark.parametrize("rate", ["auto", None])
def test_gate_shut_is_pif_modified_and_gate_open_is_the_fast_filter(lane_change, rate):
    """Both limits, on the fixed-rate path and on the general path: the stacked observer is
    exactly the two filters side by side."""
    s = lane_change.signals
    shut = E.make("pif-gated", gate_on=1e9, sample_rate=rate).run(s)
    slow = E.make("pif-modified", sample_rate=rate).run(s)
    opened = E.make("pif-gated", gate_on=-1e9, sample_rate=rate).run(s)
    fast = _fast(sample_rate=rate).run(s)
    for a, b in ((shut, slow), (opened, fast)):
        np.testing.assert_allclose(a.w, b.w, rtol=0, atol=1e-12)
        np.testing.assert_allclose(a.phi_b, b.phi_b, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(a.valid, b.valid)
    for k in ("vy", "r", "w"):
        np.testing.assert_allclose(shut.states[k], slow.states[k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(opened.states[k + "_fast"], fast.states[k], rtol=0, atol=1e-12)


def _gate_reference(t, vx, r, tf, release, on, span):
    """The gate of the module docstring, written out sample by sample in plain Python."""
    g = np.zeros(len(t))
    rf, gk_prev = r[0], 0.0
    for k in range(1, len(t)):
        dt = t[k] - t[k - 1]
        rf_new = rf + (1 - np.exp(-dt / tf)) * (r[k] - rf)
        gk = min(1.0, max(0.0, (vx[k] * abs(rf_new - rf) / dt - on) / span))
        gk_prev = gk if gk > gk_prev else gk_prev + (1 - np.exp(-dt / release)) * (gk - gk_prev)
        rf = rf_new
        g[k] = gk_prev
    return g


def test_the_output_blends_the_two_filters_by_the_documented_gate():
    """A yaw-rate step, a sine and a steady turn: the blend weight recovered from the three
    runs, (w - w_slow) / (w_fast - w_slow), equals the gate computed independently."""
    n = 1500
    t = np.arange(n) * 0.01
    vx = np.full(n, 25.0)
    r = np.where(t > 3.0, 0.1, 0.0) + 0.05 * np.sin(2 * np.pi * 0.8 * t) * (t > 8.0) * (t < 11.0)
    ay = vx * r
    s = Signals(t, vx, ay, r, np.zeros(n))
    gated = E.make("pif-gated").run(s)
    slow = E.make("pif-modified").run(s)
    fast = _fast().run(s)
    d = fast.w - slow.w
    use = np.abs(d) > 1e-6
    g = _gate_reference(t, vx, r, GATED_TUNING["gate_tf"], GATED_TUNING["gate_release"],
                        GATED_TUNING["gate_on"], GATED_TUNING["gate_span"])
    assert use.sum() > 500 and 0.99 < g.max() and (g == 0).sum() > 300      # the test exercises both ends
    np.testing.assert_allclose(((gated.w - slow.w) / np.where(use, d, 1.0))[use], g[use], atol=1e-8)
    # a steady turn shuts the gate again: the output returns to the slow filter's
    assert abs(gated.w[-1] - slow.w[-1]) < 1e-9


def test_on_the_bank_lane_change_it_meets_the_aims_the_default_pif_misses(lane_change):
    """Bank lane change (14 deg lanes), against the simulator's true bank: the default PIF lags
    the bank change (max about 2 deg); switched to the fast filter while the yaw accelerates, both
    aims are met and the RMS error is no larger than the fast filter's alone."""
    s = lane_change.signals
    out = {}
    for label, est in (("slow", E.make("pif-modified")), ("fast", _fast()), ("gated", E.make("pif-gated"))):
        m = error_metrics(s.t, est.run(s).phi_b, lane_change.truth.phi_b, usable_samples(s, est.v_min), settle=2.0)
        out[label] = (m.rms_deg, m.max_deg)
    assert out["gated"][0] <= 0.5 and out["gated"][1] <= 1.5, out      # measured 0.31 / 1.18
    assert out["slow"][1] > 1.5, out
    assert out["gated"][0] <= out["fast"][0] < out["slow"][0], out   # 0.31, 0.34, 0.56


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts").is_dir(), reason="../shared/data/kitti-oxts not present")
def test_on_kitti_it_keeps_the_default_filters_noise_level():
    """KITTI (validation data): on real roads the gate is mostly shut, so the raw theta RMS against
    the INS roll stays the default PIF's (within 5 %), where the fast filter alone is far noisier."""
    from roadbank.validation.kitti import validate_kitti_drive
    names = ["pif-modified", "pif-gated"]
    for drive in ("2011_09_26_drive_0070", "2011_10_03_drive_0047"):
        v = validate_kitti_drive(DATA / "kitti-oxts" / drive, names=names, sensitivity=False)
        rms = {n: v.scores[n].rms_raw_deg for n in names}
        assert rms["pif-gated"] < 1.05 * rms["pif-modified"], (drive, rms)


def test_a_vehicle_files_pif_modified_table_tunes_the_slow_filter(tmp_path):
    from roadbank.vehicle import load_vehicle
    v = load_vehicle("sedan").with_tuning("pif-modified", {"Q": 4e-4, "th": 1e4})
    est = v.make("pif-gated")
    assert (est.slow.Q, est.slow.th) == (4e-4, 1e4) and est.params == v.params == est.fast.params
    own = v.with_tuning("pif-gated", {"Q": 1e-4, "fast_Q_rate": 1e-3, "gate_on": 3.0})
    own.to_toml(tmp_path / "car.toml")
    est = load_vehicle(tmp_path / "car.toml").make("pif-gated")
    assert (est.slow.Q, est.fast.Q_rate, est.gate_on) == (1e-4, 1e-3, 3.0)
    assert est.slow.th == 1e4              # pif-modified's table still applies under the gated one's keys


def test_bad_gate_settings_are_refused():
    for bad in ({"gate_tf": 0.0}, {"gate_release": -1.0}, {"gate_span": 0.0}, {"gate_on": float("nan")}):
        with pytest.raises(ValueError, match="pif-gated: need gate_tf"):
            E.make("pif-gated", **bad)

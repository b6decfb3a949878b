"""pif-smoother: the backward pass against scipy, its stability, and what it buys on the
simulator's truth and on real drives (validation data nobody tuned for)."""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import solve_continuous_are

from roadbank import Signals, VehicleParams
from roadbank import estimators as E
from roadbank.evaluation.compare import usable_samples
from roadbank.evaluation.metrics import error_metrics

from conftest import linear_plant_run

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


def _noisy_constant_speed_log(vx=20.0, seed=0, jitter=0.0):
    s, _ = linear_plant_run(VehicleParams(), vx=vx, bank_deg=4.0, delta=0.02, t_step=3.0, T=10.0)
    rng = np.random.default_rng(seed)
    n = len(s)
    t = s.t + jitter * rng.uniform(-1.0, 1.0, n) * (np.arange(n) > 0)
    return Signals(t, s.vx, s.ay + 0.03 * rng.normal(size=n), s.r + np.deg2rad(0.1) * rng.normal(size=n),
                   s.delta_f)


@pytest.mark.slow
@pytest.mark.parametrize("jitter", [0.0, 0.002])
def test_backward_pass_matches_scipy_on_the_kalman_smoother_ode(jitter):
    """th = 0 (the Kalman-Bucy filter): the smoothed states equal an independent integration of
    x_s' = A x_s + b ay + W P^-1 (x_s - x_f), x_s(T) = x_f(T), with P from scipy's ARE and
    scipy's ODE solver (the filter's own states x_f as the forcing, inputs linear between samples).
    Uniform 100 Hz samples take the exact step for a frozen speed; jittered ones (+-2 ms) the
    trapezoidal substeps."""
    vx = 20.0
    s = _noisy_constant_speed_log(vx, jitter=jitter)
    sm = E.make("pif-smoother", th=0.0, roll="none")
    est = sm.run(s)
    xf = np.column_stack([s_ for s_ in (E.make("pif-modified", th=0.0, roll="none").run(s).states[k]
                                        for k in ("vy", "r", "w"))])
    A, B, C, _, _, _ = sm.design_model(vx)
    W = sm.process_density(sm.design_model(vx))
    P = solve_continuous_are(A.T, C.T, W, sm.R)
    Mx = W @ np.linalg.inv(P)
    forcing = B[:, 1][None, :] * s.ay[:, None] - xf @ Mx.T      # b ay - W P^-1 x_f at each sample

    def rhs(t, x):   # inputs linear between samples
        k = min(max(int(np.searchsorted(s.t, t)), 1), len(s.t) - 1)
        a = (t - s.t[k - 1]) / (s.t[k] - s.t[k - 1])
        return (A + Mx) @ x + (1.0 - a) * forcing[k - 1] + a * forcing[k]

    # explicit RK: A + W P^-1 has eigenvalues of 13-18 1/s here, not stiff (Radau took 15x as long)
    sol = solve_ivp(rhs, (s.t[-1], s.t[0]), xf[-1], t_eval=s.t[::-1], rtol=1e-10, atol=1e-12,
                    method="RK45", max_step=0.01)
    ref = sol.y[:, ::-1].T
    assert np.max(np.abs(np.rad2deg(est.states["w"] - ref[:, 2]))) < 2e-3
    assert np.max(np.abs(est.states["vy"] - ref[:, 0])) < 1e-3
    # and the smoothing is not negligible here: the filter lags the bank step
    assert np.max(np.abs(np.rad2deg(est.states["w"] - xf[:, 2]))) > 0.2


def test_backward_system_is_stable_in_reversed_time_at_every_grid_speed():
    """A + W P^-1 = -P (A - P Gamma)^T P^-1 for the stabilising solution: S = -(A + W P^-1) is
    Hurwitz (eigenvalues of the filter's game closed loop), for the default tuning's th > 0."""
    sm = E.make("pif-smoother")
    assert sm.th > 0
    for v in sm.vgrid[::20]:
        S, _, _ = sm.smoother_matrices(float(v))
        assert np.max(np.linalg.eigvals(S).real) < 0, v


def test_segments_are_smoothed_separately_and_invalid_samples_held():
    """A gap longer than max_gap splits the log: each part is smoothed as if alone. A short
    dropout (NaN) is stepped over as the forward pass does: its samples are flagged and hold the
    last smoothed output, and the samples around it are smoothed as if it were a longer interval."""
    a, b = _noisy_constant_speed_log(seed=1), _noisy_constant_speed_log(seed=2)
    b = Signals(b.t + a.t[-1] + 5.0, b.vx, b.ay, b.r, b.delta_f)
    both = Signals(*(np.concatenate([getattr(a, k), getattr(b, k)]) for k in ("t", "vx", "ay", "r", "delta_f")))
    est = E.make("pif-smoother")
    whole = est.run(both)
    np.testing.assert_array_equal(whole.w[:len(a)], est.run(a).w)
    np.testing.assert_array_equal(whole.w[len(a):], est.run(b).w)
    ay = a.ay.copy()
    ay[400:403] = np.nan
    e = est.run(Signals(a.t, a.vx, ay, a.r, a.delta_f))
    assert not e.valid[400:403].any() and e.valid[403:].all()
    assert np.all(e.w[400:403] == e.w[399])
    keep = np.ones(len(a), bool)
    keep[400:403] = False
    without = est.run(Signals(*(getattr(a, k)[keep] for k in ("t", "vx", "ay", "r", "delta_f"))))
    np.testing.assert_array_equal(e.w[keep], without.w)


def test_chunks_with_the_next_one_as_lookahead_equal_one_run():
    """A streamed log: each chunk smoothed with (the start of) the next chunk as lookahead gives
    the whole-log result; without it, the end of each chunk is only filtered."""
    from roadbank.sim.scenarios import run_scenario
    s = run_scenario("track-lane-change", seed=0).signals
    whole = E.make("pif-smoother").run(s)
    est = E.make("pif-smoother")
    assert 2.0 < est.lookahead_s < 10.0
    cuts = [0, 700, 1400, 2100, len(s)]      # as streamed: equal chunks, then the rest
    chunks = [s[a:b] for a, b in zip(cuts[:-1], cuts[1:])]
    parts = [est.run(c, reset=(k == 0), lookahead=chunks[k + 1] if k + 1 < len(chunks) else None)
             for k, c in enumerate(chunks)]
    w = np.concatenate([p.w for p in parts])
    assert np.max(np.abs(w - whole.w)) < 1e-10
    np.testing.assert_array_equal(np.concatenate([p.valid for p in parts]), whole.valid)
    # the settled flags too: the pass over the lookahead must not advance their clock
    np.testing.assert_array_equal(np.concatenate([p.settled for p in parts]), whole.settled)
    plain = E.make("pif-smoother")
    alone = np.concatenate([plain.run(c, reset=(k == 0)).w for k, c in enumerate(chunks)])
    assert np.max(np.abs(alone - whole.w)) > 1e-3


@pytest.mark.slow
@pytest.mark.parametrize("rows", ["500", "60"])
def test_roadbank_estimate_streams_the_smoother_as_one_run(tmp_path, rows):
    """`roadbank estimate` on a Parquet log read in 500-row (5 s) or 60-row (0.6 s, far shorter than
    the smoother's lookahead of about 5 s: several chunks are read ahead) chunks gives the
    smoother's whole-log result, and the filter's, both to rounding."""
    import pandas as pd
    from click.testing import CliRunner
    from roadbank.cli import main
    log = tmp_path / "tlc.parquet"
    assert CliRunner().invoke(main, ["simulate", "track-lane-change", "-o", str(log)]).exit_code == 0
    out = {}
    for n in (rows, "1000000"):
        r = CliRunner().invoke(main, ["estimate", str(log), "-e", "pif-modified,pif-smoother", "--chunk-rows", n,
                                      "-o", str(tmp_path / f"out{n}.parquet")])
        assert r.exit_code == 0, r.output
        out[n] = pd.read_parquet(tmp_path / f"out{n}.parquet")
    for col in ("pif-smoother.theta", "pif-modified.theta"):
        assert np.max(np.abs(out[rows][col] - out["1000000"][col])) < 1e-10, col


@pytest.mark.parametrize("scenario,condition", [("bank-lane-change", "nominal"), ("bank-lane-change", "low-mu"),
                                                ("track-lane-change", "nominal")])
def test_smoother_meets_the_accuracy_aims_where_no_causal_estimator_does(scenario, condition):
    """Cells where no estimator of the study meets RMS <= 0.5 and max <= 1.5 deg (docs/results.md):
    the lag of a causal filter behind the abrupt bank changes is the limit, not the information
    in the signals. Against the simulator's true bank."""
    from roadbank.sim.scenarios import run_scenario
    sim = run_scenario(scenario, condition, seed=0)
    s = sim.signals
    out = {}
    for name in ("pif-modified", "pif-smoother"):
        est = E.make(name)
        m = error_metrics(s.t, est.run(s).phi_b, sim.truth.phi_b, usable_samples(s, est.v_min), settle=2.0)
        out[name] = (m.rms_deg, m.max_deg)
    assert out["pif-smoother"][0] <= 0.5 and out["pif-smoother"][1] <= 1.5, out
    assert out["pif-modified"][1] > 1.5, out                 # the filter does not
    assert out["pif-smoother"][0] < 0.6 * out["pif-modified"][0], out


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "kitti-oxts").is_dir(), reason="../shared/data/kitti-oxts not present")
def test_smoother_halves_the_filter_error_on_kitti():
    """KITTI (validation data: no weight chosen from it): raw theta RMS against the INS roll."""
    from roadbank.validation.kitti import validate_kitti_drive
    names = ["kinematic", "pif-modified", "pif-smoother"]
    for drive in ("2011_09_26_drive_0070", "2011_10_03_drive_0047"):
        v = validate_kitti_drive(DATA / "kitti-oxts" / drive, names=names, sensitivity=False)
        rms = {n: v.scores[n].rms_raw_deg for n in names}
        assert rms["pif-smoother"] < 0.75 * rms["pif-modified"] < rms["kinematic"], (drive, rms)
        assert rms["pif-smoother"] < 0.3, (drive, rms)


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "comma2k19-example").is_dir(), reason="../shared/data/comma2k19-example not present")
def test_smoother_on_comma2k19_reaches_the_correlation_target_without_lag():
    from roadbank.validation.comma2k19 import validate_comma2k19
    names = ["kinematic", "pif-modified", "pif-smoother"]
    c = validate_comma2k19(DATA / "comma2k19-example", names=names, sensitivity=False)
    sc = c.scores
    assert sc["pif-smoother"].r >= 0.93 and sc["pif-smoother"].rms_deg <= 0.11
    assert sc["pif-smoother"].r > max(sc["pif-modified"].r, sc["kinematic"].r)
    # no lag (the causal filter: +0.31 s). With the noise read just above the dynamics band (the twenty-first and
    # twenty-second stages) the smoother's correlation peaks early: 0.13 s with one octave, 0.05 s with 3-4.5 Hz (r raw
    # 0.898 -> 0.918, smoothed RMS 0.094 -> 0.093): a lead, bounded here by the raw kinematic estimate's own offset
    # against the phone's roll (+0.12 s)
    assert -0.15 <= sc["pif-smoother"].best_lag_s <= 0.05


def test_the_backward_pass_compiles_once_whole_selected_or_joined():
    """A whole log, one with invalid samples (the valid ones selected) and a chunk with its
    lookahead (joined) reach the compiled backward pass with the same argument types: one
    compilation (each signature costs about a second cold)."""
    from roadbank.estimators import kernels as K
    a, b = _noisy_constant_speed_log(seed=3), _noisy_constant_speed_log(seed=4)
    est = E.make("pif-smoother")
    est.run(a)
    slow = Signals(a.t, np.where(np.arange(len(a)) % 97 == 5, 1.0, a.vx), a.ay, a.r, a.delta_f)  # below v_min
    assert not est.run(slow).valid.all()
    est.run(a, lookahead=Signals(b.t + a.t[-1] + 0.01, b.vx, b.ay, b.r, b.delta_f))
    strided = np.stack([a.ay, a.ay])                                   # a table's column: not contiguous
    est.run(Signals(a.t, a.vx, strided.T[:, 0], a.r, a.delta_f))
    assert len(set(K.smooth_backward.signatures)) == 1, K.smooth_backward.signatures

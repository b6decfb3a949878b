"""The whole-grid designs (estimators.grid_design, are_grid, Ackermann, batched discretisation)
against the per-point designs with scipy's solvers they replace (synthesis.reference_solvers)."""

from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import solve_continuous_are
from scipy.signal import place_poles

from roadbank import estimators as E
from roadbank.estimators import are_grid, base, grid_design
from roadbank.estimators.synthesis import (
    NoStabilisingSolution,
    ackermann_observer,
    reference_solvers,
    using_reference_solvers,
)
from roadbank.vehicle import load_vehicle, log_conditions, make_estimator

CARS = ("suv-paper", "sedan", "compact", "van")
#: measured ay noise (m/s^2) per car: covers the sensor's own (None), a quiet and a noisy log
NOISE = {"suv-paper": None, "sedan": 0.05, "compact": 0.3, "van": 1.0}
KITTI = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts"


@pytest.fixture(autouse=True)
def no_caches(monkeypatch):
    """Every design made here is made (no disk cache, empty memos)."""
    monkeypatch.setenv("ROADBANK_CACHE_DIR", "off")
    monkeypatch.setattr(base, "_DESIGN_CACHE", {})
    monkeypatch.setattr(base, "_DISCRETE_CACHE", {})


def _build(name, car, rate, noise, **kw):
    est = make_estimator(name, load_vehicle(car).params, log_rate=rate, log_ay_noise=noise, **kw)
    if rate is not None:
        est.set_sample_rate(rate)
    return est


def _pair(name, car, rate, noise=None, **kw):
    """The estimator designed on the whole grid, and by the per-point scipy path."""
    fast = _build(name, car, rate, noise, **kw)
    base._DESIGN_CACHE.clear()
    base._DISCRETE_CACHE.clear()
    with reference_solvers():
        assert using_reference_solvers()
        ref = _build(name, car, rate, noise, **kw)
    assert not using_reference_solvers()
    return fast, ref


def _assert_same_tables(fast, ref):
    """Same adapted weights; every table row within 1e-6 of its largest entry, and every column
    (one gain entry over the grid) within 1e-6 of its largest value (entries that are rounding
    noise around zero, below 1e-12 of the table's largest, count as zero)."""
    assert getattr(fast, "th", None) == getattr(ref, "th", None)
    assert fast._nstate == ref._nstate and np.array_equal(fast._extra, ref._extra)
    for a, b in ((fast._tab_cont, ref._tab_cont), (fast._tab, ref._tab)):
        assert a.shape == b.shape
        d = np.abs(a - b)
        assert np.all(d <= 1e-6 * np.abs(b).max(axis=1, keepdims=True))
        assert np.all(d <= np.maximum(1e-6 * np.abs(b).max(axis=0, keepdims=True), 1e-12 * np.abs(b).max()))
    # the tables are not trivially alike: the gains vary over the grid
    assert np.ptp(ref._tab_cont, axis=0).max() > 0


def _slow_but_first(values):
    """``values`` as parameters, all but the first marked ``slow`` (the quick suite keeps one case,
    the full suite runs every one)."""
    return [v if i == 0 else pytest.param(*(v if isinstance(v, tuple) else (v,)), marks=pytest.mark.slow)
            for i, v in enumerate(values)]


@pytest.mark.parametrize("rate", [10.0, 100.0])
@pytest.mark.parametrize("car", _slow_but_first(CARS))
@pytest.mark.parametrize("name", ["pif-modified", "pif-rate", "pif-gated"])
def test_speed_grid_designs_equal_the_scipy_path(name, car, rate):
    fast, ref = _pair(name, car, rate, NOISE[car])
    _assert_same_tables(fast, ref)
    assert fast.fixed_dt == ref.fixed_dt == 1.0 / rate


@pytest.mark.parametrize("car", _slow_but_first(CARS))
@pytest.mark.parametrize("name", ["kalman", "pio-modified", "pif-original"])
def test_other_riccati_and_placed_designs_equal_the_scipy_path(name, car):
    fast, ref = _pair(name, car, 100.0, NOISE[car])
    _assert_same_tables(fast, ref)


@pytest.mark.parametrize("name,car,rate", _slow_but_first([("pif-adaptive", "suv-paper", 100.0),
                                                           ("pif-adaptive", "van", 10.0),
                                                           ("pif-rate-adaptive", "sedan", 100.0),
                                                           ("pif-rate-adaptive", "compact", 10.0)]))
def test_speed_excitation_designs_equal_the_scipy_path(name, car, rate):
    fast, ref = _pair(name, car, rate, NOISE[car])
    _assert_same_tables(fast, ref)


def test_th_halving_and_its_error_are_those_of_the_scipy_path():
    # pif-rate-adaptive's default th is halved for the paper SUV (no solution at high speed)
    fast, ref = _pair("pif-rate-adaptive", "suv-paper", 100.0)
    assert fast.th == ref.th < E.pif.RATE_ADAPTIVE_TUNING["th"]
    # an explicit th is not halved: the same error, naming the same first speed
    msgs = []
    for reference in (False, True):
        base._DESIGN_CACHE.clear()
        with pytest.raises(NoStabilisingSolution) as exc:
            if reference:
                with reference_solvers():
                    E.make("pif-modified", th=50.0, tuning="paper")
            else:
                E.make("pif-modified", th=50.0, tuning="paper")
        msgs.append(str(exc.value))
    assert msgs[0] == msgs[1] and "th=50.0 at vx=" in msgs[0]


def test_points_the_grid_solver_rejects_are_designed_per_point(monkeypatch):
    """With the grid solver rejecting every point the per-point path designs each one: the same
    table as the reference (the fallback is exercised, not only reachable)."""
    real = are_grid.solve_grid

    def reject_odd(*a, **k):
        P, ok = real(*a, **k)
        ok[1::2] = False
        return P, ok
    monkeypatch.setattr(grid_design, "solve_grid", reject_odd)
    fast, ref = _pair("pif-modified", "sedan", 100.0, 0.1)
    _assert_same_tables(fast, ref)


def _scipy_game_are(A, C, Lw, W, R, th):
    if th == 0:
        return solve_continuous_are(A.T, C.T, W, R)
    b = np.hstack([C.T, Lw.T])
    r = np.zeros((b.shape[1], b.shape[1]))
    r[:R.shape[0], :R.shape[0]] = R
    r[-1, -1] = -1.0 / th
    return solve_continuous_are(A.T, b, W, r)


@pytest.mark.parametrize("smooth", [True, False])
def test_grid_solver_against_scipy_on_indefinite_and_kalman_problems(smooth):
    """A family smooth along the grid (as over speed) is solved everywhere; unrelated problems
    side by side (poor starts) may be rejected, but what is accepted is scipy's solution."""
    rng = np.random.default_rng(1)
    g, n = 40, 4
    if smooth:
        s = np.linspace(0.0, 1.0, g)[:, None, None]
        A = rng.normal(size=(n, n)) - 2.0 * np.eye(n) + s * rng.normal(size=(n, n))
        C = rng.normal(size=(2, n)) + s * rng.normal(size=(2, n))
    else:
        A = rng.normal(size=(g, n, n)) - 0.5 * np.eye(n)
        C = rng.normal(size=(g, 2, n))
    Lw = np.zeros((g, 1, n))
    Lw[:, 0, -1] = 1.0
    W = np.eye(n) * 0.3 + 0.1
    R = np.diag([0.2, 0.5])
    Gam0 = np.swapaxes(C, 1, 2) @ np.linalg.inv(R) @ C
    for th in (0.0, 0.05):
        Gam = Gam0 - th * np.swapaxes(Lw, 1, 2) @ Lw
        P, ok = are_grid.solve_grid(A, Gam0, Gam, np.broadcast_to(W, (g, n, n)).copy())
        assert ok.all() if smooth else ok.sum() >= g // 4
        for k in np.flatnonzero(ok):
            X = _scipy_game_are(A[k], C[k], Lw[k], W, R, th)
            assert np.abs(P[k] - X).max() <= 1e-9 * np.abs(X).max()


def test_grid_solver_rejects_a_problem_without_stabilising_solution():
    # unobservable unstable mode: no stabilising solution at all
    A = np.array([[[1.0, 0.0], [0.0, -1.0]]] * 3)
    Gam = np.array([[[0.0, 0.0], [0.0, 1.0]]] * 3)
    _, ok = are_grid.solve_grid(A, Gam, Gam, np.broadcast_to(np.eye(2), (3, 2, 2)).copy())
    assert not ok.any()


@pytest.mark.parametrize("vx", [5.0, 20.0, 60.0, 100.0])
def test_ackermann_gain_against_place_poles(vx):
    A, _, C, *_ = base.augmented_design_model(load_vehicle("van").params, vx, "modified")
    for poles in ((-2.0, -4.0, -6.0), (-1.0, -3.0 + 2.0j, -3.0 - 2.0j)):
        K = ackermann_observer(A, C, poles)
        ref = place_poles(A.T, C.T, np.asarray(poles)).gain_matrix.T
        assert np.abs(K - ref).max() <= 1e-9 * np.abs(ref).max()
        assert np.allclose(np.sort_complex(np.linalg.eigvals(A - K @ C)), np.sort_complex(poles))
    assert ackermann_observer(A, C, (-1.0, -2.0 + 1.0j, -3.0)) is None        # not conjugate-closed


def _theta_pair(name, signals, car="suv-paper"):
    cond = log_conditions(signals)
    fast, ref = _pair(name, car, cond["log_rate"], cond["log_ay_noise"])
    return fast.run(signals).theta, ref.run(signals).theta


@pytest.mark.parametrize("scenario,condition", _slow_but_first([("s-curve", "nominal"), ("bank-lane-change", "low-mu"),
                                                                 ("track-lane-change", "cf50")]))
def test_bank_estimates_equal_on_the_paper_scenarios(scenario, condition):
    from roadbank.sim import run_scenario
    s = run_scenario(scenario, condition).signals
    for name in ("pif-modified", "pif-gated", "pif-adaptive"):
        a, b = _theta_pair(name, s)
        assert np.nanmax(np.abs(a - b)) < np.deg2rad(0.01)
        assert np.nanmax(np.abs(b)) > np.deg2rad(0.5)              # a bank was estimated


@pytest.mark.slow
@pytest.mark.skipif(not any(KITTI.glob("*/oxts")), reason=f"KITTI oxts drives absent at {KITTI}")
def test_bank_estimates_equal_on_the_shared_kitti_drives():
    from roadbank.io.kitti import find_oxts_dirs, load_kitti_oxts
    drives = find_oxts_dirs(KITTI)
    assert drives
    for oxts in drives:
        s = load_kitti_oxts(oxts).signals
        for name in ("pif-modified", "pif-rate", "pif-gated"):
            a, b = _theta_pair(name, s)
            assert np.nanmax(np.abs(a - b)) < np.deg2rad(0.01)


def test_design_bench_section_measures_every_causal_estimator_both_ways():
    """The benchmark's design section (no timing asserted: benchmarks are not tests)."""
    from roadbank.bench import SECTIONS
    from roadbank.bench.design import design_markdown, design_speed
    assert "design" in [s.name for s in SECTIONS]
    out = design_speed({"size": "tiny"})
    assert {r["name"] for r in out["rows"]} == set(E.NAMES) - set(E.OFFLINE)     # every causal one
    for r in out["rows"]:
        for key in ("cold", "new_noise", "cached", "scipy"):
            assert r[f"{key}_ms"] > 0 and r[f"{key}_cpu_ms"] >= 0
        assert r["scipy_over_cold"] == pytest.approx(r["scipy_ms"] / r["cold_ms"])
    text = "\n".join(design_markdown(out))
    assert "`pif-adaptive`" in text and "scipy / cold" in text
    assert not using_reference_solvers()


def test_the_smoother_and_riccati_solution_take_the_grid_solutions(monkeypatch):
    """riccati_solution at a grid speed is the solution the whole-grid design used (the smoother's
    backward table asks for every speed): no scipy solve, and the same numbers as scipy's."""
    from roadbank.estimators import grid_design, smoother, synthesis
    monkeypatch.setattr(smoother, "_TABLES", {})
    monkeypatch.setattr(grid_design, "_SOLUTIONS", {})
    fast = E.make("pif-smoother")
    calls = []
    real = synthesis.solve_continuous_are
    monkeypatch.setattr(synthesis, "solve_continuous_are", lambda *a, **k: calls.append(1) or real(*a, **k))
    P = fast.riccati_solution(30.0)                   # on the grid: recalled
    assert calls == []
    A, _, C, _, Lw, _ = fast.design_model(30.0)
    X = _scipy_game_are(A, C, Lw, fast.process_density(fast.design_model(30.0)), fast.R, fast.th)
    assert np.abs(P - X).max() <= 1e-9 * np.abs(X).max()
    fast.riccati_solution(30.1)                       # between grid speeds: solved
    assert calls == [1]
    base._DESIGN_CACHE.clear()
    smoother._TABLES.clear()
    with reference_solvers():
        ref = E.make("pif-smoother")
    d = np.abs(fast._smooth_tab - ref._smooth_tab)
    assert np.all(d <= 1e-9 * np.abs(ref._smooth_tab).max(axis=1, keepdims=True))

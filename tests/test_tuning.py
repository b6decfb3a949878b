"""roadbank tune: drive sets, objective, optimiser, CLI, and the PIF's default and paper tunings."""

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank import VehicleParams
from roadbank import estimators as E
from roadbank.cli import main
from roadbank.estimators.pif import R_ESP, R_TABLE4_DEG_UNITS, TABLE4, yaw_rate_noise_density
from roadbank.tuning import (INFEASIBLE, TRAIN_ROADS, VALIDATION_ROADS, Objective, drive_set, register_drives,
                             score_set, search_space, tune_estimator)
from roadbank.tuning import pipeline
from roadbank.tuning.optimise import SEARCH_V_STEP

P = VehicleParams()


@pytest.fixture(scope="module")
def sets():
    train = drive_set("train", 4, seed=3)
    valid = drive_set("validation", 4, seed=3)
    register_drives("test-train", train)
    return train, valid


def test_train_and_validation_sets_are_disjoint(sets):
    train, valid = sets
    assert not set(TRAIN_ROADS) & set(VALIDATION_ROADS)
    assert {d.road for d in train} == set(TRAIN_ROADS) and {d.road for d in valid} == set(VALIDATION_ROADS)
    # validation cars change what training cars never do
    held_out = {"tyre_Cy", "tyre_Ey", "iz_scale", "kroll_scale"}
    assert all(held_out <= set(d.car) for d in valid) and not any(held_out & set(d.car) for d in train)
    # independent random streams: no drive of one set equals a drive of the other
    for a in train:
        for b in valid:
            assert a.car["cf_scale"] != b.car["cf_scale"]
    # deterministic for a seed
    again = drive_set("train", 2, seed=3)
    assert all(np.array_equal(a.signals.ay, b.signals.ay) for a, b in zip(again, train))


def test_drives_have_the_bank_they_were_drawn_with(sets):
    train, _ = sets
    bank_step = next(d for d in train if d.road == "bank-step")
    assert np.degrees(np.abs(bank_step.phi_b).max()) > 2.0           # a banked lane of 4-25 %
    curve = next(d for d in train if d.road == "superelevated-curve")
    assert 1.0 < np.degrees(np.abs(curve.phi_b).max()) < 6.0          # 2-10 % superelevation


@pytest.mark.slow
def test_tuning_from_table4_improves_training_and_validation_scores(sets):
    train, valid = sets
    space = search_space("pif-modified")
    # Table 4 in the search space's coordinates (Q/R and th R are what the filter depends on)
    x_table4 = [np.log10(TABLE4["Q"] / TABLE4["R"]), np.log10(TABLE4["th"] * TABLE4["R"])]
    res = tune_estimator(space, P, "test-train", budget=12, seed=1, x0=x_table4)
    assert res.train.objective < res.start_objective - 0.05
    tuned = score_set(E.make("pif-modified", P, **res.options), valid)
    table4 = score_set(E.make("pif-modified", P, tuning="paper"), valid)
    assert tuned.objective < table4.objective and tuned.median_rms < table4.median_rms
    # deterministic for a seed
    again = tune_estimator(space, P, "test-train", budget=12, seed=1, x0=x_table4)
    assert again.options == res.options


def test_infeasible_weights_score_as_infeasible(sets):
    space = search_space("pif-modified")
    objective = Objective(space, P, "test-train")
    with pytest.raises(E.NoStabilisingSolution):
        E.make("pif-modified", P, **space.options([3.0, -1.0]))
    assert objective([3.0, -1.0]) == INFEASIBLE
    assert objective([3.0, -3.0]) < 5.0


def test_fixing_R_loses_nothing_the_filter_depends_on_Q_over_R_and_th_R():
    a = E.make("pif-modified", tuning="paper")
    k = 1e-4
    b = E.make("pif-modified", Q=k * TABLE4["Q"], R=k * TABLE4["R"], th=TABLE4["th"] / k, S=1.0,
               Q_ay=0.0)                                       # Table 4 has no ay input noise
    for vx in (6.0, 22.0, 60.0):
        assert np.allclose(a.observer(vx)[0], b.observer(vx)[0], rtol=1e-6, atol=1e-9)


def test_default_R_is_the_yaw_rate_sensor_noise_plus_quantisation_density():
    res, noise, rate = np.radians(0.3), np.radians(0.1), 100.0
    # quantisation error of a busy signal is uniform on a step: variance res^2 / 12 (measured)
    x = np.random.default_rng(0).normal(0.0, 1.0, 200_000)
    q_var = np.var(res * np.round(x / res) - x)
    assert q_var == pytest.approx(res**2 / 12, rel=0.02)
    assert yaw_rate_noise_density(noise, res, rate) == pytest.approx((noise**2 + q_var) / rate, rel=0.02)
    assert R_ESP == pytest.approx((noise**2 + res**2 / 12) / rate, rel=1e-12)
    assert E.make("pif-modified").R[0, 0] == R_ESP
    with pytest.raises(ValueError):
        yaw_rate_noise_density(0.0, 0.0, 100.0)


def test_paper_tunings_are_table4():
    est = E.make("pif-modified", tuning="paper")
    assert (est.Q, est.R[0, 0], est.S, est.th) == (0.1, 0.0035, 1.0, 1.0)
    assert np.array_equal(np.diag(est.P0), [0.0, 0.0, 0.5])
    assert E.make("pif-modified", tuning="paper-deg").R[0, 0] == pytest.approx(0.0035 * (np.pi / 180) ** 2)
    assert R_TABLE4_DEG_UNITS == pytest.approx(0.0035 * (np.pi / 180) ** 2)
    assert E.make("pif-original").Q == 0.1 and E.make("pif-original").th == 1.0    # published as is
    with pytest.raises(ValueError, match="tuning must be one of"):
        E.make("pif-modified", tuning="fast")


@pytest.mark.slow
def test_tune_cli_writes_a_vehicle_file_that_reproduces_its_scores(tmp_path, monkeypatch):
    from roadbank.vehicle import load_vehicle
    calls = []
    real = pipeline.drive_set
    monkeypatch.setattr(pipeline, "drive_set", lambda kind, *a, **k: calls.append(kind) or real(kind, *a, **k))
    real_tune = pipeline.tune_estimator
    monkeypatch.setattr(pipeline, "tune_estimator", lambda *a, **k: calls.append("tune") or real_tune(*a, **k))
    out = tmp_path / "car.toml"
    r = CliRunner().invoke(main, ["tune", "-o", str(out), "--budget", "6", "--train-drives", "4",
                                  "--validation-drives", "4", "--estimators", "pif-modified,dfc", "--jobs", "1"])
    assert r.exit_code == 0, r.output
    assert calls == ["train", "tune", "tune", "validation"]        # validation drawn after all tuning
    car = load_vehicle(out)
    assert set(car.tuning) >= {"pif-modified", "dfc"} and "pif-modified (tuned)" in r.output
    valid = drive_set("validation", 4, 0, car.params, car.to_plant(), car.sensors.to_sim())
    for name in ("pif-modified", "dfc"):
        s = score_set(car.make(name), valid)
        assert s.median_rms == pytest.approx(car.scores[name]["validation_median_rms_deg"], rel=1e-9)
    assert car.scores["pif-modified"]["validation_objective_deg"] < \
        car.scores["pif-modified"]["table4_validation_objective_deg"]
    # the PIF's table is relative to the car's sensor: no R (reproduced above at the sensor's
    # rate); at a 10 Hz log R is the sensor's at 10 Hz and th is lowered where it must be
    table = car.tuning["pif-modified"]
    assert "R" not in table and {"Q", "th"} <= set(table)
    at10 = car.make("pif-modified", log_rate=10.0)
    assert at10.R[0, 0] == pytest.approx(car.sensors.r_noise_density(10.0), rel=1e-12)
    assert at10.Q == table["Q"] and 0.0 <= at10.th <= table["th"]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["pif-modified", "pif-rate"])
def test_a_given_th_with_the_sensor_R_is_halved_until_solvable_like_the_default(name):
    """A tuned th that has no stabilising solution with the sensor's R at a 10 Hz log (R ten
    times the 100 Hz density) is halved until it has one, as the default's own th is; an
    explicit R keeps an explicit th strict."""
    from roadbank.estimators.pif import DEFAULT_TUNING, RATE_TUNING, with_sensor_noise
    from roadbank.estimators.synthesis import NoStabilisingSolution
    th = (DEFAULT_TUNING if name == "pif-modified" else RATE_TUNING)["th"]
    with pytest.raises(NoStabilisingSolution):
        E.make(name, P, R=10 * R_ESP, th=th)
    est = E.make(name, P, **with_sensor_noise(name, {"th": th}, 10 * R_ESP))
    assert 0.0 < est.th < th and est.R[0, 0] == 10 * R_ESP
    assert any(th / est.th == 2.0**k for k in range(1, 11))         # halvings of the given th
    E.make(name, P, R=10 * R_ESP, th=est.th)                       # the result is solvable as given
    assert E.make(name, P, **with_sensor_noise(name, {"th": th}, R_ESP)).th == th   # solvable: unchanged


def test_tune_cli_rejects_untunable_estimators(tmp_path):
    r = CliRunner().invoke(main, ["tune", "-o", str(tmp_path / "x.toml"), "--estimators", "uio"])
    assert r.exit_code == 2 and "cannot tune uio" in r.output
    r = CliRunner().invoke(main, ["tune", "-o", str(tmp_path / "x.toml"), "--estimators", "pif-smoother"])
    assert r.exit_code == 2 and "pif-smoother runs pif-modified with that one's weights" in r.output


def test_default_th_adapts_to_the_car_explicit_th_raises(monkeypatch):
    from roadbank.estimators import pif
    monkeypatch.setitem(pif.TUNINGS, "default", dict(pif.TUNINGS["default"], th=1e9))
    est = E.make("pif-modified")
    assert 0 <= est.th < 1e9
    with pytest.raises(E.NoStabilisingSolution):
        E.make("pif-modified", th=1e9)
    # the shipped cars all get the default th itself
    from roadbank.vehicle import builtin_names, load_vehicle
    monkeypatch.undo()
    for name in builtin_names():
        assert E.make("pif-modified", load_vehicle(name).params).th == pif.DEFAULT_TUNING["th"]


@pytest.mark.slow
def test_tune_on_dask_gives_the_local_result(tmp_path):
    distributed = pytest.importorskip("distributed")
    import logging
    import tomllib
    args = ["tune", "--budget", "6", "--train-drives", "4", "--validation-drives", "4", "--estimators", "dfc"]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=logging.ERROR) as cluster:
        r = CliRunner().invoke(main, args + ["-o", str(tmp_path / "d.toml"), "--scheduler", cluster.scheduler_address])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, args + ["-o", str(tmp_path / "l.toml"), "--jobs", "1"])
    assert r.exit_code == 0, r.output
    dask_run, local_run = (tomllib.loads((tmp_path / f).read_text()) for f in ("d.toml", "l.toml"))
    assert dask_run["tuning"] == local_run["tuning"]
    key = "validation_median_rms_deg"
    assert dask_run["scores"]["dfc"][key] == local_run["scores"]["dfc"][key]


@pytest.mark.slow
def test_a_cars_default_pif_takes_R_from_its_yaw_rate_sensor():
    from roadbank.vehicle import load_vehicle
    car = load_vehicle("sedan")
    assert car.make("pif-modified").R[0, 0] == pytest.approx(R_ESP, rel=1e-12)     # ESP sensors
    noisy = car.with_sensors(r_noise=np.radians(0.5), rate=50.0)
    expected = (np.radians(0.5) ** 2 + car.sensors.r_resolution ** 2 / 12) / 50.0
    assert noisy.make("pif-modified").R[0, 0] == pytest.approx(expected, rel=1e-12)
    assert noisy.make("pif-modified", tuning="paper").R[0, 0] == 0.0035            # Table 4 untouched
    assert noisy.make("pif-modified", R=1e-6).R[0, 0] == 1e-6


def _ramp_bank_run(params, k_w, vx=22.2, T=40.0, fs=100.0):
    """Original bicycle model (scipy lsim, written out here) on a bank whose w = sin(bank) grows
    at ``k_w`` 1/s from 0.05, straight-ahead steering; returns Signals and the true w(t)."""
    from scipy.signal import StateSpace, lsim
    from roadbank import Signals
    m, Iz, Lf, Lr, Cf, Cr, g = params.m, params.Iz, params.Lf, params.Lr, params.Cf, params.Cr, params.g
    A = np.array([[-(Cf + Cr) / (m * vx), -vx - (Lf * Cf - Lr * Cr) / (m * vx)],
                  [-(Lf * Cf - Lr * Cr) / (Iz * vx), -(Lf**2 * Cf + Lr**2 * Cr) / (Iz * vx)]])
    B = np.array([[-g], [0.0]])
    C = np.array([[-(Cf + Cr) / (m * vx), -(Lf * Cf - Lr * Cr) / (m * vx)], [0.0, 1.0]])
    t = np.arange(0.0, T, 1.0 / fs)
    w = 0.05 + k_w * t
    x0 = -np.linalg.solve(A, B[:, 0] * w[0])
    _, y, _ = lsim(StateSpace(A, B, C, np.zeros((2, 1))), w, t, X0=x0)
    return Signals(t, np.full_like(t, vx), y[:, 0], y[:, 1], np.zeros_like(t)), w


@pytest.mark.parametrize("name", ["pif-rate", "pif-rate-adaptive"])
def test_pif_rate_follows_a_bank_ramp_without_lag_pif_modified_lags(name):
    """The bank-rate state makes the filter type 2: zero steady error on a constant bank *rate*;
    the paper's random-walk model (type 1) keeps a constant lag."""
    signals, w = _ramp_bank_run(P, k_w=0.004)          # 0.23 deg/s, a superelevation transition
    err_rate = E.make(name).run(signals).w[-500:] - w[-500:]
    err_mod = E.make("pif-modified").run(signals).w[-500:] - w[-500:]
    assert np.abs(err_mod).min() > 2e-4                       # constant lag (> 0.01 deg)
    assert np.abs(err_rate).max() < 0.02 * np.abs(err_mod).min()


@pytest.mark.parametrize("fc,fr", [(1.0, 1.0), (1.3, 0.7), (0.7, 1.3)])
def test_pif_rate_has_zero_steady_state_error_on_a_constant_bank(fc, fr):
    from conftest import linear_plant_run
    signals, w = linear_plant_run(P.replace(Cf=fc * P.Cf, Cr=fr * P.Cr))
    est_w = E.make("pif-rate").run(signals).w
    assert np.abs(est_w[-200:] - w).max() < 1e-4


@pytest.mark.parametrize("name", ["pif-modified", "pif-rate", "pif-adaptive", "pif-rate-adaptive", "pif-gated"])
def test_search_space_starts_at_the_estimators_default(name):
    """The optimiser's start maps back to the default options (so a tuning that finds nothing
    better keeps the default), and every coordinate moves its own option."""
    from roadbank.tuning import search_space
    space = search_space(name)
    x0 = space.start()
    default, started = E.make(name, P, v_max=30.0), E.make(name, P, v_max=30.0, **space.options(x0))
    for key in ("Q", "th", "Q_rate", "mu", "tau", "fast_Q_rate", "gate_on", "gate_span"):
        if hasattr(default, key):
            assert getattr(started, key) == pytest.approx(getattr(default, key), rel=1e-9), key
    for i in range(len(x0)):
        x = x0.copy()
        x[i] += 0.1
        moved = {k for k, v in space.options(x).items() if v != space.options(x0)[k]}
        assert len(moved) == 1, (space.labels[i], moved)


COUPE = """[vehicle]
m = "1550 kg"
Iz = "2600 kg m^2"
Lf = "1.45 m"
Lr = "1.25 m"
Cf = "95 kN/rad"
Cr = "160 kN/rad"
steering_ratio = 13
h_cg = "0.48 m"
h_roll = "0.38 m"
"""


def test_drives_on_which_the_car_lost_control_are_left_out_and_said(sets, tmp_path):
    """A sporty car (1.3 deg/g) whose track lane change spins: simulate warns (it had exited 0 without a word at 13 deg
    of sideslip), and tuning leaves such drives out of both sets and says how many (they had driven the objective:
    5-15 deg RMS drives among 0.5 deg ones)."""
    import dataclasses

    train, _ = sets
    assert all(d.max_sideslip_deg < 5.0 and not d.lost_control for d in train)      # a sane car's drives
    spun = dataclasses.replace(train[0], max_sideslip_deg=13.0)
    out = pipeline.TuningOutcome()
    assert pipeline._in_control([spun, *train[1:]], "train", out) == train[1:]
    assert out.left_out == {"train": 1}
    with pytest.raises(ValueError, match="lost control"):
        pipeline._in_control([spun], "validation", out)
    car = tmp_path / "coupe.toml"
    car.write_text(COUPE)
    res = CliRunner().invoke(main, ["simulate", "track-lane-change", "--vehicle", str(car), "-o",
                                    str(tmp_path / "c.parquet")])
    assert res.exit_code == 0 and "lost control" in res.output, res.output
    res = CliRunner().invoke(main, ["simulate", "track-lane-change", "-o", str(tmp_path / "suv.parquet")])
    assert res.exit_code == 0 and "lost control" not in res.output


@pytest.mark.parametrize("name", ["dfc", "pif-modified", "pif-rate"])
@pytest.mark.parametrize("budget", [5, 7, 24])
def test_the_objective_is_called_at_most_budget_times(sets, monkeypatch, name, budget):
    """The start point is one of the budget's evaluations (it was evaluated on its own and again in the
    first population: budget + 1 calls, and budgets below a population were overrun)."""
    calls = []
    real = Objective.__call__
    monkeypatch.setattr(Objective, "__call__", lambda self, x: calls.append(np.array(x)) or real(self, x))
    space = search_space(name)
    res = tune_estimator(space, P, "test-train", budget=budget, seed=2)
    assert 0 < len(calls) <= budget and res.evaluations == len(calls)
    assert sum(np.allclose(x, space.start(), rtol=1e-9, atol=1e-12) for x in calls) == 1   # the start, once
    searched = Objective(space, P, "test-train", (("v_step", SEARCH_V_STEP),))
    assert res.start_objective == pytest.approx(searched(space.start()))


def test_a_budget_below_the_smallest_population_is_refused(sets):
    with pytest.raises(ValueError, match="budget must be >= 5"):
        tune_estimator(search_space("dfc"), P, "test-train", budget=4)

"""``roadbank validate sim``: the simulated validation set with the car known and not described."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.tuning import drive_set
from roadbank.tuning.objective import drive_errors
from roadbank.tuning.real import SIM_CARS
from roadbank.tuning.manoeuvres import PERTURBATIONS, VALIDATION_CAR_CHANGES
from roadbank.tuning.simulated import ERROR_SOURCES, MODES, error_sources, score_simulated, summarise, to_json
from roadbank.vehicle import for_log, load_vehicle

NAMES = ("kinematic-pif", "pif-modified")
N = 3


@pytest.fixture(scope="module")
def scores():
    return score_simulated(NAMES, n=N)


@pytest.fixture(scope="module")
def sources():
    return error_sources(n=N)


@pytest.fixture(scope="module")
def van_drives():
    v = load_vehicle("van")
    return v, drive_set("validation", N, 0, v.params)


def _built(name, signals, **car):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return for_log(name, signals, **car)


def test_per_drive_errors_are_the_direct_computation(scores, van_drives):
    v, drives = van_drives
    assert scores.roads["van"] == tuple(d.road for d in drives)
    for name in NAMES:
        known = [drive_errors(_built(name, d.signals, vehicle=v), [d])[0][0] for d in drives]
        undescribed = [drive_errors(_built(name, d.signals), [d])[0][0] for d in drives]
        assert np.array_equal(scores.errors[(name, "known", "van")], known)
        assert np.array_equal(scores.errors[(name, "undescribed", "van")], undescribed)


def test_known_and_undescribed_build_different_estimators_for_the_van(scores, van_drives):
    v, drives = van_drives
    s = drives[0].signals
    known = _built("pif-modified", s, vehicle=v).run(s).phi_b
    undescribed = _built("pif-modified", s).run(s).phi_b
    assert np.degrees(np.nanmax(np.abs(known - undescribed))) > 0.05
    assert not np.array_equal(scores.errors[("pif-modified", "known", "van")],
                              scores.errors[("pif-modified", "undescribed", "van")])


def test_summaries_are_numpy_over_the_stored_errors(scores):
    for name in NAMES:
        for mode in MODES:
            for car in SIM_CARS:
                e = scores.errors[(name, mode, car)]
                assert e.shape == (N,) and np.all(np.isfinite(e))
                s = scores.summary(name, mode, car)
                assert (s.median_deg, s.p95_deg, s.n) == (np.median(e), np.percentile(e, 95), N)
            every = np.concatenate([scores.errors[(name, mode, car)] for car in SIM_CARS])
            pooled = scores.summary(name, mode)
            assert (pooled.median_deg, pooled.p95_deg, pooled.n) == (np.median(every), np.percentile(every, 95),
                                                                      N * len(SIM_CARS))
            roads = np.array([r for car in SIM_CARS for r in scores.roads[car]])
            for road in set(roads):
                assert scores.family_median(name, mode, road) == np.median(every[roads == road])


def test_the_target_verdict():
    assert summarise([0.1, 0.2, 0.3]).meets_target
    assert summarise([0.1, 0.2, 0.6]).p95_deg == pytest.approx(0.56)       # linear: 0.2 + 0.9 * 0.4
    assert summarise([0.1, 0.2, 0.6]).meets_target
    assert not summarise([0.1, 0.2, 0.8]).meets_target                      # p95 0.74
    assert not summarise([0.31, 0.31, 0.31]).meets_target


def test_cli_json_has_the_numbers_of_the_function(scores, sources):
    res = CliRunner().invoke(main, ["validate", "sim", "-e", ",".join(NAMES), "-n", str(N), "--json"])
    assert res.exit_code == 0, res.output
    got = json.loads(res.stdout)
    assert got == json.loads(json.dumps(to_json(scores, sources)))
    assert set(got["error_sources"]) == set(ERROR_SOURCES)
    pif = got["estimators"]["pif-modified"]
    assert pif["known"]["cars"]["van"]["median_deg"] == scores.summary("pif-modified", "known", "van").median_deg
    assert pif["undescribed"]["all"]["p95_deg"] == scores.summary("pif-modified", "undescribed").p95_deg
    assert got["default"] == "kinematic-pif" and not pif["offline"]


def test_a_held_perturbation_is_drawn_then_set_to_the_data_sheet(van_drives):
    """nominal=...: the same drives (road, friction, every other draw, the noise) with the named perturbations at
    the design value."""
    v, drives = van_drives
    held = drive_set("validation", N, 0, v.params, nominal=("roll-stiffness", "misalignment"))
    for d, h in zip(drives, held):
        assert h.road == d.road and h.car["kroll_scale"] == 1.0 and h.car["misalign_deg"] == 0.0
        assert {k: x for k, x in h.car.items() if k not in ("kroll_scale", "misalign_deg")} == \
            {k: x for k, x in d.car.items() if k not in ("kroll_scale", "misalign_deg")}
        assert d.car["kroll_scale"] != 1.0 and np.array_equal(h.signals.t, d.signals.t)
    every = drive_set("validation", 1, 0, v.params, nominal=tuple(PERTURBATIONS))[0].car
    assert "tyre_Cy" not in every and all(every[k] == 1.0 for k in ("cf_scale", "cr_scale", "mass_scale",
                                                                       "iz_scale", "kroll_scale"))
    assert set(VALIDATION_CAR_CHANGES) <= set(PERTURBATIONS)
    with pytest.raises(ValueError, match="unknown perturbation"):
        drive_set("validation", 1, 0, v.params, nominal=("tyre-pressure",))


def test_error_sources_score_the_held_sets(sources):
    """Each group's summary is the default, car known, on the set with that group held, scored as the set is."""
    from roadbank.tuning.real import per_log
    assert set(sources) == set(ERROR_SOURCES)
    label = "the roll stiffness"
    errs = []
    for car in SIM_CARS:
        v = load_vehicle(car)
        errs += [drive_errors(per_log("kinematic-pif", vehicle=v)(d.signals), [d])[0][0]
                 for d in drive_set("validation", N, 0, v.params, nominal=ERROR_SOURCES[label])]
    assert sources[label] == summarise(errs) and sources[label].n == N * len(SIM_CARS)


def test_cli_writes_the_document(scores, tmp_path):
    out = tmp_path / "sim.md"
    res = CliRunner().invoke(main, ["validate", "sim", "-e", ",".join(NAMES), "-n", str(N), "-o", str(out)])
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert text.startswith("# Simulated validation")
    assert f"_Generated by `roadbank validate sim -e {','.join(NAMES)} -n {N} -o {out}`" in text
    assert "| estimator | car | car known | car not described |" in text
    for name, label in (("kinematic-pif", "kinematic-pif (default)"), ("pif-modified", "pif-modified")):
        for car in (*SIM_CARS, None):
            k, u = (scores.summary(name, mode, car) for mode in MODES)
            row = (f"| {label} | {car or 'all cars'} | {k.median_deg:.3f} / {k.p95_deg:.3f} | "
                   f"{u.median_deg:.3f} / {u.p95_deg:.3f} |")
            assert row in text, row
    same = all(np.array_equal(scores.errors[(n, "known", "sedan")], scores.errors[(n, "undescribed", "sedan")])
               for n in NAMES)
    assert ("the two modes give the same error on every drive" in text) == same
    pooled = scores.summary("kinematic-pif", "known")
    verdict = "met" if pooled.median_deg <= 0.30 and pooled.p95_deg <= 0.65 else "not met"
    assert f"| all cars | {pooled.median_deg:.3f} | {pooled.p95_deg:.3f} | {verdict} |" in text
    assert "## Where the error comes from" in text and "| the roll stiffness |" in text
    res = CliRunner().invoke(main, ["validate", "sim", "-e", "pif-modified", "-n", "1", "--no-sources"])
    assert res.exit_code == 0 and "Where the error comes from" not in res.stdout


def test_cli_marks_an_offline_estimator():
    res = CliRunner().invoke(main, ["validate", "sim", "-e", "pif-smoother", "-n", "1"])
    assert res.exit_code == 0, res.output
    assert "| pif-smoother (offline) | van |" in res.stdout
    assert "`kinematic-pif` was not among the estimators scored." in res.stdout


def test_cli_unknown_estimator_is_a_one_line_error():
    res = CliRunner().invoke(main, ["validate", "sim", "-e", "kinematic-pif,no-such-filter", "-n", "1"])
    assert res.exit_code not in (0, None)
    assert isinstance(res.exception, SystemExit)
    assert "Traceback" not in res.output
    errors = [ln for ln in res.stderr.splitlines() if ln.startswith("Error")]
    assert len(errors) == 1 and "--estimators" in errors[0] and "no-such-filter" in errors[0], res.stderr


def test_the_set_the_target_was_stated_on_is_roadbank_tunes_validation_set():
    """The default set's SUV row is ``roadbank tune``'s validation set (its 40 drives, seed 0), on which the
    target was first stated; the document gives its verdict, from the same numbers as its table."""
    from roadbank.tuning.pipeline import DEFAULT_VALIDATION
    from roadbank.tuning.simulated import TARGET_CAR, TARGET_DRIVES
    from roadbank.tuning.simulated_report import markdown
    assert TARGET_DRIVES == DEFAULT_VALIDATION == 40 and TARGET_CAR in SIM_CARS
    one = score_simulated(["kinematic-pif"], cars=(TARGET_CAR,), n=TARGET_DRIVES)
    own = drive_set("validation", DEFAULT_VALIDATION, 0, load_vehicle(TARGET_CAR).params)
    assert one.roads[TARGET_CAR] == tuple(d.road for d in own)
    s = one.summary("kinematic-pif", "known", TARGET_CAR)
    verdict = "yes" if s.median_deg <= 0.30 and s.p95_deg <= 0.65 else "**no**"
    line = (f"| simulated validation set, {TARGET_CAR} ({TARGET_DRIVES} drives, where it was stated) | car known: "
            f"median <= 0.30, p95 <= 0.65 deg | {s.median_deg:.3f} / {s.p95_deg:.3f} deg | {verdict} |")
    assert line in markdown(one, command="x")
    assert "where it was stated" not in markdown(score_simulated(["kinematic-pif"], cars=(TARGET_CAR,), n=2),
                                                 command="x")


@pytest.mark.slow
def test_the_default_meets_the_car_known_target_on_the_set_it_was_stated_on():
    """Issue 23's target, car known: median <= 0.30 and p95 <= 0.65 deg on ``roadbank tune``'s validation set of
    the paper's SUV (40 drives, seed 0), against the simulator's true bank (measured 0.299 / 0.624)."""
    from roadbank.tuning.simulated import TARGET_CAR, TARGET_DRIVES
    s = score_simulated(["kinematic-pif"], cars=(TARGET_CAR,), n=TARGET_DRIVES).summary("kinematic-pif", "known")
    assert s.n == 40 and s.median_deg <= 0.30 and s.p95_deg <= 0.65, s


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "target not met on the four shipped cars pooled (40 drives each): 0.312 / 0.722 deg; the sedan 0.338 / 0.805 "
    "and the compact 0.338 / 0.697 miss it (docs/sim-validation.md)"))
def test_the_default_meets_the_car_known_target_on_every_car():
    s = score_simulated(["kinematic-pif"], n=40).summary("kinematic-pif", "known")
    assert s.median_deg <= 0.30 and s.p95_deg <= 0.65, s

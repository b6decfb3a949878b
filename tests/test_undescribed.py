"""A log whose car is not described is designed for the shipped car that fits it (roadbank.vehicle.design_car).

Truth: the simulator's plant car (each drive is simulated with one shipped car's data, perturbed), its true
bank, the analytic gain of a Butterworth band-pass at its centre, and the real KITTI drives (a car that is
none of the shipped ones, on loud 10 Hz logs, where the default is the car-free low-pass).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank import Signals
from roadbank.cli import main
from roadbank.tuning import drive_set
from roadbank.tuning.objective import drive_errors
from roadbank.sim.scenarios import run_scenario
from roadbank.vehicle import (CAR_MARGIN, UNDESCRIBED_CARS, bank_band_power, design_car, design_span, for_log,
                              load_vehicle, log_conditions, undescribed_params)

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


@pytest.fixture(scope="module")
def suv_drives():
    return drive_set("train", 8, 0, load_vehicle("suv-paper").params)


def test_the_candidates_and_the_static_car():
    from roadbank import defaults

    assert UNDESCRIBED_CARS == ("suv-paper", "sedan", "compact", "van") and defaults.VEHICLE in UNDESCRIBED_CARS
    assert undescribed_params() == load_vehicle(defaults.VEHICLE).params
    assert CAR_MARGIN == 1.25


def test_the_misfit_is_the_power_in_the_band():
    """A sine at the band's geometric centre passes the band-pass with gain 0.991 (the analytic gain of the
    two second-order Butterworth edges run forward and backward there); a constant and a 20 Hz sine pass
    nothing; invalid samples do not count."""
    from types import SimpleNamespace

    t = np.arange(0.0, 60.0, 0.01)
    s = Signals(t, np.full(t.size, 20.0), np.zeros(t.size), np.zeros(t.size), np.zeros(t.size))
    f0 = math.sqrt(0.2 * 3.0)

    def est(w, valid=None):
        return SimpleNamespace(w=w, valid=np.ones(t.size, bool) if valid is None else valid)

    a = 0.01
    g0 = (f0 / 0.2) ** 4 / (1 + (f0 / 0.2) ** 4) / (1 + (f0 / 3.0) ** 4)
    assert bank_band_power(s, est(a * np.sin(2 * np.pi * f0 * t))) == pytest.approx(g0 ** 2 * a * a / 2, rel=0.01)
    assert bank_band_power(s, est(np.full(t.size, 0.05))) < 1e-10
    assert bank_band_power(s, est(a * np.sin(2 * np.pi * 20.0 * t))) < 1e-3 * a * a / 2     # G(20 Hz) = 5e-4
    assert bank_band_power(s, est(np.zeros(t.size), np.zeros(t.size, bool))) == math.inf


def test_the_paper_suv_is_recognised_and_its_drives_gain(suv_drives):
    """On simulated drives of the paper's SUV (heavy, stiff tyres: the outlier of the four), the rule picks
    it on most drives, and the default designed that way has a fraction of the static sedan's error."""
    picks = [design_car(d.signals) for d in suv_drives]
    assert picks.count("suv-paper") >= 5, picks
    chosen = [drive_errors(for_log("kinematic-pif", d.signals), [d])[0][0] for d in suv_drives]
    static = [drive_errors(for_log("kinematic-pif", d.signals, undescribed_params()), [d])[0][0] for d in suv_drives]
    assert np.median(chosen) < 0.6 * np.median(static), (chosen, static)


def test_a_sedan_keeps_the_static_car():
    picks = [design_car(d.signals) for d in drive_set("train", 6, 0, load_vehicle("sedan").params)]
    assert picks == ["sedan"] * 6, picks


@pytest.mark.skipif(not (DATA / "kitti-oxts").is_dir(), reason="../shared/data/kitti-oxts is not here")
def test_a_loud_real_log_keeps_the_static_car():
    """On a 10 Hz KITTI drive read without its roll rate (what the fit runs on) the default is the low-pass nearly
    throughout: the misfits of the four cars are within the margin (measured: within 0.1 %) and the static car
    stays; so skipping the fit where the default reads the roll rate loses nothing on these drives."""
    import dataclasses

    from roadbank.io.kitti import load_kitti_oxts

    for drive in ("2011_09_26_drive_0070", "2011_10_03_drive_0047"):
        s = load_kitti_oxts(DATA / "kitti-oxts" / drive).signals
        span = s[:design_span(s)]
        power = {car: bank_band_power(span, for_log("kinematic-pif", dataclasses.replace(span, p=None),
                                                    params=load_vehicle(car).params).run(span))
                 for car in UNDESCRIBED_CARS}
        assert all(abs(p / power["sedan"] - 1.0) < 0.05 for p in power.values()), (drive, power)   # margin: 25 %
        assert design_car(dataclasses.replace(s, p=None)) == "sedan", drive
        assert design_car(s) == "sedan", drive


def test_estimate_designs_each_log_for_its_car_as_for_log_does(tmp_path, suv_drives):
    """The command line (the streamed fleet path) and the library choose the same car for a log."""
    d = next(d for d in suv_drives if design_car(d.signals) == "suv-paper")
    s = d.signals
    log = tmp_path / "suv.parquet"
    pq.write_table(pa.table({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "delta_f": s.delta_f}), log)
    out = tmp_path / "out.parquet"
    res = CliRunner().invoke(main, ["estimate", str(log), "-o", str(out), "--no-online-offsets"])
    assert res.exit_code == 0, res.output
    cli = pq.read_table(out).to_pandas()
    lib = for_log("kinematic-pif", s).run(s)
    np.testing.assert_allclose(cli["kinematic-pif.theta"].to_numpy(), lib.theta, rtol=0, atol=1e-12)
    static = for_log("kinematic-pif", s, undescribed_params()).run(s)
    assert np.max(np.abs(lib.theta - static.theta)) > 1e-3          # not the static car's design


def test_estimate_says_what_each_log_was_designed_for(tmp_path, suv_drives):
    """The summary (text, --json, summary.csv) names the car (fitted to the log, or the vehicle file) and
    whether the log is quiet; truth: the simulator's plant car and its data-sheet sensors (quiet), a KITTI
    drive (loud, with the INS's roll rate), and a log that cannot be read (no design)."""
    import csv
    import json

    d = next(d for d in suv_drives if design_car(d.signals) == "suv-paper")
    s = d.signals
    log = tmp_path / "suv.parquet"
    pq.write_table(pa.table({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "delta_f": s.delta_f}), log)
    bad = tmp_path / "bad.csv"
    bad.write_text("t,vx\n0,1\n")
    res = CliRunner().invoke(main, ["estimate", str(log), str(bad), "-o", str(tmp_path / "out"), "--json"])
    logs = {Path(r["log"]).name: r for r in json.loads(res.stdout)["logs"]}
    design = logs["suv.parquet"]["design"]
    assert design["car"] == "suv-paper" and design["car_from"] == "fitted to the log" and design["quiet"] is True
    assert 0 < design["ay_floor"] <= design["ay_noise"] * 1.2
    assert 0.8 < design["ay_floor_ratio"] < 1.2                 # the simulator's data-sheet accelerometer
    assert logs["bad.csv"]["design"] == {}
    rows = {Path(r["log"]).name: r for r in csv.DictReader(open(tmp_path / "out" / "summary.csv"))}
    assert "car=suv-paper" in rows["suv.parquet"]["design"] and "quiet=True" in rows["suv.parquet"]["design"]
    text = CliRunner().invoke(main, ["estimate", str(log), "-o", str(tmp_path / "o.csv"), "--vehicle", "van"])
    assert "designed for suv.parquet: van (vehicle file)" in text.stderr
    assert "quiet, so kinematic-pif is pif-adaptive" in text.stderr
    kitti = DATA / "kitti-oxts" / "2011_09_26_drive_0070"
    if kitti.is_dir():
        text = CliRunner().invoke(main, ["estimate", str(kitti), "-o", str(tmp_path / "k.csv")])
        assert "sedan (not fitted: the default reads the roll rate)" in text.stderr
        assert ("loud, so kinematic-pif is kinematic-gyro (the log has a roll rate, free of offset (an INS's); "
                "corrected for the grade by its ax and pitch rate)" in text.stderr)


@pytest.mark.slow
def test_the_shipped_margin_is_what_the_rule_picks():
    """The eighth stage (kinematic_pif_candidates(8)): the real training drives tie (every one keeps the
    static car), the simulated drives of cars not described decide; it gains over the static car."""
    from roadbank.tuning.real import choose_by_roads, kinematic_pif_candidates, simulated_sets, training_logs

    if not (DATA / "kitti-oxts-extra").is_dir():
        pytest.skip("../shared/data/kitti-oxts-extra not present")
    chosen, real, sim = choose_by_roads(kinematic_pif_candidates(8), training_logs(DATA), simulated_sets())
    assert chosen == CAR_MARGIN, (real, sim)
    assert real[CAR_MARGIN] == pytest.approx(real[math.inf], abs=1e-9)
    assert sim[CAR_MARGIN] < sim[math.inf] - 0.03


def test_the_design_line_says_what_was_not_measured_and_what_the_design_took(tmp_path):
    """A log too short for its noise to be measured is designed for the data sheet's noise (the low-pass's cut-off is
    then the data sheet's, the same as with no log at all), and the line says so instead of 'nan'; a log whose noise
    is measured but whose floor is not says the ratio is the noise's."""
    from roadbank.fleet.process import design_words
    from roadbank.vehicle import log_conditions, make_estimator, undescribed_params

    t = np.arange(0.0, 6.0, 0.1)
    rng = np.random.default_rng(0)
    s = Signals(t, np.full(t.size, 15.0), 0.2 * rng.standard_normal(t.size), np.zeros(t.size), np.zeros(t.size))
    cond = log_conditions(s)
    assert np.isnan(cond["log_ay_noise"]) and np.isnan(cond["log_ay_floor"])
    sheet = make_estimator("kinematic-pif", undescribed_params(), log_rate=10.0)    # no log: the data sheet
    assert for_log("kinematic-pif", s).Q_ay == pytest.approx(sheet.Q_ay)
    log = tmp_path / "short.parquet"
    pq.write_table(pa.table({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r}), log)
    res = CliRunner().invoke(main, ["estimate", str(log), "-o", str(tmp_path / "o.csv")])
    assert res.exit_code == 0, res.output
    line = next(x for x in res.stderr.splitlines() if x.startswith("designed for short.parquet"))
    assert "nan" not in line and "not measured" in line and "the data sheet's noise" in line, line
    base = {"car": "sedan", "car_from": "fitted to the log", "quiet": False}
    words = design_words({**base, "ay_noise": 0.21, "ay_floor": math.nan, "ay_floor_ratio": 40.0}, "kinematic-pif")
    assert "nan" not in words, words
    assert "0.21 m/s^2 (40 x the data sheet's noise density; its floor not measured" in words, words
    words = design_words({**base, "ay_noise": 0.1, "ay_floor": 0.085, "ay_floor_ratio": 6.6}, "kinematic-pif")
    assert words == ("sedan (fitted to the log); ay noise 0.1 m/s^2, floor 0.085 (6.6 x the data sheet's noise "
                     "density): loud, so kinematic-pif is the low-pass blend")


def test_the_design_span_of_the_design_span_is_itself():
    """design_car takes the caller's log conditions, measured on the whole start of the log; they are
    those of its design span because the span of the span is the span (on logs with a standstill, a
    drive cut by the time limit, and a short one)."""
    drive = run_scenario("s-curve", "nominal", seed=0).signals
    t = np.arange(0.0, 700.0, 0.05)

    def log(vx):
        return Signals(t, vx, 0.1 * np.sin(t), 0.01 * np.cos(t), np.zeros_like(t))
    parked_first = log(np.where(t < 30.0, 0.0, np.where(t < 150.0, 4.0, 12.0)))     # cut after 60 s of driving
    crawling = log(np.where(t % 100.0 < 5.0, 6.0, 4.0))              # 35 s of driving: cut by the time limit
    for s, cut in ((drive, False), (drive[:300], False), (parked_first, True), (crawling, True)):
        n = design_span(s)
        assert (n < len(s)) == cut
        assert design_span(s[:n]) == n
        np.testing.assert_equal(log_conditions(s[:n]), log_conditions(s))      # NaN where not measured
        assert design_car(s, cond=log_conditions(s)) == design_car(s)


def test_a_gap_counts_as_neither_driving_nor_time_of_the_log():
    """A stray first time stamp a day before the log (a logger's clock not yet set) made the first interval 'a
    day of driving': the noise was then read on that one sample and the design fell back to the data sheet. A gap
    longer than MAX_GAP_S counts as no time, so the span and the conditions are those of the log without the
    stray sample; a dropout of 5 s while driving is no driving (the span ends 5 s later)."""
    from roadbank.constants import MAX_GAP_S

    s = run_scenario("s-curve", "nominal", seed=0).signals
    stray = Signals(np.concatenate(([s.t[0] - 86400.0], s.t)), *(np.concatenate(([x[0]], x))
                                                                  for x in (s.vx, s.ay, s.r, s.delta_f)))
    assert design_span(stray) == design_span(s) + 1
    np.testing.assert_equal(log_conditions(stray), log_conditions(s))
    t = np.arange(0.0, 120.0, 0.01)
    drive = Signals(t, np.full_like(t, 15.0), 0.1 * np.sin(t), 0.01 * np.cos(t), np.zeros_like(t))
    assert 5.0 > MAX_GAP_S and abs(t[design_span(drive) - 1] - 60.0) < 0.02
    dropped = Signals(np.where(t > 30.0, t + 5.0, t), drive.vx, drive.ay, drive.r, drive.delta_f)
    assert abs(dropped.t[design_span(dropped) - 1] - 65.0) < 0.03       # 60 s of driving and the gap
    parked = Signals(t * 10.0, np.full_like(t, 1.0), drive.ay, drive.r, drive.delta_f)    # 0.1 s steps: time
    assert parked.t[design_span(parked) - 1] == pytest.approx(600.0, abs=0.1)             # limit, as before

"""Online sensor offsets (``estimators.with_online_offsets``).

Truth: simulated drives whose sensors carry known offsets (the simulator's sensor model adds
them), the plant's bank; and the KITTI drives, whose calibrated INS yaw rate has next to no
offset.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from roadbank import Signals
from roadbank import estimators as E
from roadbank.estimators.offsets import OffsetSettings
from roadbank.evaluation import error_metrics
from roadbank.sim import SCENARIOS, Driver, Scenario, SensorConfig, flat_road, run
from roadbank.sim.standstill import with_standstill

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
BIAS = math.radians(0.5)                   # yaw-rate offset, rad/s
STILL = 3.0                                # s of standstill before the drives
#: straight-driving evidence turned on (off by default: the fifty-second stage)
STRAIGHT = OffsetSettings(straight_ay=0.3)


def _sensors(r_bias=BIAS, swa_bias=0.0):
    s = SensorConfig()
    return s.replace(yaw_rate=dataclasses.replace(s.yaw_rate, bias=r_bias),
                     steering=dataclasses.replace(s.steering, bias=swa_bias))


def _bank_rms(est, sim, settle):
    e = est.run(sim.signals)
    return error_metrics(sim.signals.t, e.phi_b, sim.truth.phi_b, e.valid, settle=settle).rms_deg, e


#: a turn of 11 s, then 28 s straight: flat road, 20 m/s, open-loop steering wheel
TURN_THEN_STRAIGHT = Scenario(
    "turn-then-straight", flat_road(),
    Driver(speed=20.0, steering=((0.0, 1.0, 3.0, 10.0, 12.0, 40.0), np.radians([0, 0, 60, 60, 0, 0]))), 40.0)


@pytest.mark.parametrize("name", ["const-bank", "track-lane1"])
def test_a_standstill_teaches_the_yaw_rate_offset_and_removes_its_bank_error(name):
    sc = SCENARIOS[name]
    sim = with_standstill(run(sc, sensors=_sensors(), seed=3), sc, STILL)
    k = int(STILL * 100)                                     # first sample of the drive
    plain = _bank_rms(E.make("pif-modified"), sim, STILL + 2.0)[0]
    learnt, e = _bank_rms(E.with_online_offsets(E.make("pif-modified")), sim, STILL + 2.0)
    st = e.states
    assert not st["r_offset_learnt"][:100].any()           # within the settle time: not yet
    assert st["r_offset_learnt"][k - 1] == 1.0 and st["r_offset_learnt"][-1] == 1.0
    # quantised (0.3 deg/s), noisy (0.1 deg/s) samples over 2 s of standstill
    assert abs(math.degrees(st["r_offset"][k] - BIAS)) < 0.03, math.degrees(st["r_offset"][k])
    assert learnt < 0.3 * plain, (learnt, plain)            # measured 0.24 / 1.39, 0.15 / 2.09 deg


def test_without_a_standstill_the_flag_waits_for_straight_driving():
    sim = run(TURN_THEN_STRAIGHT, sensors=_sensors(), seed=5)
    assert not E.with_online_offsets(E.make("pif-modified")).run(sim.signals).states["r_offset_learnt"].any()
    est = E.with_online_offsets(E.make("pif-modified"), settings=STRAIGHT)   # (off by default)
    e = est.run(sim.signals)
    t, flag = sim.signals.t, e.states["r_offset_learnt"]
    s = est.settings
    assert not flag[t < 12.0 + s.straight_settle + s.min_straight].any()   # the turn teaches nothing
    assert flag[-1] == 1.0
    first = t[np.flatnonzero(flag)[0]]
    assert first < 12.0 + s.straight_settle + s.min_straight + 3.0, first  # once the wheel is straight
    assert abs(math.degrees(e.states["r_offset"][-1] - BIAS)) < 0.05
    assert not e.states["delta_offset_learnt"].any()       # not without a standstill (see the module)


def test_after_a_standstill_straight_driving_teaches_the_steering_offset():
    swa_bias = math.radians(3.0)
    sim = with_standstill(run(TURN_THEN_STRAIGHT, sensors=_sensors(swa_bias=swa_bias), seed=6),
                          TURN_THEN_STRAIGHT, STILL)
    est = E.with_online_offsets(E.make("pif-modified"), settings=STRAIGHT)
    e = est.run(sim.signals)
    truth = swa_bias / est.params.steering_ratio             # road-wheel angle, rad
    assert e.states["delta_offset_learnt"][-1] == 1.0
    assert not e.states["delta_offset_learnt"][sim.signals.t < STILL + 12.0 + 10.0].any()
    assert abs(math.degrees(e.states["delta_offset"][-1] - truth)) < 0.02, (
        math.degrees(e.states["delta_offset"][-1]), math.degrees(truth))
    assert abs(math.degrees(e.states["r_offset"][-1] - BIAS)) < 0.03
    assert est.offsets["delta_f_learnt"] and est.offsets["delta_f"] == e.states["delta_offset"][-1]


def test_run_and_step_give_identical_numbers_and_chunks_equal_one_run():
    sc = SCENARIOS["bank-lane-change"]
    sim = with_standstill(run(sc, sensors=_sensors(swa_bias=math.radians(2.0)), seed=2), sc, STILL)
    s = sim.signals
    for name in ("pif-modified", "kinematic", "pif-gated"):
        est = E.with_online_offsets(E.make(name))
        e = est.run(s)
        est.reset()
        steps = [est.step(*x) for x in zip(s.t, s.vx, s.ay, s.r, s.delta_f)]
        np.testing.assert_array_equal(e.phi_b, [x.phi_b for x in steps])
        np.testing.assert_array_equal(e.theta, [x.theta for x in steps])
        np.testing.assert_array_equal(e.valid, [x.valid for x in steps])
        assert est.offsets["r"] == e.states["r_offset"][-1] and est.offsets["r_learnt"]
        half = len(s) // 2
        a, b = est.run(s[:half]), est.run(s[half:], reset=False)
        np.testing.assert_array_equal(np.r_[a.phi_b, b.phi_b], e.phi_b)
        np.testing.assert_array_equal(np.r_[a.states["r_offset"], b.states["r_offset"]], e.states["r_offset"])


def test_the_inputs_are_corrected_by_the_learnt_offsets_and_ay_only_by_a_given_one():
    n = 600
    t = np.arange(n) * 0.01
    r = np.full(n, 0.01)
    s = Signals(t, np.zeros(n), np.full(n, 0.3), r, np.full(n, 0.002))
    est = E.with_online_offsets(E.make("kinematic"), settings=OffsetSettings(ay_offset=0.1))
    fixed, out = est.correct(s)
    np.testing.assert_array_equal(fixed.ay, s.ay - 0.1)          # never learnt: a standstill reads bank
    np.testing.assert_allclose(fixed.r[-1], 0.0, atol=1e-15)    # standing: r is all offset
    assert fixed.r[50] == r[50]                                   # nothing learnt within the settle time
    np.testing.assert_array_equal(fixed.delta_f, s.delta_f)     # the steering waits for straight driving
    missing = Signals(t[:3], np.zeros(3), np.full(3, np.nan), np.full(3, np.nan), np.full(3, np.nan))
    assert np.isnan(est.correct(missing)[0].r).all()            # NaN stays NaN


def test_bad_settings_are_refused():
    for bad in ({"tau_stop": 0.0}, {"v_stop": -1.0}, {"min_straight": math.nan}):
        with pytest.raises(ValueError, match="OffsetSettings"):
            OffsetSettings(**bad)
    with pytest.raises(ValueError, match="already"):
        E.with_online_offsets(E.with_online_offsets(E.make("kinematic")))


KITTI = sorted(p for d in ("kitti-oxts", "kitti-oxts-extra") for p in (DATA / d).glob("2011_*"))


@pytest.mark.slow
@pytest.mark.skipif(not KITTI, reason="../shared/data/kitti-oxts* not present")
def test_on_the_kitti_drives_the_learnt_yaw_offset_is_small_and_the_bank_no_worse():
    """The INS is calibrated: where a drive stands still long enough to learn, the learnt yaw
    offset is below 0.02 deg/s (measured <= 0.007), and theta against the INS roll is no worse."""
    from roadbank.io.kitti import load_kitti_oxts
    from roadbank.validation import SEDAN

    learnt = 0
    for path in KITTI:
        log = load_kitti_oxts(path)
        s, ref = log.signals, log.reference_roll
        plain = E.make("pif-modified", SEDAN).run(s)
        e = E.with_online_offsets(E.make("pif-modified", SEDAN)).run(s)
        if e.states["r_offset_learnt"].any():
            learnt += 1
            assert abs(math.degrees(e.states["r_offset"][-1])) < 0.02, path.name
        m = (s.vx > 5.0) & (s.t > s.t[0] + 5.0) & plain.valid & e.valid
        rms = [math.degrees(float(np.sqrt(np.mean((x.theta[m] - ref[m]) ** 2)))) for x in (plain, e)]
        assert rms[1] <= rms[0] * 1.01 + 1e-3, (path.name, rms)
    assert learnt >= 3                                        # 0009, 0018, 0047 stand still


_C_HARNESS = """
#include <stddef.h>
#include "{p}.h"
void h_run(long n, const double *t, const double *vx, const double *ay, const double *r, const double *d,
           double *out);
void h_run(long n, const double *t, const double *vx, const double *ay, const double *r, const double *d,
           double *out)
{{
    {p}_state s;
    {p}_offsets o;
    {p}_output e;
    {p}_offsets_output q;
    long k;
    {p}_init(&s);
    {p}_offsets_init(&o);
    for (k = 0; k < n; ++k) {{
        int ok = {p}_step_learning(&s, &o, t[k], ({p}_real)vx[k], ({p}_real)ay[k], ({p}_real)r[k],
                                   ({p}_real)d[k], &e, &q);
        out[8 * k] = (double)e.phi_b;
        out[8 * k + 1] = (double)e.theta;
        out[8 * k + 2] = (double)ok;
        out[8 * k + 3] = (double)q.r_offset;
        out[8 * k + 4] = (double)q.delta_offset;
        out[8 * k + 5] = (double)q.r_learnt;
        out[8 * k + 6] = (double)q.delta_learnt;
        out[8 * k + 7] = (double)q.r;
    }}
}}
"""


def _hard_offsets_log():
    """A standstill, the turn, the straight (both offsets learnt), then the same drive again after a
    2.5 s gap without a standstill, with NaN samples, a repeated and a backward time stamp."""
    a = with_standstill(run(TURN_THEN_STRAIGHT, sensors=_sensors(swa_bias=math.radians(3.0)), seed=6),
                        TURN_THEN_STRAIGHT, STILL).signals
    b = run(TURN_THEN_STRAIGHT, sensors=_sensors(), seed=7).signals
    cols = [np.r_[getattr(a, c), getattr(b, c)] for c in ("t", "vx", "ay", "r", "delta_f")]
    n = len(a)
    cols[0][n:] += a.t[-1] + 2.5
    cols[3][n + 100:n + 105] = np.nan
    cols[4][n + 200] = np.inf
    cols[1][n + 300] = np.nan
    cols[0][n + 400] = cols[0][n + 399]
    cols[0][n + 500] = cols[0][n + 450]
    return cols


FILE_OFFSETS = {"r": 0.004, "ay": 0.03, "delta_f": -0.002}      # a vehicle file's identified ones (SI)


@pytest.mark.parametrize("float32", [False, True])
@pytest.mark.parametrize("name", ["pif-modified", "kinematic-pif"])
@pytest.mark.parametrize("filed", [False, True])
def test_the_c_export_learns_the_offsets_as_step_does(tmp_path, float32, name, filed):
    """The module's learner equals step()'s; for kinematic-pif with its low-pass following a running noise
    estimate (a reference a quarter of the log's, so that it moves), the two together. With a vehicle file's
    identified offsets (``filed``) the module takes the measured channels and removes them first, as
    ``roadbank estimate --vehicle`` does before the learner (the export had left them out: 1.29 deg apart)."""
    import ctypes

    from roadbank.export import export_c
    from roadbank.export.build import compile_c
    from roadbank.signals import diff_noise_std

    if name == "kinematic-pif":
        t, vx, ay, r, _ = _hard_offsets_log()
        ref = 0.25 * diff_noise_std(ay - vx * r) ** 2
        est = E.with_online_offsets(E.make(name, Q_ay=1e-3, noise_ref=ref, noise_tau=5.0), settings=STRAIGHT)
        assert est.inner.noise_tau == 5.0
    else:
        est = E.with_online_offsets(E.make(name), settings=STRAIGHT)
    res = export_c(est, tmp_path, rate=100.0, float32=float32, offsets=FILE_OFFSETS if filed else None)
    p = res.source.stem
    assert f"{p}_step_learning" in res.header.read_text() and "Online sensor offsets" in res.readme.read_text()
    harness = tmp_path / "h.c"
    harness.write_text(_C_HARNESS.format(p=p))
    lib = ctypes.CDLL(str(compile_c([res.source, harness], tmp_path / "libh.so", shared=True, flags=("-O2",),
                                    include=[tmp_path])))
    cols = [np.ascontiguousarray(c, dtype=float) for c in _hard_offsets_log()]
    n = len(cols[0])
    out = np.zeros((n, 8))
    ptr = ctypes.POINTER(ctypes.c_double)
    lib.h_run(ctypes.c_long(n), *(c.ctypes.data_as(ptr) for c in cols), out.ctypes.data_as(ptr))
    est.reset()
    py = []
    off = FILE_OFFSETS if filed else {}
    seen = [cols[0], cols[1], cols[2] - off.get("ay", 0.0), cols[3] - off.get("r", 0.0),
            cols[4] - off.get("delta_f", 0.0)]
    for x in zip(*seen):
        s = est.step(*x)
        o = est.offsets
        py.append((s.phi_b, s.theta, s.valid, o["r"], o["delta_f"], o["r_learnt"], o["delta_f_learnt"]))
    py = np.array(py, dtype=float)
    assert py[:, 5].any() and py[:, 6].any() and not py[:, 5].all()     # both learnt, the yaw rate after a while
    if float32:
        ok = py[:, 2] == 1
        np.testing.assert_allclose(out[ok, 0], py[ok, 0], atol=np.deg2rad(0.01))
        # float32 sums over a stop: measured 0.0009 deg/s and 0.0018 deg of bank
        np.testing.assert_allclose(out[:, 3], py[:, 3], atol=np.deg2rad(0.005))
        return
    np.testing.assert_array_equal(out[:, 2], py[:, 2])
    np.testing.assert_array_equal(out[:, 5:7], py[:, 5:7])
    np.testing.assert_allclose(out[:, 0:2], py[:, 0:2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(out[:, 3:5], py[:, 3:5], rtol=0, atol=1e-12)   # measured: equal


def test_cli_export_with_online_offsets(tmp_path):
    from click.testing import CliRunner

    from roadbank.cli import main

    res = CliRunner().invoke(main, ["export", "c", "-e", "kinematic", "--online-offsets", "-o", str(tmp_path)])
    assert res.exit_code == 0, res.output
    assert "roadbank_kinematic_step_learning" in (tmp_path / "roadbank_kinematic.h").read_text()
    res = CliRunner().invoke(main, ["export", "c", "-e", "kinematic", "-o", str(tmp_path / "plain")])
    assert "_offsets_" not in (tmp_path / "plain" / "roadbank_kinematic.h").read_text()      # no learner


def test_roadbank_estimate_learns_the_offset_by_default(tmp_path):
    import pandas as pd
    from click.testing import CliRunner

    from roadbank.defaults import ESTIMATOR

    from roadbank.cli import main
    from roadbank.io.writers import write_table

    sc = SCENARIOS["const-bank"]
    sim = with_standstill(run(sc, sensors=_sensors(), seed=3), sc, STILL)
    sg = sim.signals
    log = tmp_path / "drive.parquet"
    write_table(log, {"t": sg.t, "vx": sg.vx, "ay": sg.ay, "r": sg.r, "delta_f": sg.delta_f}, {})
    rms = {}
    for label, extra in (("default", []), ("off", ["--no-online-offsets"])):
        out = tmp_path / f"{label}.csv"
        res = CliRunner().invoke(main, ["estimate", str(log), "-o", str(out), *extra])
        assert res.exit_code == 0, res.output
        got = pd.read_csv(out)
        keep = ((got["t"] > STILL + 2.0) & got[f"{ESTIMATOR}.valid"].astype(bool)).to_numpy()
        rms[label] = math.degrees(float(np.sqrt(np.mean((got[f"{ESTIMATOR}.phi_b"].to_numpy()[keep]
                                                         - sim.truth.phi_b[keep]) ** 2))))
    # 0.5 deg/s at 20 m/s reads as 1 deg of bank until it is learnt at the standstill
    assert rms["default"] < 0.5 * rms["off"], rms


@pytest.mark.parametrize("crown, bias_dps", [(0.025, 0.0), (-0.02, 0.0), (0.02, 0.3)])
def test_a_crowned_road_teaches_no_yaw_rate_offset(crown, bias_dps):
    """On straights with a cross slope (a road's crown) the car steers into the slope without yawing: the learner's
    straight-driving relation has its understeer term on the measured ay (`delta_f = L r / vx + K_us a_y`), so the
    steer is not read as a yaw-rate offset (the flat-road relation learnt -0.34 / +0.26 deg/s on these crowns, taking
    about 1 deg off the whole drive's bank, and 0.03 of a true 0.3 deg/s); what is left, about 0.1 deg/s, is the
    linear model's error against the simulator's tyres. The simulator's mixed drive, the sedan's plant and data sheet,
    no standstill."""
    from roadbank.sim import drives
    from roadbank.vehicle import load_vehicle

    car = load_vehicle("sedan")
    sensors = car.sensors.to_sim()
    sensors = sensors.replace(yaw_rate=dataclasses.replace(sensors.yaw_rate, bias=math.radians(bias_dps)))
    spec = drives.DriveSpec(crown=math.atan(crown), superelevation=0.06)
    sim = run(drives.mixed_drive(seed=201, spec=spec), plant=car.to_plant(), sensors=sensors, seed=201)
    assert not E.with_online_offsets(E.make("kinematic"), params=car.params).run(sim.signals).states["r_offset"].any()
    e = E.with_online_offsets(E.make("kinematic"), params=car.params, settings=STRAIGHT).run(sim.signals)
    assert e.states["r_offset_learnt"][-1] == 1.0
    assert abs(math.degrees(e.states["r_offset"][-1]) - bias_dps) < 0.15, math.degrees(e.states["r_offset"][-1])


def test_a_steering_channel_that_never_changes_teaches_nothing():
    """A steering column holding one value (a logger writing 0 for a signal it does not have) is no evidence: on a
    banked straight, where the relation with the measured ay would ask for a steer into the slope, nothing is learnt
    and the inputs pass unchanged; once the column moves, straight driving teaches again."""
    n = 3000
    t = np.arange(n) * 0.01
    ay = np.full(n, 9.81 * math.sin(0.01))
    sig = Signals(t, np.full(n, 20.0), ay, np.zeros(n), np.zeros(n))
    e = E.with_online_offsets(E.make("kinematic"), settings=STRAIGHT).run(sig)
    assert not e.states["r_offset_learnt"].any() and not np.any(e.states["r_offset"])
    np.testing.assert_array_equal(e.theta, E.make("kinematic").run(sig).theta)
    wiggle = Signals(t, np.full(n, 20.0), ay, np.zeros(n), 1e-6 * np.sin(t))
    learnt = E.with_online_offsets(E.make("kinematic"), settings=STRAIGHT).run(wiggle).states["r_offset_learnt"]
    assert learnt[-1] == 1.0

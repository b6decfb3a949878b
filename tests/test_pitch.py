"""The pitch from a pitch-rate gyro (roadbank.estimators.pitch, kinematic-gyro's pitch_bandwidth).

Checked against analytic results: a car circling on a tilted plane (body rates p = q = 0, r = omega; its pitch and
roll swing with its heading, known in closed form), the steady pitch error that a constant offset of the pitch rate
leaves (2 zeta b / omega, from the observer's equations), the Euler pitch rate; and against the real drives (KITTI's
INS pitch rate, its own pitch)."""

from __future__ import annotations

import dataclasses
import glob
import math
from pathlib import Path

import numpy as np
import pytest

from roadbank.constants import G
from roadbank.estimators.gyro import UNBIASED_PITCH_BANDWIDTH, KinematicGyro
from roadbank.estimators.pitch import ANCHOR_GRADE_SD, ANCHOR_SPEED_SD, PITCH_ZETA, PitchObserver
from roadbank.models.attitude import euler_pitch_rate, kinematic_roll
from roadbank.signals import Signals

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
KITTI = DATA / "kitti-oxts" / "2011_09_26_drive_0070"
needs_kitti = pytest.mark.skipif(not KITTI.is_dir(), reason=f"shared KITTI data not found at {KITTI}")


def _circle_on_a_plane(alpha_deg: float, omega: float, v: float = 15.0, rate: float = 100.0, duration: float = 120.0):
    """A car at ``v`` (m/s) turning at ``omega`` (rad/s) on a plane tilted by ``alpha_deg``, ideal sensors: body rates
    p = q = 0, r = omega; the up axis in the body (-sin pitch, sin roll cos pitch, cos roll cos pitch) = (sin psi sin a,
    cos psi sin a, cos a), psi the heading. Returns the log and the Euler pitch and roll (rad, ISO)."""
    t = np.arange(int(duration * rate)) / rate
    psi, sa = omega * t, math.sin(math.radians(alpha_deg))
    pitch = np.arcsin(-np.sin(psi) * sa)
    roll = np.arcsin(np.cos(psi) * sa / np.cos(pitch))
    n = len(t)
    s = Signals(t, np.full(n, v), v * omega + G * np.cos(psi) * sa, np.full(n, omega), np.full(n, np.nan),
                p=np.zeros(n), ax=G * np.sin(psi) * sa, q=np.zeros(n), unbiased=frozenset({"p", "ax", "q"}))
    return s, pitch, roll


def test_the_euler_pitch_rate_and_the_kinematic_roll():
    q, r, roll = np.array([0.02, 0.0, 0.01]), np.array([0.0, 0.3, 0.3]), np.array([0.1, 0.05, -0.2])
    np.testing.assert_allclose(euler_pitch_rate(q, r, roll), q * np.cos(roll) - r * np.sin(roll), rtol=0, atol=0)
    assert euler_pitch_rate(0.02, 0.3, 0.0) == pytest.approx(0.02, abs=1e-15)
    np.testing.assert_allclose(kinematic_roll([20.0, 10.0], [2.0 + G * math.sin(0.05), 50.0], [0.1, 0.0]),
                               [0.05, math.pi / 2], rtol=0, atol=1e-12)


@pytest.mark.parametrize("omega", [0.05, 0.2])
def test_circling_on_a_tilted_plane_the_observer_follows_the_pitch_without_the_windows_lag(omega):
    """p = q = 0 on the plane, so all the pitch's change comes through -r sin(roll): the observer follows it to the
    kinematic roll's second-order error (below 0.02 deg once started), and the gyro filter that reads its pitch leaves
    under a fifth of the roll error the 4 s window's pitch leaves."""
    s, pitch, roll = _circle_on_a_plane(6.0, omega)
    steady = s.t > 30.0
    got = PitchObserver(UNBIASED_PITCH_BANDWIDTH).pitch(s.t, s.vx, s.ax, s.q, s.ay, s.r)
    assert np.degrees(np.max(np.abs(got - pitch)[steady])) < 0.02
    window = KinematicGyro(pitch_bandwidth=0.0).run(s).theta
    observed = KinematicGyro(pitch_bandwidth=UNBIASED_PITCH_BANDWIDTH).run(s).theta
    target = np.arcsin(np.sin(roll) * np.cos(pitch))        # what the filter estimates: asin of the up axis's y
    e_w, e_o = (float(np.max(np.abs(x - target)[steady])) for x in (window, observed))
    assert e_o < 0.2 * e_w


@pytest.mark.parametrize("bandwidth", [0.5, 2.0])
def test_a_constant_offset_of_the_pitch_rate_leaves_two_zeta_b_over_omega(bandwidth):
    """Straight and level at a steady speed, q = b: the observer's steady state is v - v_hat = b / k2 and
    g pitch = k1 (v - v_hat), so pitch = 2 zeta b / omega (to the linearised sine: 1e-6 relative)."""
    n, rate, b = 6000, 50.0, math.radians(0.3)
    t = np.arange(n) / rate
    z = np.zeros(n)
    got = PitchObserver(bandwidth).pitch(t, np.full(n, 20.0), z, np.full(n, b), z, z)
    assert got[-1] == pytest.approx(2 * PITCH_ZETA * b / bandwidth, rel=1e-4)


def test_a_one_hertz_log_with_a_fast_start_stays_stable_and_reads_a_grade_at_rest():
    """The implicit step is stable at any step: at 1 Hz with a 3 rad/s start (3 s per step of the fast pole) the
    pitch of a car at rest on a 4 % grade (ax = -g sin pitch) comes out to rounding."""
    n = 200
    t = np.arange(n, dtype=float)
    pitch = math.atan(0.04)
    z = np.zeros(n)
    got = PitchObserver(0.5, start=(3.0, 10.0)).pitch(t, z, np.full(n, -G * math.sin(pitch)), z, z, z)
    assert np.all(np.abs(got) < 0.1) and got[-1] == pytest.approx(pitch, abs=1e-9)


def test_step_and_chunks_give_what_one_run_gives_and_a_bad_sample_keeps_the_state():
    s, _, _ = _circle_on_a_plane(6.0, 0.1, rate=20.0, duration=30.0)
    q = s.q.copy()
    q[100] = np.nan
    s = dataclasses.replace(s, q=q)
    whole = KinematicGyro(pitch_bandwidth=UNBIASED_PITCH_BANDWIDTH, pitch_anchor=1.0).run(s).theta
    est = KinematicGyro(pitch_bandwidth=UNBIASED_PITCH_BANDWIDTH, pitch_anchor=1.0)
    stepped = [est.step(*(float(getattr(s, c)[i]) for c in ("t", "vx", "ay", "r", "delta_f", "p", "ax", "q"))).theta
               for i in range(len(s))]
    np.testing.assert_array_equal(stepped, whole)
    chunks = np.concatenate([est.run(s[a:a + 13], reset=(a == 0)).theta for a in range(0, len(s), 13)])
    np.testing.assert_array_equal(chunks, whole)
    obs = PitchObserver(1.0)
    got = obs.pitch(s.t, s.vx, s.ax, s.q, s.ay, s.r)
    assert np.isnan(got[100]) and got[101] != 0.0 and np.all(np.isfinite(np.delete(got, 100)))


def test_a_pitch_rate_is_read_only_with_the_grade_correction_and_the_default_takes_it_only_when_unbiased():
    from roadbank.vehicle import design_record, log_conditions, make_estimator
    s, _, _ = _circle_on_a_plane(6.0, 0.1, duration=60.0)
    cond = log_conditions(s)
    assert cond["log_pitch_rate"] == pytest.approx(1.0, abs=0.2)
    loud = {**cond, "log_roll_rate": 1.0, "log_ax": 1.0, "log_ay_noise": 0.2, "log_ay_floor": 0.2}
    assert make_estimator("kinematic-pif", **loud).pitch_bandwidth == UNBIASED_PITCH_BANDWIDTH
    assert design_record(loud, "-", "given")["pitch_rate"] == cond["log_pitch_rate"]
    # a pitch rate not documented free of offset, or no grade correction: not read
    plain = log_conditions(dataclasses.replace(s, unbiased=frozenset({"p", "ax"})))
    assert plain["log_pitch_rate"] is None
    assert make_estimator("kinematic-pif", **{**loud, "log_pitch_rate": None}).pitch_bandwidth == 0.0
    assert make_estimator("kinematic-pif", **{**loud, "log_ax": None}).pitch_bandwidth == 0.0
    # a pitch rate of the wrong sign in deg/s read as rad/s does not follow the pitch
    s2 = dataclasses.replace(s, q=-np.degrees(euler_pitch_rate(s.q, s.r, kinematic_roll(s.vx, s.ay, s.r))))
    assert not 0.5 <= (log_conditions(s2)["log_pitch_rate"] or 0.0) <= 2.0


def test_a_map_reads_a_pitch_rate_flipped_from_frd_and_marks_it_unbiased_when_it_says_so(tmp_path):
    from roadbank.io import load_log
    n = 200
    t = np.arange(n) / 50.0
    rows = np.column_stack([t, np.full(n, 10.0), np.zeros(n), np.zeros(n), np.full(n, 0.1), np.full(n, -0.5)])
    (tmp_path / "log.csv").write_text("time,v,acc_y,gyro_z,gyro_y,acc_x\n"
                                      + "\n".join(",".join(f"{x:g}" for x in row) for row in rows) + "\n")
    (tmp_path / "map.toml").write_text(
        'convention = "FRD"\n[channels]\ntime = { column = "time", unit = "s" }\n'
        'speed = { column = "v", unit = "m/s" }\nlateral_acceleration = { column = "acc_y", unit = "m/s^2" }\n'
        'yaw_rate = { column = "gyro_z", unit = "rad/s" }\n'
        'pitch_rate = { column = "gyro_y", unit = "deg/s", unbiased = true }\n'
        'longitudinal_acceleration = { column = "acc_x", unit = "m/s^2" }\n')
    log = load_log(tmp_path / "log.csv", tmp_path / "map.toml")
    np.testing.assert_allclose(log.signals.q, -math.radians(0.1), rtol=0, atol=1e-12)
    assert "q" in log.signals.unbiased and "ax" not in log.signals.unbiased


@needs_kitti
def test_kitti_gives_its_ins_pitch_rate_free_of_offset_and_it_follows_the_pitch():
    """The OXTS wy column is the pitch rate (ISO: positive nose down, as OXTS's y axis points left): read as q,
    documented free of offset; integrated, it follows the INS's own pitch (column 4) to 0.5 deg over the drive's
    first 60 s, its negation does not; the default reads it."""
    from roadbank.io.kitti import load_kitti_oxts
    from roadbank.vehicle import for_log
    log = load_kitti_oxts(KITTI)
    s = log.signals
    assert s.q is not None and {"q", "p", "ax"} <= s.unbiased
    files = sorted(glob.glob(str(KITTI / "**" / "oxts" / "data" / "*.txt"), recursive=True))
    ins_pitch = np.array([float(open(f).read().split()[4]) for f in files])
    assert len(ins_pitch) == len(s)
    rate = euler_pitch_rate(s.q, s.r, np.asarray(log.reference_roll))
    first = s.t - s.t[0] < 60.0
    dt = np.diff(s.t)
    integ = ins_pitch[0] + np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * dt)])
    wrong = ins_pitch[0] - np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * dt)])
    spread = np.degrees(np.ptp(ins_pitch[first]))
    assert np.degrees(np.max(np.abs(integ - ins_pitch)[first])) < 0.5 < spread
    assert np.degrees(np.max(np.abs(wrong - ins_pitch)[first])) > 0.5
    assert for_log("kinematic-pif", s).pitch_bandwidth == UNBIASED_PITCH_BANDWIDTH


@needs_kitti
def test_the_thirty_ninth_stage_reads_the_pitch_from_an_unbiased_pitch_rate():
    """The rule (tuning.real.choose_pitch_rate): the lowest is 0.5 rad/s with the fast start for every pitch rate;
    within the tie of it, the use for an unbiased pitch rate only at 0.5 rad/s without a start wins (the tie order),
    and the shipped window is not within the tie; at 0.5 rad/s each use beats the window."""
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True, pitch_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_pitch_rate(logs)
    assert chosen == ("unbiased", real.BANDWIDTH_39, None) == ("unbiased", 0.5, None)
    best = min(obj.values())
    assert obj[("always", 0.5, (3.0, 3.0))] == best
    assert obj[chosen] <= best + real.TIE_DEG < obj[("window",)]
    assert all(v < obj[("window",)] for k, v in obj.items() if k[1:2] == (0.5,))


@needs_kitti
def test_the_fortieth_stage_starts_the_observer_at_three_radians_per_second_for_three_seconds():
    """The rule (tuning.real.choose_pitch_start): none is the lowest, the 3 rad/s start for 3 s within the tie of it
    and chosen by the tie order (a start over none: a zero pitch is a guess), the 6 s span outside the tie (the
    forty-fourth stage replaced that start; tuning.real.START_40 keeps it for the stages between)."""
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True, pitch_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_pitch_start(logs)
    assert chosen == real.START_40 == (3.0, 3.0)
    best = min(obj.values())
    assert obj[None] == best and obj[chosen] <= best + real.TIE_DEG < obj[(3.0, 6.0)]


@needs_kitti
def test_a_drive_that_pulls_away_turning_on_a_grade_keeps_its_start():
    """Validation drive 0070 pulls away turning at 0.66 rad/s on a 3 deg grade: with the observer started at zero
    pitch and no faster start, its first 10 s scored (vx >= 5 m/s after 5 s) leave the INS roll by more than twice
    what they leave with the fortieth stage's start or the forty-fourth's anchored start (shipped)."""
    from roadbank.estimators.gyro import (UNBIASED_GYRO_BIAS_TAU_S, UNBIASED_GYRO_CUTOFF_HZ, UNBIASED_PITCH_ANCHOR,
                                          UNBIASED_PITCH_START)
    from roadbank.tuning.real import START_40
    from roadbank.io.kitti import load_kitti_oxts
    log = load_kitti_oxts(KITTI)
    s, ref = log.signals, log.reference_roll
    m = (s.vx >= 5) & (s.t >= s.t[0] + 5) & (s.t < s.t[0] + 15)

    def rms(start, anchor=None):
        est = KinematicGyro(cutoff=UNBIASED_GYRO_CUTOFF_HZ, bias_tau=UNBIASED_GYRO_BIAS_TAU_S,
                            pitch_bandwidth=UNBIASED_PITCH_BANDWIDTH, pitch_start=start, pitch_anchor=anchor)
        return float(np.degrees(np.sqrt(np.mean((est.run(s).theta[m] - ref[m]) ** 2))))
    zero = rms(None)
    assert zero > 2 * rms(START_40) and zero > 2 * rms(UNBIASED_PITCH_START, UNBIASED_PITCH_ANCHOR)


def test_a_column_named_like_a_pitch_rate_is_guessed_as_one_never_unbiased():
    """``roadbank channels``' guess: ``PitchRate`` in deg/s by its range (99th percentile above 0.5), ``gyro_y`` in
    rad/s; the map it writes reads back with the pitch rate and without ``unbiased``."""
    import tomllib

    from roadbank.io.channels import channel_map_from_dict
    from roadbank.io.guess import channel_map_toml, guess_channels
    n = 500
    t = np.arange(n) / 50.0
    r = 0.2 * np.sin(t)
    data = {"time": t, "speed": np.full(n, 15.0), "lat_acc": 15.0 * r, "yaw_rate": r,
            "PitchRate": 3.0 * np.sin(2 * t), "gyro_y": 0.05 * np.sin(2 * t)}
    for col, unit in (("PitchRate", "deg/s"), ("gyro_y", "rad/s")):
        names = ["time", "speed", "lat_acc", "yaw_rate", col]
        got = {g.role: g for g in guess_channels(names, {k: data[k] for k in names})}
        assert got["pitch_rate"].column == col and got["pitch_rate"].unit == unit
        cmap = channel_map_from_dict(tomllib.loads(channel_map_toml(list(got.values()), "test")), "m.toml")
        assert "pitch_rate" in cmap.channels and cmap.unbiased == frozenset()


def test_a_pitch_steeper_than_a_road_is_a_fault_and_leaves_the_roll_rate_uncorrected():
    """An ``ax`` that reads 0.5 g at rest (a fault: 30 deg) drives the observer past MAX_SIN_PITCH: NaN there, and the
    gyro filter reads p as measured there."""
    n = 400
    t = np.arange(n) / 20.0
    z = np.zeros(n)
    got = PitchObserver(0.5).pitch(t, z, np.full(n, -0.5 * G), z, z, z)
    assert np.isnan(got[-1]) and np.isfinite(got[0])
    s = Signals(t, np.full(n, 10.0), z, np.full(n, 0.1), np.full(n, np.nan), p=np.full(n, 0.01),
                ax=np.full(n, -0.5 * G), q=z)
    read = KinematicGyro(pitch_bandwidth=0.5).grade.correct(s).p
    late = t > 10.0
    np.testing.assert_array_equal(read[late], s.p[late])
    assert np.all(read[1:20] != s.p[1:20])          # corrected while the pitch was still a road's


@needs_kitti
def test_the_offline_smoother_in_chunks_with_the_rest_as_lookahead_is_the_one_run_with_the_observer():
    """roadbank map's chunks: each chunk with the rest of the log as lookahead gives the one run, the observer's
    state moving on by each chunk alone (its lookahead estimated from a copy)."""
    from roadbank.estimators import KinematicGyroSmoother
    from roadbank.estimators.gyro import UNBIASED_PITCH_START
    from roadbank.io.kitti import load_kitti_oxts
    s = load_kitti_oxts(KITTI).signals
    est = KinematicGyroSmoother(pitch_bandwidth=UNBIASED_PITCH_BANDWIDTH, pitch_start=UNBIASED_PITCH_START)
    whole = est.run(s).w
    assert np.max(np.abs(whole - KinematicGyroSmoother().run(s).w)) > 1e-5       # the observer's pitch is read
    est.reset()
    parts = [est.run(s[a:a + 100], reset=False, lookahead=s[a + 100:] if a + 100 < len(s) else None).w.copy()
             for a in range(0, len(s), 100)]
    np.testing.assert_allclose(np.concatenate(parts), whole, rtol=0, atol=1e-10)


@needs_kitti
def test_the_forty_first_stage_keeps_the_bandwidth_below_the_grid_edge_within_the_tie():
    """The rule (tuning.real.choose_pitch_bandwidth): 0.25 rad/s is the lowest, 0.35 and the shipped 0.5 within the
    tie of it, so 0.5 stays (the tie order); the objectives fall with the bandwidth, by less than the tie."""
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True, pitch_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_pitch_bandwidth(logs)
    assert chosen == real.BANDWIDTH_39 == 0.5
    assert min(obj.values()) == obj[0.25] and obj[0.5] <= obj[0.25] + real.TIE_DEG
    assert obj[0.25] < obj[0.35] < obj[0.5]


def test_with_an_offset_state_a_constant_offset_of_the_pitch_rate_is_learnt_and_leaves_no_pitch():
    """The same straight, level drive with q = b: with T_q = 20 s the offset state converges to b and the pitch to 0
    (the error's poles (s + 1/T_q)(s^2 + 2 zeta omega s + omega^2): after 10 T_q, e^-10 of the start's error)."""
    n, rate, b = 10000, 50.0, math.radians(0.3)
    t = np.arange(n) / rate
    z = np.zeros(n)
    obs = PitchObserver(0.5, offset_tau=20.0)
    got = obs.pitch(t, np.full(n, 20.0), z, np.full(n, b), z, z)
    assert obs.offset == pytest.approx(b, rel=1e-3) and abs(got[-1]) < 1e-3 * b
    with pytest.raises(ValueError, match="offset_tau"):
        PitchObserver(0.5, offset_tau=0.0)


@needs_kitti
def test_the_forty_second_stage_reads_no_pitch_rate_with_an_offset():
    """The rule (tuning.real.choose_biased_pitch_rate): on the five general sets (+-0.3 deg/s on p and q, +-1 deg/s on
    q alone) not reading a pitch rate with an offset is the lowest; the offset state (20 s) beats the observer
    without one."""
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True, pitch_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_biased_pitch_rate(logs)
    assert chosen == "none" and min(obj.values()) == obj["none"]
    assert obj[20.0] < obj[60.0] < obj[None]


@needs_kitti
def test_the_forty_third_stage_lowers_the_unbiased_cut_off_with_the_observers_pitch():
    """The rule (tuning.real.choose_unbiased_gyro_again): with the observer's pitch, 0.05 Hz and 40 s are the lowest,
    below the thirty-sixth stage's 0.07 Hz by more than the tie; every 0.05 Hz pair beats every 0.07 Hz pair but one
    and 0.03 Hz is worse than both (not the grid's edge)."""
    from roadbank.estimators.gyro import UNBIASED_GYRO_BIAS_TAU_S, UNBIASED_GYRO_CUTOFF_HZ
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True, pitch_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_unbiased_gyro_again(logs)
    assert chosen == (UNBIASED_GYRO_CUTOFF_HZ, UNBIASED_GYRO_BIAS_TAU_S) == (0.05, 40.0)
    assert obj[chosen] == min(obj.values()) and obj[chosen] + real.TIE_DEG < obj[(0.07, 40.0)]
    assert max(obj[(0.05, bt)] for bt in (20.0, 40.0, 80.0)) < min(obj[(0.07, bt)] for bt in (20.0, 40.0))
    assert min(obj[(0.03, bt)] for bt in (20.0, 40.0, 80.0)) > max(obj[(0.07, bt)] for bt in (20.0, 40.0, 80.0))


@pytest.mark.parametrize("grade_deg", [-4.0, 2.0, 6.0])
def test_the_anchored_start_reads_the_grade_of_a_car_pulling_away_within_half_a_second(grade_deg):
    """A car accelerating at 0.8 m/s^2 from 2 m/s on a steady grade, ideal sensors (ax = 0.8 - g sin pitch, q = 0):
    the speed gained beyond ax's integral is g sin(pitch) tau, so the ridge least squares over the first 0.5 s (six
    samples) gives asin(sin(pitch) S / (S + lambda)), S = g^2 sum (tau - mean tau)^2, lambda the prior's weight
    (ANCHOR_SPEED_SD / ANCHOR_GRADE_SD)^2 (to rounding); the observer from a zero pitch at its 3 rad/s start still
    leaves over a fifth of the grade there. After the anchor's 1 s the observer goes on to the grade (the prior's
    shrinkage left at 1 s is gone to 0.2 % of the grade at 10 s)."""
    n, th = 100, math.radians(grade_deg)
    t = np.arange(n) / 10.0
    z = np.zeros(n)
    vx, ax = 2.0 + 0.8 * t, np.full(n, 0.8 - G * math.sin(th))
    anchored = PitchObserver(0.5, anchor=1.0).pitch(t, vx, ax, z, z, z)
    zero = PitchObserver(0.5, start=(3.0, 3.0)).pitch(t, vx, ax, z, z, z)
    tau = t[:6]
    sxx = G ** 2 * np.sum((tau - tau.mean()) ** 2)
    shrunk = math.sin(th) * sxx / (sxx + (ANCHOR_SPEED_SD / ANCHOR_GRADE_SD) ** 2)
    assert anchored[5] == pytest.approx(math.asin(shrunk), rel=1e-9) and abs(anchored[5] - th) < 0.06 * abs(th)
    assert abs(zero[5] - th) > 0.2 * abs(th)
    assert abs(anchored[-1] - th) < 2e-3 * abs(th)


def test_the_anchored_start_integrates_the_pitch_rate_between_and_keeps_its_state_across_chunks():
    """Pulling away onto a grade that steepens (q = 0.02 rad/s for the first 2 s from 1 deg): the anchored pitch is
    the first pitch plus q's integral (within 0.05 deg from 0.5 s); in chunks of 7 samples the same to the bit; a gap
    longer than PITCH_MAX_GAP_S within the span ends it and the observer goes on from the pitch reached."""
    n = 80
    t = np.arange(n) / 20.0
    q = np.where(t < 2.0, 0.02, 0.0)
    th = math.radians(1.0) + np.cumsum(np.r_[0.0, 0.5 * (q[1:] + q[:-1]) * np.diff(t)])
    vx = 3.0 + 0.5 * t
    ax = 0.5 - G * np.sin(th)
    z = np.zeros(n)
    obs = PitchObserver(0.5, anchor=3.0)
    got = obs.pitch(t, vx, ax, q, z, z)
    late = t >= 0.5
    assert np.degrees(np.max(np.abs(got - th)[late])) < 0.05
    obs.reset()
    parts = np.concatenate([obs.pitch(t[a:a + 7], vx[a:a + 7], ax[a:a + 7], q[a:a + 7], z[:7][:len(t[a:a + 7])],
                                      z[:7][:len(t[a:a + 7])]) for a in range(0, n, 7)])
    np.testing.assert_array_equal(parts, got)
    t2 = t.copy()
    t2[20:] += 2.0                                   # a 2 s gap at 1 s: the anchor ends there
    gap = PitchObserver(0.5, anchor=3.0).pitch(t2, vx, ax, q, z, z)
    assert gap[20] == gap[19] and np.all(np.isfinite(gap))


@needs_kitti
def test_the_forty_fourth_stage_anchors_the_start_for_one_second():
    """The rule (tuning.real.choose_pitch_anchor): the 1 s anchored start without a faster start after it is the
    lowest, below the shipped 3 rad/s start by more than the tie."""
    from roadbank.estimators.gyro import UNBIASED_PITCH_ANCHOR, UNBIASED_PITCH_START
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True, pitch_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_pitch_anchor(logs)
    assert chosen == (UNBIASED_PITCH_ANCHOR, UNBIASED_PITCH_START) == (1.0, None)
    assert min(obj.values()) == obj[chosen] < obj[(None, real.START_40)] - real.TIE_DEG


@needs_kitti
def test_the_forty_fifth_stage_slows_the_observer_with_the_anchored_start():
    """The rule (tuning.real.choose_unbiased_after_anchor): 0.35 rad/s with the 0.05 Hz cut-off is the lowest, the
    shipped 0.5 rad/s outside its tie, 0.25 rad/s within it (the tie order takes the higher bandwidth); at every
    bandwidth 0.05 Hz beats 0.03 and 0.07 Hz."""
    from roadbank.estimators.gyro import UNBIASED_GYRO_CUTOFF_HZ
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True, pitch_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_unbiased_after_anchor(logs)
    assert chosen == (UNBIASED_PITCH_BANDWIDTH, UNBIASED_GYRO_CUTOFF_HZ) == (0.35, 0.05)
    best = min(obj.values())
    assert obj[chosen] == best and obj[(0.25, 0.05)] <= best + real.TIE_DEG < obj[(0.5, 0.05)]
    assert all(obj[(w, 0.05)] < min(obj[(w, 0.03)], obj[(w, 0.07)]) for w in real.ANCHORED_BANDWIDTHS)


@needs_kitti
def test_the_forty_sixth_stage_keeps_the_offset_state_of_the_unbiased_roll_rate():
    """The rule (tuning.real.choose_unbiased_offset_again): whole drives alone would drop the offset state, but with
    the pieces the shipped 0.05 Hz / 40 s is the lowest of the twelve, no offset state worse by more than the tie at
    every cut-off but 0.07 Hz."""
    from roadbank.estimators.gyro import UNBIASED_GYRO_BIAS_TAU_S, UNBIASED_GYRO_CUTOFF_HZ
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True, pitch_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_unbiased_offset_again(logs)
    assert chosen == (UNBIASED_GYRO_CUTOFF_HZ, UNBIASED_GYRO_BIAS_TAU_S) == (0.05, 40.0)
    assert obj[chosen] == min(obj.values())
    assert all(obj[(fc, 0.0)] > obj[(fc, 40.0)] + real.TIE_DEG for fc in (0.03, 0.05))


@needs_kitti
def test_the_forty_seventh_stage_still_leaves_a_pitch_rate_with_an_offset_unread():
    """The rule (tuning.real.choose_biased_pitch_rate_again): with the anchored, slower observer a MEMS pitch rate is
    still better not read; the observer's best (an offset state learnt in 20 s) loses by more than the tie."""
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True, pitch_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_biased_pitch_rate_again(logs)
    assert chosen == "none" and obj["none"] == min(obj.values())
    assert min(v for k, v in obj.items() if k != "none") > obj["none"] + real.TIE_DEG

"""The roll rate corrected for the grade (roadbank.models.attitude, kinematic-gyro's grade_window).

Checked against analytic results: the pitch of a drive on a known grade, and a car circling on a tilted plane, whose
body rates are p = q = 0 and r = omega while its roll angle swings with its heading (the filter's steady-state
errors with and without the correction follow from its transfer functions); and against the real drives."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from roadbank.constants import G
from roadbank.estimators.gyro import GRADE_WINDOW_S, GYRO_BIAS_TAU_S, GYRO_CUTOFF_HZ, KinematicGyro
from roadbank.models.attitude import MAX_SIN_PITCH, euler_roll_rate, grade_pitch
from roadbank.signals import Signals

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
KITTI = DATA / "kitti-oxts" / "2011_09_26_drive_0070"
needs_kitti = pytest.mark.skipif(not KITTI.is_dir(), reason=f"shared KITTI data not found at {KITTI}")


# ------------------------------------------------------------------ the pitch from ax and vx
def test_the_pitch_of_a_steady_grade_is_read_exactly_while_the_car_accelerates():
    """On a 5 % grade (nose down), accelerating at 1 m/s^2 from 10 m/s: ax = vx' - g sin(pitch), so every window
    that has passed gives the pitch to rounding; before the first window has passed, NaN."""
    rate, window = 50.0, 2.0
    t = np.arange(500) / rate
    pitch = math.atan(0.05)
    vx, ax = 10.0 + t, np.full(len(t), 1.0 - G * math.sin(pitch))
    got = grade_pitch(t, vx, ax, window)
    full = t >= t[0] + window
    assert np.all(np.isnan(got[~full]))
    np.testing.assert_allclose(got[full], pitch, rtol=0, atol=1e-12)


def test_a_bad_sample_blanks_the_windows_it_lies_in_and_a_fault_steeper_than_a_road_is_not_a_pitch():
    rate, window = 10.0, 1.0
    t = np.arange(100) / rate
    vx, ax = np.full(100, 20.0), np.full(100, -0.5)
    ax[50] = np.nan
    got = grade_pitch(t, vx, ax, window)
    spans = (t >= t[50]) & (t <= t[50] + window + 1e-9)     # the windows that hold sample 50 (its ends included)
    assert np.all(np.isnan(got[spans])) and np.all(np.isfinite(got[(t >= window) & ~spans]))
    steep = grade_pitch(t, vx, np.full(100, -G * (MAX_SIN_PITCH + 0.01)), window)
    assert np.all(np.isnan(steep))


def test_the_euler_rate_adds_r_tan_pitch_and_keeps_p_where_the_pitch_is_unknown():
    p, r = np.array([0.01, 0.02, 0.03]), np.array([0.2, 0.2, 0.2])
    pitch = np.array([0.05, np.nan, -0.1])
    np.testing.assert_allclose(euler_roll_rate(p, r, pitch), [0.01 + 0.2 * math.tan(0.05), 0.02,
                                                              0.03 - 0.2 * math.tan(0.1)], rtol=0, atol=1e-15)


# ------------------------------------------------------------------ a car circling on a tilted plane
def _circle_on_a_plane(alpha_deg: float, omega: float, v: float = 15.0, rate: float = 100.0, duration: float = 300.0):
    """A car at ``v`` (m/s) turning at ``omega`` (rad/s) on a plane tilted by ``alpha_deg``: body rates p = q = 0,
    r = omega; the up axis in the body, (-sin pitch, sin roll cos pitch, ...) = (sin psi sin a, cos psi sin a, ...),
    psi the heading from the plane's level line. Returns the log (ideal sensors) and asin of the up axis's y
    component (rad): the roll angle times cos(pitch) inside the sine, what the kinematic estimate reads and the filter
    estimates (the roll itself differs from it by at most sin(a)^3 / 2: 0.01 deg at 6 deg)."""
    t = np.arange(int(duration * rate)) / rate
    psi, sa = omega * t, math.sin(math.radians(alpha_deg))
    up_y, sin_pitch = np.cos(psi) * sa, -np.sin(psi) * sa
    n = len(t)
    s = Signals(t, np.full(n, v), v * omega + G * up_y, np.full(n, omega), np.full(n, np.nan), p=np.zeros(n),
                ax=-G * sin_pitch)
    return s, np.arcsin(up_y)


def _filter_at(omega: float):
    """The complementary filter's transfer functions at s = j omega: from the kinematic estimate, 1 - H_k (its
    error), and from the roll rate, H_p (module docstring of roadbank.estimators.gyro)."""
    s, wc = 1j * omega, 2 * math.pi * GYRO_CUTOFF_HZ
    den = s * s + wc * s + wc / GYRO_BIAS_TAU_S
    return s * s / den, s / den


@pytest.mark.parametrize("omega", [0.05, 0.1])
def test_circling_on_a_grade_the_roll_is_followed_once_the_rate_is_corrected(omega):
    """On a 6 deg plane the roll swings with amplitude sin(6 deg) at the turn rate while the gyro reads p = 0:
    uncorrected, the filter leaves |1 - H_k| sin(a) of it; corrected by the causal pitch (a W-second mean, which
    lags by W/2), what remains is |H_p| omega sin(a) |sinc(omega W/2) exp(-j omega W/2) - 1|. Both amplitudes as the
    transfer functions give them (3 %: the terms of second order in the angles), and the second far below the
    first."""
    alpha = 6.0
    s, roll = _circle_on_a_plane(alpha, omega)
    steady = s.t > 100.0
    sa = math.sin(math.radians(alpha))
    e_k, h_p = _filter_at(omega)
    x = omega * GRADE_WINDOW_S / 2
    lag = abs(math.sin(x) / x * complex(math.cos(x), -math.sin(x)) - 1.0)
    expected = {0.0: abs(e_k) * sa, GRADE_WINDOW_S: abs(h_p) * omega * sa * lag}
    got = {w: float(np.max(np.abs(KinematicGyro(grade_window=w).run(s).theta - roll)[steady])) for w in expected}
    for w in expected:
        assert got[w] == pytest.approx(expected[w], rel=0.03), w
    assert got[GRADE_WINDOW_S] < 0.3 * got[0.0]


def test_without_ax_the_roll_rate_is_read_as_measured():
    s, _ = _circle_on_a_plane(6.0, 0.1, duration=30.0)
    a = KinematicGyro().run(dataclasses.replace(s, ax=None)).theta
    np.testing.assert_array_equal(a, KinematicGyro(grade_window=0.0).run(s).theta)


def test_step_and_chunks_give_what_one_run_gives():
    s, _ = _circle_on_a_plane(6.0, 0.1, rate=20.0, duration=30.0)
    whole = KinematicGyro().run(s).theta
    est = KinematicGyro()
    stepped = [est.step(*(float(getattr(s, c)[i]) for c in ("t", "vx", "ay", "r", "delta_f", "p", "ax"))).theta
               for i in range(len(s))]
    np.testing.assert_array_equal(stepped, whole)
    chunks = np.concatenate([est.run(s[a:a + 13], reset=(a == 0)).theta for a in range(0, len(s), 13)])
    np.testing.assert_array_equal(chunks, whole)


# ------------------------------------------------------------------ real drives and the default
def test_a_csv_log_reads_ax_by_the_default_map_and_a_map_naming_a_missing_column_says_so(tmp_path):
    from roadbank.io import load_log
    n = 200
    t = np.arange(n) / 100.0
    cols = {"t": t, "vx": np.full(n, 20.0), "ay": np.full(n, 0.3), "r": np.full(n, 0.01), "delta_f": np.zeros(n),
            "ax": np.full(n, -0.4)}
    path = tmp_path / "log.csv"
    path.write_text(",".join(cols) + "\n" + "\n".join(",".join(f"{c[i]:.6g}" for c in cols.values())
                                                     for i in range(n)) + "\n")
    log = load_log(path)
    np.testing.assert_allclose(log.signals.ax, -0.4)
    assert log.signals.p is None
    mapping = tmp_path / "map.toml"
    mapping.write_text('[channels]\ntime = { column = "t", unit = "s" }\nspeed = { column = "vx", unit = "m/s" }\n'
                       'lateral_acceleration = { column = "ay", unit = "m/s^2" }\n'
                       'yaw_rate = { column = "r", unit = "rad/s" }\n'
                       'road_wheel_angle = { column = "delta_f", unit = "rad" }\n'
                       'longitudinal_acceleration = { column = "accel_x", unit = "g" }\n')
    log = load_log(path, channels=mapping)
    assert log.signals.ax is None
    assert any("longitudinal_acceleration" in w and "accel_x" in w and "grade" in w for w in log.warnings)


@needs_kitti
@pytest.mark.parametrize("wrong", ["negated", "g read as m/s^2"])
def test_an_ax_that_does_not_follow_the_speed_leaves_the_roll_rate_uncorrected_and_said_so(wrong):
    """The slope of vx on the integrated ax (about 1 for the drive as read; -1, ~0.1 wrong): where it is outside
    0.5-2 the default's gyro filter does not correct the roll rate, and the summary line says why."""
    from roadbank.fleet.process import design_words
    from roadbank.io.kitti import load_kitti_oxts
    from roadbank.vehicle import design_record, for_log, log_conditions
    # the channels as a map's: judged (the KITTI reader's own are taken as they are, the thirty-third stage), and
    # not said to be free of offset
    s = dataclasses.replace(load_kitti_oxts(KITTI).signals, fixed=frozenset(), unbiased=frozenset())
    assert log_conditions(s)["log_ax"] == pytest.approx(1.0, abs=0.1)
    assert for_log("kinematic-pif", s).grade_window == GRADE_WINDOW_S
    bad = dataclasses.replace(s, ax={"negated": -s.ax, "g read as m/s^2": s.ax / G}[wrong])
    cond = log_conditions(bad)
    assert not 0.5 <= cond["log_ax"] <= 2.0
    est = for_log("kinematic-pif", bad)
    assert isinstance(est, KinematicGyro) and est.grade_window == 0.0
    words = design_words(design_record(cond, "sedan", "fitted to the log"), "kinematic-pif")
    assert "(the log has a roll rate)" in words and "its ax does not follow its speed" in words


@needs_kitti
def test_the_twenty_sixth_stage_chose_the_shipped_window_on_the_training_drives():
    """The rule (tuning.real.choose_grade) run again on the KITTI training drives picks the shipped window, and the
    correction lowers the objective."""
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_grade(logs)
    assert chosen == GRADE_WINDOW_S and obj[chosen] < obj[0.0]


@needs_kitti
def test_the_twenty_seventh_stage_chose_the_shipped_restart_gap_on_the_training_drives():
    """The rule (tuning.real.choose_gyro_stops) run again on the KITTI training drives picks the shipped pair: a stop
    is held through for up to GYRO_MAX_GAP_S, at the shipped v_min; and it is lower than the restart after 1 s."""
    from roadbank.estimators.kinematic import KINEMATIC_V_MIN
    from roadbank.estimators.gyro import GYRO_MAX_GAP_S
    from roadbank.tuning import real
    logs = real.training_logs(DATA, roll_rate=True)
    if len(logs) < 8:
        pytest.skip(f"the eight KITTI training drives are not all under {DATA}")
    chosen, obj = real.choose_gyro_stops(logs)
    assert chosen == (KINEMATIC_V_MIN, GYRO_MAX_GAP_S) and KinematicGyro().max_gap == GYRO_MAX_GAP_S
    assert obj[chosen] < obj[(KINEMATIC_V_MIN, 1.0)]


def test_a_stop_shorter_than_the_gap_is_held_through_with_the_offset_kept():
    """A gyro offset of 0.3 deg/s learnt over 60 s of driving on a 3 deg bank, then 5 s at rest (held: below v_min),
    then driving again: the filter goes on from its state (the learnt offset kept, the bank unchanged); with the
    former 1 s gap it starts again from one sample with no offset learnt."""
    rate = 20.0
    t = np.arange(int(75 * rate)) / rate
    n = len(t)
    vx = np.where((t >= 60.0) & (t < 65.0), 0.0, 15.0)
    bank, offset = math.radians(3.0), math.radians(0.3)
    s = Signals(t, vx, np.full(n, G * math.sin(bank)), np.zeros(n), np.full(n, np.nan), p=np.full(n, offset))
    after = np.flatnonzero(t >= 65.0)[0]
    kept = KinematicGyro().run(s).states["p_offset"]
    assert kept[after] == pytest.approx(kept[after - 1], abs=0.02 * offset)
    assert kept[after - 1] == pytest.approx(offset, rel=0.01)
    restarted = KinematicGyro(max_gap=1.0).run(s).states["p_offset"]
    assert abs(restarted[after]) < 0.01 * offset


def test_step_with_gaps_in_ax_gives_what_run_gives():
    """Samples without ax (NaN) inside a log that has one: step() keeps them in its window as run() does."""
    s, _ = _circle_on_a_plane(6.0, 0.1, rate=20.0, duration=30.0)
    ax = s.ax.copy()
    ax[100:110] = np.nan
    s = dataclasses.replace(s, ax=ax)
    whole = KinematicGyro().run(s).theta
    est = KinematicGyro()
    stepped = [est.step(*(float(getattr(s, c)[i]) for c in ("t", "vx", "ay", "r", "delta_f", "p", "ax"))).theta
               for i in range(len(s))]
    np.testing.assert_array_equal(stepped, whole)


def test_a_first_span_reads_the_pitch_from_the_first_sample_before_the_window_has_passed():
    """The steady 5 % grade of the first test, the window 4 s and the first span 1 s: from 1 s on the pitch is read
    exactly from the log's first sample (the window growing to 4 s), before 1 s NaN; after 4 s as without it."""
    rate, window = 50.0, 4.0
    t = np.arange(500) / rate
    pitch = math.atan(0.05)
    vx, ax = 10.0 + t, np.full(len(t), 1.0 - G * math.sin(pitch))
    got = grade_pitch(t, vx, ax, window, first_span=1.0)
    early = t < 1.0
    assert np.all(np.isnan(got[early]))
    np.testing.assert_allclose(got[~early], pitch, rtol=0, atol=1e-12)
    full = t >= window
    np.testing.assert_array_equal(got[full], grade_pitch(t, vx, ax, window)[full])


def test_step_and_chunks_give_what_one_run_gives_with_a_first_span():
    """As the test above, with the first span (the pitch from the first sample kept across chunks)."""
    s, _ = _circle_on_a_plane(6.0, 0.1, rate=20.0, duration=30.0)
    whole = KinematicGyro(grade_first_span=0.5).run(s).theta
    assert np.max(np.abs(whole - KinematicGyro(grade_first_span=math.inf).run(s).theta)) > 0
    est = KinematicGyro(grade_first_span=0.5)
    stepped = [est.step(*(float(getattr(s, c)[i]) for c in ("t", "vx", "ay", "r", "delta_f", "p", "ax"))).theta
               for i in range(len(s))]
    np.testing.assert_array_equal(stepped, whole)
    chunks = np.concatenate([est.run(s[a:a + 13], reset=(a == 0)).theta for a in range(0, len(s), 13)])
    np.testing.assert_array_equal(chunks, whole)
    with pytest.raises(ValueError, match="grade_first_span"):
        KinematicGyro(grade_first_span=0.0)

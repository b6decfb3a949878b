"""The grade correction of ``kinematic-gyro`` across a gap in the log longer than the filter's ``max_gap``.

After such a gap the filter starts again; the grade's window (``models.attitude.grade_pitch``, ``GradeCarry``, the C
export's ``<prefix>_roll_rate``) starts again with it, as at a log's start: the samples before the gap are not read,
the speed's change across the gap is no grade, and ``grade_first_span`` counts from the restart. Checked against the
pitch of a known grade, against the drive after the gap run alone (the filter re-initialises fully at a restart, so
from there on every output is the alone run's to rounding) and against the true roll; gaps of at most ``max_gap``
(held through) read as before, against a copy of the former formula."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from roadbank.constants import G
from roadbank.estimators.gyro import LOG_GAPS, GradeCarry, KinematicGyro, gap_time
from roadbank.models.attitude import MAX_SIN_PITCH, euler_roll_rate, grade_pitch, running_area
from roadbank.signals import Signals, concat_signals

RATE = 20.0
FIELDS = ("theta", "phi_b", "w")


def _old_grade_pitch(t, vx, ax, window, g=G, first_span=math.inf):
    """grade_pitch as it was before the restart gap counted (a copy of its formula): the window's start the last
    sample at least a window back, whatever lies between."""
    t, vx, ax = (np.asarray(a, dtype=np.float64) for a in (t, vx, ax))
    area, nbad = running_area(t, vx, ax)
    bad = ~(np.isfinite(vx) & np.isfinite(ax))
    start = np.searchsorted(t, t - window, side="right") - 1
    ok = (start >= 0) | (t - t[0] >= first_span)
    m = np.where(start >= 0, start, 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = (vx - vx[m] - (area - area[m])) / (g * (t - t[m]))
    ok &= (nbad - nbad[m] == 0) & ~bad & ~bad[m] & (np.abs(s) <= MAX_SIN_PITCH)
    return np.where(ok, np.arcsin(np.clip(s, -1.0, 1.0)), np.nan)


def _drive(duration: float, v0: float, dv: float, pitch0: float, seed: int, t0: float = 0.0):
    """A drive of ``duration`` s from ``t0`` at about 20 Hz (jittered stamps): speed ``v0 + dv sin`` (m/s), a grade
    of ``pitch0`` deg and 2 deg more or less, a bank swinging by 3 deg, weaving at 0.15 rad/s; ideal sensors: ay
    (vx r + g sin bank), ax (vx' - g sin pitch), the body roll rate p (the roll's rate less r tan pitch). Returns the
    log and its true roll (rad)."""
    rng = np.random.default_rng(seed)
    tau = np.arange(0.0, duration, 1.0 / RATE)
    tau = tau + rng.uniform(-0.2, 0.2, len(tau)) / RATE
    tau[0] = 0.0
    w_v, w_p, w_b, w_r = 2 * np.pi / 30.0, 2 * np.pi / 25.0, 2 * np.pi / 17.0, 2 * np.pi / 9.0
    vx = v0 + dv * np.sin(w_v * tau)
    pitch = np.radians(pitch0 + 2.0 * np.sin(w_p * tau))
    bank = np.radians(3.0) * np.sin(w_b * tau + seed)
    r = 0.15 * np.sin(w_r * tau)
    ax = dv * w_v * np.cos(w_v * tau) - G * np.sin(pitch)
    p = np.radians(3.0) * w_b * np.cos(w_b * tau + seed) - r * np.tan(pitch)
    s = Signals(t0 + tau, vx, vx * r + G * np.sin(bank), r, np.full(len(tau), np.nan), p=p, ax=ax)
    return s, bank


def _joined(gap: float, drive=_drive):
    """Drive A (60 s, 20 m/s, 3 deg uphill) then, ``gap`` s after its last sample, drive B (40 s from 6 m/s, 4 deg
    downhill: a jump of 14 m/s in speed across the gap that ax never shows), each made by ``drive`` (a module's
    ``_drive``). Returns the log, drive B alone (its own clock from 0), B's true roll and B's first row in the log."""
    a, _ = drive(60.0, 20.0, 2.0, 3.0, seed=1)
    b, roll = drive(40.0, 6.0, 3.0, -4.0, seed=2)
    moved = dataclasses.replace(b, t=b.t + a.t[-1] + gap)
    return concat_signals([a, moved]), b, roll, len(a)


def _with_held_gaps(s: Signals) -> Signals:
    """``s`` (at least 1601 samples) with its stamps on a grid of 1/1024 s (sums of them exact) and gaps of 3 s after
    row 800 and of exactly 10 s (``max_gap``: held through) after row 1600."""
    t = np.round(s.t * 1024.0) / 1024.0
    t[800:] += 3.0
    t[1600:] += 10.0 - (t[1600] - t[1599])
    assert np.max(np.diff(t)) == 10.0
    return dataclasses.replace(s, t=t)


# ------------------------------------------------------------------ the pitch itself
def test_after_a_restart_gap_the_pitch_of_a_steady_grade_is_read_as_at_a_log_start():
    """Two stretches of steady grade (5 % up, accelerating; then 3 % down, 8 m/s slower, 15 s later: longer than a
    max_gap of 10 s): after the gap the pitch is NaN until the first span (2 s) has passed since the restart, then
    the second grade exactly (the window growing from the restart's sample to 4 s); the former window read the speed's
    jump across the gap as a grade."""
    window, span, max_gap = 4.0, 2.0, 10.0
    t1 = np.arange(400) / 50.0
    t2 = t1[-1] + 15.0 + np.arange(400) / 50.0
    up, down = math.atan(0.05), -math.atan(0.03)
    vx = np.concatenate([10.0 + t1, 2.0 + 0.5 * (t2 - t2[0])])
    ax = np.concatenate([np.full(400, 1.0 - G * math.sin(up)), np.full(400, 0.5 - G * math.sin(down))])
    t = np.concatenate([t1, t2])
    got = grade_pitch(t, vx, ax, window, first_span=span, max_gap=max_gap)
    after = t >= t2[0]
    early = after & (t - t2[0] < span)
    assert np.all(np.isnan(got[early]))
    np.testing.assert_allclose(got[after & ~early], down, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[~after & (t >= span)], up, rtol=0, atol=1e-12)
    alone = grade_pitch(t2, vx[after], ax[after], window, first_span=span)
    np.testing.assert_allclose(got[after], alone, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.isnan(got[after]), np.isnan(alone))
    old = _old_grade_pitch(t, vx, ax, window, first_span=span)
    assert np.nanmax(np.abs(old[after & (t - t2[0] < window)] - down)) > math.radians(5.0)   # what was wrong


def test_gaps_up_to_max_gap_read_the_pitch_as_before():
    """Gaps of 2, 5, 9.5 and exactly 10 s (= max_gap, held through by the filter) and NaN samples: the pitch is the
    former formula's bit for bit; so is one without a max_gap on a log with a longer gap."""
    t = np.arange(1200) / 16.0                       # exact stamps: the last gap is 10 s to the bit
    for at, gap in ((200, 2.0), (400, 5.0), (600, 9.5), (800, 10.0 - 1.0 / 16.0)):
        t[at:] += gap
    assert np.max(np.diff(t)) == 10.0
    rng = np.random.default_rng(3)
    vx = 15.0 + 3.0 * np.sin(t / 7.0) + rng.normal(0.0, 0.05, len(t))
    ax = np.cos(t / 7.0) * 3.0 / 7.0 - G * np.sin(np.radians(2.0) * np.sin(t / 11.0))
    ax[[100, 500]] = np.nan
    vx[700] = np.nan
    for span in (math.inf, 2.0):
        old = _old_grade_pitch(t, vx, ax, 4.0, first_span=span)
        np.testing.assert_array_equal(grade_pitch(t, vx, ax, 4.0, first_span=span, max_gap=10.0), old)
        t_long = np.where(np.arange(len(t)) >= 1000, t + 30.0, t)
        np.testing.assert_array_equal(grade_pitch(t_long, vx, ax, 4.0, first_span=span),
                                      _old_grade_pitch(t_long, vx, ax, 4.0, first_span=span))


def test_the_filter_across_held_gaps_reads_the_roll_rate_the_former_formula_corrects():
    """A drive with gaps of 3 and 10 s (at most max_gap): under each gap mode the filter's estimate equals that of the
    filter without a grade correction fed the roll rate the former formula corrects on the stamps it reads."""
    s = _with_held_gaps(_drive(120.0, 15.0, 3.0, 2.0, seed=4)[0])
    for mode in LOG_GAPS:
        if mode == "restart":
            continue                                 # every gap there is made longer than max_gap: a restart
        est = KinematicGyro(log_gaps=mode, sample_rate=RATE)
        read, _ = gap_time(s.t, (math.nan, 0.0, math.nan), 1.0, est.max_gap, mode)
        assert np.max(np.diff(read)) <= est.max_gap
        pitch = _old_grade_pitch(read, s.vx, s.ax, est.grade.window, est.params.g, est.grade.first_span)
        fed = dataclasses.replace(s, p=euler_roll_rate(s.p, s.r, pitch), ax=None)
        plain = KinematicGyro(log_gaps=mode, sample_rate=RATE, grade_window=0.0).run(fed)
        got = est.run(s)
        for f in FIELDS:
            np.testing.assert_array_equal(getattr(got, f), getattr(plain, f), err_msg=f"{mode} {f}")


# ------------------------------------------------------------------ the filter: the drive after the gap as alone
@pytest.mark.parametrize("gap", [10.5, 30.0])
@pytest.mark.parametrize("kw", [dict(sample_rate=RATE), dict(sample_rate=None, cutoff=0.05, bias_tau=40.0)],
                         ids=["fixed-rate", "continuous"])
def test_the_drive_after_a_restart_gap_reads_as_alone(gap, kw):
    """From the restart on, every output (estimate, bank, valid, settled, states) equals drive B's run alone to
    1e-12 (the filter re-initialises fully: nothing carries); B's error against its true roll is the alone run's,
    where the former window (reaching back across the gap) was worse (by 0.03-0.07 deg RMS at 30 s)."""
    log, b, roll, k = _joined(gap)
    whole = KinematicGyro(**kw).run(log)
    alone = KinematicGyro(**kw).run(b)
    for f in FIELDS:
        np.testing.assert_allclose(getattr(whole, f)[k:], getattr(alone, f), rtol=0, atol=1e-12, err_msg=f)
    np.testing.assert_array_equal(whole.valid[k:], alone.valid)
    np.testing.assert_array_equal(whole.settled[k:], alone.settled)
    for name in alone.states:
        np.testing.assert_allclose(whole.states[name][k:], alone.states[name], rtol=0, atol=1e-12, err_msg=name)

    def rms(x):
        return math.degrees(math.sqrt(np.mean((x - roll) ** 2)))
    assert rms(whole.theta[k:]) == pytest.approx(rms(alone.theta), abs=1e-9)
    former = KinematicGyro(**kw)
    former.grade.max_gap = math.inf                  # the window as it was: back across the gap
    assert rms(former.run(log).theta[k:]) > rms(alone.theta) + 0.02


def test_the_first_span_counts_from_the_restart():
    """The corrected roll rate of drive B in the log equals B's alone (to rounding, NaN where B's is): the first span
    (2 s) counts from the restart, not from the log's start, and no sample of drive A enters B's windows."""
    log, b, _, k = _joined(12.0)
    est = KinematicGyro(sample_rate=RATE)
    got = est.grade.correct(log).p[k:]
    est.grade.reset()
    alone = est.grade.correct(b).p
    np.testing.assert_allclose(got, alone, rtol=0, atol=1e-12)
    corrected = np.flatnonzero(alone != b.p)
    assert b.t[corrected[0]] == pytest.approx(est.grade.first_span, abs=1.5 / RATE)    # from 2 s after the restart


# ------------------------------------------------------------------ chunks and step()
@pytest.mark.parametrize("gaps_of", ["rows", "usable"])
def test_step_and_chunks_give_what_one_run_gives_across_a_restart_gap(gaps_of):
    """A log with a held 3 s gap in drive A, a 12 s restart gap, a 15 s stop (rows below v_min: a restart gap of
    the usable samples) and NaN samples in ax: step() and chunks (of 13 and 37 samples, and split at the gap) give
    one run's numbers bit for bit, under every gap mode."""
    log, k = _with_gap_and_stop(*_joined(12.0)[::3])
    _steps_and_chunks_as_one_run(log, k, lambda mode: KinematicGyro(log_gaps=mode, sample_rate=RATE), gaps_of)


def _with_gap_and_stop(log: Signals, k: int) -> tuple[Signals, int]:
    """``log`` (two drives on one clock, the second from row ``k``) with a held 3 s gap after row 500, a 15 s stop
    (rows below v_min) from 10 s into the second drive and NaN ax at rows 300 and ``k + 5``; and ``k``."""
    t, vx, ax = log.t.copy(), log.vx.copy(), log.ax.copy()
    t[500:] += 3.0
    vx[(t > t[k] + 10.0) & (t < t[k] + 25.0)] = 0.0
    ax[[300, k + 5]] = np.nan
    return dataclasses.replace(log, t=t, vx=vx, ax=ax), k


def _steps_and_chunks_as_one_run(log: Signals, k: int, make, gaps_of: str) -> None:
    """Under every gap mode, the estimator ``make(mode)`` (its ``gaps_of`` set) gives one run's ``theta`` bit for bit
    sample by sample (with the log's roll rate, ax and pitch rate where it has them) and in chunks of 13 and 37
    samples and split at row ``k``."""
    more = [c for c in ("p", "ax", "q") if getattr(log, c) is not None]
    for mode in LOG_GAPS:
        est = make(mode)
        est.gaps_of = gaps_of
        whole = est.run(log).theta
        est.reset()
        steps = np.array([est.step(*(float(getattr(log, c)[i]) for c in ("t", "vx", "ay", "r", "delta_f")),
                                   **{c: float(getattr(log, c)[i]) for c in more}).theta for i in range(len(log))])
        np.testing.assert_array_equal(steps, whole, err_msg=f"step {mode}")
        for cuts in (range(0, len(log), 13), range(0, len(log), 37), [0, k - 2, k, k + 1, len(log)]):
            est.reset()
            bounds = [*cuts, len(log)]
            pieces = np.concatenate([est.run(log[a:z], reset=False).theta for a, z in zip(bounds, bounds[1:])
                                     if z > a])
            np.testing.assert_array_equal(pieces, whole, err_msg=f"chunks {mode}")


def test_grade_carry_in_chunks_gives_the_whole_pitch_across_a_restart_gap():
    """GradeCarry alone, chunks ending just after the gap (the sample before it kept in the tail): the corrected
    roll rate of the whole log, bit for bit."""
    log, _, _, k = _joined(12.0)
    carry = GradeCarry(4.0, G, 2.0, max_gap=10.0)
    whole = carry.correct(log).p
    for cuts in ([0, k + 1, k + 3, len(log)], [0, k, len(log)], list(range(0, len(log), 7)) + [len(log)]):
        carry.reset()
        got = np.concatenate([carry.correct(log[a:z]).p for a, z in zip(cuts, cuts[1:]) if z > a])
        np.testing.assert_array_equal(got, whole)


# ------------------------------------------------------------------ the C export
@pytest.mark.slow
def test_the_c_module_restarts_its_window_as_the_python_filter_does(c_restarts_as_alone):
    """Exported with its grade window and compiled: on the log of two drives 12 s apart the C module's corrected roll
    rate equals GradeCarry's (NaN where it is) and its estimate KinematicGyro.run's to 1e-9 rad; and the C module's
    own estimate of drive B from the restart on equals its run of B alone."""
    log, b, _, k = _joined(12.0)
    c_restarts_as_alone(KinematicGyro(sample_rate=RATE), log, b, k, RATE)

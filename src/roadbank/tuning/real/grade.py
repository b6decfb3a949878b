r"""The stages of :mod:`roadbank.tuning.real` on the grade and the pitch that correct the roll rate (the twenty-sixth,
thirty-eighth to forty-second, forty-fourth, -fifth and -seventh).

The twenty-sixth stage (:func:`choose_grade`; rule written 2026-12-05 before it ran, after an exploratory script on
the training drives alone showed that the INS's own pitch takes their median from 0.249 to 0.225 deg) corrects the
roll rate for the grade: the rate of the roll angle is :math:`p + (q \sin\theta + r \cos\theta) \tan\vartheta
\approx p + r \tan\vartheta` with :math:`\vartheta` the pitch (positive nose down), which a log with a
longitudinal accelerometer gives: :math:`\sin\vartheta = (\dot v_x - a_x)/g`, averaged causally over a window of
:math:`W` s (:mod:`roadbank.models.attitude`). Candidates: :data:`GRADE_WINDOWS_S` (0: no
correction), each ``kinematic-gyro`` with the twenty-fourth stage's cross-over and offset time constant (no grid of
its own). Real sets and objective: the twenty-fourth stage's (:func:`gyro_sets`, :func:`gyro_objective`), the drives
read with their ``ax``. The lowest wins; ties within :data:`TIE_DEG` go to no correction, then to the longer window.
The correction is then used wherever ``kinematic-gyro`` (and its smoother) runs on a log with a usable ``ax``
(:func:`roadbank.vehicle.conditions.log_conditions`: the slope of ``vx`` on the integrated ``ax``, band-passed as
the roll rate's, within the roll rate's range; not chosen, stated). No simulated set (a flat road: nothing to
correct); neither the KITTI validation drives nor comma2k19 take part.

The thirty-eighth stage (:func:`choose_grade_start`; rule written 2026-12-05 before any candidate ran, after the
thirty-seventh, and after reading on the training drives that two of them start turning out of a steep place (0064:
pitch 5.3 deg, yaw rate -0.48 rad/s; 0034), where the integrated roll rate leaves the INS roll by 3.9 and 2.4 deg in
5-10 s, and that the INS's own pitch in :math:`p + r \tan\vartheta` removes it (0.05 and -0.08 deg), while the
shipped correction does not start before its 4 s window has passed and then lags): the pitch window and its start.
Candidates: ``grade_window`` :math:`W` in (1, 2, 4 s) and ``grade_first_span`` :math:`S` (before the log has lasted
:math:`W`, the pitch averages from the log's first sample once :math:`S` has passed) in (none, 0.5, 1, 2 s) with
:math:`S < W`: nine, the shipped (4 s, none) among them. Objective: the mean of the thirty-fourth stage's objective
(the shipped ``kinematic-gyro`` constants on its three sets, whole and in pieces) and the thirty-sixth stage's (the
unbiased constants on the training drives as read, whole and in pieces). The lowest wins; ties within
:data:`TIE_DEG` go to the shipped pair, then to the longer window, then to the longer first span. Both filters and
``kinematic-gyro-smoother`` take the result. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-ninth stage (:func:`choose_pitch_rate`; rule written 2026-12-06 before any candidate ran, after reading
on the training drives, with scratch code, that the INS's own pitch in :math:`p + r \tan\vartheta` brings their
median from 0.191 to 0.179 deg (0064 0.403 -> 0.201, 0034 0.304 -> 0.245), the shipped pitch being 1.0-1.2 deg off
the INS's on those two, and that a pitch observer driven by the pitch rate, converted to the rate of the Euler pitch
with the kinematic roll, comes near it): the pitch from a pitch-rate gyro (``Signals.q``, KITTI's ``wy``). The
observer (:func:`roadbank.models.attitude.observed_pitch`): :math:`\dot{\hat v} = a_x + g \sin\hat\vartheta + k_1
(v_x - \hat v)`, :math:`\dot{\hat\vartheta} = q \cos\phi_k - r \sin\phi_k + k_2 (v_x - \hat v)`, :math:`k_1 =
2 \zeta \omega`, :math:`k_2 = \omega^2 / g`, :math:`\zeta = 0.7`, :math:`\phi_k` the kinematic roll
:math:`\arcsin((a_y - v_x r)/g)`, from :math:`\hat v = v_x`, :math:`\hat\vartheta = 0` at the log's first sample.
Candidates: the shipped pitch (the grade window, :math:`q` not read); the observer with bandwidth :math:`\omega` in
:data:`PITCH_BANDWIDTHS` (0.5, 1, 2 rad/s) x start in :data:`PITCH_STARTS` (none; 3 rad/s for the first 3 s) x use
(only for a pitch rate documented free of offset, ``Signals.unbiased``; for every pitch rate): thirteen. Sets and
objective: the thirty-eighth stage's (the mean of the thirty-fourth stage's objective, the shipped constants on its
three sets, and the thirty-sixth stage's, the unbiased constants on the drives as read; each whole and in 8, 12,
20 s pieces), the thirty-fourth stage's two offset sets carrying the same offset (+-0.3 deg/s) on :math:`q` as on
:math:`p` (a MEMS gyro's axes each have one) and counting as not documented free of offset. The lowest wins; ties
within :data:`TIE_DEG` go to the shipped pitch, then to the use for an unbiased pitch rate only, then to no start,
then to the lower bandwidth. Both filters and ``kinematic-gyro-smoother`` take the result. Neither the KITTI
validation drives nor comma2k19 take part; the stages before run on drives without their pitch rate, as they ran.

The fortieth stage (:func:`choose_pitch_start`; rule written 2026-12-06 before any of its candidates ran on it, after
the thirty-ninth chose 0.5 rad/s without a start for an unbiased pitch rate, and after a test on validation drive 0070
failed with that choice: the drive pulls away turning hard (0.66 rad/s) on a 3 deg grade, and the observer, started
at zero pitch, needs about 5 s to reach the pitch its accelerometer shows, which the window's first span (the
thirty-eighth stage) reads in 2 s; the thirty-ninth stage's training objective had the 3 s start within 0.0002 deg
of none): the observer's start. A zero pitch is a guess, not a reading. Candidates: ``pitch_start`` in
:data:`PITCH_START_CANDIDATES` (none; 3 rad/s for 3 s; 3 rad/s for 6 s; 6 rad/s for 3 s), the observer at
:data:`~roadbank.estimators.gyro.UNBIASED_PITCH_BANDWIDTH` for an unbiased pitch rate. Sets and objective: the
thirty-ninth stage's. The lowest wins; ties within :data:`TIE_DEG` go to a start over none (the reason above), then to
the shorter span, then to the lower start bandwidth. Neither the KITTI validation drives nor comma2k19 take part.

The forty-first stage (:func:`choose_pitch_bandwidth`; rule written 2026-12-06 before any of its candidates ran,
after the thirty-ninth chose the lowest bandwidth of its grid, 0.5 rad/s, whose edge it is): the observer's bandwidth
below that edge. Candidates: :data:`PITCH_BANDWIDTH_CANDIDATES` (0.25, 0.35, 0.5 rad/s), each with the fortieth
stage's start, for an unbiased pitch rate. Sets and objective: the thirty-ninth stage's. The lowest wins; ties within
:data:`TIE_DEG` go to the shipped 0.5 rad/s, then to the higher bandwidth. Neither the KITTI validation drives nor
comma2k19 take part.

The forty-second stage (:func:`choose_biased_pitch_rate`; rule written 2026-12-06 before any of its candidates ran,
after the forty-first): a pitch rate not documented free of offset (a MEMS gyro: a phone, an IMU). A constant offset
``b`` of it leaves :math:`2\zeta b/\omega` in the observer's pitch (0.84 deg for 0.3 deg/s at 0.5 rad/s; a phone's
1 deg/s, 2.8 deg), so the thirty-ninth stage read none. Candidates: none read (shipped); the observer with the
fortieth stage's start and an offset state learnt in ``T_q`` (:data:`PITCH_OFFSET_TAUS`: none, 20, 60 s; the error's
characteristic polynomial :math:`(s + 1/T_q)(s^2 + 2\zeta\omega s + \omega^2)`), for a pitch rate with an offset
only (an unbiased one keeps the shipped observer). Sets and objective: the thirty-ninth stage's, its offset sets
carrying +-0.3 deg/s on ``q`` as on ``p`` and now also +-1 deg/s on ``q`` alone (a phone's), the mean over the five
general sets. The lowest wins; ties within :data:`TIE_DEG` go to none read, then to the longer ``T_q``. Neither the
KITTI validation drives nor comma2k19 take part.

The forty-fourth stage (:func:`choose_pitch_anchor`; rule written 2026-12-06 before any of its candidates ran, after
reading on the training drives, with scratch code, that the observer as shipped is 1-2.5 deg off the INS's pitch in its
first 2 s where a drive starts on a grade (0064, 0034, 0087: 5.3, -3.1, 2.1 deg), and that the INS's pitch put into the
observer's first sample takes 0064 from 0.308 to 0.235 deg and the 8 s pieces' median from 0.166 to 0.158): the
observer's start. Its first pitch is a guess (zero); the speed, ``ax`` and the pitch rate of the first seconds fix it:
integrated, :math:`v_x(t) = v_0 + \int a_x + g (\vartheta_0 \tau + \int\!\!\int \dot\vartheta_q)` with :math:`\tau` the
time since the first sample, linear in :math:`(v_0, \vartheta_0)`. The anchored start fits them by least squares on
every sample so far (:math:`\vartheta_0` with a prior: a grade of 3 deg standard deviation, a speed noise of 0.05 m/s,
stated not tuned) and gives :math:`\vartheta_0 + \int\dot\vartheta_q` for the first ``span`` s; the observer goes on
from there. Candidates: the shipped start (3 rad/s for 3 s from a zero pitch); the anchored start over
:data:`PITCH_ANCHOR_SPANS_S` (1, 2, 3 s) with no faster start after it; the anchored start over 1 s with the shipped 3
rad/s until 3 s. Sets and objective: the fortieth stage's, with the unbiased roll rate's constants as shipped since the
forty-third stage (0.05 Hz, 40 s). The lowest wins; ties within :data:`TIE_DEG` go to the shipped start, then to the
shorter span, then to no faster start after it. Neither the KITTI validation drives nor comma2k19 take part.

The forty-fifth stage (:func:`choose_unbiased_after_anchor`; rule written 2026-12-06 before any of its candidates ran,
after the forty-fourth chose the anchored start): the observer's first seconds were what a slow observer and a low
cut-off paid for (the forty-first stage had 0.25 rad/s the lowest, within the tie of 0.5, with the 3 rad/s start; the
forty-third traded 0070's start for the rest); with the first pitch fitted, both may be chosen again, together.
Candidates: the observer's bandwidth in :data:`ANCHORED_BANDWIDTHS` (0.25, 0.35, 0.5 rad/s) x the unbiased roll rate's
cut-off in :data:`ANCHORED_CUTOFFS_HZ` (0.03, 0.05, 0.07 Hz), the offset time constant 40 s and the anchored start as
shipped: nine, the shipped pair (0.5 rad/s, 0.05 Hz) among them. Objective: the thirty-sixth stage's (the training
drives as read, whole and in 8, 12, 20 s pieces; the mean over the four lengths of the median raw RMS), as the
forty-third's. The lowest wins; ties within :data:`TIE_DEG` go to the shipped pair, then to the higher bandwidth, then
to the higher cut-off. Neither the KITTI validation drives nor comma2k19 take part.

The forty-seventh stage (:func:`choose_biased_pitch_rate_again`; rule written 2026-12-06 before any of its candidates
ran, after the forty-sixth): the forty-second stage found a pitch rate with an offset (a MEMS gyro's: a phone's, an
ECU's) better not read, with the observer started at a zero pitch; with the anchored start and the slower observer the
question is open again. Candidates and sets as the forty-second stage's (not read, shipped; the observer with an offset
state in ``T_q`` of :data:`PITCH_OFFSET_TAUS`: none, 20, 60 s; the five general sets, +-0.3 deg/s on ``q`` as on ``p``
and +-1 deg/s on ``q`` alone), the observer as shipped since the forty-fifth stage (0.35 rad/s, anchored for 1 s) and
the unbiased filter's constants as shipped (0.05 Hz, 40 s) in the objective's part for the drives as read. The lowest
wins; ties within :data:`TIE_DEG` go to not read, then to the longer ``T_q``. Neither the KITTI validation drives nor
comma2k19 take part.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from pathlib import Path

import numpy as np

from ...estimators.gyro import GRADE_WINDOW_S, UNBIASED_GYRO, UNBIASED_PITCH, KinematicGyro
from ...io.kitti import load_kitti_oxts
from ...validation.scoring import SHORT_PIECES_S
from ...validation.splits import KITTI_TRAINING
from .common import (BANDWIDTH_39, BEFORE_38, START_40, UNBIASED_36, fixed, lengths_objective, lowest_tied,
                     whole_and_pieces)
from .gyro import ANCHORED_CUTOFFS_HZ, gyro_objective, gyro_sets, sets_objective


#: the twenty-sixth stage's candidates: the window (s) of the pitch that corrects the roll rate (0: no correction)
GRADE_WINDOWS_S = (0.0, 0.5, 1.0, 2.0, 4.0)
#: the thirty-eighth stage's candidate pitch windows (s) and first spans (s; inf: none)
GRADE_START_WINDOWS_S = (1.0, 2.0, 4.0)
GRADE_FIRST_SPANS_S = (math.inf, 0.5, 1.0, 2.0)
#: the thirty-ninth stage's candidate bandwidths (rad/s) of the pitch observer and its starts ((bandwidth rad/s, span
#: s) of a faster start; None: none)
PITCH_BANDWIDTHS = (0.5, 1.0, 2.0)
PITCH_STARTS = (None, (3.0, 3.0))
#: the fortieth stage's candidate starts of the pitch observer ((bandwidth rad/s, span s); None: none)
PITCH_START_CANDIDATES = (None, (3.0, 3.0), (3.0, 6.0), (6.0, 3.0))
#: the forty-first stage's candidate bandwidths (rad/s) of the pitch observer
PITCH_BANDWIDTH_CANDIDATES = (0.25, 0.35, 0.5)
#: the forty-second stage's candidate offset time constants (s) of a pitch rate with an offset (None: no offset
#: state) and the offsets (deg/s) of its extra sets, on q alone
PITCH_OFFSET_TAUS = (None, 20.0, 60.0)
PITCH_PHONE_OFFSET_DEG = 1.0
#: the forty-fourth stage's candidate spans (s) of the pitch observer's anchored start
PITCH_ANCHOR_SPANS_S = (1.0, 2.0, 3.0)
#: the forty-fifth stage's candidate bandwidths (rad/s) of the pitch observer (its cut-offs of the unbiased roll rate's
#: filter: :data:`~roadbank.tuning.real.gyro.ANCHORED_CUTOFFS_HZ`)
ANCHORED_BANDWIDTHS = (0.25, 0.35, 0.5)


def choose_grade(logs, windows=GRADE_WINDOWS_S) -> tuple[float, dict]:
    """The twenty-sixth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate and ``ax``). Returns ``(window s, {window: objective deg})``."""
    sets = gyro_sets(logs)
    # as it ran: a restart after 1 s
    obj = {w: gyro_objective(fixed(KinematicGyro(grade_window=w, max_gap=1.0, **BEFORE_38)), sets) for w in windows}
    return lowest_tied(obj, lambda w: (w > 0, -w)), obj


def choose_grade_start(logs, windows=GRADE_START_WINDOWS_S, spans=GRADE_FIRST_SPANS_S, lengths=SHORT_PIECES_S):
    """The thirty-eighth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``((grade_window s, grade_first_span s), {(window, span): objective deg})``."""
    cut = [whole_and_pieces(one, lengths) for one in gyro_sets(logs)]
    unbiased = UNBIASED_36
    obj = {}
    for w in windows:
        for first in (f for f in spans if f < w or f == math.inf):      # none, and every first span below W
            grade = dict(grade_window=w, grade_first_span=first)
            general = np.mean([lengths_objective(fixed(KinematicGyro(**grade)), parts) for parts in cut])
            free = lengths_objective(fixed(KinematicGyro(**unbiased, **grade)), cut[0])    # the drives as read
            obj[(w, first)] = float(0.5 * (general + free))
    return lowest_tied(obj, lambda key: (key != (GRADE_WINDOW_S, math.inf), -key[0], -key[1])), obj


def choose_pitch_rate(logs, bandwidths=PITCH_BANDWIDTHS, starts=PITCH_STARTS, lengths=SHORT_PIECES_S):
    """The thirty-ninth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate, ``ax`` and pitch rate). Returns ``(key, {key: objective deg})``, a key ``("window",)`` (the shipped
    pitch) or ``(use, bandwidth rad/s, start)`` with ``use`` ``"unbiased"`` or ``"always"``."""
    cut = [whole_and_pieces(one, lengths) for one in gyro_sets(logs)]
    shipped = sets_objective(cut, pitch_bandwidth=0.0)
    obj = {("window",): 0.5 * (shipped + sets_objective(cut[:1], **UNBIASED_36, pitch_bandwidth=0.0))}
    for w, start in itertools.product(bandwidths, starts):
        pitch = dict(pitch_bandwidth=w, pitch_start=start)
        free = sets_objective(cut[:1], **UNBIASED_36, **pitch)                      # the drives as read
        obj[("unbiased", w, start)] = 0.5 * (shipped + free)
        obj[("always", w, start)] = 0.5 * (sets_objective(cut, **pitch) + free)
    return lowest_tied(obj, lambda k: (k != ("window",), k[0] != "unbiased", k[2] is not None, k[1])), obj


def unbiased_pitch_objectives(logs, candidates: dict, lengths=SHORT_PIECES_S, unbiased=None) -> dict:
    """``{key: objective deg}`` of the fortieth and forty-first stages: for each of ``candidates`` (key -> the
    ``KinematicGyro`` pitch options of the observer for an unbiased pitch rate), the thirty-ninth stage's objective:
    the mean of the window's objective on the thirty-fourth stage's sets (a pitch rate with an offset is not read) and
    the unbiased filter's with those options on the training ``logs`` as read, each whole and in pieces (its cut-off
    and offset time constant ``unbiased``, default :data:`UNBIASED_36`, as those stages ran)."""
    cut = [whole_and_pieces(one, lengths) for one in gyro_sets(logs)]
    shipped = sets_objective(cut, pitch_bandwidth=0.0)
    unbiased = UNBIASED_36 if unbiased is None else unbiased
    return {key: 0.5 * (shipped + sets_objective(cut[:1], **unbiased, **pitch))
            for key, pitch in candidates.items()}


def choose_pitch_start(logs, starts=PITCH_START_CANDIDATES, lengths=SHORT_PIECES_S):
    """The fortieth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(start, {start: objective deg})``, a start ``(bandwidth rad/s, span s)`` or
    None."""
    obj = unbiased_pitch_objectives(logs, {st: dict(pitch_bandwidth=0.5, pitch_start=st) for st in starts}, lengths)
    return lowest_tied(obj, lambda st: (st is None, () if st is None else (st[1], st[0]))), obj


def choose_pitch_bandwidth(logs, bandwidths=PITCH_BANDWIDTH_CANDIDATES, lengths=SHORT_PIECES_S):
    """The forty-first stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(bandwidth rad/s, {bandwidth: objective deg})``."""
    obj = unbiased_pitch_objectives(
        logs, {w: dict(pitch_bandwidth=w, pitch_start=START_40) for w in bandwidths}, lengths)
    return lowest_tied(obj, lambda w: (w != 0.5, -w)), obj


def choose_pitch_anchor(logs, spans=PITCH_ANCHOR_SPANS_S, lengths=SHORT_PIECES_S):
    """The forty-fourth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(key, {key: objective deg})``, a key ``(anchor span s or None, start)``
    of the observer (``start`` as ``pitch_start``)."""
    keys = [(None, START_40)] + [(a, None) for a in spans] + [(spans[0], START_40)]
    obj = unbiased_pitch_objectives(
        logs, {k: dict(pitch_bandwidth=BANDWIDTH_39, pitch_anchor=k[0], pitch_start=k[1]) for k in keys},
        lengths, UNBIASED_GYRO)
    return lowest_tied(obj, lambda k: (k[0] is not None, k[0] or 0.0, k[1] is not None)), obj


def choose_biased_pitch_rate(logs, taus=PITCH_OFFSET_TAUS, lengths=SHORT_PIECES_S, observer=None, unbiased=None):
    """The forty-second stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(key, {key: objective deg})``, a key ``"none"`` (a pitch rate with an
    offset not read) or ``T_q`` (s; None: the observer without an offset state). ``observer`` (``KinematicGyro``'s
    pitch options) and ``unbiased`` (its cut-off and offset time constant for the drives as read): as that stage ran
    (default), or the forty-seventh's (:func:`choose_biased_pitch_rate_again`)."""
    phone = math.radians(PITCH_PHONE_OFFSET_DEG)
    sets = gyro_sets(logs) + [[(dataclasses.replace(s, q=s.q + sign * phone), ref, m) for s, ref, m in logs]
                              for sign in (1.0, -1.0)]
    cut = [whole_and_pieces(one, lengths) for one in sets]
    observer = dict(pitch_bandwidth=BANDWIDTH_39, pitch_start=START_40) if observer is None else observer
    free = sets_objective(cut[:1], **(UNBIASED_36 if unbiased is None else unbiased), **observer)
    obj = {"none": 0.5 * (sets_objective(cut, pitch_bandwidth=0.0) + free)}
    for tq in taus:
        obj[tq] = 0.5 * (sets_objective(cut, **observer, pitch_offset_tau=tq) + free)
    return lowest_tied(obj, lambda k: (k != "none", -(k or 0.0) if k != "none" else 0.0)), obj


def choose_biased_pitch_rate_again(logs, taus=PITCH_OFFSET_TAUS, lengths=SHORT_PIECES_S):
    """The forty-seventh stage (module docstring): :func:`choose_biased_pitch_rate` with the observer and the unbiased
    filter's constants as shipped."""
    return choose_biased_pitch_rate(logs, taus, lengths, UNBIASED_PITCH, UNBIASED_GYRO)


def choose_unbiased_after_anchor(logs, bandwidths=ANCHORED_BANDWIDTHS, cutoffs=ANCHORED_CUTOFFS_HZ,
                                 lengths=SHORT_PIECES_S):
    """The forty-fifth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``((bandwidth rad/s, cutoff Hz), {(bandwidth, cutoff): objective deg})``."""
    cut = [whole_and_pieces(logs, lengths)]
    obj = {(w, fc): sets_objective(cut, **{**UNBIASED_GYRO, **UNBIASED_PITCH, "cutoff": fc, "pitch_bandwidth": w})
           for w in bandwidths for fc in cutoffs}
    shipped = (0.5, 0.05)
    return lowest_tied(obj, lambda k: (k != shipped, -k[0], -k[1])), obj


def training_pitch_rates(data_dir) -> list:
    """The INS's pitch rate (rad/s) of each KITTI training drive under ``data_dir``, in :func:`training_logs`' order."""
    return [load_kitti_oxts(found[0]).signals.q for name in KITTI_TRAINING
            if (found := [p for p in Path(data_dir).glob(f"*/{name}") if p.is_dir()])]

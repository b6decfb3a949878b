r"""The stages of :mod:`roadbank.tuning.real` on the roll-rate filter ``kinematic-gyro`` (the twenty-fourth, -fifth,
-seventh to -ninth, thirty-fourth to -seventh, forty-third, forty-sixth and forty-eighth).

The twenty-fourth stage (:func:`choose_gyro`; rule written 2026-12-05 before any candidate ran) is for a log that
carries a roll rate (:attr:`roadbank.Signals.p`: an INS, a phone, a six-axis IMU), which no stage before read. It
chooses the cross-over and the offset time constant of ``kinematic-gyro`` (:mod:`roadbank.estimators.gyro`) over
:data:`GYRO_CUTOFFS_HZ` x :data:`GYRO_BIAS_TAUS` (0: no offset state), and then whether ``kinematic-gyro`` is the
default on such a log. Real sets (:func:`gyro_sets`): the KITTI training drives as read (the INS compensates its
gyro's offset) and the same drives with a constant roll-rate offset of +:data:`GYRO_OFFSET_DEG` and of
-:data:`GYRO_OFFSET_DEG` deg/s added (a MEMS gyro's, the range the campaign draws for the yaw rate). Objective: the
mean over the three sets of the median raw RMS (the scoring of every stage). The lowest wins; ties within
:data:`TIE_DEG` go to fewer states (no offset state), then to the longer offset time constant, then to the lower
cross-over (the smoother filter). ``kinematic-gyro`` as chosen is then the default on a log with a roll rate if its
objective is lower than that of the default as shipped (``kinematic-pif`` designed for each log, which reads no roll
rate, so its three medians are one). No simulated set takes part: ``roadbank tune``'s drives last 15-25 s, shorter
than an offset can be learnt in, and their sensors are an ESP cluster's. Neither the KITTI validation drives nor
comma2k19 take part.

The twenty-fifth stage (:func:`choose_gyro_map`; rule written 2026-12-05 before it ran, after the twenty-fourth was
committed) asks the same of ``roadbank map``'s default: whether on a loud log with a roll rate it is
``kinematic-gyro-smoother`` (``kinematic-gyro`` forward and backward, averaged; the twenty-fourth stage's cross-over
and offset time constant, no grid of its own), by the twenty-fourth stage's objective on its three real sets,
against the map's default as shipped (``kinematic-smoother`` built for each log, without the roll rate).

The twenty-seventh stage (:func:`choose_gyro_stops`; rule written 2026-12-05 before any candidate ran) asks how
``kinematic-gyro`` passes a stop. As shipped it stops below ``v_min`` = 1 m/s like the kinematic family, and a gap
of more than ``max_gap`` = 1 s between usable samples restarts it from one sample of the kinematic estimate with no
offset learnt: after every stop at a traffic light. At rest the kinematic estimate is ``ay/g`` alone (no cornering,
no road vibration) and the gyro reads its offset, so the filter may run through a stop (``v_min`` 0.05 m/s; the rule
said 0, amended before any candidate ran when the estimators refused a ``v_min`` of 0; a speed at rest that reads
below it, an INS's -0.1 m/s, is still held); or it may hold
its state through a stop and go on from it (a longer ``max_gap``: a car at rest keeps its roll). Candidates:
:data:`GYRO_V_MINS` x :data:`GYRO_MAX_GAPS`, ``kinematic-gyro`` with the twenty-fourth to twenty-sixth stages'
constants; the twenty-fourth stage's real sets and objective (the drives with their ``ax``). The lowest wins; ties
within :data:`TIE_DEG` go to the shipped pair (1 m/s, 1 s), then to the higher ``v_min``, then to the shorter
``max_gap``. ``kinematic-gyro-smoother`` takes the same pair (its forward and backward passes are that filter).
Neither the KITTI validation drives nor comma2k19 take part.

The twenty-eighth stage (:func:`choose_gyro_order`; rule written 2026-12-05 before any candidate ran) asks for the
order of ``kinematic-gyro``'s complementary filter. On the training drives as read, its error above 0.5 Hz is
0.09-0.21 deg: the road's vibration in the kinematic estimate, which the shipped filter (order 2) passes falling at
20 dB a decade above its cross-over. Order 4 puts all four poles at :math:`\omega = 2\pi f`: the kinematic
estimate's path :math:`(6\omega^2 s^2 + 4\omega^3 s + \omega^4)/(s + \omega)^4` falls at 40 dB a decade, and
the roll rate's path :math:`s^2 (s + 4\omega)/(s + \omega)^4` (its complement over :math:`s`) still rejects a
constant gyro offset. Candidates: the shipped filter, and order 4 at each :math:`f` of
:data:`GYRO_ORDER4_CUTOFFS_HZ`; the grade correction and the stop handling as shipped; the twenty-fourth stage's
real sets and objective. The lowest wins; ties within :data:`TIE_DEG` go to the shipped filter, then to the lower
:math:`f`. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor comma2k19 take part.

The twenty-ninth stage (:func:`choose_gyro_sideslip`; rule written 2026-12-05 before any candidate ran) asks whether
``kinematic-gyro`` takes the sideslip acceleration out of the kinematic estimate. :math:`k = \sin\theta +
\dot v_y / g`, and the gyro does not see :math:`\dot v_y`, so what of it the kinematic estimate's path passes is
error, largest at turn entries in town (:math:`L_r \dot r` of 0.3 m/s^2 is 1.7 deg in :math:`k`). The rear axle's
quasi-static balance gives it without steering: :math:`v_y = L_r r - c\, v_x a_y`, :math:`c = m L_f / (C_r L)`, so
:math:`\dot v_y \approx L_r \dot r - c\, v_x \dot a_y` (:math:`v_x` the schedule, held), with the car the
estimator is built for (a log's fitted car, as the command line builds it). Candidates: ``"none"`` (shipped),
``"geometry"`` (:math:`L_r \dot r` alone, :math:`c = 0`), ``"quasi-static"`` (both terms); the earlier stages'
constants; the twenty-fourth stage's real sets and objective, each drive's estimator built for its own fitted car
(:func:`roadbank.vehicle.undescribed_params`). The lowest wins; ties within :data:`TIE_DEG` go to ``"none"``, then
``"geometry"``. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor comma2k19 take
part.

The thirty-fourth stage (:func:`choose_gyro_start`; rule written 2026-12-05 before any candidate ran, after reading on
the training drives that the gyro filter's offset state absorbs part of its start error: their first 8 s score 0.256
with it and 0.193 without it, bias_tau 0, whole drives 0.229 and 0.221 as read; the twenty-fourth stage kept the
offset state for gyros that have an offset): the offset state held at zero for the first ``start_hold`` seconds after
the log's first valid sample, learning after. Candidates: ``start_hold`` in :data:`GYRO_START_HOLDS_S` (0, shipped;
2, 5, 10 s). Sets: the twenty-fourth stage's three (the training drives as read and with a roll-rate offset of
+-0.3 deg/s), each whole and cut into the thirty-second stage's pieces (8, 12, 20 s, each run from a reset, the
KITTI scoring within it). Estimator: ``kinematic-gyro`` with the shipped constants and the grade window (as the
twenty-sixth to twenty-ninth stages ran it). Objective: the mean over the three sets of the mean over the four
lengths (whole, 8, 12, 20 s) of the median raw RMS. The lowest wins; ties within :data:`TIE_DEG` go to the shorter
hold. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-fifth stage (:func:`choose_gyro_kalman_start`; rule written 2026-12-05 before any candidate ran, after the
thirty-fourth kept learning the offset from the start, and after reading on validation drive 0070 only that the start's
Kalman filter runs and that its offset moves faster early than the shipped filter's: 0.84 against 0.27 deg/s at 4 s,
with the prior 0.3 deg/s; no error against its INS was computed): the start as the Kalman filter of the complementary
filter's own model (:mod:`roadbank.estimators.gyro_start`: the state after each sample that filter's for ``start_span``
s after each (re)start; its steady state is the shipped filter). Candidates: none (``start_span`` 0, shipped); and
``start_span`` :data:`GYRO_START_SPAN_CANDIDATE_S` (20 s, 2 T_b: by then the start filter's gains are within 4 % of
their steady values at 10 Hz for every prior here) with the offset's prior ``start_offset`` in
:data:`GYRO_START_OFFSETS_DEG` (0.03, 0.1, 0.3, 1 deg/s; the noise per sample fixed at 1 deg, only the ratio matters).
Sets, pieces, estimator and objective: the thirty-fourth stage's. The lowest wins; ties within :data:`TIE_DEG` go to
none, then to the smaller prior. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor
comma2k19 take part.

The thirty-sixth stage (:func:`choose_unbiased_gyro`; rule written 2026-12-05 before any candidate ran, after the
thirty-fifth kept the steady start, knowing from the thirty-fourth's rule that on the training drives as read the
filter without an offset state scores 0.193 deg on their first 8 s against 0.256, whole drives 0.221 against 0.229):
a roll rate whose source documents it as free of offset. KITTI's OXTS files are the outputs of an RT3003 INS, whose
own Kalman filter applies its gyro bias and scale-factor corrections to the angular rates it outputs (and its bias
corrections to the accelerations; the RT3000 manual); the reader of those files says so (``Signals.unbiased``), a
phone's raw gyro (comma2k19) or a user's map does not. For such a roll rate the twenty-fourth stage's guard against
an offset (its sets with +-0.3 deg/s added) does not apply. Candidates: the twenty-fourth stage's grid
(:data:`GYRO_CUTOFFS_HZ` x :data:`GYRO_BIAS_TAUS`, bias_tau 0: no offset state), the shipped pair among them.
Estimator: ``kinematic-gyro`` with the grade window (as the thirty-fourth stage ran it). Set: the training drives as
read, whole and cut into the thirty-second stage's pieces (8, 12, 20 s, each from a reset). Objective: the mean over
the four lengths of the median raw RMS. The lowest wins; ties within :data:`TIE_DEG` go to the shipped pair, then to
the longer ``bias_tau`` (an offset state guards against a source that is wrong about itself), then to the higher
cut-off. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-seventh stage (:func:`choose_unbiased_start`; rule written 2026-12-05 before any candidate ran, after the
thirty-sixth chose 0.07 Hz and 40 s for such a roll rate, and after a test on the first 10 s of validation drive 0070
showed that filter keeping most of a 0.8 deg start error through those 10 s, 0.41 deg against the ESP default's 0.26):
the start of the filter for a roll rate documented free of offset. Candidates: none (shipped); the thirty-fifth
stage's Kalman start with ``start_span`` 2 T_b (80 s) and the offset's prior ``start_offset`` in
:data:`UNBIASED_START_OFFSETS_DEG` (0.03, 0.1, 0.3 deg/s). Estimator: ``kinematic-gyro`` with the thirty-sixth
stage's constants and the grade window. Set, pieces and objective: the thirty-sixth stage's (the training drives as
read, whole and in 8, 12, 20 s pieces). The lowest wins; ties within :data:`TIE_DEG` go to none, then to the smaller
prior. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor comma2k19 take part.

The forty-third stage (:func:`choose_unbiased_gyro_again`; rule written 2026-12-06 before any of its candidates ran,
after the forty-second): the thirty-sixth stage's constants for an unbiased roll rate were chosen with the window's
pitch; with the observer's, the roll rate's grade error is smaller and a lower cut-off may pay. Candidates: the
cut-offs :data:`UNBIASED_CUTOFFS_AGAIN_HZ` (0.03, 0.05, 0.07, 0.1 Hz) x offset time constants
:data:`UNBIASED_TAUS_AGAIN_S` (20, 40, 80 s), the shipped pair among them, each with the observer as shipped.
Objective: the thirty-sixth stage's (the training drives as read, whole and in 8, 12, 20 s pieces; the mean over the
four lengths of the median raw RMS). The lowest wins; ties within :data:`TIE_DEG` go to the shipped pair, then to the
longer time constant, then to the higher cut-off. Neither the KITTI validation drives nor comma2k19 take part.

The forty-sixth stage (:func:`choose_unbiased_offset_again`; rule written 2026-12-06 before any of its candidates ran,
after the forty-fifth, and after reading on the training drives, with scratch code, that the shipped filter stays 0.2
deg below the INS roll on 0064 for 40 s after its start while the kinematic estimate low-passed at 0.05 Hz does not, and
that the whole drives' median at 0.05 Hz is 0.1632 deg without an offset state, 0.1658 with the shipped 40 s, 0.1638
with 160 s: the offset state learns the start's error and keeps it): the unbiased roll rate's offset state again, with
its cut-off. Candidates: the offset time constant in :data:`ANCHORED_BIAS_TAUS_S` (0: no offset state, 40, 80, 160 s) x
the cut-off in :data:`ANCHORED_CUTOFFS_HZ` (0.03, 0.05, 0.07 Hz), the observer as shipped: twelve, the shipped pair
(0.05 Hz, 40 s) among them. Objective: the thirty-sixth stage's (the training drives as read, whole and in 8, 12, 20 s
pieces; the mean over the four lengths of the median raw RMS). The lowest wins; ties within :data:`TIE_DEG` go to the
shipped pair, then to the longer offset time constant (none last: an offset state guards against a source that is wrong
about itself, as the thirty-sixth stage's order has it), then to the higher cut-off. Neither the KITTI validation drives
nor comma2k19 take part.

The forty-eighth stage (:func:`choose_log_gaps`; rule written 2026-12-06 before any of its candidates ran on training
data, and after an exploratory test of bad input had shown, on copies of validation drive 2011_10_03_drive_0047 with
the time stamps after frame 400 moved 1.5-8 s later or 50 frames removed, the default jumping by 0.3-0.7 deg at the gap
and a scratch comparison of the three candidates on those copies had been seen: hold best there, restart worst with
frames removed): what ``kinematic-gyro`` does across an interval of the log longer than
:data:`~roadbank.constants.MAX_GAP_S` (1 s) and at most its ``max_gap`` (10 s), where no sample, so no roll rate, was
read. Candidates (:data:`~roadbank.estimators.gyro.LOG_GAPS`): ``"trapezoid"`` (shipped: the roll rate taken linear
between the samples either side, as across any interval), ``"hold"`` (the state and the grade's pitch carried over,
as if the gap were one ordinary interval), ``"restart"`` (the filter starts again after the gap). Sets
(:func:`gap_sets`): the KITTI training drives with samples removed while driving: gaps of each length in
:data:`GAP_LENGTHS_S` (2 and 5 s), one starting at each of the scored samples at 25, 50 and 75 % of the drive's
scored samples (a gap that would start inside an earlier one is left out); each as read (an INS's roll rate, free of
offset) and with a constant roll-rate offset of +:data:`GYRO_OFFSET_DEG` and -:data:`GYRO_OFFSET_DEG` deg/s added (no
longer documented free of offset: a MEMS gyro's). Estimator: the default as ``roadbank estimate`` builds it for each
log (``kinematic-pif``, which is ``kinematic-gyro`` on these loud logs with a roll rate), with the candidate's
``log_gaps``. Objective: the mean over the six sets of the median raw RMS on the scored samples left. The lowest wins;
ties within :data:`TIE_DEG` go to ``"trapezoid"``, then ``"hold"``. The training drives as read have no interval
longer than 1 s, so every candidate gives them what it gave before. ``kinematic-gyro-smoother`` takes the result.
Neither the KITTI validation drives nor comma2k19 take part.

The forty-ninth stage (:func:`choose_smoother_passes`; rule written 2026-12-06 before any of its candidates ran, after
an exploratory test had shown ``roadbank map`` keeping 129 of validation drive 2011_09_26_drive_0070's 420 samples, the
gyro-aided smoother settling 26.9 s after a start, and the unsettled samples after 5 s there no further from the INS
roll than the settled ones): how ``kinematic-gyro-smoother`` (``roadbank map``'s default on a loud log with a roll
rate) combines its two passes where one has settled since its (re)start and the other has not. Candidates
(:data:`~roadbank.estimators.gyro.SMOOTHER_PASSES`): ``"average"`` (shipped: the mean wherever both are valid) and
``"settled"`` (the settled pass alone there; the mean elsewhere). Sets: the twenty-fourth stage's (:func:`gyro_sets`:
the training drives as read and with +-:data:`GYRO_OFFSET_DEG` deg/s). Estimator: the map's default as ``roadbank map``
builds it for each log (``kinematic-smoother``, which is ``kinematic-gyro-smoother`` on these logs) with the
candidate's ``passes``. Objective: the twenty-fourth stage's (the mean over the three sets of the median raw RMS).
The lowest wins; ties within :data:`TIE_DEG` go to ``"average"``. The share of valid samples that count as settled
(what the map keeps) is reported, not judged. Pieces of 8-20 s are not a set: both passes are unsettled throughout
them, where the candidates agree. Neither the KITTI validation drives nor comma2k19 take part. It ran once:
``"average"`` 0.2245 deg, ``"settled"`` 0.2668 deg (settled shares 0.72 and 0.95): the mean of the two passes,
unsettled as one of them is, stays closer to the INS roll than the settled pass alone (each pass's lag and offset loop
leave a phase error that the mean cancels), so ``"average"`` stays. Whether ``roadbank map`` should keep the mean's
samples where either pass has settled (a question of the flag, not of the estimate) is not decided here.

The fiftieth stage (:func:`choose_smoother_settled`; rule written 2026-12-06 after the forty-ninth had run, before any
of its candidates ran): which samples of ``kinematic-gyro-smoother`` count as settled, the samples ``roadbank map``
keeps. Candidates (:data:`~roadbank.estimators.gyro.SMOOTHER_SETTLED`): ``"forward"`` (shipped: where the forward pass
has settled since its (re)start) and ``"either"`` (where either pass has); the estimate the mean of the passes in both
(the forty-ninth stage). Sets, estimator and build: the forty-ninth stage's. For each candidate and set: the raw RMS of
each drive's scored samples that the candidate counts settled (a drive with none left out), the median over the
drives; the candidate's objective the mean over the three sets; the share of the scored samples it keeps is reported.
``"either"`` wins where its objective is at most ``"forward"``'s plus :data:`TIE_DEG` (it keeps more of each drive for
no more error); else ``"forward"`` stays. Neither the KITTI validation drives nor comma2k19 take part. It ran once:
``"forward"`` 0.1928 deg on 74 % of the scored samples, ``"either"`` 0.2364 deg on 95 %: the samples the forward pass
has not settled on are worse on the training drives (the mean carries half of its start), so ``"forward"`` stays.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import warnings

import numpy as np

from ... import vehicle
from ...estimators.gyro import (GAPS_OF, GRADE_WINDOW_S, GYRO_BIAS_TAU_S, GYRO_CUTOFF_HZ, LOG_GAPS, SMOOTHER_PASSES,
                               SMOOTHER_SETTLED, UNBIASED_PITCH, KinematicGyro, KinematicGyroSmoother)
from ...estimators.offsets import with_online_offsets
from ...validation.scoring import SHORT_PIECES_S
from .common import (BANDWIDTH_39, BEFORE_38, BEFORE_64, START_40, TIE_DEG, UNBIASED_36, fixed, lengths_objective,
                     log_errors, lowest_tied, per_log, rms_deg, whole_and_pieces, within, without_roll_rate)


#: the twenty-ninth stage's candidates: the sideslip acceleration ``kinematic-gyro`` takes out of the kinematic estimate
GYRO_SIDESLIPS = ("none", "geometry", "quasi-static")
#: the twenty-eighth stage's candidates: the frequency (Hz) of the four poles of an order-4 ``kinematic-gyro``
GYRO_ORDER4_CUTOFFS_HZ = (0.05, 0.07, 0.1, 0.15, 0.2, 0.3)
#: the twenty-seventh stage's candidates: ``kinematic-gyro``'s ``v_min`` (m/s) and ``max_gap`` (s)
GYRO_V_MINS = (1.0, 0.05)
GYRO_MAX_GAPS = (1.0, 10.0, 60.0)
#: the twenty-fourth stage's grid: ``kinematic-gyro``'s cross-over (Hz) and offset time constant (s; 0: none),
#: and the roll-rate offset (deg/s) added to the training drives
GYRO_CUTOFFS_HZ = (0.03, 0.05, 0.07, 0.1, 0.15, 0.2, 0.3)
GYRO_BIAS_TAUS = (0.0, 10.0, 20.0, 40.0, 80.0)
GYRO_OFFSET_DEG = 0.3
#: the thirty-fourth stage's candidate holds (s) of the offset state after a log's start, the shipped first
GYRO_START_HOLDS_S = (0.0, 2.0, 5.0, 10.0)
#: the thirty-fifth stage's candidates: the span (s) of the start's Kalman filter and its priors of the roll rate's
#: offset (deg/s)
GYRO_START_SPAN_CANDIDATE_S = 20.0
GYRO_START_OFFSETS_DEG = (0.03, 0.1, 0.3, 1.0)
#: the thirty-seventh stage's candidate priors (deg/s) of the start's Kalman filter for an unbiased roll rate
UNBIASED_START_OFFSETS_DEG = (0.03, 0.1, 0.3)
#: the forty-third stage's candidate cut-offs (Hz) and offset time constants (s) of the unbiased roll rate's filter
UNBIASED_CUTOFFS_AGAIN_HZ = (0.03, 0.05, 0.07, 0.1)
UNBIASED_TAUS_AGAIN_S = (20.0, 40.0, 80.0)
#: the forty-eighth stage's gap lengths (s) and where in a drive's scored samples each gap starts (fractions)
GAP_LENGTHS_S = (2.0, 5.0)
GAP_PLACES = (0.25, 0.5, 0.75)
#: the forty-fifth and forty-sixth stages' candidate cut-offs (Hz) of the unbiased roll rate's filter
ANCHORED_CUTOFFS_HZ = (0.03, 0.05, 0.07)
#: the forty-sixth stage's candidate offset time constants (s; 0: no offset state) of the unbiased roll rate's filter
ANCHORED_BIAS_TAUS_S = (0.0, 40.0, 80.0, 160.0)


def gyro_sets(logs, offset_deg: float | None = None) -> list[list]:
    """The twenty-fourth stage's real sets: ``logs`` (:func:`training_logs`) as read, and with a constant roll-rate
    offset of +``offset_deg`` and of -``offset_deg`` (deg/s; default :data:`GYRO_OFFSET_DEG`) added to ``p`` (and to
    ``q`` where the logs have one, the thirty-ninth stage's)."""
    off = math.radians(GYRO_OFFSET_DEG if offset_deg is None else offset_deg)
    return [logs] + [[(dataclasses.replace(s, p=s.p + sign * off, q=None if s.q is None else s.q + sign * off), ref, m)
                      for s, ref, m in logs] for sign in (1.0, -1.0)]


def gyro_objective(build, sets) -> float:
    """The twenty-fourth stage's objective (deg): the mean over ``sets`` (:func:`gyro_sets`) of the median raw RMS
    of the estimator ``build(signals)`` makes."""
    return float(np.mean([np.median(log_errors(build, logs)) for logs in sets]))


def choose_gyro(logs, cutoffs=GYRO_CUTOFFS_HZ, bias_taus=GYRO_BIAS_TAUS) -> tuple:
    """The twenty-fourth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate). Returns
    ``((cutoff Hz, bias_tau s), {(cutoff, bias_tau): objective}, default objective, gyro is the default)``."""
    sets = gyro_sets(logs)
    # as it ran: the roll rate not corrected for the grade, a restart after 1 s (the later stages came after)
    obj = {(fc, bt): gyro_objective(fixed(KinematicGyro(cutoff=fc, bias_tau=bt, grade_window=0.0, max_gap=1.0)), sets)
           for fc, bt in itertools.product(cutoffs, bias_taus)}
    chosen = lowest_tied(obj, lambda k: (k[1] > 0, -k[1], k[0]))
    shipped = gyro_objective(per_log("kinematic-pif"), [without_roll_rate(logs)])   # the default as it ran
    return chosen, obj, shipped, obj[chosen] < shipped


def choose_gyro_map(logs) -> tuple[float, float, bool]:
    """The twenty-fifth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate). Returns ``(kinematic-gyro-smoother's objective, the shipped map default's, the first is the default)``."""
    sets = gyro_sets(logs)
    smoother = gyro_objective(fixed(KinematicGyroSmoother(grade_window=0.0, max_gap=1.0)), sets)   # as it ran
    shipped = gyro_objective(within(per_log("kinematic-smoother"), **BEFORE_64), [without_roll_rate(logs)])
    return smoother, shipped, smoother < shipped


def choose_gyro_stops(logs, v_mins=GYRO_V_MINS, max_gaps=GYRO_MAX_GAPS) -> tuple[tuple[float, float], dict]:
    """The twenty-seventh stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``((v_min m/s, max_gap s), {(v_min, max_gap): objective deg})``."""
    sets = gyro_sets(logs)
    obj = {(v, gap): gyro_objective(fixed(KinematicGyro(v_min=v, max_gap=gap, **BEFORE_38)), sets)
           for v, gap in itertools.product(v_mins, max_gaps)}
    return lowest_tied(obj, lambda k: (k != (v_mins[0], max_gaps[0]), -k[0], k[1])), obj


def choose_gyro_order(logs, cutoffs=GYRO_ORDER4_CUTOFFS_HZ) -> tuple[tuple[int, float], dict]:
    """The twenty-eighth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate and ``ax``). Returns ``((order, cutoff Hz), {(order, cutoff): objective deg})``."""
    sets = gyro_sets(logs)
    shipped = (2, GYRO_CUTOFF_HZ)
    cands = [shipped] + [(4, fc) for fc in cutoffs]
    obj = {(o, fc): gyro_objective(fixed(KinematicGyro(order=o, cutoff=fc, **BEFORE_38)), sets) for o, fc in cands}
    return lowest_tied(obj, lambda k: (k != shipped, k[1])), obj


def choose_gyro_sideslip(logs, modes=GYRO_SIDESLIPS) -> tuple[str, dict]:
    """The twenty-ninth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate and ``ax``), each drive's filter built for its fitted car. Returns ``(mode, {mode: objective deg})``."""
    sets = gyro_sets(logs)
    cars = {}
    for s, _, _ in logs:             # the fitted car reads the ESP channels: the same for the three sets' drives
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            cars[id(s.ay)] = vehicle.undescribed_params(s)

    def build(mode):
        return lambda signals: KinematicGyro(cars[id(signals.ay)], sideslip=mode, **BEFORE_38)
    obj = {mode: gyro_objective(build(mode), sets) for mode in modes}
    return lowest_tied(obj, modes.index), obj


def choose_gyro_start(logs, holds=GYRO_START_HOLDS_S, lengths=SHORT_PIECES_S) -> tuple[float, dict]:
    """The thirty-fourth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``(start_hold s, {start_hold: objective deg})``."""
    cut = [whole_and_pieces(one, lengths) for one in gyro_sets(logs)]
    obj = {hold: float(np.mean([lengths_objective(fixed(KinematicGyro(grade_window=GRADE_WINDOW_S, start_hold=hold,
                                                                      **BEFORE_38)), parts) for parts in cut]))
           for hold in holds}
    return lowest_tied(obj, holds.index), obj


def choose_gyro_kalman_start(logs, offsets=GYRO_START_OFFSETS_DEG, lengths=SHORT_PIECES_S) -> tuple:
    """The thirty-fifth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``(start_offset deg/s or None for no Kalman start, {start_offset or None:
    objective deg})``."""
    cut = [whole_and_pieces(one, lengths) for one in gyro_sets(logs)]
    obj = {}
    for off in (None, *offsets):
        opts = {} if off is None else {"start_span": GYRO_START_SPAN_CANDIDATE_S, "start_offset": math.radians(off)}
        build = fixed(KinematicGyro(grade_window=GRADE_WINDOW_S, **opts, **BEFORE_38))
        obj[off] = float(np.mean([lengths_objective(build, parts) for parts in cut]))
    return lowest_tied(obj, list(obj).index), obj


def choose_unbiased_gyro(logs, cutoffs=GYRO_CUTOFFS_HZ, bias_taus=GYRO_BIAS_TAUS, lengths=SHORT_PIECES_S) -> tuple:
    """The thirty-sixth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``((cutoff Hz, bias_tau s), {(cutoff, bias_tau): objective deg})``."""
    parts = whole_and_pieces(logs, lengths)
    obj = {(fc, bt): lengths_objective(fixed(KinematicGyro(cutoff=fc, bias_tau=bt, grade_window=GRADE_WINDOW_S,
                                                           **BEFORE_38)), parts)
           for fc in cutoffs for bt in bias_taus}
    shipped = (GYRO_CUTOFF_HZ, GYRO_BIAS_TAU_S)
    return lowest_tied(obj, lambda key: (key != shipped, -key[1], -key[0])), obj


def choose_unbiased_start(logs, offsets=UNBIASED_START_OFFSETS_DEG, lengths=SHORT_PIECES_S) -> tuple:
    """The thirty-seventh stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``(start_offset deg/s or None for no Kalman start, {start_offset or None:
    objective deg})``."""
    parts = whole_and_pieces(logs, lengths)
    base = dict(**UNBIASED_36, grade_window=GRADE_WINDOW_S)
    obj = {}
    for off in (None, *offsets):
        opts = {} if off is None else {"start_span": 2.0 * UNBIASED_36["bias_tau"], "start_offset": math.radians(off)}
        obj[off] = lengths_objective(fixed(KinematicGyro(**base, **opts, **BEFORE_38)), parts)
    return lowest_tied(obj, list(obj).index), obj


def choose_unbiased_gyro_again(logs, cutoffs=UNBIASED_CUTOFFS_AGAIN_HZ, taus=UNBIASED_TAUS_AGAIN_S,
                               lengths=SHORT_PIECES_S):
    """The forty-third stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``((cutoff Hz, bias_tau s), {(cutoff, bias_tau): objective deg})``."""
    cut = [whole_and_pieces(logs, lengths)]
    observer = dict(pitch_bandwidth=BANDWIDTH_39, pitch_start=START_40)
    obj = {(fc, bt): sets_objective(cut, cutoff=fc, bias_tau=bt, **observer) for fc in cutoffs for bt in taus}
    shipped = (UNBIASED_36["cutoff"], UNBIASED_36["bias_tau"])
    return lowest_tied(obj, lambda k: (k != shipped, -k[1], -k[0])), obj


def choose_unbiased_offset_again(logs, taus=ANCHORED_BIAS_TAUS_S, cutoffs=ANCHORED_CUTOFFS_HZ,
                                 lengths=SHORT_PIECES_S):
    """The forty-sixth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``((cutoff Hz, bias_tau s), {(cutoff, bias_tau): objective deg})``."""
    cut = [whole_and_pieces(logs, lengths)]
    obj = {(fc, bt): sets_objective(cut, cutoff=fc, bias_tau=bt, **UNBIASED_PITCH) for fc in cutoffs for bt in taus}
    shipped = (0.05, 40.0)
    return lowest_tied(obj, lambda k: (k != shipped, -k[1], -k[0])), obj


def sets_objective(cut, **options) -> float:
    """The mean over ``cut`` (sets, each cut by :func:`whole_and_pieces`) of :func:`lengths_objective` of
    ``KinematicGyro(**options)`` (deg): the thirty-ninth to forty-second stages' parts."""
    return float(np.mean([lengths_objective(fixed(KinematicGyro(**options)), parts) for parts in cut]))


def with_gaps(s, ref, m, length: float, places=GAP_PLACES) -> tuple:
    """``(signals, reference roll, scored mask)`` of one training drive with samples removed: a gap of ``length`` s
    starting at each scored sample at ``places`` (fractions of its scored samples), one that would start inside an
    earlier gap left out (the forty-eighth stage)."""
    scored = np.flatnonzero(m)
    keep = np.ones(len(s), dtype=bool)
    end = -math.inf
    for frac in places:
        k = scored[int(frac * (len(scored) - 1))]
        if s.t[k] < end:
            continue
        end = s.t[k] + length
        keep &= ~((s.t >= s.t[k]) & (s.t < end))
    kept = dataclasses.replace(s, **{c: getattr(s, c)[keep] for c in s.channels})
    return kept, ref[keep], m[keep]


def gap_sets(logs, lengths=GAP_LENGTHS_S) -> list[list]:
    """The forty-eighth stage's sets (module docstring): for each gap length, the drives with their gaps, as read and
    with the roll-rate offset of :func:`gyro_sets` (those no longer marked free of offset)."""
    out = []
    for length in lengths:
        cut = [with_gaps(s, ref, m, length) for s, ref, m in logs]
        as_read, *offset = gyro_sets(cut)
        out += [as_read] + [[(dataclasses.replace(s, unbiased=frozenset()), ref, m) for s, ref, m in one]
                            for one in offset]
    return out


def choose_log_gaps(logs, modes=LOG_GAPS) -> tuple[str, dict]:
    """The forty-eighth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(mode, {mode: objective deg})``."""
    sets = gap_sets(logs)
    obj = {mode: gyro_objective(per_log_with("kinematic-pif", KinematicGyro, log_gaps=mode), sets) for mode in modes}
    return lowest_tied(obj, list(modes).index), obj


def per_log_with(name: str, cls, **options):
    """``build``: ``name`` designed for each log as the command line does (:func:`per_log`), with ``options`` set on
    it where it is a ``cls`` (the candidate of a stage: the default is that class on the logs with a roll rate)."""
    default = per_log(name)

    def one(signals):
        est = default(signals)
        if isinstance(est, cls):
            for key, value in options.items():
                setattr(est, key, value)
        return est
    return one


#: the fifty-fourth stage's speed dropouts: lengths (s) and where they start (fractions of the scored samples)
DROPOUT_LENGTHS_S = (0.7, 2.0, 5.0, 9.0)
DROPOUT_PLACES = (0.3, 0.6)
#: its rule (deg): B ships if it lowers the dropouts' median by more than this and raises the drives' by at most it
GAPS_OF_GAIN_DEG = 0.005


def speed_dropout_logs(logs, lengths=DROPOUT_LENGTHS_S, places=DROPOUT_PLACES) -> list:
    """The fifty-fourth stage's set (2): each of ``logs`` (:func:`training_logs` with their roll rate) with its speed
    missing (NaN, the rows kept: the IMU logs on) for each of ``lengths`` (s) from each of ``places`` (fractions of its
    scored samples), one dropout per log; the scored mask recomputed (a sample without a speed is not scored)."""
    out = []
    for s, ref, m in logs:
        scored = np.flatnonzero(m)
        for length in lengths:
            for frac in places:
                t0 = s.t[scored[int(frac * (len(scored) - 1))]]
                vx = np.where((s.t >= t0) & (s.t < t0 + length), np.nan, s.vx)
                out.append((dataclasses.replace(s, vx=vx), ref, m & np.isfinite(vx)))
    return out


def choose_gap_samples(logs) -> tuple:
    """The fifty-fourth stage (docs/estimators.md) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate, ``ax`` and pitch rate): ``kinematic-pif`` as ``roadbank estimate`` builds it, behind the online offset
    learner, with ``gaps_of`` ``"rows"`` (A) and ``"usable"`` (B). Returns ``(chosen, {choice: (raw RMS per drive as
    recorded, per dropout log) (deg)})``."""
    dropouts = speed_dropout_logs(logs)
    errs = {}
    for choice in GAPS_OF:
        build = per_log_with("kinematic-pif", KinematicGyro, gaps_of=choice)
        learnt = lambda sig, b=build: with_online_offsets(b(sig))      # noqa: E731
        errs[choice] = (log_errors(learnt, logs), log_errors(learnt, dropouts))
    (a1, a2), (b1, b2) = errs["rows"], errs["usable"]
    ships = (np.median(b2) < np.median(a2) - GAPS_OF_GAIN_DEG and np.median(b1) <= np.median(a1) + GAPS_OF_GAIN_DEG)
    return ("usable" if ships else "rows"), errs


def choose_smoother_passes(logs, modes=SMOOTHER_PASSES) -> tuple[str, dict, dict]:
    """The forty-ninth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(mode, {mode: objective deg}, {mode: share of the valid samples settled})``
    (the share over every drive of the three sets, reported, not judged)."""
    sets = gyro_sets(logs)

    def build(mode):
        return per_log_with("kinematic-smoother", KinematicGyroSmoother, passes=mode)

    def settled_share(mode) -> float:
        runs = [build(mode)(s).run(s) for one in sets for s, _, _ in one]
        return float(sum(int(e.settled.sum()) for e in runs) / max(sum(int(e.valid.sum()) for e in runs), 1))
    obj = {mode: gyro_objective(build(mode), sets) for mode in modes}
    return lowest_tied(obj, list(modes).index), obj, {mode: settled_share(mode) for mode in modes}


def choose_smoother_settled(logs, modes=SMOOTHER_SETTLED) -> tuple[str, dict, dict]:
    """The fiftieth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(mode, {mode: objective deg}, {mode: share of the scored samples
    kept})``."""
    sets = gyro_sets(logs)
    obj, kept = {}, {}
    for mode in modes:
        build = per_log_with("kinematic-smoother", KinematicGyroSmoother, settled_by=mode)
        medians, n_kept, n_scored = [], 0, 0
        for one in sets:
            rms = []
            for s, ref, m in one:
                out = build(s).run(s)
                use = m & out.settled
                n_kept, n_scored = n_kept + int(use.sum()), n_scored + int(m.sum())
                if use.any():
                    rms.append(rms_deg(out.theta[use], ref[use]))
            medians.append(float(np.median(rms)))
        obj[mode], kept[mode] = float(np.mean(medians)), n_kept / max(n_scored, 1)
    first, other = modes
    return (other if obj[other] <= obj[first] + TIE_DEG else first), obj, kept

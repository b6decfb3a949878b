r"""The stages of :mod:`roadbank.tuning.real` on the check that a log's roll rate is one (the thirtieth to
thirty-third).

The thirtieth stage (:func:`choose_roll_check`; rule written 2026-12-05 before any candidate ran) asks how the check
that a log's roll rate follows its ``ay`` (:func:`roadbank.vehicle.conditions.roll_rate_slope`) decides on a short
log. Many raw drives last 10-30 s; there the shipped check (centred means over 1 s and 10 s, slope within 0.5-2)
often cannot decide (fewer than about 11 s at speed: no slope) or reads 0.4-2 on a good gyro, and the default falls
back to the ESP blend. Pieces: each KITTI training drive cut into consecutive whole pieces of each of
:data:`CHECK_PIECES_S`. Candidates: the windows of :data:`CHECK_WINDOWS_S` x the ranges of :data:`CHECK_RANGES`. For
each piece: the default as the command line builds it with the roll rate accepted (``kinematic-gyro``) and without
(the ESP default), each for the piece's fitted car; a candidate takes the first where its check accepts the piece's
roll rate, else the second. Objective: the mean over the piece lengths of the median raw RMS over the pieces (the
KITTI scoring within each piece). Constraint: a candidate that accepts, on any piece, the piece's roll rate negated,
the yaw rate in its place, or the roll rate in deg/s read as rad/s is out. The lowest objective wins; ties within
:data:`TIE_DEG` go to the shipped check, then to the longer windows, then to the narrower range. Neither the KITTI
validation drives nor comma2k19 take part.

The thirty-first stage (:func:`choose_roll_check_again`; rule written 2026-12-05 before any candidate ran, after the
thirtieth found every check accepting the yaw rate in the roll rate's place on some short piece, so that the
shipped check stayed by default): the thirtieth stage's pieces, objective and candidates, each also with a second
condition, that the roll rate is not the yaw rate: the magnitude of the correlation of the two channels over the
design span's samples at speed below :data:`CHECK_MAX_CORR` (two gyros about different axes; a plausibility bound,
not tuned). Constraint: the thirtieth stage's three wrong channels and a fourth, the INS's pitch rate (``wy``) in the
roll rate's place (a gyro about the wrong horizontal axis, as a phone turned in its mount gives): a candidate that
accepts any on any piece is out. Ties as the thirtieth stage's, then without the second condition. Where none meets
the constraint, the shipped check stays. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-second stage (:func:`choose_short_check`; rule written 2026-12-05 before any candidate ran, after the
thirty-first, and after reading on the thirtieth stage's rows that on the ten 12-s training pieces where the shipped
check gives no slope the gyro's error is below the ESP default's on all ten, medians 0.36 and 0.52 deg): a second
check for the logs too short for the first. Candidates: the shipped check alone; and the shipped check where it gives
a slope, else a fallback with centred means over :data:`SHORT_CHECK_WINDOWS_S` (0.5 s and 4 s), the slope within
each of :data:`CHECK_RANGES`, and the thirty-first stage's second condition (the roll rate not the yaw rate). In each
candidate the ``ax`` check (:func:`roadbank.vehicle.conditions.ax_slope`) takes the same windows as the roll-rate
check (as shipped: the same band), fallback included, without the second condition. Pieces: the training drives cut
as the thirtieth stage's, into :data:`SHORT_PIECES_S` (8, 12 and 20 s). For each piece: the default as the command
line builds it for the piece's fitted car with the roll rate and ``ax`` accepted, with the roll rate alone, and the
ESP default; a candidate takes the one its checks give. Objective: the thirtieth stage's (mean over the lengths of
the median raw RMS). Constraint: a candidate that accepts on any piece a wrong roll rate (the thirtieth stage's three:
negated, the yaw rate in its place, deg/s read as rad/s) or a wrong ``ax`` (negated, in g read as m/s^2, ``ay`` in its
place) is out. The pitch rate in the roll rate's place is counted and reported but is no constraint: the shipped
check accepts the negated pitch rate on 4 of the 16 whole drives (the thirty-first stage), so no candidate here can
guard it, and a map must name the roll axis. The lowest objective wins; ties within :data:`TIE_DEG` go to the shipped
check, then to the narrower range. Logs on which the shipped check gives a slope (every whole training and
validation drive) are the same under every candidate. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-third stage (:func:`choose_fixed_channels`; rule written 2026-12-05 before any candidate ran, after the
thirty-second kept the shipped check: every candidate, the shipped one too, accepted a wrong channel on some piece,
though the fallback's objectives were lower, 0.265 and 0.251 against 0.303 deg): where the log's format itself fixes
what an optional channel is, there is no map to get wrong. The readers of KITTI's OXTS files and of comma2k19 name the
roll rate and ``ax`` from the format's documentation (``Signals.fixed``); a user's map (CSV, MDF, CAN, ROS) does not,
and its channels are judged by the checks as before under every candidate. Candidates for a format's channel:
``"judged"`` (shipped: used only where its check accepts it); ``"undecided"`` (where its check cannot decide because
the log has too few samples at speed for the check's band, it is used; a channel whose integral never moves is not);
``"always"`` (used whatever its check reads). Pieces and rows: the thirty-second stage's (KITTI's OXTS is such a
format); each candidate takes, per piece, the default with the roll rate and ``ax``, with the roll rate alone, or
neither, as its rule for the two channels gives. Objective: the thirtieth stage's. No wrong-channel constraint: no
map is read. The lowest wins; ties within :data:`TIE_DEG` go to ``"judged"``, then ``"undecided"``. Neither the KITTI
validation drives nor comma2k19 take part.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import warnings

import numpy as np

from ... import vehicle
from ...constants import G
from ...vehicle import conditions
from ...validation.scoring import SHORT_PIECES_S
from .common import check_pieces, design_settings, lowest_tied, rms_deg


#: the thirtieth stage's pieces (s) and candidates: the check's centred-mean windows (s) and its slope range (-)
CHECK_PIECES_S = (12.0, 20.0)
CHECK_WINDOWS_S = ((1.0, 10.0), (0.5, 4.0))
CHECK_RANGES = ((0.5, 2.0), (0.3, 3.0))
#: the thirty-second stage's fallback check's centred-mean windows (s); its pieces are the validation's short-log
#: lengths (:data:`roadbank.validation.scoring.SHORT_PIECES_S`, 8, 12 and 20 s)
SHORT_CHECK_WINDOWS_S = (0.5, 4.0)
#: the thirty-first stage's second condition: the largest magnitude of the roll rate's correlation with the yaw rate
CHECK_MAX_CORR = 0.9


def _piece_checks(piece, windows, pitch_rate=None) -> list:
    """``(slope, |correlation with the yaw rate|)`` of the roll-rate check on ``piece`` with ``windows``, for the roll
    rate as read, then negated, the yaw rate in its place, deg/s read as rad/s, and (given ``pitch_rate``, rad/s, the
    piece's) the pitch rate in its place; slopes to two digits, as :func:`roadbank.vehicle.log_conditions` gives
    them."""
    n = conditions.design_span(piece)
    span, vx, moving = conditions._design_part(piece, 5.0)
    variants = [span.p, -span.p, span.r, np.degrees(span.p)]
    if pitch_rate is not None:
        variants.append(np.asarray(pitch_rate)[:n])
    return [(conditions._two_digits(conditions.roll_rate_slope(dataclasses.replace(span, p=p), vx, moving, windows)),
             conditions.yaw_correlation(dataclasses.replace(span, p=p), moving)) for p in variants]


def _default_errors(piece, ref, m, cond: dict, variants) -> list[float]:
    """The raw RMS (deg) on ``piece``'s scored samples ``m`` against ``ref`` (rad) of the default as the command line
    builds it for the piece's fitted car (fitted at its conditions ``cond``), once for each of ``variants`` (the
    conditions as each candidate reads them)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        car = vehicle.undescribed_params(piece, cond=cond)
        ests = [vehicle.for_conditions("kinematic-pif", v, car) for v in variants]
    return [rms_deg(est.run(piece).theta[m], ref[m]) for est in ests]


def _check_rows(logs, lengths, windows, pitch_rates=None) -> list:
    """Per piece of each length (:func:`check_pieces`): ``(length, error of the default with the roll rate accepted,
    error without, {windows: _piece_checks})`` (deg); ``pitch_rates``: each drive's pitch rate (rad/s), or None."""
    rows = []
    for length in lengths:
        for piece, ref, m, (i, a, b) in check_pieces(logs, length):
            with design_settings(trust_fixed_channels=False):       # as the thirtieth and thirty-first ran
                cond = vehicle.log_conditions(piece)
            errs = _default_errors(piece, ref, m, cond,
                                   [{**cond, "log_roll_rate": 1.0}, conditions.esp_conditions(cond)])
            q = None if pitch_rates is None else pitch_rates[i][a:b]
            rows.append((length, *errs, {w: _piece_checks(piece, w, q) for w in windows}))
    return rows


def _check_choice(rows, lengths, cands: dict, order) -> tuple:
    """The thirtieth and thirty-first stages' choice over ``cands`` (key -> ``(windows, accept(slope, corr))``) on
    ``rows`` (:func:`_check_rows`): ``(chosen key, {key: objective deg}, {key: wrong channels accepted})``; ties
    within :data:`TIE_DEG` by ``order`` (a sort key of the keys, the shipped check first), none allowed: the first
    of ``order``."""
    obj, wrong = {}, {}
    for key, (w, accept) in cands.items():
        wrong[key] = sum(accept(*x) for *_, checks in rows for x in checks[w][1:])
        obj[key] = float(np.mean([np.median([eg if accept(*checks[w][0]) else ee
                                             for n, eg, ee, checks in rows if n == length]) for length in lengths]))
    allowed = {k: v for k, v in obj.items() if wrong[k] == 0}
    if not allowed:                              # none meets the constraint: the shipped check stays
        return min(cands, key=order), obj, wrong
    return lowest_tied(allowed, order), obj, wrong


def _slope_within(lo: float, hi: float, max_corr: float = math.inf):
    """``accept(slope, corr)``: the slope within ``[lo, hi]`` and the correlation with the yaw rate below
    ``max_corr`` (a NaN correlation passes: it tells nothing)."""
    return lambda slope, corr: slope is not None and lo <= slope <= hi and not corr >= max_corr


def choose_roll_check(logs, lengths=CHECK_PIECES_S, windows=CHECK_WINDOWS_S, ranges=CHECK_RANGES) -> tuple:
    """The thirtieth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate and ``ax``). Returns ``((windows, range), {(windows, range): objective deg}, {(windows, range): pieces on
    which a wrong channel was accepted})``; where every candidate accepts one, the shipped check."""
    cands = {(w, b): (w, _slope_within(b[0], b[1])) for w, b in itertools.product(windows, ranges)}
    shipped = (windows[0], ranges[0])
    return _check_choice(_check_rows(logs, lengths, windows), lengths, cands,
                         lambda k: (k != shipped, -k[0][1], k[1][1] - k[1][0]))


def choose_roll_check_again(logs, pitch_rates, lengths=CHECK_PIECES_S, windows=CHECK_WINDOWS_S,
                            ranges=CHECK_RANGES) -> tuple:
    """The thirty-first stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate and ``ax``) and their ``pitch_rates`` (:func:`training_pitch_rates`). Returns ``((windows, range, with the
    yaw-rate condition), {key: objective deg}, {key: wrong channels accepted})``."""
    cands = {(w, b, c): (w, _slope_within(b[0], b[1], CHECK_MAX_CORR if c else math.inf))
             for w, b, c in itertools.product(windows, ranges, (False, True))}
    shipped = (windows[0], ranges[0], False)
    return _check_choice(_check_rows(logs, lengths, windows, pitch_rates), lengths, cands,
                         lambda k: (k != shipped, -k[0][1], k[1][1] - k[1][0], k[2]))


def _short_piece(piece, ref, m, pitch_rate) -> tuple:
    """One piece of the thirty-second stage: ``(errors, checks)``; ``errors`` the raw RMS (deg) of the default built for
    the piece's fitted car with the roll rate and ``ax`` accepted, with the roll rate alone and with neither (the ESP
    default); ``checks[windows]`` the ``(roll, ax)`` readings with the two check windows: ``roll`` as
    :func:`_piece_checks` gives them (with the pitch rate last), ``ax`` the :func:`roadbank.vehicle.conditions.ax_slope`
    of the ``ax`` as read, negated, in g read as m/s^2 and ``ay`` in its place (two digits)."""
    cond = vehicle.log_conditions(piece)
    errors = _default_errors(piece, ref, m, cond, [{**cond, "log_roll_rate": 1.0, "log_ax": ax} for ax in (1.0, None)]
                             + [conditions.esp_conditions(cond)])
    span, vx, moving = conditions._design_part(piece, 5.0)
    axes = (span.ax, -span.ax, span.ax / G, span.ay)
    checks = {w: (_piece_checks(piece, w, pitch_rate),
                  [conditions._two_digits(conditions._slope_on_integral(span.t, vx, a, moving, w)) for a in axes])
              for w in (conditions.ROLL_CHECK_WINDOWS_S, SHORT_CHECK_WINDOWS_S)}
    return errors, checks


def short_rows(logs, pitch_rates, lengths=SHORT_PIECES_S) -> list:
    """The thirty-second stage's rows: ``(length s, errors, checks)`` (:func:`_short_piece`) per piece of each length
    (:func:`check_pieces`) of the KITTI training ``logs`` with their roll rate and ``ax``, ``pitch_rates`` each
    drive's pitch rate (rad/s, :func:`training_pitch_rates`)."""
    return [(length, *_short_piece(piece, ref, m, pitch_rates[i][a:b]))
            for length in lengths for piece, ref, m, (i, a, b) in check_pieces(logs, length)]


def _short_readings(checks, fallback) -> tuple[list, list]:
    """The roll-rate and ``ax`` readings ``([(slope, corr, range)...], [(slope, range)...])`` of a candidate on one
    piece's ``checks`` (:func:`_short_piece`): the shipped windows' where they give a slope, else (``fallback``, a
    slope range, or None: no fallback) the short windows' with that range; a fallback roll rate that correlates with
    the yaw rate by :data:`CHECK_MAX_CORR` or more gives no slope."""
    rolls, axes = checks[conditions.ROLL_CHECK_WINDOWS_S]
    short_rolls, short_axes = checks[SHORT_CHECK_WINDOWS_S]
    shipped = conditions.ROLL_SLOPE_RANGE
    roll = [(x, c, shipped) if x is not None or fallback is None
            else ((y if not d >= CHECK_MAX_CORR else None), d, fallback)
            for (x, c), (y, d) in zip(rolls, short_rolls)]
    ax = [(x, shipped) if x is not None or fallback is None else (y, fallback) for x, y in zip(axes, short_axes)]
    return roll, ax


def _within(slope, span) -> bool:
    return slope is not None and span[0] <= slope <= span[1]


def choose_short_check(rows, lengths=SHORT_PIECES_S, ranges=CHECK_RANGES) -> tuple:
    """The thirty-second stage (module docstring) on its ``rows`` (:func:`short_rows`). Returns ``(chosen, {candidate:
    objective deg}, {candidate: wrong roll-rate or ax channels accepted}, {candidate: pitch rates accepted})``; a
    candidate is None (the shipped check alone) or the fallback's slope range; where every candidate accepts a wrong
    channel, the shipped check."""
    obj, wrong, pitch = {}, {}, {}
    for cand in (None, *ranges):
        per_length: dict[float, list[float]] = {n: [] for n in lengths}
        wrong[cand], pitch[cand] = 0, 0
        for n, errors, checks in rows:
            roll, ax = _short_readings(checks, cand)
            use = [_within(x, b) for x, _, b in roll]
            use_ax = [_within(x, b) for x, b in ax]
            per_length[n].append(errors[0] if use[0] and use_ax[0] else errors[1] if use[0] else errors[2])
            wrong[cand] += sum(use[1:4]) + sum(use_ax[1:])
            pitch[cand] += sum(use[4:])
        obj[cand] = float(np.mean([np.median(v) for v in per_length.values()]))
    order = [None, *sorted(ranges, key=lambda b: b[1] - b[0])]
    allowed = {k: v for k, v in obj.items() if wrong[k] == 0}
    chosen = lowest_tied(allowed, order.index) if allowed else None
    return chosen, obj, wrong, pitch


#: the thirty-third stage's candidates for a format's fixed channel, the shipped first
FIXED_CHANNEL_RULES = ("judged", "undecided", "always")


def choose_fixed_channels(rows, rules=FIXED_CHANNEL_RULES) -> tuple[str, dict]:
    """The thirty-third stage (module docstring) on the thirty-second's ``rows`` (:func:`short_rows`): ``(chosen rule,
    {rule: objective deg})``. A piece's channel is used by ``"judged"`` where the shipped check's slope is within
    :data:`roadbank.vehicle.conditions.ROLL_SLOPE_RANGE`, by ``"undecided"`` also where it gives none (every
    training channel moves: no slope means too few samples), by ``"always"`` everywhere."""
    def used(slope, rule):
        return (rule == "always" or (slope is None and rule == "undecided")
                or _within(slope, conditions.ROLL_SLOPE_RANGE))

    obj = {}
    for rule in rules:
        per_length: dict = {}
        for n, errors, checks in rows:
            rolls, axes = checks[conditions.ROLL_CHECK_WINDOWS_S]
            roll, ax = used(rolls[0][0], rule), used(axes[0], rule)
            per_length.setdefault(n, []).append(errors[0] if roll and ax else errors[1] if roll else errors[2])
        obj[rule] = float(np.mean([np.median(v) for v in per_length.values()]))
    return lowest_tied(obj, rules.index), obj

r"""The kinematic estimate fused with a roll-rate gyro (``kinematic-gyro``): a complementary filter.

An ESP cluster measures ``ay``, ``r``, ``vx`` and the steering angle; many logs carry more. An INS, a
phone or any six-axis IMU also measures the roll rate :math:`p` about the forward axis, and the roll
angle :math:`\theta` (bank + body roll) changes at that rate: :math:`\dot\theta = p` (small pitch,
below). The kinematic estimate :math:`k = (a_y - v_x r)/g = \sin\theta + \dot v_y / g` has no drift
but carries the road's vibration and the sideslip acceleration; the integrated gyro has no vibration
to speak of but drifts. A complementary filter takes each where it is good: the low frequencies from
:math:`k`, the high ones from :math:`p`, with no lag in between, where a low-pass of :math:`k` alone
must lag to suppress its noise (:mod:`roadbank.estimators.lowpass`):

.. math::
    \dot x = p - b + \omega_c (k - x), \qquad \dot b = -\frac{\omega_c}{T_b} (k - x),
    \qquad \hat w = x, \qquad \omega_c = 2\pi f_c

``b`` (rad/s) is the gyro's offset, learnt from the disagreement of the two (a MEMS gyro's offset is
0.1-1 deg/s; one left in would bias the estimate by :math:`b/\omega_c`); :math:`T_b` (s) is the time
constant in which it is learnt (the characteristic polynomial :math:`s^2 + \omega_c s + \omega_c/T_b`
has its poles near :math:`-\omega_c` and :math:`-1/T_b`). ``bias_tau = 0`` leaves it out (one state).
The transfer from :math:`k` is a low-pass, that from :math:`p` its complement: a bank that the gyro
sees passes without lag. :math:`f_c` and :math:`T_b` were chosen by a written rule on training data
(:func:`roadbank.tuning.real.choose_gyro`, docs/estimators.md).

The grade: :math:`\dot\theta = p + (q \sin\theta + r \cos\theta) \tan\vartheta` with :math:`\vartheta` the
pitch, so on a grade the yaw rate leaks into the roll rate (a 5 % grade in a 0.2 rad/s turn: 0.57 deg/s, which
the low frequencies of :math:`k` correct only within :math:`1/\omega_c`). A log with a longitudinal accelerometer
(:attr:`roadbank.Signals.ax`) gives the pitch, and the filter reads :math:`p + r \tan\hat\vartheta` in place of
:math:`p` (:mod:`roadbank.models.attitude`: the pitch a causal mean of :math:`(\dot v_x - a_x)/g` over
``grade_window`` s, chosen by a written rule on training data, :func:`roadbank.tuning.real.choose_grade`; 0: not
corrected); without ``ax``, or before the first window has passed, :math:`p` as measured. :math:`\hat w` is
:math:`\sin\theta` and :math:`p` the rate of :math:`\theta`, the same to 1.5 % below 10 deg of roll. The filter
is linear and scheduled on speed like every ``lpv`` observer (``step()``, fixed-rate tables); it reads the roll
rate in the steering angle's input slot (it reads no steering), from :attr:`roadbank.Signals.p`;
:meth:`KinematicGyro.run` refuses a log without one, saying so, and a sample without it is held and flagged not
valid.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

import numpy as np

from ..constants import AY_MAX, MAX_GAP_S, SPEED_MAX, YAW_RATE_MAX
from ..models.attitude import euler_roll_rate, grade_pitch, running_area
from ..params import VehicleParams
from ..signals import Estimate, Signals, concat_signals
from . import layout as L
from .base import DesignInputs, ScheduledObserver, StepResult, Tables, sample_floats
from .gyro_start import KalmanStart, first_restart, kalman_begin, kalman_next
from .kinematic import KINEMATIC_V_MIN
from .kinematic_smoother import both_ways, lookahead_of
from .pitch import PitchObserver

#: ``kinematic-gyro``'s cut-off (Hz) and offset time constant (s): the rule of :mod:`roadbank.tuning.real`
GYRO_CUTOFF_HZ = 0.15
GYRO_BIAS_TAU_S = 10.0
#: the window (s) of the pitch that corrects the roll rate for the grade (0: not corrected): the rule of
#: :mod:`roadbank.tuning.real`
GRADE_WINDOW_S = 4.0
#: before the log has lasted that window, the span (s) after which the pitch averages from the log's first sample
#: (``inf``: no correction until the window has passed): the thirty-eighth stage of :mod:`roadbank.tuning.real`
GRADE_FIRST_SPAN_S = 2.0
#: the bandwidth (rad/s) of the pitch observer that gives the grade's pitch on a log with a pitch rate
#: (:mod:`roadbank.estimators.pitch`; 0: the pitch rate not read, the window's pitch) and its start ((bandwidth rad/s,
#: span s) or None): the thirty-ninth stage of :mod:`roadbank.tuning.real`
PITCH_BANDWIDTH = 0.0
PITCH_START: tuple[float, float] | None = None
#: its anchored start's span (s; None: none): the forty-fourth stage
PITCH_ANCHOR: float | None = None
#: the gap (s) between usable samples after which ``kinematic-gyro`` starts again (a stop shorter than it is held
#: through, the state kept: a car at rest keeps its roll): the twenty-seventh stage of :mod:`roadbank.tuning.real`
GYRO_MAX_GAP_S = 10.0
#: what ``kinematic-gyro`` does across an interval of the log longer than :data:`~roadbank.constants.MAX_GAP_S` (no
#: samples: a logger's dropout) and at most its ``max_gap`` (:func:`gap_time`): ``"trapezoid"`` (the roll rate taken
#: linear between the samples either side, as across any interval), ``"hold"`` (the state and the grade's pitch carried
#: over, as if the interval were the one before it) or ``"restart"``; the forty-eighth stage of
#: :mod:`roadbank.tuning.real`
LOG_GAPS = ("trapezoid", "hold", "restart")
GYRO_LOG_GAPS = "hold"
#: whose time stamps that rule reads: ``"rows"`` (the log's, every row) or ``"usable"`` (those of the samples the filter
#: can use, :func:`usable_samples`: a stretch of rows without a speed, a stop below ``v_min``, is then a gap as missing
#: rows are); the fifty-fourth stage of :mod:`roadbank.tuning.real`
GAPS_OF = ("rows", "usable")
GYRO_GAPS_OF = "rows"


def usable_samples(s: Signals, v_min: float) -> np.ndarray:
    """Which samples of ``s`` the filter can use, as its kernel judges a sample's inputs (the time's order aside):
    finite time, speed from ``v_min`` (m/s) to :data:`~roadbank.constants.SPEED_MAX`, a finite roll rate, ``ay`` and
    yaw rate within a car's limits."""
    with np.errstate(invalid="ignore"):
        return (np.isfinite(s.t) & (s.vx >= v_min) & (s.vx <= SPEED_MAX) & np.isfinite(cast(np.ndarray, s.p))
                & (np.abs(s.ay) <= AY_MAX) & (np.abs(s.r) <= YAW_RATE_MAX))
#: the order of ``kinematic-gyro``'s complementary filter (2, or 4: :func:`gyro_observer`): the twenty-eighth stage
GYRO_ORDER = 2
#: the sideslip acceleration it takes out of the kinematic estimate (:func:`sideslip_per_eta`): the twenty-ninth stage
#: kept none: it doubled the error on the training drives, whose INS is mounted at the car's rear, behind the centre
#: of gravity, where the lateral velocity has less of L_r r; where a log's accelerometer sits is not known
SIDESLIPS = ("none", "geometry", "quasi-static")
GYRO_SIDESLIP = "none"
#: seconds after the log's first usable sample during which the offset state is held at zero (0: learnt from the
#: start): the thirty-fourth stage of :mod:`roadbank.tuning.real`
GYRO_START_HOLD_S = 0.0
#: seconds after each (re)start during which the state is the start's Kalman filter's
#: (:mod:`roadbank.estimators.gyro_start`; 0: none), and that filter's prior of the roll rate's offset (rad/s): the
#: thirty-fifth stage of :mod:`roadbank.tuning.real`
GYRO_START_SPAN_S = 0.0
GYRO_START_OFFSET = math.radians(0.3)
#: the cut-off (Hz) and offset time constant (s) of the gyro-aided default for a roll rate whose source documents it
#: as free of offset (``Signals.unbiased``: an INS's outputs): the thirty-sixth stage of :mod:`roadbank.tuning.real`
#: (0.07 Hz, 40 s), the cut-off chosen again by the forty-third with the pitch observer's grade
UNBIASED_GYRO_CUTOFF_HZ = 0.05
UNBIASED_GYRO_BIAS_TAU_S = 40.0
#: the bandwidth (rad/s) of the pitch observer where the pitch rate's source documents it as free of offset
#: (``Signals.unbiased``; :data:`PITCH_BANDWIDTH` elsewhere): the thirty-ninth stage of :mod:`roadbank.tuning.real`
#: (0.5), chosen again with the anchored start by the forty-fifth (0.35)
UNBIASED_PITCH_BANDWIDTH = 0.35
#: its faster start, (bandwidth rad/s, span s) or None (the fortieth stage chose 3 rad/s for 3 s), and its anchored
#: start's span (s; :class:`~roadbank.estimators.pitch.PitchObserver`'s ``anchor``): the forty-fourth stage
UNBIASED_PITCH_START: tuple[float, float] | None = None
UNBIASED_PITCH_ANCHOR = 1.0
#: how :class:`KinematicGyroSmoother` combines its two passes where one has not settled (``"average"``: the mean, as
#: everywhere; ``"settled"``: the settled pass alone): the forty-ninth stage of :mod:`roadbank.tuning.real` kept the
#: mean (0.2245 against 0.2668 deg on the training drives)
SMOOTHER_PASSES = ("average", "settled")
GYRO_SMOOTHER_PASSES = "average"
#: which of its samples :class:`KinematicGyroSmoother` counts as settled (what ``roadbank map`` keeps): where the
#: forward pass has settled since its (re)start, or where either pass has: the fiftieth stage of
#: :mod:`roadbank.tuning.real` kept the forward pass's (0.1928 deg on 74 % of the training drives' scored samples,
#: either pass's 0.2364 on 95 %)
SMOOTHER_SETTLED = ("forward", "either")
GYRO_SMOOTHER_SETTLED = "forward"
#: those constants as :class:`KinematicGyro`'s options: the roll rate's filter and the pitch observer, each for a source
#: that documents it as free of offset (what the default reads such a log with, and the later stages' shipped state)
UNBIASED_GYRO = {"cutoff": UNBIASED_GYRO_CUTOFF_HZ, "bias_tau": UNBIASED_GYRO_BIAS_TAU_S}
UNBIASED_PITCH = {"pitch_bandwidth": UNBIASED_PITCH_BANDWIDTH, "pitch_start": UNBIASED_PITCH_START,
                  "pitch_anchor": UNBIASED_PITCH_ANCHOR}


def gap_time(t: np.ndarray, carry: tuple[float, float, float], lo: float, hi: float,
             mode: str) -> tuple[np.ndarray, tuple[float, float, float]]:
    r"""The time stamps (s) that ``kinematic-gyro`` reads for the log's ``t`` (s), and the carry at its end.

    An interval between consecutive samples longer than ``lo`` and at most ``hi`` (s) is a gap in the log: no roll
    rate was read across it. ``mode`` (:data:`LOG_GAPS`) ``"trapezoid"``: ``t`` as it is; ``"hold"``: every later
    stamp moves earlier so that the gap becomes the last interval of at most ``lo`` before it (the filter, its offset
    and the grade's pitch go on as if no time had passed); ``"restart"``: every later stamp moves ``hi`` later, so the
    filter starts again after the gap. ``carry`` = (the last finite stamp before ``t``, the shift so far, the last
    interval of at most ``lo``; NaN where none): ``(nan, 0.0, nan)`` at a log's start, then what the call returned,
    so that a log read in pieces reads the stamps read whole. Non-finite stamps are kept and step over nothing.
    """
    last, shift, step = carry
    t = np.asarray(t, dtype=float)
    n = len(t)
    fin = np.isfinite(t)
    if not n or mode == "trapezoid":
        return t, (float(t[fin][-1]) if fin.any() else last, shift, step)
    known = np.maximum.accumulate(np.where(fin, np.arange(n), -1))       # the last finite stamp up to each sample
    filled = np.where(known >= 0, t[np.maximum(known, 0)], last)
    d = t - np.concatenate([[last], filled[:-1]])
    with np.errstate(invalid="ignore"):
        gap = (d > lo) & (d <= hi)
        ok = (d > 0) & (d <= lo)
    before = np.maximum.accumulate(np.where(ok, np.arange(n), -1))       # the last ordinary interval up to each sample
    extra = np.zeros(n)
    for k in np.flatnonzero(gap):
        j = before[k - 1] if k > 0 else -1
        prior = d[j] if j >= 0 else (step if math.isfinite(step) else lo)
        extra[k] = d[k] - prior if mode == "hold" else -hi
    shifts = np.cumsum(np.concatenate([[shift], extra]))[1:]        # in order, as gap_stamp adds them
    end_step = d[before[-1]] if before[-1] >= 0 else step
    return t - shifts, (float(filled[-1]), float(shifts[-1]), float(end_step))


def gap_stamp(t: float, carry: tuple[float, float, float], lo: float, hi: float,
              mode: str) -> tuple[float, tuple[float, float, float]]:
    """:func:`gap_time` of one sample (``step()``'s, without arrays): the stamp (s) read for ``t`` (s) and the carry;
    the same numbers as :func:`gap_time` over the samples one by one."""
    last, shift, step = carry
    if not math.isfinite(t) or t <= last:       # a stamp not after the last one: the filter holds it, nothing moves
        return t - shift, carry
    if mode != "trapezoid":
        d = t - last
        if lo < d <= hi:
            shift += d - (step if math.isfinite(step) else lo) if mode == "hold" else -hi
        elif 0.0 < d <= lo:
            step = d
    return t - shift, (t, shift, step)


_FUSES = ("this estimator fuses the roll-rate gyro with the kinematic estimate (map a 'roll_rate' channel, or choose "
          "another estimator)")


class GradeCarry:
    """The roll rate of a log corrected for its grade (:func:`roadbank.models.attitude.euler_roll_rate`), chunk by
    chunk: :func:`~roadbank.models.attitude.grade_pitch` over ``window`` s (0: no correction) continues across
    chunks with the last window of samples kept, so a log in chunks gets what one run gets. ``g`` (m/s^2);
    ``first_span`` and ``max_gap`` (s) as :func:`~roadbank.models.attitude.grade_pitch`'s (``max_gap`` the filter's:
    after a longer interval between the samples it is given the window starts again, as at a log's start, so no
    window reads the speed's change across the filter's restart gap). Given a ``pitch`` observer
    (:class:`~roadbank.estimators.pitch.PitchObserver`), a log with a pitch rate ``q`` takes the pitch from it
    instead (its state carried across chunks); the window serves logs without one."""

    def __init__(self, window: float, g: float, first_span: float = math.inf, pitch: PitchObserver | None = None,
                 max_gap: float = math.inf):
        self.window, self.g, self.first_span = float(window), float(g), float(first_span)
        self.max_gap = float(max_gap)
        self.pitch = pitch
        self.reset()

    def __repr__(self) -> str:
        return (f"GradeCarry(window={self.window!r}, g={self.g!r}, first_span={self.first_span!r}, "
                f"pitch={self.pitch!r}, max_gap={self.max_gap!r})")

    def reset(self) -> None:
        """Forget the samples kept: the next chunk starts a log."""
        #: the last window's (t, vx, ax) and the running area and count at its first sample
        self._tail: tuple | None = None
        if self.pitch is not None:
            self.pitch.reset()

    @property
    def started(self) -> bool:
        """Whether samples are kept from an earlier chunk (or the pitch observer has started)."""
        return self._tail is not None or (self.pitch is not None and self.pitch.started)

    def correct(self, s: Signals, advance: int | None = None) -> Signals:
        """``s`` with its roll rate corrected (rad/s) and neither ``ax`` nor ``q`` (what the filter reads); the
        samples kept move on by the first ``advance`` of ``s`` (default all; a lookahead's samples are corrected,
        not kept)."""
        if s.ax is None or s.p is None or self.window <= 0:
            return dataclasses.replace(s, ax=None, q=None)
        if self.pitch is not None and s.q is not None:
            pitch = self.pitch.pitch(s.t, s.vx, s.ax, s.q, s.ay, s.r, advance)
            return dataclasses.replace(s, p=euler_roll_rate(s.p, s.r, pitch), ax=None, q=None)
        t, vx, ax, start = s.t, s.vx, s.ax, (0.0, 0.0)
        tail = self._tail
        if tail is not None and tail[0][-1] < t[0]:
            t, vx, ax = (np.concatenate([a, b]) for a, b in zip(tail, (t, vx, ax)))
            start = tail[3]
        area = running_area(t, vx, ax, start)
        pitch = grade_pitch(t, vx, ax, self.window, self.g, area, self.first_span, self.max_gap)[len(t) - len(s):]
        n = len(s) if advance is None else advance
        if n:
            end = len(t) - len(s) + n
            first = max(int(np.searchsorted(t[:end], t[end - 1] - self.window, side="right")) - 1, 0)
            self._tail = (t[first:end].copy(), vx[first:end].copy(), ax[first:end].copy(),
                          (float(area[0][first]), float(area[1][first])))
        return dataclasses.replace(s, p=euler_roll_rate(s.p, s.r, pitch), ax=None, q=None)


@dataclass(frozen=True)
class GyroDesign(DesignInputs):
    """Design inputs of :class:`KinematicGyro`: the cut-off ``cutoff`` (Hz), the offset's time constant
    ``bias_tau`` (s; 0: no offset state), the filter's ``order`` (2, or 4: :func:`gyro_observer`) and the
    ``sideslip`` it takes out of the kinematic estimate (:func:`sideslip_per_eta`)."""

    cutoff: float = GYRO_CUTOFF_HZ
    bias_tau: float = GYRO_BIAS_TAU_S
    order: int = GYRO_ORDER
    sideslip: str = GYRO_SIDESLIP


def gyro_observer(d: GyroDesign, vx: float):
    r"""``(F, G, H, D)`` of the complementary filter at ``vx`` (m/s); inputs ``[p, ay, r]`` (module docstring);
    states ``[x, b]`` (``[x]`` without the offset); with a ``sideslip`` (:func:`sideslip_per_eta`: ``u`` whose rate
    leaves :math:`k`), ``[x + w_c u, b - k_i u]`` and the output :math:`x` less :math:`w_c u` (no derivative taken;
    :math:`v_x` held, the schedule). Order 4 (``bias_tau`` not used; no ``sideslip``): all four poles at
    :math:`\omega = 2\pi f_c`, the kinematic estimate's path :math:`(6\omega^2 s^2 + 4\omega^3 s + \omega^4) /
    (s+\omega)^4`, the roll rate's :math:`s^2 (s + 4\omega)/(s+\omega)^4`, in observable canonical form (the estimate
    the first state)."""
    g, wc = d.params.g, 2.0 * np.pi * d.cutoff
    kin = np.array([0.0, 1.0 / g, -vx / g])                   # the kinematic estimate per eta
    gyro = np.array([1.0, 0.0, 0.0])                          # the roll rate per eta
    if d.order == 4:
        a = np.array([4.0 * wc, 6.0 * wc ** 2, 4.0 * wc ** 3, wc ** 4])     # (s + wc)^4 = s^4 + a1 s^3 + ...
        F = np.zeros((4, 4))
        F[:, 0], F[:3, 1:] = -a, np.eye(3)
        G = np.outer([1.0, 4.0 * wc, 0.0, 0.0], gyro) + np.outer([0.0, *a[1:]], kin)
        return F, G, np.eye(1, 4), np.zeros((1, 3))
    u = sideslip_per_eta(d, vx)                                # v_y / g per eta: its rate leaves k
    if d.bias_tau <= 0:
        # z = x + w_c u: z' = p + w_c (k - z) + w_c^2 u, x = z - w_c u
        return (np.array([[-wc]]), (gyro + wc * kin + wc ** 2 * u)[None, :], np.array([[1.0]]),
                (-wc * u)[None, :])
    ki = wc / d.bias_tau
    # z = x + w_c u, beta = b - k_i u: z' = p - beta + w_c (k - z) + (w_c^2 - k_i) u, beta' = k_i (z - k - w_c u)
    F = np.array([[-wc, -1.0], [ki, 0.0]])
    G = np.vstack([gyro + wc * kin + (wc ** 2 - ki) * u, -ki * kin - ki * wc * u])
    return F, G, np.array([[1.0, 0.0]]), (-wc * u)[None, :]


def sideslip_per_eta(d: GyroDesign, vx: float) -> np.ndarray:
    r"""The quasi-static lateral velocity over g, :math:`(L_r r - c\, v_x a_y)/g` (s) per input ``[p, ay, r]``, at
    ``vx`` (m/s), whose rate the filter takes out of the kinematic estimate (``sideslip``: ``"none"`` zeros,
    ``"geometry"`` :math:`c = 0`, ``"quasi-static"`` :math:`c = m L_f / (C_r (L_f + L_r))`, the car's)."""
    if d.sideslip == "none":
        return np.zeros(3)
    q = d.params
    c = q.m * q.Lf / (q.Cr * (q.Lf + q.Lr)) if d.sideslip == "quasi-static" else 0.0
    return np.array([0.0, -c * vx / q.g, q.Lr / q.g])


class KinematicGyro(ScheduledObserver):
    """The kinematic estimate and the roll-rate gyro in one complementary filter (module docstring).

    Parameters
    ----------
    params : VehicleParams, optional
        Only ``g`` and the roll model (for ``phi_b``) are used, and with a ``sideslip`` ``Lr``, ``Lf``, ``m``, ``Cr``.
    cutoff : float, optional
        Cross-over frequency ``f_c`` (Hz, > 0): below it the estimate follows the kinematic estimate, above
        it the integrated roll rate. Default :data:`GYRO_CUTOFF_HZ`.
    bias_tau : float, optional
        Time constant (s, >= 0) in which the gyro's offset is learnt; 0: no offset state. Default
        :data:`GYRO_BIAS_TAU_S`. Not used at order 4.
    order : int, optional
        2 (the module docstring's filter) or 4 (:func:`gyro_observer`: ``cutoff`` the frequency of its four
        poles). Default :data:`GYRO_ORDER`.
    sideslip : str, optional
        The sideslip acceleration taken out of the kinematic estimate (:func:`sideslip_per_eta`, with ``params``'
        ``Lr``, ``Lf``, ``m``, ``Cr``): ``"none"``, ``"geometry"`` or ``"quasi-static"``; order 2 only. Default
        :data:`GYRO_SIDESLIP`.
    grade_window : float, optional
        Window (s, >= 0) of the pitch that corrects the roll rate for the grade on a log with ``ax`` (module
        docstring); 0: not corrected. Default :data:`GRADE_WINDOW_S`.
    grade_first_span : float, optional
        Before the log has lasted ``grade_window``, the span (s, > 0) after which the pitch averages from the log's
        first sample (``inf``: the roll rate is not corrected until the window has passed). Default
        :data:`GRADE_FIRST_SPAN_S`.
    pitch_bandwidth : float, optional
        On a log with a pitch rate (:attr:`roadbank.Signals.q`) and ``ax``, the bandwidth (rad/s, >= 0) of the
        observer that gives the pitch in place of the window's (:class:`~roadbank.estimators.pitch.PitchObserver`);
        0: the pitch rate is not read. Default :data:`PITCH_BANDWIDTH`.
    pitch_start : tuple of float, optional
        That observer's faster start, ``(bandwidth rad/s, span s)``; None: none. Default :data:`PITCH_START`.
    pitch_offset_tau : float, optional
        That observer's offset state of the pitch rate, learnt in that time constant (s, > 0); None (default): none
        (a pitch rate free of offset).
    pitch_anchor : float, optional
        That observer's anchored start's span (s, > 0; :class:`~roadbank.estimators.pitch.PitchObserver`'s
        ``anchor``); None: none. Default :data:`PITCH_ANCHOR`.
    start_hold : float, optional
        Seconds (>= 0) after the log's first usable sample during which the offset state is held at zero, so that
        it does not learn the start's error (the first kinematic sample, taken as the state, is as noisy as any);
        0: learnt from the start. Only where there is an offset state (order 2, ``bias_tau`` > 0, no sideslip);
        not after a restart within the log. Default :data:`GYRO_START_HOLD_S`.
    start_span : float, optional
        Seconds (>= 0) after each (re)start during which the state after each sample is that of the Kalman filter
        whose steady state is this filter (:mod:`roadbank.estimators.gyro_start`: it weighs the first samples as
        the few they are); each sample's output is this filter's step from the previous such state. 0: none. Where
        ``start_hold`` applies, not with it. Default :data:`GYRO_START_SPAN_S`.
    start_offset : float, optional
        That Kalman filter's prior standard deviation (rad/s, > 0) of the roll rate's offset. Default
        :data:`GYRO_START_OFFSET`.
    log_gaps : str, optional
        Across an interval of the log longer than :data:`~roadbank.constants.MAX_GAP_S` and at most ``max_gap`` (no
        samples), one of :data:`LOG_GAPS` (:func:`gap_time`). Default :data:`GYRO_LOG_GAPS`.
    **kw
        Common options of :class:`~roadbank.estimators.base.Estimator`; ``v_min`` (m/s) defaults to
        :data:`~roadbank.estimators.kinematic.KINEMATIC_V_MIN`, ``max_gap`` (s) to :data:`GYRO_MAX_GAP_S`.
    """

    name = "kinematic-gyro"
    #: reads (p, ay, r): the roll rate in the steering angle's slot
    uses = (True, True, True)
    #: the :class:`~roadbank.signals.Signals` channel of the first input slot
    first_input = "p"
    default_v_min = KINEMATIC_V_MIN
    design_type = GyroDesign
    if TYPE_CHECKING:
        @property
        def design(self) -> GyroDesign: ...     # an instance of design_type

    def __init__(self, params=None, *, cutoff=None, bias_tau=None, grade_window=None, order=None, sideslip=None,
                 start_hold=None, start_span=None, start_offset=None, grade_first_span=None, pitch_bandwidth=None,
                 pitch_start=(), pitch_offset_tau=None, pitch_anchor=(), log_gaps=None, **kw):
        self.log_gaps = str(GYRO_LOG_GAPS if log_gaps is None else log_gaps)
        self.gaps_of = GYRO_GAPS_OF         # whose stamps the gap rule reads (GAPS_OF; a stage sets it)
        if self.log_gaps not in LOG_GAPS:
            raise ValueError(f"{self.name}: log_gaps must be one of {LOG_GAPS}, got {log_gaps!r}")
        self.cutoff = float(GYRO_CUTOFF_HZ if cutoff is None else cutoff)
        self.start_hold = float(GYRO_START_HOLD_S if start_hold is None else start_hold)
        if not (np.isfinite(self.start_hold) and self.start_hold >= 0):
            raise ValueError(f"{self.name}: start_hold must be >= 0 s, got {start_hold}")
        self.start_span = float(GYRO_START_SPAN_S if start_span is None else start_span)
        if not (np.isfinite(self.start_span) and self.start_span >= 0):
            raise ValueError(f"{self.name}: start_span must be >= 0 s, got {start_span}")
        self.start_offset = float(GYRO_START_OFFSET if start_offset is None else start_offset)
        if not (np.isfinite(self.start_offset) and self.start_offset > 0):
            raise ValueError(f"{self.name}: start_offset must be > 0 rad/s, got {start_offset}")
        if self.start_span > 0 and self.start_hold > 0:
            raise ValueError(f"{self.name}: start_hold and start_span are two starts; give one")
        self.bias_tau = float(GYRO_BIAS_TAU_S if bias_tau is None else bias_tau)
        self.order = int(GYRO_ORDER if order is None else order)
        self.sideslip = str(GYRO_SIDESLIP if sideslip is None else sideslip)
        if self.order not in (2, 4):
            raise ValueError(f"{self.name}: order must be 2 or 4, got {order}")
        if self.sideslip not in SIDESLIPS or (self.order == 4 and self.sideslip != "none"):
            raise ValueError(f"{self.name}: sideslip must be one of {SIDESLIPS} (order 2 only), got {sideslip!r}")
        window = float(GRADE_WINDOW_S if grade_window is None else grade_window)
        if not (np.isfinite(self.cutoff) and self.cutoff > 0):
            raise ValueError(f"{self.name}: cutoff must be > 0 Hz, got {cutoff}")
        if not (np.isfinite(self.bias_tau) and self.bias_tau >= 0):
            raise ValueError(f"{self.name}: bias_tau must be >= 0 s, got {bias_tau}")
        if not (np.isfinite(window) and window >= 0):
            raise ValueError(f"{self.name}: grade_window must be >= 0 s, got {grade_window}")
        first_span = float(GRADE_FIRST_SPAN_S if grade_first_span is None else grade_first_span)
        if not first_span > 0:
            raise ValueError(f"{self.name}: grade_first_span must be > 0 s, got {grade_first_span}")
        self.state_names = (("w", "c1", "c2", "c3") if self.order == 4 else
                            ("w", "p_offset") if self.bias_tau > 0 and self.sideslip == "none" else
                            ("z", "beta") if self.bias_tau > 0 else ("w",) if self.sideslip == "none" else ("z",))
        self.pitch_bandwidth = float(PITCH_BANDWIDTH if pitch_bandwidth is None else pitch_bandwidth)
        if not (np.isfinite(self.pitch_bandwidth) and self.pitch_bandwidth >= 0):
            raise ValueError(f"{self.name}: pitch_bandwidth must be >= 0 rad/s, got {pitch_bandwidth}")
        self.pitch_start = PITCH_START if pitch_start == () else pitch_start
        super().__init__(params, **{"max_gap": GYRO_MAX_GAP_S, **kw})
        self.pitch_offset_tau = pitch_offset_tau
        self.pitch_anchor = PITCH_ANCHOR if pitch_anchor == () else pitch_anchor
        observer = (PitchObserver(self.pitch_bandwidth, self.params.g, self.pitch_start, pitch_offset_tau,
                                  self.pitch_anchor, self.max_gap) if self.pitch_bandwidth > 0 else None)
        self.grade = GradeCarry(window, self.params.g, first_span, observer, self.max_gap)

    @property
    def grade_window(self) -> float:
        """The window (s) of the pitch that corrects the roll rate (0: not corrected)."""
        return self.grade.window

    def reset(self) -> None:
        """Forget all history, the samples kept for the grade's pitch and the start of the hold too."""
        super().reset()
        self._hold_from = math.nan           # time (s) of the first usable sample: the hold's start
        self._kalman: KalmanStart | None = None          # the start's Kalman filter while it runs
        self._before = (0.0, math.nan)       # the memory's (M_INIT, M_TLAST) before the segment
        self._gaps = (math.nan, 0.0, math.nan)   # gap_time's carry: the time stamps read across the log's gaps
        self._grade_t = -math.inf            # step(): the time of the last sample the grade's window took
        if hasattr(self, "grade"):           # the base constructor resets before the window is set
            self.grade.reset()

    def _holding(self) -> bool:
        """Whether the offset state is still (or may yet be) in its hold after the start (``start_hold``)."""
        return (self.start_hold > 0 and self.state_names[1:2] == ("p_offset",)
                and not self._mem[L.M_TLAST] - self._hold_from >= self.start_hold)

    def _starts(self) -> bool:
        """Whether (re)starts run the start's Kalman filter (``start_span`` > 0 where there is an offset state)."""
        return self.start_span > 0 and self.state_names[1:2] == ("p_offset",)

    def _segment_end(self, signals: Signals, a: int, end: int) -> int:
        """One sample at a time while :meth:`_holding` or the start's Kalman filter runs (each followed by
        :meth:`_after_segment`); else, with ``start_span``, up to the next (re)start
        (:func:`~roadbank.estimators.gyro_start.first_restart`), the (re)start alone; else to ``end``."""
        self._before = (float(self._mem[L.M_INIT]), float(self._mem[L.M_TLAST]))
        if self._holding() or self._kalman is not None:
            return a + 1
        if not self._starts():
            return end
        p = cast(np.ndarray, signals.p)              # run() has refused a log without one
        cut = a + first_restart(signals.t[a:end], signals.vx[a:end], (p[a:end], signals.ay[a:end], signals.r[a:end]),
                                self.v_min, self.max_gap, self._before[0] > 0, self._before[1])
        return a + 1 if cut == a else cut

    def _after_segment(self, signals: Signals, a: int, b: int) -> None:
        """Within the hold after the first usable sample, the offset state back to zero; after one sample with
        ``start_span``, the state the start's Kalman filter's."""
        if b - a == 1 and self._starts():
            self._kalman_sample(float(signals.t[a]), float(signals.vx[a]), float(cast(np.ndarray, signals.p)[a]),
                                float(signals.ay[a]), float(signals.r[a]))
        self._hold_offset()

    def _hold_offset(self) -> None:
        """Within the hold after the first usable sample, the offset state back to zero."""
        if not self._holding() or self._mem[L.M_INIT] == 0.0:
            return
        if math.isnan(self._hold_from):
            self._hold_from = float(self._mem[L.M_TLAST])
        if self._mem[L.M_TLAST] - self._hold_from < self.start_hold:
            self._mem[L.M_X + 1] = 0.0

    def _kalman_sample(self, t: float, vx: float, p: float, ay: float, r: float) -> None:
        """After the kernel has taken the sample (time s, vx m/s, grade-corrected p rad/s, ay m/s^2, r rad/s): at a
        (re)start the start's Kalman filter begins, within ``start_span`` of it it takes the sample, and the state is
        set to its; a sample the kernel did not use changes nothing."""
        mem, (init, last) = self._mem, self._before
        if not (mem[L.M_TLAST] == t and (init == 0.0 or t > last)):
            return
        k = (ay - vx * r) / self.params.g
        if init == 0.0 or t - last > self.max_gap:
            kf = kalman_begin(t, k, p, self.start_offset)
        elif self._kalman is not None:
            kf = kalman_next(self._kalman, t, k, p, self.cutoff, self.bias_tau)
        else:
            return
        mem[L.M_X], mem[L.M_X + 1] = kf.x, kf.b
        self._kalman = kf if t - kf.t0 < self.start_span else None

    def _design_fields(self) -> dict:
        return dict(cutoff=self.cutoff, bias_tau=self.bias_tau, order=self.order, sideslip=self.sideslip)

    def _table_inputs(self) -> GyroDesign:
        """:attr:`design` with the car reduced to its ``g``, all that the tables read (with a ``sideslip`` the car
        as it is: its ``Lr``, ``Lf``, ``m``, ``Cr`` are read too)."""
        if self.sideslip != "none":
            return self.design
        return dataclasses.replace(self.design, params=VehicleParams(g=self.params.g))

    def observer(self, vx: float):
        """``(F, G, H, D)`` at ``vx`` (m/s); inputs ``[p, ay, r]`` (:func:`gyro_observer`)."""
        return gyro_observer(self.design, vx)

    def _design(self):
        tab, n, extra = super()._design()
        # a (re)start takes the kinematic estimate and no offset, not the equilibrium of the current roll rate
        # (J: the state per eta at a start; order 4: the rest state of a constant kinematic estimate k, [k, 4 w k,
        # 0, 0])
        row, g, wc = L.lpv_row(n), self.params.g, 2.0 * np.pi * self.cutoff
        J = np.zeros((len(tab), n, L.NETA))
        J[:, 0, 1], J[:, 0, 2] = 1.0 / g, -self.design.vgrid / g
        if self.sideslip != "none":        # the shifted states at a start: z = k + w_c u, beta = -k_i u
            u = np.array([sideslip_per_eta(self.design, v) for v in self.design.vgrid])
            J[:, 0, :] += wc * u
            if n > 1:
                J[:, 1, :] = -(wc / self.bias_tau) * u
        if self.order == 4:
            J[:, 1, :] = 4.0 * wc * J[:, 0, :]
        tab = np.array(tab)
        tab[:, row.J:row.cont] = J.reshape(len(tab), -1)
        return Tables(np.ascontiguousarray(tab), n, extra)

    def _corrected(self, signals: Signals, reset: bool, lookahead: Signals | None = None):
        """``signals`` as the filter reads them (:meth:`GradeCarry.correct`), after the checks of :meth:`run` and, with
        ``reset``, :meth:`reset` (so the run itself continues: ``reset=False``); given a ``lookahead``, ``(signals,
        lookahead)`` so corrected in one pass, the samples kept moving on through ``signals`` alone."""
        if not isinstance(signals, Signals):
            raise TypeError("run() expects a roadbank.Signals")
        if signals.p is None:
            raise ValueError(f"{self.name}: the log has no roll rate (Signals.p); {_FUSES}")
        if reset:
            self.reset()
        signals = self._read_time(signals)
        if lookahead is None:
            return self._graded(signals)
        n, end = len(signals), self._gaps
        both = self._graded(concat_signals([signals, self._read_time(lookahead)]), advance=n)
        self._gaps = end                    # the lookahead's samples come again in the next piece
        return both[:n], both[n:]

    def _graded(self, s: Signals, advance: int | None = None) -> Signals:
        """:meth:`GradeCarry.correct` of ``s``; with ``gaps_of`` ``"usable"`` of its usable samples alone (an unusable
        one's roll rate, which the filter holds through, left as it is), as :meth:`step` feeds the grade."""
        use = usable_samples(s, self.v_min) if self.gaps_of == "usable" else None
        if use is None or use.all():
            return self.grade.correct(s, advance)
        if not use.any():
            return dataclasses.replace(s, ax=None, q=None)
        k = None if advance is None else int(np.count_nonzero(use[:advance]))
        part = self.grade.correct(s.take(np.flatnonzero(use)), k)
        p = np.array(s.p, dtype=np.float64)
        p[use] = part.p
        return dataclasses.replace(s, p=p, ax=None, q=None)

    def _read_time(self, s: Signals) -> Signals:
        """``s`` with the time stamps the filter reads (:func:`gap_time`, carried on from the last piece; with
        ``gaps_of`` ``"usable"`` read on the usable samples' stamps, the others' moved with their neighbours)."""
        use = usable_samples(s, self.v_min) if self.gaps_of == "usable" else None
        if use is None or use.all():
            t, self._gaps = gap_time(s.t, self._gaps, MAX_GAP_S, self.max_gap, self.log_gaps)
            return s if t is s.t else dataclasses.replace(s, t=t)
        last, shift0 = self._gaps[0], self._gaps[1]
        tu, self._gaps = gap_time(s.t[use], self._gaps, MAX_GAP_S, self.max_gap, self.log_gaps)
        if not use.any():
            return dataclasses.replace(s, t=s.t - shift0)
        # an unusable sample keeps its place between the usable ones around it (their stamps moved; the last one
        # before this piece read at its stamp less the shift then), its own held by the filter anyway
        xs, ys = s.t[use], tu
        if math.isfinite(last):
            xs, ys = np.concatenate([[last], xs]), np.concatenate([[last - shift0], ys])
        t = np.interp(s.t, xs, ys)
        before, after = s.t < xs[0], s.t > xs[-1]
        t[before] = s.t[before] - shift0
        t[after] = s.t[after] - (xs[-1] - ys[-1])
        return dataclasses.replace(s, t=t)

    def run(self, signals: Signals, *, reset: bool = True, lookahead: Signals | None = None) -> Estimate:
        """:meth:`Estimator.run <roadbank.estimators.base.Estimator.run>` of a log with a roll rate
        (:attr:`roadbank.Signals.p`, rad/s; corrected for the grade where the log has ``ax``, module docstring);
        ValueError for a log without one."""
        est = super().run(self._corrected(signals, reset), reset=False, lookahead=lookahead)
        est.t = signals.t
        return est

    def step(self, t: float, vx: float, ay: float, r: float, delta_f: float = float("nan"),
             p: float | None = None, ax: float | None = None, q: float | None = None) -> StepResult:
        """One sample: time (s), vx (m/s), ay (m/s^2), r (rad/s), the unused delta_f (rad), the roll rate ``p``
        (rad/s; required: NaN for a sample without one), the longitudinal acceleration ``ax`` (m/s^2; None or NaN:
        the roll rate is not corrected for the grade, and once an ``ax`` has come, the windows that hold the NaN are
        not, as in :meth:`run`) and the pitch rate ``q`` (rad/s; None: the log has none, the window's pitch). Give
        every one the log has: :meth:`run` reads them all, and with them both give the same numbers."""
        t, vx, ay, r, delta_f = sample_floats(self.name, t, vx, ay, r, delta_f)     # arrays: one sample, said first
        if p is None:
            raise ValueError(f"{self.name}: step() needs the roll rate, step(t, vx, ay, r, delta_f, p=p, ax=ax, q=q) "
                             f"(rad/s, m/s^2, rad/s); {_FUSES}")
        p, ax = sample_floats(self.name, p, math.nan if ax is None else ax)
        counts = (self.gaps_of != "usable" or (self.v_min <= vx <= SPEED_MAX and math.isfinite(p)    # usable_samples
                                               and abs(ay) <= AY_MAX and abs(r) <= YAW_RATE_MAX))
        t, self._gaps = (gap_stamp(t, self._gaps, MAX_GAP_S, self.max_gap, self.log_gaps) if counts
                         else (t - self._gaps[1], self._gaps))      # an unusable sample: held, as if absent
        # the grade's window takes samples in time order only (a stamp not after the last one is held anyway)
        if counts and self._grade_t < t < math.inf and self.grade.window > 0 and (not np.isnan(ax) or
                                                                                 self.grade.started):
            t_, vx_, ay_, r_, d_, p_, ax_ = (np.array([float(v)]) for v in (t, vx, ay, r, delta_f, p, ax))
            one = Signals(t_, vx_, ay_, r_, d_, p_, ax_, None if q is None else np.array([float(q)]))
            p = float(self.grade.correct(one).p[0])
            self._grade_t = t
        self._before = (float(self._mem[L.M_INIT]), float(self._mem[L.M_TLAST]))
        out = super().step(t, vx, ay, r, p)
        if self._starts():
            self._kalman_sample(float(t), float(vx), float(p), float(ay), float(r))
        self._hold_offset()
        return out


class KinematicGyroSmoother(KinematicGyro):
    """``kinematic-gyro-smoother``: :class:`KinematicGyro` over the log forward and backward (in reversed time, the roll
    rate negated), averaged: an *offline* estimator, for bank maps and post-processing
    (:func:`roadbank.estimators.kinematic_smoother.both_ways`, as ``kinematic-smoother`` does with the low-pass). Each
    pass has no lag between the kinematic estimate and the gyro; the average also cancels what each pass's offset
    loop and cross-over leave in phase. Parameters as :class:`KinematicGyro` but ``sideslip`` (not built offline);
    ``passes`` (:data:`SMOOTHER_PASSES`, default :data:`GYRO_SMOOTHER_PASSES`): ``"average"`` the two passes wherever
    both are valid, settled where the forward pass has; ``"settled"`` where only one pass has settled since its
    (re)start that pass alone, settled where either has. ``settled_by`` (:data:`SMOOTHER_SETTLED`, default
    :data:`GYRO_SMOOTHER_SETTLED`): the samples that count as settled with ``"average"``, where the forward pass has
    (``"forward"``) or where either has (``"either"``). ``step()`` is the forward pass's. Not for an ECU: no C export.
    """

    name = "kinematic-gyro-smoother"
    #: the outputs of :meth:`run` use later samples (not causal)
    offline = True
    #: the causal estimator of its forward pass (what an ECU runs instead)
    forward_filter = "kinematic-gyro"

    def __init__(self, params=None, *, cutoff=None, bias_tau=None, grade_window=None, order=None, sideslip=None,
                 passes=None, settled_by=None, **kw):
        if sideslip not in (None, "none"):
            raise ValueError(f"{self.name}: no sideslip option (its backward pass would take the derivative's "
                             "opposite; the causal kinematic-gyro has it)")
        self.passes = GYRO_SMOOTHER_PASSES if passes is None else passes
        if self.passes not in SMOOTHER_PASSES:
            raise ValueError(f"{self.name}: passes must be one of {SMOOTHER_PASSES}, got {passes!r}")
        self.settled_by = GYRO_SMOOTHER_SETTLED if settled_by is None else settled_by
        if self.settled_by not in SMOOTHER_SETTLED:
            raise ValueError(f"{self.name}: settled_by must be one of {SMOOTHER_SETTLED}, got {settled_by!r}")
        super().__init__(params, cutoff=cutoff, bias_tau=bias_tau, grade_window=grade_window, order=order, **kw)
        # the same design in reversed time, on the forward pass's fixed rate (as kinematic-smoother's); it reads
        # the roll rate as the forward pass has corrected it
        self._reverse = KinematicGyro(self.params, cutoff=self.cutoff, bias_tau=self.bias_tau, grade_window=0.0,
                                      order=self.order, **{**kw, "sample_rate": None})
        self._reverse_dt: float | None = None

    def reset(self) -> None:
        """Forget all history, the last output held for the next chunk too (:func:`both_ways`)."""
        super().reset()
        self._held = None

    @property
    def lookahead_s(self) -> float:
        """Samples after a log's end (s) that make :meth:`run` agree with smoothing the whole: :func:`lookahead_of`
        the filter (about 220 s: its offset loop is the slowest pole)."""
        return lookahead_of(self)

    def run(self, signals: Signals, *, reset: bool = True, lookahead: Signals | None = None) -> Estimate:
        """Smoothed estimate over the log ``signals`` with its roll rate; ``reset`` and ``lookahead`` as
        :meth:`roadbank.estimators.kinematic_smoother.KinematicSmoother.run`. Units: ``w`` (-), angles (rad)."""
        if lookahead is None or not len(lookahead) or lookahead.channels != signals.channels:
            s = self._corrected(signals, reset)
        else:
            s, lookahead = self._corrected(signals, reset, lookahead)
        est = both_ways(self, ScheduledObserver.run(self, s, reset=False), s, lookahead, reset)
        est.t = signals.t
        return est

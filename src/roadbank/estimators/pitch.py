r"""The pitch from a pitch-rate gyro: an observer of the speed and the pitch.

The longitudinal accelerometer reads :math:`a_x = \dot v_x - g \sin\vartheta` (:mod:`roadbank.models.attitude`), so
the speed that :math:`a_x` and a pitch :math:`\hat\vartheta` predict drifts from the measured one when
:math:`\hat\vartheta` is wrong. The observer corrects its pitch by that drift and integrates the pitch rate between
(:func:`roadbank.models.attitude.euler_pitch_rate`, with the kinematic roll):

.. math::
    \dot{\hat v} = a_x + g \sin\hat\vartheta + k_1 (v_x - \hat v), \qquad
    \dot{\hat\vartheta} = q \cos\phi_k - r \sin\phi_k + k_2 (v_x - \hat v),
    \qquad k_1 = 2 \zeta \omega, \quad k_2 = \omega^2 / g

Linearised, the error of :math:`(\hat v, \hat\vartheta)` has the characteristic polynomial :math:`s^2 + 2\zeta\omega s
+ \omega^2`: the pitch rate carries the fast changes, the accelerometer and the speed the slow ones, with no window's
lag. A constant offset :math:`b` of the pitch rate leaves :math:`2\zeta b / \omega` in the pitch, unless the
observer learns it as a third state (``offset_tau``: the error's poles then at :math:`(s + 1/T_q)(s^2 + 2\zeta\omega
s + \omega^2)`). It starts at :math:`\hat v = v_x`, :math:`\hat\vartheta = 0` on the log's first usable sample,
and again after a gap longer than ``max_gap`` (the gyro-aided filter's, where the filter starts again),
optionally with a faster bandwidth for a first span, or anchored: for a first span the pitch is the first pitch that,
with the pitch rate integrated since, explains the speed gained beyond :math:`a_x`'s integral (least squares over the
samples so far, with a prior), and the observer goes on from it. :math:`\omega`, the start and where it is used were
chosen by written rules on training data (the thirty-ninth to forty-fifth stages of :mod:`roadbank.tuning.real`:
0.35 rad/s, anchored for the first second, only for a pitch rate documented free of offset). The recursion is
compiled (:mod:`roadbank.estimators.kernels.attitude`).
"""

from __future__ import annotations

import math

import numpy as np

from ..constants import G
from ..models.attitude import MAX_SIN_PITCH, euler_pitch_rate, kinematic_roll
from .kernels.attitude import (C_ANCHOR, C_GAP, C_G, C_PRIOR, C_RESTART, C_TQ, C_TSTART, C_W, C_WSTART, C_ZETA, M_B,
                               M_INIT, N_CFG, N_MEM, pitch_run)

#: the observer's damping (-)
PITCH_ZETA = 0.7
#: the longest gap (s) between usable samples across which the speed state is kept (after it, it restarts at the
#: measured speed; the pitch is kept)
PITCH_MAX_GAP_S = 1.0
#: the anchored start's prior (stated, not tuned): the first pitch's standard deviation (rad; a road's grade) and the
#: speed's noise (m/s)
ANCHOR_GRADE_SD = math.radians(3.0)
ANCHOR_SPEED_SD = 0.05


class PitchObserver:
    r"""The pitch (rad, positive nose down) of a log with ``ax`` and a pitch rate ``q``, chunk by chunk (module
    docstring).

    Parameters
    ----------
    bandwidth : float
        :math:`\omega` (rad/s, > 0).
    g : float, optional
        Gravity (m/s^2).
    start : tuple of float, optional
        ``(bandwidth rad/s, span s)``: the bandwidth for the first ``span`` s after the first usable sample; None:
        ``bandwidth`` throughout.
    offset_tau : float, optional
        :math:`T_q` (s, > 0): the pitch rate's offset is a state, learnt with that time constant (the error's poles at
        :math:`(s + 1/T_q)(s^2 + 2\zeta\omega s + \omega^2)`; :mod:`roadbank.estimators.kernels.attitude`); None: no
        offset state.
    anchor : float, optional
        The anchored start's span (s, > 0): for that long after the first usable sample the pitch is the first pitch
        that, with the pitch rate integrated since, explains the speed gained beyond ``ax``'s integral (least squares
        over the samples so far, prior :data:`ANCHOR_GRADE_SD`, :data:`ANCHOR_SPEED_SD`;
        :mod:`roadbank.estimators.kernels.attitude`); the observer goes on from it. None: the observer from a zero
        pitch.
    max_gap : float, optional
        The gap (s, > 0) between usable samples after which the observer starts again as at the log's first usable
        sample (speed, pitch and offset anew, the start and the anchored start again): the gyro-aided filter's
        ``max_gap``, where it starts again (:class:`~roadbank.estimators.gyro.KinematicGyro`). None (default):
        never; a gap longer than :data:`PITCH_MAX_GAP_S` and at most this restarts the speed state alone.
    """

    def __init__(self, bandwidth: float, g: float = G, start: tuple[float, float] | None = None,
                 offset_tau: float | None = None, anchor: float | None = None, max_gap: float | None = None):
        w = float(bandwidth)
        ws, span = (w, 0.0) if start is None else (float(start[0]), float(start[1]))
        tq = 0.0 if offset_tau is None else float(offset_tau)
        if not (math.isfinite(w) and w > 0 and math.isfinite(ws) and ws > 0 and span >= 0):
            raise ValueError(f"pitch observer: bandwidths must be > 0 rad/s and the start's span >= 0 s, got "
                             f"{bandwidth}, {start}")
        if not (math.isfinite(tq) and (offset_tau is None or tq > 0)):
            raise ValueError(f"pitch observer: offset_tau must be > 0 s or None, got {offset_tau}")
        span_a = 0.0 if anchor is None else float(anchor)
        if not (math.isfinite(span_a) and (anchor is None or span_a > 0)):
            raise ValueError(f"pitch observer: anchor must be > 0 s or None, got {anchor}")
        restart = math.inf if max_gap is None else float(max_gap)
        if not restart > 0:
            raise ValueError(f"pitch observer: max_gap must be > 0 s or None, got {max_gap}")
        self.bandwidth, self.start, self.offset_tau, self.anchor = w, start, offset_tau, anchor
        self.max_gap = max_gap
        self._cfg = np.zeros(N_CFG)
        self._cfg[[C_W, C_ZETA, C_G, C_WSTART, C_TSTART, C_GAP, C_TQ, C_ANCHOR, C_PRIOR, C_RESTART]] = (
            w, PITCH_ZETA, float(g), ws, span, PITCH_MAX_GAP_S, tq, span_a, (ANCHOR_SPEED_SD / ANCHOR_GRADE_SD) ** 2,
            restart)
        self.reset()

    def __repr__(self) -> str:
        return (f"PitchObserver(bandwidth={self.bandwidth!r}, g={float(self._cfg[C_G])!r}, start={self.start!r}, "
                f"offset_tau={self.offset_tau!r}, anchor={self.anchor!r}, max_gap={self.max_gap!r})")

    @property
    def cfg(self) -> np.ndarray:
        """The settings as the compiled kernel reads them (a copy; :mod:`roadbank.estimators.kernels.attitude`)."""
        return self._cfg.copy()

    @property
    def offset(self) -> float:
        """The pitch rate's offset learnt so far (rad/s; 0 without an offset state)."""
        return float(self._mem[M_B])

    @property
    def started(self) -> bool:
        """Whether a usable sample has started the observer (its state carries over to the next chunk)."""
        return bool(self._mem[M_INIT] > 0.0)

    def reset(self) -> None:
        """Forget the state: the next chunk starts a log."""
        self._mem = np.zeros(N_MEM)

    def pitch(self, t, vx, ax, q, ay, r, advance: int | None = None) -> np.ndarray:
        """The pitch (rad; NaN at a sample with a non-finite input, or steeper than
        :data:`~roadbank.models.attitude.MAX_SIN_PITCH`: the roll rate is then not corrected) at each sample of t (s),
        vx (m/s), ax (m/s^2), q (rad/s), ay (m/s^2), r (rad/s); the state moves on by the first ``advance`` samples
        (default all: the later ones, a lookahead, are estimated from a copy)."""
        t, vx, ax = (np.ascontiguousarray(a, dtype=np.float64) for a in (t, vx, ax))
        rate = np.ascontiguousarray(euler_pitch_rate(q, r, kinematic_roll(vx, ay, r, self._cfg[C_G])))
        out = np.empty(len(t))
        n = len(t) if advance is None else int(advance)
        pitch_run(self._mem, self._cfg, t[:n], vx[:n], ax[:n], rate[:n], out[:n])
        if n < len(t):
            pitch_run(self._mem.copy(), self._cfg, t[n:], vx[n:], ax[n:], rate[n:], out[n:])
        out[np.abs(np.sin(out)) > MAX_SIN_PITCH] = np.nan       # steeper than a road: a fault, not a pitch
        return out

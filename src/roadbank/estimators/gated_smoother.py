r"""A low-pass smoother handed to a model smoother through hard manoeuvres (:class:`GatedSmoother`).

The offline counterpart of ``kinematic-pif``'s gate. ``kinematic-smoother`` (the kinematic estimate low-passed both
ways) neglects the sideslip acceleration :math:`\dot v_y`, which is large exactly while the yaw rate changes fast
(a lane change, a manoeuvre near the tyres' limit); ``pif-smoother`` (the PIF on the modified model, forward and RTS
backward) estimates it. Behind :class:`GatedSmoother` both run over the log and the output moves to the model's where
an offline gate is open:

.. math::
    w = w_{lp} + g\,(w_{pif} - w_{lp}), \qquad g(t) = \max_{|t_j - t| \le T} \rho_j,

with :math:`\rho_j` the ramp of the causal gate's measure at sample :math:`j` (:func:`gate_ramps`: the yaw rate
through a first-order low-pass of time constant ``gate_tf``, its rate of change times the speed, the yaw part of the
lateral jerk, ramped from ``gate_on`` over ``gate_span`` m/s^3, as :func:`roadbank.estimators.kernels.gated_step`
reads it) and :math:`T` the ``hold`` (s): the gate is open from :math:`T` before a hard transient to :math:`T` after
it, where the causal gate opens at it and releases after; the ramps count only at ``vx >= v_gate``. ``roadbank map``
builds it where the low-pass smoother is its design (:data:`roadbank.vehicle.conditions.SMOOTHER_GATE`, the
sixty-fourth stage of :mod:`roadbank.tuning.real`; ``v_gate`` :data:`~roadbank.vehicle.conditions.SMOOTHER_GATE_V_MIN`,
the sixty-fifth).

Outputs: the blend where the low-pass smoother's output is valid (its own where the model's is not), held where it
is not (before its first valid sample: its own output, or after ``run(reset=False)`` the last of the previous chunk);
``theta = asin(w)``, ``phi_b = theta - phi`` with the low-pass smoother's body roll; its states. A log run in chunks,
each with the next one as ``lookahead`` covering :attr:`GatedSmoother.lookahead_s`, gives what one run gives.
:meth:`GatedSmoother.step` is the causal form (the two forward filters, the gate held open for :math:`T` after each
ramp): the smoothed estimate of the newest sample given the samples so far has no later sample yet.
"""

from __future__ import annotations

import math

import numpy as np

from ..signals import Estimate, Signals
from . import kernels as K
from .base import StepResult, Wrapper
from .kinematic_smoother import KinematicSmoother
from .smoother import PIFSmoother


def gate_ramps(t: np.ndarray, vx: np.ndarray, r: np.ndarray, usable: np.ndarray, tf: float, on: float, span: float,
               max_gap: float, state: tuple[float, float] = (math.nan, math.nan)) -> tuple[np.ndarray, tuple]:
    """The ramp (-, in [0, 1]) of the yaw part of the lateral jerk at each sample: ``t`` (s), ``vx`` (m/s), ``r``
    (rad/s); ``usable`` (bool) the samples read (others 0, stepped over). The yaw rate through a first-order low-pass
    (time constant ``tf``, s), ``j = vx |r_f'|`` (m/s^3) between consecutive usable samples, ``clip((j - on) / span,
    0, 1)`` (``on``, ``span`` m/s^3); 0 at a (re)start: the first usable sample, or one more than ``max_gap`` (s) after
    the last (:func:`roadbank.estimators.kernels.jerk_ramps`). ``state``: ``(t, r_f)`` of the last usable sample
    before ``t`` (NaN: none). Returns ``(ramps, state)``."""
    out = np.empty(len(t))
    st = np.array(state, dtype=np.float64)
    K.jerk_ramps(np.ascontiguousarray(t, dtype=np.float64), np.ascontiguousarray(vx, dtype=np.float64),
                 np.ascontiguousarray(r, dtype=np.float64), np.ascontiguousarray(usable, dtype=np.bool_), float(tf),
                 float(on), float(span), float(max_gap), st, out)
    return out, (float(st[0]), float(st[1]))


def held_open(t: np.ndarray, ev_t: np.ndarray, ev_g: np.ndarray, before: float, after: float) -> np.ndarray:
    """The gate (-) at the stamps ``t`` (s, non-decreasing where finite): the largest ramp ``ev_g`` of the events at
    ``ev_t`` (s) from ``before`` s before each stamp to ``after`` s after it (0 where none; NaN stamps 0;
    :func:`roadbank.estimators.kernels.window_max`)."""
    order = np.argsort(ev_t, kind="stable")
    out = np.empty(len(t))
    K.window_max(np.ascontiguousarray(t, dtype=np.float64), np.ascontiguousarray(ev_t[order], dtype=np.float64),
                 np.ascontiguousarray(ev_g[order], dtype=np.float64), float(before), float(after), out,
                 np.empty(len(ev_t), dtype=np.int64))
    return out


class GatedSmoother(Wrapper):
    """``inner`` (the low-pass smoother), its output moved to ``model``'s (a model smoother) where the offline gate is
    open (module docstring).

    Parameters
    ----------
    inner, model : Estimator
        Offline estimators of one log (``kinematic-smoother``, ``pif-smoother``); ``inner`` gives the name, the body
        roll, the states, the validity and every attribute this class does not have.
    gate_tf : float
        Time constant (s) of the yaw rate's low-pass.
    gate_on, gate_span : float
        The ramp starts at ``gate_on`` m/s^3 of the yaw part of the lateral jerk and is 1 ``gate_span`` m/s^3 above.
    hold : float
        The gate is open from ``hold`` s before each ramp to ``hold`` s after it (s).
    v_gate : float, optional
        The measure counts only at ``vx >= v_gate`` (m/s; default 0: at every speed the low-pass smoother reads).
    """

    offline = True
    inner: KinematicSmoother
    model: PIFSmoother

    def __init__(self, inner, model, *, gate_tf: float, gate_on: float, gate_span: float, hold: float,
                 v_gate: float = 0.0):
        if not (gate_tf > 0 and gate_span > 0 and hold >= 0 and v_gate >= 0 and math.isfinite(gate_on)
                and math.isfinite(hold) and math.isfinite(v_gate)):
            raise ValueError(f"GatedSmoother: need gate_tf, gate_span > 0, hold, v_gate >= 0 and a finite gate_on; "
                             f"got {gate_tf}, {gate_span}, {hold}, {v_gate}, {gate_on}")
        self.inner, self.model = inner, model
        self.gate_tf, self.gate_on, self.gate_span, self.hold = (float(gate_tf), float(gate_on), float(gate_span),
                                                                 float(hold))
        self.v_gate = float(v_gate)
        self._forget()

    def _forget(self) -> None:
        self._state: tuple[float, float] = (math.nan, math.nan)     # (t, r_f) of the last sample the gate read
        self._ev_t = np.empty(0)                    # the ramps > 0 within ``hold`` of the last chunk's end
        self._ev_g = np.empty(0)
        self._held: float | None = None             # the last output of the previous chunk
        self._step_w = 0.0

    @property
    def lookahead_s(self) -> float:
        """Samples after a chunk's end (s) that make :meth:`run` agree with one run over the log: each smoother's, and
        the gate's ``hold``."""
        return max(self.inner.lookahead_s, self.model.lookahead_s, self.hold + self.gate_tf)

    def reset(self) -> None:
        """Forget all history: both smoothers' and the gate's."""
        self.inner.reset()
        self.model.reset()
        self._forget()

    def _usable(self, s: Signals) -> np.ndarray:
        with np.errstate(invalid="ignore"):
            return np.isfinite(s.t) & np.isfinite(s.vx) & np.isfinite(s.r) & (s.vx >= self.inner.v_min)

    def _ramps(self, s: Signals, state: tuple[float, float]) -> tuple[np.ndarray, tuple]:
        vx = np.asarray(s.vx, dtype=float)
        ramps, state = gate_ramps(np.asarray(s.t, dtype=float), vx, np.asarray(s.r, dtype=float), self._usable(s),
                                  self.gate_tf, self.gate_on, self.gate_span, self.inner.max_gap, state)
        with np.errstate(invalid="ignore"):
            ramps[~(vx >= self.v_gate)] = 0.0       # counted only at speed
        return ramps, state

    def _gate(self, signals: Signals, lookahead: Signals | None) -> np.ndarray:
        """The gate over ``signals`` from the events of the chunks before, of ``signals`` and of ``lookahead``; the
        gate's state moved to the end of ``signals``."""
        t = np.asarray(signals.t, dtype=float)
        ramps, self._state = self._ramps(signals, self._state)
        ev_t, ev_g = [self._ev_t, t[ramps > 0]], [self._ev_g, ramps[ramps > 0]]
        if lookahead is not None and len(lookahead):
            ahead, _ = self._ramps(lookahead, self._state)
            ta = np.asarray(lookahead.t, dtype=float)
            ev_t.append(ta[ahead > 0])
            ev_g.append(ahead[ahead > 0])
        all_t, all_g = np.concatenate(ev_t), np.concatenate(ev_g)
        g = held_open(np.fmax.accumulate(t), all_t, all_g, self.hold, self.hold)
        end = np.nanmax(t) if np.isfinite(t).any() else -math.inf
        mine = ramps > 0
        keep_t, keep_g = np.concatenate([self._ev_t, t[mine]]), np.concatenate([self._ev_g, ramps[mine]])
        recent = keep_t >= end - self.hold
        self._ev_t, self._ev_g = keep_t[recent], keep_g[recent]
        return g

    def run(self, signals: Signals, *, reset: bool = True, lookahead: Signals | None = None) -> Estimate:
        """Estimate over ``signals`` (a log, or with ``reset=False`` its next piece, ``lookahead`` the samples that
        follow it; module docstring). Units: ``w`` (-), angles (rad)."""
        if not isinstance(signals, Signals):
            raise TypeError("run() expects a roadbank.Signals")
        if reset:
            self._forget()
        lp = self.inner.run(signals, reset=reset, lookahead=lookahead)
        m = self.model.run(signals, reset=reset, lookahead=lookahead)
        g = self._gate(signals, lookahead)
        w = np.where(m.valid, lp.w + g * (m.w - lp.w), lp.w)
        n = len(w)
        last = np.maximum.accumulate(np.where(lp.valid, np.arange(n), -1))
        held = ~lp.valid & (last >= 0)
        w[held] = w[last[held]]
        before = ~lp.valid & (last < 0)
        if self._held is not None:
            w[before] = self._held
        if n:
            self._held = float(w[-1])
        theta = np.arcsin(np.clip(w, -1.0, 1.0))
        valid = lp.valid & (np.abs(w) <= np.sin(self.inner.max_angle))
        phi = lp.states.get("phi", np.zeros(n))
        return Estimate(lp.name, lp.t, w, theta, theta - phi, valid, lp.states, lp.settled & valid)

    def step(self, t: float, vx: float, ay: float, r: float, delta_f: float = float("nan"),
             **more: float) -> StepResult:
        """One sample (time s, vx m/s, ay m/s^2, r rad/s, delta_f rad; ``more`` as the smoothers take them): the two
        forward filters blended by the gate of the samples so far (module docstring)."""
        a = self.inner.step(t, vx, ay, r, delta_f, **more)
        b = self.model.step(t, vx, ay, r, delta_f, **more)
        s = Signals(np.array([t], dtype=float), np.array([vx], dtype=float), np.array([ay], dtype=float),
                    np.array([r], dtype=float), np.array([delta_f], dtype=float))
        g = float(self._gate(s, None)[0])
        if a.valid:
            self._step_w = a.w + g * (b.w - a.w) if b.valid else a.w
        w = self._step_w
        theta = math.asin(min(1.0, max(-1.0, w)))
        phi = a.theta - a.phi_b
        valid = a.valid and abs(w) <= math.sin(self.inner.max_angle)
        return StepResult(w, theta, theta - phi, valid, a.settled and valid)

    def __repr__(self) -> str:
        return f"<GatedSmoother of {self.inner!r} and {self.model!r}, hold {self.hold:.6g} s>"

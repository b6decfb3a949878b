"""An estimator handed over to another design when a log's roads change (:class:`HandOver`).

A log's design is read on its first minute of driving (:func:`roadbank.vehicle.conditions.log_conditions`). Where
that minute reads quiet, the default keeps the car's model; a long drive that then leaves the smooth road would keep
it over rough roads, where the low-pass blend does far better. Behind :class:`HandOver` an estimator reads the log on,
in stretches of log time; when a stretch closes that ``read`` finds loud (it returns the conditions of that stretch,
else None), the estimator ``redesign(**those conditions)`` builds is run over the stretch (from its first sample, so
that it has settled) and gives the outputs from the stretch's end on, for the rest of the log: causal, since the
decision is known when the stretch closes, and one way. ``roadbank estimate`` builds it where the design is quiet
(``ROAD_CHANGE``: the fifty-eighth stage of :mod:`roadbank.tuning.real`, docs/estimators.md).
"""

from __future__ import annotations

import math

import numpy as np

from ..signals import Estimate, Signals, concat_signals, stretch_index
from .base import StepResult, Wrapper

#: the stretches of log time (s) a :class:`HandOver` reads by default (``roadbank estimate`` gives it
#: :data:`roadbank.vehicle.conditions.ROAD_CHECK_WINDOW_S`, the road check's)
STRETCH_S = 60.0
#: the channels a sample may carry besides t, vx, ay, r, delta_f (:meth:`HandOver.step`)
_MORE = ("p", "ax", "q")


class HandOver(Wrapper):
    """``inner`` until a stretch of the log reads loud, then the estimator designed for that stretch (module
    docstring).

    Parameters
    ----------
    inner : Estimator
        The estimator designed for the log's first minute.
    read : callable
        ``read(stretch) -> dict or None``: the conditions of a closed stretch (a :class:`~roadbank.signals.Signals`)
        where the estimate is to be handed over there, else None.
    redesign : callable
        ``redesign(**conditions) -> Estimator``: the estimator for those conditions.
    stretch_s : float, optional
        Length of the stretches (s of log time from the first stamp), default :data:`STRETCH_S`.

    ``run`` and ``step`` agree, and a log read in chunks (``run(reset=False)``) gives what one run gives. After the
    hand-over :attr:`handed_at` is the log time (s) of the first sample of the new estimator's outputs and
    :attr:`handed_to` that estimator; the states keep the inner estimator's names (each chunk the same columns), each
    the new estimator's state of that name from there on, NaN where it has none. Every other attribute is the inner
    estimator's.
    """

    def __init__(self, inner, read, redesign, stretch_s: float = STRETCH_S):
        if not hasattr(inner, "step") or not hasattr(inner, "run"):
            raise TypeError("HandOver expects a roadbank estimator")
        if not stretch_s > 0:
            raise ValueError(f"stretch_s must be > 0 s, got {stretch_s}")
        self.inner, self.read, self.redesign, self.stretch_s = inner, read, redesign, float(stretch_s)
        self._forget()

    def _forget(self) -> None:
        self._t0 = math.nan
        self._stretch = -1
        self._last = -math.inf                      # the last stamp kept of the open stretch (s)
        self._parts: list[Signals] = []             # run(): the open stretch's samples
        self._rows: list[dict[str, float]] = []     # step(): the same, sample by sample
        self._names: tuple[str, ...] | None = None  # the inner estimator's state names
        self.handed_to = None
        self.handed_at = math.nan

    def reset(self) -> None:
        """Forget all history: the inner estimator's, the stretches read and any hand-over."""
        self.inner.reset()
        self._forget()

    def _index(self, t: np.ndarray) -> np.ndarray:
        """The stretch of each stamp of ``t`` (s), never before the open one: a stamp that is NaN or goes back (in a
        later chunk, or a later :meth:`step`) belongs to the stretch before it, as in one run
        (:func:`~roadbank.signals.stretch_index`)."""
        if math.isnan(self._t0) and np.isfinite(t).any():
            self._t0 = float(t[np.isfinite(t)][0])
        return np.maximum(stretch_index(t, self._t0, self.stretch_s), self._stretch)

    def _kept(self, t: np.ndarray) -> np.ndarray:
        """Which stamps of ``t`` (s) the stretch reader is given: finite and later than every one kept before (a
        repeated, NaN or backward stamp is left out, as a log's reader repairs them)."""
        with np.errstate(invalid="ignore"):
            keep = np.isfinite(t) & (t > np.fmax.accumulate(np.concatenate([[self._last], t]))[:-1])
        if keep.any():
            self._last = float(t[keep][-1])
        return keep

    def _close(self, stretch: Signals | None):
        """The estimator handed over to where the closed ``stretch`` reads loud (run over it), else None."""
        if stretch is None or not len(stretch):
            return None
        cond = self.read(stretch)
        if cond is None:
            return None
        est = self.redesign(**cond)
        est.run(stretch, reset=True)
        return est

    def run(self, signals: Signals, *, reset: bool = True, lookahead: Signals | None = None) -> Estimate:
        """Estimate over ``signals`` (a log, or with ``reset=False`` its next piece; class docstring); ``lookahead``
        is passed to the inner estimator (a causal one ignores it)."""
        if not isinstance(signals, Signals):
            raise TypeError("run() expects a roadbank.Signals")
        if reset:
            self.reset()
        if self.handed_to is not None:
            return self._padded(self.handed_to.run(signals, reset=False))
        est = self.inner.run(signals, reset=False, lookahead=lookahead)
        if self._names is None:
            self._names = tuple(est.states)
        w = self._index(np.asarray(signals.t, dtype=np.float64))
        for k in np.unique(w):
            rows = np.flatnonzero(w == k)
            if k != self._stretch:
                to = self._close(concat_signals(self._parts) if self._parts else None)
                self._parts, self._stretch = [], int(k)
                if to is not None:
                    self.handed_to, self.handed_at = to, float(signals.t[rows[0]])
                    return self._spliced(est, self._padded(to.run(signals[rows[0]:], reset=False)), rows[0])
            rows = rows[self._kept(np.asarray(signals.t, dtype=np.float64)[rows])]
            if len(rows):
                self._parts.append(signals.take(rows))
        return est

    def _padded(self, est: Estimate) -> Estimate:
        """``est`` under the inner estimator's state names (NaN where the handed-over estimator has none; its others
        left out): every chunk of a log has the same columns."""
        names = self._names if self._names is not None else tuple(est.states)
        est.states = {k: est.states[k] if k in est.states else np.full(len(est.t), math.nan) for k in names}
        return est

    @staticmethod
    def _spliced(before: Estimate, after: Estimate, j: int) -> Estimate:
        """``before``'s rows up to ``j`` (exclusive), then ``after``'s (the rows from ``j`` on), under ``before``'s
        state names."""
        def cat(a, b):
            return np.concatenate([a[:j], b])
        states = {k: cat(v, after.states[k]) for k, v in before.states.items()}
        return Estimate(before.name, before.t, cat(before.w, after.w), cat(before.theta, after.theta),
                        cat(before.phi_b, after.phi_b), cat(before.valid, after.valid), states,
                        cat(before.settled, after.settled))

    def step(self, t: float, vx: float, ay: float, r: float, delta_f: float = float("nan"),
             **more: float) -> StepResult:
        """One sample: time (s), vx (m/s), ay (m/s^2), r (rad/s), delta_f (rad) and ``more`` as the inner estimator
        takes them (``p`` rad/s, ``ax`` m/s^2, ``q`` rad/s); the result of the estimator in charge (class
        docstring)."""
        if self.handed_to is None:
            k = int(self._index(np.array([t], dtype=np.float64))[0])
            if k != self._stretch:
                to = self._close(self._stretch_of_rows())
                self._rows, self._stretch = [], k
                if to is not None:
                    self.handed_to, self.handed_at = to, float(t)
        if self.handed_to is not None:
            return self.handed_to.step(t, vx, ay, r, delta_f, **more)
        if self._kept(np.array([t], dtype=np.float64))[0]:
            self._rows.append({"t": t, "vx": vx, "ay": ay, "r": r, "delta_f": delta_f,
                               **{c: more[c] for c in _MORE if c in more}})
        return self.inner.step(t, vx, ay, r, delta_f, **more)

    def _stretch_of_rows(self) -> Signals | None:
        """The samples :meth:`step` kept of the open stretch, as :class:`~roadbank.signals.Signals` (None: none)."""
        if not self._rows:
            return None
        names = [c for c in self._rows[0] if all(c in row for row in self._rows)]
        chans = {c: np.array([row[c] for row in self._rows], dtype=np.float64) for c in names}
        return Signals(chans["t"], chans["vx"], chans["ay"], chans["r"], chans["delta_f"], p=chans.get("p"),
                       ax=chans.get("ax"), q=chans.get("q"))

    def __repr__(self) -> str:
        """The inner estimator, and where handed over the estimator in charge and from when (s of log time)."""
        to = "" if self.handed_to is None else f", handed to {self.handed_to!r} at {self.handed_at:.6g} s"
        return f"<HandOver of {self.inner!r}{to}>"

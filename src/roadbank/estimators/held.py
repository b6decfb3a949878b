"""A held log read at its source's rate (:class:`AtSource`).

A logger that writes a slower sensor onto a faster grid by holding its frames (a 10 Hz CAN message in a 100 Hz
table) repeats each frame's values on the rows until the next one; every filter would read the copies as samples of
a signal that stood still and then jumped. Behind :class:`AtSource` an estimator takes only the rows that bring new
values (:func:`roadbank.signals.held_copies`: ``ay``, the yaw rate and the roll rate where the log has one, not
repeated to the last bit), as it would the sensor's own log, and each repeated row gets the output of the last row
taken before it. Where a log is so written (:func:`roadbank.signals.is_held`), ``roadbank estimate`` designs for the
rows taken and runs this way (:func:`roadbank.vehicle.conditions.log_conditions`, ``READ_AT_SOURCE``: the
fifty-fifth stage of :mod:`roadbank.tuning.real`, docs/estimators.md).
"""

from __future__ import annotations

import math

import numpy as np

from ..signals import Estimate, Signals, held_copies
from .base import StepResult, Wrapper


class AtSource(Wrapper):
    """``inner`` reading only the rows of a log that bring new values (module docstring).

    Parameters
    ----------
    inner : Estimator
        Any roadbank estimator (or one behind :func:`~roadbank.estimators.with_online_offsets`).

    ``run(signals) -> Estimate`` has a row per row of ``signals`` (time ``t`` s as given); a repeated row's outputs,
    states and flags are those of the last row taken before it. ``step(...)`` of a sample whose ``ay``, yaw rate and
    roll rate ``p`` repeat the last sample's returns the last result. Every other attribute is the inner estimator's.
    """

    def __init__(self, inner):
        if isinstance(inner, AtSource):
            raise ValueError(f"{inner.name}: already reads its log at its source's rate")
        if not hasattr(inner, "step") or not hasattr(inner, "run"):
            raise TypeError("AtSource expects a roadbank estimator")
        self.inner = inner
        self._forget()

    def _forget(self) -> None:
        self._key: tuple[float, ...] | None = None         # ay, r (, p) of the last row taken
        self._last: StepResult | None = None                # step(): its result
        self._rows: dict[str, np.ndarray] | None = None     # run(): its outputs, one row of each array

    def reset(self) -> None:
        """Forget all history of the estimator and of the rows taken."""
        self.inner.reset()
        self._forget()

    def run(self, signals: Signals, *, reset: bool = True, lookahead: Signals | None = None) -> Estimate:
        """Estimate over ``signals`` (a log, or with ``reset=False`` its next piece) from the rows that bring new
        values (class docstring); ``lookahead`` (an offline estimator's later samples) likewise."""
        if not isinstance(signals, Signals):
            raise TypeError("run() expects a roadbank.Signals")
        if reset:
            self.reset()
        copies = held_copies(signals, self._key)
        taken = np.flatnonzero(~copies)
        kw = {}
        if lookahead is not None:
            last = self._key_of(signals, taken[-1]) if taken.size else self._key
            new = np.flatnonzero(~held_copies(lookahead, last))
            if new.size:            # (a lookahead of copies alone brings nothing)
                kw["lookahead"] = lookahead.take(new)
        part = self.inner.run(signals.take(taken), reset=False, **kw) if taken.size else None
        # row j's outputs: those of the last row taken at or before j (-1: the last row of the piece before)
        at = np.maximum.accumulate(np.where(copies, -1, np.arange(len(signals))))
        pos = np.searchsorted(taken, at)
        rows = self._arrays(part) if part is not None else self._none_taken()
        out = {k: self._spread(k, v, at, pos) for k, v in rows.items()}
        if taken.size:              # what the next piece, or step(), repeats
            self._key = self._key_of(signals, taken[-1])
            self._rows = {k: v[-1:].copy() for k, v in rows.items()}
            self._last = StepResult(float(rows["w"][-1]), float(rows["theta"][-1]), float(rows["phi_b"][-1]),
                                    bool(rows["valid"][-1]), bool(rows["settled"][-1]))
        name = part.name if part is not None else self.name
        states = {k[2:]: v for k, v in out.items() if k.startswith("s:")}
        return Estimate(name, np.asarray(signals.t, dtype=np.float64), out["w"], out["theta"], out["phi_b"],
                        out["valid"], states, out["settled"])

    @staticmethod
    def _key_of(signals: Signals, i: int) -> tuple[float, ...]:
        """The channels :func:`~roadbank.signals.held_copies` compares, of row ``i``."""
        chans = [signals.ay, signals.r] + ([signals.p] if signals.p is not None else [])
        return tuple(float(np.asarray(x)[i]) for x in chans)

    @staticmethod
    def _arrays(part: Estimate) -> dict[str, np.ndarray]:
        """The per-row arrays of ``part`` by name (states as ``"s:<name>"``)."""
        out = {"w": part.w, "theta": part.theta, "phi_b": part.phi_b, "valid": part.valid, "settled": part.settled}
        out.update({"s:" + k: v for k, v in part.states.items()})
        return out

    def _none_taken(self) -> dict[str, np.ndarray]:
        """The arrays of a piece that takes no row: empty, of the last piece's names (its outputs spread)."""
        names = self._rows if self._rows is not None else {"w": 0.0, "theta": 0.0, "phi_b": 0.0, "valid": False,
                                                                "settled": False}
        return {k: np.zeros(0, dtype=np.asarray(v).dtype) for k, v in names.items()}

    def _spread(self, key: str, v: np.ndarray, at: np.ndarray, pos: np.ndarray) -> np.ndarray:
        """``v`` (one value per row taken) on every row: row ``j`` the value at ``pos[j]``; before the first row
        taken (``at`` -1), the last row of the piece before, or held and not valid where there was none."""
        before = self._rows.get(key) if self._rows is not None else None
        if before is None:
            before = np.zeros(1, dtype=v.dtype) if v.dtype == bool else np.full(1, math.nan)
        full = np.concatenate([before.astype(v.dtype), v])
        return full[np.where(at < 0, 0, pos + 1)]

    def step(self, t: float, vx: float, ay: float, r: float, delta_f: float = float("nan"),
             **more: float) -> StepResult:
        """One sample: time (s), vx (m/s), ay (m/s^2), r (rad/s), delta_f (rad) and ``more`` as the inner
        estimator takes them (``p`` rad/s, ``ax`` m/s^2, ``q`` rad/s); a sample whose ``ay``, ``r`` and ``p`` repeat
        the last one's returns the last result (class docstring)."""
        p = more.get("p")
        key = (float(ay), float(r)) if p is None else (float(ay), float(r), float(p))
        if self._last is not None and key == self._key:
            return self._last
        self._last = self.inner.step(t, vx, ay, r, delta_f, **more)
        self._key = key
        return self._last

    def __repr__(self) -> str:
        return f"<AtSource of {self.inner!r}>"

"""Fault injection and the robustness study of the estimators.

- :mod:`.inject` — the faults (bad samples, dropouts, bad time stamps, stuck
  sensors, bias steps, saturation, speed through zero, extreme steering) as
  functions of a clean sample stream, and :func:`.inject.feed`, which drives an
  estimator through a stream that :class:`roadbank.Signals` would reject
  (non-increasing time) with streaming ``step()``.
- :mod:`.table` — what every estimator does through every fault (flagged
  fraction, error outside flagged samples, re-convergence time, non-finite
  output) against a clean run; ``roadbank robustness`` writes it.
"""

from .inject import FAULTS, Fault, Stream, apply, feed

__all__ = ["FAULTS", "Fault", "Stream", "apply", "feed"]

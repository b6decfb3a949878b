"""Recorded logs at scale: one log streamed in chunks, many logs in parallel on Dask.

* :func:`estimate_log` -- one log: stream it (:func:`roadbank.io.stream.stream_log`),
  run the estimators chunk by chunk (``run(reset=False)``), write the output
  incrementally, summarise (duration, valid share, bank mean/min/max).
* :func:`run_fleet` -- many logs on dask.distributed (or in-process for one
  worker); one bad log never stops or loses the others; a summary table is
  appended as each log finishes; ``resume=True`` skips finished logs.
* :func:`expand_logs` -- directories and glob patterns -> log paths.
* :mod:`.bench` -- the 24 h long-log benchmark (peak RSS, throughput).
"""

from .process import LogSummary, estimate_log
from .run import FleetResult, expand_logs, run_fleet

__all__ = ["LogSummary", "estimate_log", "FleetResult", "expand_logs", "run_fleet"]

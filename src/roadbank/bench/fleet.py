"""Benchmark section ``fleet``: ``roadbank estimate`` on many short logs, end to end, on 1 and 2
workers, per input format.

Each log is a 100 Hz drive with its own white ``ay`` noise (so each gets its own design, as on
a real fleet; :func:`roadbank.fleet.bench.fleet_logs`), run through
:func:`roadbank.fleet.run_fleet` (the path of ``roadbank estimate DIR -o OUT/ --workers N``) with
the design cache off: read + design + filter + write of every log, a summary row each.
1 worker is in this process; 2 workers a Dask LocalCluster of single-threaded processes, whose
start-up (cluster and warm-up) is timed apart. The rate is samples of all logs over the
processing wall time (start-up excluded); the total wall time includes it.
"""

from __future__ import annotations

import os
import tempfile

from ..report.markdown import Markdown, md_table
from .suite import Section

#: the estimator of the fleet runs (a designed PIF: its design is part of the cost per log)
FLEET_ESTIMATOR = "pif-modified"
#: target of the fleet benchmark: 2 workers at least this many times 1 worker's samples/s
SPEEDUP_TARGET = 1.8
#: per suite size: logs, seconds per log, formats, worker counts
FLEET_SIZES = {
    "full": dict(logs=200, seconds=600.0, formats=("parquet", "csv", "mdf4"), workers=(1, 2)),
    "quick": dict(logs=60, seconds=120.0, formats=("parquet", "csv"), workers=(1, 2)),
    "tiny": dict(logs=4, seconds=10.0, formats=("parquet", "csv"), workers=(1,)),
}


def _format_missing(fmt: str) -> str | None:
    """Why logs of ``fmt`` cannot be written here, or None."""
    if fmt == "mdf4":
        try:
            import asammdf  # noqa: F401
        except ImportError:
            return "asammdf is not installed (pip install 'roadbank[mdf]')"
    return None


def fleet_speed(cfg: dict, sizes: dict | None = None) -> dict:
    """Samples/s end to end per format and worker count (module doc); ``sizes`` overrides
    :data:`FLEET_SIZES` for the run's size."""
    from ..fleet.bench import fleet_speedup

    size = dict(FLEET_SIZES[cfg["size"]], **(sizes or {}))
    rows, skipped = [], {}
    with tempfile.TemporaryDirectory(prefix="roadbank-bench-fleet-") as tmp:
        for fmt in size["formats"]:
            why = _format_missing(fmt)
            if why:
                skipped[fmt] = why
                continue
            load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
            for r in fleet_speedup(size["logs"], size["seconds"], workers=size["workers"],
                                   estimator=FLEET_ESTIMATOR, bad_every=0, workdir=tmp, fmt=fmt):
                r["load_before"] = load
                rows.append(r)
    for r in rows:
        r["met"] = r["speedup"] >= SPEEDUP_TARGET if r["workers"] > 1 else None
    return {"rows": rows, "skipped": skipped, "estimator": FLEET_ESTIMATOR, "logs": size["logs"],
            "seconds_per_log": size["seconds"], "target_speedup": SPEEDUP_TARGET,
            "cores": os.cpu_count()}


def fleet_markdown(out: dict) -> list[str]:
    rows = []
    for r in out["rows"]:
        met = "" if r["met"] is None else Markdown("yes" if r["met"] else "**no**")
        rows.append([r["format"], r["workers"], f"{r['samples_per_s'] / 1e6:.2f}", f"{r['wall_s']:.2f}",
                     f"{r['startup_s']:.1f}", f"{r['total_s']:.1f}", f"{r['speedup']:.2f}x", met])
    headers = ["format", "workers", "M samples/s", "processing (s)", "start-up (s)", "total (s)",
               "vs 1 worker", f">= {out['target_speedup']:g}x?"]
    loads = sorted({f"{r['load_before']:.1f}" for r in out["rows"]})
    note = (f"{out['logs']} logs of {out['seconds_per_log']:g} s at 100 Hz per format, each with its own `ay` "
            f"noise (its own design), `{out['estimator']}`, design cache off: read + design + filter + write "
            "of every log (`roadbank.fleet.run_fleet`, as `roadbank estimate DIR -o OUT/ --workers N`). "
            "1 worker: in this process; 2: a Dask LocalCluster of single-threaded processes, start-up "
            "(cluster and warm-up) apart; M samples/s over the processing time. "
            f"{out['cores']} cores; load average before each format: {', '.join(loads) or '-'} (on a shared "
            "machine the second worker competes with other jobs for the second core).")
    lines = [md_table(headers, rows, align="lrrrrrrl"), "", note]
    for fmt, why in out["skipped"].items():
        lines += ["", f"{fmt}: not measured: {why}."]
    return lines


SECTION = Section("fleet", "Fleets: many short logs end to end (roadbank estimate --workers)", fleet_speed,
                  fleet_markdown)

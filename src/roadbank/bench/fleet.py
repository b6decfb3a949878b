"""Benchmark section ``fleet``: ``roadbank estimate`` on many short logs, end to end, on 1 and 2
workers, per input format.

Each log is a 100 Hz drive with its own white ``ay`` noise (so the logs need their own designs,
one per noise level to two significant digits, as on a real fleet;
:func:`roadbank.fleet.bench.fleet_logs`), run through
:func:`roadbank.fleet.run_fleet` (the path of ``roadbank estimate DIR -o OUT/ --workers N``) with
the design cache off: read + design + filter + write of every log, a summary row each.
1 worker is in this process; 2 workers a pool of 2 worker processes on this machine, whose
start-up (processes and warm-up) is timed apart. The rate is samples of all logs over the
processing wall time (start-up excluded); the total wall time includes it. The CPU seconds the
workers spent are reported beside it: on a shared machine the wall-time speed-up also depends
on what else runs on the cores, the CPU ratio does not.

``roadbank bench --fleet-logs N`` also runs a fleet at scale: ``N`` Parquet logs of 10 min
(:data:`SCALE_SECONDS`), each with its own ``ay`` noise, on 1 and 2 workers (:func:`fleet_scale`;
the logs are written to a temporary folder and removed afterwards).
"""

from __future__ import annotations

import os
import tempfile

from ..defaults import ESTIMATOR
from ..report.markdown import Markdown, md_table
from .suite import Section

#: the estimator of the fleet runs: what `roadbank estimate` runs (designed for each log: its design is part of the
#: cost per log)
FLEET_ESTIMATOR = ESTIMATOR
#: target of the fleet benchmark: 2 workers at least this many times 1 worker's samples/s
SPEEDUP_TARGET = 1.8
#: per suite size: logs, seconds per log, formats, worker counts
FLEET_SIZES = {
    "full": dict(logs=200, seconds=600.0, formats=("parquet", "csv", "mdf4"), workers=(1, 2)),
    "quick": dict(logs=60, seconds=120.0, formats=("parquet", "csv"), workers=(1, 2)),
    "tiny": dict(logs=4, seconds=10.0, formats=("parquet", "csv"), workers=(1,)),
}

#: length of each log of the fleet at scale (s)
SCALE_SECONDS = 600.0


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
    out = {"rows": rows, "skipped": skipped, "estimator": FLEET_ESTIMATOR, "logs": size["logs"],
           "seconds_per_log": size["seconds"], "target_speedup": SPEEDUP_TARGET,
           "cores": os.cpu_count()}
    if cfg.get("fleet_logs"):
        out["scale"] = fleet_scale(int(cfg["fleet_logs"]))
    return out


def fleet_scale(n_logs: int, seconds: float = SCALE_SECONDS, workers=(1, 2)) -> dict:
    """``n_logs`` Parquet logs of ``seconds`` at 100 Hz, each with its own ``ay`` noise
    (:func:`roadbank.fleet.bench.fleet_logs`, none corrupt), end to end on each worker count
    (:func:`roadbank.fleet.bench.fleet_speedup`); the logs are written to a temporary folder,
    timed (s, ``write_s``) and removed afterwards with the outputs."""
    import time

    from ..fleet.bench import fleet_logs, fleet_speedup

    with tempfile.TemporaryDirectory(prefix="roadbank-bench-scale-") as tmp:
        t0 = time.perf_counter()
        paths, _ = fleet_logs(tmp, n_logs, seconds, "parquet", bad_every=0)
        write_s = time.perf_counter() - t0
        input_mb = sum(p.stat().st_size for p in paths) / 2**20
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        rows = fleet_speedup(n_logs, seconds, workers=workers, estimator=FLEET_ESTIMATOR, bad_every=0,
                             workdir=tmp, fmt="parquet", keep_outputs=False)
    for r in rows:
        r["met"] = r["speedup"] >= SPEEDUP_TARGET if r["workers"] > 1 else None
    return {"rows": rows, "logs": n_logs, "seconds_per_log": seconds, "write_s": write_s,
            "input_mb": input_mb, "load_before": load}


def _cpu(r: dict) -> list:
    """The CPU columns of a row: workers' CPU s and its ratio to 1 worker's."""
    cpu, ratio = r.get("cpu_s", float("nan")), r.get("cpu_ratio", float("nan"))
    return [f"{cpu:.1f}" if cpu == cpu else "-", f"{ratio:.2f}" if ratio == ratio else "-"]


def _row(r: dict, first) -> list:
    met = "" if r["met"] is None else Markdown("yes" if r["met"] else "**no**")
    return [first, r["workers"], f"{r['samples_per_s'] / 1e6:.2f}", f"{r['wall_s']:.2f}", *_cpu(r),
            f"{r['startup_s']:.1f}", f"{r['total_s']:.1f}", f"{r['speedup']:.2f}x", met]


def fleet_markdown(out: dict) -> list[str]:
    rows = [_row(r, r["format"]) for r in out["rows"]]
    headers = ["format", "workers", "M samples/s", "processing (s)", "CPU (s)", "CPU vs 1 worker", "start-up (s)",
               "total (s)", "vs 1 worker", f">= {out['target_speedup']:g}x?"]
    loads = sorted({f"{r['load_before']:.1f}" for r in out["rows"]})
    note = (f"{out['logs']} logs of {out['seconds_per_log']:g} s at 100 Hz per format, each with its own `ay` "
            f"noise (a design per noise level to two significant digits), `{out['estimator']}`, design cache "
            "off: read + design + filter + write "
            "of every log (`roadbank.fleet.run_fleet`, as `roadbank estimate DIR -o OUT/ --workers N`). "
            "1 worker: in this process; 2: a pool of 2 worker processes on this machine, start-up "
            "(processes and warm-up) apart; M samples/s over the processing time. "
            f"{out['cores']} cores; load average before each format: {', '.join(loads) or '-'} (on a shared "
            "machine the second worker competes with other jobs for the second core).")
    note += (" CPU: seconds the workers spent on the processing (each worker's own CPU time, every "
             "thread); its ratio to 1 worker's says how much more work the same logs took on workers, "
             "whatever else ran on the cores.")
    lines = [md_table(headers, rows, align="lrrrrrrrrl"), "", note]
    for fmt, why in out["skipped"].items():
        lines += ["", f"{fmt}: not measured: {why}."]
    if "scale" in out:
        sc = out["scale"]
        lines += ["", f"At scale (`roadbank bench --fleet-logs {sc['logs']}`): {sc['logs']} Parquet logs of "
                  f"{sc['seconds_per_log']:g} s at 100 Hz ({sc['rows'][0]['samples'] / 1e6:.0f} M samples, "
                  f"{sc['input_mb']:.0f} MiB, written in {sc['write_s']:.0f} s beforehand), each with its own "
                  f"`ay` noise; load average before: {sc['load_before']:.1f}.", "",
                  md_table(headers, [_row(r, "parquet") for r in sc["rows"]], align="lrrrrrrrrl")]
    return lines


SECTION = Section("fleet", "Fleets: many short logs end to end (roadbank estimate --workers)", fleet_speed,
                  fleet_markdown)

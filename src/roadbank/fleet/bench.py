"""Long-log and fleet benchmarks: peak memory and end-to-end throughput of ``estimate`` on generated logs.

Run ``python -m roadbank.fleet.bench [--hours 24] [--formats parquet,mdf4] [--peer-hours 2]
[--fleet 200] [--json]``; results are recorded in docs/io.md ("Long logs" and "Fleets").

* :func:`write_long_log` -- a 100 Hz log of any length: a simulated 25 s drive on the banked
  test track (``track-lane-change``) tiled end to end on one continuous clock, written
  chunk by chunk (Parquet row groups / MDF4 blocks), so making it needs little memory too.
* :func:`measure` -- runs :func:`roadbank.fleet.estimate_log` on it in a fresh process and
  reads that process's peak resident set size (``wait4`` rusage) and wall times: import,
  estimator design, and the end-to-end run (read + resample + estimate + write).
  The peer is the whole-log path (``load_log`` + one ``run()`` + ``write_table``) on a
  shorter log, measured the same way.
* :func:`fleet_speedup` -- many small logs with 1 and 2 worker processes.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..defaults import ESTIMATOR
from ..estimators.grid_design import clear_memos
from ..io.stream import CHUNK_ROWS
from .run import run_fleet

COLUMNS = ("t", "vx", "ay", "r", "delta_f")


@functools.lru_cache(maxsize=4)
def _base_drive(scenario: str = "track-lane-change", seed: int = 0) -> dict[str, np.ndarray]:
    from ..sim import run_scenario
    s = run_scenario(scenario, seed=seed).signals
    return {"vx": s.vx, "ay": s.ay, "r": s.r, "delta_f": s.delta_f}


def write_long_log(path, hours: float = 24.0, rate_hz: float = 100.0, chunk_s: float = 1800.0,
                   ay_noise: float = 0.0, seed: int = 0) -> int:
    """Write a ``hours``-long log at ``rate_hz`` to ``path`` (.parquet or .mf4); returns the sample count.

    Columns / channels ``t`` (s), ``vx`` (m/s), ``ay`` (m/s^2), ``r`` (rad/s), ``delta_f`` (rad):
    roadbank's default channel map. ``ay_noise`` (m/s^2): white noise of that standard deviation
    added to ``ay`` (random generator ``seed``), so that logs measure distinct noise levels and
    each gets its own design.
    """
    p = Path(path)
    base = _base_drive()
    nb = len(base["vx"])
    total = int(round(hours * 3600.0 * rate_hz))
    step = int(chunk_s * rate_hz)
    p.parent.mkdir(parents=True, exist_ok=True)

    rng = np.random.default_rng(seed)

    def chunk(k0):
        k = np.arange(k0, min(k0 + step, total))
        c = {"t": k / rate_hz, **{c: v[k % nb] for c, v in base.items()}}
        if ay_noise > 0:
            c["ay"] = c["ay"] + ay_noise * rng.standard_normal(k.size)
        return c

    if p.suffix.lower() == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq
        writer = None
        for k0 in range(0, total, step):
            tab = pa.table(chunk(k0))
            writer = writer or pq.ParquetWriter(p, tab.schema)
            writer.write_table(tab, row_group_size=step)
        if writer is not None:
            writer.close()
    elif p.suffix.lower() in (".mf4", ".mdf"):
        from asammdf import MDF, Signal
        mdf = MDF(version="4.10")
        for j, k0 in enumerate(range(0, total, step)):
            c = chunk(k0)
            if j == 0:
                mdf.append([Signal(c[n], c["t"], name=n) for n in COLUMNS[1:]], common_timebase=True)
            else:
                mdf.extend(0, [(c["t"], None)] + [(c[n], None) for n in COLUMNS[1:]])
        mdf.save(p, overwrite=True)
        mdf.close()
    else:
        raise ValueError(f"{p}: write .parquet or .mf4")
    return total


_CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import roadbank.cli       # the process set-up of the roadbank command (BLAS threads, Arrow's allocator)
from roadbank import estimators
from roadbank.fleet import estimate_log
mode, log, out, est, chunk = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5])
t1 = time.perf_counter()
estimators.make(est)
t2 = time.perf_counter()
res = {"import_s": t1 - t0, "design_s": t2 - t1, "samples": 0, "run_s": 0.0}
if mode == "stream":
    c0 = time.process_time()
    s = estimate_log(log, out, [est], chunk_rows=chunk)
    if s.status != "ok":
        raise SystemExit(s.error)
    res.update(samples=s.samples, run_s=s.seconds, chunks=s.chunks, run_cpu_s=time.process_time() - c0)
elif mode.startswith("baseline-"):      # what every run pays before the first row: no log data
    import numpy as np
    from roadbank import Signals
    n = 1000
    estimators.make(est).run(Signals(np.arange(n) * 0.01, np.full(n, 20.0), np.zeros(n), np.zeros(n), np.zeros(n)))
    import pyarrow.parquet
    if mode == "baseline-mdf4":
        from roadbank.io.mdfimport import import_asammdf
        import_asammdf()                # as the MDF4 reader imports it
elif mode == "whole":
    from roadbank.io import load_log
    from roadbank.io.writers import estimate_table, write_table
    t3, c0 = time.perf_counter(), time.process_time()
    lg = load_log(log)
    e = estimators.make(est).run(lg.signals)
    write_table(out, estimate_table(lg.signals.t, [e]))
    res.update(samples=len(lg), run_s=time.perf_counter() - t3, chunks=1, run_cpu_s=time.process_time() - c0)
try:    # the peak of this process image only (VmHWM starts afresh at exec; ru_maxrss would
        # also count the parent's memory, inherited through fork, when the parent is large)
    with open("/proc/self/status") as fh:
        res["vm_hwm_kb"] = next(int(l.split()[1]) for l in fh if l.startswith("VmHWM:"))
except (OSError, StopIteration, ValueError):
    pass
print(json.dumps(res))
"""


def measure(mode: str, log, out, estimator: str = ESTIMATOR, chunk_rows: int | None = None) -> dict:
    """Run one measurement in a fresh Python process.

    Parameters
    ----------
    mode : {"stream", "whole", "baseline-parquet", "baseline-mdf4"}
        ``stream``: :func:`roadbank.fleet.estimate_log` (chunks, incremental output);
        ``whole``: load_log + run + write_table; ``baseline-<format>``: no log, only what every run
        pays first (imports, estimator design, the compiled kernel loaded by a first tiny
        ``run()``, the format's reader library).

    chunk_rows : int, optional
        Rows per chunk (default :data:`roadbank.io.stream.CHUNK_ROWS`, as ``roadbank estimate``).

    Returns
    -------
    dict
        ``peak_rss_mb`` (MiB, the child's peak resident set: VmHWM on Linux, else ru_maxrss),
        ``samples``, ``run_s`` (s, read + estimate + write), ``samples_per_s``, ``run_cpu_s`` (s of CPU
        in the run: on a shared machine wall time also counts waiting for a core), ``samples_per_cpu_s``,
        ``import_s``, ``design_s``, ``chunks``.
    """
    chunk_rows = chunk_rows or CHUNK_ROWS
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, mode, str(log), str(out), estimator, str(chunk_rows)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=dict(os.environ, OMP_NUM_THREADS="1",
                                                                                      OPENBLAS_NUM_THREADS="1"))
    _, status, usage = os.wait4(proc.pid, 0)
    assert proc.stdout is not None and proc.stderr is not None        # both are pipes
    out_text = proc.stdout.read().decode()
    err = proc.stderr.read().decode()
    proc.stdout.close()
    proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"benchmark child ({mode}) failed: {err.strip()[-2000:]}")
    res = json.loads(out_text.strip().splitlines()[-1])
    res["peak_rss_mb"] = res.pop("vm_hwm_kb", usage.ru_maxrss) / 1024.0
    res["samples_per_s"] = res["samples"] / res["run_s"] if res["run_s"] > 0 else float("nan")
    res["samples_per_cpu_s"] = res["samples"] / res["run_cpu_s"] if res.get("run_cpu_s") else float("nan")
    res["mode"] = mode
    return res


#: fleet log formats -> file suffix
FLEET_SUFFIXES = {"parquet": ".parquet", "csv": ".csv", "mdf4": ".mf4"}


def write_fleet_log(path, seconds: float, ay_noise: float = 0.0, seed: int = 0) -> int:
    """One short 100 Hz fleet log of ``seconds`` as .parquet, .mf4 (:func:`write_long_log`, one
    chunk) or .csv (the same samples: a header line of the column names, one row per sample);
    returns the sample count."""
    p = Path(path)
    if p.suffix.lower() != ".csv":
        return write_long_log(p, hours=seconds / 3600.0, chunk_s=seconds, ay_noise=ay_noise, seed=seed)
    import pyarrow as pa
    import pyarrow.csv as pacsv

    base = _base_drive()
    k = np.arange(int(round(seconds * 100.0)))
    cols = {"t": k / 100.0, **{c: v[k % len(base["vx"])] for c, v in base.items()}}
    if ay_noise > 0:        # as write_long_log draws it for a log of one chunk
        cols["ay"] = cols["ay"] + ay_noise * np.random.default_rng(seed).standard_normal(k.size)
    p.parent.mkdir(parents=True, exist_ok=True)
    pacsv.write_csv(pa.table(cols), p)
    return k.size


def fleet_logs(workdir, n_logs: int, seconds: float, fmt: str = "parquet", bad_every: int = 20) -> tuple[list, int]:
    """``n_logs`` logs of ``seconds`` in ``workdir/logs-<fmt>`` (written if missing), every
    ``bad_every``-th corrupt (0: none); log ``i`` carries white ``ay`` noise of ``0.05 + 0.001 i``
    m/s^2 (each log its own design, as on a real fleet). Returns (paths, samples in the good logs)."""
    logs = Path(workdir) / f"logs-{fmt}"
    logs.mkdir(parents=True, exist_ok=True)
    paths = []
    samples = 0
    for i in range(n_logs):
        p = logs / f"log{i:04d}{FLEET_SUFFIXES[fmt]}"
        bad = bool(bad_every) and i % bad_every == bad_every - 1
        if not p.exists():
            if bad:
                p.write_bytes(b"PAR1 truncated" if fmt == "parquet" else b"t,vx\n0,not a number\n")
            else:
                write_fleet_log(p, seconds, ay_noise=0.05 + 0.001 * i, seed=i)
        samples += 0 if bad else round(seconds * 100.0)
        paths.append(p)
    return paths, samples


def fleet_speedup(n_logs: int = 200, seconds: float = 600.0, workers=(1, 2), estimator: str = ESTIMATOR,
                  bad_every: int = 20, workdir=None, batch: int | None = None, fmt: str = "parquet",
                  keep_outputs: bool = True) -> list[dict]:
    """Wall time of ``run_fleet`` on ``n_logs`` logs of ``seconds`` (100 Hz, every ``bad_every``-th corrupt).

    The logs are :func:`fleet_logs` in format ``fmt`` ("parquet", "csv", "mdf4"). Each worker
    count runs in a fresh output directory with the design cache off (``ROADBANK_CACHE_DIR=off``,
    so every design is made); Dask start-up (cluster + warm-up) is reported apart from the
    processing wall time. ``batch``: logs per Dask task (None: automatic). End to end = read +
    design + filter + write, in ``samples_per_s`` (start-up excluded) and ``total_s`` (s, included).
    ``keep_outputs``: False removes each run's outputs once it is measured (a large fleet's
    results need not be on disk twice). ``cpu_s``: CPU seconds the workers spent on the processing
    (:attr:`~roadbank.fleet.FleetResult.cpu_s`), ``cpu_ratio`` that over the first worker count's
    (how much more CPU the same logs took), ``client_cpu_s`` this process' CPU seconds meanwhile
    on Dask.
    """
    work = Path(workdir or tempfile.mkdtemp(prefix="roadbank-fleet-"))
    paths, samples = fleet_logs(work, n_logs, seconds, fmt, bad_every)
    rows = []
    old = os.environ.get("ROADBANK_CACHE_DIR")
    os.environ["ROADBANK_CACHE_DIR"] = "off"
    try:
        for w in workers:
            clear_memos()      # the in-process run designs every log anew, as a fresh worker does
            t0 = time.perf_counter()
            out = work / f"out-{fmt}-{w}-{batch or 'auto'}"
            res = run_fleet(paths, out, [estimator], workers=w, batch=batch)
            total = time.perf_counter() - t0
            if not keep_outputs:
                shutil.rmtree(out, ignore_errors=True)
            rows.append({"workers": w, "logs": n_logs, "failed": len(res.failed), "wall_s": res.wall_s,
                         "startup_s": res.startup_s, "total_s": total, "logs_per_s": n_logs / res.wall_s,
                         "samples_per_s": samples / res.wall_s, "batch": batch or "auto", "format": fmt,
                         "samples": samples, "cpu_s": res.cpu_s, "client_cpu_s": res.client_cpu_s})
    finally:
        if old is None:
            os.environ.pop("ROADBANK_CACHE_DIR", None)
        else:
            os.environ["ROADBANK_CACHE_DIR"] = old
    base, base_cpu = rows[0]["wall_s"], rows[0]["cpu_s"]
    for r in rows:
        r["speedup"] = base / r["wall_s"]
        r["cpu_ratio"] = r["cpu_s"] / base_cpu          # NaN where a reading is missing
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m roadbank.fleet.bench", description=__doc__.split("\n")[0])
    ap.add_argument("--hours", type=float, default=24.0)
    ap.add_argument("--peer-hours", type=float, default=2.0)
    ap.add_argument("--formats", default="parquet,mdf4")
    ap.add_argument("--estimator", default=ESTIMATOR, help="default: the command line's default estimator")
    ap.add_argument("--chunk-rows", type=int, default=None, help="default: roadbank.io.stream.CHUNK_ROWS")
    ap.add_argument("--fleet", type=int, default=0, help="also time N small logs with 1 and 2 workers")
    ap.add_argument("--fleet-seconds", type=float, default=600.0, help="length of each fleet log (s)")
    ap.add_argument("--batch", type=int, default=None, help="logs per Dask task (default: automatic)")
    ap.add_argument("--workdir", default=None)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    work = Path(a.workdir or tempfile.mkdtemp(prefix="roadbank-bench-"))
    results: dict[str, Any] = {}
    for fmt in filter(None, a.formats.split(",")):
        results[f"baseline-{fmt}"] = measure(f"baseline-{fmt}", "-", "-", a.estimator)
        suf = {"parquet": ".parquet", "mdf4": ".mf4"}[fmt]
        log = work / f"long-{a.hours:g}h{suf}"
        if not log.exists():
            t = time.perf_counter()
            write_long_log(log, a.hours)
            print(f"wrote {log} ({log.stat().st_size / 2**20:.0f} MiB) in {time.perf_counter() - t:.0f} s",
                  file=sys.stderr)
        results[f"{fmt}-stream"] = measure("stream", log, work / f"out-{fmt}.parquet", a.estimator, a.chunk_rows)
        peer = work / f"long-{a.peer_hours:g}h{suf}"
        if a.peer_hours > 0:
            if not peer.exists():
                write_long_log(peer, a.peer_hours)
            results[f"{fmt}-whole-{a.peer_hours:g}h"] = measure("whole", peer, work / f"whole-{fmt}.parquet",
                                                                a.estimator)
            results[f"{fmt}-stream-{a.peer_hours:g}h"] = measure("stream", peer, work / f"out2-{fmt}.parquet",
                                                                 a.estimator, a.chunk_rows)
    if a.fleet:
        results["fleet"] = fleet_speedup(a.fleet, a.fleet_seconds, estimator=a.estimator, workdir=work / "fleet",
                                         batch=a.batch)
    if a.json:
        print(json.dumps(results, indent=1))
    else:
        for k, r in results.items():
            if k == "fleet":
                for row in r:
                    print(f"fleet {row['workers']} worker(s), batch {row['batch']}: {row['logs']} logs in "
                          f"{row['wall_s']:.1f} s ({row['logs_per_s']:.1f} logs/s, "
                          f"{row['samples_per_s'] / 1e6:.2f} M samples/s end to end, {row['speedup']:.2f}x), "
                          f"{row['failed']} failed; start-up {row['startup_s']:.1f} s")
                continue
            print(f"{k:>22}: peak RSS {r['peak_rss_mb']:.0f} MiB, {r['samples']} samples in {r['run_s']:.2f} s "
                  f"= {r['samples_per_s'] / 1e6:.2f} M samples/s ({r['samples_per_cpu_s'] / 1e6:.2f} M per CPU s; "
                  f"import {r['import_s']:.1f} s, design "
                  f"{r['design_s']:.1f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

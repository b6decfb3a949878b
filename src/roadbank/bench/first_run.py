"""A user's first ``roadbank estimate``: the plain command on a log, in a fresh process, with empty caches.

What a user meets first after installing is ``roadbank estimate LOG -o out.csv``: the kernels its default
runs compile (nothing is in the numba cache) and its designs are solved (nothing is in the design cache,
:mod:`roadbank.cache`). Each case runs the command line (``python -m roadbank.cli estimate LOG -o OUT``) in a
new process whose ``NUMBA_CACHE_DIR`` and ``ROADBANK_CACHE_DIR`` are new empty directories (*cold*), then the
same command again with those caches filled (*warm*, the peer in the same run); ``cold - warm`` is what the first
run pays for compiling and designing. Wall times (s), the process start and ``import roadbank`` included.

The cases: a synthetic 10 min, 100 Hz ESP log (:func:`roadbank.fleet.bench.write_long_log`: ``t, vx, ay, r,
delta_f``), and with ``--data`` a KITTI drive as read (the default reads its roll rate) and the same drive's
ESP channels alone (written to Parquet: ``t, vx, ay, r``; the default is then the blend on the ESP channels).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from ..fleet.bench import write_long_log
from ..io.kitti import load_kitti_oxts
from ..report.markdown import md_table
from .suite import Section, timed_command

#: the KITTI drive the section reads under ``--data`` (a validation drive of the shared data), by folder name
KITTI_DRIVE = "2011_09_26_drive_0028"
#: minutes of the synthetic ESP log
SYNTHETIC_MIN = 10.0


def first_estimate(log: Path, timeout: float = 600.0) -> dict:
    """``{"cold_s", "warm_s"}`` (s) of ``roadbank estimate log`` with empty caches, then with them filled
    (module docstring); ``{"reason": ...}`` where a run failed."""
    with tempfile.TemporaryDirectory(prefix="roadbank-first-") as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "numba"), ROADBANK_CACHE_DIR=str(Path(tmp) / "design"))
        args = ["estimate", log, "-o", Path(tmp) / "out.csv"]
        cold, why = timed_command(args, timeout, env, about=str(log))
        if cold is None:
            return {"reason": f"cold run failed: {why}"}
        warm, why = timed_command(args, timeout, env, about=str(log))
        if warm is None:
            return {"reason": f"warm run failed: {why}"}
    return {"cold_s": cold, "warm_s": warm}


def _esp_copy(drive: Path, path: Path) -> Path:
    """The KITTI ``drive``'s ESP channels (``t, vx, ay, r``, SI, ISO) written to the Parquet file ``path``."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    s = load_kitti_oxts(drive).signals
    pq.write_table(pa.table({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r}), path)
    return path


def first_run(cfg: dict) -> dict:
    """The section's cases (module docstring): ``{"cases": [{"case", "cold_s", "warm_s"} or {"case", "reason"}]}``."""
    if cfg["size"] == "tiny":
        return {"reason": "not run with --tiny (each case compiles every kernel its default runs)"}
    cases = []
    with tempfile.TemporaryDirectory(prefix="roadbank-first-logs-") as tmp:
        synthetic = Path(tmp) / "synthetic-esp.parquet"
        write_long_log(synthetic, SYNTHETIC_MIN / 60.0, ay_noise=0.05)
        logs = [(f"synthetic ESP log ({SYNTHETIC_MIN:g} min, 100 Hz)", synthetic)]
        found = sorted(Path(cfg["data"]).glob(f"*/{KITTI_DRIVE}")) if cfg.get("data") else []
        if found:
            logs += [(f"KITTI {KITTI_DRIVE} as read (roll rate: the gyro-aided default)", found[0]),
                     (f"KITTI {KITTI_DRIVE}, its ESP channels alone (Parquet)",
                      _esp_copy(found[0], Path(tmp) / f"{KITTI_DRIVE}-esp.parquet"))]
        for label, log in logs:
            cases.append({"case": label, **first_estimate(log)})
    return {"cases": cases, "data": bool(found)}


def first_run_markdown(out: dict) -> list[str]:
    rows = [[c["case"], c.get("cold_s"), c.get("warm_s"),
             c["cold_s"] - c["warm_s"] if "cold_s" in c else f"n/a: {c.get('reason')}"] for c in out["cases"]]
    note = "" if out["data"] else " (no KITTI drive: `roadbank bench --data ../shared/data` adds two cases)"
    return [md_table(["log", "first run, empty caches (s)", "again, caches filled (s)", "compile + design (s)"],
                     rows, digits=1, align="lrrr"),
            "", "`roadbank estimate LOG -o out.csv`, no other option, each run a new process "
            "(`python -m roadbank.cli`; the first with new empty `NUMBA_CACHE_DIR` and `ROADBANK_CACHE_DIR`, "
            f"`roadbank.bench.first_run`); wall time including the process start{note}."]


SECTION = Section("first_run", "A user's first roadbank estimate (empty caches)", first_run, first_run_markdown)

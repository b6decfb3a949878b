"""Benchmark section ``design``: milliseconds per estimator design, cold and cached, against
the per-point scipy path in the same run.

A design is what ``roadbank estimate``/``map``/``validate`` pay per log before filtering:
``roadbank.vehicle.make_estimator`` for the log's rate and the noise measured on its ``ay``,
plus the fixed-rate tables at that rate (``set_sample_rate``). Measured per causal estimator on
the default car at 100 Hz, each repeat with a new ``ay`` noise level (so no design is shared):

* ``cold``: design cache off (``ROADBANK_CACHE_DIR=off``) and every in-process memo emptied
  (the car's design models too): a new car, rate and noise;
* ``new noise``: as cold, but the car's design models kept from an earlier design (a fleet of
  one car whose logs each measure their own noise);
* ``cached``: the same design again in a new process' state (memos emptied) with the design on
  disk (a fresh temporary cache directory);
* ``scipy``: cold, with :func:`roadbank.estimators.synthesis.reference_solvers` (one scipy ARE
  or ``place_poles`` per grid point, the per-point discretisation): the path the whole-grid
  design replaced, the peer of the ratio.

Wall time (``time.perf_counter``) and CPU time of the process (``time.process_time``, less
sensitive to other load on a shared machine); medians over the repeats. The designs are
numpy/scipy; the fixed-rate tables' exponential is batched over the speed grid in numpy
(:mod:`roadbank.estimators.expm`), and the scipy path takes
``scipy.linalg.expm`` point by point as before.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time

from ..report.markdown import Markdown, md_table
from .suite import Section


def design_estimators() -> tuple[str, ...]:
    """The estimators timed: every causal one (the offline ``pif-smoother`` designs as
    ``pif-modified`` plus its backward table)."""
    from ..estimators import NAMES, OFFLINE
    return tuple(n for n in NAMES if n not in OFFLINE)
#: target of a cold design (ms, one core)
DESIGN_TARGET_MS = 50.0
RATE_HZ = 100.0


def _clear_memos(models: bool = True) -> None:
    from ..estimators.grid_design import clear_memos
    clear_memos(models)


def _time_design(name: str, noise: float, grid: dict, *, models: bool = True) -> tuple[float, float]:
    """Wall and CPU seconds of one design of ``name`` (memos emptied first; ``models``: the car's
    design models too)."""
    from ..vehicle import make_estimator

    _clear_memos(models)
    t0, c0 = time.perf_counter(), time.process_time()
    est = make_estimator(name, None, log_rate=RATE_HZ, log_ay_noise=noise, **grid)
    est.set_sample_rate(RATE_HZ)
    return time.perf_counter() - t0, time.process_time() - c0


def _with_cache_dir(value: str):
    old = os.environ.get("ROADBANK_CACHE_DIR")
    os.environ["ROADBANK_CACHE_DIR"] = value
    return old


def _restore_cache_dir(old) -> None:
    if old is None:
        os.environ.pop("ROADBANK_CACHE_DIR", None)
    else:
        os.environ["ROADBANK_CACHE_DIR"] = old


def design_speed(cfg: dict) -> dict:
    """ms per design per estimator: cold, new noise, cached and the scipy path (module docstring)."""
    from ..estimators.synthesis import reference_solvers

    tiny = cfg["size"] == "tiny"
    repeats = 1 if tiny else max(3, cfg.get("repeats", 3))
    ref_repeats = 1 if tiny else 2
    grid = {"v_step": 2.5, "v_max": 30.0} if tiny else {}
    rows = []
    old = _with_cache_dir("off")
    try:
        for i, name in enumerate(design_estimators()):
            noise = iter(0.05 + 0.0137 * (k + 1) + 0.001 * i for k in range(4 * repeats + 4))
            _time_design(name, next(noise), grid)                       # imports, first calls
            cold = [_time_design(name, next(noise), grid) for _ in range(repeats)]
            warm_models = [_time_design(name, next(noise), grid, models=False) for _ in range(repeats)]
            with reference_solvers():
                _time_design(name, next(noise), grid)                   # its imports (scipy.signal)
                ref = [_time_design(name, next(noise), grid) for _ in range(ref_repeats)]
            with tempfile.TemporaryDirectory(prefix="roadbank-bench-design-") as tmp:
                os.environ["ROADBANK_CACHE_DIR"] = tmp
                n = next(noise)
                _time_design(name, n, grid)                              # writes the entry
                cached = [_time_design(name, n, grid) for _ in range(repeats)]
                os.environ["ROADBANK_CACHE_DIR"] = "off"
            row = {"name": name}
            for key, runs in (("cold", cold), ("new_noise", warm_models), ("cached", cached), ("scipy", ref)):
                row[f"{key}_ms"] = 1e3 * statistics.median(r[0] for r in runs)
                row[f"{key}_cpu_ms"] = 1e3 * statistics.median(r[1] for r in runs)
            row["scipy_over_cold"] = row["scipy_ms"] / row["cold_ms"]
            row["met"] = row["cold_cpu_ms"] <= DESIGN_TARGET_MS
            rows.append(row)
    finally:
        _restore_cache_dir(old)
        _clear_memos()
    return {"rows": rows, "repeats": repeats, "scipy_repeats": ref_repeats, "rate_hz": RATE_HZ,
            "grid": grid or "default",
            "target_ms": DESIGN_TARGET_MS}


def design_markdown(out: dict) -> list[str]:
    rows = [[Markdown(f"`{r['name']}`"), f"{r['cold_ms']:.1f} ({r['cold_cpu_ms']:.1f})",
             f"{r['new_noise_ms']:.1f} ({r['new_noise_cpu_ms']:.1f})", f"{r['cached_ms']:.1f}",
             f"{r['scipy_ms']:.0f} ({r['scipy_cpu_ms']:.0f})", f"{r['scipy_over_cold']:.0f}x",
             Markdown("yes" if r["met"] else "**no**")] for r in out["rows"]]
    grid = "the default speed grids" if out["grid"] == "default" else f"a short grid {out['grid']}"
    note = (f"One design = `make_estimator` for a {out['rate_hz']:.0f} Hz log with its own `ay` noise plus "
            f"the fixed-rate tables, on the default car and {grid}; medians of {out['repeats']} repeats "
            f"(scipy: {out['scipy_repeats']}), each with a new noise level. Cold: no design cache, memos "
            "emptied; new noise: the car's design models kept; scipy: the per-point path "
            "(`synthesis.reference_solvers`) in the same run. CPU time of the process in parentheses "
            "(the machine may be shared).")
    headers = ["estimator", "cold, ms wall (CPU)", "new noise, same car", "cached (disk)",
               "scipy per point, ms (CPU)", "scipy / cold", f"cold CPU <= {out['target_ms']:.0f} ms?"]
    return [md_table(headers, rows, align="lrrrrrl"), "", note]


SECTION = Section("design", "Estimator design (ms per design)", design_speed, design_markdown)

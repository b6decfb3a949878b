"""Built-in extra sections of the benchmark suite: the exported C step and long logs.

Both are :class:`~roadbank.bench.suite.Section` objects registered by
:mod:`roadbank.bench` on import, so ``roadbank bench`` runs them after the core
measurements and a failure in one never loses the others.

* ``c_step`` -- the estimator exported as C (:func:`roadbank.export.measure_c_step_ns`,
  compiled with ``-O2``) against the compiled Python kernel (``run()``), both on the
  same synthetic 100 Hz log in the same run: ns/sample and their ratio.
* ``long_log`` -- ``roadbank estimate``'s streaming path on a generated 24 h, 100 Hz
  Parquet log (:mod:`roadbank.fleet.bench`): peak resident memory of a fresh process
  and end-to-end samples/s including reading and writing (full suite only: it writes
  a ~0.5 GB log).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from ..defaults import ESTIMATOR
from ..report.markdown import Markdown, md_table
from .suite import Section, synthetic_log, time_batch

#: estimators timed as C, and whether a float32 build is timed too: the paper's PIF and two peers, the default and
#: the baseline to beat
_C_PEERS = (("pif-modified", True), ("kalman", False), ("pio-modified", False))
C_ESTIMATORS = _C_PEERS + tuple((n, False) for n in dict.fromkeys((ESTIMATOR, "kinematic-lp"))
                                if n not in dict(_C_PEERS))
#: long-log targets: peak RSS (MiB) and end-to-end throughput (samples/s)
LONG_LOG_TARGETS = {"peak_rss_mb": 300.0, "samples_per_s": 1e6}


def c_step(cfg: dict) -> dict:
    """C step cost against the numba kernel (ns/sample), per estimator; see the module doc."""
    from .. import estimators
    from ..export import CompilerError, measure_c_step_ns

    tiny = cfg["size"] == "tiny"
    signals = synthetic_log(10.0 if tiny else 600.0)
    repeats = 1 if tiny else cfg["repeats"]
    min_samples = 2_000 if tiny else 1_000_000
    rows = []
    for name, with_f32 in C_ESTIMATORS:
        est = estimators.make(name)
        row = {"name": name, "python_ns": time_batch(est, signals, repeats)["ns_per_sample"]}
        try:
            row["c_ns"] = measure_c_step_ns(est, signals, repeats=repeats, min_samples=min_samples)
            if with_f32:
                row["c_f32_ns"] = measure_c_step_ns(est, signals, float32=True, repeats=repeats,
                                                    min_samples=min_samples)
        except CompilerError as exc:
            return {"reason": f"no C compiler: {exc}"}
        row["python_over_c"] = row["python_ns"] / row["c_ns"]
        rows.append(row)
    return {"rows": rows, "samples": len(signals)}


def c_step_markdown(out: dict) -> list[str]:
    rows = [[Markdown(f"`{r['name']}`"), r["c_ns"], r.get("c_f32_ns"), r["python_ns"], f"{r['python_over_c']:.2f}x"]
            for r in out["rows"]]
    return [md_table(["estimator", "C float64 (ns/sample)", "C float32",
                      Markdown("numba `run()` (ns/sample)"), "numba / C"], rows, digits=1, na="-", align="lrrrr"),
            "", f"Both on the same synthetic 100 Hz log ({out['samples']} samples) in this run; the C "
            "module is `roadbank export c` output with its fixed-rate tables, compiled with `-O2` "
            "(docs/embedded.md)."]


#: the CSV log of :func:`long_log` (h): 1.08 M lines, above :data:`roadbank.io.csvtable.CSV_WHOLE_BYTES`, so streamed
CSV_HOURS = 3.0


def long_log(cfg: dict, hours: float = 24.0) -> dict:
    """Streaming ``estimate`` on a generated ``hours`` h Parquet log: peak RSS (MiB) and samples/s; and on a
    :data:`CSV_HOURS` h CSV log, streamed and read whole (``load_log``), as the peer."""
    if cfg["size"] != "full":
        return {"reason": "full suite only (writes a 24 h log); "
                          "`python -m roadbank.fleet.bench` measures it on its own"}
    from ..fleet.bench import measure, write_fleet_log, write_long_log

    with tempfile.TemporaryDirectory(prefix="roadbank-longlog-") as tmp:
        log, csv = Path(tmp) / f"long-{hours:g}h.parquet", Path(tmp) / f"long-{CSV_HOURS:g}h.csv"
        write_long_log(log, hours)
        base = measure("baseline-parquet", "-", "-")
        run = measure("stream", log, Path(tmp) / "out.parquet")
        write_fleet_log(csv, CSV_HOURS * 3600.0)
        csv_mb = csv.stat().st_size / 2**20
        runs = {mode: measure(mode, csv, Path(tmp) / f"out-{mode}.parquet") for mode in ("stream", "whole")}
    out = {"hours": hours, "samples": run["samples"], "peak_rss_mb": run["peak_rss_mb"], "estimator": ESTIMATOR,
           "baseline_rss_mb": base["peak_rss_mb"], "samples_per_s": run["samples_per_s"],
           "csv": {"hours": CSV_HOURS, "file_mb": csv_mb, "samples": runs["stream"]["samples"],
                   **{f"{mode}_{k}": r[k] for mode, r in runs.items() for k in ("peak_rss_mb", "run_s")}}}
    out["met"] = {"peak_rss_mb": out["peak_rss_mb"] <= LONG_LOG_TARGETS["peak_rss_mb"],
                  "samples_per_s": out["samples_per_s"] >= LONG_LOG_TARGETS["samples_per_s"]}
    return out


def long_log_markdown(out: dict) -> list[str]:
    met = out["met"]
    rows = [[f"peak RSS, streamed {out['hours']:g} h Parquet log", f"{out['peak_rss_mb']:.0f} MiB",
             f"<= {LONG_LOG_TARGETS['peak_rss_mb']:.0f} MB", Markdown("yes" if met["peak_rss_mb"] else "**no**")],
            ["the same process before reading any row", f"{out['baseline_rss_mb']:.0f} MiB", "", ""],
            ["end to end (read + resample + estimate + write)", f"{out['samples_per_s'] / 1e6:.2f} M samples/s",
             ">= 1 M samples/s", Markdown("yes" if met["samples_per_s"] else "**no**")]]
    csv = out.get("csv")
    if csv:
        rows += [[f"peak RSS, streamed {csv['hours']:g} h CSV log ({csv['file_mb']:.0f} MiB, {csv['samples']} lines)",
                  f"{csv['stream_peak_rss_mb']:.0f} MiB", "", ""],
                 [Markdown("the same CSV read whole (`load_log`, then one run)"), f"{csv['whole_peak_rss_mb']:.0f} MiB",
                  "", ""],
                 ["its time streamed / read whole", f"{csv['stream_run_s']:.1f} / {csv['whole_run_s']:.1f} s", "", ""]]
    return [md_table(["what", "value", "target", "met?"], rows, align="lrrl"),
            "", f"{out['samples']} samples, `{out['estimator']}` (what `roadbank estimate` runs), "
            "each in a fresh process "
            "(`roadbank.fleet.bench.measure`); a CSV above 64 MiB is streamed in blocks of lines, its lines parsed "
            "twice (the time base is decided on the whole log first); more formats and the fleet speed-up: "
            "`python -m roadbank.fleet.bench`, docs/io.md."]


SECTIONS = (Section("c_step", "Exported C step (roadbank export c)", c_step, c_step_markdown),
            Section("long_log", "Long logs in bounded memory (roadbank estimate)", long_log, long_log_markdown))

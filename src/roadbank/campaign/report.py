"""The campaign report: error distributions per estimator, box plot, failure cells.

Input: the de-duplicated rows of :func:`roadbank.campaign.store.load` (one per
run and estimator). Output in the campaign directory:

- ``summary.csv`` — per estimator: runs scored, median / 95th percentile / max
  of the bank RMS and max error (deg), failure rate;
- ``failure_cells.csv`` — failure rate per estimator and parameter cell
  (binned plant front / rear stiffness scale, friction, mass scale, scenario);
- ``errors.csv`` — runs that raised, with seed and error text;
- ``boxplot.png`` — bank RMS error distribution per estimator (log axis);
- ``report.md`` — all of it in one page, with the throughput of the campaign;
- ``report.html`` — the same page, self-contained (the box plot embedded).

Failure of an estimator in a run is defined in :mod:`roadbank.campaign.runner`
(non-finite output, bank RMS > 2 deg, or an error).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..defaults import ESTIMATOR as DEFAULT
from ..evaluation.targets import Target
from ..report.html import write_document
from ..report.markdown import md_table
from ..sim.scenarios import DT_DEFAULT, LOST_CONTROL_DEG
from .runner import FAIL_RMS_DEG

#: bins of the parameter cells (edges)
CELL_BINS = {
    "cf_scale": [0.5, 0.75, 1.0, 1.25, 1.5],
    "cr_scale": [0.5, 0.75, 1.0, 1.25, 1.5],
    "mu": [0.3, 0.5, 0.75, 1.0],
    "mass_scale": [0.8, 1.0, 1.2],
}

#: roadbank's accuracy goal for a campaign: 95th-percentile bank RMS of the PIF (deg)
PIF_GOAL_P95_DEG = 1.0


def default_target(df, name: str = DEFAULT) -> Target | None:
    """The campaign target of the default estimator ``name`` (:class:`~roadbank.evaluation.targets.Target`): the
    95th percentile of its per-run bank RMS at most :data:`PIF_GOAL_P95_DEG` (stated for runs that start at standstill
    with the offsets learnt online; the label says how these ran); None where ``df`` (the campaign's rows) has no
    scored run of it."""
    ran = df[df["estimator"] == name]
    rms = ran[ran["error"] == ""]["rms_deg"].dropna()
    if not len(rms):
        return None
    p95 = float(np.percentile(rms, 95))
    how = [w for w, on in (("standstill starts", (ran["standstill_s"] > 0).any()),
                           ("offsets learnt online", ran["offsets"].astype(bool).any())) if on]
    return Target(f"campaign ({len(rms)} runs" + "".join(f", {w}" for w in how) + ")",
                  f"p95 of the bank RMS <= {PIF_GOAL_P95_DEG:g} deg", f"{p95:.3f} deg", p95 <= PIF_GOAL_P95_DEG)


def summary_table(df):
    """Per-estimator distribution of the bank RMS / max error (deg) and failure rate."""
    import pandas as pd

    rows = []
    for name, g in df.groupby("estimator", sort=False):
        ok = g[g["error"] == ""]
        rms, mx = ok["rms_deg"].dropna(), ok["max_deg"].dropna()
        q = lambda s, p: float(np.percentile(s, p)) if len(s) else float("nan")  # noqa: E731
        rows.append({"estimator": name, "runs": int(len(g)), "scored": int(len(rms)),
                     "rms_median": q(rms, 50), "rms_p95": q(rms, 95), "rms_max": q(rms, 100),
                     "max_median": q(mx, 50), "max_p95": q(mx, 95), "max_max": q(mx, 100),
                     "nonfinite_runs": int(ok["nonfinite"].sum()), "errors": int((g["error"] != "").sum()),
                     "fail_rate": float(g["failed"].mean())})
    return pd.DataFrame(rows)


def failure_cells(df, min_runs: int = 5):
    """Failure rate per estimator in each one-parameter cell (bin of one parameter, or a scenario).

    Returns a tidy frame ``estimator, parameter, cell, runs, fail_rate`` sorted by
    decreasing failure rate; cells with fewer than ``min_runs`` runs are dropped.
    """
    import pandas as pd

    parts = []
    for par, edges in CELL_BINS.items():
        cell = pd.cut(df[par], edges, include_lowest=True).astype(str)
        g = df.assign(cell=cell).groupby(["estimator", "cell"], observed=True)["failed"]
        t = g.agg(["size", "mean"]).reset_index().rename(columns={"size": "runs", "mean": "fail_rate"})
        t.insert(1, "parameter", par)
        parts.append(t)
    g = df.groupby(["estimator", "scenario"])["failed"].agg(["size", "mean"]).reset_index()
    g = g.rename(columns={"scenario": "cell", "size": "runs", "mean": "fail_rate"})
    g.insert(1, "parameter", "scenario")
    parts.append(g)
    out = pd.concat(parts, ignore_index=True)
    out = out[out["runs"] >= min_runs]
    return out.sort_values(["estimator", "fail_rate"], ascending=[True, False]).reset_index(drop=True)


def worst_cells(cells, top: int = 3):
    """The ``top`` cells of highest failure rate per estimator (only cells with failures)."""
    c = cells[cells["fail_rate"] > 0]
    return c.groupby("estimator", sort=False).head(top)


def scenario_table(df):
    """95th percentile of the bank RMS error (deg) per scenario (rows) and estimator (columns)."""
    ok = df[(df["error"] == "") & np.isfinite(df["rms_deg"])]
    t = ok.pivot_table(index="scenario", columns="estimator", values="rms_deg",
                       aggfunc=lambda s: float(np.percentile(s, 95)))
    names = [n for n in dict.fromkeys(df["estimator"]) if n in t.columns]
    return t[names].reset_index()


def lost_control(df, beta_deg: float = LOST_CONTROL_DEG) -> int:
    """Runs in which the plant itself lost control (max sideslip above ``beta_deg``)."""
    runs = df.drop_duplicates("run_id")
    return int((runs["max_beta_deg"] > beta_deg).sum())


def box_plot(df, path: Path) -> None:
    """Box plot of the bank RMS error (deg) per estimator, log axis, the goal line dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = df[(df["error"] == "") & np.isfinite(df["rms_deg"])]
    names = list(dict.fromkeys(df["estimator"]))
    data = [np.clip(ok.loc[ok["estimator"] == n, "rms_deg"].to_numpy(), 1e-3, None) for n in names]
    fig, ax = plt.subplots(figsize=(8, 4.2))
    ax.boxplot(data, whis=(5, 95), showfliers=True, flierprops={"markersize": 2})
    ax.set_xticks(range(1, len(names) + 1), names, rotation=30, ha="right")
    ax.set_yscale("log")
    ax.axhline(PIF_GOAL_P95_DEG, ls="--", lw=0.8, color="k", label="1 deg (PIF p95 goal)")
    ax.axhline(FAIL_RMS_DEG, ls=":", lw=0.8, color="r", label=f"{FAIL_RMS_DEG:g} deg (failure)")
    ax.set_ylabel("bank RMS error (deg)")
    ax.set_title(f"Campaign: bank RMS error per estimator ({ok['run_id'].nunique()} runs; whiskers 5-95 %)")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _md_table(frame, best=None, best_in: str = "row") -> str:
    """A data frame as a markdown table (:func:`roadbank.report.markdown.md_table`; floats to 2 decimals)."""
    rows = [[v.item() if isinstance(v, np.generic) else v for v in r]
            for r in frame.itertuples(index=False, name=None)]
    return md_table([str(c) for c in frame.columns], rows, best=best, best_in=best_in)


#: the summary's error columns: the smallest of each column is the best estimator
SUMMARY_BEST = {c: "min" for c in ("rms_median", "rms_p95", "rms_max", "max_median", "max_p95", "max_max",
                                   "fail_rate")}


def _step_text(sim_dt) -> str:
    """The plant step of a campaign's settings, in words (None: the simulator's default)."""
    return (f"the simulator's default ({DT_DEFAULT * 1e3:g} ms at 100 Hz sensors)" if sim_dt is None
            else f"{sim_dt * 1e3:g} ms")


def _trim_text(choice, runs) -> str:
    """What the report says of the designs' rear trim (``RunOptions.rear_trim``, absent from a campaign stored before
    it: off) and on how many of ``runs`` (a row per run) it trimmed."""
    if not choice:
        return "; the designs' rear cornering stiffness not trimmed to the runs"
    trimmed = int((runs["rear_trim"].fillna(1.0) != 1.0).sum()) if "rear_trim" in runs else 0
    how = "to a softer axle only" if choice == "softer" else "either way"
    return f"; the designs' rear cornering stiffness trimmed to each run {how} ({trimmed} runs trimmed)"


def write_report(outdir, df, settings: dict, throughput: dict | None = None) -> Path:
    """Write summary.csv, failure_cells.csv, errors.csv, boxplot.png, report.md and report.html into
    ``outdir``; returns the path of report.md.

    Parameters
    ----------
    df : DataFrame
        Rows of :func:`roadbank.campaign.store.load`.
    settings : dict
        The campaign settings (``campaign.json``).
    throughput : dict, optional
        ``workers, runs, wall_s, startup_s, runs_per_s`` of the call that just ran.
    """
    out = Path(outdir)
    summ = summary_table(df)
    cells = failure_cells(df)
    summ.to_csv(out / "summary.csv", index=False)
    cells.to_csv(out / "failure_cells.csv", index=False)
    runs = df.drop_duplicates("run_id")
    errs = runs[runs["error"] != ""][["run_id", "noise_seed", "scenario", "error"]]
    errs.to_csv(out / "errors.csv", index=False)
    box_plot(df, out / "boxplot.png")
    opts = settings.get("options", {})
    n = runs["run_id"].nunique()
    lines = [f"# Monte-Carlo campaign: {n} runs", "",
             f"Seed {settings.get('seed')}; scenarios {', '.join(sorted(runs['scenario'].unique()))}; "
             f"scenario duration x {opts.get('duration_scale', 1.0):g}"
             + (" (manoeuvres truncated)" if opts.get("duration_scale", 1.0) < 1 else " (full paper durations)")
             + f"; plant integration step {_step_text(opts.get('sim_dt'))}; "
             f"scores after {opts.get('settle', 2.0):g} s"
             + (f" of driving; each run starts with {opts['standstill']:g} s of standstill"
                if opts.get("standstill") else "")
             + ("; sensor offsets learnt online" if opts.get("offsets") else "; no online offset learning")
             + _trim_text(opts.get("rear_trim"), runs)
             + ". Perturbations: see roadbank.campaign.sampling.", "",
             f"Failure of an estimator in a run: non-finite output, bank RMS error > {FAIL_RMS_DEG:g} deg, "
             "or an error raised.", ""]
    pif = summ[summ["estimator"] == "pif-modified"]
    if len(pif):
        p95 = float(pif["rms_p95"].iloc[0])
        verdict = "meets" if p95 <= PIF_GOAL_P95_DEG else "misses"
        lines += [f"**PIF (modified model) 95th-percentile bank RMS: {p95:.2f} deg** — {verdict} the "
                  f"{PIF_GOAL_P95_DEG:g} deg goal.", ""]
    own = default_target(df)
    if own is not None:
        lines += [f"**The default ({DEFAULT}) 95th-percentile bank RMS: {own.measured}** — "
                  f"{'meets' if own.met else 'misses'} the {PIF_GOAL_P95_DEG:g} deg goal.", ""]
    lines += ["## Bank error per estimator (deg)", "", _md_table(summ, SUMMARY_BEST, "column"), "",
              "Best (smallest) error and failure rate of each column in bold.", "", "![box plot](boxplot.png)", "",
              "## 95th-percentile bank RMS (deg) per scenario", "", _md_table(scenario_table(df), best="min"), "",
              "Best (smallest) value of each line in bold.", "",
              f"Runs in which the plant lost control (max sideslip > 10 deg; the largest errors of every "
              f"estimator): {lost_control(df)}.", "",
              "## Where estimators fail (worst one-parameter cells)", "",
              "Failure rate per cell of one parameter (bins of the plant's front/rear cornering stiffness "
              "scale, friction, mass scale, or the scenario); full table in failure_cells.csv.", ""]
    wc = worst_cells(cells)
    lines += [_md_table(wc) if len(wc) else "No failures.", ""]
    lines += ["## Runs that raised", "", f"{len(errs)} run(s); see errors.csv." if len(errs) else "None.", ""]
    if throughput:
        lines += ["## Throughput of the last call", "",
                  f"{throughput['runs']} runs on {throughput['workers']} worker(s): "
                  f"{throughput['wall_s']:.1f} s ({throughput['runs_per_s']:.1f} runs/s) after "
                  f"{throughput['startup_s']:.1f} s cluster start-up and warm-up. Mean per-run cost in "
                  f"the workers: simulation {runs['sim_s'].mean() * 1e3:.1f} ms, all estimators "
                  f"{df.groupby('run_id')['est_s'].sum().mean() * 1e3:.1f} ms.", ""]

    text = "\n".join(lines)
    write_document(out / "report.html", text, f"roadbank campaign: {n} runs")
    return write_document(out / "report.md", text)

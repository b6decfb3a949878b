"""``roadbank reproduce``: the paper's simulation study into a folder."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import click

from .options import PathOption, SEED, checked_output, output_path_problem, vehicle_option


def _split(values):
    out = []
    for v in values:
        out += [x for x in v.split(",") if x]
    return out


def _clock(seconds: float) -> str:
    m, s = divmod(int(round(seconds)), 60)
    return f"{m:02d}:{s:02d}"


class _CellProgress:
    """Progress callback of :func:`roadbank.report.reproduce.run_study` on a click progress bar.

    The time left is only shown from the second finished cell on, timed from the first one's
    end: the first cell also compiles or loads the kernels and designs the estimators, which
    the others do not repeat.
    """

    def __init__(self, bar, n_cells: int):
        self.bar, self.n, self.done, self.t_first = bar, n_cells, 0, None

    def __call__(self, res) -> None:
        self.done += 1
        now = time.perf_counter()
        if self.t_first is None:
            self.t_first = now
            text = f"first cell in {res.seconds:.1f} s"
        else:
            left = (now - self.t_first) / (self.done - 1) * (self.n - self.done)
            text = f"{_clock(left)} left"
        self.bar.update(1, text if self.done < self.n else "done")


@click.command()
@click.option("-o", "--outdir", type=PathOption(file_okay=False, path_type=Path), required=True,
              callback=checked_output(directory=True),
              help="Output folder for figures, tables and the report.")
@click.option("--scenarios", multiple=True,
              help="Scenarios to run (default: all of the paper's study). Repeat or comma-separate.")
@click.option("--estimators", "names", multiple=True,
              help="Estimators to run and to draw in the figures (default: all, the figures a selection). "
                   "Each name is the same filter and tuning as in `roadbank estimate -e`: pif-modified "
                   "is roadbank's default tuning, pif-paper the paper's Table 4 (the claims' PIF).")
@click.option("--jobs", "-j", type=click.IntRange(min=1), default=None, help="Parallel processes (default: all cores).")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Sensor-noise seed.")
@click.option("--docs", "docs_results", type=PathOption(dir_okay=False, path_type=Path), default=None,
              callback=checked_output(),
              help="Also write the tables to this markdown file (e.g. docs/results.md).")
@vehicle_option("The paper's scenarios and conditions with this car as plant (and its sensors) and as "
                "the estimators' design; its [tuning.<name>] tables apply to the column of that name "
                "(pif-paper is Table 4 as published).")
def reproduce(outdir, scenarios, names, jobs, seed, docs_results, vehicle):
    """Run every estimator on every scenario x condition of the paper and write the report."""
    t_start = time.perf_counter()            # before the imports: they are part of the command's time
    from ..report.coldstart import cold_families, compile_estimate_s
    from ..report.reproduce import COLUMNS, check_estimators, plan, run_study, write_outputs
    from ..report.labels import tuning_of
    from ..report.tables import lookup

    chosen = _split(names)
    names = chosen or list(COLUMNS)
    scenarios = _split(scenarios) or None
    try:
        cells = plan(scenarios)
        check_estimators(names)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None
    files = ("report.md", "report.html", "metrics.csv", "metrics.parquet")
    for inner, folder in [(outdir / f, False) for f in files] + [(outdir / "figures", True)]:
        why = output_path_problem(inner, directory=folder)      # what is written inside, before the work
        if why:
            raise click.BadParameter(why, param_hint="-o")
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise click.ClickException(f"cannot create output folder {outdir}: {exc}") from None

    cold = cold_families(names)
    if cold:
        click.echo(f"compiling the kernels once (about {compile_estimate_s(cold):.0f} s on an idle core; "
                   f"later runs load them from the cache): {', '.join(cold)}", err=True)
    with click.progressbar(length=len(cells), label=f"{len(cells)} cells x {len(names)} estimators",
                           show_eta=False, item_show_func=lambda s: s, file=sys.stderr) as bar:
        study = run_study(scenarios, names, jobs=jobs, seed=seed, progress=_CellProgress(bar, len(cells)),
                          vehicle=vehicle)
    written = write_outputs(study, outdir, docs_results=docs_results, jobs=jobs,
                            figure_names=chosen or None, started=t_start)
    total_s = time.perf_counter() - t_start

    rms = lookup(study.rows, "bank", "rms_deg")
    show = [n for n in ("pif-paper", "pif-modified", "pif-rate", "pio-original", "dfc", "uio", "kalman")
            if n in names] or names
    click.echo(f"\nBank RMS error (deg) after 2 s, {vehicle.name} — {len(cells)} cells in {study.wall_s:.1f} s")
    click.echo(f"{'scenario':18s} {'condition':11s} " + " ".join(f"{n[:12]:>12s}" for n in show))
    for (sc, cond) in study.cells:
        click.echo(f"{sc:18s} {cond:11s} " + " ".join(f"{rms.get((sc, cond, n), float('nan')):12.2f}" for n in show))
    paper = [n for n in show if tuning_of(n) == "Table 4"]
    if paper:
        click.echo(f"{', '.join(paper)}: the paper's Table 4 weights; the others: roadbank's default tuning "
                   "(the filters of `roadbank estimate -e NAME`)")
    click.echo(f"\nReport: {written['report'][0]}  Tables: {written['tables'][0]}  "
               f"(total {total_s:.1f} s)")

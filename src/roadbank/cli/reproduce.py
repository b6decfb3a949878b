"""``roadbank reproduce``: the paper's simulation study into a folder."""

from __future__ import annotations

import time
from pathlib import Path

import click

from .options import vehicle_option


def _split(values):
    out = []
    for v in values:
        out += [x for x in v.split(",") if x]
    return out


@click.command()
@click.option("-o", "--outdir", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Output folder for figures, tables and the report.")
@click.option("--scenarios", multiple=True, help="Scenarios to run (default: all of SPEC 6). Repeat or comma-separate.")
@click.option("--estimators", "names", multiple=True,
              help="Estimators to run (default: all, plus pif-default = the default-tuned PIF; "
                   "pif-modified/pif-original use the paper's Table 4).")
@click.option("--jobs", "-j", type=click.IntRange(min=1), default=None, help="Parallel processes (default: all cores).")
@click.option("--seed", type=int, default=0, show_default=True, help="Sensor-noise seed.")
@click.option("--docs", "docs_results", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the tables to this markdown file (e.g. docs/results.md).")
@vehicle_option("The paper's scenarios and conditions with this car as plant (and its sensors) and as "
                "the estimators' design; its [tuning] tables apply to every column except the published "
                "PIFs (Table 4), so pif-default is the car's tuned PIF.")
def reproduce(outdir, scenarios, names, jobs, seed, docs_results, vehicle):
    """Run every estimator on every scenario x condition of the paper and write the report."""
    from ..report.reproduce import COLUMNS, check_estimators, plan, run_study, write_outputs
    from ..report.tables import lookup

    t_start = time.perf_counter()
    names = _split(names) or list(COLUMNS)
    scenarios = _split(scenarios) or None
    try:
        cells = plan(scenarios)
        check_estimators(names)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise click.ClickException(f"cannot create output folder {outdir}: {exc}") from None

    with click.progressbar(length=len(cells), label=f"{len(cells)} cells x {len(names)} estimators",
                           file=click.get_text_stream("stderr")) as bar:
        study = run_study(scenarios, names, jobs=jobs, seed=seed, progress=lambda res: bar.update(1),
                          vehicle=vehicle)
    written = write_outputs(study, outdir, docs_results=docs_results, jobs=jobs)
    total_s = time.perf_counter() - t_start

    rms = lookup(study.rows, "bank", "rms_deg")
    show = [n for n in ("pif-modified", "pif-default", "pif-rate", "pio-original", "dfc", "uio", "kalman")
            if n in names] or names
    click.echo(f"\nBank RMS error (deg) after 2 s, {vehicle.name} — {len(cells)} cells in {study.wall_s:.1f} s")
    click.echo(f"{'scenario':18s} {'condition':11s} " + " ".join(f"{n[:12]:>12s}" for n in show))
    for (sc, cond) in study.cells:
        click.echo(f"{sc:18s} {cond:11s} " + " ".join(f"{rms.get((sc, cond, n), float('nan')):12.2f}" for n in show))
    click.echo(f"\nReport: {written['report'][0]}  Tables: {written['tables'][0]}  "
               f"(total {total_s:.1f} s)")

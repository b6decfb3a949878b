"""``roadbank campaign``: a Monte-Carlo campaign of randomised simulator runs on Dask.

Runs ``--runs N`` randomised runs (plant and sensor perturbations around the
design values, the paper's five scenarios) through every estimator, storing
results in ``OUTDIR/parts/*.parquet`` as batches finish, then writes the report
(``OUTDIR/report.md`` and the self-contained ``report.html``, ``summary.csv``, ``failure_cells.csv``, ``boxplot.png``).
Interrupted (Ctrl-C)? Run the same command with ``--resume``.
"""

from __future__ import annotations

from pathlib import Path

import click

from .options import PathOption, SEED, checked_output, vehicle_option
from .parallel import scheduler_option

#: ``--rear-trim`` -> :attr:`roadbank.campaign.runner.RunOptions.rear_trim`
_TRIMS = {"softer": "softer", "either": True, "off": False}


@click.command()
@click.option("--runs", "-n", type=click.IntRange(min=1), required=True, help="Number of runs.")
@click.option("--output", "-o", "outdir", required=True, type=PathOption(file_okay=False, path_type=Path),
              callback=checked_output(directory=True), help="Campaign directory (created).")
@scheduler_option("Dask scheduler address (tcp://host:8786 or host:8786). Default: a local cluster.",
                  metavar="ADDRESS")
@click.option("--workers", "-j", type=click.IntRange(min=1), default=2, show_default=True,
              help="Worker processes of the local cluster.")
@click.option("--resume", is_flag=True, help="Continue the campaign stored in OUTDIR.")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Campaign seed.")
@click.option("--batch-size", type=click.IntRange(min=1), default=50, show_default=True,
              help="Runs per Dask task.")
@click.option("--duration-scale", type=click.FloatRange(0.0, 1.0, min_open=True), default=1.0,
              show_default=True, help="Factor on the scenario durations (<1 truncates the manoeuvres).")
@click.option("--sim-dt", type=click.FloatRange(0.0, 0.01, min_open=True), default=None,
              help="Plant integration step (s) [default: the simulator's, 2 ms at 100 Hz sensors].")
@click.option("--estimators", default="", help="Comma-separated estimator names (default: all).")
@click.option("--standstill", type=click.FloatRange(min=0.0), default=3.0, show_default=True,
              help="Seconds of standstill before each run (s).")
@click.option("--offsets/--no-offsets", default=True, show_default=True,
              help="Estimators learn the yaw-rate and steering offsets online.")
@click.option("--rear-trim", type=click.Choice(sorted(_TRIMS)), default=None,
              help="Trim the designs' rear cornering stiffness to each run: to a softer axle only, either way, or "
                   "not [default: softer, as every command trims a described car's to its log].")
@vehicle_option("Runs perturb this car (plant and sensors); the estimators are designed for it "
                "(parameters and [tuning] tables).")
def campaign(runs, outdir, scheduler, workers, resume, seed, batch_size, duration_scale, sim_dt, estimators,
             standstill, offsets, rear_trim, vehicle):
    """Run a Monte-Carlo campaign and write its report into OUTDIR."""
    from ..campaign import store
    from ..campaign.runner import RunOptions

    names = tuple(n.strip() for n in estimators.split(",") if n.strip())
    if names:
        from ..estimators import NAMES
        bad = [n for n in names if n not in NAMES]
        if bad:
            raise click.BadParameter(f"unknown estimator(s) {', '.join(bad)} (choose from {', '.join(NAMES)})",
                                     param_hint="--estimators")
    from ..vehicle import load_vehicle

    # the paper SUV stays None: its campaigns resume those stored before vehicle files
    trim = {} if rear_trim is None else {"rear_trim": _TRIMS[rear_trim]}
    options = RunOptions(names=names, duration_scale=duration_scale, sim_dt=sim_dt, standstill=standstill,
                         offsets=offsets, vehicle=None if vehicle == load_vehicle(None) else vehicle, **trim)
    from ..campaign.execute import DaskMissing, run_campaign, settings_of

    def progress(done, total):
        click.echo(f"\r{done}/{total} runs stored", nl=False, err=True)

    try:
        res = run_campaign(outdir, runs, seed=seed, options=options, scheduler=scheduler, workers=workers,
                           batch_size=batch_size, resume=resume, progress=progress)
    except KeyboardInterrupt:
        done = len(store.stored_run_ids(outdir)) if outdir.exists() else 0
        click.echo(f"\ninterrupted: {done} run(s) stored in {outdir}; continue with --resume", err=True)
        raise SystemExit(130) from None
    except (DaskMissing, store.StoreError, ConnectionError, ValueError, OSError) as exc:
        raise click.ClickException(str(exc)) from None
    click.echo("", err=True)
    from ..campaign.report import write_report

    df = store.load(outdir)
    throughput = None
    if res.completed:
        throughput = {"workers": res.workers, "runs": res.completed, "wall_s": res.wall_s,
                      "startup_s": res.startup_s, "runs_per_s": res.runs_per_s}
    path = write_report(outdir, df, settings_of(runs, seed, options), throughput)
    click.echo(f"{res.completed} run(s) computed, {res.already_stored} already stored, "
               f"{len(res.failed_runs)} raised; "
               + (f"{res.runs_per_s:.1f} runs/s on {res.workers} worker(s); " if res.completed else "")
               + f"report: {path}")

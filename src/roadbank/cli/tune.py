"""``roadbank tune``: tune a car's estimators on simulated drives and write them to its vehicle file.

Draws a randomised training set of simulated drives for the car (bank steps, superelevated
curves, lane changes, driving near the tyre limit; plant Cf, Cr, mass and accelerometer
alignment perturbed), optimises each tunable estimator's weights on it (differential
evolution, deterministic for ``--seed``), scores them on a separate validation set of road
and car families the optimiser never sees, and writes ``[tuning.<estimator>]`` and
``[scores.<estimator>]`` into the output TOML. See docs/estimators.md ("Tuning").
"""

from __future__ import annotations

import time
from pathlib import Path

import click

from .options import PathOption, SEED, checked_output, vehicle_option
from .parallel import scheduler_option


@click.command()
@vehicle_option("Its parameters design the estimators; its sensors and plant data shape the drives.")
@click.option("-o", "--output", "out", required=True, type=PathOption(dir_okay=False, path_type=Path),
              callback=checked_output(suffixes=(".toml",), what="tune writes a vehicle file"),
              help="Vehicle file to write, .toml (the input car plus the tuned [tuning] and [scores] tables); "
                   "checked before the tuning starts (its folder is created if missing).")
@click.option("--budget", type=click.IntRange(min=5), default=None,   # min: tuning.optimise.MIN_POPULATION
              help="Objective evaluations per estimator, at most, the start point included (default 240: "
                   "about 1 min on 2 cores; at least 5, the smallest population of the optimiser).")
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Seed of the drive sets and the optimiser (same seed, same result).")
@click.option("--estimators", "names", default="", help="Comma-separated estimators to tune "
              "(default: pif-modified, pif-rate, kalman, pio-modified, dfc; also pif-adaptive, "
              "pif-rate-adaptive, pif-gated).")
@click.option("--jobs", "-j", type=click.IntRange(min=1), default=2, show_default=True,
              help="Local worker processes (ignored with --scheduler).")
@scheduler_option("Dask scheduler address (tcp://host:8786 or host:8786): evaluate there instead of locally.",
                  metavar="ADDRESS")
@click.option("--train-drives", type=click.IntRange(min=4), default=None, help="Drives in the training set (48).")
@click.option("--validation-drives", type=click.IntRange(min=4), default=None,
              help="Drives in the validation set (40).")
def tune(vehicle, out, budget, seed, names, jobs, scheduler, train_drives, validation_drives):
    """Tune the estimators for a car (--vehicle) and write the result to a vehicle file."""
    from ..sim.scenarios import LOST_CONTROL_DEG
    from ..tuning import pipeline
    from ..tuning.spaces import ON_REQUEST, TUNABLE

    chosen = tuple(n.strip() for n in names.split(",") if n.strip()) or TUNABLE
    bad = [n for n in chosen if n not in TUNABLE + ON_REQUEST]
    if bad:
        from ..estimators import TUNED_AS
        hint = "".join(f"; {n} runs {TUNED_AS[n]} with that one's weights" for n in bad if n in TUNED_AS)
        raise click.BadParameter(f"cannot tune {', '.join(bad)} (tunable: {', '.join(TUNABLE + ON_REQUEST)}){hint}",
                                 param_hint="--estimators")
    budget = budget or pipeline.DEFAULT_BUDGET
    t0 = time.perf_counter()
    bar = click.progressbar(length=budget * len(chosen), label=f"tuning {', '.join(chosen)}",
                            file=click.get_text_stream("stderr"), show_pos=True)
    last = [0]

    def progress(stage, done, total):
        if stage == "tuning":
            bar.update(done - last[0])
            last[0] = done
        else:
            click.echo(f"{stage}: {total} drives", err=True)

    try:
        with bar:
            outcome = pipeline.tune_car(
                vehicle.params, vehicle.to_plant(), vehicle.sensors.to_sim(), names=chosen, budget=budget,
                seed=seed, n_train=train_drives or pipeline.DEFAULT_TRAIN,
                n_validation=validation_drives or pipeline.DEFAULT_VALIDATION, jobs=jobs, scheduler=scheduler,
                current=dict(vehicle.tuning), progress=progress)
    except (ConnectionError, RuntimeError, ValueError) as exc:
        raise click.ClickException(str(exc)) from None
    tuned = vehicle
    for name in chosen:
        tuned = tuned.with_tuning(name, outcome.options[name], outcome.scores[name])
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        tuned.to_toml(out)
    except OSError as exc:
        raise click.ClickException(f"cannot write {out}: {exc}") from None

    click.echo(f"\nValidation set ({outcome.validation[chosen[0]].n} drives, roads and cars not used "
               "for tuning): bank error (deg)")
    click.echo(f"{'estimator':24s} {'median RMS':>10s} {'p95 RMS':>8s} {'mean max':>9s}")
    for name, s in sorted(outcome.validation.items(), key=lambda kv: kv[1].median_rms):
        mark = " (tuned)" if name in chosen else ""
        click.echo(f"{name + mark:24s} {s.median_rms:10.3f} {s.p95_rms:8.3f} {s.mean_max:9.3f}")
    if any(outcome.left_out.values()):
        click.echo(f"\nnote: left out {outcome.left_out['train']} training and {outcome.left_out['validation']} "
                   "validation drive(s) on which the simulated car lost control (sideslip above "
                   f"{LOST_CONTROL_DEG:g} deg: the drawn tyres and friction beyond its grip); no estimator's model "
                   "holds there", err=True)
    click.echo(f"\nwrote {out} ({time.perf_counter() - t0:.0f} s)")

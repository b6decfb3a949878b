"""``roadbank validate``: check the estimators on real driving data."""

from __future__ import annotations

import contextlib
import json
import sys
from pathlib import Path

import click

from ..report.html import write_document
from .options import SEED, checked_output, vehicle_option
from .parallel import pool_options, start_pool

_VEHICLE = vehicle_option("The estimators are designed for this car: its parameters and [tuning] tables.",
                          default_help="a car nobody described: the shipped sedan's parameters (README)",
                          none_if_absent=True)


def _car(vehicle) -> dict:
    """``validate_*`` keyword arguments for ``--vehicle`` (none: the data set's default car)."""
    return {} if vehicle is None else {"params": vehicle.params, "tuning": dict(vehicle.tuning),
                                       "sensors": vehicle.sensors}


@click.group()
def validate():
    """Validate the estimators on real data sets."""


def _names(names: str) -> list[str]:
    """``--estimators`` value -> list of names (BadParameter for an unknown one)."""
    from .. import estimators

    sel = list(estimators.NAMES) if names.strip() == "all" else [n.strip() for n in names.split(",") if n.strip()]
    bad = [n for n in sel if n not in estimators.NAMES]
    if bad:
        raise click.BadParameter(f"unknown estimator(s) {bad}", param_hint="--estimators")
    return sel


def _comma2k19_outcome(path, **kwargs):
    """``(ValidationResult, None)`` of one comma2k19 segment, or ``(None, reason)`` (one pool task)."""
    from ..validation import validate_comma2k19

    try:
        return validate_comma2k19(path, **kwargs), None
    except (ValueError, OSError) as exc:       # LogError is a ValueError
        return None, str(exc)


def _outcome(pool, task, what) -> tuple:
    """``(value, reason)`` of a task whose value is itself ``(value, reason)``."""
    value, failure = pool.outcome(task)
    return value if failure is None else (None, f"{what}: {failure}")


_ESTIMATORS = click.option("--estimators", "-e", "names", default="all", show_default=True,
                           help="Comma-separated estimator names or 'all'.")


@validate.command("comma2k19")
@click.argument("path", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True,
              help='Print {estimator: {"r", "rms_deg", "offset_deg"}} on stdout.')
@click.option("-o", "--output", type=click.Path(path_type=Path), default=None,
              callback=checked_output(next_to=(".png",)),
              help="Write the markdown report here (e.g. docs/real-data.md; .html: a self-contained page) "
                   "and a PNG next to it.")
@_ESTIMATORS
@click.option("--no-sensitivity", is_flag=True, help="Skip the SUV-parameter and PIF-Q sensitivity runs.")
@_VEHICLE
@pool_options("Tasks", "The segment is one task: more workers do not make it faster; `validate all` runs "
                       "it next to the KITTI drives.")
def comma2k19(path, as_json, output, names, no_sensitivity, vehicle, workers, scheduler):
    """Score every estimator against the pose-derived roll of a comma2k19 segment at PATH."""
    from ..validation import markdown, plot, to_json

    sel = _names(names)
    with contextlib.ExitStack() as stack:
        pool = start_pool(stack, workers, scheduler)
        task = pool.submit(_comma2k19_outcome, path, names=sel, sensitivity=not no_sensitivity, **_car(vehicle))
        res, error = _outcome(pool, task, path)
    if error is not None:
        click.echo(f"error: {error}", err=True)
        sys.exit(1)
    if output is not None:
        fig = output.with_suffix(".png")
        plot(res, fig)
        cmd = f"roadbank validate comma2k19 {path} -o {output}" + (f" --vehicle {vehicle.name}" if vehicle else "")
        output.parent.mkdir(parents=True, exist_ok=True)
        write_document(output, markdown(res, figure=fig.name, command=cmd))
        click.echo(f"wrote {output} and {fig}", err=True)
    if as_json:
        click.echo(json.dumps(to_json(res), indent=2))
    elif output is None:
        for name, v in to_json(res).items():
            click.echo(f"{name:14s} r = {v['r']:.3f}  rms = {v['rms_deg']:.3f} deg  "
                       f"offset = {v['offset_deg']:+.3f} deg")


def _write_kitti_figures(v, output: Path) -> dict:
    """Write the drive figures of ``v`` (PNG bytes drawn by the drives' tasks) next to the report at
    ``output``; ``{drive: file name}``."""
    from ..validation.kitti_report import figure_name

    output.parent.mkdir(parents=True, exist_ok=True)
    figs = {}
    for label, png in v.figures.items():
        figs[label] = figure_name(output.stem, label)
        (output.parent / figs[label]).write_bytes(png)
    return figs


@validate.command("kitti")
@click.argument("paths", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True,
              help='Print {"drives": {drive: {estimator: scores}}, "pooled": {...}, "errors": [...]} on stdout.')
@click.option("-o", "--output", type=click.Path(path_type=Path), default=None, callback=checked_output(),
              help="Write the markdown report (KITTI section; .html: a self-contained page) here and one "
                   "PNG per drive next to it.")
@_ESTIMATORS
@click.option("--no-sensitivity", is_flag=True,
              help="Skip the sensitivity runs (the paper's SUV parameters; the PIFs designed from the data "
                   "sheet alone).")
@_VEHICLE
@pool_options("Drives")
def kitti(paths, as_json, output, names, no_sensitivity, vehicle, workers, scheduler):
    """Score every estimator against the INS roll of KITTI raw drives.

    PATHS: drive folders (holding oxts/), oxts folders, or folders holding drive folders.
    A drive that cannot be read is reported and the others are still scored (exit code 1 then).
    With --workers or --scheduler each drive is one task; the report is the same as in one process.
    """
    from ..validation.kitti import validate_kitti
    from ..validation.kitti_report import drive_png, markdown, to_json

    sel = _names(names)
    with contextlib.ExitStack() as stack:
        pool = start_pool(stack, workers, scheduler)
        v = validate_kitti(paths, names=sel, sensitivity=not no_sensitivity, pool=pool,
                           figure=None if output is None else drive_png, **_car(vehicle))
    for e in v.errors:
        click.echo(f"error: {e}", err=True)
    if not v.drives:
        click.echo("error: no KITTI drive could be read", err=True)
        sys.exit(1)
    if output is not None:
        figs = _write_kitti_figures(v, output)
        cmd = ("roadbank validate kitti " + " ".join(map(str, paths)) + f" -o {output}"
               + (f" --vehicle {vehicle.name}" if vehicle else ""))
        write_document(output, f"# Real-data validation: KITTI\n\n_Generated by `{cmd}`; do not edit by hand._\n\n"
                       + markdown(v, figs, level=2))
        click.echo(f"wrote {output} and {len(figs)} figure(s)", err=True)
    if as_json:
        click.echo(json.dumps(to_json(v), indent=2))
    elif output is None:
        for d in v.drives:
            click.echo(d.label)
            for name, sc in d.scores.items():
                if sc.valid_fraction == 0:
                    click.echo(f"  {name:14s} no valid sample (needs the steering angle)")
                else:
                    click.echo(f"  {name:14s} rms raw = {sc.rms_raw_deg:.3f} deg  r raw = {sc.r_raw:.3f}  "
                               f"rms smoothed = {sc.rms_deg:.3f} deg  r smoothed = {sc.r:.3f}")
    if v.errors:
        sys.exit(1)


@validate.command("all")
@click.argument("data_dir", type=click.Path(path_type=Path, exists=True, file_okay=False))
@click.option("-o", "--output", type=click.Path(path_type=Path), required=True,
              callback=checked_output(next_to=(".png",)),
              help="The combined report (e.g. docs/real-data.md; .html: a self-contained page); figures "
                   "are written next to it.")
@click.option("--no-jitter", is_flag=True, help="Skip the 10 Hz-with-jitter simulation study.")
@pool_options("Tasks", "One task each: the comma2k19 segment, every KITTI drive, every jitter scenario.")
def all_(data_dir, output, no_jitter, workers, scheduler):
    """One report over every real data set under DATA_DIR (comma2k19 segments, KITTI drives).

    Regenerate docs/real-data.md with: roadbank validate all ../shared/data -o docs/real-data.md
    """
    from ..validation import plot
    from ..validation.document import find_datasets, real_data_markdown
    from ..validation.jitter import jitter_study
    from ..validation.kitti import validate_kitti
    from ..validation.kitti_report import drive_png

    found = find_datasets(data_dir)
    if not found["comma2k19"] and not found["kitti"]:
        click.echo(f"error: {data_dir}: no comma2k19 segment or KITTI drive found", err=True)
        sys.exit(1)
    output.parent.mkdir(parents=True, exist_ok=True)
    figs, comma, kv, failed = {}, None, None, False
    scenarios = () if no_jitter else ("bank-lane-change", "s-curve", "track-lane-change")
    with contextlib.ExitStack() as stack:
        pool = start_pool(stack, workers, scheduler)
        # submitted first, so that on workers they run while the drives do
        comma_task = pool.submit(_comma2k19_outcome, found["comma2k19"][0]) if found["comma2k19"] else None
        jitter_tasks = [pool.submit(jitter_study, sc) for sc in scenarios]
        kv = validate_kitti(found["kitti"], pool=pool, figure=drive_png) if found["kitti"] else None
        if comma_task is not None:
            comma, error = _outcome(pool, comma_task, found["comma2k19"][0])
        jit = []
        for sc, task in zip(scenarios, jitter_tasks):
            value, failure = pool.outcome(task)
            if failure is not None:
                click.echo(f"error: jitter study {sc}: {failure}", err=True)
                failed = True
            else:
                jit.append(value)
    if comma_task is not None:
        if error is not None:
            click.echo(f"error: {error}", err=True)
            failed = True
        else:
            f = output.with_suffix(".png")
            plot(comma, f)
            figs["comma2k19"] = f.name
    if kv is not None:
        for e in kv.errors:
            click.echo(f"error: {e}", err=True)
        failed |= bool(kv.errors)
        figs.update(_write_kitti_figures(kv, output))
    cmd = f"roadbank validate all {data_dir} -o {output}"
    write_document(output, real_data_markdown(comma, kv, jit, figs, command=cmd))
    click.echo(f"wrote {output} and {len(figs)} figure(s)", err=True)
    if failed:
        sys.exit(1)


def _sim_command(names, drives: int | None, seed: int, output) -> str:
    """The ``roadbank validate sim`` command line of these options (the defaults left out)."""
    return ("roadbank validate sim" + ("" if names is None else f" -e {names}")
            + ("" if drives is None else f" -n {drives}") + ("" if seed == 0 else f" --seed {seed}")
            + ("" if output is None else f" -o {output}"))


@validate.command("sim")
@click.option("--estimators", "-e", "names", default=None,
              help="Comma-separated estimator names or 'all'. Default: kinematic-pif (the default estimator), "
                   "kinematic-lp, pif-modified, pif-adaptive, pif-gated, pif-smoother and kinematic-smoother "
                   "(offline).")
@click.option("-n", "--drives", type=click.IntRange(min=1), default=None,
              help="Drives per car. Default: as many as roadbank tune's validation set (40).")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the drive set.")
@click.option("--json", "as_json", is_flag=True,
              help='Print {"estimators": {name: {"known" | "undescribed": {"cars", "all", "families"}}}, ...} '
                   "(deg) on stdout.")
@click.option("-o", "--output", type=click.Path(path_type=Path), default=None, callback=checked_output(),
              help="Write the markdown document here (e.g. docs/sim-validation.md; .html: a self-contained page).")
def sim(names, drives, seed, as_json, output):
    """Score the estimators on the simulated validation set of every shipped car (roadbank tune's
    validation drives), built with the car known (as with --vehicle CAR) and with the car not
    described (no --vehicle). Without --json or -o the document is printed.

    Regenerate docs/sim-validation.md with: roadbank validate sim -o docs/sim-validation.md
    """
    from ..tuning.simulated import DEFAULT_NAMES, score_simulated, to_json
    from ..tuning.simulated_report import markdown

    sel = list(DEFAULT_NAMES) if names is None else _names(names)
    scores = score_simulated(sel, seed=seed) if drives is None else score_simulated(sel, n=drives, seed=seed)
    if output is not None:
        output.parent.mkdir(parents=True, exist_ok=True)
        write_document(output, markdown(scores, command=_sim_command(names, drives, seed, output)))
        click.echo(f"wrote {output}", err=True)
    if as_json:
        click.echo(json.dumps(to_json(scores), indent=2))
    elif output is None:
        click.echo(markdown(scores, command=_sim_command(names, drives, seed, None)))

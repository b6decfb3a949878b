"""``roadbank validate``: check the estimators on real driving data."""

from __future__ import annotations

import contextlib
import json
import sys
from pathlib import Path

import click

from ..report.html import write_document
from .options import PathOption, SEED, checked_output, vehicle_option
from .parallel import pool_options, start_pool

_VEHICLE = vehicle_option("The estimators are designed for this car: its parameters and [tuning] tables.",
                          default_help="a car nobody described: the shipped sedan's parameters (README)",
                          none_if_absent=True)


def _car(vehicle) -> dict:
    """``validate_*`` keyword arguments for ``--vehicle`` (none: the data set's default car)."""
    from ..vehicle import trims_rear

    return {} if vehicle is None else {"params": vehicle.params, "tuning": dict(vehicle.tuning),
                                       "sensors": vehicle.sensors, "trim": trims_rear(vehicle)}


@click.group()
def validate():
    """Validate the estimators on real data sets."""


def _names(names: str) -> list[str]:
    """``--estimators`` value -> list of names (BadParameter for an unknown one)."""
    from .. import estimators

    from ..validation.scoring import ESP_LABELS, VALIDATION_NAMES

    sel = list(VALIDATION_NAMES) if names.strip() == "all" else [n.strip() for n in names.split(",") if n.strip()]
    bad = [n for n in sel if n not in estimators.NAMES + estimators.GYRO + tuple(ESP_LABELS)]
    if bad:
        raise click.BadParameter(f"unknown estimator(s) {bad}", param_hint="--estimators")
    return sel


def _outcome(pool, task, what) -> tuple:
    """``(value, reason)`` of a task whose value is itself ``(value, reason)``."""
    value, failure = pool.outcome(task)
    return value if failure is None else (None, f"{what}: {failure}")


def _joined(ctx, param, value) -> str | None:
    """A repeated ``-e`` as one comma-separated value (None where none was given and there is no default)."""
    return ",".join(value) if value else None


_ESTIMATORS = click.option("--estimators", "-e", "names", multiple=True, default=("all",), show_default="all",
                           callback=_joined, help="Comma-separated estimator names or 'all' (may be repeated).")


def _warn(notes) -> None:
    """Each note of a validation (a data set given twice, a reader warning) as ``warning: ...`` on stderr."""
    for note in notes:
        click.echo(f"warning: {note}", err=True)


def _segments_under(path: Path) -> tuple[list[Path], list[str], bool]:
    """The comma2k19 segments of ``validate comma2k19 PATH``, the notes on finding them, and whether PATH
    is one segment (or holds none: reading it then says what is missing)."""
    from ..validation.comma2k19 import unique_segments
    from ..validation.datasets import find_datasets

    found = find_datasets(path) if path.is_dir() else {"comma2k19": [], "notes": []}
    if found["comma2k19"] in ([], [path]):
        return [path], found["notes"], True
    segments, notes = unique_segments(found["comma2k19"])
    return segments, found["notes"] + notes, False


def _run_segments(pool, segments, **kwargs) -> tuple[list, list[str]]:
    """Every segment validated, one pool task each: ``(results, errors)``, each error naming its segment
    (the others still scored); results named apart (:func:`roadbank.validation.comma2k19.named_apart`)."""
    from ..validation.comma2k19 import comma2k19_outcome

    tasks = [pool.submit(comma2k19_outcome, p, **kwargs) for p in segments]
    return _collect_segments(pool, segments, tasks)


def _collect_segments(pool, segments, tasks) -> tuple[list, list[str]]:
    """``(results, errors)`` of the segments' tasks of :func:`_run_segments`."""
    from ..validation.comma2k19 import named_apart

    results, errors = [], []
    for p, task in zip(segments, tasks):
        res, error = _outcome(pool, task, p)
        if error is None:
            results.append(res)
        else:
            errors.append(error if str(p) in error else f"{p}: {error}")
    return named_apart(results), errors


def _segment_figures(results, output: Path) -> dict:
    """Draw each segment's figure next to the report at ``output``: ``{"comma2k19": file}`` for one segment
    (``output`` with ``.png``), ``{segment label: file}`` for several
    (:func:`roadbank.validation.report.figure_name`)."""
    from ..validation import plot
    from ..validation.report import figure_name

    output.parent.mkdir(parents=True, exist_ok=True)
    if len(results) == 1:
        plot(results[0], output.with_suffix(".png"))
        return {"comma2k19": output.with_suffix(".png").name}
    figs = {}
    for res in results:
        figs[res.label] = figure_name(output.stem, res.label)
        plot(res, output.parent / figs[res.label])
    return figs


def _options(ctx: click.Context, flags: dict[str, str]) -> list[tuple[str, object]]:
    """``(flag, value)`` of the options given on the command line (not at their defaults), for
    :func:`roadbank.validation.document.command_line`; ``flags``: ``{parameter name: flag}``. Where the work ran
    (``--workers``, ``--scheduler``) is not among them: it changes no number, and a report made on a cluster is
    the same document as one made in one process."""
    out = []
    for name, flag in flags.items():
        given = ctx.get_parameter_source(name) not in (None, click.core.ParameterSource.DEFAULT)
        value = ctx.params.get(name)
        if given and value is not None:
            out.append((flag, getattr(value, "name", value) if name == "vehicle" else value))
    return out


_FLAGS = {"output": "-o", "names": "-e", "no_sensitivity": "--no-sensitivity", "no_jitter": "--no-jitter",
          "vehicle": "--vehicle", "as_json": "--json"}


@validate.command("comma2k19")
@click.argument("path", type=PathOption(path_type=Path))
@click.option("--json", "as_json", is_flag=True,
              help='Print {estimator: {"r", "rms_deg", "offset_deg"}} on stdout; when PATH is a folder holding '
                   'segments {"segments": {segment: {estimator: ...}}, "errors": [...], "notes": [...]}.')
@click.option("-o", "--output", type=PathOption(path_type=Path), default=None,
              callback=checked_output(next_to=(".png",)),
              help="Write the markdown report here (e.g. docs/real-data.md; .html: a self-contained page) "
                   "and a PNG next to it (one per segment).")
@_ESTIMATORS
@click.option("--no-sensitivity", is_flag=True, help="Skip the SUV-parameter and PIF-Q sensitivity runs.")
@_VEHICLE
@pool_options("Tasks", "Each segment is one task: more workers than segments do not make it faster; "
                       "`validate all` runs them next to the KITTI drives.")
@click.pass_context
def comma2k19(ctx, path, as_json, output, names, no_sensitivity, vehicle, workers, scheduler):
    """Score every estimator against the pose-derived roll of the comma2k19 segment at PATH, or of every
    segment under PATH (a folder holding processed_log/ and global_pose/, at any depth).

    A segment that cannot be read is named and the others are still scored (exit code 1 then); a segment
    reached twice (a link to it) is scored once, with a warning.
    """
    from ..validation import markdown, to_json
    from ..validation.document import command_line, real_data_markdown

    sel = _names(names)
    segments, notes, single = _segments_under(path)
    _warn(notes)
    with contextlib.ExitStack() as stack:
        pool = start_pool(stack, workers, scheduler)
        results, errors = _run_segments(pool, segments, names=sel, sensitivity=not no_sensitivity, **_car(vehicle))
    for e in errors:
        click.echo(f"error: {e}", err=True)
    if not results:
        if not single:
            click.echo(f"error: {path}: no comma2k19 segment could be read", err=True)
        if as_json:             # what a script reads: the same keys, nothing scored
            click.echo(json.dumps({"segments": {}, "errors": errors, "notes": notes}, indent=2))
        sys.exit(1)
    if output is not None:
        figs = _segment_figures(results, output)
        cmd = command_line(["roadbank", "validate", "comma2k19", path], _options(ctx, _FLAGS))
        text = (markdown(results[0], figure=figs["comma2k19"], command=cmd) if single
                else real_data_markdown(results, figures=figs, command=cmd))
        write_document(output, text)
        click.echo(f"wrote {output} and {len(figs)} figure(s)", err=True)
    if as_json:
        out = (to_json(results[0]) if single else
               {"segments": {r.label: to_json(r) for r in results}, "errors": errors, "notes": notes})
        click.echo(json.dumps(out, indent=2))
    elif output is None:
        for res in results:
            if not single:
                click.echo(res.label)
            for name, v in to_json(res).items():
                click.echo(f"{'  ' if not single else ''}{name:14s} r = {v['r']:.3f}  rms = {v['rms_deg']:.3f} deg  "
                           f"offset = {v['offset_deg']:+.3f} deg")
    if errors:
        sys.exit(1)


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
@click.argument("paths", nargs=-1, required=True, type=PathOption(path_type=Path))
@click.option("--json", "as_json", is_flag=True,
              help='Print {"drives": {drive: {estimator: scores}}, "pooled": {...}, "errors": [...]} on stdout.')
@click.option("-o", "--output", type=PathOption(path_type=Path), default=None, callback=checked_output(),
              help="Write the markdown report (KITTI section; .html: a self-contained page) here and one "
                   "PNG per drive next to it.")
@_ESTIMATORS
@click.option("--no-sensitivity", is_flag=True,
              help="Skip the sensitivity runs (the paper's SUV parameters; the PIFs designed from the data "
                   "sheet alone).")
@_VEHICLE
@pool_options("Drives")
@click.pass_context
def kitti(ctx, paths, as_json, output, names, no_sensitivity, vehicle, workers, scheduler):
    """Score every estimator against the INS roll of KITTI raw drives.

    PATHS: drive folders (holding oxts/), oxts folders, or folders holding drive folders (at any depth).
    A drive that cannot be read is reported and the others are still scored (exit code 1 then); a drive
    reached twice is scored once, with a warning. With --workers or --scheduler each drive is one task;
    the report is the same as in one process.
    """
    from ..validation.document import command_line
    from ..validation.kitti import validate_kitti
    from ..validation.kitti_report import drive_png, markdown, to_json

    sel = _names(names)
    with contextlib.ExitStack() as stack:
        pool = start_pool(stack, workers, scheduler)
        v = validate_kitti(paths, names=sel, sensitivity=not no_sensitivity, pool=pool,
                           figure=None if output is None else drive_png, **_car(vehicle))
    _warn(v.notes)
    for e in v.errors:
        click.echo(f"error: {e}", err=True)
    if not v.drives:
        click.echo("error: no KITTI drive could be read", err=True)
        if as_json:             # what a script reads: the same keys, nothing scored
            click.echo(json.dumps({"drives": {}, "errors": v.errors, "notes": v.notes}, indent=2))
        sys.exit(1)
    if output is not None:
        figs = _write_kitti_figures(v, output)
        cmd = command_line(["roadbank", "validate", "kitti", *paths], _options(ctx, _FLAGS))
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
@click.argument("data_dir", type=PathOption(path_type=Path, exists=True, file_okay=False))
@click.option("-o", "--output", type=PathOption(path_type=Path), required=True,
              callback=checked_output(next_to=(".png",)),
              help="The combined report (e.g. docs/real-data.md; .html: a self-contained page); figures "
                   "are written next to it.")
@click.option("--no-jitter", is_flag=True, help="Skip the 10 Hz-with-jitter simulation study.")
@click.option("--json", "as_json", is_flag=True,
              help='Also print {"comma2k19": {segment: {estimator: {"r", "rms_deg", "offset_deg"}}}, "kitti": '
                   '(as validate kitti --json, or null), "jitter": [scenario], "errors": [...], "notes": [...]} '
                   "on stdout.")
@pool_options("Tasks", "One task each: every comma2k19 segment, every KITTI drive, every jitter scenario.")
@click.pass_context
def all_(ctx, data_dir, output, no_jitter, as_json, workers, scheduler):
    """One report over every real data set under DATA_DIR, at any depth (every comma2k19 segment, every
    KITTI drive).

    A segment or drive that cannot be read is named and the others are still scored (exit code 1 then);
    one reached twice (a link to it) is scored once, with a warning.

    Regenerate docs/real-data.md with: roadbank validate all ../shared/data -o docs/real-data.md
    """
    from ..validation import to_json
    from ..validation.comma2k19 import comma2k19_outcome, unique_segments
    from ..validation.datasets import find_datasets
    from ..validation.document import command_line, real_data_markdown
    from ..validation.jitter import jitter_study
    from ..validation.kitti import validate_kitti
    from ..validation.kitti_report import drive_png
    from ..validation.kitti_report import to_json as kitti_json

    found = find_datasets(data_dir)
    segments, notes = unique_segments(found["comma2k19"])
    notes = found["notes"] + notes
    _warn(notes)
    if not segments and not found["kitti"]:
        click.echo(f"error: {data_dir}: no comma2k19 segment or KITTI drive found", err=True)
        sys.exit(1)
    output.parent.mkdir(parents=True, exist_ok=True)
    errors, kv = [], None
    scenarios = () if no_jitter else ("bank-lane-change", "s-curve", "track-lane-change")
    with contextlib.ExitStack() as stack:
        pool = start_pool(stack, workers, scheduler)
        # submitted first, so that on workers they run while the drives do
        comma_tasks = [pool.submit(comma2k19_outcome, p) for p in segments]
        jitter_tasks = [pool.submit(jitter_study, sc) for sc in scenarios]
        kv = validate_kitti(found["kitti"], pool=pool, figure=drive_png) if found["kitti"] else None
        comma, comma_errors = _collect_segments(pool, segments, comma_tasks)
        jit = []
        for sc, task in zip(scenarios, jitter_tasks):
            value, failure = pool.outcome(task)
            if failure is not None:
                errors.append(f"jitter study {sc}: {failure}")
            else:
                jit.append(value)
    errors = comma_errors + errors
    figs = _segment_figures(comma, output) if comma else {}
    if kv is not None:
        _warn(kv.notes)
        notes += kv.notes
        errors += kv.errors
        figs.update(_write_kitti_figures(kv, output))
    for e in errors:
        click.echo(f"error: {e}", err=True)
    cmd = command_line(["roadbank", "validate", "all", data_dir], _options(ctx, _FLAGS))
    write_document(output, real_data_markdown(comma or None, kv, jit, figs, command=cmd))
    click.echo(f"wrote {output} and {len(figs)} figure(s)", err=True)
    if as_json:
        click.echo(json.dumps({"comma2k19": {r.label: to_json(r) for r in comma},
                               "kitti": None if kv is None else kitti_json(kv),
                               "jitter": [r.scenario for r in jit], "errors": errors, "notes": notes}, indent=2))
    if errors:
        sys.exit(1)


def _sim_command(names, drives: int | None, seed: int, output, sources: bool = True) -> str:
    """The ``roadbank validate sim`` command line of these options (the defaults left out)."""
    return ("roadbank validate sim" + ("" if names is None else f" -e {names}")
            + ("" if drives is None else f" -n {drives}") + ("" if seed == 0 else f" --seed {seed}")
            + ("" if sources else " --no-sources") + ("" if output is None else f" -o {output}"))


@validate.command("sim")
@click.option("--estimators", "-e", "names", multiple=True, callback=_joined,
              help="Comma-separated estimator names or 'all' (may be repeated). Default: kinematic-pif (the default "
                   "estimator), kinematic-lp, pif-modified, pif-adaptive, pif-gated, pif-smoother and "
                   "kinematic-smoother (offline).")
@click.option("-n", "--drives", type=click.IntRange(min=1), default=None,
              help="Drives per car. Default: as many as roadbank tune's validation set (40).")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the drive set.")
@click.option("--sources/--no-sources", default=True, show_default=True,
              help="Also score the default, car known, on the same drives with groups of the plant's perturbations "
                   "held at the data sheet (where its error comes from; about 6 s per group for 40 drives per car).")
@click.option("--json", "as_json", is_flag=True,
              help='Print {"estimators": {name: {"known" | "undescribed": {"cars", "all", "families"}}}, '
                   '"error_sources": {...}, ...} (deg) on stdout.')
@click.option("-o", "--output", type=PathOption(path_type=Path), default=None, callback=checked_output(),
              help="Write the markdown document here (e.g. docs/sim-validation.md; .html: a self-contained page).")
def sim(names, drives, seed, sources, as_json, output):
    """Score the estimators on the simulated validation set of every shipped car (roadbank tune's
    validation drives), built with the car known (as with --vehicle CAR) and with the car not
    described (no --vehicle). Without --json or -o the document is printed.

    Regenerate docs/sim-validation.md with: roadbank validate sim -o docs/sim-validation.md
    """
    from .. import estimators
    from ..tuning.simulated import DEFAULT_NAMES, error_sources, score_simulated, to_json
    from ..tuning.simulated_report import markdown

    sel = list(DEFAULT_NAMES) if names is None else _names(names)
    size = {} if drives is None else {"n": drives}
    scores = score_simulated(sel, seed=seed, **size)
    found = error_sources(seed=seed, **size) if sources and estimators.DEFAULT in sel else None
    if output is not None:
        output.parent.mkdir(parents=True, exist_ok=True)
        write_document(output, markdown(scores, _sim_command(names, drives, seed, output, sources), found))
        click.echo(f"wrote {output}", err=True)
    if as_json:
        click.echo(json.dumps(to_json(scores, found), indent=2))
    elif output is None:
        click.echo(markdown(scores, _sim_command(names, drives, seed, None, sources), found))

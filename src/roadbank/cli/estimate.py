"""``roadbank estimate``: run estimators on recorded logs."""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

import click

from ..defaults import ESTIMATOR as DEFAULT
from ..io.channels import steering_ratio_problem
from ..io.errors import LogError
from ..io.readers import FORMATS
from .inputs import channel_map_and_logs, check_output
from .options import PathOption, vehicle_offsets, vehicle_option
from .parallel import one_pool, scheduler_option


def _parse_estimators(values: tuple[str, ...]) -> list[str]:
    from .. import estimators

    names: list[str] = []
    for v in values:
        if not v.strip(", "):
            raise click.BadParameter(f"no estimator named in {v!r}", param_hint="--estimators")
        for n in (x.strip() for x in v.split(",")):
            if not n:
                continue
            if n == "all":
                names.extend(estimators.NAMES)
            elif n not in estimators.NAMES + estimators.PRESETS + estimators.GYRO:
                raise click.BadParameter(f"unknown estimator '{n}' (choose from "
                                         f"{', '.join(estimators.NAMES + estimators.PRESETS + estimators.GYRO)} or "
                                         "'all')", param_hint="--estimators")
            else:
                names.append(n)
    return list(dict.fromkeys(names)) or [DEFAULT]


@click.command()
@click.argument("logs", nargs=-1, required=True, type=PathOption(path_type=Path))
@click.option("--channels", "channels", type=PathOption(path_type=Path), default=None,
              help="Channel map (TOML). Default: roadbank's own columns (roadbank simulate files).")
@click.option("--format", "fmt", type=click.Choice(list(FORMATS)), default=None,
              help="Input format. Default: from the file suffix or the directory layout (docs/io.md).")
@click.option("--estimators", "-e", "est_names", multiple=True, default=(DEFAULT,),
              show_default=True, help="Estimators, comma-separated or repeated; 'all' for every one. "
                                      "Default kinematic-pif: the filtered kinematic estimate on real "
                                      "roads, the paper's PIF while the yaw rate changes fast; on a quiet "
                                      "log pif-adaptive; on a loud log with a roll rate kinematic-gyro (README). "
                                      "pif-modified is roadbank's default tuning of the paper's filter; "
                                      "pif-paper the same filter with the paper's Table 4 weights.")
@click.option("-o", "--output", required=True, type=PathOption(),
              help="Output .csv/.parquet for one log; a directory for several, or for one log a path ending "
                   "in '/' (created if missing).")
@click.option("--output-format", type=click.Choice(["csv", "parquet"]), default="parquet", show_default=True,
              help="Table format of the files written into an output directory.")
@click.option("--plot", type=PathOption(path_type=Path), default=None,
              help="PNG of theta, phi_b and their error against the log's truth or reference roll "
                   "(deg) vs time, flagged spans shaded; for several logs, a directory of PNGs.")
@click.option("--steering-ratio", type=float, default=None,
              help="Steering-wheel / road-wheel ratio when the log has a steering-wheel angle "
                   "(default: the channel map's, else VehicleParams' 16).")
@vehicle_option("Every estimator is designed for this car: its parameters and its [tuning] tables.",
                default_help="a car nobody described: the default estimator needs no car data, the "
                             "model-based ones are designed for the shipped sedan's parameters (README)",
                none_if_absent=True)
@click.option("--online-offsets/--no-online-offsets", default=True, show_default=True,
              help="Learn the yaw-rate offset at standstill while the log runs, and remove it before the "
                   "estimators (straights teach nothing: a road's crown and an accelerometer offset look alike "
                   "there; docs/estimators.md).")
@click.option("--workers", type=int, default=1, show_default=True,
              help="Logs in parallel on N worker processes on this machine (1: in this process).")
@scheduler_option("Run on the Dask scheduler at ADDR (tcp://host:8786) instead of local worker processes.")
@click.option("--resume", is_flag=True,
              help="Skip logs the output directory's summary.csv lists as finished (failed ones are retried).")
@click.option("--chunk-rows", type=click.IntRange(min=2), default=None,
              help="Rows per streamed chunk (Parquet, MDF4, and CSV files above 64 MiB); default 20000.")
@click.option("--json", "as_json", is_flag=True,
              help="Print the summary as one JSON object on stdout (per log: status, duration, time-stamp "
                   "repairs, and valid share and bank mean/min/max of every estimator) instead of the table.")
@one_pool
def estimate(logs, channels, fmt, est_names, output, output_format, plot, steering_ratio, vehicle,
             online_offsets, workers, scheduler, resume, chunk_rows, as_json):
    """Estimate the road bank angle on recorded LOGS and write t, theta, phi_b, valid per estimator.

    \b
    roadbank estimate drive.parquet -o drive_bank.csv --plot drive.png
    roadbank estimate logs/*.csv --channels car.toml -e kinematic,pif-modified -o out/
    roadbank estimate fleet/ --channels car.toml --workers 2 -o out/ [--resume]
    roadbank estimate drive.parquet -e pif-smoother -o smoothed.csv

    -e pif-smoother is for post-processing: it also uses the samples after each
    instant (no lag; a streamed log is smoothed as a whole; docs/estimators.md).

    LOGS are files, log directories (comma2k19 segment, ROS 2 bag, KITTI drive),
    directories of logs or glob patterns. Parquet and MDF4 logs are streamed in
    chunks (bounded memory) and the output is written as it is computed. With
    several logs, -o is a directory: one table per log plus summary.csv (per log:
    duration, valid share, bank mean/min/max, error), appended as each log
    finishes (an -o ending in .csv or .parquet is then refused, not made a
    directory). A bad log is reported (name and reason) and never stops the
    others; files that are not logs (a README.md a glob picked up) are skipped
    and said so; the exit code is 1 if any log failed, 0 otherwise. A folder of
    KITTI drives gives each drive. Time stamps a logger duplicated, swapped or
    sent back are repaired (samples reordered or dropped, the ones next to a
    repair flagged not valid) and counted in the summary, a KITTI drive's
    too; a log with no increasing time base is refused (docs/io.md). Output columns
    are SI (rad); the summary is in degrees, one row per log and estimator, and a
    line per log (on stderr; the design column of summary.csv, design in --json)
    says what it was designed for: the car (without --vehicle the shipped one
    that fits the log), its ay noise and noise floor, and whether it is quiet
    (the default then uses the car's model). With --vehicle, the sensor offsets
    `roadbank identify` wrote into the file (yaw rate, ay, steering) are
    subtracted from every log first (docs/identification.md).
    """
    from ..fleet import estimate_log, run_fleet

    from ..vehicle import undescribed_params

    names = _parse_estimators(est_names)
    # no car described: each log's estimators are designed for the shipped car that fits it
    # (roadbank.vehicle.design_car, in estimate_log); a steering ratio alone keeps the static car
    params = vehicle.params if vehicle is not None else None
    if steering_ratio is not None:
        why = steering_ratio_problem(steering_ratio)
        if why is not None:
            raise click.BadParameter(why, param_hint="--steering-ratio")
        try:
            params = (params or undescribed_params()).replace(steering_ratio=steering_ratio)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--steering-ratio") from None
        if vehicle is not None:
            vehicle = vehicle.with_params(steering_ratio=steering_ratio)
    if workers < 1:
        raise click.BadParameter("must be >= 1", param_hint="--workers")
    as_dir = output.endswith(("/", "\\"))
    output = Path(output)
    cmap, paths = channel_map_and_logs(channels, logs, fmt)
    batch = (len(paths) > 1 or len(logs) != 1 or paths[0] != Path(logs[0]) or as_dir
             or output.is_dir() or workers > 1 or scheduler is not None or resume)
    tables = (".csv", ".parquet", ".pq")
    if not batch and output.suffix.lower() not in tables:
        raise click.BadParameter("for one log, -o must end in .csv or .parquet (or be a directory)",
                                 param_hint="-o")
    if batch and output.suffix.lower() in tables and not as_dir and not output.is_dir():
        # a directory called x.csv is not what anyone asking for x.csv expects
        why = (f"{len(paths)} logs are written" if len(paths) > 1 else
               "with a folder or pattern of logs, --workers, --scheduler or --resume the output is a directory")
        raise click.BadParameter(f"'{output}' names a file, but {why} (one table per log and summary.csv); "
                                 f"give a directory, e.g. '{output.with_suffix('')}/' (or '{output}/' to call it so)",
                                 param_hint="-o")
    check_output(output, "-o", directory=batch)
    _check_not_an_input(paths, output, batch, output_format, resume)
    if plot is not None:
        check_output(plot, "--plot", directory=batch)
    vehicle_offsets(vehicle, "every log")
    meta = {"estimators": ",".join(names),
            "steering_ratio": str(cmap.steering_ratio if cmap and cmap.steering_ratio
                                  else (params or undescribed_params()).steering_ratio)}
    if not batch:
        s = estimate_log(paths[0], output, names, channels=cmap, format=fmt, vehicle=vehicle, params=params,
                         chunk_rows=chunk_rows, metadata=dict(meta, source=str(paths[0])), plot=plot,
                         online_offsets=online_offsets)
        summaries = [s]
    else:
        with click.progressbar(length=len(paths), label=f"estimating ({', '.join(names)})", file=sys.stderr,
                               item_show_func=lambda s: Path(s.log).name if s else "") as bar:
            def progress(s):
                bar.update(1, s)
            try:
                res = run_fleet(paths, output, names, channels=cmap, format=fmt, vehicle=vehicle, params=params,
                                output_format=output_format, workers=workers, scheduler=scheduler, resume=resume,
                                chunk_rows=chunk_rows, metadata=meta, plot_dir=plot, on_result=progress,
                                online_offsets=online_offsets)
            except (OSError, RuntimeError, LogError) as exc:    # the cluster, the output directory, summary.csv
                click.echo(f"\nerror: {exc}", err=True)
                sys.exit(1)
        summaries = res.summaries
        for note in res.notes:
            click.echo(note, err=True)
        if res.skipped:
            click.echo(f"{len(res.skipped)} log(s) already finished (--resume), skipped", err=True)
        click.echo(f"summary: {Path(output) / 'summary.csv'}", err=True)
    if as_json:
        click.echo(json.dumps(summary_json(summaries, names), indent=1))
    elif batch or summaries[0].status == "ok":
        click.echo(summary_table(summaries, names))
        for line in design_lines(summaries):
            click.echo(line, err=True)
    for s in summaries:
        for w in filter(None, s.warnings.split("; ")):
            click.echo(f"warning: {w}", err=True)
    failures = [s for s in summaries if s.status != "ok"]
    for s in failures:
        click.echo(f"FAILED {s.error}" if s.error.startswith(s.log) else f"FAILED {s.log}: {s.error}", err=True)
    unplotted = [s for s in summaries if s.plot_error]      # the table written, its PNG not (said in a warning)
    click.echo(f"{len(summaries) - len(failures)} log(s) written, {len(failures)} failed"
               + (f", {len(unplotted)} plot(s) not written" if unplotted else ""), err=True)
    sys.exit(1 if failures or unplotted else 0)


def _check_not_an_input(paths, output: Path, batch: bool, output_format: str, resume: bool) -> None:
    """Exit with a usage error (exit code 2) before anything is read if an output file would be one of the input
    logs ``paths``: ``-o`` itself for one log, ``-o``/<name> for each log of a batch
    (:func:`roadbank.fleet.run.output_names`)."""
    from ..fleet.run import fleet_output_names

    try:
        names = fleet_output_names(paths, output, output_format, resume) if batch else {}
    except LogError:            # a summary.csv that is not one: the run says so
        names = fleet_output_names(paths, output, output_format, False)
    outs = [output / n for n in names.values()] if batch else [output]
    inputs = {os.path.realpath(p) for p in paths}       # (never raises: a link loop is a log the reader refuses)
    clash = [o for o in outs if os.path.realpath(o) in inputs]
    if clash:
        raise click.BadParameter(f"the output '{clash[0]}' is one of the input logs: writing it would overwrite the "
                                 "log; give another -o", param_hint="-o")


def repairs_text(repairs: dict, by_channel: dict | None = None) -> str:
    """The time-stamp repairs of one log in words ('' when there were none): channel by channel where
    ``by_channel`` (channel -> kind -> int) has them on channels of their own clocks, the channels with the same
    counts together (``each of yaw_rate, roll_rate, pitch_rate: 735 out-of-order stamps dropped, ...``); a table's
    one clock (``time``), or a log without ``by_channel``, as the sums of ``repairs``."""
    from ..io.timebase import describe

    def words(counts: dict, sep: str) -> str:
        text = describe(counts)
        n = int(counts.get("flagged", 0))
        return text + (f"{sep}{n} sample(s) flagged not valid" if n else "") if text or n else ""

    groups: dict[str, list[str]] = {}
    for channel, counts in (by_channel or {}).items():
        text = words(counts, ", ")
        if text:
            groups.setdefault(text, []).append(channel)
    if not groups or list(groups.values()) == [["time"]]:
        return words(repairs, "; ")
    return "; ".join(f"{'each of ' if len(chs) > 1 else ''}{', '.join(chs)}: {text}" for text, chs in groups.items())


def log_names(paths) -> list[str]:
    """Short names of the logs ``paths`` for the summary: each file's name, with as many of its folders before it as
    tell it from another log of the same name (``day1/log.csv``, ``day2/log.csv``); at most 32 characters, the end
    kept."""
    parts = [Path(p).parts for p in paths]
    depth = [1] * len(parts)
    while True:
        names = [Path(*q[-d:]).as_posix() for q, d in zip(parts, depth)]
        clash = {n for n in names if names.count(n) > 1}
        grow = [i for i, n in enumerate(names) if n in clash and depth[i] < len(parts[i])]
        if not grow:
            return [n[-32:] for n in names]
        for i in grow:
            depth[i] += 1


def summary_table(summaries, estimators) -> str:
    """Plain-text table: per log and estimator the duration, valid share and bank mean/min/max (deg),
    or the log's error; then the time-stamp repairs of each log that needed any."""
    if isinstance(estimators, str):
        estimators = [estimators]
    width = max([16, *map(len, estimators)])
    head = (f"{'log':<32} {'estimator':<{width}} {'duration':>9} {'valid':>6} {'bank mean':>9} {'min':>7} {'max':>7}"
            "  (deg)")
    lines = [head, "-" * len(head)]
    notes = []
    for s, name in zip(summaries, log_names([s.log for s in summaries])):
        if s.status != "ok":
            lines.append(f"{name:<32} ERROR {s.error[:150]}")
            continue
        per = s.estimators or {s.estimator: {k: getattr(s, k) for k in
                                             ("valid_share", "bank_mean_deg", "bank_min_deg", "bank_max_deg")}}
        for k, est in enumerate(e for e in estimators if e in per):
            st = per[est]
            lines.append(f"{name if k == 0 else '':<32} {est:<{width}} {s.duration_s:>8.1f}s "
                         f"{100 * st['valid_share']:>5.1f}% {st['bank_mean_deg']:>9.2f} "
                         f"{st['bank_min_deg']:>7.2f} {st['bank_max_deg']:>7.2f}")
        text = repairs_text(s.time_repairs, s.time_repairs_by_channel)
        if text:
            notes.append(f"time stamps repaired in {name}: {text}")
    return "\n".join(lines + notes)


def design_lines(summaries) -> list[str]:
    """One line per log that was read: what its estimators were designed for
    (:func:`roadbank.fleet.process.design_words`)."""
    from ..fleet.process import design_words

    return [f"designed for {name}: {design_words(s.design, s.estimator)}"
            for s, name in zip(summaries, log_names([s.log for s in summaries])) if s.design]


def _finite(x):
    return None if isinstance(x, float) and not math.isfinite(x) else x


def summary_json(summaries, estimators) -> dict:
    """What ``--json`` prints: ``{"estimators": [...], "logs": [...], "written": n, "failed": n}``; per log
    its status, error, output, samples, duration_s, seconds, warnings (list), time_repairs (kind -> int, summed over
    the channels), time_repairs_by_channel (channel -> kind -> int, the channels and kinds with a repair),
    design (:attr:`roadbank.fleet.LogSummary.design`; ``{}`` on error) and per estimator valid_share,
    bank_mean_deg, bank_min_deg, bank_max_deg (null where undefined)."""
    logs = []
    for s in summaries:
        logs.append({"log": s.log, "status": s.status, "error": s.error, "output": s.output,
                     "samples": s.samples, "duration_s": _finite(s.duration_s), "seconds": round(s.seconds, 3),
                     "warnings": [w for w in s.warnings.split("; ") if w],
                     "time_repairs": {k: int(v) for k, v in s.time_repairs.items()},
                     "time_repairs_by_channel": {ch: {k: int(v) for k, v in c.items() if v}
                                                 for ch, c in s.time_repairs_by_channel.items() if any(c.values())},
                     "design": {k: _finite(v) for k, v in s.design.items()},
                     "estimators": {n: {k: _finite(v) for k, v in st.items()} for n, st in s.estimators.items()}})
    failed = sum(s.status != "ok" for s in summaries)
    return {"estimators": list(estimators), "logs": logs, "written": len(summaries) - failed, "failed": failed}

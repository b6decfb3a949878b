"""``roadbank channels``: write a channel-map skeleton for a foreign log, guessed from its columns."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from .options import PathOption, checked_output


def read_columns(path: Path, fmt: str):
    """``(names, data, times, units, unread)`` of every numeric column of a CSV, Parquet or MDF4 log (as stored;
    ``units``: those the file states, a CSV's units row; ``unread``: column -> why it could not be read).

    Columns that cannot be read as numbers (a gear as text, a comment, an MDF4 name in two channel groups) are left
    out, each with its reason in ``unread``. LogError for a file that cannot be read, and for one whose every column
    fails to read as numbers (the first column's reason: e.g. numbers with a decimal comma).
    """
    from ..io import LogError, readers

    if fmt not in readers.READERS:
        raise LogError(f"{path}: guessing a channel map works on CSV, Parquet and MDF4 logs, not {fmt}")
    reader = readers.READERS[fmt]
    names = reader(path, {}).names
    unread: dict[str, str] = {}
    try:
        raw = reader(path, {n: n for n in names})
        data = raw.data
    except LogError:                          # a non-numeric column: read the others one by one
        data, raw, why = {}, None, []
        for n in names:
            try:
                got = reader(path, {n: n})
            except LogError as exc:
                why.append(exc)
                unread[n] = str(exc)
                continue
            data.update(got.data)
            raw = got
        if not data and why:
            raise why[0] from None
    times = dict(raw.times) if raw is not None else {}
    return names, data, times, (dict(raw.units) if raw is not None else {}), unread


@click.command()
@click.argument("log", type=PathOption(exists=True, path_type=Path))
@click.option("-o", "--output", required=True, type=PathOption(path_type=Path), callback=checked_output(),
              help="The channel map to write (.toml), for `roadbank estimate LOG --channels map.toml`.")
@click.option("--format", "fmt", type=click.Choice(["csv", "parquet", "mdf4"]), default=None,
              help="Input format. Default: from the file suffix.")
def channels(log, output, fmt):
    """Guess which column of LOG is time, speed, ay, yaw rate and steering, in which unit and sign,
    and write a channel map for it.

    \b
    roadbank channels drive.csv -o map.toml
    roadbank estimate drive.csv --channels map.toml -o drive_bank.csv

    The guesses come from the column names (VehSpd, speed, v; YawRate, wz; LatAcc, ay;
    SteerAngle, SWA; timestamp, time ...) and from the data: plausible ranges (km/h or
    m/s, deg/s or rad/s, g or m/s^2), ay = vx r in turns (units and the yaw rate's sign)
    and the steering angle against the kinematic angle (road wheel or steering wheel,
    deg or rad, sign). Each line of the map says how sure the guess is. The sign convention
    is assumed, not read: ay positive to the left (ISO 8855); a log whose ay, yaw rate and
    steering are all positive to the right reads the same (then convention = "FRD"). A log
    with no column named like a steering angle (an IMU or INS log) gets a map without one:
    the default estimator does not read it. Check the map before using it. Exit code 1 if
    time, speed, ay or yaw rate was not found (the map is written, with that channel to fill
    in) or the map does not read the log.

    Without --channels, estimate, map, identify and export c --log read a log named
    otherwise with this guess where every one of time, speed, ay and yaw rate is high,
    and say so (docs/io.md): this command writes it down, to check and to pin.
    """
    from ..io import LogError, load_log, read_channel_map
    from ..io.channels import STEERING
    from ..io.guess import CONVENTION_NOTE, NO_STEERING, channel_map_toml, guess_channels
    from ..io.readers import detect_format

    try:
        fmt = fmt or detect_format(log)
        if fmt not in ("csv", "parquet", "mdf4"):
            raise LogError(f"{log}: guessing a channel map works on CSV, Parquet and MDF4 logs, not {fmt}")
        names, data, times, stated, unread = read_columns(log, fmt)
    except LogError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(1)
    guesses = guess_channels(names, data, times if fmt == "mdf4" else None, stated)
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_text(channel_map_toml(guesses, log.name))
    width = max(len(g.role) for g in guesses)
    for g in guesses:
        if g.column is None and g.role in STEERING:
            click.echo(f"{'steering':<{width}}  none ({g.reason}): {NO_STEERING}")
        elif g.column is None:
            click.echo(f"{g.role:<{width}}  not found ({g.reason})")
        else:
            sign = ", inverted" if g.invert else ""
            click.echo(f"{g.role:<{width}}  <- {g.column!r} in {g.unit}{sign}   {g.confidence}: {g.reason}")
    click.echo(f"{'convention':<{width}}  {CONVENTION_NOTE}")
    for name, why in unread.items():          # a channel named like a role may be among them
        click.echo(f"note: column {name!r} not read, so not proposed: {why}", err=True)
    click.echo(f"wrote {output}", err=True)
    if any(g.column is None and g.role not in STEERING for g in guesses):
        click.echo(f"error: not every required channel was found: fill in {output} by hand", err=True)
        sys.exit(1)
    try:
        got = load_log(log, channels=read_channel_map(output), format=fmt)
    except LogError as exc:
        click.echo(f"warning: the map does not read the log yet: {exc}", err=True)
        sys.exit(1)
    click.echo(f"the map reads {log.name}: {len(got)} samples, {got.signals.t[-1] - got.signals.t[0]:.1f} s; "
               f"next: roadbank estimate {log} --channels {output} -o OUT", err=True)

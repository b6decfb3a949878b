"""``roadbank map``: a road bank map from logs with GNSS positions."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

import click

from ..defaults import MAP_ESTIMATOR
from ..io.readers import FORMATS
from ..mapping.grid import CELL_RANGE_M, SECTOR_RANGE
from .inputs import channel_map_and_logs, check_output
from .options import PathOption, vehicle_offsets, vehicle_option
from .parallel import pool_options, start_pool


def _origin(ctx, param, value):
    if value is None:
        return None
    try:
        lat, lon = (float(x) for x in value.split(","))
    except ValueError:
        raise click.BadParameter("give LAT,LON in degrees, e.g. 37.72,-122.47") from None
    return lat, lon


@click.command(name="map")
@click.argument("logs", nargs=-1, required=True, type=PathOption(path_type=Path))
@click.option("-o", "--output", required=True, type=PathOption(path_type=Path),
              help="The map table (.parquet): one row per cell and heading sector.")
@click.option("--geojson", type=PathOption(path_type=Path), default=None, help="Also write the cells as GeoJSON.")
@click.option("--png", type=PathOption(path_type=Path), default=None, help="Also draw the map (PNG).")
@click.option("--channels", type=PathOption(path_type=Path), default=None,
              help="Channel map (TOML) with 'latitude' and 'longitude' channels (docs/io.md); without one, a CSV, "
                   "Parquet or MDF4 log's columns named lat and lon (latitude/longitude, gps_lat/gps_lon, in deg) "
                   "are read as its position.")
@click.option("--format", "fmt", type=click.Choice(list(FORMATS)), default=None,
              help="Input format (default: from the suffix / directory layout).")
@click.option("--estimator", "-e", "estimator", default=MAP_ESTIMATOR, show_default=True,
              help="Estimator whose settled bank estimates are mapped (default: the offline kinematic smoother, "
                   "pif-smoother on a quiet log with --vehicle, kinematic-gyro-smoother on a loud one with a roll "
                   "rate, as a map is made after the drives; docs/estimators.md).")
@click.option("--cell", "cell_m", type=click.FloatRange(*CELL_RANGE_M), default=10.0, show_default=True,
              help="Cell edge (m).")
@click.option("--sectors", type=click.IntRange(*SECTOR_RANGE), default=4, show_default=True,
              help="Heading sectors per cell (the bank's sign depends on the direction of travel); 1 = none.")
@click.option("--origin", callback=_origin, default=None, metavar="LAT,LON",
              help="Origin of the map's plane (deg); default: the first fix rounded to 0.01 deg.")
@click.option("--chunk-rows", type=int, default=None, help="Rows per streamed chunk (default 20000).")
@vehicle_option("The estimator is designed for this car.",
                default_help="a car nobody described: the shipped sedan's parameters (README)",
                none_if_absent=True)
@pool_options("Logs", "The logs' cells are merged in the order of the logs: the same map as in one process.")
def map_command(logs, output, geojson, png, channels, fmt, estimator, cell_m, sectors, origin, chunk_rows, vehicle,
                workers, scheduler):
    """Map the road bank: attach each settled bank estimate of LOGS to its GNSS position and aggregate per cell.

    \b
    roadbank map ../shared/data/comma2k19-example -o bank_map.parquet --geojson map.geojson --png map.png
    roadbank map drives/ --channels car.toml --cell 5 -o bank_map.parquet

    LOGS are files, log directories, directories of logs or glob patterns, with a
    position: channel-map 'latitude'/'longitude' roles (without --channels: columns
    named lat and lon, in deg), comma2k19 (ECEF pose),
    KITTI oxts, ROS NavSatFix. Columns: cell indices, cell-centre lat/lon, heading
    sector, count, logs, bank mean/std/min/max (deg, left side up in the sector's
    heading). A bad log is reported and skipped, and so is a log without a GNSS fix (its latitude or
    longitude all missing, or every position exactly 0,0, what a receiver without a fix logs; a 0,0 sample
    is no position and never the origin); exit code 1 if any failed.
    """
    from .. import estimators
    from ..mapping.build import map_logs, write_outputs

    known = estimators.NAMES + estimators.GYRO
    if estimator not in known:
        raise click.BadParameter(f"unknown estimator '{estimator}' (choose from {', '.join(known)})",
                                 param_hint="--estimator")
    if output.suffix.lower() not in (".parquet", ".pq"):
        raise click.BadParameter("the map table must end in .parquet", param_hint="-o")
    if png is not None and png.suffix.lower() != ".png":       # the figure's format follows its suffix
        raise click.BadParameter(f"'{png}' must end in .png", param_hint="--png")
    for path, option in ((output, "-o"), (geojson, "--geojson"), (png, "--png")):
        if path is not None:        # before the work, not after it
            check_output(path, option)
    cmap, paths = channel_map_and_logs(channels, logs, fmt)
    vehicle_offsets(vehicle, "every log")
    try:
        with contextlib.ExitStack() as stack:
            pool = start_pool(stack, workers, scheduler)
            bar = stack.enter_context(click.progressbar(length=len(paths), label=f"mapping ({estimator})",
                                                        file=sys.stderr))
            bmap, recs = map_logs(paths, estimator, channels=cmap, format=fmt, vehicle=vehicle, cell_m=cell_m,
                                  sectors=sectors, origin=origin, chunk_rows=chunk_rows,
                                  on_log=lambda r: bar.update(1), pool=pool)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None
    for r in recs:
        for w in r.warnings:
            click.echo(f"warning: {w}", err=True)
    failed = [r for r in recs if r.status != "ok"]
    for r in failed:
        click.echo(f"FAILED {r.error}" if r.error.startswith(r.log) else f"FAILED {r.log}: {r.error}", err=True)
    if len(failed) == len(recs):
        click.echo(f"error: no log could be mapped ({len(failed)} not mapped, see above): nothing to map", err=True)
        sys.exit(1)
    if bmap is None or len(bmap) == 0:
        click.echo(f"error: no settled bank estimate with a position: nothing to map (`roadbank estimate LOG -e "
                   f"{estimator}` shows its valid and settled samples: an estimator that reads the steering angle "
                   "gives none on a log without one, and pio-original never settles)", err=True)
        sys.exit(1)
    try:
        files = write_outputs(bmap, output, geojson, png, {"estimator": estimator,
                                                           "logs": ",".join(r.log for r in recs if r.status == "ok")})
    except OSError as exc:          # names the file and what was written before it
        click.echo(f"error: {exc}", err=True)
        sys.exit(1)
    empty = [r for r in recs if r.status == "ok" and r.mapped == 0]
    for r in empty:             # read, but no cell got a sample of it: said, not passed over
        click.echo(f"warning: {r.log}: read, but none of its estimates is in the map (no settled estimate at a "
                   "position: a position that never moves or jumps, a log too short to settle, or no driving at "
                   "5 m/s or more)", err=True)
    tab = bmap.table()
    mapped = sum(r.mapped for r in recs)
    shown = f"{len(recs) - len(failed)} log(s)" + (f", {len(empty)} of them adding none" if empty else "")
    click.echo(f"{len(tab['ix'])} cell(s) x sector from {mapped} settled estimate(s) of {shown}; "
               f"bank {tab['bank_mean_deg'].min():.1f} .. "
               f"{tab['bank_mean_deg'].max():.1f} deg; origin {bmap.projection.lat0_deg:.5f}, "
               f"{bmap.projection.lon0_deg:.5f}; cell {bmap.cell_m:g} m")
    for f in files:
        click.echo(f"wrote {f}", err=True)
    sys.exit(1 if failed else 0)

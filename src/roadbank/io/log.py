"""``load_log``: any supported file -> :class:`Log` (validated :class:`~roadbank.Signals`, SI, ISO 8855)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..params import VehicleParams
from ..signals import Signals, road_wheel_angle
from . import readers
from .channels import ChannelMap, check_plausible, default_channel_map, read_channel_map
from .consistency import check_consistency
from .errors import LogError, channel_error
from .formats import CAN_FORMATS, FORMATS, ROS_FORMATS
from .resample import common_time_base, resample
from .timebase import TimeRepair, UnrepairableTime, add_counts, describe, repair_time
from .types import Log


#: the signal roles whose values are set to NaN on a sample flagged by the time-stamp repair
FLAGGED_ROLES = ("speed", "lateral_acceleration", "yaw_rate", "road_wheel_angle", "steering_wheel_angle")


def repair_stamps(source, column: str, t: np.ndarray, label: str = "time", after: float | None = None,
                  rownums=None, row_label: str = "sample") -> tuple[TimeRepair, list[str]]:
    """:func:`~roadbank.io.timebase.repair_time` of one channel's stamps ``t`` (s), with its message.

    Returns the repair and a warning naming the file, the channel, what was repaired and the first
    line / row / sample it touched (an empty list when nothing was). ``rownums`` number the samples
    in messages (default: 0, 1, ...). Raises :class:`LogError` when the stamps cannot be repaired.
    """
    try:
        rep = repair_time(t, after=after)
    except UnrepairableTime as exc:
        where = ""
        if after is not None and len(t):         # a streamed chunk: say where it is
            lo, hi = (rownums[0], rownums[len(t) - 1]) if rownums is not None else (0, len(t) - 1)
            where = f" ({row_label}s {lo}-{hi})"
        raise channel_error(source, label, column, f"{exc}{where}") from None
    if not rep.changed:
        return rep, []
    touched = np.ones(len(t), dtype=bool)
    touched[rep.keep] = False
    touched[rep.keep[rep.flagged]] = True
    first = int(np.flatnonzero(touched)[0])
    where = f"{row_label} {rownums[first] if rownums is not None else first}"
    n_flag = int(rep.flagged.sum())
    return rep, [f"{source}: channel '{label}' (column '{column}'): time stamps repaired: "
                 f"{describe(rep.counts)} (first at {where}), {n_flag} sample(s) flagged not valid"]


def repair_counts(rep: TimeRepair) -> dict:
    """The repair's counts (kind -> int) with ``flagged``: the samples flagged not valid."""
    return dict(rep.counts, flagged=int(rep.flagged.sum()))


def missing_column(p, role: str, column: str | None, names,
                   what: str = "column not found in the file") -> LogError:
    """The error for a required channel whose column is not in the file, with the way out: a
    channel map (``--channels map.toml``) that ``roadbank channels`` writes for the file's columns."""
    return channel_error(p, role, column, f"{what} (it has: "
                         f"{', '.join(names) or 'nothing'}); for a log with other column names give a "
                         f"channel map with --channels map.toml (`roadbank channels {Path(p).name} -o map.toml` "
                         "writes one for these columns)")


def select_roles(p, cmap: ChannelMap, have: set, names) -> list[str]:
    """Roles to read: speed, lateral_acceleration, yaw_rate, [the steering role], [reference_roll].

    The steering role is the road-wheel angle if its column exists, else the
    steering-wheel angle (none if the map has no steering channel: ROS maps). ``have`` are the columns
    present; ``names`` all the file's columns (for messages). LogError for a missing column.
    """
    steer_roles = [r for r in ("road_wheel_angle", "steering_wheel_angle") if r in cmap.channels]
    present = [r for r in steer_roles if cmap.channels[r].column in have]
    if not steer_roles:      # allowed for ROS maps only (ChannelMap): no steering, delta_f NaN
        present = [None]
    roles = ["speed", "lateral_acceleration", "yaw_rate"]
    for role in roles:
        col = cmap.channels[role].column
        if col not in have:
            raise missing_column(p, role, col, names)
    if not present:
        cols = " or ".join(f"'{cmap.channels[r].column}'" for r in steer_roles)
        raise missing_column(p, "steering", None, names, f"missing: no column {cols} in the file")
    if present[0] is not None:
        roles.append(present[0])
    if "reference_roll" in cmap.channels:
        roles.append("reference_roll")
        col = cmap.channels["reference_roll"].column
        if col not in have:
            raise channel_error(p, "reference_roll", col, f"column not found in the file "
                                f"(it has: {', '.join(names) or 'nothing'})")
    return roles


def steering_delta_f(cmap: ChannelMap, params: VehicleParams, roles: list[str], values: dict) -> np.ndarray:
    """``delta_f`` (rad): the road-wheel angle, or the steering-wheel angle over the steering ratio
    (the map's, else the car's; :func:`roadbank.signals.road_wheel_angle`), or NaN when the map has
    no steering channel (ROS robots; the modified-model estimators do not read it)."""
    if "road_wheel_angle" in roles:
        return values["road_wheel_angle"]
    if "steering_wheel_angle" in roles:
        car = params.replace(steering_ratio=cmap.steering_ratio) if cmap.steering_ratio else params
        return road_wheel_angle(values["steering_wheel_angle"], car)
    return np.full(len(values["speed"]), np.nan)


def load_log(path, channels: ChannelMap | str | Path | None = None, format: str | None = None,
             params: VehicleParams | None = None) -> Log:
    """Read one log into SI / ISO 8855 signals on one time base.

    Parameters
    ----------
    path : path-like
        A CSV, Parquet or MDF4 file, a comma2k19 segment directory, or a KITTI raw
        drive (its ``oxts`` folder, the drive folder or a folder holding one drive).
    channels : ChannelMap or path to a TOML channel map, optional
        Default: roadbank's own columns (what ``roadbank simulate`` writes).
        Not used for comma2k19 (fixed layout).
    format : str, optional
        "csv", "parquet", "mdf4", "comma2k19" or "kitti-oxts"; default from the
        suffix or the directory layout.
    params : VehicleParams, optional
        Supplies the steering ratio when the map gives a steering-wheel angle
        and no ``steering_ratio`` of its own.

    Raises
    ------
    LogError
        For every kind of bad input, naming the file, the channel and the problem.
    """
    p = Path(path)
    fmt = (format or readers.detect_format(p)).lower()
    if fmt not in FORMATS:
        raise LogError(f"{p}: unknown format '{fmt}' (known: {', '.join(FORMATS)})")
    if fmt == "comma2k19":
        from .comma2k19 import load_comma2k19
        return load_comma2k19(p, params=params)
    if fmt == "kitti-oxts":
        from .kitti import load_kitti_oxts
        return load_kitti_oxts(p)
    if not p.exists():
        raise LogError(f"{p}: file not found")
    cmap = channels if isinstance(channels, ChannelMap) else (
        read_channel_map(channels) if channels is not None else default_channel_map())
    params = params or VehicleParams()

    wanted = {spec.column: role for role, spec in cmap.channels.items()}
    warns: list[str] = []
    if fmt == "mdf4" and cmap.dbc is not None:
        fmt = "mdf4-can"                  # an MDF4 file with a DBC: bus logging
    if fmt in CAN_FORMATS:
        from .can import read_can
        raw, warns = read_can(p, cmap, fmt)
    elif fmt in ROS_FORMATS:
        from .ros import read_ros
        raw, warns = read_ros(p, cmap, fmt)
    else:
        raw = readers.READERS[fmt](p, wanted, cmap.truth_prefix)
    timed = fmt == "mdf4" or fmt in CAN_FORMATS or fmt in ROS_FORMATS
    have = set(raw.data)
    roles = select_roles(p, cmap, have, raw.names)

    series: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    shared = None
    if not timed:
        if "time" not in cmap.channels:
            raise LogError(f"{cmap.source}: channel map has no 'time' channel (required for {fmt})")
        tspec = cmap.channels["time"]
        if tspec.column not in have:
            raise missing_column(p, "time", tspec.column, raw.names)
        t = cmap.to_si_iso("time", raw.data[tspec.column])
        rep, w = repair_stamps(p, tspec.column, t, rownums=raw.rownums, row_label=raw.row_label)
        warns += w
        repairs = repair_counts(rep)
        if rep.changed:       # every column follows the repaired clock; flagged rows become NaN
            raw.data = {c: a[rep.keep] for c, a in raw.data.items()}
            for role in FLAGGED_ROLES:
                if role in cmap.channels and cmap.channels[role].column in raw.data:
                    raw.data[cmap.channels[role].column][rep.flagged] = np.nan
            t = t[rep.keep]
        check_plausible(p, "time", tspec.column, tspec.unit, None, t)
        shared = t
    else:
        repairs = {}
    for role in roles:
        spec = cmap.channels[role]
        v = cmap.to_si_iso(role, raw.data[spec.column])
        if timed:
            tr = raw.times[spec.column]
            rep, w = repair_stamps(p, spec.column, tr, label=role)
            warns += w
            repairs = add_counts(repairs, repair_counts(rep))
            if rep.changed:
                tr, v = tr[rep.keep], v[rep.keep]
                if role in FLAGGED_ROLES:
                    v[rep.flagged] = np.nan
        else:
            tr = shared
        if not np.any(np.isfinite(v)):
            raise channel_error(p, role, spec.column, "no finite values")
        warns += check_plausible(p, role, spec.column, spec.unit, tr, v)
        series[role] = (tr, v)

    try:
        t_base = common_time_base(series, cmap.time_base, cmap.rate_hz, shared_clock=shared)
        values = resample(series, t_base, cmap.max_gap_s, shared_clock=shared)
    except LogError as exc:
        raise LogError(f"{p}: {exc}") from None
    if len(t_base) < 2:
        raise LogError(f"{p}: fewer than 2 samples on the common time base")

    delta = steering_delta_f(cmap, params, roles, values)
    try:
        sig = Signals(t_base, values["speed"], values["lateral_acceleration"], values["yaw_rate"], delta)
    except ValueError as exc:
        raise LogError(f"{p}: {exc}") from None
    warns += check_consistency(sig, p, {role: cmap.channels[role].column for role in
                                        ("speed", "lateral_acceleration", "yaw_rate")})

    truth = {}
    if cmap.truth_prefix and shared is not None:
        for c, arr in raw.data.items():
            if c.startswith(cmap.truth_prefix) and c not in wanted:
                truth[c] = arr if t_base is shared else np.interp(t_base, shared, arr)
    return Log(signals=sig, reference_roll=values.get("reference_roll"), source=p, format=fmt,
               metadata=dict(raw.metadata), truth=truth, warnings=warns, channel_map=cmap,
               extra=_gnss(p, cmap, raw, shared, t_base), time_repairs=repairs)


#: GNSS fixes come at 1-20 Hz: a gap up to this long (s) is interpolated across
GNSS_MAX_GAP_S = 2.0


def gnss_roles(cmap: ChannelMap) -> list[str]:
    """The map's position channels: ``latitude``, ``longitude``; or ``ecef_x/y/z``; or none."""
    if {"latitude", "longitude"} <= set(cmap.channels):
        return ["latitude", "longitude"]
    if {"ecef_x", "ecef_y", "ecef_z"} <= set(cmap.channels):
        return ["ecef_x", "ecef_y", "ecef_z"]
    return []


def gnss_extra(p, cmap: ChannelMap, vals: dict) -> dict:
    """``{"lat_deg", "lon_deg"}`` (deg) from position channels already on the time base (SI: rad or m)."""
    if "ecef_x" in vals:
        from .comma2k19 import ecef_to_latlon
        pos = np.stack([vals["ecef_x"], vals["ecef_y"], vals["ecef_z"]], axis=1)
        r = np.linalg.norm(pos, axis=1)
        r = r[np.isfinite(r)]
        if len(r) and not 6.30e6 < float(np.median(r)) < 6.42e6:
            spec = cmap.channels["ecef_x"]
            raise channel_error(p, "ecef_x", spec.column, f"median distance from the Earth's centre "
                                f"{float(np.median(r)):.4g} m after converting from '{spec.unit}': not an "
                                "ECEF position (WGS-84 radius ~6.37e6 m)")
        lat, lon = ecef_to_latlon(pos)
    else:
        lat, lon = vals["latitude"], vals["longitude"]
    out = {"lat_deg": np.degrees(lat), "lon_deg": np.degrees(lon)}
    for role, key, limit in (("latitude", "lat_deg", 90.0), ("longitude", "lon_deg", 180.0)):
        if role in cmap.channels and np.nanmax(np.abs(out[key]), initial=0.0) > limit:
            spec = cmap.channels[role]
            raise channel_error(p, role, spec.column, f"|value| beyond {limit:g} deg after converting "
                                f"from '{spec.unit}'")
    return out


def _gnss(p, cmap: ChannelMap, raw, shared, t_base) -> dict:
    """``lat_deg`` / ``lon_deg`` on ``t_base`` from the map's position channels (else {})."""
    from .resample import interpolate

    vals = {}
    for role in gnss_roles(cmap):
        spec = cmap.channels[role]
        if spec.column not in raw.data:
            raise channel_error(p, role, spec.column, f"column not found in the file "
                                f"(it has: {', '.join(raw.names) or 'nothing'})")
        v = cmap.to_si_iso(role, raw.data[spec.column])
        tr = raw.times.get(spec.column)
        if tr is None:
            tr = shared
        else:                 # a position channel with its own clock: the same repair, not counted
            rep, _ = repair_stamps(p, spec.column, tr, label=role)
            tr, v = tr[rep.keep], v[rep.keep]
        vals[role] = interpolate(tr, v, t_base, GNSS_MAX_GAP_S)
    return gnss_extra(p, cmap, vals) if vals else {}

"""The assembler: raw channels of a source -> :class:`~roadbank.io.Log` chunks (SI, ISO 8855, one time base).

Every channel-map format (CSV, Parquet, MDF4, raw CAN, ROS) comes here from its source
(:mod:`roadbank.io.sources`), whole or in chunks, and goes through the same steps in the same order:

1. **channel selection**: the roles the map names and the file has (:func:`select_roles`);
2. **time stamps**: the table clock, or each channel's own, repaired chunk by chunk
   (:class:`~roadbank.io.repair.ChunkRepair`); samples next to a repair are set to NaN;
3. **SI and ISO 8855**: each channel's unit and sign convention (:meth:`ChannelMap.to_si_iso`);
4. **plausibility** of each channel's values in its declared unit
   (:func:`~roadbank.io.channels.check_plausible`);
5. **resampling** onto one time base (:class:`~roadbank.io.resample.StreamResampler`);
6. **the log**: :class:`~roadbank.Signals`, reference roll, truth, GNSS position, the cross-channel
   consistency check (:func:`~roadbank.io.consistency.check_consistency`) and the repair counts.

A log read whole is one chunk and gives one :class:`Log`; streamed, the same steps give its
consecutive chunks, which put end to end equal the whole log. ``time_base = "auto"`` is decided on
the whole log (for a table read in chunks, by a first pass over it: :mod:`roadbank.io.survey`).
Unit plausibility is checked on every chunk (its warnings come from the first), the time column's
sample period and the consistency check on the first chunk: on a log read whole, the whole log.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..params import VehicleParams
from ..signals import Signals, road_wheel_angle
from .channels import ChannelMap, check_plausible
from .comma2k19 import ecef_to_latlon
from .consistency import check_consistency
from .errors import LogError, channel_error
from .repair import FLAGGED_ROLES, ChunkRepair
from .resample import StreamResampler, clean_series
from .survey import auto_uses_clock
from .timebase import add_counts
from .types import Log

#: GNSS fixes come at 1-20 Hz: a gap up to this long (s) is interpolated across
GNSS_MAX_GAP_S = 2.0


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
    present: list[str | None] = [r for r in steer_roles if cmap.channels[r].column in have]
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


def same_rate(t: np.ndarray, vals: dict, roles) -> bool:
    """The ``time_base = "auto"`` rule of :func:`~roadbank.io.resample.common_time_base`: every role's
    valid samples come at the table clock's median period ``t`` (s), to 1 %."""
    if len(t) < 2:
        return False
    base = float(np.median(np.diff(t)))
    for r in roles:
        tc, _ = clean_series(t, vals[r])
        d = np.diff(tc)
        if not len(d) or abs(float(np.median(d)) - base) > 0.01 * base:
            return False
    return True


class _Logs:
    """Resampled output -> :class:`Log` s, given one behind: the last one waits for the repair
    counts and warnings that come after the last base time, and the log's length check."""

    def __init__(self, p, fmt, cmap, params, roles, gnss, truth_cols, metadata):
        self.p, self.fmt, self.cmap, self.params = p, fmt, cmap, params
        self.roles, self.gnss, self.truth_cols, self.metadata = roles, gnss, truth_cols, metadata
        self.warnings: list[str] = []      # for the next log
        self.counts: dict = {}             # repair counts for the next log
        self.pending: Log | None = None
        self.n = 0                         # samples given so far

    def add(self, out, counts: dict) -> Iterator[Log]:
        """The log of one :meth:`StreamResampler.emit` output (nothing for None), with the repair
        ``counts`` found since the last log."""
        self.counts = add_counts(self.counts, counts)
        if out is None or not len(out["t"]):
            return
        p, cmap = self.p, self.cmap
        delta = steering_delta_f(cmap, self.params, self.roles, out)
        try:
            sig = Signals(out["t"], out["speed"], out["lateral_acceleration"], out["yaw_rate"], delta)
        except ValueError as exc:
            raise LogError(f"{p}: {exc}") from None
        pos = {r: out[r] for r in self.gnss}
        log = Log(signals=sig, reference_roll=out.get("reference_roll"), source=p, format=self.fmt,
                  metadata=dict(self.metadata), truth={c: out[c] for c in self.truth_cols},
                  warnings=self.warnings, channel_map=cmap, extra=gnss_extra(p, cmap, pos) if pos else {},
                  time_repairs=self.counts)
        self.warnings, self.counts = [], {}
        if self.n == 0:
            log.warnings += check_consistency(sig, p, {r: cmap.channels[r].column for r in self.roles[:3]})
        self.n += len(sig)
        if self.pending is not None:
            yield self.pending
        self.pending = log

    def finish(self, counts: dict) -> Iterator[Log]:
        """The last log, with ``counts`` and the warnings left; LogError if the log is too short."""
        if self.n < 2:
            raise LogError(f"{self.p}: fewer than 2 samples on the common time base")
        assert self.pending is not None        # two samples or more were assembled
        self.pending.time_repairs = add_counts(self.pending.time_repairs, add_counts(self.counts, counts))
        self.pending.warnings += self.warnings
        yield self.pending


def _time_base(p, cmap: ChannelMap, roles) -> str:
    """The map's time base; LogError for a role name the log does not read."""
    tb = cmap.time_base
    if tb not in ("auto", "uniform") and tb not in roles:
        raise LogError(f"{p}: resample.time_base '{tb}' is not one of the log's channels ({', '.join(roles)})")
    return tb


def assemble(src, cmap: ChannelMap, params: VehicleParams, fmt: str) -> Iterator[Log]:
    """The log of source ``src`` in chunks (see the module doc).

    Parameters
    ----------
    src : source
        A table or channel source of :mod:`roadbank.io.sources`.
    cmap : ChannelMap
    params : VehicleParams
        Supplies the steering ratio when the map gives a steering-wheel angle without one.
    fmt : str
        Format name, for :attr:`Log.format`.

    Yields
    ------
    Log
        Consecutive chunks of the log: ``signals`` (SI, ISO 8855), ``reference_roll`` (rad),
        ``truth``, ``extra`` (``lat_deg`` / ``lon_deg``, deg) on the chunk's base times.

    Raises
    ------
    LogError
        Naming the file, the channel and the problem, when the bad part is reached.
    """
    p = src.path
    roles = select_roles(p, cmap, set(src.names), src.names)
    gnss = gnss_roles(cmap)
    for r in gnss:
        if cmap.channels[r].column not in src.names:
            raise channel_error(p, r, cmap.channels[r].column, f"column not found in the file "
                                f"(it has: {', '.join(src.names) or 'nothing'})")
    if src.shared_clock:
        yield from _tables(src, cmap, params, fmt, roles, gnss)
    else:
        yield from _channels(src, cmap, params, fmt, roles, gnss)


def _tables(src, cmap, params, fmt, roles, gnss) -> Iterator[Log]:
    """A table: every column on the table's time column."""
    p, names = src.path, src.names
    if "time" not in cmap.channels:
        raise LogError(f"{cmap.source}: channel map has no 'time' channel (required for {fmt})")
    tspec = cmap.channels["time"]
    if tspec.column not in names:
        raise missing_column(p, "time", tspec.column, names)
    wanted = {spec.column: role for role, spec in cmap.channels.items()}
    prefix = cmap.truth_prefix
    truth_cols = [c for c in names if prefix and c.startswith(prefix) and c not in wanted]
    tb = _time_base(p, cmap, roles)
    if tb == "auto" and not src.whole:    # decided on the whole log, as when it is read in one chunk
        used = {cmap.channels[r].column: r for r in ["time"] + roles}     # (a pass reads these only)
        tb = "clock" if auto_uses_clock(lambda: ((t, vals) for _, t, _, vals, _, _ in
                                                 _table_rows(src, cmap, roles, used, None)), roles) else "uniform"
    logs = _Logs(p, fmt, cmap, params, roles, gnss, truth_cols, src.metadata)
    logs.warnings += src.warnings
    finite = dict.fromkeys(roles, False)
    rs = None
    for last, t, cols, vals, w, fix in _table_rows(src, cmap, roles, wanted, prefix):
        logs.warnings += w
        first = rs is None and len(t) > 0
        if first:
            check_plausible(p, "time", tspec.column, tspec.unit, None, t)
        for r in roles:
            spec = cmap.channels[r]
            finite[r] = finite[r] or bool(np.isfinite(vals[r]).any())
            if last and not finite[r]:
                raise channel_error(p, r, spec.column, "no finite values")
            w = check_plausible(p, r, spec.column, spec.unit, t, vals[r])
            if first:
                logs.warnings += w
        if first:
            base = ("clock" if same_rate(t, vals, roles) else "uniform") if tb == "auto" else tb
            rs = StreamResampler(roles, dict.fromkeys(gnss, GNSS_MAX_GAP_S), base, cmap.rate_hz, cmap.max_gap_s,
                                 raw=truth_cols)
        if rs is None:
            if last:
                raise LogError(f"{p}: fewer than 2 samples on the common time base")
            continue
        rs.add_clock(t)
        for r in roles:
            rs.add(r, t, vals[r])
        for r in gnss:
            rs.add(r, t, cmap.to_si_iso(r, cols[cmap.channels[r].column]))
        for c in truth_cols:
            rs.add(c, t, cols[c])
        if last:
            for k in rs.done:
                rs.finish(k)
        yield from logs.add(_emit(p, rs), fix.take_counts())
    yield from logs.finish({})


def _table_rows(src, cmap, roles, wanted, prefix):
    """The table's chunks with the clock repaired: ``(last, t, columns, role values, warnings, repair)``
    per chunk; ``t`` (s) and the role values (SI, ISO 8855, NaN where flagged by the repair) row for
    row, the columns as stored."""
    tspec = cmap.channels["time"]
    fix = ChunkRepair(src.path, tspec.column, "time", src.row_label)
    flag_cols = [cmap.channels[r].column for r in FLAGGED_ROLES if r in cmap.channels]
    for chunk in src.chunks(wanted, prefix):
        t, cols, flagged, w = fix.feed(cmap.to_si_iso("time", chunk.data[tspec.column]), chunk.data,
                                       chunk.rownums, chunk.last)
        for c in flag_cols:          # every column follows the repaired clock; flagged rows become NaN
            if c in cols:
                cols[c][flagged] = np.nan
        vals = {r: cmap.to_si_iso(r, cols[cmap.channels[r].column]) for r in roles}
        yield chunk.last, t, cols, vals, w, fix


def _channels(src, cmap, params, fmt, roles, gnss) -> Iterator[Log]:
    """Channels that each carry their own clock (MDF4, raw CAN, ROS)."""
    p = src.path
    tb = _time_base(p, cmap, roles)
    rs = StreamResampler(roles, dict.fromkeys(gnss, GNSS_MAX_GAP_S), "uniform" if tb == "auto" else tb,
                         cmap.rate_hz, cmap.max_gap_s)
    read = roles + gnss
    col = {r: cmap.channels[r].column for r in read}
    fixes = {r: ChunkRepair(p, col[r], r, "sample") for r in read}
    rows = dict.fromkeys(read, 0)
    finite = dict.fromkeys(roles, False)
    checked = dict.fromkeys(roles, False)
    logs = _Logs(p, fmt, cmap, params, roles, gnss, [], src.metadata)
    logs.warnings += src.warnings

    def counts() -> dict:
        total: dict = {}
        for r in roles:
            total = add_counts(total, fixes[r].take_counts())
        return total

    for chunk in src.chunks({col[r]: r for r in read}):
        for r in read:
            c, fix = col[r], fixes[r]
            ends = c in chunk.done
            if c in chunk.data:
                n = len(chunk.data[c])
                t, got, flagged, w = fix.feed(chunk.times[c], {"v": chunk.data[c]},
                                           np.arange(rows[r], rows[r] + n), ends)
                rows[r] += n
            elif ends and fix.holding:
                t, got, flagged, w = fix.feed(np.zeros(0), {"v": np.zeros(0)}, [], True)
            else:
                t = None
            if t is not None:
                v = cmap.to_si_iso(r, got["v"])
                if r in roles:               # (a position channel: repaired, neither flagged nor checked)
                    logs.warnings += w
                    if r in FLAGGED_ROLES:
                        v[flagged] = np.nan
                    finite[r] = finite[r] or bool(np.isfinite(v).any())
                    spec = cmap.channels[r]
                    w = check_plausible(p, r, spec.column, spec.unit, t, v)
                    if len(t) and not checked[r]:
                        checked[r] = True
                        logs.warnings += w
                rs.add(r, t, v)
            if ends:
                if r in roles and not rows[r]:
                    raise channel_error(p, r, c, "no samples")
                if r in roles and not finite[r]:
                    raise channel_error(p, r, c, "no finite values")
                rs.finish(r)
        yield from logs.add(_emit(p, rs), counts())
    yield from logs.finish(counts())


def _emit(p, rs: StreamResampler):
    try:
        return rs.emit()
    except LogError as exc:
        raise LogError(f"{p}: {exc}") from None

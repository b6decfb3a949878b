"""Logs -> bank map: stream each log, estimate the bank, attach settled estimates to their GNSS position."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

import numpy as np

from ..defaults import MAP_ESTIMATOR
from ..estimators import OFFLINE
from ..io import LogError
from ..io.assemble import gnss_roles
from ..io.channels import ChannelMap
from ..io.errors import channel_text
from ..io.files import must_exist
from ..io.stream import CHUNK_ROWS, ReadAhead, stream_log
from ..io.writers import write_error
from ..params import VehicleParams
from ..vehicle import (DESIGN_MAX_S, Vehicle, described_car, for_conditions, has_design_span, load_vehicle,
                       log_conditions, trims_rear, undescribed_params)
from ..vehicle.conditions import (QUIET_MODELS, RoadCheck, design_ay_floor, handed_over_warnings, is_quiet,
                                  keeps_cars_model, louder_warnings, models_car)
from ..vehicle.sensors import SensorSpec
from .geo import CourseStream, LocalProjection, PositionJumps, TrackScale
from .grid import BankMap


@dataclass
class MappedLog:
    """One log's part in a map: ``status`` "ok" or "error" (with ``error``), samples read and mapped, and the
    reader's warnings (file, channel, problem)."""

    log: str
    status: str = "ok"
    error: str = ""
    samples: int = 0
    mapped: int = 0
    warnings: list[str] = field(default_factory=list)


#: a log whose settled estimates are fewer than this share (-) of its valid ones is warned about (only settled ones
#: are mapped: on a 43 s KITTI drive the gyro-aided smoother's 27 s settling leaves 31 %)
UNSETTLED_SHARE = 0.5
#: a fix farther than this (m) from the map's origin is warned about: the local projection's scale error is below
#: 0.1 % within it (:mod:`roadbank.mapping.geo`)
FAR_M = 50_000.0


def fixes(lat_deg, lon_deg) -> tuple[np.ndarray, np.ndarray]:
    """Positions (deg) with those that are no fix NaN: a latitude or longitude that is not finite, and exactly
    0, 0 (what a GNSS receiver without a fix logs; no road there), both of the pair."""
    lat, lon = np.asarray(lat_deg, dtype=np.float64), np.asarray(lon_deg, dtype=np.float64)
    bad = ~(np.isfinite(lat) & np.isfinite(lon)) | ((lat == 0.0) & (lon == 0.0))
    if not bad.any():
        return lat, lon
    return np.where(bad, np.nan, lat), np.where(bad, np.nan, lon)


class FixCount:
    """What a log's positions held, chunk by chunk: a finite latitude, a finite longitude, a pair at
    exactly 0, 0, a fix (:func:`fixes`); :meth:`problem` words why a log without a fix is not mapped."""

    def __init__(self):
        self.lat = self.lon = self.zero = self.fix = False

    def add(self, lat_deg, lon_deg) -> tuple[np.ndarray, np.ndarray]:
        """Count one chunk's positions (deg); return them as :func:`fixes`."""
        lat, lon = np.asarray(lat_deg, dtype=np.float64), np.asarray(lon_deg, dtype=np.float64)
        self.lat = self.lat or bool(np.isfinite(lat).any())
        self.lon = self.lon or bool(np.isfinite(lon).any())
        self.zero = self.zero or bool(((lat == 0.0) & (lon == 0.0)).any())
        lat, lon = fixes(lat, lon)
        self.fix = self.fix or bool(np.isfinite(lat).any())
        return lat, lon

    def problem(self, path, cmap: ChannelMap | None) -> str | None:
        """None if the log had a fix; else the reason it is not mapped, naming ``path`` and the position
        channels (their roles and columns in ``cmap``: ``latitude``/``longitude`` or ``ecef_x/y/z``; a data
        set's own: ``lat_deg``/``lon_deg``)."""
        if self.fix:
            return None
        roles, cols, lat, lon = _position_channels(cmap)
        if roles and lat not in roles:      # ECEF: one position from three channels
            return f"{path}: {position_names(cmap)}: no finite position in the whole log: no fix, not mapped"
        missing = [r for r, seen in ((lat, self.lat), (lon, self.lon)) if not seen]
        for_role = {lat: "latitude", lon: "longitude"}
        if missing:
            return "; ".join(channel_text(path, r, cols.get(r), f"no finite {for_role[r]} in the whole log "
                                          "(all missing): no position, not mapped") for r in missing)
        names = position_names(cmap)
        if self.zero:
            return (f"{path}: {names}: no GNSS fix in the whole log (every position is missing or exactly 0, 0, "
                    "which a receiver without a fix logs): not mapped")
        return f"{path}: {names}: never both finite at one sample: no position, not mapped"


def _position_channels(cmap: ChannelMap | None) -> tuple[list, dict, str, str]:
    """The position roles of ``cmap`` (``latitude``/``longitude`` or ``ecef_x/y/z``; none for a data set's own),
    their columns, and the names of the latitude and longitude (a data set's: ``lat_deg``/``lon_deg``)."""
    roles = gnss_roles(cmap) if cmap is not None else []
    cols = {r: cmap.channels[r].column for r in roles} if cmap is not None else {}
    lat, lon = ("latitude", "longitude") if "latitude" in roles else ("lat_deg", "lon_deg")
    return roles, cols, lat, lon


def position_names(cmap: ChannelMap | None) -> str:
    """``channels '<role>' (column '<column>') and ...``: how a message names a log's position channels."""
    roles, cols, lat, lon = _position_channels(cmap)
    if roles and lat not in roles:
        return "channels " + ", ".join(f"'{r}' (column '{c}')" for r, c in cols.items())
    return f"channels '{lat}' (column '{cols.get(lat, lat)}') and '{lon}' (column '{cols.get(lon, lon)}')"


def _origin(lat, lon) -> LocalProjection | None:
    """The projection of the first fix (:func:`fixes`) of positions ``lat``, ``lon`` (deg) rounded to
    0.01 deg; None if they hold none."""
    lat, lon = fixes(lat, lon)
    ok = np.isfinite(lat)
    if not ok.any():
        return None
    # rounded to 0.01 deg, so maps of the same area made separately share one grid
    return LocalProjection(round(float(lat[ok][0]), 2), round(float(lon[ok][0]), 2))


@dataclass(frozen=True)
class MapSettings:
    """How every log of a map is read, estimated and gridded (see :func:`map_logs`)."""

    estimator: str = MAP_ESTIMATOR
    channels: ChannelMap | str | Path | None = None
    format: str | None = None
    params: VehicleParams | None = None
    vehicle: Vehicle | None = None
    cell_m: float = 10.0
    sectors: int = 4
    chunk_rows: int | None = None


def _design(settings: MapSettings, signals, designs: dict):
    """The estimator for a log (its sample rate and road noise, :func:`roadbank.vehicle.for_conditions`; a car
    that is not described chosen for the log, :func:`roadbank.vehicle.undescribed_params`, one described with its rear
    stiffness trimmed to the log, :func:`roadbank.vehicle.described_car`, unless measured), memoised in
    ``designs`` by those conditions and the car, and where the log reads quiet and the estimator keeps the car's
    model there, the :class:`~roadbank.vehicle.conditions.RoadCheck` of its roads (else None)."""
    cond = log_conditions(signals)
    described = settings.params is not None or settings.vehicle is not None
    if described:
        car_file = settings.vehicle
        given = car_file.params if car_file is not None else settings.params
        on_car = (car_file.sensors, car_file.tuning) if car_file is not None else (None, None)
        car = described_car(signals, cast(VehicleParams, given), cond, trims_rear(car_file), *on_car)
    else:
        car = undescribed_params(signals, cond=cond)
    key = (tuple(round(v, 6) if v is not None and np.isfinite(v) else None for v in cond.values()), car, described)
    if key not in designs:
        designs[key] = for_conditions(settings.estimator, cond, car, vehicle=settings.vehicle, described=described)
    sensors = settings.vehicle.sensors if settings.vehicle is not None else SensorSpec()
    model = settings.estimator in QUIET_MODELS and models_car(settings.estimator, described) and keeps_cars_model(
        is_quiet(sensors, cond.get("log_rate"), cond.get("log_ay_noise"), log_ay_floor=cond.get("log_ay_floor")),
        cond.get("log_roll_rate"), bool(cond.get("log_gyro_unbiased")))
    return designs[key], (RoadCheck(design_ay_floor(signals)) if model else None), cond.get("log_roll_rate")


def map_one_log(path, log_id, settings: MapSettings, projection: LocalProjection | None = None,
                designs: dict | None = None) -> tuple[MappedLog, BankMap | None, LocalProjection | None]:
    """One log's part of a map.

    Parameters
    ----------
    path : path-like
    log_id : hashable
        Counts the distinct logs per cell (:meth:`BankMap.add`).
    settings : MapSettings
    projection : LocalProjection, optional
        The map's plane; None: the one of this log's first fix (rounded to 0.01 deg).
    designs : dict, optional
        Estimator designs shared between the logs of one process.

    Returns
    -------
    (MappedLog, BankMap or None, LocalProjection or None)
        The log's record; its cells (None if it failed or had no fix while ``projection`` was
        None); the projection of its first fix (None if it reached none), whatever ``projection``.
    """
    designs = {} if designs is None else designs
    s = settings
    correct = (lambda x: x) if s.vehicle is None else s.vehicle.correct
    params = s.vehicle.params if s.vehicle is not None else s.params
    rec, first, part = MappedLog(str(path)), None, None
    far = 0.0                    # the farthest fix from the map's origin (m)
    valid = settled = 0          # the estimator's valid samples, and those of them settled
    track = CourseStream()       # the course of each sample over the whole log, not its chunk
    seen, cmap, jumps, scale = FixCount(), None, PositionJumps(), TrackScale()

    def add(crs, arrays):
        if part is not None and len(crs):
            rec.mapped += part.add(*arrays, log_id=log_id, course_rad=crs)
    try:
        must_exist(path)     # before its format is guessed from a suffix it may not have
        chunks = ReadAhead(stream_log(path, channels=s.channels, format=s.format, params=params,
                                      chunk_rows=s.chunk_rows or CHUNK_ROWS))
        road, roll_rate = None, None       # whether a log designed quiet stays so (RoadCheck), its roll-rate check
        t0 = math.nan                      # the log's first stamp (s)
        # an offline estimator smooths each chunk with the chunks after it as lookahead
        for k, chunk in enumerate(chunks):
            if "lat_deg" not in chunk.extra or "lon_deg" not in chunk.extra:
                raise LogError(f"{path}: no GNSS position (map 'latitude' and 'longitude' in the channel "
                               "map, or use a format that has one: comma2k19, kitti-oxts, ROS NavSatFix)")
            cmap = chunk.channel_map
            rec.warnings += chunk.warnings
            lat, lon = seen.add(chunk.extra["lat_deg"], chunk.extra["lon_deg"])   # 0, 0: no fix, NaN
            lat, lon = jumps.add(chunk.signals.t, lat, lon)                          # a receiver's glitch: NaN
            scale.add(chunk.signals.t, lat, lon, chunk.signals.vx)
            first = first or _origin(lat, lon)
            plane = projection or first
            if part is None and plane is not None:
                part = BankMap(plane, s.cell_m, s.sectors)
            if k == 0:      # designed on the log's first minute of driving, as roadbank estimate does
                t0 = float(chunk.signals.t[0])
                est, road, roll_rate = _design(s, chunks.leading(chunk.signals, DESIGN_MAX_S, has_design_span),
                                               designs)
            signals = correct(chunk.signals)
            if road is not None:
                road.add(signals)
            nxt = chunks.following(est.lookahead_s) if s.estimator in OFFLINE else None
            out = est.run(signals, reset=(k == 0), lookahead=None if nxt is None else correct(nxt))
            rec.samples += len(out.t)
            valid += int(np.count_nonzero(out.valid))
            settled += int(np.count_nonzero(out.settled))
            if part is not None:
                east, north = part.projection.to_en(lat, lon)
                with np.errstate(invalid="ignore"):
                    far = max(far, float(np.nanmax(np.hypot(east, north), initial=0.0)))
                add(*track.push(east, north, lat, lon, out.phi_b, out.settled))
        add(*track.finish())
        if far > FAR_M and part is not None:
            rec.warnings.append(f"{path}: positions up to {far / 1e3:,.0f} km from the map's origin "
                                f"({part.projection.lat0_deg:.5f}, {part.projection.lon0_deg:.5f}): beyond "
                                f"{FAR_M / 1e3:g} km its flat cells are distorted (their scale off by more than "
                                "0.1 %); map each region apart, or give --origin near it")
        why = seen.problem(path, cmap)
        if why is not None:
            raise LogError(why)
        handed_at = getattr(est, "handed_at", math.nan)     # a causal estimator handed over as roads turned loud
        if math.isfinite(handed_at):
            rec.warnings += handed_over_warnings(str(path), {s.estimator: (handed_at, est.handed_to)}, t0)
        elif road is not None:
            rec.warnings += louder_warnings(str(path), [s.estimator], roll_rate, *road.finish())
        if settled < UNSETTLED_SHARE * valid:
            rec.warnings.append(f"{path}: {settled} of its {valid} valid estimates had settled, and only those are "
                                f"mapped ({s.estimator} settles {est.settle_time:.3g} s after each (re)start of the "
                                "log: a short log loses much of itself)")
        off = scale.problem()
        if off is not None:
            raise LogError(f"{path}: {position_names(cmap)}: {off}")
        jumped = jumps.problem()
        if jumped is not None:
            rec.warnings.append(f"{path}: {position_names(cmap)}: {jumped}")
    except (LogError, ValueError, OSError) as exc:
        rec.status, rec.error = "error", str(exc)
    except Exception as exc:  # never a traceback for one bad file
        rec.status, rec.error = "error", f"{type(exc).__name__}: {exc}"
    if rec.status != "ok":
        part, rec.mapped = None, 0
    return rec, part, first


def _map_batch(jobs, settings: MapSettings, projection) -> list[tuple]:
    """:func:`map_one_log` on each ``(log_id, path)`` of ``jobs`` in turn (one pool task; the
    designs are shared between them)."""
    designs: dict = {}
    return [map_one_log(path, k, settings, projection, designs) for k, path in jobs]


def _first_fix(paths, settings: MapSettings) -> LocalProjection | None:
    """The default origin: the projection of the first fix of the first log (in order) that reaches
    one, reading each log only up to it (a log that fails before it is passed over)."""
    params = settings.vehicle.params if settings.vehicle is not None else settings.params
    for path in paths:
        chunks = stream_log(path, channels=settings.channels, format=settings.format, params=params,
                            chunk_rows=settings.chunk_rows or CHUNK_ROWS)
        try:
            for chunk in chunks:
                if "lat_deg" not in chunk.extra or "lon_deg" not in chunk.extra:
                    break
                proj = _origin(chunk.extra["lat_deg"], chunk.extra["lon_deg"])
                if proj is not None:
                    return proj
        except Exception:   # the log is reported when it is mapped
            pass
        finally:
            chunks.close()  # type: ignore[attr-defined]  # stream_log returns a generator
    return None


def _parts_on_pool(pool, paths, settings, projection, on_log=None) -> list[tuple]:
    """:func:`map_one_log` of every log on ``pool`` in batches, in the order of ``paths``."""
    groups = [[(k, paths[k]) for k in idx] for idx in pool.batches(paths)]
    tasks = {pool.submit(_map_batch, g, settings, projection): g for g in groups}
    done = {}
    for task in pool.as_completed(tasks):
        parts, failure = pool.outcome(task)
        if failure is not None:      # the worker died (memory, signal): this batch only; where its
            # logs would have put the origin is not known, so they leave the one guessed
            parts = [(MappedLog(str(p), "error", failure), None, projection) for _, p in tasks[task]]
        for (k, _), part in zip(tasks[task], parts):
            done[k] = part
            if on_log is not None:
                on_log(part[0])
    return [done[k] for k in range(len(paths))]


def map_logs(logs, estimator: str = MAP_ESTIMATOR, *, channels=None, format: str | None = None, params=None,
             vehicle=None, cell_m: float = 10.0, sectors: int = 4, origin: tuple | None = None,
             chunk_rows: int | None = None, on_log=None, pool=None) -> tuple[BankMap | None, list[MappedLog]]:
    """Build a bank map from logs that carry GNSS positions.

    Parameters
    ----------
    logs : sequence of path-like
        Any format :func:`roadbank.io.load_log` reads whose :attr:`~roadbank.io.Log.extra` has
        ``lat_deg`` / ``lon_deg``: a channel map with ``latitude`` / ``longitude`` roles
        (CSV, Parquet, MDF4, CAN, ROS ``NavSatFix``), comma2k19 (ECEF pose), KITTI oxts.
    estimator : str
        Estimator whose settled ``phi_b`` is mapped (:attr:`~roadbank.signals.Estimate.settled`); default
        :data:`roadbank.defaults.MAP_ESTIMATOR`,
        the offline ``kinematic-smoother`` (``pif-smoother`` on a quiet log of a car described; a map is made after
        the drives, so the samples after each instant may be used; each streamed chunk is smoothed
        with the chunks after it as lookahead, as one run over the log).
    channels, format, params, vehicle
        As for :func:`roadbank.fleet.estimate_log`.
    cell_m, sectors
        The grid (see :class:`BankMap`).
    origin : (lat_deg, lon_deg), optional
        Origin of the map's plane; default the first fix of the first log that has one, rounded
        to 0.01 deg.
    chunk_rows : int, optional
        Streaming chunk size.
    on_log : callable(MappedLog), optional
        Called as each log finishes (on Dask workers: as each batch of logs finishes).
    pool : optional
        Where the logs are mapped (a pool of :func:`roadbank.fleet.cluster.open_pool`; default
        one after another in this process). On workers each log is mapped on its own and the logs' cells
        are merged in the order of ``logs`` (:meth:`BankMap.merge`), so the map is the same as
        in one process.

    Returns
    -------
    (BankMap or None, list of MappedLog)
        None if no log gave a position. A bad log is reported in its MappedLog, adds nothing to
        the map and never stops the others.
    """
    vehicle = None if vehicle is None else load_vehicle(vehicle)   # a Vehicle, a built-in name or a file's path
    settings = MapSettings(estimator, channels, format, params, vehicle, cell_m, sectors, chunk_rows)
    paths = list(logs)
    fixed = LocalProjection(*origin) if origin is not None else None
    bmap = BankMap(fixed, cell_m, sectors) if fixed is not None else None
    records: list[MappedLog] = []
    if pool is None or pool.in_process:
        designs: dict = {}
        for k, path in enumerate(paths):
            rec, part, first = map_one_log(path, k, settings, None if bmap is None else bmap.projection, designs)
            if bmap is None and first is not None:
                bmap = BankMap(first, cell_m, sectors)
            if part is not None:    # a part has a projection: then so has the map
                bmap.merge(part)  # type: ignore[union-attr]
            records.append(rec)
            if on_log is not None:
                on_log(rec)
        return bmap, records
    guess = fixed or _first_fix(paths, settings)
    parts = _parts_on_pool(pool, paths, settings, guess, on_log)
    if fixed is None:
        # the origin is the first fix the logs reach in order (as in one process); a guess that
        # missed it (a log that failed before mapping it) is corrected by mapping again
        origin_found = next((first for _, _, first in parts if first is not None), None)
        if origin_found is not None and origin_found != guess:
            parts = _parts_on_pool(pool, paths, settings, origin_found)
        bmap = BankMap(origin_found, cell_m, sectors) if origin_found is not None else None
    for rec, part, _ in parts:
        if part is not None:    # a part has a projection: then so has the map
            bmap.merge(part)  # type: ignore[union-attr]
        records.append(rec)
    return bmap, records


def write_outputs(bmap: BankMap, output, geojson=None, png=None, metadata: dict | None = None) -> list[Path]:
    """Write the map's Parquet table and, if asked, its GeoJSON and PNG. A file that cannot be written is
    an ``OSError`` naming it, why, and the files written before it."""
    out: list[Path] = []
    for path, write in ((output, lambda p: bmap.write_parquet(p, metadata)), (geojson, bmap.write_geojson),
                        (png, bmap.plot)):
        if path is None:
            continue
        try:
            out.append(write(path))
        except (OSError, ValueError) as exc:    # ValueError: matplotlib, a suffix it cannot draw
            why = str(write_error(path, exc)) if isinstance(exc, OSError) else f"cannot write '{path}': {exc}"
            raise OSError(why + (f" ({', '.join(map(str, out))} written)" if out else "")) from None
    return out

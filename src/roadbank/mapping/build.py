"""Logs -> bank map: stream each log, estimate the bank, attach valid estimates to their GNSS position."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .geo import LocalProjection
from .grid import BankMap


@dataclass
class MappedLog:
    """One log's part in a map: ``status`` "ok" or "error" (with ``error``), samples read and mapped."""

    log: str
    status: str = "ok"
    error: str = ""
    samples: int = 0
    mapped: int = 0


def _origin(lat, lon) -> LocalProjection | None:
    ok = np.isfinite(lat) & np.isfinite(lon)
    if not ok.any():
        return None
    # rounded to 0.01 deg, so maps of the same area made separately share one grid
    return LocalProjection(round(float(lat[ok][0]), 2), round(float(lon[ok][0]), 2))


def map_logs(logs, estimator: str = "pif-smoother", *, channels=None, format: str | None = None, params=None,
             vehicle=None, cell_m: float = 10.0, sectors: int = 4, origin: tuple | None = None,
             chunk_rows: int | None = None, on_log=None) -> tuple[BankMap | None, list[MappedLog]]:
    """Build a bank map from logs that carry GNSS positions.

    Parameters
    ----------
    logs : sequence of path-like
        Any format :func:`roadbank.io.load_log` reads whose :attr:`~roadbank.io.Log.extra` has
        ``lat_deg`` / ``lon_deg``: a channel map with ``latitude`` / ``longitude`` roles
        (CSV, Parquet, MDF4, CAN, ROS ``NavSatFix``), comma2k19 (ECEF pose), KITTI oxts.
    estimator : str
        Estimator whose valid ``phi_b`` is mapped; default the offline ``pif-smoother`` (a map is
        made after the drives, so the samples after each instant may be used; each streamed
        chunk is smoothed with the chunks after it as lookahead, as one run over the log).
    channels, format, params, vehicle
        As for :func:`roadbank.fleet.estimate_log`.
    cell_m, sectors
        The grid (see :class:`BankMap`).
    origin : (lat_deg, lon_deg), optional
        Origin of the map's plane; default the first fix, rounded to 0.01 deg.
    chunk_rows : int, optional
        Streaming chunk size.
    on_log : callable(MappedLog), optional

    Returns
    -------
    (BankMap or None, list of MappedLog)
        None if no log gave a position. A bad log is reported in its MappedLog
        and never stops the others.
    """
    from ..estimators import OFFLINE
    from ..io import LogError
    from ..io.stream import CHUNK_ROWS, ReadAhead, stream_log
    from ..vehicle import log_conditions, make_estimator, undescribed_params

    if vehicle is not None:
        params = vehicle.params
    car = params if params is not None else undescribed_params()   # a car nobody described
    # designed per log, for its sample rate and ay noise (as roadbank estimate:
    # roadbank.vehicle.make_estimator)
    designs = {}

    def design(signals):
        cond = log_conditions(signals)
        key = tuple(round(v, 6) if np.isfinite(v) else None for v in cond.values())
        if key not in designs:
            designs[key] = (vehicle.make(estimator, **cond) if vehicle is not None
                            else make_estimator(estimator, car, **cond))
        return designs[key]
    correct = (lambda s: s) if vehicle is None else vehicle.correct
    bmap = BankMap(LocalProjection(*origin), cell_m, sectors) if origin is not None else None
    done: list[MappedLog] = []
    for k_log, path in enumerate(logs):
        rec = MappedLog(str(path))
        try:
            chunks = ReadAhead(stream_log(path, channels=channels, format=format, params=params,
                                          chunk_rows=chunk_rows or CHUNK_ROWS))
            # an offline estimator smooths each chunk with the chunks after it as lookahead
            for k, chunk in enumerate(chunks):
                if "lat_deg" not in chunk.extra or "lon_deg" not in chunk.extra:
                    raise LogError(f"{path}: no GNSS position (map 'latitude' and 'longitude' in the channel "
                                   "map, or use a format that has one: comma2k19, kitti-oxts, ROS NavSatFix)")
                if k == 0:
                    est = design(chunk.signals)
                signals = correct(chunk.signals)
                nxt = chunks.following(est.lookahead_s) if estimator in OFFLINE else None
                out = est.run(signals, reset=(k == 0), lookahead=None if nxt is None else correct(nxt))
                lat, lon = chunk.extra["lat_deg"], chunk.extra["lon_deg"]
                if bmap is None:
                    proj = _origin(lat, lon)
                    if proj is not None:
                        bmap = BankMap(proj, cell_m, sectors)
                rec.samples += len(out.t)
                if bmap is not None:
                    rec.mapped += bmap.add(lat, lon, out.phi_b, out.valid, log_id=k_log)
        except (LogError, ValueError, OSError) as exc:
            rec.status, rec.error = "error", str(exc)
        except Exception as exc:  # never a traceback for one bad file
            rec.status, rec.error = "error", f"{type(exc).__name__}: {exc}"
        done.append(rec)
        if on_log is not None:
            on_log(rec)
    return bmap, done


def write_outputs(bmap: BankMap, output, geojson=None, png=None, metadata: dict | None = None) -> list[Path]:
    """Write the map's Parquet table and, if asked, its GeoJSON and PNG."""
    out = [bmap.write_parquet(output, metadata)]
    if geojson is not None:
        out.append(bmap.write_geojson(geojson))
    if png is not None:
        out.append(bmap.plot(png))
    return out

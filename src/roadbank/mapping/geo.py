"""The map's plane: East/North metres about an origin (equirectangular projection on the WGS-84 sphere).

``e = R cos(lat0) (lon - lon0)``, ``n = R (lat - lat0)`` with R the WGS-84
mean radius. Within 50 km of the origin the scale error is below 0.1 %
(the cells are a few metres), which is why each map stores its origin and maps
of far-apart regions use their own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..constants import MAX_GAP_S

#: WGS-84 mean Earth radius (m)
EARTH_RADIUS = 6_371_008.8


@dataclass(frozen=True)
class LocalProjection:
    """East/North (m) about ``(lat0_deg, lon0_deg)`` and back.

    Parameters
    ----------
    lat0_deg, lon0_deg : float
        Origin (deg).
    """

    lat0_deg: float
    lon0_deg: float

    def __post_init__(self):
        if not (abs(self.lat0_deg) < 85.0 and abs(self.lon0_deg) <= 180.0):
            raise ValueError(f"map origin ({self.lat0_deg}, {self.lon0_deg}) deg out of range (|lat| < 85)")

    @property
    def _k(self) -> float:
        return math.radians(1.0) * EARTH_RADIUS

    def to_en(self, lat_deg, lon_deg) -> tuple[np.ndarray, np.ndarray]:
        """(east, north) in m of positions in deg."""
        c = math.cos(math.radians(self.lat0_deg))
        e = (np.asarray(lon_deg, dtype=np.float64) - self.lon0_deg) * self._k * c
        n = (np.asarray(lat_deg, dtype=np.float64) - self.lat0_deg) * self._k
        return e, n

    def to_latlon(self, east, north) -> tuple[np.ndarray, np.ndarray]:
        """(lat, lon) in deg of (east, north) in m."""
        c = math.cos(math.radians(self.lat0_deg))
        lat = self.lat0_deg + np.asarray(north, dtype=np.float64) / self._k
        lon = self.lon0_deg + np.asarray(east, dtype=np.float64) / (self._k * c)
        return lat, lon


def course(east: np.ndarray, north: np.ndarray, half_window: int = 25, min_move: float = 0.5) -> np.ndarray:
    """Course over ground (rad, clockwise from north, 0..2 pi) from positions (m), by centred differences.

    ``half_window`` samples either side (25 = 0.25 s at 100 Hz); NaN where the
    positions moved less than ``min_move`` metres over the window or near the ends.
    """
    e, n = np.asarray(east, dtype=np.float64), np.asarray(north, dtype=np.float64)
    out = np.full(len(e), np.nan)
    k = int(half_window)
    if len(e) <= 2 * k:
        return out
    de, dn = e[2 * k:] - e[:-2 * k], n[2 * k:] - n[:-2 * k]
    c = np.mod(np.arctan2(de, dn), 2 * np.pi)
    c[np.hypot(de, dn) < min_move] = np.nan
    out[k:len(e) - k] = c
    return out


class CourseStream:
    """:func:`course` over a track that arrives in chunks, equal to :func:`course` over the whole.

    The course at a sample needs ``half_window`` samples either side, so each chunk's last
    ``half_window`` samples are held back until the next chunk (or :meth:`finish`) brings them.
    :meth:`push` takes a chunk's positions (m) and the per-sample arrays that go with them and
    returns the samples now complete, with their course (rad): ``(course, arrays)``.
    """

    def __init__(self, half_window: int = 25, min_move: float = 0.5):
        self.k, self.min_move = int(half_window), float(min_move)
        self._buf: list[np.ndarray] | None = None     # east, north, then the carried arrays
        self._ctx = 0                                  # leading samples already handed out (context)

    def push(self, east, north, *arrays) -> tuple[np.ndarray, list[np.ndarray]]:
        """Add a chunk; return ``(course rad, [arrays...])`` of the samples whose course is now known."""
        new = [np.asarray(a) for a in (east, north, *arrays)]
        self._buf = new if self._buf is None else [np.concatenate([b, a]) for b, a in zip(self._buf, new)]
        return self._hand_out(self._buf, max(self._ctx, len(self._buf[0]) - self.k))

    def finish(self) -> tuple[np.ndarray, list[np.ndarray]]:
        """The samples still held back (the track's end: no course within ``half_window`` of it)."""
        if self._buf is None:
            return np.empty(0), []
        return self._hand_out(self._buf, len(self._buf[0]))

    def _hand_out(self, b: list[np.ndarray], end: int) -> tuple[np.ndarray, list[np.ndarray]]:
        """The samples of the buffer ``b`` up to ``end`` with their course; keeps the context after them."""
        crs = course(b[0], b[1], self.k, self.min_move)[self._ctx:end]
        out = [a[self._ctx:end] for a in b[2:]]
        keep = max(0, end - self.k)
        self._buf, self._ctx = [a[keep:] for a in b], end - keep
        return crs, out


#: a fix farther from the track before it than a car drives at this speed (m/s, the speed limit of
#: :data:`roadbank.io.limits.LIMITS`) ...
JUMP_SPEED = 120.0
#: ... plus this (m, a fix's error in a street canyon) is a jump of the receiver, not of the car
JUMP_SLACK = 50.0
#: fixes that jump together and then stay consistent with each other for this long (s) are the track again
#: (the jump was the track before them: a wrong first fix, a datum changed mid-log)
RELOCK_S = 2.0


def _distance(lat1, lon1, lat2, lon2):
    """Distance (m) between positions (deg) on the sphere (equirectangular about their mean latitude; within 0.1 %
    up to 50 km, and always far above :data:`JUMP_SLACK` for a jump of more than that)."""
    c = np.cos(np.radians(0.5 * (lat1 + lat2)))
    return EARTH_RADIUS * np.hypot(np.radians(lat2 - lat1), c * np.radians(lon2 - lon1))


class PositionJumps:
    """The fixes of a log that jump farther than a car can drive, chunk by chunk (:meth:`add`): a fix more than
    :data:`JUMP_SPEED` times the time since the last fix kept, plus :data:`JUMP_SLACK`, away from it is left out
    (NaN) and counted, unless it and the fixes after it stay consistent with each other for :data:`RELOCK_S`: from
    then on they are the track. A GNSS receiver's glitch (a multipath fix kilometres off, a fix of another
    position) would otherwise put the estimates of those samples into cells the car never drove through."""

    def __init__(self) -> None:
        self.last: tuple | None = None          # (t s, lat deg, lon deg) of the last fix kept
        self.other: tuple | None = None         # the fixes left out since: (t of the first, t, lat, lon) of the last
        self.count = 0
        self.first: tuple | None = None         # (t s, distance m, time s) of the first jump

    def add(self, t, lat_deg, lon_deg) -> tuple[np.ndarray, np.ndarray]:
        """Positions (deg, NaN: no fix) at times ``t`` (s) with the jumps NaN."""
        t, lat, lon = (np.asarray(x, dtype=np.float64) for x in (t, lat_deg, lon_deg))
        idx = np.flatnonzero(np.isfinite(lat) & np.isfinite(lon))
        if not len(idx):
            return lat, lon
        ft, fa, fo = t[idx], lat[idx], lon[idx]
        if self.other is None:        # the usual log: every step within reach, checked at once
            pts = np.column_stack((ft, fa, fo))
            pt, pa, po = (np.vstack(([self.last], pts)) if self.last else pts).T
            with np.errstate(invalid="ignore"):
                ok = _distance(pa[:-1], po[:-1], pa[1:], po[1:]) <= JUMP_SPEED * np.abs(np.diff(pt)) + JUMP_SLACK
            if ok.all():
                self.last = (ft[-1], fa[-1], fo[-1])
                return lat, lon
        keep = np.array([self._one(*x) for x in zip(ft, fa, fo)])
        if keep.all():
            return lat, lon
        gone = idx[~keep]
        lat, lon = lat.copy(), lon.copy()
        lat[gone] = lon[gone] = np.nan
        return lat, lon

    def _one(self, t: float, lat: float, lon: float) -> bool:
        """Whether the fix at ``t`` (s) is kept (sample by sample, where a chunk holds a jump)."""
        if self.last is None or self._near(self.last, t, lat, lon):
            self.last, self.other = (t, lat, lon), None
            return True
        if self.other is not None and self._near(self.other[1:], t, lat, lon):
            if t - self.other[0] >= RELOCK_S:
                self.last, self.other = (t, lat, lon), None
                return True
            self.other = (self.other[0], t, lat, lon)
        else:
            self.other = (t, t, lat, lon)
        self.count += 1
        if self.first is None:
            self.first = (t, float(_distance(self.last[1], self.last[2], lat, lon)), t - self.last[0])
        return False

    @staticmethod
    def _near(fix: tuple, t: float, lat: float, lon: float) -> bool:
        return bool(_distance(fix[1], fix[2], lat, lon) <= JUMP_SPEED * abs(t - fix[0]) + JUMP_SLACK)

    def problem(self) -> str | None:
        """What the jumps left out (``None`` if none), to follow the file and the position channels' names."""
        if self.first is None:
            return None
        t, d, dt = self.first
        return (f"{self.count} fix(es) jump farther than a car can drive ({JUMP_SPEED:g} m/s and {JUMP_SLACK:g} m) "
                f"from the track before them, the first at t = {t:.3f} s ({d / 1000:.3g} km in {dt:.3g} s): a "
                f"receiver's glitch, left out of the map")


#: the distance a log's fixes move over the one its speed drives (-) outside which the positions are refused as in
#: another unit (:class:`TrackScale`; radians declared as degrees move 1/57 as far; the 16 KITTI drives and the
#: comma2k19 segment 0.997-1.011), once the speed has driven :data:`TRACK_MIN_M` (m) between fixes (those drives
#: 246-2207 m)
TRACK_SCALE_RANGE = (0.2, 5.0)
TRACK_MIN_M = 200.0


class TrackScale:
    """The distance a log's fixes move against the one its speed drives between them, chunk by chunk (:meth:`add`):
    a latitude and longitude in radians, or scaled by 1e7 (an integer format), declared as degrees pass every check of
    one position but move 1/57 (or 1e7) times as far as the car."""

    def __init__(self) -> None:
        self.last: tuple | None = None      # (t s, lat deg, lon deg, vx m/s) of the last fix
        self.moved = 0.0                    # m, by the fixes
        self.driven = 0.0                   # m, by the speed (trapezoid) over the same intervals

    def add(self, t, lat_deg, lon_deg, vx) -> None:
        """Fixes (deg, NaN: none) and speed (m/s) at times ``t`` (s); intervals longer than
        :data:`~roadbank.constants.MAX_GAP_S` or with a speed that is not finite are not counted."""
        t, lat, lon, v = (np.asarray(x, dtype=np.float64) for x in (t, lat_deg, lon_deg, vx))
        ok = np.isfinite(lat) & np.isfinite(lon) & np.isfinite(v)
        pts = np.column_stack((t[ok], lat[ok], lon[ok], v[ok]))
        if self.last is not None:
            pts = np.vstack(([self.last], pts))
        if len(pts) < 2:
            self.last = tuple(pts[-1]) if len(pts) else self.last
            return
        pt, pa, po, pv = pts.T
        dt = np.diff(pt)
        use = (dt > 0) & (dt <= MAX_GAP_S)
        self.moved += float(np.sum(_distance(pa[:-1], po[:-1], pa[1:], po[1:])[use]))
        self.driven += float(np.sum((0.5 * np.abs(pv[:-1] + pv[1:]) * dt)[use]))
        self.last = tuple(pts[-1])

    def problem(self) -> str | None:
        """What is wrong with the positions' scale (their channel names go before it), or None: too little driven
        to tell, or within :data:`TRACK_SCALE_RANGE`."""
        if self.driven < TRACK_MIN_M:
            return None
        k = self.moved / self.driven
        if TRACK_SCALE_RANGE[0] <= k <= TRACK_SCALE_RANGE[1]:
            return None
        return (f"the positions move {k:.3g} times as far as the speed drives ({self.moved / 1e3:.3g} km against "
                f"{self.driven / 1e3:.3g} km): not degrees? (radians read as degrees move 1/57 as far)")

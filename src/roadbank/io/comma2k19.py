"""The comma2k19 processed-log layout as a source of raw channels (:class:`SegmentSource`) and its
pose-derived reference roll.

A comma2k19 segment is a directory of NumPy arrays saved without the ``.npy``
suffix (read with ``allow_pickle=False``)::

    processed_log/IMU/accelerometer/{t,value}   specific force, axes [forward, right, down], m/s^2
    processed_log/IMU/gyro/{t,value}            angular rate, axes [forward, right, down], rad/s
    processed_log/CAN/speed/{t,value}           vehicle speed, m/s
    processed_log/CAN/steering_angle/{t,value}  steering-wheel angle, deg
    global_pose/frame_times, frame_positions (ECEF, m), frame_orientations (quaternion w,x,y,z)

The steering angle and the pose are optional (a warning says what a segment read without them loses: the pose is
the reference roll and the positions); pose frames whose position is not on the Earth (no fix) have neither.

Mapping to roadbank (SI, ISO 8855):

* ``ay = -accel[:, 1]``, ``r = -gyro[:, 2]``, roll rate ``p = gyro[:, 0]``, ``ax = accel[:, 0]``
  (forward-right-down -> ISO).
* ``vx`` = CAN speed.
* steering-wheel angle = CAN ``steering_angle`` in deg, **sign kept**: on the
  example segment it correlates positively with the ISO yaw rate (left turn ->
  positive angle, r = +0.70 between the angle and ``r``), i.e. it is already
  ISO-positive. ``delta_f`` = angle / steering ratio.
* ``extra["lat_deg"]``, ``extra["lon_deg"]``: WGS-84 position of the pose (deg),
  for bank maps.
* reference roll (device roll relative to gravity, rad, ISO positive left
  side up): local down (WGS-84 ellipsoid normal at the ECEF position) expressed
  in the camera frame, ``g = R^T down``, ``roll = atan2(g[1], g[2])``.

The source is a set of channels, each on its own clock, stored as they are (the
IMU's forward-right-down axes declared FRD in the layout's channel map,
:func:`channel_map`), with the pose roll as the ``reference_roll`` channel and the
pose position in degrees as carried channels. The assembler
(:mod:`roadbank.io.assemble`) does the rest: units and signs, the time-stamp repair,
plausibility, one uniform 100 Hz grid over the channels' common time span
(:mod:`roadbank.io.resample`; the 20 Hz pose roll and position are linearly
interpolated), the consistency check.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..params import VehicleParams
from .assemble import read_whole
from .channels import ChannelMap, ChannelSpec
from .errors import LogError
from .files import not_found, present
from .geodesy import ecef_to_latlon, ellipsoid_down_ecef
from .timebase import UnrepairableTime, repair_time, stretch_order
from .types import RawChunk

__all__ = ["FILES", "SegmentSource", "channel_map", "ecef_to_latlon", "ellipsoid_down_ecef", "load_comma2k19",
           "pose_roll", "quat_to_matrix"]

FILES = {
    "accelerometer": "processed_log/IMU/accelerometer",
    "gyro": "processed_log/IMU/gyro",
    "speed": "processed_log/CAN/speed",
    "steering_angle": "processed_log/CAN/steering_angle",
}


def _load(path: Path, rel: str, who: str = "") -> np.ndarray:
    """The array of file ``rel`` of segment ``path``; LogError naming the file (after ``who``: the channels it
    carries, :func:`_whose`) where it is missing, unreadable, not one array or not of real numbers."""
    f = path / rel
    if not present(f):
        raise LogError(f"{path}: {who}comma2k19 file '{rel}' is missing")
    try:
        arr = np.load(f, allow_pickle=False)
    except Exception as exc:  # truncated / not an npy array / a folder / no permission
        raise LogError(f"{path}: {who}comma2k19 file '{rel}' is unreadable ({exc})") from None
    if not isinstance(arr, np.ndarray):             # an .npz archive loads as one, lazily
        raise LogError(f"{path}: {who}comma2k19 file '{rel}' is not one array (.npy) but {type(arr).__name__} (an "
                       ".npz archive?)")
    if arr.dtype.kind not in "biuf":                # complex, text, dates: not a measured quantity
        raise LogError(f"{path}: {who}comma2k19 file '{rel}' holds {arr.dtype} values, not real numbers")
    return arr


def _whose(roles) -> str:
    """How a message names the channels a file carries: ``"channel 'speed': "``, ``"channels 'a', 'b': "``."""
    roles = list(roles)
    return f"channel{'s' if len(roles) > 1 else ''} {', '.join(repr(r) for r in roles)}: " if roles else ""


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) from quaternions [w, x, y, z] (Hamilton; normalised first)."""
    q = np.asarray(q, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):        # a zero quaternion gives NaN: no roll there
        q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    R = np.empty((len(q), 3, 3))
    R[:, 0, 0] = 1 - 2 * (y * y + z * z)
    R[:, 0, 1] = 2 * (x * y - w * z)
    R[:, 0, 2] = 2 * (x * z + w * y)
    R[:, 1, 0] = 2 * (x * y + w * z)
    R[:, 1, 1] = 1 - 2 * (x * x + z * z)
    R[:, 1, 2] = 2 * (y * z - w * x)
    R[:, 2, 0] = 2 * (x * z - w * y)
    R[:, 2, 1] = 2 * (y * z + w * x)
    R[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def pose_roll(pos_ecef: np.ndarray, quat_wxyz: np.ndarray) -> np.ndarray:
    """Device roll relative to gravity (rad, ISO: left side up) from the comma2k19 global pose.

    ``g = R^T down`` (down in the camera frame, whose axes are forward, right,
    down), ``roll = atan2(g[1], g[2])``.
    """
    R = quat_to_matrix(quat_wxyz)
    down = ellipsoid_down_ecef(pos_ecef)
    g = np.einsum("nji,nj->ni", R, down)
    return np.arctan2(g[:, 1], g[:, 2])


#: what a segment read without its steering angle loses (the rest of the warning)
OPTIONAL_FILES = {"steering_angle": "the steering angle is NaN (the default estimator and the modified-model "
                                    "filters do not read it, the original-model ones, uio, dfc and kalman give no "
                                    "valid sample)"}
#: the pose's folder, and what a segment read without it (or without a fix) loses
POSE = "global_pose"
POSE_LOSS = ("no reference roll (the estimate is not scored) and no positions (roadbank map has nothing to place "
             "it at)")
#: distances (m) from the Earth's centre of a position on the ground: the WGS-84 polar radius less 1 km to its
#: equatorial radius plus 10 km
EARTH_RADII_M = (6_356_752.0 - 1_000.0, 6_378_137.0 + 10_000.0)

#: the channels of a segment: role -> (column, stored unit, axis convention)
CHANNELS = {
    "speed": ("processed_log/CAN/speed", "m/s", "ISO"),
    "lateral_acceleration": ("processed_log/IMU/accelerometer[1]", "m/s^2", "FRD"),
    "yaw_rate": ("processed_log/IMU/gyro[2]", "rad/s", "FRD"),
    "roll_rate": ("processed_log/IMU/gyro[0]", "rad/s", "FRD"),
    "longitudinal_acceleration": ("processed_log/IMU/accelerometer[0]", "m/s^2", "FRD"),
    "pitch_rate": ("processed_log/IMU/gyro[1]", "rad/s", "FRD"),
    "steering_wheel_angle": ("processed_log/CAN/steering_angle", "deg", "ISO"),   # left already positive
    "reference_roll": ("global_pose (roll)", "rad", "ISO"),
}


#: the roles each file of :data:`FILES` carries (for messages)
FILE_ROLES = {key: [r for r, (c, _, _) in CHANNELS.items() if c.split("[")[0] == rel] for key, rel in FILES.items()}
#: the files whose value is one number per time stamp (the others: the IMU's three axes)
SCALAR_FILES = ("speed", "steering_angle")


def channel_map(rate_hz: float = 100.0, max_gap_s: float = 0.5, roles=tuple(CHANNELS)) -> ChannelMap:
    """The fixed channel map of a comma2k19 segment: stored units and axes, a uniform grid at ``rate_hz``
    (Hz), gaps longer than ``max_gap_s`` (s) not bridged; the steering ratio is the car's. ``roles``: those of
    :data:`CHANNELS` the segment has (a segment without steering or pose has neither in its map)."""
    ch = {"time": ChannelSpec("time", "t", "s")}      # (each channel has its own clock: not read)
    for role in roles:
        col, unit, conv = CHANNELS[role]
        ch[role] = ChannelSpec(role, col, unit, conv)
    return ChannelMap(ch, time_base="uniform", rate_hz=rate_hz, max_gap_s=max_gap_s,
                      source="comma2k19 processed-log layout", fixed_layout=True,
                      no_steering="steering_wheel_angle" not in roles)


class SegmentSource:
    """One comma2k19 segment as a channel source (:mod:`roadbank.io.sources`), read whole: the channels
    of :data:`CHANNELS` (stored values, each with its own time stamps, s) and the pose position as
    ``lat_deg`` / ``lon_deg`` (deg, carried into ``Log.extra``). Opening it reads every array: LogError naming
    the file, its channels and the problem for a required one (speed, IMU) missing, unreadable or of the wrong
    shape; an optional one (steering angle, pose) so broken is read as missing, with a warning saying why.
    Stretches of rows written out of their place are sorted back into time order, with a warning
    (:func:`~roadbank.io.timebase.stretch_order`)."""

    shared_clock = False
    whole = True
    row_label = "sample"
    time_typed: dict[str, str] = {}      # NumPy arrays of seconds: no column's type carries a time unit
    units: dict[str, str] = {}           # the data set's units are its reader's

    def __init__(self, path, params: VehicleParams | None = None, rate_hz: float = 100.0,
                 max_gap_s: float = 0.5):
        p = Path(path)
        if not present(p):
            raise not_found(p)
        if not p.is_dir() or not (p / "processed_log").is_dir():
            raise LogError(f"{p}: not a comma2k19 segment (a folder holding processed_log/ and global_pose/)")
        params = params or VehicleParams()
        arr = {}
        self.warnings: list[str] = []
        for key, rel in FILES.items():
            if key in OPTIONAL_FILES and not present(p / rel):
                self.warnings.append(f"{p}: comma2k19 '{rel}' is missing, so the log is read without it: "
                                     f"{OPTIONAL_FILES[key]}")
                continue
            try:
                arr[key] = self._timed(p, key, rel)
            except LogError as exc:
                if key not in OPTIONAL_FILES:
                    raise
                self.warnings.append(f"{exc}, so the log is read without it: {OPTIONAL_FILES[key]}")
        acc_t, acc = arr["accelerometer"]
        gyr_t, gyr = arr["gyro"]
        col = {role: c for role, (c, _, _) in CHANNELS.items()}
        series = {
            col["speed"]: (arr["speed"][0], arr["speed"][1][:, 0]),
            col["lateral_acceleration"]: (acc_t, acc[:, 1]),
            col["yaw_rate"]: (gyr_t, gyr[:, 2]),
            col["roll_rate"]: (gyr_t, gyr[:, 0]),
            col["longitudinal_acceleration"]: (acc_t, acc[:, 0]),
            col["pitch_rate"]: (gyr_t, gyr[:, 1]),
        }
        if "steering_angle" in arr:
            series[col["steering_wheel_angle"]] = (arr["steering_angle"][0], arr["steering_angle"][1][:, 0])
        pose = self._pose(p)
        if pose is not None:
            ft, pos, quat = pose
            lat, lon = ecef_to_latlon(pos)
            series.update({col["reference_roll"]: (ft, pose_roll(pos, quat)),
                           "lat_deg": (ft, np.degrees(lat)), "lon_deg": (ft, np.degrees(lon))})
        self.path = p
        self.times = {c: t for c, (t, _) in series.items()}
        self.data = {c: v for c, (_, v) in series.items()}
        self.names = list(series)
        self.channel_map = channel_map(rate_hz, max_gap_s, [r for r, (c, _, _) in CHANNELS.items() if c in series])
        self.carried = {"lat_deg": max_gap_s, "lon_deg": max_gap_s} if pose is not None else {}
        self.metadata = {"dataset": "comma2k19", "steering_ratio": str(params.steering_ratio),
                         "time_origin": "boot time (s)"}

    def _timed(self, p: Path, key: str, rel: str) -> tuple[np.ndarray, np.ndarray]:
        """File ``rel`` (``key`` of :data:`FILES`) as ``(t (s), values (n, k))``: its rows in time order where
        stretches of them were written out of their place (:meth:`_in_order`). LogError naming the file, the
        channels it carries and the problem for parts missing or unreadable, no samples, lengths or shapes that
        do not match, and (an optional file, which is then read as missing) time stamps that cannot be
        repaired."""
        who = _whose(FILE_ROLES[key])
        t = np.asarray(_load(p, rel + "/t", who), dtype=np.float64).reshape(-1)
        v = np.asarray(_load(p, rel + "/value", who), dtype=np.float64)
        shape = v.shape
        head = f"{p}: {who}comma2k19 '{rel}"
        if v.ndim == 1:
            v = v[:, None]
        if v.ndim != 2:
            raise LogError(f"{head}/value': an array of shape {shape}, not one row of values per time stamp")
        if len(t) == 0 and len(v) == 0:
            raise LogError(f"{head}': no samples (t and value are empty)")
        if len(t) != len(v):
            raise LogError(f"{head}': {len(t)} time stamps (t) but {len(v)} values (value)")
        if key not in SCALAR_FILES and v.shape[1] != 3:
            raise LogError(f"{head}/value': IMU array of shape {shape}, need (n, 3) (forward, right, down)")
        if key in SCALAR_FILES and v.shape[1] != 1:
            raise LogError(f"{head}/value': an array of shape {shape}, need (n,) or (n, 1): one value per time "
                           "stamp")
        t, (v,) = self._in_order(p, who, rel, t, [v])
        if key in OPTIONAL_FILES:
            _repairable(head + "/t'", t)
        return t, v

    def _in_order(self, p: Path, who: str, rel: str, t: np.ndarray,
                  values: list[np.ndarray]) -> tuple[np.ndarray, list[np.ndarray]]:
        """Stamps ``t`` (s) and the arrays of ``values`` (row for row) with stretches of rows written out of their
        place sorted back into time order (:func:`~roadbank.io.timebase.stretch_order`: never two parts of the
        clock mixed), said once in :attr:`warnings`; as they are otherwise."""
        found = stretch_order(t)
        if found is None:
            return t, values
        order, moved = found
        out = order != np.arange(len(t))
        span = t[out][np.isfinite(t[out])]
        self.warnings.append(f"{p}: {who}comma2k19 '{rel}': {moved} of {len(t)} rows out of time order (stretches "
                             f"of rows written out of their place, from {span.min():.3f} to {span.max():.3f} s, "
                             "none overlapping another in time): sorted by time, each row's values with its "
                             "stamp")
        return t[order], [a[order] for a in values]

    def _pose(self, p: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The segment's pose frames ``(times (s), ECEF positions (m), quaternions w, x, y, z)``, the positions NaN
        where they are not on the Earth (:data:`EARTH_RADII_M`: no fix); None, with a warning, where ``global_pose/``
        is missing, broken (a file missing or unreadable, arrays of inconsistent shapes, frame times that cannot be
        repaired: read as missing, the warning naming the file and the problem) or has no frame on the Earth."""
        if not present(p / POSE):
            self.warnings.append(f"{p}: comma2k19 '{POSE}' is missing, so the log is read without it: {POSE_LOSS}")
            return None
        try:
            ft, pos, quat = self._pose_arrays(p)
        except LogError as exc:
            self.warnings.append(f"{exc}, so the log is read without the pose: {POSE_LOSS}")
            return None
        radius = np.linalg.norm(pos, axis=1)
        on_earth = (radius >= EARTH_RADII_M[0]) & (radius <= EARTH_RADII_M[1])
        if not on_earth.any():
            self.warnings.append(f"{p}: comma2k19 '{POSE}/frame_positions': no frame of the {len(pos)} is on the "
                                 f"Earth (distance from its centre {EARTH_RADII_M[0] / 1e3:.0f}-"
                                 f"{EARTH_RADII_M[1] / 1e3:.0f} km: a pose without a fix), so the log is read "
                                 f"without the pose: {POSE_LOSS}")
            return None
        if not on_earth.all():
            self.warnings.append(f"{p}: comma2k19 '{POSE}/frame_positions': {np.count_nonzero(~on_earth)} of the "
                                 f"{len(pos)} frames are not on the Earth (no fix): no reference roll or position "
                                 "there")
        return ft, np.where(on_earth[:, None], pos, np.nan), quat

    def _pose_arrays(self, p: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``global_pose/``'s frame times (s), ECEF positions (m) and quaternions, in time order
        (:meth:`_in_order`); LogError naming the file and the problem where one is missing or unreadable, their
        shapes do not match or the frame times cannot be repaired."""
        who = _whose(["reference_roll"])
        ft = np.asarray(_load(p, f"{POSE}/frame_times", who), dtype=np.float64).reshape(-1)
        pos = np.asarray(_load(p, f"{POSE}/frame_positions", who), dtype=np.float64)
        quat = np.asarray(_load(p, f"{POSE}/frame_orientations", who), dtype=np.float64)
        if not (len(ft) == len(pos) == len(quat)) or pos.shape[1:] != (3,) or quat.shape[1:] != (4,):
            raise LogError(f"{p}: {who}comma2k19 {POSE} arrays have inconsistent shapes (frame_times "
                           f"{ft.shape}, frame_positions {pos.shape}, frame_orientations {quat.shape}; need (n,), "
                           "(n, 3), (n, 4))")
        ft, (pos, quat) = self._in_order(p, who, POSE, ft, [pos, quat])
        _repairable(f"{p}: {who}comma2k19 '{POSE}/frame_times'", ft)
        return ft, pos, quat

    def close(self) -> None:
        """Nothing to close: the arrays were read when the source was opened."""

    def chunks(self, wanted: dict[str, str] | None = None, prefix: str | None = None) -> Iterator[RawChunk]:
        """The one chunk: every channel whole, with its time stamps (``wanted`` and ``prefix`` are not
        used: the layout is fixed)."""
        yield RawChunk(dict(self.data), times=dict(self.times), done=tuple(self.data))


def _repairable(head: str, t: np.ndarray) -> None:
    """LogError ``<head>: <why>`` where the stamps ``t`` (s) hold no increasing time base
    (:func:`~roadbank.io.timebase.repair_time`): an optional file is then read as missing. A check only: the stamps
    are left as they are and nothing is counted; the assembler repairs and counts them, once."""
    try:
        repair_time(t)
    except UnrepairableTime as exc:
        raise LogError(f"{head}: {exc}") from None


def load_comma2k19(path, params: VehicleParams | None = None, rate_hz: float = 100.0,
                   max_gap_s: float = 0.5):
    """Read a comma2k19 segment directory into a :class:`~roadbank.io.Log` with ``reference_roll``.

    Parameters
    ----------
    path : path-like
        Segment directory (containing ``processed_log/`` and ``global_pose/``).
    params : VehicleParams, optional
        Its ``steering_ratio`` converts the steering-wheel angle (the car is not
        identified in the dataset; choose a ratio, see docs/real-data.md).
    rate_hz : float
        Rate of the common uniform time base (default 100 Hz).
    max_gap_s : float
        A gap in a channel longer than this (s) becomes NaN, never bridged.

    Returns
    -------
    Log
        ``signals``: t (s, boot time), vx (m/s), ay (m/s^2), r (rad/s), delta_f (rad) on the grid;
        ``reference_roll`` (rad, ISO: left side up); ``extra``: ``lat_deg``, ``lon_deg`` (deg).

    Raises
    ------
    LogError
        A file missing, unreadable or of the wrong shape, time stamps that cannot be repaired, or
        values implausible in their unit.
    """
    params = params or VehicleParams()
    src = SegmentSource(path, params, rate_hz, max_gap_s)
    return read_whole(src, src.channel_map, params, "comma2k19")

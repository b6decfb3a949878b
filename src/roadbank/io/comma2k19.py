"""The comma2k19 processed-log layout and its pose-derived reference roll.

A comma2k19 segment is a directory of NumPy arrays saved without the ``.npy``
suffix (read with ``allow_pickle=False``)::

    processed_log/IMU/accelerometer/{t,value}   specific force, axes [forward, right, down], m/s^2
    processed_log/IMU/gyro/{t,value}            angular rate, axes [forward, right, down], rad/s
    processed_log/CAN/speed/{t,value}           vehicle speed, m/s
    processed_log/CAN/steering_angle/{t,value}  steering-wheel angle, deg
    global_pose/frame_times, frame_positions (ECEF, m), frame_orientations (quaternion w,x,y,z)

Mapping to roadbank (SI, ISO 8855):

* ``ay = -accel[:, 1]``, ``r = -gyro[:, 2]`` (forward-right-down -> ISO).
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

All channels go onto one uniform 100 Hz grid over their common time span
(:mod:`roadbank.io.resample`); the 20 Hz pose roll is linearly interpolated.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..params import VehicleParams
from ..signals import Signals
from .errors import LogError
from .resample import common_time_base, interpolate, resample
from .types import Log

# WGS-84
_A = 6378137.0
_F = 1.0 / 298.257223563
_E2 = _F * (2.0 - _F)

FILES = {
    "accelerometer": "processed_log/IMU/accelerometer",
    "gyro": "processed_log/IMU/gyro",
    "speed": "processed_log/CAN/speed",
    "steering_angle": "processed_log/CAN/steering_angle",
}


def _load(path: Path, rel: str) -> np.ndarray:
    f = path / rel
    if not f.exists():
        raise LogError(f"{path}: comma2k19 file '{rel}' is missing")
    try:
        return np.load(f, allow_pickle=False)
    except Exception as exc:  # truncated / not an npy array
        raise LogError(f"{path}: comma2k19 file '{rel}' is unreadable ({exc})") from None


def ecef_to_latlon(pos_ecef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Geodetic WGS-84 latitude and longitude (rad) of ECEF positions (n, 3) in m."""
    x, y, z = np.asarray(pos_ecef, dtype=np.float64).T
    lon = np.arctan2(y, x)
    p = np.hypot(x, y)
    # Bowring's closed form for the geodetic latitude (sub-mm at the Earth's surface)
    b = _A * (1.0 - _F)
    ep2 = (_A ** 2 - b ** 2) / b ** 2
    th = np.arctan2(z * _A, p * b)
    lat = np.arctan2(z + ep2 * b * np.sin(th) ** 3, p - _E2 * _A * np.cos(th) ** 3)
    return lat, lon


def ellipsoid_down_ecef(pos_ecef: np.ndarray) -> np.ndarray:
    """Unit vector along the downward WGS-84 ellipsoid normal at ECEF positions (n, 3), m -> (n, 3)."""
    lat, lon = ecef_to_latlon(pos_ecef)
    up = np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=1)
    return -up


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) from quaternions [w, x, y, z] (Hamilton; normalised first)."""
    q = np.asarray(q, dtype=np.float64)
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
    """
    p = Path(path)
    if not p.is_dir():
        raise LogError(f"{p}: not a comma2k19 segment directory")
    params = params or VehicleParams()
    arr = {}
    for key, rel in FILES.items():
        t = np.asarray(_load(p, rel + "/t"), dtype=np.float64).reshape(-1)
        v = np.asarray(_load(p, rel + "/value"), dtype=np.float64)
        if v.ndim == 1:
            v = v[:, None]
        if len(t) != len(v) or len(t) == 0:
            raise LogError(f"{p}: comma2k19 '{rel}': {len(t)} time stamps but {len(v)} values")
        arr[key] = (t, v)
    acc_t, acc = arr["accelerometer"]
    gyr_t, gyr = arr["gyro"]
    if acc.shape[1] != 3 or gyr.shape[1] != 3:
        raise LogError(f"{p}: comma2k19 IMU arrays must have 3 columns")
    series = {
        "speed": (arr["speed"][0], arr["speed"][1][:, 0]),
        "lateral_acceleration": (acc_t, -acc[:, 1]),
        "yaw_rate": (gyr_t, -gyr[:, 2]),
        "steering_wheel_angle": (arr["steering_angle"][0], np.radians(arr["steering_angle"][1][:, 0])),
    }
    ft = np.asarray(_load(p, "global_pose/frame_times"), dtype=np.float64).reshape(-1)
    pos = np.asarray(_load(p, "global_pose/frame_positions"), dtype=np.float64)
    quat = np.asarray(_load(p, "global_pose/frame_orientations"), dtype=np.float64)
    if not (len(ft) == len(pos) == len(quat)) or pos.shape[1:] != (3,) or quat.shape[1:] != (4,):
        raise LogError(f"{p}: comma2k19 global_pose arrays have inconsistent shapes "
                       f"{ft.shape}, {pos.shape}, {quat.shape}")
    series["reference_roll"] = (ft, pose_roll(pos, quat))
    lat, lon = ecef_to_latlon(pos)
    for name, (t, _) in series.items():
        if np.any(np.diff(t) < 0):
            raise LogError(f"{p}: comma2k19 channel '{name}': time goes backwards")
    try:
        t_base = common_time_base(series, "uniform", rate_hz)
        vals = resample(series, t_base, max_gap_s)
    except LogError as exc:
        raise LogError(f"{p}: {exc}") from None
    sig = Signals(t_base, vals["speed"], vals["lateral_acceleration"], vals["yaw_rate"],
                  vals["steering_wheel_angle"] / params.steering_ratio)
    meta = {"dataset": "comma2k19", "steering_ratio": str(params.steering_ratio),
            "time_origin": "boot time (s)"}
    # GNSS position for bank maps (the pose positions, 20 Hz), deg, on the same grid
    extra = {"lat_deg": interpolate(ft, np.degrees(lat), t_base, max_gap_s),
             "lon_deg": interpolate(ft, np.degrees(lon), t_base, max_gap_s)}
    return Log(signals=sig, reference_roll=vals["reference_roll"], source=p, format="comma2k19",
               metadata=meta, extra=extra)

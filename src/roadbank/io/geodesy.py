"""WGS-84 geodesy for position channels: ECEF position (m) -> geodetic latitude / longitude (rad), and
the local downward ellipsoid normal."""

from __future__ import annotations

import numpy as np

#: WGS-84 semi-major axis (m) and flattening
A = 6378137.0
F = 1.0 / 298.257223563
_E2 = F * (2.0 - F)


def ecef_to_latlon(pos_ecef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Geodetic WGS-84 latitude and longitude (rad) of ECEF positions (n, 3) in m."""
    x, y, z = np.asarray(pos_ecef, dtype=np.float64).T
    lon = np.arctan2(y, x)
    p = np.hypot(x, y)
    # Bowring's closed form for the geodetic latitude (sub-mm at the Earth's surface)
    b = A * (1.0 - F)
    ep2 = (A ** 2 - b ** 2) / b ** 2
    th = np.arctan2(z * A, p * b)
    lat = np.arctan2(z + ep2 * b * np.sin(th) ** 3, p - _E2 * A * np.cos(th) ** 3)
    return lat, lon


def ellipsoid_down_ecef(pos_ecef: np.ndarray) -> np.ndarray:
    """Unit vector along the downward WGS-84 ellipsoid normal at ECEF positions (n, 3), m -> (n, 3)."""
    lat, lon = ecef_to_latlon(pos_ecef)
    up = np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=1)
    return -up

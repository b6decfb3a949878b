"""Put a log on a uniform grid, split it into runs of usable driving and low-pass filter them.

The regressions of the identification are linear with constant coefficients,
so a zero-phase linear filter applied to both sides keeps them exact; it
removes the sensor noise and quantisation above the bandwidth of the vehicle
response before the yaw acceleration is differentiated from the yaw rate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, sosfiltfilt


@dataclass(frozen=True)
class Grid:
    """Signals of one log on a uniform time grid (SI, ISO 8855; NaN in gaps).

    ``t`` (s), ``vx`` (m/s), ``ay`` (m/s^2), ``r`` (rad/s), ``delta`` (rad,
    road-wheel angle), ``roll`` (rad, reference roll, or None), ``fs`` (Hz).
    """

    t: np.ndarray
    vx: np.ndarray
    ay: np.ndarray
    r: np.ndarray
    delta: np.ndarray
    roll: np.ndarray | None
    fs: float


def fill_short_gaps(x: np.ndarray, max_len: int) -> np.ndarray:
    """``x`` with NaN stretches of at most ``max_len`` samples between finite samples linearly interpolated
    (sporadic dropouts would otherwise cut a log into pieces too short to use)."""
    x = np.asarray(x, dtype=float).copy()
    bad = ~np.isfinite(x)
    if not bad.any() or bad.all():
        return x
    idx = np.arange(len(x))
    fill = np.zeros(len(x), dtype=bool)
    for a, b in runs(bad):
        if a > 0 and b < len(x) and b - a <= max_len:
            fill[a:b] = True
    x[fill] = np.interp(idx[fill], idx[~bad], x[~bad])
    return x


def to_grid(t, vx, ay, r, delta, roll=None, max_gap: float = 0.5, max_fill: float = 0.1) -> Grid:
    """Resample channels onto a uniform grid at the log's median sample rate.

    Parameters
    ----------
    t : array (s), strictly increasing
    vx, ay, r, delta : arrays (m/s, m/s^2, rad/s, rad); NaN marks missing samples
    roll : array (rad) or None
    max_gap : float
        Samples further than this (s) from a valid sample of a channel become NaN.
    max_fill : float
        Gaps (NaN) up to this long (s) are linearly interpolated (dropped CAN frames).

    Returns
    -------
    Grid
    """
    t = np.asarray(t, dtype=float)
    if len(t) < 2:
        raise ValueError("fewer than 2 samples")
    dt = float(np.median(np.diff(t)))
    chans = {"vx": vx, "ay": ay, "r": r, "delta": delta}
    if roll is not None:
        chans["roll"] = roll
    if np.allclose(np.diff(t), dt, rtol=1e-3, atol=1e-9):
        out = {k: np.asarray(v, dtype=float) for k, v in chans.items()}
        tg = t
    else:
        tg = t[0] + dt * np.arange(int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1)
        out = {}
        for k, v in chans.items():
            v = np.asarray(v, dtype=float)
            ok = np.isfinite(v)
            tv, vv = t[ok], v[ok]
            if len(tv) < 2:
                out[k] = np.full(len(tg), np.nan)
                continue
            y = np.interp(tg, tv, vv)
            i = np.clip(np.searchsorted(tv, tg), 1, len(tv) - 1)
            gap = tv[i] - tv[i - 1]
            y[(gap > max_gap) | (tg < tv[0]) | (tg > tv[-1])] = np.nan
            out[k] = y
    n_fill = int(round(max_fill / dt))
    out = {k: fill_short_gaps(v, n_fill) for k, v in out.items()}
    return Grid(tg, out["vx"], out["ay"], out["r"], out["delta"], out.get("roll"), 1.0 / dt)


def runs(mask: np.ndarray, min_len: int = 1) -> list[tuple[int, int]]:
    """``[(start, stop), ...]`` of the contiguous True stretches of ``mask`` at least ``min_len`` long."""
    m = np.concatenate(([False], np.asarray(mask, dtype=bool), [False]))
    d = np.diff(m.astype(np.int8))
    starts, stops = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return [(int(a), int(b)) for a, b in zip(starts, stops) if b - a >= min_len]


def lowpass(x: np.ndarray, fs: float, fc: float) -> np.ndarray:
    """Zero-phase 2nd-order Butterworth low-pass (run forward and backward) at ``fc`` (Hz)."""
    if fc >= 0.45 * fs:
        return np.asarray(x, dtype=float).copy()
    sos = butter(2, fc, fs=fs, output="sos")
    padlen = min(len(x) - 1, int(3 * fs / fc))
    return sosfiltfilt(sos, x, padlen=padlen)


def derivative(x: np.ndarray, fs: float) -> np.ndarray:
    """Central-difference time derivative of a (filtered) uniformly sampled signal (units/s)."""
    return np.gradient(x) * fs if len(x) > 1 else np.zeros_like(x)

"""Put channels sampled on different clocks onto one time base.

Rules (also in docs/io.md):

* Each channel is a series of (time, value) samples; samples whose value is
  not finite are dropped before interpolation (they are gaps).
* The **time base** is chosen by ``time_base``:

  - ``"auto"`` (default): if every channel comes from one table clock and is
    sampled at that clock's rate (its median period between valid samples equals the
    clock's), that clock is used as it is -- no interpolation, NaN samples
    stay NaN (dropouts the estimators skip). Otherwise as ``"uniform"``.
  - ``"uniform"``: a uniform grid at ``rate_hz`` (default 100 Hz) starting at
    the latest first sample of all channels and ending at or before the
    earliest last sample -- the overlap of all channels.
  - a role name (e.g. ``"lateral_acceleration"``): that channel's own valid
    sample times inside the overlap.

* Values are linearly interpolated onto the base. Nothing is extrapolated:
  the base never leaves the overlap. Where the two valid samples bracketing a
  base time are more than ``max_gap_s`` (default 0.5 s) apart, the result is
  NaN rather than a line drawn across the gap.
"""

from __future__ import annotations

import numpy as np

from .errors import LogError


def clean_series(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Valid samples of one channel: finite time and value, duplicate time stamps removed (first kept).

    The time stamps must already be non-decreasing.
    """
    t = np.asarray(t, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    ok = np.isfinite(t) & np.isfinite(v)
    t, v = t[ok], v[ok]
    if len(t) > 1:
        keep = np.concatenate(([True], np.diff(t) > 0))
        t, v = t[keep], v[keep]
    return t, v


def overlap(series: dict[str, tuple[np.ndarray, np.ndarray]]) -> tuple[float, float]:
    """(start, end) of the time span covered by every channel's valid samples.

    Raises
    ------
    LogError
        If a channel has no valid sample or the channels do not overlap.
    """
    starts, ends = {}, {}
    for name, (t, v) in series.items():
        tc, _ = clean_series(t, v)
        if len(tc) == 0:
            raise LogError(f"channel '{name}': no valid (finite) samples")
        starts[name], ends[name] = tc[0], tc[-1]
    t0, t1 = max(starts.values()), min(ends.values())
    if not t1 > t0:
        late = max(starts, key=starts.get)
        early = min(ends, key=ends.get)
        raise LogError(f"channels do not overlap in time: '{late}' starts at {starts[late]:.3f} s "
                       f"but '{early}' ends at {ends[early]:.3f} s")
    return float(t0), float(t1)


def uniform_grid(t0: float, t1: float, rate_hz: float) -> np.ndarray:
    """Uniform grid t0, t0 + 1/rate, ... not beyond t1 (tolerance 1e-9 s)."""
    n = int(np.floor((t1 - t0) * rate_hz + 1e-9)) + 1
    return t0 + np.arange(n) / rate_hz


def interpolate(t: np.ndarray, v: np.ndarray, t_new: np.ndarray, max_gap_s: float) -> np.ndarray:
    """Linear interpolation of one channel onto ``t_new``; NaN outside its span and across long gaps."""
    tc, vc = clean_series(t, v)
    out = np.full(len(t_new), np.nan)
    if len(tc) == 0:
        return out
    inside = (t_new >= tc[0]) & (t_new <= tc[-1])
    if len(tc) == 1:
        out[t_new == tc[0]] = vc[0]
        return out
    out[inside] = np.interp(t_new[inside], tc, vc)
    if not (np.diff(tc) > max_gap_s).any():       # no gap anywhere: the rule below changes nothing
        return out
    # gap rule: bracketing valid samples more than max_gap_s apart -> NaN (exact hits excepted)
    right = np.searchsorted(tc, t_new, side="right")
    idx = np.clip(right, 1, len(tc) - 1)
    gap = tc[idx] - tc[idx - 1]
    exact = tc[np.maximum(right - 1, 0)] == t_new     # the last sample at or before t_new is t_new
    out[(gap > max_gap_s) & ~exact] = np.nan
    return out


def _median_period(t: np.ndarray) -> float:
    d = np.diff(t)
    return float(np.median(d)) if len(d) else np.inf


def common_time_base(series: dict[str, tuple[np.ndarray, np.ndarray]], time_base: str = "auto",
                     rate_hz: float = 100.0, shared_clock: np.ndarray | None = None) -> np.ndarray:
    """Choose the time base (s) for ``series`` (role -> (t, values)); see the module doc.

    Parameters
    ----------
    shared_clock : array, optional
        The table's own time column when all channels come from one table; it
        is the candidate for ``"auto"``.
    """
    t0, t1 = overlap(series)
    if time_base == "auto":
        if shared_clock is not None and len(shared_clock) > 1:
            base = _median_period(shared_clock)
            same_rate = all(abs(_median_period(clean_series(t, v)[0]) - base) <= 0.01 * base
                            for t, v in series.values())
            if same_rate:
                return np.asarray(shared_clock, dtype=np.float64)
        time_base = "uniform"
    if time_base == "uniform":
        return uniform_grid(t0, t1, rate_hz)
    if time_base not in series:
        raise LogError(f"resample.time_base '{time_base}' is not one of the log's channels "
                       f"({', '.join(series)})")
    tc, _ = clean_series(*series[time_base])
    return tc[(tc >= t0) & (tc <= t1)]


def resample(series: dict[str, tuple[np.ndarray, np.ndarray]], t_base: np.ndarray,
             max_gap_s: float = 0.5, shared_clock: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Every channel on ``t_base``. If ``t_base`` is ``shared_clock`` the values are taken as they are."""
    if shared_clock is not None and t_base is shared_clock:
        return {k: np.asarray(v, dtype=np.float64) for k, (_, v) in series.items()}
    return {k: interpolate(t, v, t_base, max_gap_s) for k, (t, v) in series.items()}

"""Input signals and estimation results: the data containers of roadbank.

Everything is SI and ISO 8855 (x forward, y left, z up; yaw rate positive
turning left; ``ay`` positive to the left; roll and bank positive left side up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .constants import MAX_GAP_S
from .params import VehicleParams

CHANNELS = ("t", "vx", "ay", "r", "delta_f")
#: optional channels: present in a log that has them, None otherwise
OPTIONAL_CHANNELS = ("p", "ax", "q")


def _as_1d(name: str, a) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"Signals.{name}: not numeric ({exc})") from None
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ValueError(f"Signals.{name}: expected a 1-D array, got shape {arr.shape}")
    return arr


@dataclass(frozen=True)
class Signals:
    """ESP signals of one log, validated.

    Parameters
    ----------
    t : array (s)
        Sample times, finite and strictly increasing.
    vx : array (m/s)
        Longitudinal speed.
    ay : array (m/s^2)
        Measured lateral acceleration (specific force), positive to the left.
    r : array (rad/s)
        Yaw rate, positive turning left.
    delta_f : array (rad) or None
        Front road-wheel angle, positive to the left. Use
        :meth:`from_steering_wheel` when the log holds the steering-wheel angle. None: the log has none (NaN
        throughout, as a KITTI drive is read; the default estimator does not read it).
    p : array (rad/s), optional
        Roll rate (rotation about the forward axis, positive left side up), when the log has a
        roll-rate gyro (an INS, a phone, a six-axis IMU); None for an ESP log without one. Only
        the estimators of :data:`roadbank.estimators.GYRO` read it.
    ax : array (m/s^2), optional
        Measured longitudinal acceleration (specific force, positive forward: ``vx' - g sin(pitch)`` with the
        pitch positive nose down), when the log has one; None otherwise. The gyro-aided estimators read the
        road's grade from it (:mod:`roadbank.models.attitude`).
    q : array (rad/s), optional
        Pitch rate (rotation about the left axis, positive nose down), when the log has a pitch-rate gyro; None
        otherwise. With ``ax``, the gyro-aided estimators read the pitch from both (:mod:`roadbank.estimators.pitch`).

    fixed : frozenset of str, optional
        The optional channels (``"p"``, ``"ax"``, ``"q"``) whose axis, sign and unit the log's format itself documents
        (the readers of KITTI's OXTS files and of comma2k19 set it; a user's channel map does not): the design takes
        them as they are, without the checks that guard a map's channels (:func:`roadbank.vehicle.log_conditions`).
        Only channels the log carries stay in it (``dataclasses.replace(s, p=None)`` drops ``"p"``); slices keep
        it; :func:`concat_signals` keeps what every part has.
    unbiased : frozenset of str, optional
        The optional channels whose source documents them as free of offset: an INS's outputs, corrected by its
        own Kalman filter (the reader of KITTI's OXTS files sets it: its RT3003 applies its gyro and accelerometer
        bias corrections to what it outputs); a phone's raw gyro or a user's channel map does not. The gyro-aided
        default reads such a roll rate with its own constants
        (:data:`roadbank.estimators.gyro.UNBIASED_GYRO_CUTOFF_HZ`). Kept, dropped, sliced and joined as ``fixed``.

    NaN / inf samples in ``vx, ay, r, delta_f, p, ax, q`` are allowed: the estimators hold
    their output there and flag it not valid. The time base itself must be clean.
    """

    t: np.ndarray
    vx: np.ndarray
    ay: np.ndarray
    r: np.ndarray
    delta_f: np.ndarray
    p: np.ndarray | None = None
    ax: np.ndarray | None = None
    q: np.ndarray | None = None
    fixed: frozenset[str] = frozenset()
    unbiased: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        if self.delta_f is None:        # a log without a steering angle (a KITTI drive's): NaN, as its readers give
            object.__setattr__(self, "delta_f", np.full(np.size(self.t), math.nan))
        arrays = {name: _as_1d(name, getattr(self, name)) for name in self.channels}
        for mark in ("fixed", "unbiased"):
            marked = frozenset(getattr(self, mark))
            if not marked <= set(OPTIONAL_CHANNELS):
                raise ValueError(f"Signals.{mark}: {sorted(marked - set(OPTIONAL_CHANNELS))} not optional channels "
                                 f"(of {', '.join(OPTIONAL_CHANNELS)})")
            object.__setattr__(self, mark, frozenset(c for c in marked if getattr(self, c) is not None))
        n = len(arrays["t"])
        if n == 0:
            raise ValueError("Signals: empty arrays (no samples)")
        lengths = {name: len(a) for name, a in arrays.items()}
        if len(set(lengths.values())) != 1:
            raise ValueError(f"Signals: mismatched lengths {lengths}")
        t = arrays["t"]
        if not np.all(np.isfinite(t)):
            bad = int(np.flatnonzero(~np.isfinite(t))[0])
            raise ValueError(f"Signals.t: non-finite time at sample {bad}")
        if n > 1:
            dt = np.diff(t)
            if np.any(dt <= 0):
                bad = int(np.flatnonzero(dt <= 0)[0])
                raise ValueError(
                    f"Signals.t: time not strictly increasing at sample {bad + 1} "
                    f"(t[{bad}]={t[bad]!r}, t[{bad + 1}]={t[bad + 1]!r})")
        for name, a in arrays.items():
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    def __len__(self) -> int:
        return len(self.t)

    def __getitem__(self, index: slice) -> "Signals":
        """Samples ``index`` (a slice) as a new :class:`Signals`."""
        if not isinstance(index, slice):
            raise TypeError("Signals can only be sliced with a slice")
        return self.take(index)

    @property
    def channels(self) -> tuple[str, ...]:
        """The names of the channels this log has: :data:`CHANNELS` and those of :data:`OPTIONAL_CHANNELS` it
        carries."""
        return CHANNELS + tuple(c for c in OPTIONAL_CHANNELS if getattr(self, c) is not None)

    def take(self, index) -> "Signals":
        """Samples ``index`` (a slice, or an index array in increasing order) of every channel, as a new
        :class:`Signals`."""
        return Signals(**{c: getattr(self, c)[index] for c in self.channels}, fixed=self.fixed, unbiased=self.unbiased)

    @classmethod
    def from_steering_wheel(cls, t, vx, ay, r, steering_wheel_angle,
                            params: VehicleParams | None = None) -> "Signals":
        """Build signals from the steering-wheel angle (rad) instead of the road-wheel angle.

        ``delta_f = steering_wheel_angle / params.steering_ratio``.
        """
        return cls(t, vx, ay, r, road_wheel_angle(steering_wheel_angle, params))


def stretch_index(t, t0: float, window_s: float) -> np.ndarray:
    """The stretch of log time each stamp of ``t`` (s) falls in: ``floor((t - t0) / window_s)`` (``t0``, the log's first
    stamp, s; ``window_s`` s), never decreasing (a stamp out of order or NaN belongs to the stretch before it; -1 before
    the first finite one): the same stretches whatever chunks the log is read in."""
    with np.errstate(invalid="ignore"):
        w = np.floor((np.asarray(t, dtype=np.float64) - t0) / window_s)
    return np.maximum.accumulate(np.where(np.isfinite(w), w, -1.0)).astype(np.int64)


def driving_s(signals: "Signals", v_min: float = 5.0) -> float:
    """How long (s) ``signals`` drive at ``vx >= v_min`` (m/s): the intervals after each such sample summed."""
    with np.errstate(invalid="ignore"):
        moving = np.asarray(signals.vx, dtype=np.float64) >= v_min
    dt = np.diff(np.asarray(signals.t, dtype=np.float64))
    return float(np.nansum(np.where(moving[1:], dt, 0.0)))


def concat_signals(parts) -> "Signals":
    """The :class:`Signals` of consecutive pieces of one log, one after the other (every channel)."""
    parts = list(parts)
    if len(parts) == 1:
        return parts[0]
    shared = [c for c in parts[0].channels if all(c in p.channels for p in parts)]
    return Signals(**{c: np.concatenate([getattr(p, c) for p in parts]) for c in shared},
                   fixed=frozenset.intersection(*(p.fixed for p in parts)),
                   unbiased=frozenset.intersection(*(p.unbiased for p in parts)))


def bridged(signals: "Signals") -> "Signals":
    """``signals`` with each single missing sample of a channel (a non-finite value between two finite ones: one
    dropout) linearly interpolated in time from its neighbours; ``signals`` itself where there is none. What a log's
    conditions are measured on (:func:`roadbank.vehicle.log_conditions`): one dropout would split the runs of valid
    samples the noise is read on and move the design (the ``ay`` floor of a KITTI drive by up to 45 %, or to not
    measured). Never what an estimator reads: it holds its output over a missing sample."""
    t = signals.t
    changed = {}
    for c in signals.channels[1:]:
        x = getattr(signals, c)
        bad = ~np.isfinite(x)
        if len(x) < 3 or not bad[1:-1].any():
            continue
        k = 1 + np.flatnonzero(bad[1:-1] & ~bad[:-2] & ~bad[2:])
        if k.size:
            y = x.copy()
            y[k] = x[k - 1] + (t[k] - t[k - 1]) / (t[k + 1] - t[k - 1]) * (x[k + 1] - x[k - 1])
            changed[c] = y
    return replace(signals, **changed) if changed else signals


def interval_rate(dt) -> float:
    """Sample rate (Hz) of the sample intervals ``dt`` (s): the one rule of roadbank.

    1 / the median positive finite interval, rounded to a whole number of Hz when it is one to
    1e-9 relative (time stamps ``k * h`` in floating point carry such an error). NaN when ``dt``
    holds no such interval. Jittered logs (KITTI's 0.06-0.14 s frames) get their typical rate
    (10 Hz); a single interval gives its own rate, which is what the estimators' fixed-rate
    path uses (it must choose causally, at the first interval it sees).
    """
    dt = np.asarray(dt, dtype=np.float64).ravel()
    dt = dt[np.isfinite(dt) & (dt > 0)]
    if not dt.size:
        return float("nan")
    rate = 1.0 / float(np.median(dt))
    return float(round(rate)) if abs(rate - round(rate)) <= 1e-9 * rate else rate


def sample_rate(t) -> float:
    """Sample rate (Hz) of a time base ``t`` (s): :func:`interval_rate` of its intervals.

    NaN when ``t`` has no positive finite interval (fewer than two distinct samples).
    """
    return interval_rate(np.diff(np.asarray(t, dtype=np.float64)))


def spread_rate(t, windows: int = 64, width: int = 64) -> float:
    """Sample rate (Hz) of a time base ``t`` (s) by :func:`interval_rate` of ``windows`` runs of ``width`` consecutive
    intervals spread evenly over the log: :func:`sample_rate` itself for a log of at most ``windows * width``
    intervals. Consecutive intervals, so that a time base with a repeating pattern (two rows per frame) reads as a
    whole one does. For checks on a hot path (an estimator's run warns when a log's rate is far from its design's):
    constant cost, not a pass over the log."""
    t = np.asarray(t, dtype=np.float64)
    n = t.size - 1
    if n <= windows * width:
        return sample_rate(t)
    k = (np.linspace(0, n - width, windows).astype(np.int64)[:, None] + np.arange(width)).ravel()
    return interval_rate(t[k + 1] - t[k])


def running_integral(t, x) -> np.ndarray:
    """The running trapezoidal integral of ``x`` over the times ``t`` (s; ``x`` in its unit, the integral in its
    unit times s), non-finite samples as 0, from 0; held across an interval longer than
    :data:`~roadbank.constants.MAX_GAP_S` (a gap in the log: no rate was read)."""
    t, x = np.asarray(t, dtype=np.float64), np.asarray(x, dtype=np.float64)
    dt = np.diff(t)
    return np.concatenate([[0.0], np.cumsum(0.5 * np.nan_to_num(x[1:] + x[:-1]) * np.where(dt > MAX_GAP_S, 0.0, dt))])


def centred_mean(x, n: int) -> np.ndarray:
    """The mean of ``x`` over ``n`` samples centred on each (the window shortened at the ends)."""
    c = np.concatenate([[0.0], np.cumsum(np.asarray(x, dtype=np.float64))])
    i = np.arange(len(c) - 1)
    lo, hi = np.maximum(i - n // 2, 0), np.minimum(i - n // 2 + n, len(c) - 1)
    return (c[hi] - c[lo]) / (hi - lo)


def band_windows(t, windows_s: tuple[float, float]) -> tuple[int, int]:
    """The two windows ``windows_s`` (s; shorter, longer) of :func:`band_pass` in samples of the time base ``t``
    (s), at its :func:`sample_rate`; at least 1."""
    rate = sample_rate(t)
    return tuple(max(int(round(w * rate)), 1) for w in windows_s)  # type: ignore[return-value]


def band_pass(x, windows: tuple[int, int]) -> np.ndarray:
    """``x`` band-passed without phase by centred means (:func:`centred_mean`) over ``windows`` samples: the shorter
    less the longer (1 s and 10 s: about 0.05-0.5 Hz). Non-finite samples as 0."""
    x = np.nan_to_num(np.asarray(x, dtype=np.float64))
    return centred_mean(x, windows[0]) - centred_mean(x, windows[1])


def band_inner(mask, windows: tuple[int, int]) -> np.ndarray | None:
    """The samples of ``mask`` (bool array) at least half the longer of ``windows`` (samples) from either end, where
    :func:`band_pass` has its full windows; None where fewer than a tenth of that window (plus two) are left."""
    use = np.array(mask, dtype=bool)
    use[:windows[1] // 2] = False
    use[len(use) - windows[1] // 2:] = False
    return use if np.count_nonzero(use) >= windows[1] // 10 + 2 else None


def integral_band_fit(t, level, rate, use, windows: tuple[int, int]) -> tuple[float, float, float] | None:
    """How ``level`` follows the time integral of ``rate`` (:func:`running_integral`; ``t`` s), both band-passed over
    ``windows`` (:func:`band_pass`) and read on the samples ``use`` (:func:`band_inner`): ``(least-squares slope of
    level on the integral, their correlation, the band-passed level's root mean square)`` in their units; None where
    the integral never moves in the band."""
    lb = band_pass(level, windows)[use]
    ab = band_pass(running_integral(t, rate), windows)[use]
    ll, aa, la = float(lb @ lb), float(ab @ ab), float(lb @ ab)
    if not aa > 0:
        return None
    return la / aa, (la / math.sqrt(ll * aa) if ll > 0 else 0.0), math.sqrt(ll / len(lb))


#: fewest sample triples :func:`white_noise_std` measures from
MIN_NOISE_TRIPLES = 100


def white_noise_std(x, valid=None) -> float:
    """Standard deviation (unit of ``x``) of the white noise on a sampled channel ``x``.

    From its second differences ``d_k = x[k+1] - 2 x[k] + x[k-1]``: for ``x = s + n`` with
    ``n`` white Gaussian of standard deviation ``sigma`` and ``s`` close to linear over three
    samples, ``d`` has standard deviation ``sqrt(6) sigma``. Its scale is taken robustly, as
    1.4826 x the median absolute deviation, so that the samples where the signal itself bends
    within three samples (steering reversals, a 10 Hz log's manoeuvres), which are few, do not
    count as noise. Only triples of finite samples that are all ``valid`` (bool array, default
    all) count; NaN with fewer than :data:`MIN_NOISE_TRIPLES`. Noise much finer than the
    channel's quantisation step reads as 0.
    """
    x = np.asarray(x, dtype=np.float64)
    ok = np.isfinite(x) if valid is None else np.isfinite(x) & np.asarray(valid, dtype=bool)
    ok3 = ok[2:] & ok[1:-1] & ok[:-2]
    if ok3.sum() < MIN_NOISE_TRIPLES:
        return float("nan")
    d = (x[2:] - 2.0 * x[1:-1] + x[:-2])[ok3]
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(6.0))


#: upper edge (Hz) of the band of the vehicle's own lateral dynamics (yaw, sideslip, roll): what a
#: channel carries above it is vibration and sensor noise, not manoeuvre (:func:`noise_band_hz`)
DYNAMICS_BAND_HZ = 3.0
#: lowest edge (Hz) a slow log measures its noise from: below it manoeuvres dominate any channel
NOISE_BAND_MIN_HZ = 1.0
#: a log sampled at ``rate`` measures its noise from at most ``rate * NOISE_BAND_PER_RATE`` Hz, so that
#: the measured band spans a factor 5 up to the Nyquist frequency
NOISE_BAND_PER_RATE = 0.1


def noise_band_hz(rate: float) -> float:
    """Lower edge (Hz) of the band in which :func:`road_noise_std` measures a log's noise, for a log
    sampled at ``rate`` (Hz): the vehicle's dynamics band :data:`DYNAMICS_BAND_HZ` (3 Hz) where the log
    reaches five times as high, a tenth of ``rate`` below that, and never below
    :data:`NOISE_BAND_MIN_HZ` (1 Hz; a 10 Hz log measures from 1 Hz, a log at 4 Hz or slower falls
    back to second differences). On simulated drives with the data sheet's sensors a 1 Hz edge read
    up to 6 times the true noise density in hard manoeuvres (the dynamics above 1 Hz); 2-3 Hz reads
    it within 15 % (``tests/test_ay_noise.py``)."""
    return float(min(DYNAMICS_BAND_HZ, max(NOISE_BAND_MIN_HZ, NOISE_BAND_PER_RATE * rate)))


#: shortest run of valid samples (in periods of the dynamics band) that :func:`road_noise_std` reads
ROAD_NOISE_MIN_PERIODS = 4.0


def road_noise_std(x, t, valid=None, band_hz: float | None = None, top_hz: float = math.inf) -> float:
    """Standard deviation (unit of ``x``) of the noise a channel carries on a real road.

    The noise model of real roads: what the sampled channel ``x`` (on time stamps ``t``, s)
    carries above the vehicle's dynamics band ``band_hz`` (Hz; default :func:`noise_band_hz` of the
    log's rate) is road and body vibration (aliased into a slow log) and sensor noise, and it is
    taken as white over the whole band ``0 .. rate/2``. Each run of consecutive valid samples (at least
    :data:`ROAD_NOISE_MIN_PERIODS` periods of the band long) is detrended, tapered with a Hann
    window and high-passed without phase in the frequency domain (samples in order, at the
    log's median rate) with the gain ``G(f) = (f/band)^8 / (1 + (f/band)^8)`` (an eighth-order
    Butterworth magnitude: a fourth-order one run forward and backward). The windowed mean
    square of the result over all runs, divided by the share of white noise that ``G`` passes
    (the mean of ``G^2`` over the band), is the noise variance (a Welch-type estimate). Unlike
    :func:`white_noise_std` (second differences, robust scale) it counts the heavy tails and the
    coloured part of the vibration, which pass a filter designed for white noise. Only finite
    samples that are ``valid`` (bool array, default all) count; NaN with fewer than
    :data:`MIN_NOISE_TRIPLES` of them in such runs. Where the log is too slow for the band
    (``rate <= 4 band_hz``) it falls back to :func:`white_noise_std`. ``top_hz`` (Hz, default none): the band read
    ends there too, ``G`` times the low-pass ``1 / (1 + (f/top)^8)`` (the density read in ``band .. top``, taken as
    the whole band's: the noise where a filter's stop band begins, whatever lies above).
    """
    x = np.asarray(x, dtype=np.float64)
    ok = np.isfinite(x) if valid is None else np.isfinite(x) & np.asarray(valid, dtype=bool)
    rate = sample_rate(t)
    if ok.sum() < MIN_NOISE_TRIPLES or not np.isfinite(rate):
        return float("nan")
    band_hz = noise_band_hz(rate) if band_hz is None else band_hz
    if rate <= 4.0 * band_hz:
        return white_noise_std(x, valid)
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(np.int8), 0]))
    shortest = max(MIN_NOISE_TRIPLES, int(np.ceil(ROAD_NOISE_MIN_PERIODS * rate / band_hz)))
    power = weight = 0.0
    for a, b in zip(edges[0::2], edges[1::2]):
        n = b - a
        if n < shortest:
            continue
        k = np.arange(n)
        y = x[a:b] - np.polyval(np.polyfit(k, x[a:b], 1), k)
        w = np.hanning(n)
        f = np.fft.rfftfreq(n, d=1.0 / rate)
        q = (f / band_hz) ** 8
        gain = q / (1.0 + q) / (1.0 + (f / top_hz) ** 8)
        h = np.fft.irfft(np.fft.rfft(y * w) * gain, n)
        power += float(np.sum(h ** 2)) / float(np.mean(gain ** 2))
        weight += float(np.sum(w ** 2))
    return float(np.sqrt(power / weight)) if weight > 0 else float("nan")


#: length (s) of the windows over which :func:`road_noise_floor_std` takes its median (at least as
#: many samples as :func:`road_noise_std` needs of one run)
NOISE_FLOOR_WINDOW_S = 4.0


def road_noise_floor_std(x, t, valid=None, band_hz: float | None = None, at_rate: float = 0.0,
                         top_hz: float = math.inf) -> float:
    """The noise floor (unit of ``x``) of a channel: :func:`road_noise_std` of half-overlapping windows
    of :data:`NOISE_FLOOR_WINDOW_S` (longer where the log is slow: at least the samples one run needs
    there), the median of their variances (``band_hz``, ``top_hz`` as there). ``at_rate`` (Hz; 0: the log's own
    rate): where the log is faster than 1.5 times it, the floor of the channel read at about that rate
    (:func:`block_means` of ``k`` samples, ``k`` the rate ratio rounded), returned as the standard deviation that
    white noise of the same density at the log's own rate has (times ``sqrt(k)``): white noise reads the same floor
    either way.

    :func:`road_noise_std` counts everything above the dynamics band over the whole span, the bursts
    too: road vibration that comes and goes is noise a filter must stand, but so is the response of a
    manoeuvre at the tyres' limit, which reaches past 3 Hz while it lasts (the paper's S-curve on the
    data sheet's sensors reads 2-6 times their density over the drive). The median over windows reads
    what the channel carries most of the time, the sensor and the road surface, and not a few seconds
    of manoeuvre: on that S-curve it reads the data sheet's noise. Same arguments as
    :func:`road_noise_std`; NaN where no window has enough valid samples.
    """
    x = np.asarray(x, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    ok = np.ones(len(x), dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    rate = sample_rate(t)
    if not np.isfinite(rate):
        return float("nan")
    if at_rate > 0.0 and rate > 1.5 * at_rate:
        k = int(round(rate / at_rate))
        return float(np.sqrt(k)) * road_noise_floor_std(*block_means(x, t, ok, k), band_hz=band_hz, top_hz=top_hz)
    band = noise_band_hz(rate) if band_hz is None else band_hz
    n = max(int(round(NOISE_FLOOR_WINDOW_S * rate)), MIN_NOISE_TRIPLES,
            int(np.ceil(ROAD_NOISE_MIN_PERIODS * rate / band)))
    var = [road_noise_std(x[a:a + n], t[a:a + n], ok[a:a + n], band, top_hz) ** 2
           for a in range(0, max(len(x) - n, 0) + 1, max(n // 2, 1))]
    var = [v for v in var if np.isfinite(v)]
    return float(np.sqrt(np.median(var))) if var else float("nan")


def block_means(x, t, valid, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(x, t, valid)`` averaged over consecutive blocks of ``k`` samples (the last partial block dropped): a
    block is valid where all its samples are valid and finite. Units of ``x`` and ``t`` (s) kept."""
    n = (len(x) // k) * k
    xb = np.asarray(x[:n], dtype=np.float64).reshape(-1, k)
    ok = np.asarray((np.asarray(valid[:n], dtype=bool) & np.isfinite(xb.reshape(-1))).reshape(-1, k).all(axis=1))
    with np.errstate(invalid="ignore"):
        return xb.mean(axis=1), np.asarray(t[:n], dtype=np.float64).reshape(-1, k).mean(axis=1), ok


#: share (-) of a channel's second differences that must vanish for :func:`source_step` to read it as written from a
#: slower source (a linear or held interpolation vanishes between the source's samples: 1 - 2/k of them at k samples
#: per source sample; a quantised sensor at its own rate, the data sheet's, vanishes on at most 0.3 of them)
SOURCE_ZERO_SHARE = 0.5
#: a second difference vanishes below this share (-) of the channel's 99th percentile of them (a log written with
#: four decimals or more keeps its interpolation's rounding below it)
SOURCE_ZERO_REL = 1e-2
#: the source's samples come at a steady rate: the interquartile range of the distances between the runs of
#: non-vanishing second differences is at most this share (-) of their median (a quantised channel whose value
#: holds for a while between random steps is not read as a slower source)
SOURCE_SPREAD = 0.5


#: a channel's values lie on a grid (:func:`value_step`) where this share (-) of the differences between consecutive
#: samples are whole multiples of the smallest one
GRID_SHARE = 0.99
#: how close (-, relative) a difference must come to a whole multiple of the grid step to count as one (a value written
#: with a few decimals and read back as a float is a multiple to about 1e-15)
GRID_TOL = 1e-6


def value_step(x, valid=None) -> float:
    """The grid step (unit of ``x``) on which the values of the channel ``x`` lie, 0 where they lie on none: a channel
    written with a few decimals (0.001 for three) or at a sensor's resolution changes by whole multiples of one step.
    Read on the differences between consecutive finite samples that are both ``valid`` (bool array, default all) and
    not zero: the smallest of them where :data:`GRID_SHARE` of them are multiples of it (within :data:`GRID_TOL`);
    0 with fewer than :data:`MIN_NOISE_TRIPLES` such differences."""
    x = np.asarray(x, dtype=np.float64)
    ok = np.isfinite(x) if valid is None else np.isfinite(x) & np.asarray(valid, dtype=bool)
    d = np.abs(np.diff(x))[ok[1:] & ok[:-1]]
    d = d[d > 0.0]
    if d.size < MIN_NOISE_TRIPLES:
        return 0.0
    step = float(d.min())
    n = d / step
    whole = np.abs(n - np.round(n)) <= GRID_TOL * n
    return step if whole.mean() >= GRID_SHARE else 0.0


#: the share (-) of a channel's 99th percentile of second differences that its rounding bound (two grid steps,
#: :func:`value_step`) may reach for :func:`source_step` to let that bound vanish too (``rounding``): the rounding must
#: be small against the bends that mark the source's samples; a quantised sensor at its own rate, whose steps are
#: its bends, is read without it
SOURCE_ROUNDING_SHARE = 0.25


def source_step(x, valid=None, rounding: bool = False) -> int:
    """How many samples of the sampled channel ``x`` (any unit) make one sample of its source: 1 for a channel at
    its own rate, ``k`` for one that a logger interpolated linearly (or held) onto a grid ``k`` times faster than
    the sensor (a 10 Hz INS written at 100 Hz: 10). Between the source's samples such a channel is a straight line,
    so its second differences vanish there (below :data:`SOURCE_ZERO_REL` of their 99th percentile); where at least
    :data:`SOURCE_ZERO_SHARE` of them do and the runs that do not start at a steady pace (:data:`SOURCE_SPREAD`),
    ``k`` is the median distance (samples) between those starts (with every triple between them read). It reads
    ``k`` >= 4 (below, too few vanish: 2 and 3 read 1). Only triples of finite samples that are all
    ``valid`` (bool array, default all) count; 1 with fewer than :data:`MIN_NOISE_TRIPLES` of them.

    ``rounding``: a channel written with few decimals (its values on a grid, :func:`value_step`) carries its
    rounding between the source's samples, up to two grid steps of second difference; with ``rounding`` those vanish
    too, where two steps are at most :data:`SOURCE_ROUNDING_SHARE` of the 99th percentile."""
    x = np.asarray(x, dtype=np.float64)
    ok = np.isfinite(x) if valid is None else np.isfinite(x) & np.asarray(valid, dtype=bool)
    ok3 = ok[2:] & ok[1:-1] & ok[:-2]
    if ok3.sum() < MIN_NOISE_TRIPLES:
        return 1
    d2 = np.abs(x[2:] - 2.0 * x[1:-1] + x[:-2])
    d2[~ok3] = 0.0
    top = float(np.percentile(d2[ok3], 99.0))
    zero = SOURCE_ZERO_REL * top
    if rounding:
        bound = 2.0 * value_step(x, valid) * (1.0 + GRID_TOL)
        if bound <= SOURCE_ROUNDING_SHARE * top:
            zero = max(zero, bound)
    bent = d2 > zero
    if top <= 0.0 or 1.0 - bent[ok3].mean() < SOURCE_ZERO_SHARE:
        return 1
    starts = np.flatnonzero(bent & ~np.r_[False, bent[:-1]])
    unread = np.r_[0, np.cumsum(~ok3)]                  # triples left out before each index
    gaps = np.diff(starts)[unread[starts[1:]] == unread[starts[:-1]]]     # between starts, every triple read
    if len(gaps) < 2:
        return 1
    q1, mid, q3 = np.percentile(gaps, [25.0, 50.0, 75.0])
    return max(1, int(round(float(mid)))) if q3 - q1 <= SOURCE_SPREAD * mid else 1


#: share (-) of a log's moving rows that must repeat the row before (:func:`held_copies`) for it to be read as a
#: logger's copies of slower frames (:func:`is_held`): a 10 Hz sensor held onto a 20 Hz grid repeats half its rows, a
#: log at its sensors' rate almost none (a noisy channel seldom repeats to the last bit while the car moves)
HELD_SHARE = 0.5
#: the shortest distance (-, a share of their median) between the rows that bring new values in all but 5 % of the
#: cases, in a log written by holding frames (:func:`is_held`): 0.5 takes a 10 Hz sensor held at 20 Hz (distances of
#: 1-3 rows, median 2) and one with KITTI's jittered clock (0.06-0.14 s) at 50 Hz
HELD_MIN_SPACING = 0.5


def held_copies(s: "Signals", before: tuple[float, ...] | None = None) -> np.ndarray:
    """Which rows of ``s`` repeat the row before in ``ay`` (m/s^2), the yaw rate (rad/s) and, where ``s`` has one, the
    roll rate (rad/s), to the last bit: a logger that writes a slower sensor onto a faster grid by holding its frames
    writes such copies. ``before``: those channels of the row before ``s``'s first (a log read in pieces; None: the
    first row repeats nothing). A NaN repeats nothing."""
    chans = [s.ay, s.r] + ([s.p] if s.p is not None else [])
    same = np.ones(len(s), dtype=bool)
    for i, x in enumerate(chans):
        x = np.asarray(x, dtype=np.float64)
        first = math.nan if before is None or i >= len(before) else before[i]
        same &= x == np.concatenate([[first], x[:-1]])
    return same


def is_held(copies: np.ndarray, moving: np.ndarray) -> bool:
    """Whether a log whose repeated rows are ``copies`` (:func:`held_copies`) was written by holding a slower sensor's
    frames: at least :data:`HELD_SHARE` of its ``moving`` rows (bool array) repeat the row before, and the moving rows
    that bring new values come no closer than frames do: between consecutive ones at least 2 rows in three quarters
    of the cases, and in 95 % at least :data:`HELD_MIN_SPACING` of the median distance (a frame that repeats the
    one before it makes a distance of two or three frames, never a short one). A quantised sensor at its own rate
    repeats at random (the simulator's 100 Hz ESP channels a quarter of their rows, nearly all with a tenth of the
    data sheet's noise): its distances spread as a geometric law's, many far shorter than their median."""
    moving = np.asarray(moving, dtype=bool)
    if not (moving.any() and copies[moving].mean() >= HELD_SHARE):
        return False
    d = np.diff(np.flatnonzero(~copies & moving))      # (one across a stop is one distance among many)
    if d.size < 2:
        return False
    p5, q1, mid = np.percentile(d, [5.0, 25.0, 50.0])
    return bool(q1 >= 2.0 and p5 >= HELD_MIN_SPACING * mid)


#: the Huber limit of :func:`diff_noise_std` (squared standard deviations), as the kernels' running estimate's
#: (:data:`roadbank.estimators.kernels.sample.NOISE_HUBER`)
DIFF_NOISE_HUBER = 9.0


def diff_noise_std(x, valid=None) -> float:
    r"""White-noise standard deviation (unit of ``x``) that the first differences of ``x`` read, Huber-robust:
    the fixed point of :math:`\sigma^2 = \operatorname{mean}\min\left((\Delta x)^2/2,\; H \sigma^2\right)`,
    :math:`H` = :data:`DIFF_NOISE_HUBER` (a difference counts at most 3 standard deviations), from the plain
    mean square. The same measure as the running noise estimate of a limited low-pass
    (:func:`roadbank.estimators.kernels.sample.noise_update`), which reads its noise relative to this one on
    the log's design span. Only differences of consecutive finite samples that are both ``valid`` (bool
    array, default all) count; NaN with fewer than :data:`MIN_NOISE_TRIPLES` of them.
    """
    x = np.asarray(x, dtype=np.float64)
    ok = np.isfinite(x) if valid is None else np.isfinite(x) & np.asarray(valid, dtype=bool)
    ok2 = ok[1:] & ok[:-1]
    if ok2.sum() < MIN_NOISE_TRIPLES:
        return float("nan")
    u = 0.5 * np.diff(x)[ok2] ** 2
    var = float(np.mean(u))
    for _ in range(50):
        new = float(np.mean(np.minimum(u, DIFF_NOISE_HUBER * var)))
        if abs(new - var) <= 1e-12 * var:
            break
        var = new
    return float(np.sqrt(var))


def road_wheel_angle(steering_wheel_angle, params: VehicleParams | None = None) -> np.ndarray:
    """Front road-wheel angle (rad) from the steering-wheel angle (rad) by the steering ratio."""
    p = params or VehicleParams()
    return np.asarray(steering_wheel_angle, dtype=np.float64) / p.steering_ratio


@dataclass
class Estimate:
    """Output of one estimator over a log.

    Attributes
    ----------
    name : str
        Estimator name (one of :data:`roadbank.estimators.NAMES`).
    t : array (s)
    w : array (-)
        Estimated ``sin(theta)`` (the observers' disturbance).
    theta : array (rad)
        Raw observer angle ``asin(w)`` = bank + body roll.
    phi_b : array (rad)
        Road bank after roll separation, ``theta - phi_hat``.
    valid : bool array
        False where the sample could not be used (NaN/inf input, vx below
        v_min, a non-increasing time stamp; the outputs are held there) or the
        estimate is implausible (``|theta| > max_angle``, default 60 deg; ``|w| > 1``
        has no angle and theta is clipped to +-90 deg).
    states : dict of arrays
        Estimator-specific internal states (e.g. ``vy``, ``r`` of the observer,
        ``phi`` the estimated body roll), SI.
    settled : bool array
        ``valid``, and at least the estimator's settling time after its last (re)start (the first
        usable sample, or the first after a gap longer than its ``max_gap``), where it begins from one
        sample: :mod:`roadbank.estimators.settle`. Not given: ``valid``.
    """

    name: str
    t: np.ndarray
    w: np.ndarray
    theta: np.ndarray
    phi_b: np.ndarray
    valid: np.ndarray
    states: dict[str, np.ndarray] = field(default_factory=dict)
    settled: np.ndarray = None      # type: ignore[assignment]     # __post_init__: valid where not given

    def __post_init__(self) -> None:
        if self.settled is None:
            self.settled = self.valid

    def __len__(self) -> int:
        return len(self.t)

"""Dataset-independent scoring of bank estimates against a measured reference roll.

Used identically by every real-data validation (comma2k19, KITTI). Method,
fixed before looking at any result and applied to every estimator alike:

1. Run each estimator over the whole log (default tuning).
2. Speed gate: only samples with ``vx >= v_gate`` (5 m/s, the estimators'
   ``v_min``) are scored.
3. Warm-up: samples less than ``warmup_s`` (5 s) after a start are dropped; a
   start is the first gated sample of the log or after more than ``max_gap``
   (1 s, the estimators' re-initialisation gap) below the gate. With
   ``from_log_start`` the warm-up is the first ``warmup_s`` of the log, once: every
   gated sample after it is scored, those after each stop too. Samples without a
   reference (NaN) are not scored, and a log whose reference covers less time than
   it is run and scored as the log cut to the stretch from the reference's first
   sample to its last (:func:`covered_span`).
4. Smoothing: the reference and every estimate (held over not-valid samples) go
   through the same zero-phase first-order low-pass (``tau`` = 2/3 s, the paper's
   reference filter, run forward and backward so it adds no lag of its own).
   Unsmoothed ("raw") scores are computed on the same samples too.
5. Offset: where the reference frame differs from the vehicle frame by an unknown
   constant (a device mount), ``offset = mean(reference - estimate)`` is fitted on
   the first ``fit_fraction`` of the scored samples and those samples are not
   scored. ``fit_fraction = 0``: no offset, every scored sample counts.
6. Scores: Pearson r and RMS error (deg) of ``theta`` (bank + body roll, what a
   measured roll contains), smoothed and raw; diagnostics: r with a causal
   low-pass, r without the split, ``phi_b`` instead of ``theta``, the lag that
   would maximise r, the valid fraction.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..defaults import ESTIMATOR
from ..estimators import NAMES
from ..estimators.base import NoSteeringWarning
from ..signals import sample_rate
from ..vehicle import SensorSpec, log_conditions, make_estimator, tuning_of
from ..vehicle.conditions import GYRO_MODELS, esp_conditions

#: the real-road estimators built as for a log without a roll rate (the ESP channels alone), by label: on a log with
#: one, ``kinematic-pif`` and ``kinematic-smoother`` are the gyro-aided filters
#: (:data:`roadbank.vehicle.conditions.GYRO_MODELS`), and these rows keep the comparison on ESP signals, where every
#: other estimator is (labels of the validation, not estimator names)
ESP_LABELS = {f"{name}-esp": name for name in GYRO_MODELS}
#: the default's label among them
ESP_DEFAULT = f"{ESTIMATOR}-esp"
#: what ``roadbank validate`` runs on a real log unless told: every estimator and :data:`ESP_LABELS`
VALIDATION_NAMES = NAMES + tuple(ESP_LABELS)


#: the lengths (s) a drive is cut into for its short-log scores (:func:`piece_bounds`): many raw drives last 10-30 s
SHORT_PIECES_S = (8.0, 12.0, 20.0)


def piece_bounds(t, length: float) -> list[tuple[int, int]]:
    """Sample bounds ``[a, b)`` of the consecutive whole pieces of ``length`` (s) of a log sampled at ``t`` (s), from
    its first sample on (the remainder shorter than ``length`` left out), those that hold a sample: a gap in the time
    stamps longer than a piece leaves pieces without one, which are not listed (nor made: a gap of a year costs
    nothing)."""
    t = np.asarray(t, dtype=np.float64)
    whole = int((t[-1] - t[0]) // length)
    # the pieces that may hold a sample, with their neighbours (the edges are t[0] + length j, as always)
    j = np.unique(np.floor((t - t[0]) / length).astype(np.int64))
    j = np.unique(np.concatenate([j - 1, j, j + 1]))
    j = j[(j >= 0) & (j < whole)]
    a = np.searchsorted(t, t[0] + length * j)
    b = np.searchsorted(t, t[0] + length * (j + 1))
    return [(int(x), int(y)) for x, y in zip(a, b) if y > x]


@dataclass(frozen=True)
class Scoring:
    """Settings of the scoring (see the module docstring).

    Attributes
    ----------
    tau : float
        Smoothing time constant (s).
    warmup_s : float
        Warm-up dropped after each start (s).
    v_gate : float
        Lowest scored speed (m/s).
    fit_fraction : float
        Fraction of the scored samples used to fit a constant offset (0 = none).
    max_gap : float
        Time below the gate (s) after which the warm-up starts again.
    from_log_start : bool
        The warm-up is the first ``warmup_s`` of the log, once (``max_gap`` unused).
    """

    tau: float = 2.0 / 3.0
    warmup_s: float = 5.0
    v_gate: float = 5.0
    fit_fraction: float = 0.3
    max_gap: float = 1.0
    from_log_start: bool = False


@dataclass
class Score:
    """Scores of one estimator on one log (angles in deg)."""

    r: float            # Pearson r on the scored part (smoothed)
    rms_deg: float      # RMS error on the scored part after the offset (smoothed, deg)
    offset_deg: float   # offset reference - estimate fitted on the first part (deg; 0 if not fitted)
    r_raw: float        # same samples, no smoothing
    rms_raw_deg: float  # same samples, no smoothing (deg)
    r_causal: float     # same samples, causal low-pass on both
    r_whole: float      # fit + scored samples, no split (smoothed)
    r_phi_b: float      # phi_b instead of theta (smoothed)
    rms_phi_b_deg: float
    best_lag_s: float   # lag of the estimate that would maximise r (diagnostic)
    r_at_best_lag: float
    valid_fraction: float  # valid share of the fit + scored samples


def is_uniform(t: np.ndarray, rel: float = 1e-6) -> bool:
    """True if the steps of ``t`` (s) are all equal within ``rel`` of the median step."""
    d = np.diff(t)
    return _uniform_steps(d, np.median(d), rel)


def _uniform_steps(d: np.ndarray, median: float, rel: float = 1e-6) -> bool:
    return bool(np.all(np.abs(d - median) <= rel * median))


@dataclass(frozen=True)
class TimeGrid:
    """The steps of a time grid, worked out once for the many low-passes of one log.

    Attributes
    ----------
    steps : array
        ``diff(t)`` (s).
    median_step : float
        Their median (s).
    uniform : bool
        :func:`is_uniform` of the grid.
    """

    steps: np.ndarray
    median_step: float
    uniform: bool

    @classmethod
    def of(cls, t: np.ndarray) -> TimeGrid:
        """The grid of the time stamps ``t`` (s)."""
        d = np.diff(np.asarray(t, dtype=np.float64))
        med = float(np.median(d))
        return cls(d, med, _uniform_steps(d, med))


def lowpass(x: np.ndarray, tau: float, dt: float, zero_phase: bool = True) -> np.ndarray:
    """First-order low-pass 1/(tau s + 1) on a uniform grid of step ``dt`` (s).

    Discretised as ``y += dt/(tau+dt) (x - y)``; zero-phase by forward-backward.
    """
    # imported here: scipy.signal takes about a second to import, and a jittered log (KITTI)
    # never comes here
    from scipy.signal import filtfilt, lfilter

    a = dt / (tau + dt)
    b, den = [a], [1.0, -(1.0 - a)]
    x = np.asarray(x, dtype=np.float64)
    if zero_phase:
        return filtfilt(b, den, x, padtype="constant")
    y, _ = lfilter(b, den, x, zi=[(1.0 - a) * x[0]])
    return y


@njit(cache=True, error_model="numpy")
def _lowpass_steps(x: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``y[0] = x[0]``, ``y[k] = y[k-1] + a[k-1] (x[k] - y[k-1])`` (compiled: the same operations in
    the same order as the loop in Python, so the same numbers)."""
    y = np.empty_like(x)
    if len(x) == 0:
        return y
    y[0] = x[0]
    for k in range(1, len(x)):
        y[k] = y[k - 1] + a[k - 1] * (x[k] - y[k - 1])
    return y


def lowpass_t(x: np.ndarray, t: np.ndarray, tau: float, zero_phase: bool = True,
              grid: TimeGrid | None = None) -> np.ndarray:
    """:func:`lowpass` on any time grid ``t`` (s): per-step ``a = dt_k/(tau + dt_k)``.

    A uniform grid uses :func:`lowpass` exactly; a jittered one (KITTI, 0.06-0.14 s)
    runs the same recursion with each step's own ``dt``, forward then backward.
    ``grid``: :meth:`TimeGrid.of` of ``t`` if already known (it is then not worked out again).
    """
    x = np.asarray(x, dtype=np.float64)
    grid = grid or TimeGrid.of(t)
    if grid.uniform:
        return lowpass(x, tau, grid.median_step, zero_phase)
    d = grid.steps
    a = d / (tau + d)
    y = _lowpass_steps(np.ascontiguousarray(x), a)
    if zero_phase:
        y = _lowpass_steps(np.ascontiguousarray(y[::-1]), np.ascontiguousarray(a[::-1]))[::-1]
    return y


def reference_covered(ref) -> tuple[np.ndarray, np.ndarray]:
    """``(held, covered)`` of a reference roll (rad): ``held`` the reference with its last value held over the
    samples without one (NaN) and its first value before its first sample, for smoothing; ``covered`` the mask of
    the samples that have one, the only ones scored (:func:`masks`)."""
    covered = np.isfinite(np.asarray(ref, dtype=np.float64))
    held = hold_invalid(ref)
    if covered.any() and not covered[0]:
        first = int(np.argmax(covered))
        held[:first] = held[first]
    return held, covered


def covered_span(covered: np.ndarray) -> slice:
    """The samples from the first to the last of the mask ``covered`` (those with a reference,
    :func:`reference_covered`): the stretch a log is scored on; the whole log where none is covered."""
    k = np.flatnonzero(covered)
    return slice(int(k[0]), int(k[-1]) + 1) if len(k) else slice(0, len(covered))


def hold_invalid(x: np.ndarray) -> np.ndarray:
    """Hold the last finite value over non-finite samples (the estimators already hold; NaN guard)."""
    x = np.array(x, dtype=np.float64)
    bad = ~np.isfinite(x)
    if bad.any():
        idx = np.where(~bad, np.arange(len(x)), 0)
        np.maximum.accumulate(idx, out=idx)
        x = x[idx]
    return x


def pearson_r(a, b) -> float:
    """Pearson correlation of two equal-length arrays (NaN if fewer than 3 samples or constant)."""
    if len(a) < 3 or np.std(a) == 0 or np.std(b) == 0:
        return float("nan")
    return float(np.corrcoef(a, b)[0, 1])


def lag_correlations(x: np.ndarray, ref: np.ndarray, idx: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """Pearson r of ``x[idx + k]`` with ``ref[idx]`` for every ``k`` of ``lags`` at once (one array;
    NaN where :func:`pearson_r` would give NaN, or where a spread is zero). The same quantity as
    :func:`pearson_r` per lag, up to rounding."""
    if len(idx) < 3:
        return np.full(len(lags), np.nan)
    X = x[idx[:, None] + lags[None, :]]
    y = ref[idx]
    X = X - X.mean(axis=0)
    y = y - y.mean()
    with np.errstate(invalid="ignore", divide="ignore"):
        return (y @ X) / np.sqrt((X * X).sum(axis=0) * (y @ y))


#: lags whose vectorised r is within this of the largest are checked again with :func:`pearson_r`
#: (rounding of the two ways of computing r differs by ~1e-16)
_LAG_TIE = 1e-9


def best_lag(x: np.ndarray, ref: np.ndarray, idx: np.ndarray, lags) -> tuple[float, int]:
    """``(r, k)``: the lag ``k`` of ``lags`` (samples) whose ``x[idx + k]`` best correlates with
    ``ref[idx]``, and its Pearson r (:func:`pearson_r`); NaN correlations count as the lowest, and of
    equal ones the first lag wins (as ``max`` over the lags in order).

    The candidates are found with :func:`lag_correlations` (all lags at once); those within
    rounding of the best, and any that came out NaN, get :func:`pearson_r` itself, so the answer is
    the one of :func:`pearson_r` lag by lag.
    """
    lags = np.asarray(lags)
    r = lag_correlations(x, ref, idx, lags)
    ok = np.isfinite(r)
    top = r[ok].max() if ok.any() else -np.inf
    check = [k for k, rk, f in zip(lags, r, ok) if not f or rk >= top - _LAG_TIE]
    return max(((pearson_r(x[idx + k], ref[idx]), k) for k in check),
               key=lambda z: -np.inf if np.isnan(z[0]) else z[0])


def _rms_deg(e) -> float:
    return float(np.degrees(np.sqrt(np.mean(e ** 2)))) if len(e) else float("nan")


def masks(t: np.ndarray, vx: np.ndarray, scoring: Scoring,
          covered: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(fit, scored)`` boolean masks of the samples at times ``t`` (s) with speeds ``vx`` (m/s) (see the module
    docstring, steps 2, 3, 5); ``covered``: the samples that have a reference (:func:`reference_covered`), the
    others neither fitted nor scored (the warm-up is the estimators' and counts from the speed alone)."""
    gate = np.isfinite(vx) & (vx >= scoring.v_gate)
    if scoring.from_log_start:
        keep = gate & (t - t[0] >= scoring.warmup_s) if len(t) else np.zeros(0, bool)
    else:
        keep = np.zeros(len(t), bool)
        start = None
        last = -np.inf
        for k in np.flatnonzero(gate):
            if start is None or t[k] - last > scoring.max_gap:
                start = t[k]
            last = t[k]
            keep[k] = t[k] - start >= scoring.warmup_s
    if covered is not None:
        keep = keep & covered
    idx = np.flatnonzero(keep)
    n_fit = int(scoring.fit_fraction * len(idx))
    fit = np.zeros(len(t), bool)
    fit[idx[:n_fit]] = True
    return fit, keep & ~fit


def scored_pieces(signals, length: float, scoring: Scoring) -> list[tuple[int, int, object, np.ndarray]]:
    """``(a, b, piece, scored)`` of each consecutive whole piece of ``length`` (s) of the log ``signals``
    (:func:`piece_bounds`) that has a sample ``scoring`` scores within it: its bounds, the piece (``signals[a:b]``)
    and its scored mask (:func:`masks`, read within the piece)."""
    out = []
    for a, b in piece_bounds(signals.t, length):
        piece = signals[a:b]
        scored = masks(piece.t, piece.vx, scoring)[1]
        if scored.any():
            out.append((a, b, piece, scored))
    return out


def score(t, theta, phi_b, valid, ref, fit, scored, scoring: Scoring, max_lag_s: float = 1.0,
          grid: TimeGrid | None = None) -> Score:
    """Score one estimate (rad) against the reference roll (rad) on the given masks.

    ``theta``, ``phi_b`` must already be held over not-valid samples (:func:`hold_invalid`).
    Returns NaN scores when nothing usable is scored (e.g. every sample flagged not valid).
    ``t`` (s) is the time grid; ``grid`` its :meth:`TimeGrid.of` if already known.
    """
    both = fit | scored
    vf = float(np.mean(valid[both])) if both.any() else 0.0
    if not scored.any() or vf == 0.0 or not np.all(np.isfinite(theta[both])):
        nan = float("nan")
        return Score(nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, vf)
    grid = grid or TimeGrid.of(t)

    def f(x):
        return lowpass_t(x, t, scoring.tau, grid=grid)

    rs, xs, ps = f(ref), f(theta), f(phi_b)
    fitted = fit.any()
    off = float(np.mean(rs[fit] - xs[fit])) if fitted else 0.0
    offp = float(np.mean(rs[fit] - ps[fit])) if fitted else 0.0
    rc = lowpass_t(ref, t, scoring.tau, False, grid=grid)
    xc = lowpass_t(theta, t, scoring.tau, False, grid=grid)
    dt = grid.median_step
    nl = int(round(max_lag_s / dt))
    lags = np.arange(-nl, nl + 1, max(1, int(round(0.01 / dt))))
    idx = np.flatnonzero(scored)
    idx = idx[(idx < len(xs) - nl) & (idx >= nl)]  # room for the lags at both ends
    best = best_lag(xs, rs, idx, lags)
    return Score(r=pearson_r(xs[scored], rs[scored]), rms_deg=_rms_deg(xs[scored] + off - rs[scored]),
                 offset_deg=float(np.degrees(off)), r_raw=pearson_r(theta[scored], ref[scored]),
                 rms_raw_deg=_rms_deg(theta[scored] + off - ref[scored]),
                 r_causal=pearson_r(xc[scored], rc[scored]), r_whole=pearson_r(xs[both], rs[both]),
                 r_phi_b=pearson_r(ps[scored], rs[scored]), rms_phi_b_deg=_rms_deg(ps[scored] + offp - rs[scored]),
                 best_lag_s=float(best[1] * dt), r_at_best_lag=float(best[0]), valid_fraction=vf)


@dataclass
class Scored:
    """Every estimator run and scored on one log.

    ``reference`` and ``estimates`` are smoothed (rad; estimates + their offset),
    ``raw_reference``/``raw_estimates`` unsmoothed (held over not-valid samples),
    ``fit``/``scored`` the sample masks, ``valid`` each estimator's flags (name -> bool array).
    """

    scores: dict
    t: np.ndarray
    reference: np.ndarray
    estimates: dict
    raw_reference: np.ndarray
    raw_estimates: dict
    fit: np.ndarray
    scored: np.ndarray
    valid: dict


def log_rate_R(t, sensors=None) -> float:
    """Yaw-rate noise density ``R`` ((rad/s)^2 s) of a sensor sampled at the log's rate.

    The rate is :func:`roadbank.signals.sample_rate` of ``t`` (s) (1 / the median positive
    sample interval); the noise and resolution are those of ``sensors``
    (:class:`roadbank.vehicle.SensorSpec`, default the paper's ESP cluster):
    :meth:`~roadbank.vehicle.SensorSpec.r_noise_density`. At 100 Hz this is the default
    PIF's ``R``; a 10 Hz log (KITTI) gets ten times that.
    """
    return (sensors or SensorSpec()).r_noise_density(sample_rate(t))


def run_and_score(signals, ref, names, params, scoring: Scoring, per_estimator=None, sensors=None,
                  **tuning) -> Scored:
    """Run each estimator (``roadbank.estimators.make(name, params, **tuning)``) and score ``theta``.

    Parameters
    ----------
    signals : Signals
        The log (SI, ISO 8855).
    ref : array
        Reference roll (rad, ISO: left side up) on ``signals.t``; NaN where there is none: those samples are
        not scored, and the estimators run on the log cut to the stretch from its first sample to its last
        (:func:`covered_span`; the returned ``t``, masks and traces are the stretch's).
    names : sequence of str
        Estimator names, or labels of :data:`ESP_LABELS` (the estimator without the log's roll rate).
    params : VehicleParams
        The estimators' vehicle model.
    scoring : Scoring
        Settings.
    per_estimator : mapping, optional
        ``{name: {option: value}}`` on top of ``tuning`` for that estimator (a vehicle file's
        ``[tuning]`` tables), read as :meth:`roadbank.vehicle.Vehicle.make` reads them
        (:func:`roadbank.vehicle.tuning_of`: an estimator that runs another's filter takes that one's table under its
        own; a label of :data:`ESP_LABELS` its estimator's).
    sensors : SensorSpec, optional
        The car's sensor cluster (a vehicle file's ``[sensors]``); default the paper's ESP.
    **tuning
        Options of every estimator (:func:`roadbank.vehicle.make_estimator`'s: ``described=False`` for a car nobody
        described, chosen for the log).

    Notes
    -----
    The estimators are built by :func:`roadbank.vehicle.make_estimator` for the log's sample
    rate, as ``roadbank estimate`` builds them: the default-tuned PIFs' yaw-rate noise
    density ``R`` is the sensor's noise and resolution at the log's own rate (median
    sample interval), unless ``R`` or another tuning is given (see :func:`log_rate_R`).
    """
    per_estimator = per_estimator or {}
    ref, covered = reference_covered(ref)
    cut = covered_span(covered)
    if cut.stop - cut.start < len(covered):         # the log where the reference has samples
        signals, ref, covered = signals[cut], ref[cut], covered[cut]
    t = signals.t
    fit, scored = masks(t, signals.vx, scoring, covered)
    scores, smooth, raw, flags = {}, {}, {}, {}
    cond = log_conditions(signals)
    grid = TimeGrid.of(t)
    for name in names:
        build, built_for = (ESP_LABELS[name], esp_conditions(cond)) if name in ESP_LABELS else (name, cond)
        with warnings.catch_warnings():     # a log without steering: the table says "needs the steering angle"
            warnings.simplefilter("ignore", NoSteeringWarning)
            est = make_estimator(build, params, sensors=sensors, **built_for,
                                 **{**tuning, **tuning_of(per_estimator, build)}).run(signals)
        th, pb = hold_invalid(est.theta), hold_invalid(est.phi_b)
        sc = score(t, th, pb, est.valid, ref, fit, scored, scoring, grid=grid)
        scores[name] = sc
        raw[name] = th
        flags[name] = est.valid
        smooth[name] = (lowpass_t(th, t, scoring.tau, grid=grid) + np.radians(sc.offset_deg)
                        if np.all(np.isfinite(th)) else th)
    return Scored(scores, t, lowpass_t(ref, t, scoring.tau, grid=grid), smooth, ref, raw, fit, scored, flags)


def pooled(runs, names) -> dict[str, dict[str, float]]:
    """Scores over the scored samples of several logs together.

    Parameters
    ----------
    runs : sequence of Scored
    names : sequence of str

    Returns
    -------
    dict name -> {"r", "rms_deg", "r_raw", "rms_raw_deg", "n"}: Pearson r and RMS
    error (deg) over all scored samples of all logs (each log's own offset),
    smoothed and raw; n = number of samples.
    """
    out = {}
    for name in names:
        xs, rs, xr, rr = [], [], [], []
        for run in runs:
            m = run.scored
            off = np.radians(run.scores[name].offset_deg)
            if not np.isfinite(off):
                continue
            xs.append(run.estimates[name][m])
            rs.append(run.reference[m])
            xr.append(run.raw_estimates[name][m] + off)
            rr.append(run.raw_reference[m])
        if not xs:
            out[name] = {"r": float("nan"), "rms_deg": float("nan"), "r_raw": float("nan"),
                         "rms_raw_deg": float("nan"), "n": 0}
            continue
        x, ref, x_raw, ref_raw = (np.concatenate(v) for v in (xs, rs, xr, rr))
        out[name] = {"r": pearson_r(x, ref), "rms_deg": _rms_deg(x - ref), "r_raw": pearson_r(x_raw, ref_raw),
                     "rms_raw_deg": _rms_deg(x_raw - ref_raw), "n": int(len(x))}
    return out

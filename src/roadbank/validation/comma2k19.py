"""Score every estimator against the pose-derived roll of a comma2k19 segment.

Method (fixed before looking at the results, applied identically to every
estimator; docs/real-data.md is generated from :func:`validate_comma2k19`):

1. Read the segment with :func:`roadbank.io.comma2k19.load_comma2k19` (100 Hz
   uniform grid, ISO signs, reference roll from the global pose).
2. Run each estimator over the whole segment (default tuning).
3. Drop the first ``warmup_s`` (5 s) as observer warm-up.
4. Smooth the reference and every estimate with the same zero-phase first-order
   low-pass (time constant ``tau`` = 2/3 s, the paper's reference filter, run
   forward and backward so it adds no lag of its own).
5. The reference is device roll = bank + body roll + a constant mounting offset
   (plus accelerometer bias on the estimate side). Estimate that offset as the
   mean difference reference - estimate over the first ``fit_fraction`` (30 %)
   of the remaining span; score on the rest: Pearson r and RMS error (deg)
   after adding the offset. The estimate compared is ``theta`` (bank + body
   roll, what the device roll contains); ``phi_b`` is scored the same way.
6. Diagnostics: r without smoothing, r with a causal (one-way) low-pass on both,
   r over the whole span without the split, the lag that would maximise r.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.signal import filtfilt, lfilter

from ..params import VehicleParams

#: Plausible compact/mid-size sedan (Toyota Prius/Corolla/Camry, Honda Civic/Accord,
#: Lexus ES class: most comma2k19 cars). The car is not identified in the data.
SEDAN = VehicleParams(m=1450.0, ms=1300.0, Iz=2400.0, Lf=1.08, Lr=1.62, Cf=120_000.0,
                      Cr=130_000.0, steering_ratio=15.0, h_cg=0.55, h_roll=0.40,
                      k_roll=80_000.0, c_roll=5_000.0, Ixx=500.0, track_f=1.55, track_r=1.55,
                      wheel_radius=0.31)


def lowpass(x: np.ndarray, tau: float, dt: float, zero_phase: bool = True) -> np.ndarray:
    """First-order low-pass 1/(tau s + 1), discretised as y += dt/(tau+dt) (x - y); zero-phase by forward-backward."""
    a = dt / (tau + dt)
    b, den = [a], [1.0, -(1.0 - a)]
    x = np.asarray(x, dtype=np.float64)
    if zero_phase:
        return filtfilt(b, den, x, padtype="constant")
    y, _ = lfilter(b, den, x, zi=[(1.0 - a) * x[0]])
    return y


def _r(a, b) -> float:
    return float(np.corrcoef(a, b)[0, 1])


@dataclass
class Score:
    r: float            # Pearson r on the scoring part (smoothed)
    rms_deg: float      # RMS error on the scoring part after the offset (deg)
    offset_deg: float   # offset reference - estimate fitted on the first part (deg)
    r_raw: float        # same split, no smoothing
    r_causal: float     # same split, causal low-pass on both
    r_whole: float      # whole span after warm-up, no split (smoothed)
    r_phi_b: float      # phi_b instead of theta (smoothed, split)
    rms_phi_b_deg: float
    best_lag_s: float   # lag of the estimate that would maximise r (diagnostic)
    r_at_best_lag: float
    valid_fraction: float


@dataclass
class ValidationResult:
    scores: dict[str, Score]
    params: VehicleParams
    t: np.ndarray
    reference: np.ndarray           # rad, smoothed
    estimates: dict[str, np.ndarray]  # theta, rad, smoothed + offset
    split_time: float
    data: dict = field(default_factory=dict)       # data-limit numbers
    sensitivity: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)


def _score(t, th, phb, valid, ref, m_fit, m_sc, tau, dt, max_lag_s=1.0) -> Score:
    f = lambda x: lowpass(x, tau, dt)
    rs, xs, ps = f(ref), f(th), f(phb)
    off = float(np.mean(rs[m_fit] - xs[m_fit]))
    offp = float(np.mean(rs[m_fit] - ps[m_fit]))
    err = xs[m_sc] + off - rs[m_sc]
    errp = ps[m_sc] + offp - rs[m_sc]
    rc, xc = lowpass(ref, tau, dt, False), lowpass(th, tau, dt, False)
    whole = m_fit | m_sc
    nl = int(round(max_lag_s / dt))
    lags = np.arange(-nl, nl + 1, max(1, int(round(0.01 / dt))))
    idx = np.flatnonzero(m_sc)
    idx = idx[idx < len(xs) - nl]  # room for a positive lag at the end
    best = max(((_r(xs[idx + k], rs[idx]), k) for k in lags), key=lambda z: z[0])
    return Score(r=_r(xs[m_sc], rs[m_sc]), rms_deg=float(np.degrees(np.sqrt(np.mean(err ** 2)))),
                 offset_deg=float(np.degrees(off)), r_raw=_r(th[m_sc], ref[m_sc]),
                 r_causal=_r(xc[m_sc], rc[m_sc]), r_whole=_r(xs[whole], rs[whole]),
                 r_phi_b=_r(ps[m_sc], rs[m_sc]), rms_phi_b_deg=float(np.degrees(np.sqrt(np.mean(errp ** 2)))),
                 best_lag_s=float(best[1] * dt), r_at_best_lag=float(best[0]),
                 valid_fraction=float(np.mean(valid[whole])))


def _fill_invalid(x: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Hold the last valid value over invalid samples (the estimators already hold; NaN guard)."""
    x = np.array(x, dtype=np.float64)
    bad = ~np.isfinite(x)
    if bad.any():
        idx = np.where(~bad, np.arange(len(x)), 0)
        np.maximum.accumulate(idx, out=idx)
        x = x[idx]
    return x


def validate_comma2k19(path, names=None, params: VehicleParams | None = None, tau: float = 2.0 / 3.0,
                       warmup_s: float = 5.0, fit_fraction: float = 0.3,
                       sensitivity: bool = True) -> ValidationResult:
    """Run every estimator on a comma2k19 segment and score it against the pose roll.

    Parameters
    ----------
    path : path-like
        Segment directory.
    names : sequence of str, optional
        Estimators (default: all of :data:`roadbank.estimators.NAMES`).
    params : VehicleParams, optional
        Default :data:`SEDAN`.
    tau : float
        Smoothing time constant (s) applied to the reference and all estimates.
    warmup_s, fit_fraction : float
        Warm-up dropped (s); fraction of the rest used to fit the offset.
    sensitivity : bool
        Also score with the paper's default SUV parameters and a PIF Q sweep.
    """
    from .. import estimators
    from ..io.comma2k19 import load_comma2k19

    params = params or SEDAN
    names = list(names or estimators.NAMES)
    log = load_comma2k19(path, params=params)
    s, ref = log.signals, log.reference_roll
    t = s.t
    dt = float(np.median(np.diff(t)))
    if not np.all(np.isfinite(ref)):
        ref = _fill_invalid(ref, np.isfinite(ref))
    start = t[0] + warmup_s
    m_all = t >= start
    i0 = int(np.flatnonzero(m_all)[0])
    i_split = i0 + int(fit_fraction * (len(t) - i0))
    m_fit = np.zeros(len(t), bool)
    m_fit[i0:i_split] = True
    m_sc = np.zeros(len(t), bool)
    m_sc[i_split:] = True

    scores, smoothed = {}, {}
    for name in names:
        est = estimators.make(name, params=params).run(s)
        th = _fill_invalid(est.theta, est.valid)
        pb = _fill_invalid(est.phi_b, est.valid)
        sc = _score(t, th, pb, est.valid, ref, m_fit, m_sc, tau, dt)
        scores[name] = sc
        smoothed[name] = lowpass(th, tau, dt) + np.radians(sc.offset_deg)

    # ------------------------------------------------------------ data limits
    acc_t = np.load(Path(path) / "processed_log/IMU/accelerometer/t", allow_pickle=False)
    acc = np.load(Path(path) / "processed_log/IMU/accelerometer/value", allow_pickle=False)
    gyr = np.load(Path(path) / "processed_log/IMU/gyro/value", allow_pickle=False)
    steer = np.load(Path(path) / "processed_log/CAN/steering_angle/value", allow_pickle=False)

    def quantum(x):
        d = np.abs(np.diff(np.unique(np.round(x, 12))))
        return float(np.min(d[d > 0])) if np.any(d > 0) else float("nan")

    n1 = max(1, int(round(1.0 / dt)))
    box = np.convolve(s.ay, np.ones(n1) / n1, mode="same")
    inner = slice(n1, -n1)
    kin = (s.ay - s.vx * s.r) / params.g
    kin_s = lowpass(kin, tau, dt)
    ref_s = lowpass(ref, tau, dt)
    off_k = np.mean(ref_s[m_fit] - kin_s[m_fit])
    resid = kin_s[m_sc] + off_k - ref_s[m_sc]
    ref_sig = float(np.std(ref_s[m_sc]))
    # kinematic r for a range of smoothing constants: the best any such filtering achieves here
    tau_sweep = {}
    for tt in (0.25, 0.5, 2.0 / 3.0, 1.0, 1.5, 2.0, 3.0):
        ks, rs2 = lowpass(kin, tt, dt), lowpass(ref, tt, dt)
        tau_sweep[tt] = _r(ks[m_sc], rs2[m_sc])
    # what the steering channel means in lateral acceleration (steady-state bicycle model)
    L_ = params.L
    kus = params.m / L_ * (params.Lr / params.Cf - params.Lf / params.Cr)
    vx_ = np.nan_to_num(s.vx)
    ay_steer = vx_ ** 2 * np.nan_to_num(s.delta_f) / (L_ + kus * vx_ ** 2)
    vmed = float(np.median(vx_))
    data = {
        "ay_from_steering_mean": float(np.mean(ay_steer[m_all])),
        "ay_from_steering_std": float(np.std(ay_steer[m_all])),
        "ay_measured_mean": float(np.nanmean(s.ay[m_all])),
        "steer_step_ay": float(vmed ** 2 * np.radians(0.1) / params.steering_ratio / (L_ + kus * vmed ** 2)),
        "v_median": vmed,
        "duration_s": float(t[-1] - t[0]),
        "speed_range": (float(np.nanmin(s.vx)), float(np.nanmax(s.vx))),
        "ref_range_deg": (float(np.degrees(ref.min())), float(np.degrees(ref.max()))),
        "ref_std_deg_scored": float(np.degrees(ref_sig)),
        "ref_std_deg_raw_scored": float(np.degrees(np.std(ref[m_sc]))),
        "ref_highfreq_std_deg": float(np.degrees(np.std(ref - lowpass(ref, 0.2, dt)))),
        "ay_vibration_std": float(np.std((s.ay - box)[inner])),
        "ay_1s_mean_std": float(np.std(box[inner])),
        "signal_ay_equiv_std": float(params.g * np.sin(ref_sig)),
        "vx_r_std": float(np.nanstd(s.vx * s.r)),
        "kin_residual_rms_deg": float(np.degrees(np.sqrt(np.mean(resid ** 2)))),
        "accel_quantum": quantum(acc[:, 1]),
        "gyro_quantum": quantum(gyr[:, 2]),
        "steer_quantum_deg": quantum(steer),
        "accel_rate_hz": float(1.0 / np.median(np.diff(acc_t))),
        "kin_tau_sweep": tau_sweep,
        "yaw_steer_corr": _r(np.nan_to_num(s.delta_f), np.nan_to_num(s.r)),
    }
    sens = {}
    if sensitivity:
        suv = VehicleParams()
        log_suv = load_comma2k19(path, params=suv)
        sens["suv"] = {}
        for name in names:
            est = estimators.make(name, params=suv).run(log_suv.signals)
            sens["suv"][name] = _score(t, _fill_invalid(est.theta, est.valid),
                                       _fill_invalid(est.phi_b, est.valid), est.valid, ref,
                                       m_fit, m_sc, tau, dt)
        if "pif-modified" in names:
            sens["pif_Q"] = {}
            for Q in (0.01, 0.1, 1.0, 10.0):
                est = estimators.make("pif-modified", params=params, Q=Q).run(s)
                sens["pif_Q"][Q] = _score(t, _fill_invalid(est.theta, est.valid),
                                          _fill_invalid(est.phi_b, est.valid), est.valid, ref,
                                          m_fit, m_sc, tau, dt)
    settings = {"tau": tau, "warmup_s": warmup_s, "fit_fraction": fit_fraction, "dt": dt,
                "path": str(path)}
    return ValidationResult(scores=scores, params=params, t=t, reference=ref_s, estimates=smoothed,
                            split_time=float(t[i_split]), data=data, sensitivity=sens,
                            settings=settings)

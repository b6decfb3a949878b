"""Score every estimator against the pose-derived roll of a comma2k19 segment.

The scoring is :mod:`roadbank.validation.scoring` (the same for every data
set: speed gate, warm-up, zero-phase smoothing tau = 2/3 s, r and RMS smoothed
and raw). Specific to comma2k19:

* reader :func:`roadbank.io.comma2k19.load_comma2k19` (100 Hz uniform grid, ISO
  signs, reference roll from the global pose);
* the reference is *device* roll = bank + body roll + a constant mounting offset
  (plus accelerometer bias on the estimate side): the offset is fitted on the
  first 30 % of the scored samples (``fit_fraction``) and r/RMS come from the rest;
* the phone IMU's vibration is about 14 times the bank signal, so the smoothed
  scores are the meaningful ones here (raw ones are reported too);
* data-limit numbers (vibration, resolution, steering term) and a sensitivity
  study (paper SUV parameters, PIF Q sweep).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import estimators
from ..io.comma2k19 import CHANNELS, POSE, SegmentSource, load_comma2k19
from ..io.errors import LogError
from ..params import VehicleParams
from ..vehicle import described_car, undescribed_params
from .scoring import (VALIDATION_NAMES, Score, Scored, Scoring, covered_span, hold_invalid, lowpass, pearson_r,
                      reference_covered, run_and_score, score)

__all__ = ["SEDAN", "ValidationResult", "comma2k19_outcome", "named_apart", "segment_name", "unique_segments",
           "validate_comma2k19", "lowpass"]

#: Plausible compact/mid-size sedan (Toyota Prius/Corolla/Camry, Honda Civic/Accord,
#: Lexus ES class: most comma2k19 cars). The car is not identified in the data.
SEDAN = VehicleParams(m=1450.0, ms=1300.0, Iz=2400.0, Lf=1.08, Lr=1.62, Cf=120_000.0,
                      Cr=130_000.0, steering_ratio=15.0, h_cg=0.55, h_roll=0.40,
                      k_roll=80_000.0, c_roll=5_000.0, Ixx=500.0, track_f=1.55, track_r=1.55,
                      wheel_radius=0.31)


@dataclass
class ValidationResult:
    """One log validated: scores per estimator and the traces to plot.

    ``reference``/``estimates`` are smoothed (rad; estimates + their offset),
    ``run`` the :class:`~roadbank.validation.scoring.Scored` (raw traces, masks),
    ``valid`` each estimator's not-valid flags (name -> bool array, True = valid).
    """

    scores: dict[str, Score]
    params: VehicleParams
    t: np.ndarray
    reference: np.ndarray           # rad, smoothed
    estimates: dict[str, np.ndarray]  # theta, rad, smoothed + offset
    split_time: float
    data: dict = field(default_factory=dict)       # data-limit numbers
    sensitivity: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    run: Scored | None = None
    label: str = ""
    dataset: str = "comma2k19"
    valid: dict = field(default_factory=dict)


def segment_name(path) -> str:
    """The name a comma2k19 segment is reported under: its folder's name, with the route folder's in front
    when the folder is a bare segment number (comma2k19 keeps ``Chunk_N/<route>/<segment number>/``), e.g.
    ``comma2k19-example`` or ``b0c9d2329ad1606b|2018-07-27--06-03-57/3``."""
    p = Path(path).resolve() if Path(path).name in ("", ".", "..") else Path(path)
    return f"{p.parent.name}/{p.name}" if p.name.isdigit() and p.parent.name else p.name


def unique_segments(paths) -> tuple[list[Path], list[str]]:
    """``paths`` (comma2k19 segment folders) with each segment once, and notes on what was left out or
    shares a name: the rule of :func:`roadbank.validation.kitti.unique_drives`.

    Returns
    -------
    segments : list of Path
        In the order given; a segment reached a second time (the same folder once links are resolved,
        e.g. a link to a segment next to it) is left out.
    notes : list of str
        One per segment left out, naming it and both paths; one per name two kept folders share
        (:func:`segment_name`: both are scored, reported under that one name).
    """
    kept: dict[Path, Path] = {}
    notes = []
    for p in map(Path, paths):
        try:
            key = p.resolve()
        except (OSError, RuntimeError):     # a loop of links: validating it says what is wrong
            key = p
        if key in kept:
            notes.append(f"comma2k19 segment {segment_name(p)} given more than once (as {kept[key]}, then as {p}; "
                         f"the same folder {key}): scored once")
            continue
        kept[key] = p
    segments = list(kept.values())
    names = [segment_name(p) for p in segments]
    for name in sorted({n for n in names if names.count(n) > 1}):
        where = " and ".join(str(p) for p, n in zip(segments, names) if n == name)
        notes.append(f"two folders hold a comma2k19 segment named {name} ({where}): both scored, each named by "
                     "its folder's path")
    return segments, notes


def named_apart(results: list[ValidationResult]) -> list[ValidationResult]:
    """``results`` with the label of every segment whose name another one shares replaced by its folder's
    path (the note of :func:`unique_segments`), so that each has its own row, section and figure."""
    labels = [r.label for r in results]
    for r in results:
        if labels.count(r.label) > 1:
            r.label = str(r.settings.get("path", r.label))
    return results


def comma2k19_outcome(path, **kwargs) -> tuple:
    """``(ValidationResult, None)`` of one comma2k19 segment, or ``(None, reason)`` when it cannot be read
    (a :class:`~roadbank.io.LogError` naming the file, or an OSError): one task per segment, so that one
    bad segment never loses the others. ``kwargs``: those of :func:`validate_comma2k19`."""
    try:
        return validate_comma2k19(path, **kwargs), None
    except (ValueError, OSError) as exc:       # LogError is a ValueError
        return None, str(exc)


def validate_comma2k19(path, names=None, params: VehicleParams | None = None, tau: float = 2.0 / 3.0,
                       warmup_s: float = 5.0, fit_fraction: float = 0.3,
                       sensitivity: bool = True, tuning=None, sensors=None, trim: bool = True) -> ValidationResult:
    """Run every estimator on a comma2k19 segment and score it against the pose roll.

    Parameters
    ----------
    path : path-like
        Segment directory.
    names : sequence of str, optional
        Estimators (default: all of :data:`roadbank.estimators.NAMES` and the default without the roll rate,
        :data:`~roadbank.validation.scoring.VALIDATION_NAMES`).
    params : VehicleParams, optional
        The car; default the rule for a car that is not described
        (:func:`roadbank.vehicle.undescribed_params`, as every command uses).
    tau : float
        Smoothing time constant (s) applied to the reference and all estimates.
    warmup_s, fit_fraction : float
        Warm-up dropped (s); fraction of the rest used to fit the offset.
    sensitivity : bool
        Also score with the paper's SUV parameters and a PIF Q sweep.
    tuning : mapping, optional
        ``{estimator: {option: value}}`` for the main scores and the rear trim's trial designs (a vehicle file's
        ``[tuning]``, read as :func:`roadbank.vehicle.tuning_of` reads it).
    sensors : roadbank.vehicle.SensorSpec, optional
        The car's sensors (a vehicle file's ``[sensors]``; default the paper's ESP): the
        default PIFs' ``R`` is their noise density at the log's rate.
    trim : bool
        With ``params``: whether its rear cornering stiffness is trimmed to the segment
        (:func:`roadbank.vehicle.described_car`; False for a stiffness measured on the car,
        :func:`roadbank.vehicle.trims_rear`).
    """
    described, params = params, params or undescribed_params()
    names = list(names or VALIDATION_NAMES)
    scoring = Scoring(tau=tau, warmup_s=warmup_s, fit_fraction=fit_fraction)
    log = load_comma2k19(path, params=params)
    if log.reference_roll is None:
        raise LogError(f"{path}: nothing to score: no reference roll ('{POSE}' missing, or none of its frames has a "
                       "fix)")
    # the stretch the pose covers, as run_and_score reads it (NaN where it has no frame: not scored)
    ref, covered = reference_covered(log.reference_roll)
    if not covered.any():
        raise LogError(f"{path}: nothing to score: the pose has no frame with a fix within the inputs' time span "
                       f"({log.signals.t[0]:.3f} to {log.signals.t[-1]:.3f} s)")
    cut = covered_span(covered)
    s, ref, covered = log.signals[cut], ref[cut], covered[cut]
    t = s.t
    dt = float(np.median(np.diff(t)))
    # a car not described: designed for the one that fits the segment (read with the static one)
    design = (undescribed_params(s) if described is None
              else described_car(s, params, trim=trim, sensors=sensors, tuning=tuning))
    run = run_and_score(s, log.reference_roll[cut], names, design, scoring, per_estimator=tuning, sensors=sensors,
                        described=described is not None)
    scores, smoothed = run.scores, run.estimates
    m_fit, m_sc = run.fit, run.scored
    m_all = m_fit | m_sc
    if not (m_fit.any() and m_sc.any()):        # a short, slow or standing segment: nothing to fit or to score
        raise LogError(f"{path}: nothing to score: {np.count_nonzero(m_fit)} samples to fit the offset on and "
                       f"{np.count_nonzero(m_sc)} to score (moving at >= the scoring speed after the {warmup_s:g} s "
                       f"warm-up, the first {fit_fraction:g} of them fitting; {t[-1] - t[0]:.1f} s read)")
    i_split = int(np.flatnonzero(m_sc)[0])

    # ------------------------------------------------------------ data limits
    # the raw samples as the reader holds them: rows in time order, a broken or missing steering file left out
    raw = SegmentSource(path, params)
    acc_t = raw.times[CHANNELS["lateral_acceleration"][0]]
    acc_y = raw.data[CHANNELS["lateral_acceleration"][0]]
    gyr_z = raw.data[CHANNELS["yaw_rate"][0]]
    steer = raw.data.get(CHANNELS["steering_wheel_angle"][0], np.zeros(0))

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
        tau_sweep[tt] = pearson_r(ks[m_sc], rs2[m_sc])
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
        "ref_range_deg": (float(np.degrees(ref[covered].min())), float(np.degrees(ref[covered].max()))),
        "ref_std_deg_scored": float(np.degrees(ref_sig)),
        "ref_std_deg_raw_scored": float(np.degrees(np.std(ref[m_sc]))),
        "ref_highfreq_std_deg": float(np.degrees(np.std((ref - lowpass(ref, 0.2, dt))[covered]))),
        "ay_vibration_std": float(np.std((s.ay - box)[inner])),
        "ay_1s_mean_std": float(np.std(box[inner])),
        "signal_ay_equiv_std": float(params.g * np.sin(ref_sig)),
        "vx_r_std": float(np.nanstd(s.vx * s.r)),
        "kin_residual_rms_deg": float(np.degrees(np.sqrt(np.mean(resid ** 2)))),
        "accel_quantum": quantum(acc_y),
        "gyro_quantum": quantum(gyr_z),
        "steer_quantum_deg": quantum(steer),
        "accel_rate_hz": float(1.0 / np.median(np.diff(acc_t))),
        "kin_tau_sweep": tau_sweep,
        "yaw_steer_corr": pearson_r(np.nan_to_num(s.delta_f), np.nan_to_num(s.r)),
    }
    sens: dict[str, Any] = {}
    if sensitivity:
        other = VehicleParams()
        log_other = load_comma2k19(path, params=other)
        # the same masks: the segment's time base and speed do not depend on the car
        sens["suv"] = run_and_score(log_other.signals[cut], log.reference_roll[cut], names, other, scoring).scores
        if "pif-modified" in names:
            sens["pif_Q"] = {}
            for Q in (0.01, 0.1, 1.0, 10.0):   # Table 4 weights with Q varied
                est = estimators.make("pif-modified", params=params, tuning="paper", Q=Q).run(s)
                sens["pif_Q"][Q] = score(t, hold_invalid(est.theta), hold_invalid(est.phi_b), est.valid,
                                         ref, m_fit, m_sc, scoring)
    settings = {"tau": tau, "warmup_s": warmup_s, "fit_fraction": fit_fraction, "dt": dt,
                "path": str(path)}
    return ValidationResult(scores=scores, params=design, t=t, reference=run.reference, estimates=smoothed,
                            split_time=float(t[i_split]), data=data, sensitivity=sens,
                            settings=settings, run=run, label=segment_name(path),
                            dataset="comma2k19", valid=run.valid)

"""``identify``: what a set of logs can tell about a car (see docs/identification.md).

Steps: put each log on a uniform grid and find its straights, quasi-steady
corners and linear-range driving (:mod:`.segments`); sensor offsets from the
straights (:mod:`.offsets`); the roll gain when a roll reference is present
(:mod:`.roll`); understeer gradient, axle cornering stiffnesses and steering
offset from one regression on the tyre forces (:mod:`.stiffness`). A log with
no usable driving is reported and left out; a quantity the logs do not excite
is refused with the reason, never guessed.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from ..models.roll import roll_stiffness_for_gain, steady_roll_gain
from ..params import VehicleParams
from .offsets import Offsets, straight_offsets
from .pair import PairCheck, stiffness_pair
from .prepare import to_grid
from .results import IdentificationResult, LogReport, Quantity, refused
from .roll import identify_roll_gain
from .segments import Segmented, segment
from .settings import IdentifySettings
from .stiffness import identify_stiffness

#: usable driving (s at >= v_min) a log needs to be used at all
MIN_USABLE_S = 20.0

#: a log whose steering angle and yaw rate correlate below this over its turns (-, normalised about the
#: straight-ahead values) has the steering sign flipped: every stable car steers into its turn (the
#: steady yaw rate per steering angle is positive below the critical speed), so a left turn with a
#: negative steering angle is a channel map's sign, not the car; the correct sign gives 0.9 .. 1
STEERING_SIGN_CORR = -0.5

#: the band (-) of a log's steering gain in its turns, the road-wheel angle per kinematic angle ``L r / vx``
#: (:func:`steering_gain`): a road car's is ``1 + Kus vx^2 / L`` in its linear range, 1.2-2.1 on the simulated
#: identification drives of the four shipped cars, a sports car and a loaded light truck (5.5 deg/g) at 12-31 m/s,
#: and below 10 for 15 deg/g at 35 m/s; above 0.15 for an oversteering car short of its critical speed. An angle in
#: rad declared as deg is 57 times too small (0.02-0.04 on those drives), a steering-wheel angle read as the
#: road-wheel angle a steering ratio (12-20) too large: outside the band, each gave a Kus refused as "needs more
#: cornering" (or absurd) and a steering offset in the wrong unit written to the file
STEERING_GAIN_BAND = (0.15, 10.0)

#: the channels the identification reads: Signals field -> how the messages name it
CHANNEL_NAMES = {"vx": "speed (vx)", "ay": "lateral acceleration (ay)", "r": "yaw rate (r)",
                 "delta_f": "steering angle (delta_f)"}

#: how a log without a steering angle is named (it gives the straights' offsets only)
NO_STEERING = "no steering channel"

ORDER = ("Cf", "Cr", "Kus", "steering_offset", "yaw_rate_offset", "ay_offset", "roll_gain")


def _channel_problem(sig) -> str:
    """Why a log cannot be identified from for a channel it lacks (every sample NaN); "" if it has them all."""
    missing = [name for name in CHANNEL_NAMES if not np.isfinite(np.asarray(getattr(sig, name), float)).any()]
    if not missing:
        return ""
    if missing == ["delta_f"]:
        return (f"{NO_STEERING}: the steering angle (delta_f) holds no value; the understeer gradient, the "
                "stiffnesses and the steering offset need the road-wheel or steering-wheel angle (a channel map's "
                "road_wheel_angle or steering_wheel_angle, docs/io.md)")
    return f"no {' and no '.join(CHANNEL_NAMES[m] for m in missing)}: every sample is missing"


def _usable_problem(seg, s: IdentifySettings, top_speed: float) -> str:
    """Why a log has too little driving to use ("" if it has enough); ``top_speed`` (m/s) its highest speed."""
    secs = seg.seconds
    if secs["usable"] >= MIN_USABLE_S:
        return ""
    need = f"at least {MIN_USABLE_S:g} s of driving at >= {s.v_min:g} m/s needed"
    if secs["total"] < MIN_USABLE_S:
        return f"too short: {secs['total']:.1f} s of log; {need}"
    if not seg.pieces and not top_speed >= s.v_min:
        return (f"too slow: top speed {top_speed:.1f} m/s in {secs['total']:.0f} s of log; "
                f"identification needs >= {MIN_USABLE_S:g} s of driving at >= {s.v_min:g} m/s")
    return (f"too little driving at >= {s.v_min:g} m/s: {secs['usable']:.1f} s of {secs['total']:.0f} s in stretches "
            f"of >= {s.min_run:g} s; {need}")


def _straight_median(seg, name: str) -> float:
    """Median of a :class:`~.segments.Piece` channel ``name`` over a log's straights (its unit; 0 without any)."""
    x = np.concatenate([getattr(p, name)[p.straight] for p in seg.pieces]) if seg.pieces else np.zeros(0)
    return float(np.median(x)) if len(x) else 0.0


def steering_sign(seg, s: IdentifySettings) -> tuple[float, float]:
    """How a log's steering angle follows its yaw rate in the turns: ``(correlation, seconds)``.

    The correlation (-) of ``delta - delta0`` with ``r - r0`` about their median values on the straights
    (0 without straights), over the samples in the linear range that turn (``|vx (r - r0)|`` at least
    ``s.corner_ay``); ``seconds`` (s) of such samples. NaN when fewer than ``s.corner_min`` seconds turn;
    0 when the steering angle does not change over them (a dead channel).
    """
    d0, r0 = _straight_median(seg, "delta"), _straight_median(seg, "r")
    sdr = sdd = srr = 0.0
    n = 0
    for p in seg.pieces:
        turn = p.regress & (np.abs(p.vx * (p.r_f - r0)) >= s.corner_ay)
        dd, rr = p.delta[turn] - d0, p.r[turn] - r0
        sdr, sdd, srr, n = sdr + float(dd @ rr), sdd + float(dd @ dd), srr + float(rr @ rr), n + int(turn.sum())
    secs = n / seg.fs
    if secs < s.corner_min or srr <= 0:
        return float("nan"), secs
    if sdd <= 0:
        return 0.0, secs
    return sdr / np.sqrt(sdd * srr), secs


def _sign_problem(seg, s: IdentifySettings) -> str:
    """Why a log's steering angle cannot be used: its sign looks flipped, or it never changes while the car
    turns ("" if neither, or if it cannot be told)."""
    corr, secs = steering_sign(seg, s)
    if corr == 0.0:
        return (f"dead steering channel: the steering angle (delta_f) never changes over {secs:.0f} s of turning; "
                f"check the channel map's road_wheel_angle or steering_wheel_angle column (docs/io.md)")
    if not corr < STEERING_SIGN_CORR:
        return ""
    return (f"steering sign flipped: the steering angle (delta_f) and the yaw rate correlate negatively over "
            f"{secs:.0f} s of turning (correlation {corr:.2f}): a left turn reads as a negative steering angle, "
            f"which no car does (the understeer gradient would come out absurd); flip the steering channel's sign "
            f"in the channel map (invert = true on road_wheel_angle or steering_wheel_angle, docs/io.md)")


def steering_gain(seg, s: IdentifySettings, wheelbase: float) -> tuple[float, float]:
    """How large a log's steering angle is against the kinematic angle in its turns: ``(gain, seconds)``.

    The least-squares slope (-) of ``delta - delta0`` on ``L (r - r0) / vx`` (``L`` = ``wheelbase``, m; road-wheel
    angle in rad, yaw rate in rad/s, speed in m/s), both about their median values on the straights (0 without
    straights), over the turning samples of :func:`steering_sign`; ``seconds`` (s) of them. A road car's gain
    is ``1 + Kus vx^2 / L`` (:data:`STEERING_GAIN_BAND`). NaN when fewer than ``s.corner_min`` seconds turn.
    """
    d0, r0 = _straight_median(seg, "delta"), _straight_median(seg, "r")
    skk = sdk = 0.0
    n = 0
    for p in seg.pieces:
        turn = p.regress & (np.abs(p.vx * (p.r_f - r0)) >= s.corner_ay)
        kin = wheelbase * (p.r_f[turn] - r0) / p.vx[turn]
        skk, sdk, n = skk + float(kin @ kin), sdk + float((p.delta[turn] - d0) @ kin), n + int(turn.sum())
    secs = n / seg.fs
    if secs < s.corner_min or skk <= 0:
        return float("nan"), secs
    return sdk / skk, secs


def _gain_problem(seg, s: IdentifySettings, wheelbase: float, ratio: float) -> str:
    """Why a log's steering angle is of the wrong size for the car's turns ("" if it is not, or cannot be told);
    ``wheelbase`` (m) and the steering ``ratio`` (-) of the base vehicle."""
    gain, secs = steering_gain(seg, s, wheelbase)
    lo, hi = STEERING_GAIN_BAND
    if not (gain < lo or gain > hi):
        return ""
    size = (f"over {secs:.0f} s of turning the steering angle (delta_f) is {gain:.3g} times the kinematic angle "
            f"L r / vx (a road car's is 1 + Kus vx^2 / L, between {lo:g} and {hi:g})")
    if gain <= 0:
        cause = "it does not follow the turns: a channel that is not the steering angle"
    elif gain < lo:
        cause = ("far too small: a steering channel in rad declared as deg (a factor 57), or a steering ratio far "
                 "too large")
    else:
        cause = (f"far too large: a steering channel in deg declared as rad (a factor 57), or a steering-wheel angle "
                 f"read as the road-wheel angle (a factor of the steering ratio; the base vehicle's is {ratio:g})")
    return (f"steering angle of the wrong size: {size}, {cause}; check the unit and the role (road_wheel_angle or "
            f"steering_wheel_angle) of the channel map's steering column and the steering ratio (docs/io.md)")


def _merge_refusal(straights: Quantity, regression: Quantity) -> Quantity:
    """The regression's yaw-rate offset, or both refusal reasons (straights and speed spread)."""
    if regression.ok:
        return regression
    return refused(straights.name, straights.unit, f"{straights.refused}; {regression.refused}")


def _samples_digest(sig) -> str:
    """SHA-256 of a log's time base and ESP channels (the bytes of ``t, vx, ay, r, delta_f``)."""
    h = hashlib.sha256()
    for a in (sig.t, sig.vx, sig.ay, sig.r, sig.delta_f):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return h.hexdigest()


def _examine(log, p: VehicleParams, s: IdentifySettings, seen: dict[str, Path]
             ) -> tuple[LogReport, Segmented | None, bool]:
    """What one log can give: ``(report, segmented log or None, has a steering angle)``.

    A log without a steering angle (every sample NaN) whose driving is usable gives the straights' yaw-rate
    and ay offsets (which need no steering) and nothing else: its report is used, with a problem saying so.
    ``seen`` (digest of a log's samples -> its source) is updated; a copy of an earlier log is not used.
    """
    source = Path(getattr(log, "source", "") or "")
    sig = log.signals
    missing = _channel_problem(sig)
    steering = not missing
    if missing and not missing.startswith(NO_STEERING):
        return LogReport(source, False, missing), None, steering
    digest = _samples_digest(sig)
    if digest in seen:      # a copy is no new evidence: counted twice it passes the corner minimum
        return (LogReport(source, False, f"the same samples as {seen[digest]}: a copy adds no evidence"),
                None, steering)
    seen[digest] = source
    delta = sig.delta_f if steering else np.zeros(len(sig.t))     # read by no quantity of such a log
    try:
        seg = segment(to_grid(sig.t, sig.vx, sig.ay, sig.r, delta, log.reference_roll), s)
    except Exception as exc:  # one log that cannot be analysed never loses the others
        return LogReport(source, False, f"cannot be analysed: {type(exc).__name__}: {exc}"), None, steering
    vx = np.asarray(sig.vx, float)
    top = float(np.nanmax(vx)) if np.isfinite(vx).any() else float("nan")
    problem = _usable_problem(seg, s, top)
    if not problem and steering:
        problem = _sign_problem(seg, s) or _gain_problem(seg, s, p.L, p.steering_ratio)
    if problem:
        return LogReport(source, False, problem, dict(seg.seconds), seg.n_corners, seg.speed_range), None, steering
    note = "" if steering else f"{missing}; used for the yaw-rate and ay offsets only (straight driving)"
    return LogReport(source, True, note, dict(seg.seconds), seg.n_corners, seg.speed_range), seg, steering


def identify(logs, params: VehicleParams | None = None, settings: IdentifySettings | None = None,
             check: PairCheck | None = None) -> IdentificationResult:
    """Identify a car's parameters and sensor offsets from driving logs.

    Parameters
    ----------
    logs : iterable of roadbank.io.Log
        Logs of the same car (``signals`` in SI / ISO 8855; ``reference_roll`` in
        rad when present).
    params : VehicleParams, optional
        Base vehicle: m, Iz, Lf, Lr and the roll data are taken as known.
        Default: the paper's SUV.
    settings : IdentifySettings, optional
    check : callable, optional
        ``params -> ""`` when a Cf, Cr pair with one stiffness derived from ``Kus`` may be written, else
        why not (``roadbank identify`` passes the vehicle file's plausibility checks). Default: positive
        values only.

    Returns
    -------
    IdentificationResult
        Every quantity with its value and standard uncertainty, or the reason it
        was refused; a report per log; ``params`` with the identified Cf, Cr (or, one of them refused, the
        identified one and the other derived from ``Kus``: ``derived``; if that is not possible, the base
        pair, with a warning when it contradicts the identified ``Kus``) and the roll stiffness that gives
        the identified roll gain.
    """
    p = params or VehicleParams()
    s = settings or IdentifySettings()
    reports: list[LogReport] = []
    segs: list[Segmented] = []
    offset_segs: list[Segmented] = []
    seen: dict[str, Path] = {}        # digest of a log's samples -> the first log that had them
    for log in logs:
        report, seg, steering = _examine(log, p, s, seen)
        reports.append(report)
        if seg is not None:
            (segs if steering else offset_segs).append(seg)
    base_roll = steady_roll_gain(p)
    per_log, q_r, q_a = straight_offsets(segs + offset_segs, s, p.g, base_roll)
    per_log = per_log[:len(segs)]     # the logs without steering give the offsets, nothing the regression reads
    # below, a quantity that is ``ok`` has a float value and std
    pooled = Offsets(q_r.value, q_a.value) if q_r.ok and q_a.ok else Offsets(0.0, 0.0)  # type: ignore[arg-type]
    offs = [o if o is not None else pooled for o in per_log]
    quantities = {"yaw_rate_offset": q_r, "ay_offset": q_a}
    roll_gain, roll_std = base_roll, s.roll_gain_rel_std * base_roll
    if any(pc.roll is not None for seg in segs for pc in seg.pieces):
        q = identify_roll_gain(segs, offs, s)
        quantities["roll_gain"] = q
        if q.ok and q.value > 0:  # type: ignore[operator]
            roll_gain, roll_std = q.value, q.std  # type: ignore[assignment]
    offsets_std = (q_r.std, q_a.std) if q_r.ok and q_a.ok else None
    fit = identify_stiffness(segs, offs, p, roll_gain, s, offsets_std, roll_std)  # type: ignore[arg-type]
    if "yaw_rate_offset" in fit:  # no straights: the regression's estimate or both reasons
        fit["yaw_rate_offset"] = _merge_refusal(q_r, fit["yaw_rate_offset"])
    if offset_segs and not segs:      # say what is missing, not that the offsets-only logs have no corners
        why = (f"{NO_STEERING}: none of the logs used has a steering angle (delta_f) ({len(offset_segs)} without one "
               f"gave the yaw-rate and ay offsets only)")
        fit = {k: refused(k, q.unit, why) if not q.ok else q for k, q in fit.items()}
    quantities.update(fit)
    quantities = {k: quantities[k] for k in ORDER if k in quantities}
    out_p, derived, warnings = stiffness_pair(quantities, p, check)
    rg = quantities.get("roll_gain")
    if rg is not None and rg.ok and rg.value > 0 and p.ms * p.h_roll > 0:  # type: ignore[operator]
        out_p = out_p.replace(k_roll=roll_stiffness_for_gain(p, rg.value))  # type: ignore[arg-type]
    return IdentificationResult(quantities, reports, out_p, derived, warnings)

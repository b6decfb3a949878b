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

from pathlib import Path

from ..models.roll import steady_roll_gain
from ..params import VehicleParams
from .offsets import Offsets, straight_offsets
from .prepare import to_grid
from .results import IdentificationResult, LogReport, Quantity, refused
from .roll import identify_roll_gain
from .segments import segment
from .settings import IdentifySettings
from .stiffness import identify_stiffness

#: usable driving (s at >= v_min) a log needs to be used at all
MIN_USABLE_S = 20.0

ORDER = ("Cf", "Cr", "Kus", "steering_offset", "yaw_rate_offset", "ay_offset", "roll_gain")


def _usable_problem(seg, s: IdentifySettings) -> str:
    secs = seg.seconds
    if secs["usable"] >= MIN_USABLE_S:
        return ""
    if not seg.pieces:
        return (f"too slow: no stretch of >= {s.min_run:g} s at >= {s.v_min:g} m/s in {secs['total']:.0f} s "
                f"of log; identification needs >= {MIN_USABLE_S:g} s of driving at >= {s.v_min:g} m/s")
    return (f"too little driving at >= {s.v_min:g} m/s: {secs['usable']:.1f} s of {secs['total']:.0f} s; "
            f"needs >= {MIN_USABLE_S:g} s")


def _merge_refusal(straights: Quantity, regression: Quantity) -> Quantity:
    """The regression's yaw-rate offset, or both refusal reasons (straights and speed spread)."""
    if regression.ok:
        return regression
    return refused(straights.name, straights.unit, f"{straights.refused}; {regression.refused}")


def identify(logs, params: VehicleParams | None = None, settings: IdentifySettings | None = None
             ) -> IdentificationResult:
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

    Returns
    -------
    IdentificationResult
        Every quantity with its value and standard uncertainty, or the reason it
        was refused; a report per log; ``params`` with the identified Cf, Cr.
    """
    p = params or VehicleParams()
    s = settings or IdentifySettings()
    reports, segs = [], []
    for log in logs:
        source = Path(getattr(log, "source", "") or "")
        sig = log.signals
        try:
            seg = segment(to_grid(sig.t, sig.vx, sig.ay, sig.r, sig.delta_f, log.reference_roll), s)
        except Exception as exc:  # one log that cannot be analysed never loses the others
            reports.append(LogReport(source, False, f"cannot be analysed: {type(exc).__name__}: {exc}"))
            continue
        problem = _usable_problem(seg, s)
        reports.append(LogReport(source, not problem, problem, dict(seg.seconds), seg.n_corners, seg.speed_range))
        if not problem:
            segs.append(seg)
    base_roll = steady_roll_gain(p)
    per_log, q_r, q_a = straight_offsets(segs, s, p.g, base_roll)
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
    quantities.update(fit)
    quantities = {k: quantities[k] for k in ORDER if k in quantities}
    out_p = p
    if quantities["Cf"].ok and quantities["Cr"].ok:
        out_p = p.replace(Cf=quantities["Cf"].value, Cr=quantities["Cr"].value)  # type: ignore[arg-type]
    return IdentificationResult(quantities, reports, out_p)

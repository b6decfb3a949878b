"""Run estimators on a simulated log and score them against the plant's truth.

References: ``bank`` — estimated ``phi_b`` against the plant's
contact-height bank; ``theta`` — raw observer ``theta`` against the plant's
``theta = phi_b + phi``; ``theta_ref`` — raw ``theta`` against the paper's
test-track reference (eq 45) computed from the sensors' ``ay, vx, r`` and the
true ``dvy/dt`` (the optical sensor), low-passed with 2/3 s.

Scored samples are the same for every estimator: those whose inputs are usable
(finite, ``vx >= v_min``). An estimator's own flag is not used to drop samples —
an output it flags as implausible (``|theta| > max_angle``) is scored with its clipped angle —
and the share of scored samples it flagged is reported as ``flagged_pct``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import estimators as est_mod
from ..params import VehicleParams
from ..signals import Estimate
from .metrics import error_metrics
from .reference import theta_reference

REFERENCES = ("bank", "theta", "theta_ref")


@dataclass
class Evaluation:
    """Estimates of several estimators on one run and their tidy metric rows."""

    scenario: str
    condition: str
    estimates: dict[str, Estimate]
    references: dict
    rows: list[dict] = field(default_factory=list)


def reference_angles(sim) -> dict:
    """Reference angles (rad) of a :class:`roadbank.sim.SimResult` keyed by :data:`REFERENCES`."""
    s, tr = sim.signals, sim.truth
    return {"bank": tr.phi_b, "theta": tr.theta,
            "theta_ref": theta_reference(s.t, s.ay, tr.dvy_dt, s.vx, s.r)}


def usable_samples(signals, v_min: float) -> np.ndarray:
    """Samples whose inputs any estimator can use: all channels finite and ``vx >= v_min`` (m/s)."""
    ok = np.isfinite(signals.vx) & (signals.vx >= v_min)
    for a in (signals.ay, signals.r, signals.delta_f):
        ok &= np.isfinite(a)
    return ok


def evaluate(sim, names=est_mod.NAMES, params: VehicleParams | None = None, *, settle: float = 2.0,
             tuning: dict | None = None) -> Evaluation:
    """Run each estimator of ``names`` on ``sim.signals`` and score it.

    Parameters
    ----------
    sim : roadbank.sim.SimResult
    names : estimator names
    params : design parameters of the estimators (default: paper Table 1)
    settle : seconds excluded from scoring at the start
    tuning : optional ``{name: {option: value}}`` passed to :func:`roadbank.estimators.make`

    Returns
    -------
    Evaluation with rows ``{scenario, condition, estimator, reference, metric, value}``
    (angles in degrees, times in seconds).
    """
    refs = reference_angles(sim)
    s = sim.signals
    t = s.t
    estimates, rows = {}, []
    for name in names:
        est = est_mod.make(name, params, **(tuning or {}).get(name, {}))
        e = est.run(s)
        estimates[name] = e
        usable = usable_samples(s, est.v_min)
        row = {"scenario": sim.scenario, "condition": sim.condition, "estimator": name}
        flagged = float(100.0 * np.mean(~e.valid[usable])) if usable.any() else float("nan")
        for ref_name, ref in refs.items():
            angle = e.phi_b if ref_name == "bank" else e.theta
            m = error_metrics(t, angle, ref, usable, settle=settle)
            for metric, value in m.as_dict().items():
                if metric != "n":
                    rows.append({**row, "reference": ref_name, "metric": metric, "value": value})
            rows.append({**row, "reference": ref_name, "metric": "flagged_pct", "value": flagged})
    return Evaluation(sim.scenario, sim.condition, estimates, refs, rows)

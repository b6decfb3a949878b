"""Check the identification on simulated drives whose parameters and sensor offsets are known.

:func:`simulate_case` drives a :func:`roadbank.sim.drives.mixed_drive` with a plant whose
tyres differ from the base vehicle (``Cf``, ``Cr`` scaled) and with sensor
offsets injected; :func:`check_case` identifies the car from that log (with
the *base* vehicle, as a user would) and compares every quantity with the truth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..io import Log
from ..models.bicycle import understeer_gradient
from ..models.roll import steady_roll_gain
from ..params import VehicleParams
from ..sim import PlantParams, SensorConfig, run
from .identify import identify
from .settings import IdentifySettings
from ..sim.drives import DriveSpec, mixed_drive


@dataclass(frozen=True)
class SimCase:
    """A simulated drive with known truth (SI).

    ``params``: the base vehicle (what the user knows); the plant's axle
    stiffnesses are ``scale_front * Cf`` and ``scale_rear * Cr``. Offsets added to
    the sensors: ``r_bias`` (rad/s), ``ay_bias`` (m/s^2), ``swa_bias`` (rad,
    steering-wheel angle). ``with_roll``: the log carries the true roll
    ``theta`` (bank + body roll) as its roll reference.
    """

    name: str = "suv"
    params: VehicleParams = field(default_factory=VehicleParams)
    sensors: SensorConfig = field(default_factory=SensorConfig)
    scale_front: float = 1.15
    scale_rear: float = 0.9
    r_bias: float = math.radians(0.5)
    ay_bias: float = 0.15
    swa_bias: float = math.radians(3.0)
    seed: int = 1
    drive: DriveSpec = field(default_factory=DriveSpec)
    with_roll: bool = True


def simulate_case(case: SimCase) -> tuple[Log, dict[str, float]]:
    """Simulate ``case``; returns the log and the true value of every identified quantity (SI)."""
    p = case.params
    sens = case.sensors
    sens = sens.replace(yaw_rate=_with_bias(sens.yaw_rate, case.r_bias), ay=_with_bias(sens.ay, case.ay_bias),
                        steering=_with_bias(sens.steering, case.swa_bias))
    plant = PlantParams(vehicle=p, cornering_scale_front=case.scale_front, cornering_scale_rear=case.scale_rear)
    res = run(mixed_drive(case.seed, case.drive), plant=plant, sensors=sens, seed=case.seed)
    log = Log(signals=res.signals, reference_roll=res.truth.theta if case.with_roll else None,
              source=Path(f"sim:{case.name}:seed{case.seed}"))
    true_p = p.replace(Cf=case.scale_front * p.Cf, Cr=case.scale_rear * p.Cr)
    truth = {"Cf": true_p.Cf, "Cr": true_p.Cr, "Kus": understeer_gradient(true_p),
             "steering_offset": case.swa_bias / p.steering_ratio, "yaw_rate_offset": case.r_bias,
             "ay_offset": case.ay_bias, "roll_gain": steady_roll_gain(p)}
    return log, truth


def _with_bias(ch, bias: float):
    """A sensor channel spec with its offset set to ``bias``."""
    return replace(ch, bias=bias)


def check_case(case: SimCase, settings: IdentifySettings | None = None) -> list[dict]:
    """Identify ``case`` and compare with the truth.

    Returns
    -------
    list of dict
        Per quantity: ``case, quantity, unit, truth, value, std`` (SI; value/std None if
        refused), ``rel_err`` (-), ``z`` = error / std, ``refused`` (reason or "").
    """
    log, truth = simulate_case(case)
    s = settings or IdentifySettings(straight_bank=case.drive.crown)
    res = identify([log], case.params, s)
    rows = []
    for name, q in res.quantities.items():
        t = truth[name]
        row = {"case": f"{case.name} seed {case.seed}", "quantity": name, "unit": q.unit, "truth": t,
               "value": q.value,
               "std": q.std, "rel_err": None, "z": None, "refused": q.refused or ""}
        if q.ok:
            row["rel_err"] = (q.value - t) / t if t else None
            row["z"] = (q.value - t) / q.std if q.std > 0 else math.inf
        rows.append(row)
    return rows

"""The random draw of one campaign run, reproducible from ``(base_seed, run_id)``.

Each run gets its own generator ``numpy.random.default_rng([base_seed, run_id])``,
so run ``k`` is the same whatever the number of runs, the batching, the worker it
lands on or the order runs finish in — which is what makes resuming exact.

Perturbations (around the design values of the car -- :class:`roadbank.VehicleParams`
and the simulator's default sensors, or a :class:`roadbank.vehicle.Vehicle` given to
:meth:`RunSpec.plant_and_sensors`; the estimators keep the design values, only the plant
and sensors change; the drawn biases and misalignment add to the car's own):

============================  =====================================================
plant front cornering stiffness  ``Cf`` x U(0.5, 1.5)
plant rear cornering stiffness   ``Cr`` x U(0.5, 1.5)
mass                             ``m`` (and sprung mass ``ms``) x U(0.8, 1.2)
yaw inertia                      ``Iz`` x U(0.8, 1.2)
road friction                    ``mu`` ~ U(0.3, 1.0)
accelerometer misalignment       U(-2, 2) deg about z (yaw): reads
                                 ``ay cos(a) + ax sin(a)``
sensor noise                     every channel's noise std x U(0.5, 2)
yaw-rate bias                    U(-0.3, 0.3) deg/s
ay bias                          U(-0.05, 0.05) m/s^2
sensor noise seed                drawn from the run generator
============================  =====================================================

The scenario cycles through the paper's scenarios by run id (``run_id mod 5``),
so every scenario gets the same share of the campaign.

A *roll* misalignment of the accelerometer (about x) is not drawn: it adds
``g sin(a)`` to ``ay``, which no estimator using only ESP signals can tell from a
bank of ``a`` (it is physically the same measurement); the yaw misalignment is
what the simulator's sensor model offers (``ay_cross_axis=True``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..sim import PlantParams, SensorConfig

#: the paper's scenarios, in the order the run ids cycle through them
SCENARIO_ORDER = ("const-bank", "bank-lane-change", "s-curve", "track-lane1", "track-lane-change")

#: half-widths / ranges of the perturbations (see the module docstring)
RANGES = {
    "cf_scale": (0.5, 1.5),
    "cr_scale": (0.5, 1.5),
    "mass_scale": (0.8, 1.2),
    "iz_scale": (0.8, 1.2),
    "mu": (0.3, 1.0),
    "misalign_deg": (-2.0, 2.0),
    "noise_scale": (0.5, 2.0),
    "r_bias_dps": (-0.3, 0.3),
    "ay_bias": (-0.05, 0.05),
}

#: the parameter columns of a spec, in the order they are drawn
PARAMS = tuple(RANGES)


@dataclass(frozen=True)
class RunSpec:
    """Everything that defines one campaign run.

    Attributes
    ----------
    run_id : int
        Index of the run in the campaign (0 .. N-1).
    base_seed : int
        Seed of the whole campaign.
    scenario : str
        One of :data:`roadbank.sim.SCENARIOS`.
    cf_scale, cr_scale : float
        Plant front / rear cornering stiffness relative to the design ``Cf``, ``Cr`` (-).
    mass_scale, iz_scale : float
        Plant mass (and sprung mass) and yaw inertia relative to the design (-).
    mu : float
        Road friction coefficient (-).
    misalign_deg : float
        Accelerometer yaw misalignment (deg).
    noise_scale : float
        Factor on every sensor channel's noise standard deviation (-).
    r_bias_dps : float
        Yaw-rate sensor bias (deg/s).
    ay_bias : float
        Lateral accelerometer bias (m/s^2).
    noise_seed : int
        Seed of the sensor noise of the simulator.
    """

    run_id: int
    base_seed: int
    scenario: str
    cf_scale: float = 1.0
    cr_scale: float = 1.0
    mass_scale: float = 1.0
    iz_scale: float = 1.0
    mu: float = 0.85
    misalign_deg: float = 0.0
    noise_scale: float = 1.0
    r_bias_dps: float = 0.0
    ay_bias: float = 0.0
    noise_seed: int = 0

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)

    def plant_and_sensors(self, vehicle=None):
        """``(PlantParams, SensorConfig)`` of this run (the simulator's objects).

        ``vehicle`` (a :class:`roadbank.vehicle.Vehicle`, default the paper's SUV) is the car
        perturbed: its plant (``Vehicle.to_plant()``) and sensors (``SensorSpec.to_sim()``).
        """
        base = PlantParams() if vehicle is None else vehicle.to_plant()
        s = SensorConfig() if vehicle is None else vehicle.sensors.to_sim()
        v = base.vehicle
        vehicle = v.replace(m=v.m * self.mass_scale, ms=v.ms * self.mass_scale, Iz=v.Iz * self.iz_scale)
        plant = base.replace(vehicle=vehicle, mu=self.mu, cornering_scale_front=self.cf_scale,
                             cornering_scale_rear=self.cr_scale)
        k = self.noise_scale
        sensors = s.replace(
            yaw_rate=dataclasses.replace(s.yaw_rate, noise_std=s.yaw_rate.noise_std * k,
                                         bias=s.yaw_rate.bias + math.radians(self.r_bias_dps)),
            ay=dataclasses.replace(s.ay, noise_std=s.ay.noise_std * k, bias=s.ay.bias + self.ay_bias),
            speed=dataclasses.replace(s.speed, noise_std=s.speed.noise_std * k),
            steering=dataclasses.replace(s.steering, noise_std=s.steering.noise_std * k),
            ay_misalignment=s.ay_misalignment + math.radians(self.misalign_deg), ay_cross_axis=True)
        return plant, sensors


def draw(run_id: int, base_seed: int = 0) -> RunSpec:
    """The spec of run ``run_id`` of the campaign seeded ``base_seed``.

    Parameters
    ----------
    run_id : int
        Run index, >= 0.
    base_seed : int
        Campaign seed, >= 0.
    """
    run_id, base_seed = int(run_id), int(base_seed)
    if run_id < 0 or base_seed < 0:
        raise ValueError("run_id and base_seed must be >= 0")
    rng = np.random.default_rng([base_seed, run_id])
    values = {name: float(rng.uniform(lo, hi)) for name, (lo, hi) in RANGES.items()}
    noise_seed = int(rng.integers(0, 2**31 - 1))
    return RunSpec(run_id=run_id, base_seed=base_seed, scenario=SCENARIO_ORDER[run_id % len(SCENARIO_ORDER)],
                   noise_seed=noise_seed, **values)

"""Randomised sets of simulated drives for tuning (training) and for scoring (validation).

A set is drawn for one car (design :class:`~roadbank.params.VehicleParams`, the simulator's
:class:`~roadbank.sim.PlantParams` built from it, and its ESP sensors as a
:class:`~roadbank.sim.SensorConfig`). Every drive perturbs the *plant* (the estimators keep the
design values, as on a real car whose data sheet is not exact) and draws a road and a driver.

Road families (:data:`TRAIN_ROADS`, :data:`VALIDATION_ROADS`, disjoint):

========================  ========  =========================================================
family                    set       what
========================  ========  =========================================================
``bank-step``             train     lane changes between a flat and a banked lane (4-25 %)
``superelevated-curve``   train     a curve with clothoid transitions, superelevation 2-10 %
                                    (road design practice: up to 8-10 %), 60-130 km/h
``lane-change``           train     double lane change on a flat road
``tyre-limit``            train     open-loop S-curve steering to 60-95 % of the friction
                                    limit (mu 0.5-1.0), flat road
``banked-lane-weave``     valid.    weave over two lanes of different bank (-6..+20 %)
``hairpin``               valid.    rural hairpin, radius 25-60 m, superelevation 3-8 %
``reverse-curves``        valid.    highway S: curve left then right, superelevation
                                    switching sign through the transition
``tyre-limit-banked``     valid.    open-loop steering near the limit on a banked straight
========================  ========  =========================================================

Plant perturbations (around the design): training and validation both draw plant ``Cf``
x U(0.5, 1.5), ``Cr`` x U(0.8, 1.2), mass (and sprung mass) x U(0.8, 1.2) and an
accelerometer yaw misalignment U(-2, 2) deg (read ``ay cos a + ax sin a``). The validation
cars also change what training never does (:data:`VALIDATION_CAR_CHANGES`): tyre shape
(``Cy``, ``Ey``), yaw inertia x U(0.8, 1.2), roll stiffness x U(0.75, 1.25).

A perturbation may be held at the design value (``nominal``, names of :data:`PERTURBATIONS`): drawn as always (the
random stream and every other draw stay the same), then not applied; what an error owes to each one.

Seeds: drive ``k`` of a set uses ``numpy.random.default_rng([seed, SET_ID[kind], k])``, so
training (``SET_ID = 0``) and validation (``1``) never share a random stream, and a set is the
same for the same ``(seed, kind, k)`` whatever its size.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..params import VehicleParams
from ..signals import Signals
from ..sim import Driver, PlantParams, Scenario, SensorConfig, flat_road, run, straight_road
from ..sim.road import Road, two_lane_road
from ..sim.scenarios import LOST_CONTROL_DEG

#: road families of each set (disjoint by construction)
TRAIN_ROADS = ("bank-step", "superelevated-curve", "lane-change", "tyre-limit")
VALIDATION_ROADS = ("banked-lane-weave", "hairpin", "reverse-curves", "tyre-limit-banked")
#: plant changes only the validation cars get
VALIDATION_CAR_CHANGES = ("tyre-shape", "yaw-inertia", "roll-stiffness")
#: the plant perturbations by name: the drive's ``car`` keys each sets (held at the design value: a scale 1, a
#: misalignment 0; the tyre shape's keys removed); the last three are :data:`VALIDATION_CAR_CHANGES`
PERTURBATIONS: dict[str, dict[str, float | None]] = {
    "front-stiffness": {"cf_scale": 1.0}, "rear-stiffness": {"cr_scale": 1.0}, "mass": {"mass_scale": 1.0},
    "misalignment": {"misalign_deg": 0.0}, "tyre-shape": {"tyre_Cy": None, "tyre_Ey": None},
    "yaw-inertia": {"iz_scale": 1.0}, "roll-stiffness": {"kroll_scale": 1.0}}
#: random-stream id of each set
SET_ID = {"train": 0, "validation": 1}

DURATION = 20.0     #: seconds per drive (after a 3 s settling pre-roll)
PRE_ROLL = 3.0


@dataclass(frozen=True)
class Drive:
    """One simulated drive: the sensor signals and the true bank.

    Attributes
    ----------
    kind : {"train", "validation"}
    index : int
        Position in the set (the seed's third entry).
    road : str
        Road family.
    car : dict
        Plant changes of this drive (scales, friction, misalignment in deg, ...).
    signals : Signals
        What the estimators read (SI, ISO 8855).
    phi_b : ndarray
        True road bank at the signal samples (rad).
    max_sideslip_deg : float
        The plant's largest sideslip (deg): above :data:`roadbank.sim.scenarios.LOST_CONTROL_DEG` the car lost
        control (a sporty car drawn with soft front tyres oversteers), and tuning leaves the drive out.
    """

    kind: str
    index: int
    road: str
    car: dict
    signals: Signals
    phi_b: np.ndarray
    max_sideslip_deg: float = 0.0

    @property
    def lost_control(self) -> bool:
        """Whether the car lost control on this drive (see :attr:`max_sideslip_deg`)."""
        return self.max_sideslip_deg > LOST_CONTROL_DEG


def _uniform(rng, lo, hi):
    return float(rng.uniform(lo, hi))


def _sign(rng):
    return 1.0 if rng.random() < 0.5 else -1.0


def _kmh(v):
    return v / 3.6


# ---- roads and drivers ----------------------------------------------------------------------

def _bank_step(rng):
    v = _kmh(_uniform(rng, 50.0, 120.0))
    bank = _sign(rng) * math.atan(_uniform(rng, 0.04, 0.25))
    road = two_lane_road(bank_left=bank, bank_right=0.0, transition=_uniform(rng, 0.3, 2.0))
    nr, nl = road.lanes["right"], road.lanes["left"]
    s1 = v * _uniform(rng, 2.0, 5.0)
    length = v * _uniform(rng, 1.5, 3.5)            # distance of one lane change
    hold = v * _uniform(rng, 3.0, 7.0)
    s = (s1, s1 + length, s1 + length + hold, s1 + 2 * length + hold)
    driver = Driver(speed=v, path=(s, (nr, nl, nl, nr)))
    return Scenario("bank-step", road, driver, DURATION, start_n=nr, pre_roll=PRE_ROLL)


def _curve_road(kappas, banks, s_knots, name):
    return Road(curvature=(s_knots, kappas), bank_profile=((0.0,), (1.0,)), bank_factor=(s_knots, banks),
                lanes={"lane": 0.0}, name=name)


def _superelevated_curve(rng):
    v = _kmh(_uniform(rng, 60.0, 130.0))
    ay = _uniform(rng, 1.0, 4.0)                     # lateral acceleration in the curve
    kap = _sign(rng) * ay / v**2
    bank = -math.copysign(math.atan(_uniform(rng, 0.02, 0.10)), kap)   # inside of the curve lower
    s0, trans, arc = v * _uniform(rng, 2.0, 5.0), v * _uniform(rng, 1.5, 4.0), v * _uniform(rng, 4.0, 8.0)
    s = (s0, s0 + trans, s0 + trans + arc, s0 + 2 * trans + arc)
    road = _curve_road((0.0, kap, kap, 0.0), (0.0, bank, bank, 0.0), s, "superelevated-curve")
    return Scenario("superelevated-curve", road, Driver(speed=v, path=((0.0,), (0.0,))), DURATION,
                    pre_roll=PRE_ROLL)


def _lane_change(rng):
    v = _kmh(_uniform(rng, 50.0, 110.0))
    w = _uniform(rng, 3.0, 4.0)
    s1, length, hold = v * _uniform(rng, 2.0, 5.0), v * _uniform(rng, 1.2, 3.0), v * _uniform(rng, 1.0, 4.0)
    s = (s1, s1 + length, s1 + length + hold, s1 + 2 * length + hold)
    d = _sign(rng) * w
    return Scenario("lane-change", flat_road(), Driver(speed=v, path=(s, (0.0, d, d, 0.0))), DURATION,
                    pre_roll=PRE_ROLL)


def _limit_steering(rng, params, v, mu):
    """Open-loop S-curve knots (t, swa) reaching about ``f mu g`` of lateral acceleration."""
    f = _uniform(rng, 0.6, 0.95)
    ay = f * mu * params.g
    kus = params.m / params.L * (params.Lr / params.Cf - params.Lf / params.Cr)
    swa = _sign(rng) * params.steering_ratio * (params.L + kus * v**2) * ay / v**2
    t1, ramp, hold = _uniform(rng, 1.0, 3.0), _uniform(rng, 0.5, 2.5), _uniform(rng, 2.0, 5.0)
    rev = _uniform(rng, 0.8, 3.0)
    t = np.cumsum([0.0, t1, ramp, hold, rev, hold, ramp, 1.0])
    a = np.array([0.0, 0.0, swa, swa, -swa, -swa, 0.0, 0.0])
    return t, a


def _tyre_limit(rng, params, mu):
    v = _kmh(_uniform(rng, 40.0, 80.0))
    return Scenario("tyre-limit", flat_road(), Driver(speed=v, steering=_limit_steering(rng, params, v, mu)),
                    DURATION, pre_roll=PRE_ROLL)


def _banked_lane_weave(rng):
    v = _kmh(_uniform(rng, 50.0, 110.0))
    left, right = math.atan(_uniform(rng, -0.06, 0.20)), math.atan(_uniform(rng, -0.06, 0.06))
    road = two_lane_road(bank_left=left, bank_right=right, transition=_uniform(rng, 0.3, 2.0))
    nr, nl = road.lanes["right"], road.lanes["left"]
    s, n, pos, lane = [], [], v * _uniform(rng, 1.5, 3.0), nr
    while pos < v * DURATION:
        s.append(pos)
        n.append(lane)
        pos += v * _uniform(rng, 1.2, 2.5)
        lane = nl if lane == nr else nr
        s.append(pos)
        n.append(lane)
        pos += v * _uniform(rng, 0.5, 3.0)
    return Scenario("banked-lane-weave", road, Driver(speed=v, path=(tuple(s), tuple(n))), DURATION,
                    start_n=nr, pre_roll=PRE_ROLL)


def _hairpin(rng):
    v = _kmh(_uniform(rng, 25.0, 50.0))
    radius = _uniform(rng, 25.0, 60.0)
    kap = _sign(rng) / radius
    bank = -math.copysign(math.atan(_uniform(rng, 0.03, 0.08)), kap)
    s0, trans = v * _uniform(rng, 2.0, 4.0), _uniform(rng, 15.0, 30.0)
    arc = 0.9 * math.pi * radius
    s = (s0, s0 + trans, s0 + trans + arc, s0 + 2 * trans + arc)
    road = _curve_road((0.0, kap, kap, 0.0), (0.0, bank, bank, 0.0), s, "hairpin")
    return Scenario("hairpin", road, Driver(speed=v, path=((0.0,), (0.0,))), DURATION, pre_roll=PRE_ROLL)


def _reverse_curves(rng):
    v = _kmh(_uniform(rng, 70.0, 130.0))
    kap = _sign(rng) * _uniform(rng, 1.0, 3.5) / v**2
    bank = -math.copysign(math.atan(_uniform(rng, 0.03, 0.10)), kap)
    s0, trans, arc = v * _uniform(rng, 2.0, 4.0), v * _uniform(rng, 1.5, 3.0), v * _uniform(rng, 2.0, 5.0)
    s = np.cumsum([s0, trans, arc, 2 * trans, arc, trans])
    road = _curve_road((0.0, kap, kap, -kap, -kap, 0.0), (0.0, bank, bank, -bank, -bank, 0.0), tuple(s),
                       "reverse-curves")
    return Scenario("reverse-curves", road, Driver(speed=v, path=((0.0,), (0.0,))), DURATION,
                    pre_roll=PRE_ROLL)


def _tyre_limit_banked(rng, params, mu):
    v = _kmh(_uniform(rng, 40.0, 80.0))
    road = straight_road(_sign(rng) * math.atan(_uniform(rng, 0.03, 0.10)), name="banked-straight")
    return Scenario("tyre-limit-banked", road, Driver(speed=v, steering=_limit_steering(rng, params, v, mu)),
                    DURATION, pre_roll=PRE_ROLL)


_NEEDS_CAR = {"tyre-limit": _tyre_limit, "tyre-limit-banked": _tyre_limit_banked}
_ROADS = {"bank-step": _bank_step, "superelevated-curve": _superelevated_curve, "lane-change": _lane_change,
          "banked-lane-weave": _banked_lane_weave, "hairpin": _hairpin, "reverse-curves": _reverse_curves}


# ---- cars --------------------------------------------------------------------------------------

def _car(rng, kind: str) -> dict:
    car = {"cf_scale": _uniform(rng, 0.5, 1.5), "cr_scale": _uniform(rng, 0.8, 1.2),
           "mass_scale": _uniform(rng, 0.8, 1.2), "misalign_deg": _uniform(rng, -2.0, 2.0)}
    if kind == "validation":
        car.update({"tyre_Cy": _uniform(rng, 1.15, 1.5), "tyre_Ey": _uniform(rng, -1.0, 0.2),
                    "iz_scale": _uniform(rng, 0.8, 1.2), "kroll_scale": _uniform(rng, 0.75, 1.25)})
    return car


def held(car: dict, nominal) -> dict:
    """The drawn plant changes ``car`` with the perturbations named in ``nominal`` (:data:`PERTURBATIONS`) at the
    design value: a scale 1, a misalignment 0 deg, the tyre shape the design's (its keys removed).

    Raises
    ------
    ValueError
        A name that is not a perturbation.
    """
    bad = [k for k in nominal if k not in PERTURBATIONS]
    if bad:
        raise ValueError(f"unknown perturbation(s) {bad}; known: {', '.join(PERTURBATIONS)}")
    out = dict(car)
    for name in nominal:
        for key, value in PERTURBATIONS[name].items():
            if key in out:
                if value is None:
                    del out[key]
                else:
                    out[key] = value
    return out


def _plant_and_sensors(car: dict, mu: float, plant, sensors):
    v = plant.vehicle
    k = car["mass_scale"]
    changes = {"m": v.m * k, "ms": v.ms * k, "Iz": v.Iz * car.get("iz_scale", 1.0)}
    if "kroll_scale" in car:
        changes["k_roll"] = v.k_roll * car["kroll_scale"]
    new = plant.replace(vehicle=v.replace(**changes), mu=mu,
                        cornering_scale_front=plant.cornering_scale_front * car["cf_scale"],
                        cornering_scale_rear=plant.cornering_scale_rear * car["cr_scale"])
    if "tyre_Cy" in car:
        new = new.replace(tyre=dataclasses.replace(plant.tyre, Cy=car["tyre_Cy"], Ey=car["tyre_Ey"]))
    s = sensors.replace(ay_misalignment=math.radians(car["misalign_deg"]), ay_cross_axis=True)
    return new, s


# ---- sets --------------------------------------------------------------------------------------

def draw_drive(kind: str, index: int, seed: int, params, plant, sensors, nominal=()) -> Drive:
    """Draw and simulate drive ``index`` of the ``kind`` set, the perturbations named in ``nominal`` held at the
    design value (:func:`held`).

    Parameters
    ----------
    kind : {"train", "validation"}
    index, seed : int
        Position in the set and the set's seed (>= 0).
    params : VehicleParams
        Design parameters of the car (the estimators' model).
    plant : roadbank.sim.PlantParams
        The car as the simulator sees it (built from ``params``), before the perturbations.
    sensors : roadbank.sim.SensorConfig
        The car's sensors.
    """
    if kind not in SET_ID:
        raise ValueError(f"kind must be 'train' or 'validation', got {kind!r}")
    rng = np.random.default_rng([int(seed), SET_ID[kind], int(index)])
    roads = TRAIN_ROADS if kind == "train" else VALIDATION_ROADS
    road = roads[index % len(roads)]
    car = held(_car(rng, kind), nominal)
    limit = road in _NEEDS_CAR
    mu = _uniform(rng, 0.5, 1.0) if limit else _uniform(rng, 0.7, 1.0)
    car["mu"] = mu
    scenario = _NEEDS_CAR[road](rng, params, mu) if limit else _ROADS[road](rng)
    p, s = _plant_and_sensors(car, mu, plant, sensors)
    sim = run(scenario, p, s, seed=int(rng.integers(0, 2**31 - 1)))
    return Drive(kind, int(index), road, car, sim.signals, sim.truth.phi_b, sim.truth.max_sideslip_deg())


def drive_set(kind: str, n: int, seed: int = 0, params=None, plant=None, sensors=None, nominal=()) -> list[Drive]:
    """``n`` drives of the ``kind`` set (road families cycle, see the module docstring).

    ``params`` (default: the paper's SUV), ``plant`` (default ``PlantParams(vehicle=params)``),
    ``sensors`` (default ``SensorConfig()``, the paper's ESP sensors) describe the car; ``nominal``: names of
    :data:`PERTURBATIONS` held at the design value (the same drives otherwise).
    """
    params = params or VehicleParams()
    plant = plant or PlantParams(vehicle=params)
    sensors = sensors or SensorConfig()
    if n < 1:
        raise ValueError(f"a drive set needs n >= 1 drives, got {n}")
    return [draw_drive(kind, k, seed, params, plant, sensors, nominal) for k in range(int(n))]

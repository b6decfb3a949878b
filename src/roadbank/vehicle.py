"""Vehicle files: a car's parameters, sensors and estimator tuning in one TOML file.

A :class:`Vehicle` holds everything roadbank needs to know about one car:

* ``params`` -- the :class:`~roadbank.params.VehicleParams` (bicycle model, roll data, geometry),
* ``sensors`` -- its ESP cluster (:class:`SensorSpec`: rate, noise, resolution, range),
* ``plant`` -- optional simulator-only data (drive/brake limits, drag; see :class:`PlantParams`),
* ``tuning`` -- keyword options per estimator (``estimators.make(name, params, **tuning[name])``),
* ``scores`` / ``identified`` -- what ``roadbank tune`` / ``roadbank identify`` found.

It is read from and written to TOML (format reference: ``docs/vehicles.md``)::

    [meta]
    name = "sedan"
    description = "BMW 320i (CommonRoad vehicle 2)"
    sources = ["Althoff & Wuersching, CommonRoad: Vehicle Models, 2020"]

    [vehicle]            # SI numbers, or "value unit" strings ("1093 kg", "128 kN/rad")
    m = 1093.3
    Iz = "1791.6 kg m^2"
    ...
    [sensors]
    r_resolution = "0.3 deg/s"
    [tuning.pif-modified]
    Q = 30.0
    th = 0.5

Every problem in a file -- TOML syntax, an unknown table or key (with the close
match), a wrong type, an unknown or incompatible unit, an impossible or
implausible value, an unknown estimator or tuning option -- raises
:class:`VehicleFileError` naming the file and the key.

``load_vehicle(None)`` is the paper's SUV; ``load_vehicle("sedan")`` a shipped car
(:data:`BUILTINS`); ``load_vehicle("car.toml")`` a file.
"""

from __future__ import annotations

import dataclasses
import difflib
import inspect
import functools
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from .params import G, VehicleParams

__all__ = ["Vehicle", "SensorSpec", "VehicleFileError", "load_vehicle", "builtin_names", "BUILTINS",
           "UNITS", "PLAUSIBLE", "parse_quantity"]


class VehicleFileError(ValueError):
    """A vehicle file (or a vehicle built in code) is malformed; the message names file and key."""


# ---------------------------------------------------------------------------------------------
# units

#: dimension -> {unit: factor to SI}. Unit keys are normalised (see :func:`_norm_unit`):
#: spaces, ``*``, ``.`` between units, ``^`` removed and ``²`` -> ``2``.
UNITS: dict[str, dict[str, float]] = {
    "mass": {"kg": 1.0, "t": 1000.0},
    "length": {"m": 1.0, "cm": 1e-2, "mm": 1e-3},
    "inertia": {"kgm2": 1.0},
    "angle": {"rad": 1.0, "mrad": 1e-3, "deg": math.pi / 180.0},
    "angular rate": {"rad/s": 1.0, "mrad/s": 1e-3, "deg/s": math.pi / 180.0},
    "acceleration": {"m/s2": 1.0, "g": G, "mg": 1e-3 * G},
    "speed": {"m/s": 1.0, "km/h": 1.0 / 3.6},
    "cornering stiffness": {"N/rad": 1.0, "kN/rad": 1e3, "N/deg": 180.0 / math.pi,
                            "kN/deg": 1e3 * 180.0 / math.pi},
    "roll stiffness": {"Nm/rad": 1.0, "kNm/rad": 1e3, "Nm/deg": 180.0 / math.pi,
                       "kNm/deg": 1e3 * 180.0 / math.pi},
    "roll damping": {"Nms/rad": 1.0, "kNms/rad": 1e3, "Nms/deg": 180.0 / math.pi},
    "frequency": {"Hz": 1.0, "kHz": 1e3},
    "time": {"s": 1.0, "ms": 1e-3},
    "power": {"W": 1.0, "kW": 1e3},
    "torque": {"Nm": 1.0, "kNm": 1e3},
    "area": {"m2": 1.0},
    "density": {"kg/m3": 1.0},
    "dimensionless": {"": 1.0, "-": 1.0, "%": 0.01},
}

#: SI unit each dimension is stored in (for messages and documentation)
SI_UNIT = {"mass": "kg", "length": "m", "inertia": "kg m^2", "angle": "rad", "angular rate": "rad/s",
           "acceleration": "m/s^2", "speed": "m/s", "cornering stiffness": "N/rad",
           "roll stiffness": "N m/rad", "roll damping": "N m s/rad", "frequency": "Hz", "time": "s",
           "power": "W", "torque": "N m", "area": "m^2", "density": "kg/m^3", "dimensionless": "-"}

_UNIT_DIM = {u: dim for dim, table in UNITS.items() for u in table}
_NUMBER = re.compile(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(.*?)\s*$")


def _norm_unit(unit: str) -> str:
    u = unit.strip().replace("²", "2").replace("³", "3").replace("°", "deg").replace("·", "")
    u = re.sub(r"[\s*^]", "", u)
    return u.replace("degree", "deg").replace("degs", "deg")


def parse_quantity(value: str, dimension: str) -> float:
    """Convert a ``"value unit"`` string (e.g. ``"0.3 deg/s"``) to SI for ``dimension``.

    Parameters
    ----------
    value : str
        Number, optional whitespace, unit from :data:`UNITS` (``"1687 kg"``, ``"115 kN/rad"``).
    dimension : str
        Key of :data:`UNITS` the quantity must have.

    Returns
    -------
    float
        The value in the SI unit of ``dimension`` (:data:`SI_UNIT`).

    Raises
    ------
    ValueError
        Not a number followed by a unit, an unknown unit, or a unit of another dimension.
    """
    m = _NUMBER.match(value)
    if m is None:
        raise ValueError("expected a number or a \"value unit\" string such as \"1687 kg\"")
    number, unit = float(m.group(1)), _norm_unit(m.group(2))
    if unit in UNITS[dimension]:
        return number * UNITS[dimension][unit]
    accepted = ", ".join(repr(u) for u in UNITS[dimension] if u)
    other = _UNIT_DIM.get(unit)
    if other is None:
        close = difflib.get_close_matches(unit, list(_UNIT_DIM), n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise ValueError(f"unknown unit '{m.group(2)}'{hint}; {dimension} accepts {accepted or 'no unit'}")
    raise ValueError(f"unit '{m.group(2)}' is {'an' if other[0] in 'aeiou' else 'a'} {other}, "
                     f"this key needs {'an' if dimension[0] in 'aeiou' else 'a'} {dimension} "
                     f"({accepted or 'a plain number'})")


# ---------------------------------------------------------------------------------------------
# field tables: key -> (dimension, plausible (lo, hi) in SI or None)

#: [vehicle] keys: dimension and plausible range for a road vehicle (passenger car to light
#: van, SI). Outside the range is an error: it catches unit mistakes (mass in tonnes, Cf in
#: N/deg, heights in mm, ...). ``None`` = only VehicleParams' own checks.
PLAUSIBLE: dict[str, tuple[str, tuple[float, float] | None]] = {
    "m": ("mass", (500.0, 5000.0)),
    "Iz": ("inertia", (200.0, 20_000.0)),
    "Lf": ("length", (0.5, 3.0)),
    "Lr": ("length", (0.5, 3.0)),
    "Cf": ("cornering stiffness", (10e3, 1.5e6)),
    "Cr": ("cornering stiffness", (10e3, 1.5e6)),
    "steering_ratio": ("dimensionless", (5.0, 30.0)),
    "h_cg": ("length", (0.2, 1.6)),
    "h_roll": ("length", (0.0, 1.6)),
    "ms": ("mass", (400.0, 5000.0)),
    "Ixx": ("inertia", (50.0, 6000.0)),
    "k_roll": ("roll stiffness", (5e3, 1e6)),
    "c_roll": ("roll damping", (0.0, 1e5)),
    "roll_stiffness_front_share": ("dimensionless", (0.0, 1.0)),
    "track_f": ("length", (1.0, 2.5)),
    "track_r": ("length", (1.0, 2.5)),
    "wheel_radius": ("length", (0.2, 0.6)),
    "wheel_inertia": ("inertia", (0.1, 20.0)),
    "g": ("acceleration", (9.7, 9.9)),
}
#: plausible wheelbase Lf + Lr (m)
WHEELBASE_RANGE = (1.8, 4.5)

#: [sensors] keys: dimension, plausible range (SI)
SENSOR_FIELDS: dict[str, tuple[str, tuple[float, float] | None]] = {
    "rate": ("frequency", (10.0, 2000.0)),
    "latency": ("time", (0.0, 0.5)),
    "dropout_prob": ("dimensionless", (0.0, 0.5)),
    "ay_noise": ("acceleration", (0.0, 2.0)),
    "ay_resolution": ("acceleration", (0.0, 0.5)),
    "ay_range": ("acceleration", (0.5 * G, 20.0 * G)),
    "ay_bias": ("acceleration", (-2.0, 2.0)),
    "ay_misalignment": ("angle", (-math.radians(45.0), math.radians(45.0))),
    "r_noise": ("angular rate", (0.0, 0.1)),
    "r_resolution": ("angular rate", (0.0, 0.05)),
    "r_range": ("angular rate", (0.5, 10.0)),
    "r_bias": ("angular rate", (-0.1, 0.1)),
    "speed_noise": ("speed", (0.0, 2.0)),
    "speed_resolution": ("speed", (0.0, 1.0)),
    "steering_noise": ("angle", (0.0, 0.1)),
    "steering_resolution": ("angle", (0.0, 0.1)),
    "steering_range": ("angle", (math.radians(90.0), math.radians(1800.0))),
}

#: [plant] keys (simulator only, :class:`roadbank.sim.PlantParams`): dimension, plausible range
PLANT_FIELDS: dict[str, tuple[str, tuple[float, float] | None]] = {
    "mu": ("dimensionless", (0.05, 1.5)),
    "cornering_scale_front": ("dimensionless", (0.1, 5.0)),
    "cornering_scale_rear": ("dimensionless", (0.1, 5.0)),
    "drive_torque_max": ("torque", (100.0, 20_000.0)),
    "drive_power_max": ("power", (10e3, 1e6)),
    "brake_torque_max": ("torque", (500.0, 50_000.0)),
    "brake_front_share": ("dimensionless", (0.0, 1.0)),
    "CdA": ("area", (0.0, 10.0)),
    "air_density": ("density", (0.0, 2.0)),
    "accel_height": ("length", (-1.0, 1.5)),
    "load_transfer_lag": ("time", (1e-3, 1.0)),
}

TABLES = ("meta", "vehicle", "sensors", "plant", "tuning", "scores", "identified")
META_KEYS = ("name", "description", "sources")

#: the roll and geometry data a file may leave out: the SUV's value, scaled by m / m_SUV
#: where marked (keeps the SUV's roll gradient, roll frequency and damping ratio)
_SUV = VehicleParams()
_SCALED_WITH_MASS = ("ms", "Ixx", "k_roll", "c_roll")
REQUIRED_VEHICLE_KEYS = ("m", "Iz", "Lf", "Lr", "Cf", "Cr")


# ---------------------------------------------------------------------------------------------
# sensors

@dataclass(frozen=True)
class SensorSpec:
    """A car's ESP sensor cluster (SI). Defaults: the paper's ESP sensors = ``SensorConfig()``.

    Parameters
    ----------
    rate : float
        Sample rate (Hz), 100.
    latency : float
        Delay of every channel (s), 0.
    dropout_prob : float
        Probability that a sample (CAN frame) is lost (-), 0.
    ay_noise, ay_resolution, ay_range, ay_bias : float
        Lateral accelerometer: white-noise std, quantisation step, saturation, offset
        (m/s^2): 0.03, 0.005 g, 1.8 g, 0.
    ay_misalignment : float
        Mounting angle of the accelerometer (rad), 0: it reads ``ay cos(angle)``.
    r_noise, r_resolution, r_range, r_bias : float
        Yaw-rate sensor (rad/s): 0.1 deg/s, 0.3 deg/s, 100 deg/s, 0.
    speed_noise, speed_resolution : float
        Wheel-speed vehicle speed (m/s): 0.02, 0.01.
    steering_noise, steering_resolution, steering_range : float
        Steering-wheel angle sensor (rad): 0, 0.1 deg, 780 deg.
    """

    rate: float = 100.0
    latency: float = 0.0
    dropout_prob: float = 0.0
    ay_noise: float = 0.03
    ay_resolution: float = 0.005 * G
    ay_range: float = 1.8 * G
    ay_bias: float = 0.0
    ay_misalignment: float = 0.0
    r_noise: float = math.radians(0.1)
    r_resolution: float = math.radians(0.3)
    r_range: float = math.radians(100.0)
    r_bias: float = 0.0
    speed_noise: float = 0.02
    speed_resolution: float = 0.01
    steering_noise: float = 0.0
    steering_resolution: float = math.radians(0.1)
    steering_range: float = math.radians(780.0)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise ValueError(f"SensorSpec.{f.name} must be a finite number, got {v!r}")
        if not self.rate > 0:
            raise ValueError(f"SensorSpec.rate must be > 0 Hz, got {self.rate}")
        for name in ("latency", "ay_noise", "ay_resolution", "r_noise", "r_resolution", "speed_noise",
                     "speed_resolution", "steering_noise", "steering_resolution"):
            if getattr(self, name) < 0:
                raise ValueError(f"SensorSpec.{name} must be >= 0, got {getattr(self, name)}")
        for name in ("ay_range", "r_range", "steering_range"):
            if not getattr(self, name) > 0:
                raise ValueError(f"SensorSpec.{name} must be > 0, got {getattr(self, name)}")
        if not 0.0 <= self.dropout_prob < 1.0:
            raise ValueError(f"SensorSpec.dropout_prob must be in [0, 1), got {self.dropout_prob}")

    @property
    def r_variance(self) -> float:
        """Yaw-rate measurement variance, noise + uniform quantisation: ``r_noise^2 + r_resolution^2/12``
        ((rad/s)^2)."""
        return self.r_noise ** 2 + self.r_resolution ** 2 / 12.0

    def rate_for(self, rate: float | None = None) -> float:
        """``rate`` (Hz) when it is a positive finite number, else the sensor's own ``rate``."""
        return rate if rate is not None and math.isfinite(rate) and rate > 0 else self.rate

    def r_noise_density(self, rate: float | None = None) -> float:
        """Yaw-rate noise density ``R`` ((rad/s)^2 s) of this sensor sampled at ``rate`` (Hz).

        ``r_variance / rate`` (:func:`roadbank.estimators.pif.yaw_rate_noise_density`): the
        same per-sample noise and quantisation stand for a density ten times larger at 10 Hz
        than at 100 Hz. ``rate`` None or not a positive finite number: the sensor's ``rate``.
        """
        from .estimators.pif import yaw_rate_noise_density

        return yaw_rate_noise_density(self.r_noise, self.r_resolution, self.rate_for(rate))

    @property
    def ay_variance(self) -> float:
        """Lateral-acceleration measurement variance ``ay_noise^2 + ay_resolution^2/12`` ((m/s^2)^2)."""
        return self.ay_noise ** 2 + self.ay_resolution ** 2 / 12.0

    def ay_noise_density(self, rate: float | None = None) -> float:
        """Lateral-acceleration noise density ``Q_ay`` ((m/s^2)^2 s) of this sensor sampled at
        ``rate`` (Hz): ``ay_variance / rate``, as :meth:`r_noise_density`."""
        return self.ay_variance / self.rate_for(rate)

    @property
    def dt(self) -> float:
        """Sample period 1/rate (s)."""
        return 1.0 / self.rate

    def replace(self, **changes: float) -> "SensorSpec":
        """Copy with fields changed (validated)."""
        return dataclasses.replace(self, **changes)

    def to_sim(self, **changes):
        """The simulator's sensor model for this cluster.

        Parameters
        ----------
        **changes
            Fields of :class:`roadbank.sim.SensorConfig` to override (e.g. ``seed``-independent
            ``dropout_prob``).

        Returns
        -------
        roadbank.sim.sensors.SensorConfig
        """
        from .sim.sensors import ChannelSpec, SensorConfig

        cfg = SensorConfig(
            rate=float(self.rate), latency=float(self.latency), dropout_prob=float(self.dropout_prob),
            yaw_rate=ChannelSpec(noise_std=self.r_noise, bias=self.r_bias, resolution=self.r_resolution,
                                 range=self.r_range),
            ay=ChannelSpec(noise_std=self.ay_noise, bias=self.ay_bias, resolution=self.ay_resolution,
                           range=self.ay_range),
            speed=ChannelSpec(noise_std=self.speed_noise, resolution=self.speed_resolution),
            steering=ChannelSpec(noise_std=self.steering_noise, resolution=self.steering_resolution,
                                 range=self.steering_range),
            ay_misalignment=float(self.ay_misalignment))
        return cfg.replace(**changes) if changes else cfg


# ---------------------------------------------------------------------------------------------
# estimators for a car's sensors at a log's rate

def make_estimator(name: str, params: VehicleParams | None = None, *, sensors: SensorSpec | None = None,
                   log_rate: float | None = None, log_ay_noise: float | None = None,
                   log_r_noise: float | None = None, **options):
    """``estimators.make(name, params, **options)`` for a log sampled at ``log_rate`` by ``sensors``.

    The one rule for the sensor-derived weights of a default-tuned PIF
    (:func:`roadbank.estimators.pif.with_sensor_noise`):

    * ``R``, the yaw-rate noise density: the yaw-rate sensor's noise and resolution at
      the rate of the log it will run on (:meth:`SensorSpec.r_noise_density`);
    * ``Q_ay``, the noise density of the ``ay`` input: the accelerometer's at that rate
      (:meth:`SensorSpec.ay_noise_density`), or the road noise measured on the log's own
      ``ay`` (``log_ay_noise``, :func:`log_conditions`) where that is larger — vibration
      of the road, the body or the mount that no data sheet knows (a phone IMU, a 10 Hz INS
      that samples without an anti-alias filter);
    * likewise ``R`` from the road noise of the log's yaw rate (``log_r_noise``) where that is
      larger than the sensor's.

    ``roadbank estimate``/``map`` (:mod:`roadbank.fleet`, :mod:`roadbank.mapping`),
    :meth:`Vehicle.make` and the real-data validation all build their estimators here.

    Parameters
    ----------
    name : str
        One of :data:`roadbank.estimators.NAMES`.
    params : VehicleParams, optional
        The car (default the paper's SUV).
    sensors : SensorSpec, optional
        Its sensor cluster (default the paper's ESP sensors).
    log_rate : float, optional
        Sample rate (Hz) of the log (:func:`roadbank.signals.sample_rate` of its time
        base). Default (or NaN): ``sensors.rate``.
    log_ay_noise, log_r_noise : float, optional
        Road-noise standard deviation of the log's ``ay`` (m/s^2) and yaw rate (rad/s)
        (:func:`roadbank.signals.road_noise_std`); None or NaN: not measured.
    **options
        The estimator's keyword options; an explicit ``R``, ``Q_ay`` or ``tuning`` keeps the
        sensor out of that weight.
    """
    from . import estimators
    from .estimators.pif import with_sensor_noise

    sensors = sensors if sensors is not None else SensorSpec()
    if sensors.r_variance > 0:
        rate = sensors.rate_for(log_rate)
        Q_ay, R = sensors.ay_noise_density(rate), sensors.r_noise_density(rate)
        if log_ay_noise is not None and math.isfinite(log_ay_noise):
            Q_ay = max(Q_ay, log_ay_noise ** 2 / rate)
        if log_r_noise is not None and math.isfinite(log_r_noise):
            R = max(R, log_r_noise ** 2 / rate)
        options = with_sensor_noise(name, options, R, Q_ay)
    return estimators.make(name, params, **options)


@functools.lru_cache(maxsize=1)
def undescribed_params() -> VehicleParams:
    """The car parameters for a log whose car is not described (:data:`roadbank.defaults.VEHICLE`;
    read once, the parameters are immutable)."""
    from .defaults import VEHICLE

    return load_vehicle(VEHICLE).params


#: seconds at the start of a log on which :func:`log_conditions` measures it (s)
DESIGN_SPAN_S = 60.0


def log_conditions(signals, v_min: float = 5.0) -> dict[str, float]:
    """What a log tells :func:`make_estimator` about its sensors: ``{"log_rate": Hz,
    "log_ay_noise": m/s^2, "log_r_noise": rad/s}`` — the sample rate of its time base
    (:func:`roadbank.signals.sample_rate`) and the road noise of its ``ay`` and yaw rate on the
    samples at ``vx >= v_min`` (m/s): what they carry above the vehicle's dynamics band, taken
    as white (:func:`roadbank.signals.road_noise_std`, the noise model of real roads; NaN when
    too few samples). Measured on the first :data:`DESIGN_SPAN_S` of the log (all of a shorter
    one), so that a streamed log gets the same design whatever its chunk size.
    """
    import numpy as np

    from .signals import road_noise_std, sample_rate

    n = int(np.searchsorted(signals.t, signals.t[0] + DESIGN_SPAN_S, side="right"))
    if n < len(signals):
        signals = signals[:n]
    vx = np.asarray(signals.vx, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        moving = vx >= v_min
    ay_noise = road_noise_std(signals.ay, signals.t, moving)
    r_noise = road_noise_std(signals.r, signals.t, moving)
    # two significant digits: logs of one car and road share a design (the design cache)
    return {"log_rate": sample_rate(signals.t), "log_ay_noise": float(f"{ay_noise:.2g}"),
            "log_r_noise": float(f"{r_noise:.2g}")}


def for_conditions(name: str, cond: dict, params: VehicleParams | None = None, *, vehicle=None, **tuning):
    """Build the estimator ``name`` for a log's conditions ``cond`` (:func:`log_conditions`).

    The car is ``vehicle`` (a :class:`Vehicle`: its parameters, sensors and tuning tables) or
    ``params`` with the data sheet's sensors; neither: the car for a log whose car is not
    described (:func:`undescribed_params`). What ``roadbank estimate``, ``map`` and
    :func:`for_log` build.
    """
    if vehicle is not None:
        return vehicle.make(name, **cond, **tuning)
    return make_estimator(name, params if params is not None else undescribed_params(), **cond, **tuning)


def for_log(name: str, signals, params: VehicleParams | None = None, *, vehicle=None, **tuning):
    """Build the estimator ``name`` for the log ``signals`` as ``roadbank estimate`` does.

    A default-tuned PIF is designed for the log's sample rate and the road noise measured on
    its ``ay`` and yaw rate (:func:`log_conditions`); the car as :func:`for_conditions`.
    ``for_log(name, s).run(s)`` is what the command line writes for the log ``s``.
    """
    return for_conditions(name, log_conditions(signals), params, vehicle=vehicle, **tuning)


#: ``[identified.<quantity>]`` sensor offsets (measured minus true) -> the Signals channel they
#: are removed from by :meth:`Vehicle.correct`, and their unit (what ``roadbank identify`` writes)
OFFSET_CHANNELS = {"yaw_rate_offset": ("r", "rad/s"), "ay_offset": ("ay", "m/s^2"),
                   "steering_offset": ("delta_f", "rad")}


# ---------------------------------------------------------------------------------------------
# the vehicle

def _py(v):
    """numpy scalars/arrays and tuples -> Python scalars and lists (what TOML holds)."""
    if hasattr(v, "tolist") and not isinstance(v, (str, bytes)):  # numpy scalar or array
        v = v.tolist()
    if isinstance(v, (list, tuple)):
        return [_py(x) for x in v]
    return v


def _plain(mapping, depth: int):
    """Deep copy of nested mappings into plain dicts of Python values (picklable, comparable)."""
    if not isinstance(mapping, Mapping):
        return mapping  # reported by the checks
    if depth == 0:
        return {str(k): _py(v) for k, v in mapping.items()}
    return {str(k): _plain(v, depth - 1) for k, v in mapping.items()}


@dataclass(frozen=True, eq=True)
class Vehicle:
    """One car: parameters, sensors, estimator tuning and tool results (see module docstring).

    Parameters
    ----------
    name : str
        Short name (a built-in's name is its file stem, e.g. ``"sedan"``).
    description : str
    sources : tuple of str
        Where the numbers come from.
    params : VehicleParams
        SI parameters of the models, estimators and simulator.
    sensors : SensorSpec
    tuning : mapping
        Estimator name -> keyword options for :func:`roadbank.estimators.make`.
    scores : mapping
        Estimator name -> {metric: value} (written by ``roadbank tune``).
    identified : mapping
        Quantity -> {"value", "std", "unit", "note", ...} (written by ``roadbank identify``).
    plant : mapping
        Simulator-only :class:`roadbank.sim.PlantParams` fields (``drive_power_max``, ``CdA``, ...);
        missing ones take the PlantParams defaults.
    source : str
        The file it was read from ("" if built in code); names it in :meth:`check` errors.
        Not part of equality or of the written file.
    """

    name: str = "suv-paper"
    description: str = ""
    sources: tuple[str, ...] = ()
    params: VehicleParams = field(default_factory=VehicleParams)
    sensors: SensorSpec = field(default_factory=SensorSpec)
    tuning: Mapping[str, Mapping[str, object]] = field(default_factory=dict)
    scores: Mapping[str, Mapping[str, object]] = field(default_factory=dict)
    identified: Mapping[str, Mapping[str, object]] = field(default_factory=dict)
    plant: Mapping[str, float] = field(default_factory=dict)
    source: str = field(default="", compare=False, repr=False)

    __hash__ = None  # holds dicts

    def __post_init__(self) -> None:
        if not isinstance(self.params, VehicleParams):
            raise TypeError("Vehicle.params must be a VehicleParams")
        if not isinstance(self.sensors, SensorSpec):
            raise TypeError("Vehicle.sensors must be a SensorSpec")
        set_ = object.__setattr__
        set_(self, "name", str(self.name))
        set_(self, "description", str(self.description))
        set_(self, "sources", tuple(str(s) for s in self.sources))
        set_(self, "tuning", _plain(self.tuning, 1))
        set_(self, "scores", _plain(self.scores, 1))
        set_(self, "identified", _plain(self.identified, 1))
        set_(self, "plant", _plain(self.plant, 0))
        # the same checks as a file gets, with "<vehicle NAME>" as the file
        _check_document(self._document(), f"<vehicle {self.name}>")

    # ---- reading and writing -------------------------------------------------------------
    @classmethod
    def from_toml(cls, path: str | Path) -> "Vehicle":
        """Read a vehicle file.

        Raises
        ------
        VehicleFileError
            File missing/unreadable or any problem in it (message names file and key).
        """
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise VehicleFileError(f"{path}: no such vehicle file") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise VehicleFileError(f"{path}: cannot read ({exc})") from None
        return dataclasses.replace(cls.loads(text, source=str(path), default_name=path.stem), source=str(path))

    @classmethod
    def loads(cls, text: str, source: str = "<string>", default_name: str = "vehicle") -> "Vehicle":
        """Parse vehicle-file text; ``source`` names it in error messages."""
        try:
            doc = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise VehicleFileError(f"{source}: TOML syntax error: {exc}") from None
        return _from_document(doc, source, default_name)

    def dumps(self) -> str:
        """The vehicle as TOML text (every field explicit, SI, floats exact via ``repr``)."""
        return _dump_document(self._document(), header=f"roadbank vehicle file: {self.name} (SI units; "
                                                       "format: docs/vehicles.md)")

    def to_toml(self, path: str | Path) -> None:
        """Write :meth:`dumps` to ``path``."""
        Path(path).write_text(self.dumps(), encoding="utf-8")

    def _document(self) -> dict:
        return {
            "meta": {"name": self.name, "description": self.description, "sources": list(self.sources)},
            "vehicle": {f.name: getattr(self.params, f.name) for f in dataclasses.fields(self.params)},
            "sensors": {f.name: getattr(self.sensors, f.name) for f in dataclasses.fields(self.sensors)},
            "plant": dict(self.plant),
            "tuning": {k: dict(v) for k, v in self.tuning.items()},
            "scores": {k: dict(v) for k, v in self.scores.items()},
            "identified": {k: dict(v) for k, v in self.identified.items()},
        }

    # ---- use --------------------------------------------------------------------------------
    def make(self, estimator_name: str, *, log_rate: float | None = None, log_ay_noise: float | None = None,
             log_r_noise: float | None = None, **overrides):
        """Build an estimator for this car: its params, sensors and ``[tuning.<name>]`` options.

        :func:`make_estimator` ``(name, self.params, sensors=self.sensors, log_rate=log_rate,
        log_ay_noise=log_ay_noise, **{**tuning, **overrides})``, ``tuning`` the car's
        ``[tuning.<name>]`` table; for an estimator that runs another's filter
        (:data:`roadbank.estimators.TUNED_AS`: ``pif-smoother`` and ``pif-gated`` run
        ``pif-modified``) that one's table with its own table's keys over it: a default-tuned
        PIF without an ``R`` gets the noise
        densities of this car's sensors at ``log_rate`` (Hz; default the sensor's ``rate``),
        ``Q_ay`` at least the log's own ``ay`` road noise ``log_ay_noise`` (m/s^2), ``R`` at least
        its yaw rate's ``log_r_noise`` (rad/s).
        """
        from .estimators import TUNED_AS
        tuning = {**self.tuning.get(TUNED_AS.get(estimator_name), {}), **self.tuning.get(estimator_name, {})}
        return make_estimator(estimator_name, self.params, sensors=self.sensors, log_rate=log_rate,
                              log_ay_noise=log_ay_noise, log_r_noise=log_r_noise, **{**tuning, **overrides})

    @property
    def sensor_offsets(self) -> dict[str, float]:
        """The identified sensor offsets (measured minus true, SI) by :class:`~roadbank.Signals` channel.

        From the ``[identified]`` tables ``roadbank identify`` writes (:data:`OFFSET_CHANNELS`):
        ``{"r": yaw_rate_offset (rad/s), "ay": ay_offset (m/s^2), "delta_f": steering_offset
        (rad, road-wheel angle)}``, only those the vehicle has.

        Raises
        ------
        VehicleFileError
            An offset that is not a finite number or is in another unit than the one above.
        """
        out = {}
        for quantity, (channel, unit) in OFFSET_CHANNELS.items():
            entry = self.identified.get(quantity)
            if entry is None:
                continue
            where = f"{self.source or f'<vehicle {self.name}>'}: [identified.{quantity}]"
            value = entry.get("value")
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise VehicleFileError(f"{where} value = {_fmt(value)}: need a finite number ({unit})")
            if entry.get("unit", unit) != unit:
                raise VehicleFileError(f"{where} unit = {_fmt(entry['unit'])}: the offset must be in {unit} "
                                       "(as roadbank identify writes it)")
            out[channel] = float(value)
        return out

    def correct(self, signals):
        """``signals`` with this car's identified sensor offsets subtracted (:attr:`sensor_offsets`).

        What ``roadbank estimate`` / ``roadbank map`` do to every log before estimating when
        given ``--vehicle`` (docs/identification.md). Returns ``signals`` itself when the car
        has no identified offset.

        Parameters
        ----------
        signals : roadbank.Signals
            Measured ESP signals (SI, ISO 8855).

        Returns
        -------
        roadbank.Signals
            ``r - yaw_rate_offset`` (rad/s), ``ay - ay_offset`` (m/s^2), ``delta_f -
            steering_offset`` (rad); ``t`` and ``vx`` unchanged.
        """
        offsets = self.sensor_offsets
        if not offsets:
            return signals
        from .signals import CHANNELS, Signals

        return Signals(*(getattr(signals, c) - offsets[c] if c in offsets else getattr(signals, c)
                         for c in CHANNELS))

    def check(self) -> "Vehicle":
        """Build every tuned estimator once; a failing design raises :class:`VehicleFileError`.

        Returns ``self`` (chainable). Costs a design per ``[tuning]`` table (~0.2-0.4 s each).
        """
        from .estimators import NoStabilisingSolution

        for name, options in self.tuning.items():
            try:
                self.make(name)
            except (ValueError, TypeError, NoStabilisingSolution) as exc:
                raise VehicleFileError(f"{self.source or f'<vehicle {self.name}>'}: [tuning.{name}] "
                                       f"{_fmt_options(options)}: {exc}") from None
        return self

    def to_plant(self, **changes):
        """The simulator's :class:`roadbank.sim.PlantParams` for this car.

        The plant's tyres have the axle cornering stiffnesses ``Cf``, ``Cr`` at static load;
        ``[plant]`` values and then ``changes`` override the PlantParams defaults.
        """
        from .sim.params import PlantParams

        return PlantParams(vehicle=self.params, **{**self.plant, **changes})

    def simulate(self, scenario: str, condition: str = "nominal", seed: int = 0, **plant_changes):
        """Run a built-in scenario (``roadbank.sim.SCENARIOS``) with this car as plant and sensors.

        Returns
        -------
        roadbank.sim.SimResult
        """
        from .sim import run_scenario

        return run_scenario(scenario, condition=condition, seed=seed, plant=self.to_plant(**plant_changes),
                            sensors=self.sensors.to_sim())

    # ---- copies -------------------------------------------------------------------------------
    def with_tuning(self, name: str, options: Mapping[str, object],
                    scores: Mapping[str, object] | None = None) -> "Vehicle":
        """Copy with ``tuning[name] = options`` (replaced, not merged) and, if given, ``scores[name]``."""
        tuning = {**self.tuning, name: dict(options)}
        new_scores = {**self.scores, name: dict(scores)} if scores is not None else self.scores
        return dataclasses.replace(self, tuning=tuning, scores=new_scores, source="")

    def with_params(self, **changes: float) -> "Vehicle":
        """Copy with :class:`VehicleParams` fields changed (validated)."""
        return dataclasses.replace(self, params=self.params.replace(**changes), source="")

    def with_sensors(self, **changes: float) -> "Vehicle":
        """Copy with :class:`SensorSpec` fields changed (validated)."""
        return dataclasses.replace(self, sensors=self.sensors.replace(**changes), source="")

    def with_identified(self, identified: Mapping[str, Mapping[str, object]]) -> "Vehicle":
        """Copy with the given ``identified`` quantities added (a quantity present is replaced)."""
        return dataclasses.replace(self, identified={**self.identified, **identified}, source="")

    def replace(self, **changes) -> "Vehicle":
        """Copy with :class:`Vehicle` fields changed (``name``, ``description``, ``sensors`` ...)."""
        return dataclasses.replace(self, **{"source": "", **changes})


# ---------------------------------------------------------------------------------------------
# parsing and checking

def _fmt(value) -> str:
    """A value as it would be written in the file (for messages)."""
    try:
        return _toml_value(value)
    except TypeError:
        return repr(value)


def _fmt_options(options: Mapping) -> str:
    return "{" + ", ".join(f"{k} = {_fmt(v)}" for k, v in options.items()) + "}"


def _unknown(key: str, known, what: str) -> str:
    close = difflib.get_close_matches(key, list(known), n=1, cutoff=0.6)
    if not close:
        close = [k for k in known if k.lower() == key.lower()][:1]
    hint = f"; did you mean '{close[0]}'?" if close else ""
    return f"unknown {what}{hint} (known: {', '.join(known)})"


def _quantity(source: str, table: str, key: str, raw, dimension: str,
              rng: tuple[float, float] | None) -> float:
    """One numeric value of a file: number or "value unit" string -> SI float, range-checked."""
    where = f"{source}: [{table}] {key} = {_fmt(raw)}"
    if isinstance(raw, bool) or not isinstance(raw, (int, float, str)):
        raise VehicleFileError(f"{where}: expected a number or a \"value unit\" string, "
                               f"got {_toml_type(raw)}")
    if isinstance(raw, str):
        try:
            value = parse_quantity(raw, dimension)
        except ValueError as exc:
            raise VehicleFileError(f"{where}: {exc}") from None
    else:
        value = float(raw)
    if not math.isfinite(value):
        raise VehicleFileError(f"{where}: must be finite")
    unit = SI_UNIT[dimension]
    shown = "" if unit == "-" else f" {unit}"
    if rng is not None and rng[0] > 0 and value <= 0:
        raise VehicleFileError(f"{where}: must be > 0{shown}")
    if rng is not None and rng[0] == 0 and value < 0:
        raise VehicleFileError(f"{where}: must be >= 0{shown}")
    if rng is not None and not rng[0] <= value <= rng[1]:
        si = "" if isinstance(raw, (int, float)) and not isinstance(raw, bool) else f" (= {value:.6g}{shown})"
        raise VehicleFileError(f"{where}{si}: outside the plausible range {rng[0]:g} .. {rng[1]:g}{shown} "
                               f"for a road vehicle (unit mistake?)")
    return value


def _toml_type(v) -> str:
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, dict):
        return "a table"
    if isinstance(v, list):
        return "an array"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, (int, float)):
        return "a number"
    return type(v).__name__


def _is_scalar(v) -> bool:
    return isinstance(v, (bool, int, float, str))


def _check_free_table(source: str, table: str, sub: str, values) -> None:
    """scores/identified/tuning entries: TOML scalars or (nested) arrays of scalars."""
    if not isinstance(values, dict):
        raise VehicleFileError(f"{source}: [{table}.{sub}] must be a table, got {_toml_type(values)}")

    def ok(v):
        return _is_scalar(v) or (isinstance(v, (list, tuple)) and all(ok(x) for x in v))

    for k, v in values.items():
        if not ok(v):
            raise VehicleFileError(f"{source}: [{table}.{sub}] {k}: expected a number, string, boolean "
                                   f"or array of them, got {_toml_type(v)}")


def _estimator_options(name: str) -> set[str] | None:
    """Keyword options ``estimators.make(name, ...)`` accepts (None: cannot tell, accept any)."""
    from . import estimators

    factory = getattr(estimators, "_FACTORIES", {}).get(name)
    if factory is None:
        return None
    fixed = set(getattr(factory, "keywords", None) or ())
    cls = getattr(factory, "func", factory)
    names: set[str] = set()
    for klass in (inspect.getmro(cls) if inspect.isclass(cls) else (cls,)):
        init = vars(klass).get("__init__") if inspect.isclass(klass) else klass
        if init is None:            # a mixin without its own __init__: look further up
            continue
        if init is object.__init__:
            break
        try:
            sig = inspect.signature(init)
        except (TypeError, ValueError):
            return None
        names |= {p.name for p in sig.parameters.values()
                  if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD) and p.name not in ("self", "params")}
        if not any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values()):
            break
    return names - fixed


def _check_tuning(source: str, name: str, options) -> None:
    from . import estimators

    if name not in estimators.NAMES:
        raise VehicleFileError(f"{source}: [tuning.{name}]: {_unknown(name, estimators.NAMES, 'estimator')}")
    _check_free_table(source, "tuning", name, options)
    known = _estimator_options(name)
    if known is not None:
        for key in options:
            if key not in known:
                raise VehicleFileError(f"{source}: [tuning.{name}] {key}: "
                                       f"{_unknown(key, sorted(known), f'option of {name}')}")


def _check_document(doc: dict, source: str) -> None:
    """Plausibility and cross-field checks on a document of SI values (from a file or a Vehicle)."""
    veh = doc["vehicle"]
    for key, (dim, rng) in PLAUSIBLE.items():
        _quantity(source, "vehicle", key, veh[key], dim, rng)
    L = veh["Lf"] + veh["Lr"]
    if not WHEELBASE_RANGE[0] <= L <= WHEELBASE_RANGE[1]:
        raise VehicleFileError(f"{source}: [vehicle] Lf + Lr = {L:.6g} m: wheelbase outside the plausible "
                               f"range {WHEELBASE_RANGE[0]:g} .. {WHEELBASE_RANGE[1]:g} m")
    for key, (dim, rng) in SENSOR_FIELDS.items():
        _quantity(source, "sensors", key, doc["sensors"][key], dim, rng)
    for key, value in doc["plant"].items():
        if key not in PLANT_FIELDS:
            raise VehicleFileError(f"{source}: [plant] {key}: {_unknown(key, PLANT_FIELDS, 'key')}")
        _quantity(source, "plant", key, value, *PLANT_FIELDS[key])
    for name, options in doc["tuning"].items():
        _check_tuning(source, name, options)
    for table in ("scores", "identified"):
        for sub, values in doc[table].items():
            _check_free_table(source, table, sub, values)


def _params_error(source: str, table: str, raw: dict, exc: Exception) -> VehicleFileError:
    """Turn a VehicleParams/SensorSpec validation error into one naming the file and the key:
    the first key of the file the message mentions (else the table)."""
    msg = str(exc)
    text = re.sub(r"\b(?:VehicleParams|SensorSpec)(?:\.|: )", "", msg)
    mentioned = sorted((m.start(), m.group(0)) for key in raw
                       for m in [re.search(rf"\b{re.escape(key)}\b", msg)] if m)
    if mentioned:
        key = mentioned[0][1]
        return VehicleFileError(f"{source}: [{table}] {key} = {_fmt(raw[key])}: {text}")
    return VehicleFileError(f"{source}: [{table}]: {msg}")


def _from_document(doc: dict, source: str, default_name: str) -> Vehicle:
    for table, value in doc.items():
        if not isinstance(value, dict):
            raise VehicleFileError(f"{source}: {table} = {_fmt(value) if _is_scalar(value) else '...'}: "
                                   f"a key outside any table; keys belong in one of "
                                   f"[{'], ['.join(TABLES[:4])}]")
        if table not in TABLES:
            raise VehicleFileError(f"{source}: [{table}]: {_unknown(table, TABLES, 'table')}")
    meta = doc.get("meta", {})
    for key in meta:
        if key not in META_KEYS:
            raise VehicleFileError(f"{source}: [meta] {key}: {_unknown(key, META_KEYS, 'key')}")
    for key in ("name", "description"):
        if key in meta and not isinstance(meta[key], str):
            raise VehicleFileError(f"{source}: [meta] {key} = {_fmt(meta[key]) if _is_scalar(meta[key]) else '...'}"
                                   f": expected a string, got {_toml_type(meta[key])}")
    sources = meta.get("sources", [])
    if isinstance(sources, str):
        sources = [sources]
    if not isinstance(sources, list) or not all(isinstance(s, str) for s in sources):
        raise VehicleFileError(f"{source}: [meta] sources: expected an array of strings")

    # [vehicle]: required bicycle-model keys, optional roll data and geometry
    veh_raw = doc.get("vehicle")
    if veh_raw is None:
        raise VehicleFileError(f"{source}: missing table [vehicle] (needs at least "
                               f"{', '.join(REQUIRED_VEHICLE_KEYS)})")
    for key in veh_raw:
        if key not in PLAUSIBLE:
            raise VehicleFileError(f"{source}: [vehicle] {key}: {_unknown(key, PLAUSIBLE, 'key')}")
    missing = [k for k in REQUIRED_VEHICLE_KEYS if k not in veh_raw]
    if missing:
        raise VehicleFileError(f"{source}: [vehicle] {', '.join(missing)}: missing (required: "
                               f"{', '.join(REQUIRED_VEHICLE_KEYS)})")
    values = {k: _quantity(source, "vehicle", k, v, *PLAUSIBLE[k]) for k, v in veh_raw.items()}
    for key in _SCALED_WITH_MASS:
        values.setdefault(key, getattr(_SUV, key) * values["m"] / _SUV.m)
    try:
        params = VehicleParams(**values)
    except (ValueError, TypeError) as exc:
        raise _params_error(source, "vehicle", veh_raw, exc) from None

    sens_raw = doc.get("sensors", {})
    for key in sens_raw:
        if key not in SENSOR_FIELDS:
            raise VehicleFileError(f"{source}: [sensors] {key}: {_unknown(key, SENSOR_FIELDS, 'key')}")
    try:
        sensors = SensorSpec(**{k: _quantity(source, "sensors", k, v, *SENSOR_FIELDS[k])
                                for k, v in sens_raw.items()})
    except (ValueError, TypeError) as exc:
        raise _params_error(source, "sensors", sens_raw, exc) from None

    plant_raw = doc.get("plant", {})
    plant = {}
    for key, value in plant_raw.items():
        if key not in PLANT_FIELDS:
            raise VehicleFileError(f"{source}: [plant] {key}: {_unknown(key, PLANT_FIELDS, 'key')}")
        plant[key] = _quantity(source, "plant", key, value, *PLANT_FIELDS[key])

    for table in ("tuning", "scores", "identified"):
        for sub, values_ in doc.get(table, {}).items():
            if table == "tuning":
                _check_tuning(source, sub, values_)
            else:
                _check_free_table(source, table, sub, values_)
    try:
        return Vehicle(name=meta.get("name", default_name), description=meta.get("description", ""),
                       sources=tuple(sources), params=params, sensors=sensors,
                       tuning=doc.get("tuning", {}), scores=doc.get("scores", {}),
                       identified=doc.get("identified", {}), plant=plant)
    except VehicleFileError as exc:  # cross-field plausibility: re-label with the file
        raise VehicleFileError(re.sub(r"^<vehicle [^>]*>", source, str(exc))) from None


# ---------------------------------------------------------------------------------------------
# writing TOML (the flat tables of a vehicle file; tomllib only reads)

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _toml_string(s: str) -> str:
    out = []
    for ch in s:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _toml_key(k: str) -> str:
    return k if _BARE_KEY.match(k) else _toml_string(k)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)  # shortest exact repr; inf, -inf, nan are TOML too
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    # numpy scalars and the like
    if hasattr(v, "item"):
        return _toml_value(v.item())
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _dump_document(doc: dict, header: str = "") -> str:
    lines = [f"# {header}", ""] if header else []

    def table(title: str, values: Mapping) -> None:
        lines.append(f"[{title}]")
        lines.extend(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in values.items())
        lines.append("")

    for name in ("meta", "vehicle", "sensors"):
        table(name, doc[name])
    if doc["plant"]:
        table("plant", doc["plant"])
    for name in ("tuning", "scores", "identified"):
        for sub, values in doc[name].items():
            table(f"{name}.{_toml_key(sub)}", values)
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# built-in cars

_BUILTIN_DIR = Path(__file__).with_name("vehicles")
#: the default car
DEFAULT_VEHICLE = "suv-paper"


def builtin_names() -> tuple[str, ...]:
    """Names of the shipped cars (``src/roadbank/vehicles/*.toml``), default first."""
    names = sorted(p.stem for p in _BUILTIN_DIR.glob("*.toml"))
    return tuple(sorted(names, key=lambda n: n != DEFAULT_VEHICLE))


BUILTINS = builtin_names()


def load_vehicle(spec: "str | Path | Vehicle | None" = None) -> Vehicle:
    """The car ``spec`` names: None = the paper's SUV, a built-in name, or a path to a .toml file.

    Parameters
    ----------
    spec : str, Path, Vehicle or None
        ``None`` -> ``"suv-paper"``; a name from :func:`builtin_names`; a file path.

    Raises
    ------
    VehicleFileError
        Unknown name / missing file, or a malformed file.
    """
    if isinstance(spec, Vehicle):
        return spec
    if spec is None:
        spec = DEFAULT_VEHICLE
    text = str(spec)
    path = Path(spec)
    if isinstance(spec, str) and text in builtin_names() and not path.suffix:
        return Vehicle.from_toml(_BUILTIN_DIR / f"{text}.toml")
    if path.suffix.lower() == ".toml" or path.exists() or "/" in text or "\\" in text:
        return Vehicle.from_toml(path)
    close = difflib.get_close_matches(text, builtin_names(), n=1)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    raise VehicleFileError(f"{text}: not a vehicle file and not a built-in car "
                           f"(built-in: {', '.join(builtin_names())}){hint}")

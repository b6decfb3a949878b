"""Vehicle parameters shared by the models, the estimators and the simulator.

The defaults are the paper's Table 1 (a front-wheel-drive SUV) for the bicycle
model quantities; the quantities the paper does not give (steering ratio, roll
data, geometry) are plausible values for a mid-size SUV, documented per field.
All values are SI (kg, m, s, rad, N).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .constants import G

__all__ = ["G", "VehicleParams", "ESP_RATE", "ESP_AY_NOISE", "ESP_AY_RESOLUTION", "ESP_AY_RANGE", "ESP_R_NOISE",
           "ESP_R_RESOLUTION", "ESP_R_RANGE", "ESP_SPEED_NOISE", "ESP_SPEED_RESOLUTION", "ESP_STEERING_NOISE",
           "ESP_STEERING_RESOLUTION", "ESP_STEERING_RANGE"]

# The paper's ESP sensor cluster (SI), written once: the defaults of a car's sensors
# (roadbank.vehicle.SensorSpec) and of the simulator's (roadbank.sim.SensorConfig)
#: sample rate of every channel (Hz)
ESP_RATE = 100.0
#: lateral accelerometer: white-noise standard deviation, quantisation step, saturation (m/s^2)
ESP_AY_NOISE = 0.03
ESP_AY_RESOLUTION = 0.005 * G
ESP_AY_RANGE = 1.8 * G
#: yaw-rate sensor: white-noise standard deviation, quantisation step, saturation (rad/s)
ESP_R_NOISE = math.radians(0.1)
ESP_R_RESOLUTION = math.radians(0.3)
ESP_R_RANGE = math.radians(100.0)
#: wheel-speed vehicle speed: white-noise standard deviation, quantisation step (m/s)
ESP_SPEED_NOISE = 0.02
ESP_SPEED_RESOLUTION = 0.01
#: steering-wheel angle sensor: white-noise standard deviation, quantisation step, saturation (rad)
ESP_STEERING_NOISE = 0.0
ESP_STEERING_RESOLUTION = math.radians(0.1)
ESP_STEERING_RANGE = math.radians(780.0)


@dataclass(frozen=True)
class VehicleParams:
    """Vehicle parameters (SI units).

    Parameters
    ----------
    m : float
        Total mass (kg). Paper Table 1: 1687.
    Iz : float
        Yaw moment of inertia about the CG (kg m^2). Table 1: 3401.
    Lf, Lr : float
        Distances from the CG to the front / rear axle (m). Table 1: 1.15, 1.47.
    Cf, Cr : float
        Front / rear *axle* cornering stiffness (N/rad), i.e. both tyres of an
        axle together. Table 1: Cf_ss = 115 000, Cr_ss = 396 820.
    steering_ratio : float
        Steering-wheel angle / front road-wheel angle (-). SUV default 16.
    h_cg : float
        CG height above ground (m). SUV default 0.70.
    h_roll : float
        Roll-axis height below the CG at the CG station (m); the roll arm of
        the sprung mass. SUV default 0.50 (roll centre about 0.2 m above ground).
    ms : float
        Sprung mass (kg). Default 1527 (m minus 160 kg unsprung).
    Ixx : float
        Roll moment of inertia of the sprung mass about the roll axis (kg m^2).
        Default 750.
    k_roll : float
        Total roll stiffness of both axles (N m/rad). Default 84 000, which with
        ``ms``, ``h_roll`` gives a steady roll gain of about 0.6 deg per m/s^2.
    c_roll : float
        Total roll damping (N m s/rad). Default 6 500 (damping ratio ~0.4).
    roll_stiffness_front_share : float
        Fraction of the roll stiffness carried by the front axle (-). Default 0.6.
    track_f, track_r : float
        Front / rear track widths (m). Default 1.62, 1.62.
    wheel_radius : float
        Loaded tyre radius (m). Default 0.36.
    wheel_inertia : float
        Spin inertia of one wheel with its share of the driveline (kg m^2).
        Default 1.2.
    g : float
        Gravity (m/s^2), :data:`roadbank.constants.G` (9.81).
    """

    m: float = 1687.0
    Iz: float = 3401.0
    Lf: float = 1.15
    Lr: float = 1.47
    Cf: float = 115_000.0
    Cr: float = 396_820.0
    steering_ratio: float = 16.0
    h_cg: float = 0.70
    h_roll: float = 0.50
    ms: float = 1527.0
    Ixx: float = 750.0
    k_roll: float = 84_000.0
    c_roll: float = 6_500.0
    roll_stiffness_front_share: float = 0.6
    track_f: float = 1.62
    track_r: float = 1.62
    wheel_radius: float = 0.36
    wheel_inertia: float = 1.2
    g: float = G

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not isinstance(v, (int, float)) or isinstance(v, bool):
                raise TypeError(f"VehicleParams.{f.name} must be a number, got {type(v).__name__}")
            if not math.isfinite(v):
                raise ValueError(f"VehicleParams.{f.name} must be finite, got {v}")
        positive = ("m", "Iz", "Lf", "Lr", "Cf", "Cr", "steering_ratio", "h_cg", "ms", "Ixx",
                    "k_roll", "track_f", "track_r", "wheel_radius", "wheel_inertia", "g")
        for name in positive:
            if getattr(self, name) <= 0:
                raise ValueError(f"VehicleParams.{name} must be > 0, got {getattr(self, name)}")
        if self.h_roll < 0 or self.c_roll < 0:
            raise ValueError("VehicleParams.h_roll and c_roll must be >= 0")
        if self.ms > self.m:
            raise ValueError(f"VehicleParams.ms ({self.ms} kg) cannot exceed the total mass m ({self.m} kg)")
        if not 0.0 <= self.roll_stiffness_front_share <= 1.0:
            raise ValueError("VehicleParams.roll_stiffness_front_share must be in [0, 1]")
        if self.h_roll > self.h_cg:
            raise ValueError("VehicleParams.h_roll (roll arm) cannot exceed the CG height h_cg")
        if self.k_roll <= self.ms * self.g * self.h_roll:
            raise ValueError(
                "VehicleParams: roll stiffness k_roll must exceed ms*g*h_roll "
                f"({self.ms * self.g * self.h_roll:.0f} N m/rad) or the body is unstable in roll")

    @property
    def L(self) -> float:
        """Wheelbase Lf + Lr (m)."""
        return self.Lf + self.Lr

    def replace(self, **changes: float) -> "VehicleParams":
        """Return a copy with some fields changed (validated), e.g. ``p.replace(Cf=1.2 * p.Cf)``."""
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise TypeError(f"VehicleParams has no field(s) {sorted(unknown)}")
        return dataclasses.replace(self, **changes)

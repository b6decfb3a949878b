"""Plant-only parameters of the simulator: tyres, powertrain, brakes, aerodynamics.

:class:`PlantParams` wraps a :class:`roadbank.VehicleParams` (mass, inertia,
geometry, roll data, axle cornering stiffnesses ``Cf``, ``Cr``) and adds what
only the simulation plant needs. :meth:`PlantParams.pack` flattens it into the
float64 array the compiled plant reads; the index constants ``P_*`` below name
its entries.

Cornering stiffness convention
------------------------------
Each tyre's linear cornering stiffness at its *static* load on a flat road is
``cornering_scale_front * Cf / 2`` (front) and ``cornering_scale_rear * Cr / 2``
(rear), so the axle totals equal ``Cf_ss``, ``Cr_ss`` of the estimators when the
scales are 1, and the paper's "Cf = 1.2 Cf_ss" is ``cornering_scale_front=1.2``.
Away from the static load the stiffness follows the Magic-Formula load law
``Ky(Fz) = Ky0 * s(Fz) / s(Fz0)``, ``s(F) = sin(2 atan(F / (pky2 Fz0)))``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..params import VehicleParams


@dataclass(frozen=True)
class TyreParams:
    """Magic-Formula-type tyre data shared by the four tyres (SI, dimensionless).

    Pure slip (per tyre, ``x`` = slip, ``D = mu_road * (1 + pd2 * dfz) * Fz``,
    ``dfz = (Fz - Fz0)/Fz0``, ``B = K / (C D)``)::

        F = D sin(C atan(B x - E (B x - atan(B x))))

    Lateral slip ``x = tan(alpha)`` (MF 6.x convention), ``K = Ky(Fz)`` from the
    axle stiffness (see module doc); longitudinal slip ``x = kappa`` (transient,
    relaxation length ``sigma_x``), ``K = kx_per_fz * Fz``.

    Combined slip uses MF-style cosine weighting with shape factor 1 (cheap and
    smooth, no shifts)::

        Fy = Fy0 / sqrt(1 + (Byk kappa)^2),   Byk = rby1 / sqrt(1 + (rby2 tan(alpha))^2)
        Fx = Fx0 / sqrt(1 + (Bxa tan(alpha))^2), Bxa = rbx1 / sqrt(1 + (rbx2 kappa)^2)

    Parameters
    ----------
    Cy, Ey : float
        Lateral shape and curvature factors (defaults 1.30, -0.60; passenger/SUV tyre).
    Cx, Ex : float
        Longitudinal shape and curvature factors (1.65, 0.0).
    pky2 : float
        Load at which the cornering stiffness peaks, in units of the static load
        (2.0: degressive load sensitivity). Use a very large value (1e6) for a
        stiffness proportional to load.
    pdy2, pdx2 : float
        Friction load sensitivity: ``mu(Fz) = mu_road (1 + pd2 dfz)`` (-0.08).
    kx_per_fz : float
        Longitudinal slip stiffness per unit load (-), 20.
    rby1, rby2, rbx1, rbx2 : float
        Combined-slip weighting coefficients (7.0, 9.0, 13.0, 13.8).
    sigma_x : float
        Longitudinal relaxation length (m), 0.25. Makes the wheel-spin dynamics
        well conditioned at every speed (no 1/vx stiffness).
    rolling_resistance : float
        Rolling resistance coefficient (-), 0.012, applied as a wheel torque.
    """

    Cy: float = 1.30
    Ey: float = -0.60
    Cx: float = 1.65
    Ex: float = 0.0
    pky2: float = 2.0
    pdy2: float = -0.08
    pdx2: float = -0.08
    kx_per_fz: float = 20.0
    rby1: float = 7.0
    rby2: float = 9.0
    rbx1: float = 13.0
    rbx2: float = 13.8
    sigma_x: float = 0.25
    rolling_resistance: float = 0.012

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise ValueError(f"TyreParams.{f.name} must be a finite number, got {v!r}")
        # The compiled fast sine is accurate for |arg| <= 2.6, i.e. C <= 1.65.
        for name in ("Cy", "Cx"):
            if not 0.5 <= getattr(self, name) <= 1.65:
                raise ValueError(f"TyreParams.{name} must be in [0.5, 1.65]")
        for name in ("Ey", "Ex"):
            if getattr(self, name) > 1.0:
                raise ValueError(f"TyreParams.{name} must be <= 1")
        for name in ("pky2", "kx_per_fz", "sigma_x"):
            if getattr(self, name) <= 0:
                raise ValueError(f"TyreParams.{name} must be > 0")


# ---- indices into the packed parameter array --------------------------------
(P_M, P_IZ, P_LF, P_LR, P_HCG, P_HROLL, P_MS, P_IXX, P_KROLL, P_CROLL, P_SHAREF,
 P_TF, P_TR, P_RW, P_IW, P_G, P_RATIO,
 P_KY0F, P_KY0R, P_FZ0F, P_FZ0R, P_PKY2, P_CY, P_EY, P_CX, P_EX, P_PDY2, P_PDX2,
 P_KX, P_RBY1, P_RBY2, P_RBX1, P_RBX2, P_SIGX, P_FRR,
 P_MU, P_TDRIVE, P_PDRIVE, P_TBRAKE, P_BRAKEF, P_CDA, P_RHO, P_HSENS, P_TAULOAD,
 P_MUNSPRUNG, N_PARAMS) = range(46)


@dataclass(frozen=True)
class PlantParams:
    """Everything the simulation plant needs (SI).

    Parameters
    ----------
    vehicle : VehicleParams
        Body, geometry, roll data and the *design* axle cornering stiffnesses.
    tyre : TyreParams
        Magic-Formula shape data.
    mu : float
        Road friction coefficient (peak, at static load). Default 0.85.
    cornering_scale_front, cornering_scale_rear : float
        Scale of the plant tyres' cornering stiffness against ``vehicle.Cf``,
        ``vehicle.Cr`` (the paper's ``Cf = 1.2 Cf_ss`` is ``1.2``).
    drive_torque_max : float
        Maximum total drive torque at the front wheels (N m), 3500.
    drive_power_max : float
        Maximum drive power (W), 150 kW; torque is limited to P / omega.
    brake_torque_max : float
        Total brake torque at full pedal (N m), 9000 (about 1.5 g).
    brake_front_share : float
        Fraction of the brake torque on the front axle, 0.65.
    CdA : float
        Drag area (m^2), 1.0. ``air_density`` (kg/m^3), 1.2.
    accel_height : float
        Height of the lateral accelerometer above the roll axis (m), 0: the ESP
        cluster sits on the floor near the CG, close to the roll axis.
    load_transfer_lag : float
        Time constant (s) of the specific forces used for load transfer (stands
        in for pitch/heave dynamics and removes the algebraic loop), 0.05.
    """

    vehicle: VehicleParams = field(default_factory=VehicleParams)
    tyre: TyreParams = field(default_factory=TyreParams)
    mu: float = 0.85
    cornering_scale_front: float = 1.0
    cornering_scale_rear: float = 1.0
    drive_torque_max: float = 3500.0
    drive_power_max: float = 150e3
    brake_torque_max: float = 9000.0
    brake_front_share: float = 0.65
    CdA: float = 1.0
    air_density: float = 1.2
    accel_height: float = 0.0
    load_transfer_lag: float = 0.05

    def __post_init__(self) -> None:
        if not isinstance(self.vehicle, VehicleParams):
            raise TypeError("PlantParams.vehicle must be a VehicleParams")
        if not isinstance(self.tyre, TyreParams):
            raise TypeError("PlantParams.tyre must be a TyreParams")
        for name in ("mu", "cornering_scale_front", "cornering_scale_rear", "drive_torque_max",
                     "drive_power_max", "brake_torque_max", "load_transfer_lag"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"PlantParams.{name} must be a finite number > 0, got {v!r}")
        if not 0.0 <= self.brake_front_share <= 1.0:
            raise ValueError("PlantParams.brake_front_share must be in [0, 1]")
        if self.CdA < 0 or self.air_density < 0:
            raise ValueError("PlantParams.CdA and air_density must be >= 0")

    def replace(self, **changes) -> "PlantParams":
        """Copy with fields changed, e.g. ``p.replace(mu=0.3)``."""
        return dataclasses.replace(self, **changes)

    @property
    def static_loads(self) -> tuple[float, float]:
        """Static vertical load of one front and one rear tyre on a flat road (N)."""
        v = self.vehicle
        return (v.m * v.g * v.Lr / v.L / 2.0, v.m * v.g * v.Lf / v.L / 2.0)

    @property
    def axle_cornering_stiffness(self) -> tuple[float, float]:
        """Plant axle cornering stiffnesses at static load (N/rad): scaled Cf, Cr."""
        return (self.cornering_scale_front * self.vehicle.Cf, self.cornering_scale_rear * self.vehicle.Cr)

    def pack(self) -> np.ndarray:
        """Flat float64 array for the compiled plant (see the ``P_*`` indices)."""
        v, t = self.vehicle, self.tyre
        p = np.zeros(N_PARAMS)
        fz0f, fz0r = self.static_loads
        cf, cr = self.axle_cornering_stiffness
        p[P_M], p[P_IZ], p[P_LF], p[P_LR] = v.m, v.Iz, v.Lf, v.Lr
        p[P_HCG], p[P_HROLL], p[P_MS], p[P_IXX] = v.h_cg, v.h_roll, v.ms, v.Ixx
        p[P_KROLL], p[P_CROLL], p[P_SHAREF] = v.k_roll, v.c_roll, v.roll_stiffness_front_share
        p[P_TF], p[P_TR], p[P_RW], p[P_IW], p[P_G] = v.track_f, v.track_r, v.wheel_radius, v.wheel_inertia, v.g
        p[P_RATIO] = v.steering_ratio
        p[P_KY0F], p[P_KY0R] = cf / 2.0, cr / 2.0
        p[P_FZ0F], p[P_FZ0R] = fz0f, fz0r
        p[P_PKY2], p[P_CY], p[P_EY], p[P_CX], p[P_EX] = t.pky2, t.Cy, t.Ey, t.Cx, t.Ex
        p[P_PDY2], p[P_PDX2], p[P_KX] = t.pdy2, t.pdx2, t.kx_per_fz
        p[P_RBY1], p[P_RBY2], p[P_RBX1], p[P_RBX2] = t.rby1, t.rby2, t.rbx1, t.rbx2
        p[P_SIGX], p[P_FRR] = t.sigma_x, t.rolling_resistance
        p[P_MU], p[P_TDRIVE] = self.mu, self.drive_torque_max
        p[P_PDRIVE], p[P_TBRAKE] = self.drive_power_max, self.brake_torque_max
        p[P_BRAKEF], p[P_CDA], p[P_RHO] = self.brake_front_share, self.CdA, self.air_density
        p[P_HSENS], p[P_TAULOAD] = self.accel_height, self.load_transfer_lag
        p[P_MUNSPRUNG] = v.m - v.ms
        return p

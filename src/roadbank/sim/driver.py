"""Driver models: speed PI control, open-loop steering profiles, a preview path follower.

The driver runs inside the compiled integration loop at the integration rate
(zero-order hold on the plant inputs during an RK4 step).

Speed control
    ``a_cmd = kp (v_ref(t) - vx) + ki int (v_ref - vx) dt``, turned into a drive
    force ``m a_cmd`` and mapped to throttle (drive torque available at the
    current speed) or brake pedal; the integrator is clamped (anti-windup).
Open-loop steering
    Steering-wheel angle ``swa(t)`` through knots with raised-cosine
    interpolation (smooth ramps and holds), e.g. the paper's S-curve.
Path follower (lane keeping, lane changes)
    Preview point ``Lp = max(preview_min, preview_time * vx)`` ahead; lateral
    error there against the reference offset ``n_ref(s + Lp)`` (knots in path
    distance, raised-cosine between them, so a lane change is a smooth S):
    ``e = n_ref(s + Lp) - (n + Lp sin(psi + vy/vx))``; curvature command
    ``kappa_cmd = kappa_lane + 2 e / Lp^2``; road-wheel angle
    ``delta = (L + Kus vx^2) kappa_cmd + ki_lat int e dt`` (``Kus`` the driver's
    estimate of the understeer gradient from the design parameters; the
    integral removes the offset on a bank), then a first-order lag
    ``steer_lag`` and a rate limit on the steering wheel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from ..params import VehicleParams
from .road import _wrap, interp1, knots
from .tyres import fast_sincos

MODE_OPEN_LOOP, MODE_PATH = 0, 1
(G_MODE, G_KPV, G_KIV, G_TPREV, G_LPMIN, G_KILAT, G_TAUS, G_SWARATE, G_KUS, G_L, G_RATIO,
 G_M, G_RW, G_TDRIVE, G_PDRIVE, G_TBRAKE, G_SWAMAX, G_COAST, N_GAINS) = range(19)
D_VINT, D_LATINT, D_SWA = 0, 1, 2
ND = 3


@dataclass(frozen=True)
class Driver:
    """A driver: speed target plus either a steering profile or a lateral path.

    Parameters
    ----------
    speed : (t_knots, v_knots)
        Speed target (m/s) against time (s), piecewise linear. A float means constant.
    steering : (t_knots, swa_knots) or None
        Open-loop steering-wheel angle (rad) against time, raised-cosine
        interpolation. Exactly one of ``steering`` and ``path`` is given.
    path : (s_knots, n_knots) or None
        Reference lateral offset (m) against path distance (m), raised-cosine
        interpolation; held beyond the end knots.
    kp_speed, ki_speed : float
        Speed PI gains (1/s, 1/s^2). Defaults 1.5, 0.5.
    preview_time, preview_min : float
        Preview time (s) and minimum preview distance (m). Defaults 1.0 s, 12 m.
    ki_lateral : float
        Integral gain on the preview error (rad/(m s)). Default 0.02.
    steer_lag : float
        Time constant of the driver's steering (s). Default 0.08.
    steer_rate_max : float
        Steering-wheel rate limit (rad/s). Default 12 (about 700 deg/s).
    coast : bool
        If True the pedals stay released (no speed control); ``speed`` then only
        gives the initial speed.
    """

    # given as documented above, held as knot arrays ``(x, y)`` after ``__post_init__``
    speed: Any = 22.2
    steering: Any = None
    path: Any = None
    kp_speed: float = 1.5
    ki_speed: float = 0.5
    preview_time: float = 1.0
    preview_min: float = 12.0
    ki_lateral: float = 0.02
    steer_lag: float = 0.08
    steer_rate_max: float = 12.0
    coast: bool = False

    def __post_init__(self) -> None:
        sp = self.speed
        if isinstance(sp, (int, float)):
            sp = ((0.0,), (float(sp),))
        object.__setattr__(self, "speed", knots("Driver.speed", *sp))
        if (self.steering is None) == (self.path is None):
            raise ValueError("Driver: give exactly one of steering (open loop) or path (closed loop)")
        if self.steering is not None:
            object.__setattr__(self, "steering", knots("Driver.steering", *self.steering))
        else:
            object.__setattr__(self, "path", knots("Driver.path", *self.path))
        for name in ("preview_time", "preview_min", "steer_lag", "steer_rate_max"):
            if not getattr(self, name) > 0:
                raise ValueError(f"Driver.{name} must be > 0")

    @property
    def closed_loop(self) -> bool:
        return self.path is not None

    def initial_speed(self) -> float:
        return float(self.speed[1][0])

    def pack(self, plant) -> np.ndarray:
        """Flat float64 array for the compiled driver; ``plant`` is a :class:`PlantParams`."""
        v: VehicleParams = plant.vehicle
        g = np.zeros(N_GAINS)
        g[G_MODE] = MODE_PATH if self.closed_loop else MODE_OPEN_LOOP
        g[G_KPV], g[G_KIV] = self.kp_speed, self.ki_speed
        g[G_TPREV], g[G_LPMIN], g[G_KILAT] = self.preview_time, self.preview_min, self.ki_lateral
        g[G_TAUS], g[G_SWARATE] = self.steer_lag, self.steer_rate_max
        # the driver knows the car from its design data (not the plant's tyres)
        g[G_KUS] = v.m / v.L * (v.Lr / v.Cf - v.Lf / v.Cr)
        g[G_L], g[G_RATIO], g[G_M], g[G_RW] = v.L, v.steering_ratio, v.m, v.wheel_radius
        g[G_TDRIVE], g[G_PDRIVE], g[G_TBRAKE] = plant.drive_torque_max, plant.drive_power_max, plant.brake_torque_max
        g[G_SWAMAX] = math.radians(720.0)
        g[G_COAST] = 1.0 if self.coast else 0.0
        st = self.steering if self.steering is not None else (np.zeros(1), np.zeros(1))
        pa = self.path if self.path is not None else (np.zeros(1), np.zeros(1))
        # one flat array: gains, then (offset, count) of the speed, steering and path
        # knots, then the knots (no tuple of arrays: no reference counting when compiled)
        hdr = np.zeros(6)
        off = N_GAINS + 6
        for j, (xs, _) in enumerate((self.speed, st, pa)):
            hdr[2 * j], hdr[2 * j + 1] = off, len(xs)
            off += 2 * len(xs)
        return np.concatenate([g, hdr, self.speed[0], self.speed[1], st[0], st[1], pa[0], pa[1]])


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy", no_cpython_wrapper=True,
      no_cfunc_wrapper=True)
def interp_knots(a, off, n, x, smooth):
    """Interpolation through knots ``a[off:off+n]`` -> ``a[off+n:off+2n]``, held beyond the ends.

    Between two knots the weight of the right one is the fraction ``u`` of the
    way (``smooth = 0.0``: piecewise linear) or ``(1 - cos(pi u))/2``
    (``smooth = 1.0``: raised cosine, zero slope at the knots). ``smooth`` is a
    float so that one compiled version serves both.
    """
    ys = off + n
    if n == 1 or x <= a[off]:
        return a[ys]
    if x >= a[off + n - 1]:
        return a[ys + n - 1]
    k = 0
    while a[off + k + 1] < x:
        k += 1
    u = (x - a[off + k]) / (a[off + k + 1] - a[off + k])
    if smooth != 0.0:
        u = 0.5 - 0.5 * fast_sincos(math.pi * u)[1]
    return a[ys + k] + u * (a[ys + k + 1] - a[ys + k])


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def driver_step(t, x, dstate, drv, road, u, dt):
    """Driver at time ``t``: write plant inputs into ``u`` and advance ``dstate`` by ``dt``.

    ``x`` is the plant state (see :mod:`roadbank.sim.plant`), ``dstate`` =
    [speed integrator (m/s^2), lateral integrator (rad), steering-wheel angle (rad)].
    """
    g = drv
    H = N_GAINS
    vx = x[3]
    # ---- speed ------------------------------------------------------------------
    e_v = interp_knots(drv, np.int64(drv[H]), np.int64(drv[H + 1]), t, 0.0) - vx
    a_cmd = g[G_KPV] * e_v + dstate[D_VINT]
    force = g[G_M] * a_cmd
    saturated = False
    if force >= 0.0:
        om = vx / g[G_RW]
        t_av = g[G_TDRIVE]
        if om > 1.0 and g[G_PDRIVE] / om < t_av:
            t_av = g[G_PDRIVE] / om
        thr = force * g[G_RW] / t_av
        saturated = thr >= 1.0
        u[1] = thr if thr < 1.0 else 1.0
        u[2] = 0.0
    else:
        brk = -force * g[G_RW] / g[G_TBRAKE]
        saturated = brk >= 1.0
        u[1] = 0.0
        u[2] = brk if brk < 1.0 else 1.0
    # conditional integration (anti-windup): freeze the integrator while the
    # pedal is saturated in the direction of the error
    if g[G_COAST] != 0.0:
        u[1] = 0.0
        u[2] = 0.0
    elif not (saturated and e_v * force > 0.0):
        vint = dstate[D_VINT] + g[G_KIV] * e_v * dt
        if vint > 6.0:
            vint = 6.0
        elif vint < -8.0:
            vint = -8.0
        dstate[D_VINT] = vint
    # ---- steering -----------------------------------------------------------------
    if g[G_MODE] == MODE_OPEN_LOOP:
        u[0] = interp_knots(drv, np.int64(drv[H + 2]), np.int64(drv[H + 3]), t, 1.0)
        dstate[D_SWA] = u[0]
        return
    s = x[0]
    n = x[1]
    psi = x[2]
    vxs = vx if vx > 1.0 else 1.0
    lp = g[G_TPREV] * vxs
    if lp < g[G_LPMIN]:
        lp = g[G_LPMIN]
    heading = psi + x[4] / vxs
    e = interp_knots(drv, np.int64(drv[H + 4]), np.int64(drv[H + 5]), s + lp, 1.0) - (n + lp * math.sin(heading))
    kap = interp1(road, np.int64(road[1]), np.int64(road[2]), _wrap(road, s + 0.5 * lp))   # road_curvature
    den = 1.0 - n * kap
    kap_cmd = kap / den + 2.0 * e / (lp * lp)
    dstate[D_LATINT] += g[G_KILAT] * e * dt
    delta = (g[G_L] + g[G_KUS] * vxs * vxs) * kap_cmd + dstate[D_LATINT]
    swa_cmd = g[G_RATIO] * delta
    if swa_cmd > g[G_SWAMAX]:
        swa_cmd = g[G_SWAMAX]
    elif swa_cmd < -g[G_SWAMAX]:
        swa_cmd = -g[G_SWAMAX]
    rate = (swa_cmd - dstate[D_SWA]) / g[G_TAUS]
    rmax = g[G_SWARATE]
    if rate > rmax:
        rate = rmax
    elif rate < -rmax:
        rate = -rmax
    dstate[D_SWA] += rate * dt
    u[0] = dstate[D_SWA]

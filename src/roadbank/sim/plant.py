"""The simulation plant: a compiled, pure right-hand side ``f(x, u, road, params)``.

Degrees of freedom (18 states, SI)
---------------------------------
=====  =========  ==========================================================
index  name       meaning
=====  =========  ==========================================================
0      s          path distance of the CG along the road's reference line (m)
1      n          lateral offset of the CG from the reference line (m, left +)
2      psi        heading relative to the reference-line tangent (rad, left +)
3      vx         longitudinal velocity of the chassis (m/s)
4      vy         lateral velocity (m/s)
5      r          yaw rate about the road normal (rad/s, left +)
6      phi        sprung-mass roll relative to the road (rad, left side up +)
7      dphi       roll rate (rad/s)
8-11   omega      wheel spin rates FL, FR, RL, RR (rad/s)
12-15  kappa      transient longitudinal slips FL, FR, RL, RR (-)
16,17  fx_l,fy_l  lagged chassis specific forces used for load transfer (m/s^2)
=====  =========  ==========================================================

Inputs ``u = [steering-wheel angle (rad), throttle (0..1), brake (0..1)]``.

Model
-----
*Chassis* moves in the local road plane; gravity is resolved through the road
normal (bank ``phi_b`` about the road tangent, grade ``theta_g`` about the road
lateral axis, then the heading ``psi``)::

    g_t = -g sin(theta_g),  g_l = -g sin(phi_b) cos(theta_g),  g_n = -g cos(phi_b) cos(theta_g)
    g_x = g_t cos(psi) + g_l sin(psi),      g_y = -g_t sin(psi) + g_l cos(psi)

On a banked curve the lane is (close to) a horizontal circle, so the road pushes
the car along its normal with ``a_N = -v_t^2 kappa_loc tan(phi_b)`` (``kappa_loc``
the in-surface curvature of the lane); the normal specific force is
``f_z = a_N - g_n``.

*Path kinematics* (Frenet)::

    s' = (vx cos psi - vy sin psi) / (1 - n kappa),  n' = vx sin psi + vy cos psi,  psi' = r - kappa s'

*Longitudinal / lateral / roll / yaw* (sprung mass ``ms`` with roll arm ``h`` above
the roll axis, roll stiffness ``k`` and damping ``c`` about it, ``Ixx`` about the roll axis)::

    m (vx' - vy r) = sum Fx - F_aero + m g_x
    m vy' - ms h cos(phi) phi'' = sum Fy + m g_y - m vx r - ms h phi'^2 sin(phi)
    Ixx phi'' - ms h cos(phi) vy' = ms h cos(phi) (vx r - g_y) + ms h sin(phi) f_z - k phi - c phi'
    Iz r' = sum (x_i Fy_i - y_i Fx_i)

*Loads*: axle loads from ``m f_z`` and longitudinal transfer ``m h_cg f_x / L``;
lateral transfer per axle ``[share (k phi + c phi') + (ms_axle h_rc + m_u,axle R_w) f_y] / track``
with the roll-centre height ``h_rc = h_cg - h_roll``. ``f_x, f_y`` are the chassis
specific forces through a first-order lag (``load_transfer_lag``).

*Wheels* (FWD, open differential, brakes with ``brake_front_share``)::

    Iw omega' = T_drive - T_brake sgn(omega) - f_rr Fz R_w sgn(omega) - R_w Fx
    sigma_x kappa' = (R_w omega - v_x,wheel) - |v_x,wheel| kappa

*Tyres*: :func:`roadbank.sim.tyres.tyre_forces` with ``tan(alpha) = -v_y,w / |v_x,w|``
in each wheel frame (front wheels steered by ``delta = swa / steering_ratio``).

The accelerometer (on the sprung mass, ``accel_height`` above the roll axis) reads
``ay = (vy' + vx r - g_y) cos(phi) + f_z sin(phi) - h_s phi''``, i.e.
``dvy/dt + vx r + g sin(phi_b + phi)`` to first order (the paper's eq 2).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .params import (P_BRAKEF, P_CDA, P_CROLL, P_CX, P_CY, P_EX, P_EY, P_FRR, P_FZ0F, P_FZ0R, P_G,
                     P_HCG, P_HROLL, P_HSENS, P_IW, P_IXX, P_IZ, P_KROLL, P_KX, P_KY0F, P_KY0R, P_LF,
                     P_LR, P_M, P_MS, P_MU, P_MUNSPRUNG, P_PDRIVE, P_PDX2, P_PDY2, P_PKY2, P_RATIO,
                     P_RBX1, P_RBX2, P_RBY1, P_RBY2, P_RHO, P_RW, P_SHAREF, P_SIGX, P_TAULOAD,
                     P_TBRAKE, P_TDRIVE, P_TF, P_TR)
from .road import bank_under_vehicle, road_curvature, road_grade
from .tyres import fast_sin, tyre_forces

# state indices
X_S, X_N, X_PSI, X_VX, X_VY, X_R, X_PHI, X_DPHI = range(8)
X_OMEGA = 8   # 8..11
X_KAPPA = 12  # 12..15
X_FXL, X_FYL = 16, 17
NX = 18
# input indices
U_SWA, U_THROTTLE, U_BRAKE = 0, 1, 2
NU = 3
# auxiliary outputs of the plant evaluation
(A_PHIB, A_GRADE, A_KAPPA, A_FX, A_FY, A_FZ, A_AY, A_AX, A_DVY, A_DDPHI, A_DELTA) = range(11)
A_FZW = 11   # 11..14 wheel loads
A_FXW = 15   # 15..18 wheel-frame longitudinal forces
A_FYW = 19   # 19..22 wheel-frame lateral forces
A_TANA = 23  # 23..26 tan(slip angle)
NAUX = 27

_VX_FLOOR = 1.0  # m/s, denominator floor of the slip definitions


@njit(cache=True, inline="always", fastmath=True)
def _sin_cos_small(a):
    """(sin a, cos a) for |a| < pi/2 with the polynomial sine."""
    s = fast_sin(a)
    return s, math.sqrt(1.0 - s * s)


@njit(cache=True, fastmath=True)
def plant_eval(x, u, road, p, dx, aux, want_aux):
    """Evaluate the plant: write dx/dt into ``dx`` and, if ``want_aux``, outputs into ``aux``.

    ``x`` (NX,), ``u`` (NU,), ``road`` from :meth:`Road.pack`, ``p`` from
    :meth:`PlantParams.pack`. No allocation.
    """
    m = p[P_M]
    g = p[P_G]
    lf = p[P_LF]
    lr = p[P_LR]
    L = lf + lr
    tf = p[P_TF]
    tr = p[P_TR]
    rw = p[P_RW]
    ms = p[P_MS]
    h = p[P_HROLL]

    s = x[X_S]
    n = x[X_N]
    psi = x[X_PSI]
    vx = x[X_VX]
    vy = x[X_VY]
    r = x[X_R]
    phi = x[X_PHI]
    dphi = x[X_DPHI]

    delta = u[U_SWA] / p[P_RATIO]

    # ---- road and gravity --------------------------------------------------
    kap = road_curvature(road, s)
    grade = road_grade(road, s)
    phib = bank_under_vehicle(road, s, n, 0.25 * (tf + tr))
    sb, cb = _sin_cos_small(phib)
    sg, cg = _sin_cos_small(grade)
    cpsi = math.cos(psi)
    spsi = math.sin(psi)
    g_t = -g * sg
    g_l = -g * sb * cg
    g_n = -g * cb * cg
    gx = g_t * cpsi + g_l * spsi
    gy = -g_t * spsi + g_l * cpsi

    den = 1.0 - n * kap
    if den < 0.1:
        den = 0.1
    vt = vx * cpsi - vy * spsi
    sdot = vt / den
    a_n = -vt * vt * (kap / den) * (sb / cb)
    fz_spec = a_n - g_n

    # ---- wheel loads -------------------------------------------------------
    fxl = x[X_FXL]
    fyl = x[X_FYL]
    ntot = m * fz_spec
    fzf = ntot * lr / L - m * p[P_HCG] * fxl / L
    fzr = ntot * lf / L + m * p[P_HCG] * fxl / L
    mroll = p[P_KROLL] * phi + p[P_CROLL] * dphi
    hrc = p[P_HCG] - h
    mu_ax = 0.5 * p[P_MUNSPRUNG]
    share = p[P_SHAREF]
    dff = (share * mroll + (ms * lr / L * hrc + mu_ax * rw) * fyl) / tf
    dfr = ((1.0 - share) * mroll + (ms * lf / L * hrc + mu_ax * rw) * fyl) / tr

    # ---- drive and brake torques ---------------------------------------------
    om_f = 0.5 * (x[X_OMEGA] + x[X_OMEGA + 1])
    t_avail = p[P_TDRIVE]
    if om_f > 1.0 and p[P_PDRIVE] / om_f < t_avail:
        t_avail = p[P_PDRIVE] / om_f
    t_drive = 0.5 * u[U_THROTTLE] * t_avail
    t_brake = u[U_BRAKE] * p[P_TBRAKE]
    bf = p[P_BRAKEF]

    cd = math.cos(delta)
    sd = math.sin(delta)
    sum_fx = 0.0
    sum_fy = 0.0
    sum_mz = 0.0
    mu = p[P_MU]
    for i in range(4):
        front = i < 2
        xw = lf if front else -lr
        if front:
            yw = 0.5 * tf if i == 0 else -0.5 * tf
            fz = 0.5 * fzf - dff if i == 0 else 0.5 * fzf + dff
            ky0 = p[P_KY0F]
            fz0 = p[P_FZ0F]
        else:
            yw = 0.5 * tr if i == 2 else -0.5 * tr
            fz = 0.5 * fzr - dfr if i == 2 else 0.5 * fzr + dfr
            ky0 = p[P_KY0R]
            fz0 = p[P_FZ0R]
        vxc = vx - yw * r
        vyc = vy + xw * r
        if front:
            vxw = vxc * cd + vyc * sd
            vyw = -vxc * sd + vyc * cd
        else:
            vxw = vxc
            vyw = vyc
        avx = abs(vxw)
        tana = -vyw / (avx if avx > _VX_FLOOR else _VX_FLOOR)
        kappa = x[X_KAPPA + i]
        fxw, fyw = tyre_forces(tana, kappa, fz, mu, ky0, fz0, p[P_PKY2], p[P_CY], p[P_EY], p[P_PDY2],
                               p[P_KX], p[P_CX], p[P_EX], p[P_PDX2],
                               p[P_RBY1], p[P_RBY2], p[P_RBX1], p[P_RBX2])
        if front:
            fxc = fxw * cd - fyw * sd
            fyc = fxw * sd + fyw * cd
        else:
            fxc = fxw
            fyc = fyw
        sum_fx += fxc
        sum_fy += fyc
        sum_mz += xw * fyc - yw * fxc
        # wheel spin and transient slip
        om = x[X_OMEGA + i]
        sgn = om / (abs(om) + 0.5)
        tb = t_brake * (0.5 * bf if front else 0.5 * (1.0 - bf))
        fzp = fz if fz > 0.0 else 0.0
        torque = (t_drive if front else 0.0) - tb * sgn - p[P_FRR] * fzp * rw * sgn - rw * fxw
        dx[X_OMEGA + i] = torque / p[P_IW]
        dx[X_KAPPA + i] = ((rw * om - vxw) - avx * kappa) / p[P_SIGX]
        if want_aux:
            aux[A_FZW + i] = fz
            aux[A_FXW + i] = fxw
            aux[A_FYW + i] = fyw
            aux[A_TANA + i] = tana

    f_aero = 0.5 * p[P_RHO] * p[P_CDA] * vx * abs(vx)

    # ---- body dynamics -------------------------------------------------------
    sphi = math.sin(phi)
    cphi = math.cos(phi)
    msh = ms * h
    a12 = -msh * cphi
    ixx = p[P_IXX]
    b1 = sum_fy + m * gy - m * vx * r - msh * dphi * dphi * sphi
    b2 = msh * cphi * (vx * r - gy) + msh * sphi * fz_spec - mroll
    det = m * ixx - a12 * a12
    dvy = (ixx * b1 - a12 * b2) / det
    ddphi = (m * b2 - a12 * b1) / det
    fx_spec = (sum_fx - f_aero) / m
    fy_spec = sum_fy / m

    dx[X_S] = sdot
    dx[X_N] = vx * spsi + vy * cpsi
    dx[X_PSI] = r - kap * sdot
    dx[X_VX] = vy * r + gx + fx_spec
    dx[X_VY] = dvy
    dx[X_R] = sum_mz / p[P_IZ]
    dx[X_PHI] = dphi
    dx[X_DPHI] = ddphi
    tau = p[P_TAULOAD]
    dx[X_FXL] = (fx_spec - fxl) / tau
    dx[X_FYL] = (fy_spec - fyl) / tau

    if want_aux:
        aux[A_PHIB] = phib
        aux[A_GRADE] = grade
        aux[A_KAPPA] = kap
        aux[A_FX] = fx_spec
        aux[A_FY] = fy_spec
        aux[A_FZ] = fz_spec
        aux[A_AY] = (dvy + vx * r - gy) * cphi + fz_spec * sphi - p[P_HSENS] * ddphi
        aux[A_AX] = fx_spec
        aux[A_DVY] = dvy
        aux[A_DDPHI] = ddphi
        aux[A_DELTA] = delta


@njit(cache=True, fastmath=True)
def f(x, u, road, params):
    """Pure right-hand side ``dx/dt = f(x, u, road, params)`` (allocates the result).

    See the module docstring for the states, inputs and equations.
    """
    dx = np.empty(NX)
    aux = np.empty(NAUX)
    plant_eval(x, u, road, params, dx, aux, False)
    return dx


@njit(cache=True, fastmath=True)
def outputs(x, u, road, params):
    """Auxiliary outputs (``A_*`` indices) at one state: loads, forces, specific forces, dvy/dt."""
    dx = np.empty(NX)
    aux = np.empty(NAUX)
    plant_eval(x, u, road, params, dx, aux, True)
    return aux

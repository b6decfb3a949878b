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
from .road import road_at
from .tyres import fast_sin, fast_sincos, tyre_core

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

# ---- derived constants (prepare(p)): scalars, then per-wheel blocks of 4 (FL, FR, RL, RR) --------
# Everything the plant needs that does not depend on the state, reciprocals
# instead of divisions, and the wheel data as struct-of-arrays so that the loop
# over the four wheels compiles to SIMD code.
(Q_M, Q_G, Q_INV_M, Q_HALF_TRACK, Q_INV_RATIO, Q_TDRIVE, Q_PDRIVE, Q_TBRAKE, Q_MU,
 Q_CY, Q_EY, Q_PDY2, Q_KX, Q_CX, Q_EX, Q_PDX2, Q_RBY1SQ, Q_RBY2, Q_RBX1SQ, Q_RBX2, Q_KYNORM,
 Q_RW, Q_FRR_RW, Q_INV_IW, Q_INV_SIGX, Q_AERO, Q_MSH, Q_IXX, Q_INV_IZ, Q_INV_TAU, Q_HSENS,
 Q_KROLL, Q_CROLL, NQS) = range(34)
Q_XW = NQS            # wheel x position (m)
Q_YW = Q_XW + 4       # wheel y position (m)
Q_KY0 = Q_YW + 4      # cornering stiffness at static load (N/rad)
Q_INVFZ0 = Q_KY0 + 4  # 1 / static load
Q_INVFZPK = Q_INVFZ0 + 4  # 1 / (pky2 static load)
Q_LN = Q_INVFZPK + 4  # load per unit normal force m f_z (-)
Q_LX = Q_LN + 4       # load per unit lagged f_x (kg)
Q_LR = Q_LX + 4       # load per unit roll moment (1/m)
Q_LY = Q_LR + 4       # load per unit lagged f_y (kg)
Q_DRIVE = Q_LY + 4    # share of the drive torque
Q_BRAKE = Q_DRIVE + 4  # share of the brake torque
# per-step blocks (step_inputs) and per-evaluation scratch (plant_core): the wheel loop reads
# and writes only this array, so LLVM sees no aliasing and vectorises it
Q_CW = Q_BRAKE + 4    # cos of the wheel steer angle (1 at the rear)
Q_SW = Q_CW + 4       # sin of the wheel steer angle (0 at the rear)
Q_TB = Q_SW + 4       # brake torque per wheel (N m)
Q_OM = Q_TB + 4       # in: wheel spins
Q_KA = Q_OM + 4       # in: transient slips
Q_OFXC = Q_KA + 4     # out: chassis-frame forces, yaw moments, state derivatives, aux
Q_OFYC = Q_OFXC + 4
Q_OMZ = Q_OFYC + 4
Q_ODOM = Q_OMZ + 4
Q_ODKA = Q_ODOM + 4
Q_OFZ = Q_ODKA + 4
Q_OFXW = Q_OFZ + 4
Q_OFYW = Q_OFXW + 4
Q_OTANA = Q_OFYW + 4
# scalars of the last evaluation that only the auxiliary outputs need (written by every
# plant_core call, read by _fill_aux): bank, grade, curvature, specific forces, gravity
# along y, roll sine and cosine
(Q_APHIB, Q_AGRADE, Q_AKAP, Q_AFX, Q_AFY, Q_AFZ, Q_AGY, Q_ASPHI, Q_ACPHI) = range(Q_OTANA + 4, Q_OTANA + 13)
NQ = Q_OTANA + 13

# ---- per-step scalars (step_inputs(u, q, c)): the inputs are held over an RK4 step ---------
(C_DELTA, C_THROTTLE, NC) = range(3)


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def _sin_cos_small(a):
    """(sin a, cos a) for |a| < pi/2 with the polynomial sine (exactly (0, 1) at 0: flat roads skip it)."""
    if a == 0.0:
        return 0.0, 1.0
    s = fast_sin(a)
    return s, math.sqrt(1.0 - s * s)


def prepare(p) -> np.ndarray:
    """Derived constants ``q`` (``Q_*`` indices, length ``NQ``) from the packed parameters ``p`` (once per run).

    Plain Python (about 50 us, once per run): nothing to compile.
    """
    p = [float(v) for v in np.asarray(p, dtype=np.float64)]
    q = np.zeros(NQ)
    m = p[P_M]
    lf = p[P_LF]
    lr = p[P_LR]
    L = lf + lr
    tf = p[P_TF]
    tr = p[P_TR]
    rw = p[P_RW]
    ms = p[P_MS]
    h = p[P_HROLL]
    q[Q_M] = m
    q[Q_G] = p[P_G]
    q[Q_INV_M] = 1.0 / m
    q[Q_HALF_TRACK] = 0.25 * (tf + tr)
    q[Q_INV_RATIO] = 1.0 / p[P_RATIO]
    q[Q_TDRIVE] = p[P_TDRIVE]
    q[Q_PDRIVE] = p[P_PDRIVE]
    q[Q_TBRAKE] = p[P_TBRAKE]
    q[Q_MU] = p[P_MU]
    q[Q_CY] = p[P_CY]
    q[Q_EY] = p[P_EY]
    q[Q_PDY2] = p[P_PDY2]
    q[Q_KX] = p[P_KX]
    q[Q_CX] = p[P_CX]
    q[Q_EX] = p[P_EX]
    q[Q_PDX2] = p[P_PDX2]
    q[Q_RBY1SQ] = p[P_RBY1] * p[P_RBY1]
    q[Q_RBY2] = p[P_RBY2]
    q[Q_RBX1SQ] = p[P_RBX1] * p[P_RBX1]
    q[Q_RBX2] = p[P_RBX2]
    y0 = 1.0 / p[P_PKY2]
    q[Q_KYNORM] = (1.0 + y0 * y0) / y0
    q[Q_RW] = rw
    q[Q_FRR_RW] = p[P_FRR] * rw
    q[Q_INV_IW] = 1.0 / p[P_IW]
    q[Q_INV_SIGX] = 1.0 / p[P_SIGX]
    q[Q_AERO] = 0.5 * p[P_RHO] * p[P_CDA]
    q[Q_MSH] = ms * h
    q[Q_IXX] = p[P_IXX]
    q[Q_INV_IZ] = 1.0 / p[P_IZ]
    q[Q_INV_TAU] = 1.0 / p[P_TAULOAD]
    q[Q_HSENS] = p[P_HSENS]
    q[Q_KROLL] = p[P_KROLL]
    q[Q_CROLL] = p[P_CROLL]
    hrc = p[P_HCG] - h
    mu_ax = 0.5 * p[P_MUNSPRUNG]
    share = p[P_SHAREF]
    bf = p[P_BRAKEF]
    for i in range(4):
        front = i < 2
        left = i == 0 or i == 2
        sgn = -1.0 if left else 1.0  # the left wheels unload for a positive roll moment / f_y
        track = tf if front else tr
        q[Q_XW + i] = lf if front else -lr
        q[Q_YW + i] = (0.5 if left else -0.5) * track
        q[Q_KY0 + i] = p[P_KY0F] if front else p[P_KY0R]
        fz0 = p[P_FZ0F] if front else p[P_FZ0R]
        q[Q_INVFZ0 + i] = 1.0 / fz0
        q[Q_INVFZPK + i] = 1.0 / (p[P_PKY2] * fz0)
        q[Q_LN + i] = 0.5 * (lr if front else lf) / L
        q[Q_LX + i] = (-0.5 if front else 0.5) * m * p[P_HCG] / L
        q[Q_LR + i] = sgn * (share if front else 1.0 - share) / track
        q[Q_LY + i] = sgn * (ms * (lr if front else lf) / L * hrc + mu_ax * rw) / track
        q[Q_DRIVE + i] = 0.5 if front else 0.0
        q[Q_BRAKE + i] = 0.5 * bf if front else 0.5 * (1.0 - bf)
    return q


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def step_inputs(u, q, c):
    """Per-step constants ``c`` (``C_*``) from the inputs ``u``: steer angle and its sine/cosine, pedals."""
    delta = u[U_SWA] * q[Q_INV_RATIO]
    sd, cd = fast_sincos(delta)
    c[C_DELTA] = delta
    c[C_THROTTLE] = u[U_THROTTLE]
    tb = u[U_BRAKE] * q[Q_TBRAKE]
    for i in range(4):
        front = i < 2
        q[Q_CW + i] = cd if front else 1.0
        q[Q_SW + i] = sd if front else 0.0
        q[Q_TB + i] = tb * q[Q_BRAKE + i]


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy", no_cpython_wrapper=True,
      no_cfunc_wrapper=True)
def plant_core(x, road, q, c, dx):
    """The plant's right-hand side on derived constants ``q`` and per-step constants ``c``.

    Writes dx/dt into ``dx``, and into ``q``'s per-evaluation slots (``Q_O*``,
    ``Q_A*``) what :func:`_fill_aux` needs for the auxiliary outputs. No
    allocation, no calls with arrays (inlined into its callers: no reference
    counting in the integration loop). One compiled version serves the
    integration loop and the outputs (no specialisation per caller).
    """
    m = q[Q_M]
    g = q[Q_G]

    s = x[X_S]
    n = x[X_N]
    psi = x[X_PSI]
    vx = x[X_VX]
    vy = x[X_VY]
    r = x[X_R]
    phi = x[X_PHI]
    dphi = x[X_DPHI]

    # ---- road and gravity --------------------------------------------------
    kap, grade, phib = road_at(road, s, n, q[Q_HALF_TRACK])
    sb, cb = _sin_cos_small(phib)
    sg, cg = _sin_cos_small(grade)
    spsi, cpsi = fast_sincos(psi)
    g_t = -g * sg
    g_l = -g * sb * cg
    g_n = -g * cb * cg
    gx = g_t * cpsi + g_l * spsi
    gy = -g_t * spsi + g_l * cpsi

    den = 1.0 - n * kap
    if den < 0.1:
        den = 0.1
    inv_den = 1.0 / den
    vt = vx * cpsi - vy * spsi
    sdot = vt * inv_den
    # (zero unless banked *and* curved: skipping it then keeps the heading's sine and
    # cosine off the path to the wheel loads)
    a_n = -vt * vt * (kap * inv_den) * (sb / cb) if kap != 0.0 and sb != 0.0 else 0.0
    fz_spec = a_n - g_n

    # ---- loads and drive ---------------------------------------------------------
    fxl = x[X_FXL]
    fyl = x[X_FYL]
    ntot = m * fz_spec
    mroll = q[Q_KROLL] * phi + q[Q_CROLL] * dphi
    om_f = 0.5 * (x[X_OMEGA] + x[X_OMEGA + 1])
    t_avail = q[Q_TDRIVE]
    if om_f > 1.0 and q[Q_PDRIVE] / om_f < t_avail:
        t_avail = q[Q_PDRIVE] / om_f
    t_drive = c[C_THROTTLE] * t_avail

    # ---- the four wheels: one branch-free loop on q only (SIMD over the wheels) ----
    for i in range(4):
        q[Q_OM + i] = x[X_OMEGA + i]
        q[Q_KA + i] = x[X_KAPPA + i]
    mu = q[Q_MU]
    rw = q[Q_RW]
    kynorm = q[Q_KYNORM]
    cy = q[Q_CY]
    ey = q[Q_EY]
    pdy2 = q[Q_PDY2]
    kx = q[Q_KX]
    cx = q[Q_CX]
    ex = q[Q_EX]
    pdx2 = q[Q_PDX2]
    rby1sq = q[Q_RBY1SQ]
    rby2 = q[Q_RBY2]
    rbx1sq = q[Q_RBX1SQ]
    rbx2 = q[Q_RBX2]
    frr_rw = q[Q_FRR_RW]
    inv_iw = q[Q_INV_IW]
    inv_sigx = q[Q_INV_SIGX]
    for i in range(4):
        xw = q[Q_XW + i]
        yw = q[Q_YW + i]
        cw = q[Q_CW + i]
        sw = q[Q_SW + i]
        fz = ntot * q[Q_LN + i] + fxl * q[Q_LX + i] + mroll * q[Q_LR + i] + fyl * q[Q_LY + i]
        vxc = vx - yw * r
        vyc = vy + xw * r
        vxw = vxc * cw + vyc * sw
        vyw = vyc * cw - vxc * sw
        avx = abs(vxw)
        tana = -vyw / (_VX_FLOOR if _VX_FLOOR > avx else avx)
        kappa = q[Q_KA + i]
        fxw, fyw = tyre_core(tana, kappa, fz, mu, q[Q_KY0 + i], q[Q_INVFZ0 + i], kynorm, q[Q_INVFZPK + i],
                             cy, ey, pdy2, kx, cx, ex, pdx2, rby1sq, rby2, rbx1sq, rbx2)
        fxc = fxw * cw - fyw * sw
        fyc = fxw * sw + fyw * cw
        q[Q_OFXC + i] = fxc
        q[Q_OFYC + i] = fyc
        q[Q_OMZ + i] = xw * fyc - yw * fxc
        # wheel spin and transient slip
        om = q[Q_OM + i]
        sgn = om / (abs(om) + 0.5)
        torque = t_drive * q[Q_DRIVE + i] - q[Q_TB + i] * sgn - frr_rw * (0.0 if 0.0 > fz else fz) * sgn - rw * fxw
        q[Q_ODOM + i] = torque * inv_iw
        q[Q_ODKA + i] = ((rw * om - vxw) - avx * kappa) * inv_sigx
        q[Q_OFZ + i] = fz
        q[Q_OFXW + i] = fxw
        q[Q_OFYW + i] = fyw
        q[Q_OTANA + i] = tana
    sum_fx = (q[Q_OFXC] + q[Q_OFXC + 1]) + (q[Q_OFXC + 2] + q[Q_OFXC + 3])
    sum_fy = (q[Q_OFYC] + q[Q_OFYC + 1]) + (q[Q_OFYC + 2] + q[Q_OFYC + 3])
    sum_mz = (q[Q_OMZ] + q[Q_OMZ + 1]) + (q[Q_OMZ + 2] + q[Q_OMZ + 3])
    for i in range(4):
        dx[X_OMEGA + i] = q[Q_ODOM + i]
        dx[X_KAPPA + i] = q[Q_ODKA + i]

    f_aero = q[Q_AERO] * vx * abs(vx)

    # ---- body dynamics -------------------------------------------------------
    sphi, cphi = fast_sincos(phi)
    msh = q[Q_MSH]
    a12 = -msh * cphi
    ixx = q[Q_IXX]
    b1 = sum_fy + m * gy - m * vx * r - msh * dphi * dphi * sphi
    b2 = msh * cphi * (vx * r - gy) + msh * sphi * fz_spec - mroll
    inv_det = 1.0 / (m * ixx - a12 * a12)
    dvy = (ixx * b1 - a12 * b2) * inv_det
    ddphi = (m * b2 - a12 * b1) * inv_det
    fx_spec = (sum_fx - f_aero) * q[Q_INV_M]
    fy_spec = sum_fy * q[Q_INV_M]

    dx[X_S] = sdot
    dx[X_N] = vx * spsi + vy * cpsi
    dx[X_PSI] = r - kap * sdot
    dx[X_VX] = vy * r + gx + fx_spec
    dx[X_VY] = dvy
    dx[X_R] = sum_mz * q[Q_INV_IZ]
    dx[X_PHI] = dphi
    dx[X_DPHI] = ddphi
    dx[X_FXL] = (fx_spec - fxl) * q[Q_INV_TAU]
    dx[X_FYL] = (fy_spec - fyl) * q[Q_INV_TAU]

    q[Q_APHIB] = phib
    q[Q_AGRADE] = grade
    q[Q_AKAP] = kap
    q[Q_AFX] = fx_spec
    q[Q_AFY] = fy_spec
    q[Q_AFZ] = fz_spec
    q[Q_AGY] = gy
    q[Q_ASPHI] = sphi
    q[Q_ACPHI] = cphi


@njit(cache=True, fastmath=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _fill_aux(x, q, c, dx, aux):
    """Auxiliary outputs (``A_*``) of the last :func:`plant_core` evaluation (its ``x``, ``q``, ``c``, ``dx``)."""
    vx = x[X_VX]
    r = x[X_R]
    dvy = dx[X_VY]
    ddphi = dx[X_DPHI]
    fz_spec = q[Q_AFZ]
    aux[A_PHIB] = q[Q_APHIB]
    aux[A_GRADE] = q[Q_AGRADE]
    aux[A_KAPPA] = q[Q_AKAP]
    aux[A_FX] = q[Q_AFX]
    aux[A_FY] = q[Q_AFY]
    aux[A_FZ] = fz_spec
    aux[A_AY] = (dvy + vx * r - q[Q_AGY]) * q[Q_ACPHI] + fz_spec * q[Q_ASPHI] - q[Q_HSENS] * ddphi
    aux[A_AX] = q[Q_AFX]
    aux[A_DVY] = dvy
    aux[A_DDPHI] = ddphi
    aux[A_DELTA] = c[C_DELTA]
    for i in range(4):
        aux[A_FZW + i] = q[Q_OFZ + i]
        aux[A_FXW + i] = q[Q_OFXW + i]
        aux[A_FYW + i] = q[Q_OFYW + i]
        aux[A_TANA + i] = q[Q_OTANA + i]


@njit(cache=True, fastmath=True, error_model="numpy", no_cfunc_wrapper=True)
def plant_eval_prepared(x, u, road, q, dx, aux):
    """:func:`plant_eval` on :func:`prepare`'s constants ``q``: dx/dt into ``dx``, the outputs into ``aux``."""
    c = np.empty(NC)
    step_inputs(u, q, c)
    plant_core(x, road, q, c, dx)
    _fill_aux(x, q, c, dx, aux)


def plant_eval(x, u, road, p, dx, aux, want_aux=True) -> None:
    """Evaluate the plant: write dx/dt into ``dx`` and the outputs into ``aux`` (always; ``want_aux`` is kept
    for compatibility).

    ``x`` (NX,), ``u`` (NU,), ``road`` from :meth:`Road.pack`, ``p`` from
    :meth:`PlantParams.pack`. Convenience entry (derives the constants on every
    call); the integration loop uses :func:`prepare`, :func:`step_inputs` and
    :func:`plant_core` directly.
    """
    f64 = np.float64
    plant_eval_prepared(np.ascontiguousarray(x, dtype=f64), np.ascontiguousarray(u, dtype=f64),
                        np.ascontiguousarray(road, dtype=f64), prepare(p), dx, aux)


def f(x, u, road, params) -> np.ndarray:
    """Pure right-hand side ``dx/dt = f(x, u, road, params)`` (allocates the result; units of the states per second).

    See the module docstring for the states, inputs and equations.
    """
    dx = np.empty(NX)
    plant_eval(x, u, road, params, dx, np.empty(NAUX))
    return dx


def outputs(x, u, road, params) -> np.ndarray:
    """Auxiliary outputs (``A_*`` indices) at one state: loads, forces, specific forces, dvy/dt (SI)."""
    aux = np.empty(NAUX)
    plant_eval(x, u, road, params, np.empty(NX), aux)
    return aux

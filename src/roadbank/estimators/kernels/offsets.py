"""The compiled per-sample step of the online sensor-offset learner
(:mod:`roadbank.estimators.offsets`).

One function, :func:`offsets_step`, does all the work of a sample; :func:`offsets_run`
is the same function in a loop, so a log processed in one call and sample by sample
gives identical numbers. Layouts of ``cfg`` (settings) and ``mem`` (state) are the
``C_*`` and ``M_*`` indices below; :mod:`roadbank.estimators.offsets` fills ``cfg`` and explains
the rules, :mod:`roadbank.export.offsets_c` writes the same operations in C. Compiled with the
kernels' options (:mod:`._jit`: no reference counting, numpy's division rules, helpers inlined).

Units: t (s), vx (m/s), ay (m/s^2), r (rad/s), delta_f (front road-wheel angle, rad).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...constants import AY_MAX, SPEED_MAX, YAW_RATE_MAX
from ._jit import ENTRY, INLINE

# ---- cfg: settings -----------------------------------------------------------------------
(C_VSTOP, C_TSTOP, C_TAUSTOP, C_NSTOP, C_RSTOP, C_TRAIL, C_VSTR, C_AYSTR, C_DSTR, C_RSTR, C_RDOT,
 C_DDOT, C_TSTR, C_TAUSTR, C_NSTR, C_L, C_KUS, C_TAUF, C_RMAX, C_DMAX, C_AYOFF, C_GAP, N_CFG) = range(23)
# ---- mem: state --------------------------------------------------------------------------
# committed yaw-rate offset and evidence; the running stop: r dt summed, its evidence, the
# snapshots A (newest) and B (at least C_TRAIL old) of those sums, A's time, the offset and
# evidence committed before the stop; whether the steering angle has ever changed
(M_BR, M_BD, M_ESTOP, M_ESTRR, M_ESTRD, M_TSTOP, M_TSTR, M_TLAST, M_INIT, M_RF, M_DF, M_AF,
 M_FINIT, M_SSUM, M_SE, M_ASUM, M_AE, M_AT, M_BSUM, M_BE, M_BR0, M_DMOVED, N_MEM) = range(23)
# ---- out: one sample ---------------------------------------------------------------------
(O_R, O_AY, O_D, O_BR, O_BD, O_RLEARNT, O_DLEARNT, N_OUT) = range(8)


@njit(**INLINE)
def _clamp(x, lim):
    if x > lim:
        return lim
    if x < -lim:
        return -lim
    return x


@njit(**INLINE)
def _combine(b0, e0, ssum, se, cfg):
    """Offset from the committed one ``b0`` (evidence ``e0``, weighing at most ``C_TAUSTOP`` s)
    and a stop's sum of ``r dt`` over ``se`` seconds."""
    w0 = min(e0, cfg[C_TAUSTOP])
    if w0 + se <= 0.0:
        return b0
    return _clamp((w0 * b0 + ssum) / (w0 + se), cfg[C_RMAX])


@njit(**INLINE)
def _end_stop(mem, cfg):
    """The car drives off (or a gap): commit the stop's samples up to snapshot B, those at least
    ``C_TRAIL`` s before its end (a creeping drive-off turns already), and forget the stop."""
    if mem[M_SE] > 0.0:
        mem[M_BR] = _combine(mem[M_BR0], mem[M_ESTOP], mem[M_BSUM], mem[M_BE], cfg)
        mem[M_ESTOP] += mem[M_BE]
    mem[M_TSTOP] = 0.0
    mem[M_SSUM] = 0.0
    mem[M_SE] = 0.0
    mem[M_ASUM] = 0.0
    mem[M_AE] = 0.0
    mem[M_BSUM] = 0.0
    mem[M_BE] = 0.0


@njit(**ENTRY)
def offsets_step(mem, cfg, t, vx, d, ay, r, out):
    """Learn from one sample and write its corrected channels into ``out`` (layout ``O_*``).

    The inputs in the kernels' order (:mod:`roadbank.estimators.kernels`, calling convention):
    t (s), vx (m/s), d (front road-wheel angle, rad), ay (m/s^2), r (rad/s).

    ``mem`` is updated in place. A sample whose time is not finite or not after the last
    usable one teaches nothing (the offsets are still applied to it).
    """
    dt = 0.0
    ok_t = math.isfinite(t) and (mem[M_INIT] == 0.0 or t > mem[M_TLAST])
    if ok_t:
        if mem[M_INIT] != 0.0:
            dt = t - mem[M_TLAST]
        if dt > cfg[C_GAP]:                      # a gap: no standstill or straight runs across it
            dt = 0.0
            _end_stop(mem, cfg)
            mem[M_TSTR] = 0.0
            mem[M_FINIT] = 0.0
        mem[M_TLAST] = t
        mem[M_INIT] = 1.0
    fin_v = abs(vx) <= SPEED_MAX              # within a car's limits (False for NaN): a glitch teaches nothing
    fin_r = abs(r) <= YAW_RATE_MAX
    fin_a = abs(ay) <= AY_MAX
    fin_d = math.isfinite(d)
    # ---- standstill: the yaw rate must be zero --------------------------------------------
    if ok_t and fin_v and fin_r:
        if abs(vx) < cfg[C_VSTOP]:
            mem[M_TSTOP] += dt
            if dt > 0.0 and mem[M_TSTOP] > cfg[C_TSTOP] and abs(r - mem[M_BR]) < cfg[C_RSTOP]:
                if mem[M_SE] == 0.0:                 # the stop's first taught sample
                    mem[M_BR0] = mem[M_BR]
                    mem[M_AT] = t
                mem[M_SSUM] += r * dt
                mem[M_SE] += dt
                if t - mem[M_AT] >= cfg[C_TRAIL]:
                    mem[M_BSUM] = mem[M_ASUM]
                    mem[M_BE] = mem[M_AE]
                    mem[M_ASUM] = mem[M_SSUM]
                    mem[M_AE] = mem[M_SE]
                    mem[M_AT] = t
                # provisional, while the car stands: every sample of the stop so far
                mem[M_BR] = _combine(mem[M_BR0], mem[M_ESTOP], mem[M_SSUM], mem[M_SE], cfg)
        elif mem[M_TSTOP] > 0.0:
            _end_stop(mem, cfg)
    # ---- straight driving: the yaw rate must agree with the steering angle ----------------
    if ok_t and fin_v and fin_r and fin_a and fin_d:
        if mem[M_FINIT] == 0.0:                  # the first sample (after a gap) starts the filters
            mem[M_RF] = r
            mem[M_DF] = d
            mem[M_AF] = ay
            mem[M_FINIT] = 1.0
            mem[M_TSTR] = 0.0
        elif dt > 0.0:
            if d != mem[M_DF]:                   # a steering channel that never changes (zeros) tells nothing
                mem[M_DMOVED] = 1.0
            a = dt / (cfg[C_TAUF] + dt)
            rf = mem[M_RF] + a * (r - mem[M_RF])
            df = mem[M_DF] + a * (d - mem[M_DF])
            af = mem[M_AF] + a * (ay - mem[M_AF])
            rdot = (rf - mem[M_RF]) / dt
            ddot = (df - mem[M_DF]) / dt
            mem[M_RF] = rf
            mem[M_DF] = df
            mem[M_AF] = af
            straight = (vx >= cfg[C_VSTR] and abs(af - cfg[C_AYOFF]) < cfg[C_AYSTR]
                        and abs(df - mem[M_BD]) < cfg[C_DSTR] and abs(rf - mem[M_BR]) < cfg[C_RSTR]
                        and abs(rdot) < cfg[C_RDOT] and abs(ddot) < cfg[C_DDOT])
            if straight:
                mem[M_TSTR] += dt
            else:
                mem[M_TSTR] = 0.0
            if straight and mem[M_TSTR] > cfg[C_TSTR] and mem[M_DMOVED] != 0.0:
                # the steady single-track model, the understeer term on the tyres' lateral force that the
                # accelerometer measures (a crowned road's too): delta_f = L r / vx + K_us a_y
                under = cfg[C_KUS] * (af - cfg[C_AYOFF])
                if mem[M_ESTOP] < cfg[C_NSTOP]:
                    # no standstill yet: the yaw rate from the steering angle's kinematic one
                    r_kin = vx * (d - mem[M_BD] - under) / cfg[C_L]
                    e = mem[M_ESTRR] + dt
                    mem[M_ESTRR] = e
                    mem[M_BR] = _clamp(mem[M_BR] + dt / min(e, cfg[C_TAUSTR]) * (r - r_kin - mem[M_BR]),
                                       cfg[C_RMAX])
                else:
                    # yaw rate learnt at standstill: the steering angle from the corrected yaw rate
                    d_kin = cfg[C_L] * (r - mem[M_BR]) / vx + under
                    e = mem[M_ESTRD] + dt
                    mem[M_ESTRD] = e
                    mem[M_BD] = _clamp(mem[M_BD] + dt / min(e, cfg[C_TAUSTR]) * (d - d_kin - mem[M_BD]),
                                       cfg[C_DMAX])
    elif ok_t and dt > 0.0:
        mem[M_TSTR] = 0.0
    out[O_R] = r - mem[M_BR]
    out[O_AY] = ay - cfg[C_AYOFF]
    out[O_D] = d - mem[M_BD]
    out[O_BR] = mem[M_BR]
    out[O_BD] = mem[M_BD]
    out[O_RLEARNT] = 1.0 if (mem[M_ESTOP] + mem[M_BE] >= cfg[C_NSTOP] or mem[M_ESTRR] >= cfg[C_NSTR]) else 0.0
    out[O_DLEARNT] = 1.0 if mem[M_ESTRD] >= cfg[C_NSTR] else 0.0


@njit(**ENTRY)
def offsets_run(mem, cfg, t, vx, d, ay, r, out):
    """:func:`offsets_step` over every sample; ``out`` has shape ``(n, N_OUT)``."""
    for k in range(t.shape[0]):
        offsets_step(mem, cfg, t[k], vx[k], d[k], ay[k], r[k], out[k])


def new_memory() -> np.ndarray:
    """A fresh state: no offset learnt, no history."""
    return np.zeros(N_MEM)

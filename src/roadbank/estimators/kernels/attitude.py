r"""The compiled recursion of the pitch observer (:func:`roadbank.models.attitude.observed_pitch`).

One function, :func:`pitch_run`, runs the observer of the speed :math:`\hat v` and the pitch :math:`\hat\vartheta`
over a log's samples:

.. math::
    \dot{\hat v} = a_x + g \sin\hat\vartheta + k_1 (v_x - \hat v), \qquad
    \dot{\hat\vartheta} = \dot\vartheta_q + k_2 (v_x - \hat v)

with :math:`\dot\vartheta_q` the rate of the Euler pitch from the pitch-rate gyro. Each interval is one backward
(implicit) Euler step, :math:`\sin` linearised about the previous pitch: a 2x2 linear solve, stable at any step
(a 1 Hz log with a 3 rad/s observer does not diverge). The state ``mem`` (:data:`M_V`, :data:`M_PITCH`,
:data:`M_TLAST`, :data:`M_TFIRST`, :data:`M_INIT`) carries over between calls, so a log in chunks gets what one call
gets. A sample with a non-finite input is skipped (its output NaN, the state kept); after a gap longer than
``max_gap`` the speed state restarts at the measured speed and the pitch is kept. Units: t (s), vx (m/s), ax
(m/s^2), rates (rad/s), g (m/s^2), pitch (rad, positive nose down).
"""

from __future__ import annotations

import math

from numba import njit

from ._jit import ENTRY

# ---- cfg: settings; mem: state ----------------------------------------------------------------
(C_W, C_ZETA, C_G, C_WSTART, C_TSTART, C_GAP, N_CFG) = range(7)
(M_V, M_PITCH, M_TLAST, M_TFIRST, M_INIT, N_MEM) = range(6)


@njit(**ENTRY)
def pitch_run(mem, cfg, t, vx, ax, rate, out):
    """The observer over the samples (``t``, ``vx``, ``ax``, ``rate`` the Euler pitch rate) into ``out`` (rad; NaN
    where a sample is skipped), from the state ``mem`` (updated); ``cfg``: bandwidth (rad/s), damping (-), g (m/s^2),
    start bandwidth (rad/s) and span (s, from the first sample used), the longest gap bridged (s)."""
    g = cfg[C_G]
    for i in range(t.shape[0]):
        ti, v, a, q = t[i], vx[i], ax[i], rate[i]
        if not (math.isfinite(ti) and math.isfinite(v) and math.isfinite(a) and math.isfinite(q)):
            out[i] = math.nan
            continue
        if mem[M_INIT] == 0.0:
            mem[M_V], mem[M_PITCH], mem[M_TLAST], mem[M_TFIRST], mem[M_INIT] = v, 0.0, ti, ti, 1.0
            out[i] = 0.0
            continue
        h = ti - mem[M_TLAST]
        if not h > 0.0:
            out[i] = mem[M_PITCH]
            continue
        if h > cfg[C_GAP]:
            mem[M_V], mem[M_TLAST] = v, ti
            out[i] = mem[M_PITCH]
            continue
        w = cfg[C_WSTART] if ti - mem[M_TFIRST] <= cfg[C_TSTART] else cfg[C_W]
        k1, k2 = 2.0 * cfg[C_ZETA] * w, w * w / g
        th0, v0 = mem[M_PITCH], mem[M_V]
        s, c = math.sin(th0), math.cos(th0)
        # v+ (1 + h k1) - h g c th+ = v0 + h (a + g (s - c th0) + k1 v);   th+ + h k2 v+ = th0 + h (q + k2 v)
        rhs_v = v0 + h * (a + g * (s - c * th0) + k1 * v)
        rhs_t = th0 + h * (q + k2 * v)
        vn = (rhs_v + h * g * c * rhs_t) / (1.0 + h * k1 + h * h * g * c * k2)
        mem[M_V], mem[M_PITCH], mem[M_TLAST] = vn, rhs_t - h * k2 * vn, ti
        out[i] = mem[M_PITCH]

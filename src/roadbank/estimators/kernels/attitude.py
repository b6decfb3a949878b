r"""The compiled recursion of the pitch observer (:class:`roadbank.estimators.pitch.PitchObserver`).

One function, :func:`pitch_run`, runs the observer of the speed :math:`\hat v`, the pitch :math:`\hat\vartheta` and
the pitch rate's offset :math:`\hat b` over a log's samples:

.. math::
    \dot{\hat v} = a_x + g \sin\hat\vartheta + k_1 (v_x - \hat v), \qquad
    \dot{\hat\vartheta} = \dot\vartheta_q - \hat b + k_2 (v_x - \hat v), \qquad
    \dot{\hat b} = -k_3 (v_x - \hat v)

with :math:`\dot\vartheta_q` the rate of the Euler pitch from the pitch-rate gyro; the gains place the error's poles
at :math:`(s + 1/T_q)(s^2 + 2\zeta\omega s + \omega^2)` (:math:`k_1 = 2\zeta\omega + 1/T_q`, :math:`k_2 = (\omega^2
+ 2\zeta\omega/T_q)/g`, :math:`k_3 = \omega^2/(T_q g)`; :math:`T_q = 0`: no offset state, :math:`k_3 = 0`). Each
interval is one backward (implicit) Euler step, :math:`\sin` linearised about the previous pitch; the offset
substituted, a 2x2 linear solve: stable at any step (a 1 Hz log with a 3 rad/s observer does not diverge). The state
``mem`` (:data:`M_V`, :data:`M_PITCH`, :data:`M_B`, :data:`M_TLAST`, :data:`M_TFIRST`, :data:`M_INIT`) carries over
between calls, so a log in chunks gets what one call gets. A sample with a non-finite input is skipped (its output
NaN, the state kept); after a gap longer than ``max_gap`` the speed state restarts at the measured speed and the pitch
and offset are kept. Units: t (s), vx (m/s), ax (m/s^2), rates (rad/s), g (m/s^2), pitch (rad, positive nose down).
"""

from __future__ import annotations

import math

from numba import njit

from ._jit import ENTRY

# ---- cfg: settings; mem: state ----------------------------------------------------------------
(C_W, C_ZETA, C_G, C_WSTART, C_TSTART, C_GAP, C_TQ, N_CFG) = range(8)
(M_V, M_PITCH, M_B, M_TLAST, M_TFIRST, M_INIT, N_MEM) = range(7)


@njit(**ENTRY)
def pitch_run(mem, cfg, t, vx, ax, rate, out):
    """The observer over the samples (``t``, ``vx``, ``ax``, ``rate`` the Euler pitch rate) into ``out`` (rad; NaN
    where a sample is skipped), from the state ``mem`` (updated); ``cfg``: bandwidth (rad/s), damping (-), g (m/s^2),
    start bandwidth (rad/s) and span (s, from the first sample used), the longest gap bridged (s), the offset's time
    constant T_q (s; 0: no offset state)."""
    g = cfg[C_G]
    for i in range(t.shape[0]):
        ti, v, a, q = t[i], vx[i], ax[i], rate[i]
        if not (math.isfinite(ti) and math.isfinite(v) and math.isfinite(a) and math.isfinite(q)):
            out[i] = math.nan
            continue
        if mem[M_INIT] == 0.0:
            mem[M_V], mem[M_PITCH], mem[M_B], mem[M_TLAST], mem[M_TFIRST], mem[M_INIT] = v, 0.0, 0.0, ti, ti, 1.0
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
        inv_t = 1.0 / cfg[C_TQ] if cfg[C_TQ] > 0.0 else 0.0
        zw = 2.0 * cfg[C_ZETA] * w
        k1, k2, k3 = zw + inv_t, (w * w + zw * inv_t) / g, w * w * inv_t / g
        th0, v0, b0 = mem[M_PITCH], mem[M_V], mem[M_B]
        s, c = math.sin(th0), math.cos(th0)
        # b+ = b0 - h k3 (v - v+) in th+ gives th+ + h K2 v+ = th0 + h (q - b0 + K2 v), K2 = k2 + h k3; then
        # v+ (1 + h k1) - h g c th+ = v0 + h (a + g (s - c th0) + k1 v)
        k2h = k2 + h * k3
        rhs_v = v0 + h * (a + g * (s - c * th0) + k1 * v)
        rhs_t = th0 + h * (q - b0 + k2h * v)
        vn = (rhs_v + h * g * c * rhs_t) / (1.0 + h * k1 + h * h * g * c * k2h)
        mem[M_V], mem[M_PITCH], mem[M_B], mem[M_TLAST] = vn, rhs_t - h * k2h * vn, b0 - h * k3 * (v - vn), ti
        out[i] = mem[M_PITCH]

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
substituted, a 2x2 linear solve: stable at any step (a 1 Hz log with a 3 rad/s observer does not diverge).

With an anchored start (``cfg[C_ANCHOR]`` s > 0), the first pitch is not a guess: for that span from the first sample,
:math:`v_x(t) = v_0 + A(t) + g (\sin\vartheta_0 \, \tau + S(t))` (the sine linearised about the first pitch), with
:math:`\tau` the time since the first sample, :math:`A = \int a_x`, :math:`Q = \int \dot\vartheta_q`, :math:`S = \int Q`
(trapezoids), is fitted for :math:`(v_0, \sin\vartheta_0)` by least squares over every sample so far,
:math:`\sin\vartheta_0` shrunk to zero by the prior weight ``cfg[C_PRIOR]`` (:math:`\sigma_v^2/\sigma_\vartheta^2`,
(m/s)^2 per rad^2); the pitch is :math:`\hat\vartheta_0 + Q` and the speed state the fitted speed, from which the
observer goes on (a gap longer than ``max_gap`` ends the span). The state ``mem`` (:data:`M_V`, :data:`M_PITCH`,
:data:`M_B`, :data:`M_TLAST`, :data:`M_TFIRST`, :data:`M_INIT`, and the anchored start's integrals and sums) carries
over between calls, so a log in chunks gets what one call gets. A sample with a non-finite input is skipped (its output
NaN, the state kept); after a gap longer than ``max_gap`` the speed state restarts at the measured speed and the pitch
and offset are kept; after one longer than ``cfg[C_RESTART]`` (the gyro-aided filter's own ``max_gap``, where it
starts again; ``inf``: never) the observer starts again as at a log's first sample, its faster and anchored starts
included. Units: t (s), vx (m/s), ax (m/s^2), rates (rad/s), g (m/s^2), pitch (rad, positive nose down).
"""

from __future__ import annotations

import math

from numba import njit

from ._jit import ENTRY, HELPER

# ---- cfg: settings; mem: state ----------------------------------------------------------------
(C_W, C_ZETA, C_G, C_WSTART, C_TSTART, C_GAP, C_TQ, C_ANCHOR, C_PRIOR, C_RESTART, N_CFG) = range(11)
(M_V, M_PITCH, M_B, M_TLAST, M_TFIRST, M_INIT,
 M_ANCHORED, M_AXLAST, M_RLAST, M_A, M_Q, M_S, M_N, M_ST, M_STT, M_SY, M_STY, N_MEM) = range(18)


@njit(**ENTRY)
def pitch_run(mem, cfg, t, vx, ax, rate, out):
    """The observer over the samples (``t``, ``vx``, ``ax``, ``rate`` the Euler pitch rate) into ``out`` (rad; NaN
    where a sample is skipped), from the state ``mem`` (updated); ``cfg``: bandwidth (rad/s), damping (-), g (m/s^2),
    start bandwidth (rad/s) and span (s, from the first sample used), the longest gap bridged (s), the offset's time
    constant T_q (s; 0: no offset state), the anchored start's span (s; 0: none) and prior weight ((m/s)^2/rad^2),
    the gap (s) after which the observer starts again as at the log's first sample (inf: never)."""
    g = cfg[C_G]
    for i in range(t.shape[0]):
        ti, v, a, q = t[i], vx[i], ax[i], rate[i]
        if not (math.isfinite(ti) and math.isfinite(v) and math.isfinite(a) and math.isfinite(q)):
            out[i] = math.nan
            continue
        if mem[M_INIT] == 0.0 or ti - mem[M_TLAST] > cfg[C_RESTART]:      # a (re)start
            mem[M_V], mem[M_PITCH], mem[M_B], mem[M_TLAST], mem[M_TFIRST], mem[M_INIT] = v, 0.0, 0.0, ti, ti, 1.0
            mem[M_ANCHORED] = 1.0 if cfg[C_ANCHOR] > 0.0 else 0.0
            mem[M_AXLAST], mem[M_RLAST], mem[M_A], mem[M_Q], mem[M_S] = a, q, 0.0, 0.0, 0.0
            mem[M_N], mem[M_ST], mem[M_STT], mem[M_SY], mem[M_STY] = 1.0, 0.0, 0.0, v, 0.0
            out[i] = 0.0
            continue
        h = ti - mem[M_TLAST]
        if not h > 0.0:
            out[i] = mem[M_PITCH]
            continue
        if mem[M_ANCHORED] > 0.0 and h <= cfg[C_GAP] and ti - mem[M_TFIRST] <= cfg[C_ANCHOR]:
            out[i] = anchor_step(mem, cfg, ti, v, a, q, h)
            continue
        mem[M_ANCHORED] = 0.0
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


@njit(**HELPER)
def anchor_step(mem, cfg, ti, v, a, q, h):
    """One sample of the anchored start (module docstring): the integrals and the least-squares sums move on by the
    interval ``h`` (s) to the sample (``ti`` s, ``v`` m/s, ``a`` m/s^2, ``q`` rad/s); the pitch (rad) and the fitted
    speed go into ``mem``; returns the pitch."""
    g = cfg[C_G]
    mem[M_A] += 0.5 * h * (a + mem[M_AXLAST])
    q_new = mem[M_Q] + 0.5 * h * (q + mem[M_RLAST])
    mem[M_S] += 0.5 * h * (mem[M_Q] + q_new)
    mem[M_Q], mem[M_AXLAST], mem[M_RLAST], mem[M_TLAST] = q_new, a, q, ti
    tau = ti - mem[M_TFIRST]
    y = v - mem[M_A] - g * mem[M_S]
    mem[M_N] += 1.0
    mem[M_ST] += tau
    mem[M_STT] += tau * tau
    mem[M_SY] += y
    mem[M_STY] += tau * y
    n = mem[M_N]
    sxx = g * g * (mem[M_STT] - mem[M_ST] * mem[M_ST] / n)
    sxy = g * (mem[M_STY] - mem[M_ST] * mem[M_SY] / n)
    s0 = sxy / (sxx + cfg[C_PRIOR])
    v0 = (mem[M_SY] - g * s0 * mem[M_ST]) / n
    mem[M_PITCH] = math.asin(min(max(s0, -1.0), 1.0)) + q_new
    mem[M_V] = v0 + mem[M_A] + g * (s0 * tau + mem[M_S])
    return mem[M_PITCH]

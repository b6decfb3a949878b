"""Two observers, the output switched on the yaw acceleration (the ``gated`` family)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..layout import (C_GAP, C_LIM, C_N, C_NR, M_INIT, M_PHI, M_PHIB, M_THETA, M_TLAST, M_W, M_X, gate_states,
                      gated_block)
from ._jit import ENTRY, HELPER, optimise_for_size
from .lpv import lpv_step
from .sample import output, sample_valid, step_by_run, store


@njit(inline="always", **HELPER)
def gated_sample(mem, cfg, tab, work, t, vx, d, ay, r):
    r"""One sample of two stacked observers whose outputs are blended by a gate; returns
    ``(w, theta, phi_b, valid)``. Inlined into :func:`gated_run`, the family's one compiled function
    (:func:`gated_step` runs it on one-sample arrays, as ``riccati_step`` does), so that numba
    optimises the sample's code once, not in a step and again in the loop that calls it.

    The states of both observers form one block-diagonal ``lpv`` observer (the table and the
    fixed-rate path of :func:`~roadbank.estimators.kernels.lpv.lpv_step`, whose output
    ``H xi + D eta`` is the first observer's ``w_s``); the second's is ``w_f = H_f xi`` (``H_f``
    constant, :func:`roadbank.estimators.layout.gated_block`). The gate ``g`` in [0, 1] follows the
    yaw acceleration: the yaw rate through a first-order low-pass (time constant ``tf``),
    :math:`r_f \mathrel{+}= (1 - e^{-\Delta t/t_f})(r - r_f)`, its rate of change times the
    speed, :math:`j = v_x |\Delta r_f| / \Delta t` (m/s^3, the yaw part of the lateral jerk),
    the ramp :math:`g_k = \min(1, \max(0, (j - j_{on}) / j_{span}))` (0 below the speed ``v_gate``) and a peak
    follower that
    rises at once and falls back with the release time constant ``tau``:
    :math:`g \leftarrow g_k` if :math:`g_k > g`, else :math:`g \mathrel{+}= (1 -
    e^{-\Delta t/\tau})(g_k - g)`. At a (re)start ``r_f = r``, ``g = 0``. Output
    :math:`w = w_s + g (w_f - w_s)`, :math:`\theta = \arcsin w`, :math:`\phi_b = \theta - \phi`.
    ``r_f`` and ``g`` in ``mem`` (:func:`~roadbank.estimators.layout.gate_states`). With a limit
    (``kinematic-pif``'s low-pass) the first observer reads
    :func:`~roadbank.estimators.kernels.sample.limited_ay` in the steering's input slot, which neither
    observer of that pair reads otherwise (:func:`~roadbank.estimators.kernels.lpv.lpv_step` computes it;
    the validity test here reads ``ay`` in that slot, finite exactly where the limited one is); the second
    reads ``ay``.
    """
    # validity as lpv_step sees the sample: a limited low-pass's slot holds ay limited, finite where ay is
    if not sample_valid(mem, cfg, t, vx, ay if cfg[C_LIM] > 0.0 else d, ay, r):
        return mem[M_W], mem[M_THETA], mem[M_PHIB], False
    restart = mem[M_INIT] == 0.0 or (t - mem[M_TLAST]) > cfg[C_GAP]
    dt = t - mem[M_TLAST]
    lpv_step(mem, cfg, tab, work, t, vx, d, ay, r)
    n = np.int64(cfg[C_N])
    nr = np.int64(cfg[C_NR])
    gb = gated_block(n, nr)
    gs = gate_states(n, nr)
    if restart:
        rf = r
        g = 0.0
    else:
        rf0 = mem[gs.RF]
        rf = rf0 + (1.0 - math.exp(-dt / cfg[gb.TF])) * (r - rf0)
        gk = (vx * abs(rf - rf0) / dt - cfg[gb.ON]) / cfg[gb.SPAN]
        gk = gk if gk > 0.0 else 0.0
        gk = gk if gk < 1.0 else 1.0
        gk = gk if vx >= cfg[gb.VMIN] else 0.0
        g = mem[gs.G]
        g = gk if gk > g else g + (1.0 - math.exp(-dt / cfg[gb.TAU])) * (gk - g)
    mem[gs.RF] = rf
    mem[gs.G] = g
    wf = 0.0
    for p in range(n):
        wf += cfg[gb.HF + p] * mem[M_X + p]
    w = mem[M_W] + g * (wf - mem[M_W])
    ok = output(mem, cfg, w, mem[M_PHI])
    return w, mem[M_THETA], mem[M_PHIB], ok


@njit(**ENTRY)
def gated_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
              out_x):
    """:func:`gated_sample` over every sample."""
    optimise_for_size()
    n = np.int64(cfg[C_N])
    for k in range(t.shape[0]):
        ok = gated_sample(mem, cfg, tab, work, t[k], vx[k], d[k], ay[k], r[k])[3]
        store(mem, k, n, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x)


def gated_step(mem, cfg, tab, work, t, vx, d, ay, r):
    """One sample of :func:`gated_run`; returns ``(w, theta, phi_b, valid)`` (Python: :func:`step_by_run`)."""
    return step_by_run(gated_run, mem, cfg, tab, work, t, vx, d, ay, r)

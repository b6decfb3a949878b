"""Observers scheduled on speed and excitation (the ``adaptive`` family, ``pif-adaptive``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..layout import C_N, C_USE, C_NG, C_NR, M_PHIB, M_THETA, M_W, adaptive_block, adaptive_state, lpv_row
from ._jit import ENTRY
from .lpv import observer_update
from .sample import begin, finish, grid, sample_valid, store


@njit(**ENTRY)
def adaptive_step(mem, cfg, tab, work, t, vx, d, ay, r):
    r"""One sample of an observer scheduled on speed and excitation; returns ``(w, theta, phi_b, valid)``.

    Excitation ``e`` (m/s^2): ``|ay|`` through a first-order low-pass of time constant
    ``tf`` (the tyre forces build up with a lag), :math:`a_f \mathrel{+}= (1 -
    e^{-\Delta t/t_f})(|a_y| - a_f)`, then a peak follower that rises at once and decays
    with the release time constant ``tau``: :math:`e_k = \max(a_f, e_{k-1}
    e^{-\Delta t/\tau})`; ``a_f = e = |ay|`` at a (re)start. ``tab`` rows
    (``layout.lpv_row(n)``, continuous part) for speed point
    ``iv`` and excitation point ``ie`` at row ``iv * ne + ie``; the matrices at
    ``(vx, e)`` are interpolated bilinearly (clamped at the ends of both grids), then the
    state advances by :func:`~roadbank.estimators.kernels.lpv.observer_update` on its general
    path: trapezoidal rule with substeps, the inputs linear between samples, the matrices frozen
    over the interval. Grid, ``tau`` and ``tf`` in ``cfg``
    (:func:`roadbank.estimators.layout.adaptive_block`); ``e``, ``a_f`` in ``mem``
    (:func:`~roadbank.estimators.layout.adaptive_state`).
    """
    if not sample_valid(mem, cfg, t, vx, d, ay, r):
        return mem[M_W], mem[M_THETA], mem[M_PHIB], False
    n = np.int64(cfg[C_N])
    nr = np.int64(cfg[C_NR])
    ab = adaptive_block(nr)
    st = adaptive_state(n, nr)
    eta = (d if cfg[C_USE] > 0 else 0.0, ay if cfg[C_USE + 1] > 0 else 0.0, r if cfg[C_USE + 2] > 0 else 0.0)
    dt, restart, _ = begin(mem, cfg, t)
    if restart:
        af = abs(ay)
        e = af
    else:
        af = mem[st.AF] + (1.0 - math.exp(-dt / cfg[ab.TF])) * (abs(ay) - mem[st.AF])
        e = mem[st.E] * math.exp(-dt / cfg[ab.TAU])
        e = e if e > af else af               # max(af, e)
    mem[st.E] = e
    mem[st.AF] = af
    # bilinear interpolation of the row at (vx, e)
    iv, av = grid(cfg, vx)
    nv = np.int64(cfg[C_NG])
    ne = np.int64(cfg[ab.NE])
    se = (e - cfg[ab.E0]) / cfg[ab.DE]
    if ne == 1 or se <= 0.0:
        ie, ae = 0, 0.0
    elif se >= ne - 1:
        ie, ae = ne - 2, 1.0
    else:
        ie = np.int64(se)
        ae = se - ie
    iv1 = iv + 1 if iv + 1 < nv else nv - 1
    ie1 = ie + 1 if ie + 1 < ne else ne - 1
    r00 = iv * ne + ie
    r01 = iv * ne + ie1
    r10 = iv1 * ne + ie
    r11 = iv1 * ne + ie1
    for k in range(lpv_row(n).cont):
        lo = tab[r00, k] + av * (tab[r10, k] - tab[r00, k])
        hi = tab[r01, k] + av * (tab[r11, k] - tab[r01, k])
        work[k] = lo + ae * (hi - lo)
    w = observer_update(mem, cfg, work, n, eta, dt, restart, False)
    ok = finish(mem, cfg, w, ay, dt, restart, False)
    return mem[M_W], mem[M_THETA], mem[M_PHIB], ok


@njit(**ENTRY)
def adaptive_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
                 out_x):
    """Batch version of :func:`adaptive_step` (same arithmetic, sample by sample)."""
    n = np.int64(cfg[C_N])
    for k in range(t.shape[0]):
        ok = adaptive_step(mem, cfg, tab, work, t[k], vx[k], d[k], ay[k], r[k])[3]
        store(mem, k, n, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x)

"""Dynamic filter compensation (the ``dfc`` family)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..layout import (C_AREF, C_G, C_SUB, C_TAU, DFC_HAU, DFC_HAW, DFC_HRU, DFC_HRW, M_DFC_IND, M_DFC_X, M_GATED,
                      M_PHIB, M_THETA, M_W)
from ._jit import ENTRY
from .sample import begin, finish, grid, sample_valid, store


@njit(**ENTRY)
def dfc_step(mem, cfg, tab, work, t, vx, d, ay, r):
    r"""One sample of the DFC estimator (returns ``(w, theta, phi_b, valid)``). ``tab`` rows: Haw0, Hrw0, Hau0, Hru0.

    .. math::
        w_v = (a_y - v_x r)/g,\quad
        DFC = H_{aw0}(w_a - w_v) + v_x H_{rw0}(w_r - w_v)
            = (a_y - H_{au0}\delta) + v_x (r - H_{ru0}\delta) - (H_{aw0} + v_x H_{rw0}) w_v

    (the second form avoids dividing by ``Hrw0``, which vanishes for a neutral
    steer car), gate :math:`w_v \max(0, 1 - |DFC|/a_{ref})`, then a first-order
    low-pass :math:`x' = (g - x)/\tau` of time constant ``tau`` (trapezoidal rule,
    substeps, gate linear between samples). States (``layout.M_DFC_*``): the low-pass
    output, then the DFC indicator (m/s^2).
    """
    if not sample_valid(mem, cfg, t, vx, d, ay, r):
        return mem[M_W], mem[M_THETA], mem[M_PHIB], False
    i, a = grid(cfg, vx)
    i1 = i + 1 if i + 1 < tab.shape[0] else tab.shape[0] - 1
    haw = tab[i, DFC_HAW] + a * (tab[i1, DFC_HAW] - tab[i, DFC_HAW])
    hrw = tab[i, DFC_HRW] + a * (tab[i1, DFC_HRW] - tab[i, DFC_HRW])
    hau = tab[i, DFC_HAU] + a * (tab[i1, DFC_HAU] - tab[i, DFC_HAU])
    hru = tab[i, DFC_HRU] + a * (tab[i1, DFC_HRU] - tab[i, DFC_HRU])
    wv = (ay - vx * r) / cfg[C_G]
    dfc = (ay - hau * d) + vx * (r - hru * d) - (haw + vx * hrw) * wv
    gate = 1.0 - abs(dfc) / cfg[C_AREF]
    gated = wv * (gate if gate > 0.0 else 0.0)
    dt, restart, fixed = begin(mem, cfg, t)
    if restart:
        x = gated
    else:
        x = mem[M_DFC_X]
        g0 = mem[M_GATED]
        f = -1.0 / cfg[C_TAU]
        gg = 1.0 / cfg[C_TAU]
        nsub = np.int64(math.ceil(dt / cfg[C_SUB] - 1e-9))
        if nsub < 1:
            nsub = 1
        hh = 0.5 * (dt / nsub)
        m = 1.0 - hh * f
        for k in range(nsub):
            s = (2.0 * k + 1.0) / nsub
            x = (x + hh * f * x + hh * gg * (2.0 * g0 + s * (gated - g0))) / m
    mem[M_DFC_X] = x
    mem[M_GATED] = gated
    mem[M_DFC_IND] = dfc
    ok = finish(mem, cfg, x, ay, dt, restart, False)
    return mem[M_W], mem[M_THETA], mem[M_PHIB], ok


@njit(**ENTRY)
def dfc_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
            out_x):
    """Batch version of :func:`dfc_step`."""
    for k in range(t.shape[0]):
        ok = dfc_step(mem, cfg, tab, work, t[k], vx[k], d[k], ay[k], r[k])[3]
        store(mem, k, 2, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x)

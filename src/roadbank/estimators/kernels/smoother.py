"""The backward pass of the offline ``pif-smoother`` (:mod:`roadbank.estimators.smoother`)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..layout import DT_REL_TOL, smooth_fixed_row, smooth_row
from ._jit import ENTRY, INLINE


@njit(**INLINE)
def _grid_point(v, v0, dv, ng):
    """Rows ``i``, ``i1`` and weight ``fa`` of speed ``v`` (m/s) on the grid ``v0 + j dv``
    (``ng`` points), clamped at both ends: the schedule at ``v`` is ``(1 - fa) row i + fa row i1``."""
    x = (v - v0) / dv
    i = np.int64(math.floor(x)) if x > 0.0 else np.int64(0)
    if i > ng - 2:
        i = ng - 2 if ng > 1 else np.int64(0)
    fa = x - i
    fa = 0.0 if fa < 0.0 else (1.0 if fa > 1.0 else fa)
    i1 = i + 1 if i + 1 < ng else i
    return i, i1, fa


@njit(**ENTRY)
def smooth_backward(tab, ftab, hfix, v0, dv, n, max_sub, t, vx, ay, xf, a, b, out, work):
    r"""Backward pass of the smoother over the samples ``a .. b-1`` (one segment of a log).

    Integrates :math:`\dot x_s = A x_s + b\,a_y + M (x_s - \hat x)` from ``t[b-1]`` back to
    ``t[a]``, starting at ``x_s = \hat x`` (``xf``, the forward filter's states, shape (N, n)),
    i.e. in reversed time :math:`\tau` the stable system :math:`x_s' = S x_s + M \hat x - b\,a_y`
    with ``S = -(A + M)``; ``vx``, ``ay`` and ``xf`` linear across each sample interval, the
    matrices at the interval's (substep's) mid speed, interpolated between grid speeds
    ``v0 + i dv``. ``tab`` rows (:func:`~roadbank.estimators.layout.smooth_row`): ``S`` (n x n),
    ``M`` (n x n), ``b`` (n).

    An interval of ``hfix`` seconds (relative tolerance ``DT_REL_TOL``; ``hfix = 0``: none) takes
    the exact step for a frozen speed, ``ftab`` rows
    (:func:`~roadbank.estimators.layout.smooth_fixed_row`) ``Phi`` (n x n), ``Gam0``, ``Gam1``
    (n x (n + 1)): :math:`z_k = \Phi z_{k+1} + \Gamma_0 e_{k+1} + \Gamma_1 e_k`,
    :math:`e = [\hat x, a_y]` (first-order hold, :func:`roadbank.estimators.discretise.foh`).
    Any other interval: the trapezoidal rule in substeps of at most ``max_sub`` seconds. Writes
    ``out[a:b]``; ``work`` holds at least ``3 n^2 + 4 n`` floats.
    """
    sr = smooth_row(n)                             # the interpolated row, at its table offsets
    oS, oM, ob = sr.S, sr.M, sr.b
    fr = smooth_fixed_row(n)                       # fixed-rate row; inputs e = [xf, ay]
    oG0, oG1, ne = fr.Gam0, fr.Gam1, fr.ne
    nn = n * n
    oA = sr.end                                    # scratch: I - h/2 S, then the right-hand side
    orhs = oA + nn
    ng = tab.shape[0]
    for p in range(n):
        out[b - 1, p] = xf[b - 1, p]
    for k in range(b - 2, a - 1, -1):
        h = t[k + 1] - t[k]
        if hfix > 0.0 and abs(h - hfix) <= DT_REL_TOL * hfix:
            i, i1, fa = _grid_point(0.5 * (vx[k] + vx[k + 1]), v0, dv, ng)
            for p in range(n):
                acc = 0.0
                for q in range(n):
                    c = ftab[i, fr.Phi + p * n + q] + fa * (ftab[i1, fr.Phi + p * n + q]
                                                            - ftab[i, fr.Phi + p * n + q])
                    acc += c * out[k + 1, q]
                for q in range(ne):
                    e0 = xf[k + 1, q] if q < n else ay[k + 1]
                    e1 = xf[k, q] if q < n else ay[k]
                    c0 = ftab[i, oG0 + p * ne + q] + fa * (ftab[i1, oG0 + p * ne + q] - ftab[i, oG0 + p * ne + q])
                    c1 = ftab[i, oG1 + p * ne + q] + fa * (ftab[i1, oG1 + p * ne + q] - ftab[i, oG1 + p * ne + q])
                    acc += c0 * e0 + c1 * e1
                work[orhs + n + p] = acc
            for p in range(n):
                out[k, p] = work[orhs + n + p]
            continue
        m = np.int64(math.ceil(h / max_sub)) if h > max_sub else np.int64(1)
        hs = h / m
        for j in range(m):
            s0 = 1.0 - j / m                      # fractions of the interval from t[k]
            s1 = 1.0 - (j + 1) / m
            sm = 0.5 * (s0 + s1)
            i, i1, fa = _grid_point(vx[k] + sm * (vx[k + 1] - vx[k]), v0, dv, ng)
            for q in range(sr.end):
                work[q] = tab[i, q] + fa * (tab[i1, q] - tab[i, q])
            ay0 = ay[k] + s0 * (ay[k + 1] - ay[k])
            ay1 = ay[k] + s1 * (ay[k + 1] - ay[k])
            for p in range(n):
                acc = out[k + 1, p] if j == 0 else work[orhs + n + p]
                work[orhs + 2 * n + p] = acc          # z (the state at s0)
            for p in range(n):
                r = work[orhs + 2 * n + p] - 0.5 * hs * work[ob + p] * (ay0 + ay1)
                for q in range(n):
                    sz = work[oS + p * n + q]
                    r += 0.5 * hs * sz * work[orhs + 2 * n + q]
                    x0 = xf[k, q] + s0 * (xf[k + 1, q] - xf[k, q])
                    x1 = xf[k, q] + s1 * (xf[k + 1, q] - xf[k, q])
                    r += 0.5 * hs * work[oM + p * n + q] * (x0 + x1)
                    work[oA + p * n + q] = (1.0 if p == q else 0.0) - 0.5 * hs * sz
                work[orhs + p] = r
            # Gaussian elimination with partial pivoting: (I - h/2 S) z = rhs -> work[orhs + n:]
            for c in range(n):
                piv = c
                for p in range(c + 1, n):
                    if abs(work[oA + p * n + c]) > abs(work[oA + piv * n + c]):
                        piv = p
                if piv != c:
                    for q in range(n):
                        tmp = work[oA + c * n + q]
                        work[oA + c * n + q] = work[oA + piv * n + q]
                        work[oA + piv * n + q] = tmp
                    tmp = work[orhs + c]
                    work[orhs + c] = work[orhs + piv]
                    work[orhs + piv] = tmp
                for p in range(c + 1, n):
                    f = work[oA + p * n + c] / work[oA + c * n + c]
                    for q in range(c, n):
                        work[oA + p * n + q] -= f * work[oA + c * n + q]
                    work[orhs + p] -= f * work[orhs + c]
            for p in range(n - 1, -1, -1):
                acc = work[orhs + p]
                for q in range(p + 1, n):
                    acc -= work[oA + p * n + q] * work[orhs + n + q]
                work[orhs + n + p] = acc / work[oA + p * n + p]
        for p in range(n):
            out[k, p] = work[orhs + n + p]


@njit(**ENTRY)
def jerk_ramps(t, vx, r, usable, tf, on, span, max_gap, state, out):
    r"""The offline gate's measure (:class:`roadbank.estimators.GatedSmoother`): the ramp (-, in [0, 1]) of the yaw part
    of the lateral jerk at each sample into ``out``, as :func:`roadbank.estimators.kernels.gated_step` reads it. The yaw
    rate through a first-order low-pass, :math:`r_f \mathrel{+}= (1 - e^{-\Delta t/t_f})(r - r_f)`, between
    consecutive ``usable`` samples (the others 0, stepped over), :math:`j = v_x |\Delta r_f| / \Delta t` and
    :math:`\min(1, \max(0, (j - j_{on}) / j_{span}))`; 0 at a (re)start (no sample before, or one more than
    ``max_gap`` s before) and where a stamp does not advance (not read). Units: t, tf, max_gap (s), vx (m/s), r
    (rad/s), on, span (m/s^3). ``state``: ``[t, r_f]`` of the last sample read (NaN: none), updated in place."""
    t_last, rf = state[0], state[1]
    for k in range(t.shape[0]):
        out[k] = 0.0
        if not usable[k]:
            continue
        dt = t[k] - t_last
        if not dt <= max_gap:                   # the first sample, or after a gap (NaN compares False)
            t_last, rf = t[k], r[k]
            continue
        if dt <= 0.0:
            continue
        rf_new = rf + (1.0 - math.exp(-dt / tf)) * (r[k] - rf)
        g = (vx[k] * abs(rf_new - rf) / dt - on) / span
        out[k] = 0.0 if g < 0.0 else (1.0 if g > 1.0 else g)
        t_last, rf = t[k], rf_new
    state[0], state[1] = t_last, rf


@njit(**ENTRY)
def window_max(t, ev_t, ev_g, before, after, out, queue):
    """The largest ``ev_g`` of the events at ``ev_t`` (s, sorted) from ``before`` s before each stamp of ``t`` (s,
    non-decreasing; NaN stamps none) to ``after`` s after it, into ``out`` (0 where none): a sliding maximum over a
    window of log time, each event entering and leaving ``queue`` (int64 work, as long as ``ev_t``), whose values
    decrease, once."""
    m = ev_t.shape[0]
    head, tail, nxt = 0, 0, 0
    for k in range(t.shape[0]):
        out[k] = 0.0
        if not math.isfinite(t[k]):
            continue
        while nxt < m and ev_t[nxt] <= t[k] + after:
            while tail > head and ev_g[queue[tail - 1]] <= ev_g[nxt]:
                tail -= 1
            queue[tail] = nxt
            tail += 1
            nxt += 1
        while tail > head and ev_t[queue[head]] < t[k] - before:
            head += 1
        if tail > head:
            out[k] = ev_g[queue[head]]

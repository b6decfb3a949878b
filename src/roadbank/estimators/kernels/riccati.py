"""The PIF with the time-varying Riccati equation (the ``riccati`` family)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..layout import (C_N, C_NR, C_P, C_SUB, C_USE, M_ETA, M_X, NETA, riccati_block, riccati_p, riccati_row,
                      riccati_work)
from ._jit import ENTRY, optimise_for_size
from .linalg import lu_factor, lu_solve, tustin
from .sample import begin, finish, grid, sample_valid, step_by_run, store


@njit(**ENTRY)
def riccati_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
                out_x):
    r"""The PIF with the Riccati ODE (paper eq 42-43) over a batch of samples (outputs as
    :func:`~roadbank.estimators.kernels.lpv.lpv_run`).

    ``tab`` rows (:func:`~roadbank.estimators.layout.riccati_row`): A (n*n), B (n*3), C (p*n),
    Dy (p*3), J (n*3) where the innovation is ``Dy eta - C x``. ``cfg`` holds ``R^-1``, ``W = Ew Q Ew^T`` and
    ``Mneg = th Lw^T S Lw`` (:func:`roadbank.estimators.layout.riccati_block`). Gain ``K = P C^T R^-1``;
    :math:`\dot P = AP + PA^T + W - P(C^T R^{-1} C - \theta L^T S L)P`.
    States after the observer and roll states: P (n*n,
    :func:`~roadbank.estimators.layout.riccati_p`; its initial value is written by ``reset()``).
    If P stops being finite (no bounded solution for this ``th``) the sample is flagged
    invalid; only ``reset()`` restores P (not reached with the default tuning).

    All matrices are row-major blocks of the flat arrays (no array views):
    ``work`` holds the interpolated row at its table offsets
    (:func:`~roadbank.estimators.layout.riccati_row`), then ``K``, ``F``,
    ``G``, the Hamiltonian ``Hm`` (2n x 2n), its trapezoidal matrix ``Mw`` with
    pivots, ``Z = [X; Y]`` (2n x n), ``X^T`` with pivots and a column buffer
    (:func:`~roadbank.estimators.layout.riccati_work`).

    The whole recursion is written out in this one function: it is the only compiled
    code of the family (:func:`riccati_step` runs it on one-sample arrays), which halves
    the family's compile time; the variant is not latency-critical (about 2 us per sample).
    """
    optimise_for_size()
    n = np.int64(cfg[C_N])
    p = np.int64(cfg[C_P])
    nr = np.int64(cfg[C_NR])
    # cfg: R^-1, W, Mneg; mem: P; work: the row (A, B, C, Dy, J) at its table offsets, then the scratch
    cb = riccati_block(n, p, nr)
    oR, oW, oMn = cb.Rinv, cb.W, cb.Mneg
    oP = riccati_p(n, nr)
    rw = riccati_row(n, p)
    oA, oB, oC, oDy, oJ = rw.A, rw.B, rw.C, rw.Dy, rw.J
    wk = riccati_work(n, p)
    oK, oF, oG, oHm, oMw, opiv, oZ, oXt, opx, ocol, oe = (wk.K, wk.F, wk.G, wk.Hm, wk.Mw, wk.piv, wk.Z, wk.Xt,
                                                          wk.px, wk.col, wk.e)
    for k in range(t.shape[0]):
        vxk = vx[k]
        if not sample_valid(mem, cfg, t[k], vxk, d[k], ay[k], r[k]):
            # a bool, not the literal False: one compiled store, the one below
            store(mem, k, n, np.bool_(False), out_w, out_theta, out_phib, out_phi, out_valid, out_x)
            continue
        i, a = grid(cfg, vxk)
        i1 = i + 1 if i + 1 < tab.shape[0] else tab.shape[0] - 1
        for c in range(rw.end):
            work[c] = tab[i, c] + a * (tab[i1, c] - tab[i, c])
        work[oe] = d[k] if cfg[C_USE] > 0 else 0.0
        work[oe + 1] = ay[k] if cfg[C_USE + 1] > 0 else 0.0
        work[oe + 2] = r[k] if cfg[C_USE + 2] > 0 else 0.0
        dt, restart, _ = begin(mem, cfg, t[k])
        ok = True
        if restart:
            for q in range(n):
                s = 0.0
                for j in range(NETA):
                    s += work[oJ + q * NETA + j] * work[oe + j]
                mem[M_X + q] = s
        else:
            nsub = np.int64(math.ceil(dt / cfg[C_SUB] - 1e-9))
            if nsub < 1:
                nsub = 1
            h = dt / nsub
            for sub in range(nsub):
                # gain from the current P, then the state over the substep
                for q in range(n):
                    for j in range(p):
                        s = 0.0
                        for l in range(n):
                            for mm in range(p):
                                s += mem[oP + q * n + l] * work[oC + mm * n + l] * cfg[oR + mm * p + j]
                        work[oK + q * p + j] = s
                for q in range(n):
                    for j in range(n):
                        s = work[oA + q * n + j]
                        for l in range(p):
                            s -= work[oK + q * p + l] * work[oC + l * n + j]
                        work[oF + q * n + j] = s
                    for j in range(NETA):
                        s = work[oB + q * NETA + j]
                        for l in range(p):
                            s += work[oK + q * p + l] * work[oDy + l * NETA + j]
                        work[oG + q * NETA + j] = s
                a0 = sub / nsub
                a1 = (sub + 1.0) / nsub
                for j in range(NETA):
                    work[ocol + j] = mem[M_ETA + j] + a0 * (work[oe + j] - mem[M_ETA + j])
                    work[ocol + NETA + j] = mem[M_ETA + j] + a1 * (work[oe + j] - mem[M_ETA + j])
                tustin(mem, M_X, n, work, oF, oG, NETA, work, ocol, work, ocol + NETA, h, h, work, oMw)
                # Riccati via the Hamiltonian: Z' = Hm Z, Hm = [[-A^T, M], [W, A]], Z = [I; P]
                m2 = 2 * n
                for q in range(n):
                    for j in range(n):
                        mpos = 0.0
                        for l in range(p):
                            for mm in range(p):
                                mpos += work[oC + l * n + q] * cfg[oR + l * p + mm] * work[oC + mm * n + j]
                        work[oHm + q * m2 + j] = -work[oA + j * n + q]
                        work[oHm + q * m2 + n + j] = mpos - cfg[oMn + q * n + j]
                        work[oHm + (n + q) * m2 + j] = cfg[oW + q * n + j]
                        work[oHm + (n + q) * m2 + n + j] = work[oA + q * n + j]
                for q in range(m2):
                    for j in range(m2):
                        work[oMw + q * m2 + j] = -0.5 * h * work[oHm + q * m2 + j]
                    work[oMw + q * m2 + q] += 1.0
                lu_factor(work, oMw, work, opiv, m2)
                for j in range(n):
                    for q in range(m2):
                        if q >= n:
                            zq = mem[oP + (q - n) * n + j]
                        else:
                            zq = 1.0 if q == j else 0.0
                        s = zq
                        for l in range(m2):
                            if l < n:
                                zl = 1.0 if l == j else 0.0
                            else:
                                zl = mem[oP + (l - n) * n + j]
                            s += 0.5 * h * work[oHm + q * m2 + l] * zl
                        work[ocol + q] = s
                    lu_solve(work, oMw, work, opiv, work, ocol, m2)
                    for q in range(m2):
                        work[oZ + q * n + j] = work[ocol + q]
                # P = Y X^-1  <=>  X^T P^T = Y^T ; P symmetric
                for q in range(n):
                    for j in range(n):
                        work[oXt + q * n + j] = work[oZ + j * n + q]
                lu_factor(work, oXt, work, opx, n)
                for j in range(n):
                    for q in range(n):
                        work[ocol + q] = work[oZ + (n + j) * n + q]
                    lu_solve(work, oXt, work, opx, work, ocol, n)
                    for q in range(n):
                        work[oF + j * n + q] = work[ocol + q]
                ok = True
                for q in range(n):
                    for j in range(n):
                        v = 0.5 * (work[oF + q * n + j] + work[oF + j * n + q])
                        if not math.isfinite(v):
                            ok = False
                        mem[oP + q * n + j] = v
                if not ok:
                    break
        if ok:          # P finite: record the inputs, separate the roll
            for q in range(NETA):
                mem[M_ETA + q] = work[oe + q]
            ok = finish(mem, cfg, mem[M_X + n - 1], ay[k], dt, restart, False)
        store(mem, k, n, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x)


def riccati_step(mem, cfg, tab, work, t, vx, d, ay, r):
    """One sample of :func:`riccati_run`; returns ``(w, theta, phi_b, valid)`` (Python: :func:`step_by_run`)."""
    return step_by_run(riccati_run, mem, cfg, tab, work, t, vx, d, ay, r)

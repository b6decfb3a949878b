"""Linear algebra on small row-major matrices stored in flat arrays (no views, no allocation)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._jit import HELPER, optimise_for_size

@njit(**HELPER)
def lu_factor(M, o, piv, op, n):
    """LU factorisation with partial pivoting, in place, of the row-major ``n x n`` matrix stored in
    ``M[o:o + n*n]``; the pivot rows go to ``piv[op:op + n]`` (as floats). A zero pivot leaves its
    column unreduced (the solve then gives inf/NaN)."""
    optimise_for_size()
    for k in range(n):
        p = k
        big = abs(M[o + k * n + k])
        for i in range(k + 1, n):
            if abs(M[o + i * n + k]) > big:
                big = abs(M[o + i * n + k])
                p = i
        piv[op + k] = p
        if p != k:
            for j in range(n):
                tmp = M[o + k * n + j]
                M[o + k * n + j] = M[o + p * n + j]
                M[o + p * n + j] = tmp
        d = M[o + k * n + k]
        if d == 0.0:
            continue
        for i in range(k + 1, n):
            M[o + i * n + k] /= d
            f = M[o + i * n + k]
            for j in range(k + 1, n):
                M[o + i * n + j] -= f * M[o + k * n + j]


@njit(**HELPER)
def lu_solve(M, o, piv, op, b, ob, n):
    """Solve ``A x = b`` in place in ``b[ob:ob + n]`` with the factors of :func:`lu_factor`
    (``M[o:]``, pivots ``piv[op:]``)."""
    optimise_for_size()
    for k in range(n):
        p = np.int64(piv[op + k])
        if p != k:
            tmp = b[ob + k]
            b[ob + k] = b[ob + p]
            b[ob + p] = tmp
    for i in range(n):
        s = b[ob + i]
        for j in range(i):
            s -= M[o + i * n + j] * b[ob + j]
        b[ob + i] = s
    for i in range(n - 1, -1, -1):
        s = b[ob + i]
        for j in range(i + 1, n):
            s -= M[o + i * n + j] * b[ob + j]
        b[ob + i] = s / M[o + i * n + i]


@njit(inline="always", **HELPER)
def tustin(x, ox, n, A, oF, oG, m, E0, oe0, E1, oe1, dt, max_sub, W, oM):
    """Advance ``x' = F x + G e`` over ``dt`` (s) by the trapezoidal rule in substeps of at most
    ``max_sub`` (s), ``e`` linear in time from ``e0`` to ``e1`` (the general path of the ``lpv``,
    ``adaptive`` and ``riccati`` families).

    State ``x[ox:ox+n]``; ``F`` (n x n) at ``A[oF:]`` and ``G`` (n x m) at
    ``A[oG:]``, row-major; inputs ``e0``/``e1`` at ``E0[oe0:]``/``E1[oe1:]``;
    scratch ``W[oM:]`` of ``n*n + 2n`` floats (matrix ``I - h/2 F``, pivots, right-hand side).
    Inlined by numba into its callers (one call in each kernel): no compiled function of its own, which
    each kernel family compiled and optimised again inside its kernel (about 0.3 s per family).
    """
    if n == 0:
        return
    opiv = oM + n * n
    orhs = opiv + n
    nsub = np.int64(math.ceil(dt / max_sub - 1e-9))
    if nsub < 1:
        nsub = 1
    h = dt / nsub
    hh = 0.5 * h
    for i in range(n):
        for j in range(n):
            W[oM + i * n + j] = -hh * A[oF + i * n + j]
        W[oM + i * n + i] += 1.0
    lu_factor(W, oM, W, opiv, n)
    for k in range(nsub):
        a = (2.0 * k + 1.0) / nsub  # e0*(1-a0)+e1*a0 + e0*(1-a1)+e1*a1 = 2 e0 + (e1-e0)*(a0+a1)
        for i in range(n):
            s = x[ox + i]
            for j in range(n):
                s += hh * A[oF + i * n + j] * x[ox + j]
            for j in range(m):
                s += hh * A[oG + i * m + j] * (2.0 * E0[oe0 + j] + a * (E1[oe1 + j] - E0[oe0 + j]))
            W[orhs + i] = s
        lu_solve(W, oM, W, opiv, W, orhs, n)
        for i in range(n):
            x[ox + i] = W[orhs + i]


r"""The exponential of the first-order-hold matrix of a whole stack of small systems (compiled).

:func:`foh_blocks` gives the blocks of :math:`\exp(hM)`, ``M = [[F, G, 0], [0, 0, I], [0, 0, 0]]``,
of every system of a stack (the fixed-rate discretisation, :mod:`roadbank.estimators.discretise`)
by scaling and squaring with the diagonal [13/13] Pade approximant: the matrix is scaled by
``2^-s``, the smallest power of two that brings its 1-norm to at most :data:`THETA13`, its
exponential is approximated by ``r(B) = (V - U)^{-1} (V + U)`` (``U`` the odd, ``V`` the even part
of the numerator polynomial), and the result is squared ``s`` times:

.. math::
    e^{A} = r(2^{-s} A)^{2^s}, \qquad s = \max(0, \lceil \log_2 (\|A\|_1 / \theta_{13}) \rceil).

With :math:`\theta_{13} = 5.37` the backward error of the approximant is below the double-precision
unit roundoff (Higham, "The scaling and squaring method for the matrix exponential revisited",
SIAM J. Matrix Anal. Appl. 26, 2005). Every system gets the same degree and its own ``s``. The
powers of ``M`` keep its block form, so only their first block row is computed (below), and the
whole stack runs in one compiled loop: no Python loop over the grid, no per-matrix call overhead.
The numbers agree with ``scipy.linalg.expm`` of the full matrix to rounding (about 1e-15 relative to
the norm of the exponential on the observers' grids; scipy chooses its degree and scaling per
matrix by a refined rule, hence not bit for bit).
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: coefficients b_0..b_13 of the [13/13] Pade approximant of exp
PADE13 = (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
          129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0,
          40840800.0, 960960.0, 16380.0, 182.0, 1.0)
#: the same divided by b_0 (the constant terms are then 1: ``exp(0)`` comes out exactly ``I``)
_PADE13_UNIT = tuple(c / PADE13[0] for c in PADE13)
#: largest 1-norm for which the [13/13] approximant's backward error is below the unit roundoff
THETA13 = 5.371920351148152


# -- the exponential of the first-order-hold matrix, block by block (compiled) ------------------
#
# The matrix M = h [[F, G, 0], [0, 0, I], [0, 0, 0]] (F n x n, G n x m) and every polynomial in it is
# [[X, Y], [0, x0 I + x1 S]] with X (n, n), Y (n, 2m) and S = [[0, I], [0, 0]] (2m x 2m, S^2 = 0):
# the algorithm, applied to M, only ever needs X, Y and the two numbers (x0, x1). A product
#     [[X, Y], [0, x0 I + x1 S]] [[X', Y'], [0, x0' I + x1' S]]
#       = [[X X', X Y' + x0' Y + x1' Y S], [0, x0 x0' I + (x0 x1' + x1 x0') S]],
# with Y S = [0, Y[:, :m]], costs n^2 (n + 2m) multiplications instead of (n + 2m)^3.


@njit(cache=True, error_model="numpy")
def _bmul(X, Y, x0, x1, Xp, Yp, y0, y1, m, OX, OY):
    """(OX, OY) = top blocks of the product (see above); returns the lower block's (z0, z1)."""
    n = X.shape[0]
    w = Y.shape[1]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += X[i, k] * Xp[k, j]
            OX[i, j] = acc
        for j in range(w):
            acc = 0.0
            for k in range(n):
                acc += X[i, k] * Yp[k, j]
            acc += y0 * Y[i, j]
            if j >= m:
                acc += y1 * Y[i, j - m]
            OY[i, j] = acc
    return x0 * y0, x0 * y1 + x1 * y0


@njit(cache=True, error_model="numpy")
def _lu_solve_into(A, R):
    """Solve ``A Z = R`` in place (``R`` becomes ``Z``; ``A`` is overwritten), partial pivoting."""
    n = A.shape[0]
    w = R.shape[1]
    for k in range(n):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                p = i
        if p != k:
            for j in range(n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            for j in range(w):
                R[k, j], R[p, j] = R[p, j], R[k, j]
        d = A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] / d
            for j in range(k + 1, n):
                A[i, j] -= f * A[k, j]
            for j in range(w):
                R[i, j] -= f * R[k, j]
    for i in range(n - 1, -1, -1):
        for j in range(w):
            acc = R[i, j]
            for k in range(i + 1, n):
                acc -= A[i, k] * R[k, j]
            R[i, j] = acc / A[i, i]


@njit(cache=True, error_model="numpy")
def _foh_blocks(F, G, h, b, theta, Phi, A1, A2):
    g, n, m = G.shape
    w = 2 * m
    BX, BY = np.empty((n, n)), np.empty((n, w))
    X2, Y2, X4, Y4, X6, Y6 = (np.empty((n, n)), np.empty((n, w)), np.empty((n, n)), np.empty((n, w)),
                              np.empty((n, n)), np.empty((n, w)))
    WX, WY, ZX, ZY = np.empty((n, n)), np.empty((n, w)), np.empty((n, n)), np.empty((n, w))
    UX, UY, VX, VY = np.empty((n, n)), np.empty((n, w)), np.empty((n, n)), np.empty((n, w))
    QX, R = np.empty((n, n)), np.empty((n, n + w))
    RX, RY, TX, TY = np.empty((n, n)), np.empty((n, w)), np.empty((n, n)), np.empty((n, w))
    for q in range(g):
        # 1-norm of h M: its columns are those of h [F, G], and h in each of the last m
        norm = abs(h) if m else 0.0
        for j in range(n + m):
            col = 0.0
            for i in range(n):
                col += abs(F[q, i, j] if j < n else G[q, i, j - n])
            norm = max(norm, col * abs(h))
        s = 0
        if norm > theta:                 # not finite: no squaring (the result comes out NaN)
            s = int(np.ceil(np.log2(norm / theta)))
        c = h * 0.5 ** s                 # exact: a power of two
        for i in range(n):
            for j in range(n):
                BX[i, j] = F[q, i, j] * c
            for j in range(m):
                BY[i, j] = G[q, i, j] * c
                BY[i, m + j] = 0.0
        b1 = c                           # B = [[BX, BY], [0, c S]]
        _bmul(BX, BY, 0.0, b1, BX, BY, 0.0, b1, m, X2, Y2)          # lower blocks of B^2.. vanish
        _bmul(X2, Y2, 0.0, 0.0, X2, Y2, 0.0, 0.0, m, X4, Y4)
        _bmul(X4, Y4, 0.0, 0.0, X2, Y2, 0.0, 0.0, m, X6, Y6)
        # U = B (B6 (b13 B6 + b11 B4 + b9 B2) + b7 B6 + b5 B4 + b3 B2 + b1 I)
        for i in range(n):
            for j in range(n):
                WX[i, j] = b[13] * X6[i, j] + b[11] * X4[i, j] + b[9] * X2[i, j]
            for j in range(w):
                WY[i, j] = b[13] * Y6[i, j] + b[11] * Y4[i, j] + b[9] * Y2[i, j]
        _bmul(X6, Y6, 0.0, 0.0, WX, WY, 0.0, 0.0, m, ZX, ZY)
        for i in range(n):
            for j in range(n):
                ZX[i, j] += b[7] * X6[i, j] + b[5] * X4[i, j] + b[3] * X2[i, j]
            ZX[i, i] += b[1]
            for j in range(w):
                ZY[i, j] += b[7] * Y6[i, j] + b[5] * Y4[i, j] + b[3] * Y2[i, j]
        u0, u1 = _bmul(BX, BY, 0.0, b1, ZX, ZY, b[1], 0.0, m, UX, UY)
        # V = B6 (b12 B6 + b10 B4 + b8 B2) + b6 B6 + b4 B4 + b2 B2 + b0 I
        for i in range(n):
            for j in range(n):
                WX[i, j] = b[12] * X6[i, j] + b[10] * X4[i, j] + b[8] * X2[i, j]
            for j in range(w):
                WY[i, j] = b[12] * Y6[i, j] + b[10] * Y4[i, j] + b[8] * Y2[i, j]
        _bmul(X6, Y6, 0.0, 0.0, WX, WY, 0.0, 0.0, m, VX, VY)
        for i in range(n):
            for j in range(n):
                VX[i, j] += b[6] * X6[i, j] + b[4] * X4[i, j] + b[2] * X2[i, j]
            VX[i, i] += b[0]
            for j in range(w):
                VY[i, j] += b[6] * Y6[i, j] + b[4] * Y4[i, j] + b[2] * Y2[i, j]
        v0 = b[0]
        # r = (V - U)^-1 (V + U); lower blocks: (v0 - u0) I - u1 S and (v0 + u0) I + u1 S, whose
        # quotient is r0 I + r1 S with r0 = p0 / q0, r1 = (p1 - r0 q1) / q0
        q0, q1, p0, p1 = v0 - u0, -u1, v0 + u0, u1
        r0 = p0 / q0
        r1 = (p1 - r0 * q1) / q0
        for i in range(n):
            for j in range(n):
                QX[i, j] = VX[i, j] - UX[i, j]
                R[i, j] = VX[i, j] + UX[i, j]
            for j in range(w):                     # P_Y - Q_Y (r0 I + r1 S)
                qy = VY[i, j] - UY[i, j]
                rhs = VY[i, j] + UY[i, j] - r0 * qy
                if j >= m:
                    rhs -= r1 * (VY[i, j - m] - UY[i, j - m])
                R[i, n + j] = rhs
        _lu_solve_into(QX, R)
        for i in range(n):
            for j in range(n):
                RX[i, j] = R[i, j]
            for j in range(w):
                RY[i, j] = R[i, n + j]
        for _ in range(s):                          # squaring
            r0, r1 = _bmul(RX, RY, r0, r1, RX, RY, r0, r1, m, TX, TY)
            RX[:, :] = TX
            RY[:, :] = TY
        for i in range(n):
            for j in range(n):
                Phi[q, i, j] = RX[i, j]
            for j in range(m):
                A1[q, i, j] = RY[i, j]
                A2[q, i, j] = RY[i, m + j]


def foh_blocks(F: np.ndarray, G: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Phi, A1, A2)``: the blocks of ``exp(h [[F, G, 0], [0, 0, I], [0, 0, 0]])`` of every system
    of a stack, ``F`` (g, n, n) (1/s), ``G`` (g, n, m), ``h`` (s).

    The method of the module docstring on that matrix, block by block (the zero blocks of its
    powers never computed; compiled): ``Phi`` (g, n, n) ``= e^{hF}``, ``A1``, ``A2`` (g, n, m) the
    blocks of the exponential in the second and third block columns (``G``'s units times s and
    times s^2). A system that is not finite comes out NaN.
    """
    F = np.ascontiguousarray(F, dtype=np.float64)
    G = np.ascontiguousarray(G, dtype=np.float64)
    g, n, m = G.shape
    Phi, A1, A2 = np.empty((g, n, n)), np.empty((g, n, m)), np.empty((g, n, m))
    if g and n:
        _foh_blocks(F, G, float(h), np.array(_PADE13_UNIT), THETA13, Phi, A1, A2)
    return Phi, A1, A2

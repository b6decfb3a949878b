r"""Matrix exponential of a whole stack of small matrices at once (scaling and squaring, Pade 13).

Each matrix ``A`` of the stack is scaled by ``2^-s``, the smallest power of two that brings its
1-norm to at most :data:`THETA13`, its exponential is approximated by the diagonal [13/13] Pade
approximant ``r(B) = (V - U)^{-1} (V + U)`` (``U`` the odd, ``V`` the even part of the numerator
polynomial), and the result is squared ``s`` times:

.. math::
    e^{A} = r(2^{-s} A)^{2^s}, \qquad s = \max(0, \lceil \log_2 (\|A\|_1 / \theta_{13}) \rceil).

With :math:`\theta_{13} = 5.37`, the backward error of the approximant is below the double-precision
unit roundoff (Higham, "The scaling and squaring method for the matrix exponential revisited",
SIAM J. Matrix Anal. Appl. 26, 2005). Every matrix gets the same degree and its own ``s``, so the
whole stack is a few batched products and one batched solve (numpy) instead of a Python loop over
the matrices; the squarings of a stack whose matrices need different ``s`` are applied to those
that still need them. The numbers agree with ``scipy.linalg.expm`` to rounding (about 1e-15
relative to the norm of the exponential on the observers' grids; scipy chooses its degree and
scaling per matrix by a refined rule, hence not bit for bit).
"""

from __future__ import annotations

import numpy as np

#: coefficients b_0..b_13 of the [13/13] Pade approximant of exp
PADE13 = (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
          129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0,
          40840800.0, 960960.0, 16380.0, 182.0, 1.0)
#: the same divided by b_0 (the constant terms are then 1: ``exp(0)`` comes out exactly ``I``)
_PADE13_UNIT = tuple(c / PADE13[0] for c in PADE13)
#: largest 1-norm for which the [13/13] approximant's backward error is below the unit roundoff
THETA13 = 5.371920351148152


def squarings(A: np.ndarray) -> np.ndarray:
    """Number of squarings ``s`` (int array over the stack) for each matrix of ``A`` (..., n, n).

    The smallest ``s >= 0`` with ``||A||_1 / 2^s <= THETA13`` (0 for a matrix that is not finite:
    its exponential comes out NaN).
    """
    norm = np.abs(A).sum(axis=-2).max(axis=-1) if A.shape[-1] else np.zeros(A.shape[:-2])
    norm = np.where(np.isfinite(norm), norm, 0.0)
    s = np.ceil(np.log2(np.maximum(norm, THETA13) / THETA13))
    return s.astype(np.int64)


def expm_stack(A: np.ndarray) -> np.ndarray:
    """``exp(A)`` of every matrix of ``A`` (..., n, n): the same shape (dimensionless).

    ``A`` is usually a continuous-time system matrix times a time step (1/s * s). See the module
    docstring for the method and its accuracy.
    """
    A = np.asarray(A, dtype=np.float64)
    if A.ndim < 2 or A.shape[-1] != A.shape[-2]:
        raise ValueError(f"expm_stack: expected square matrices (..., n, n), got shape {A.shape}")
    shape, n = A.shape, A.shape[-1]
    if A.size == 0:
        return np.zeros(shape)
    A = A.reshape(-1, n, n)
    s = squarings(A)
    B = A * np.ldexp(1.0, -s)[:, None, None]          # exact: a power of two
    b = _PADE13_UNIT
    eye = np.eye(n)
    B2 = B @ B
    B4 = B2 @ B2
    B6 = B4 @ B2
    U = B @ (B6 @ (b[13] * B6 + b[11] * B4 + b[9] * B2) + b[7] * B6 + b[5] * B4 + b[3] * B2 + b[1] * eye)
    V = B6 @ (b[12] * B6 + b[10] * B4 + b[8] * B2) + b[6] * B6 + b[4] * B4 + b[2] * B2 + b[0] * eye
    R = np.linalg.solve(V - U, V + U)
    for k in range(int(s.max())):
        more = s > k
        if more.all():
            R = R @ R
        else:
            R[more] = R[more] @ R[more]
    return R.reshape(shape)

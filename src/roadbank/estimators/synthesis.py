r"""Gain synthesis for the observers: game-type Riccati (H-infinity / Kalman) and pole placement.

All functions are pure numpy/scipy and work on one frozen speed; the
estimators call them on every point of their speed grid (the steady-state PIFs and the
Kalman filter solve their whole grid at once instead, :mod:`roadbank.estimators.grid_design`).
:func:`reference_solvers` makes every design take scipy's solvers point by point, as before
the faster paths: what they are compared with.
"""

from __future__ import annotations

import contextlib

import numpy as np
from scipy.linalg import solve_continuous_are

_REFERENCE = False


@contextlib.contextmanager
def reference_solvers():
    """Inside the ``with`` block, designs use scipy's solvers point by point: the Riccati
    equation per grid speed (no whole-grid design) and ``place_poles`` for every pole
    placement. For comparisons and the benchmark; the design caches still answer for designs
    already made (clear them, or use ``ROADBANK_CACHE_DIR=off``, to compare)."""
    global _REFERENCE
    old, _REFERENCE = _REFERENCE, True
    try:
        yield
    finally:
        _REFERENCE = old


def using_reference_solvers() -> bool:
    """True inside :func:`reference_solvers`."""
    return _REFERENCE


class NoStabilisingSolution(ValueError):
    """The filter Riccati equation has no stabilising, positive-definite solution."""


def game_are(A: np.ndarray, C: np.ndarray, Lw: np.ndarray, W: np.ndarray, R: np.ndarray,
             S: np.ndarray, th: float, *, where: str = "") -> np.ndarray:
    r"""Stabilising solution of the filter (game-type) algebraic Riccati equation (paper eq 44).

    .. math::
        A P + P A^T + W - P (C^T R^{-1} C - \theta L_w^T S L_w) P = 0

    solved as the dual control ARE of ``scipy.linalg.solve_continuous_are`` with
    ``a = A^T``, ``b = [C^T, L_w^T]``, ``q = W``, ``r = diag(R, -S^{-1}/\theta)``.
    ``th = 0`` gives the Kalman-Bucy filter ARE.

    Raises
    ------
    NoStabilisingSolution
        if no solution exists, or it is not positive definite, or the filter
        ``A - P C^T R^{-1} C`` or the game closed loop is not Hurwitz. ``where``
        (e.g. ``"vx=12.0 m/s"``) is added to the message.

    """
    R = np.atleast_2d(R).astype(float)
    S = np.atleast_2d(S).astype(float)
    if th < 0:
        raise ValueError(f"th must be >= 0, got {th}")
    try:
        if th == 0:
            P = solve_continuous_are(A.T, C.T, W, R)
        else:
            b = np.hstack([C.T, Lw.T])
            r = np.zeros((b.shape[1], b.shape[1]))
            p = C.shape[0]
            r[:p, :p] = R
            r[p:, p:] = -np.linalg.inv(S) / th
            P = solve_continuous_are(A.T, b, W, r)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise NoStabilisingSolution(
            f"no stabilising solution of the H-infinity Riccati equation for th={th} {where}: {exc}. "
            "Lower th (th=0 is the Kalman filter).") from None
    P = 0.5 * (P + P.T)
    Rinv = np.linalg.inv(R)
    eig_p = np.linalg.eigvalsh(P)
    if not np.all(np.isfinite(P)) or eig_p.min() <= 0:
        why = ("the H-infinity bound 1/th is not achievable; lower th." if th > 0 else
               "with th = 0 (the Kalman filter) the process noise W leaves a state unexcited: W (Q) must be "
               "positive definite, not zero in a direction.")
        raise NoStabilisingSolution(
            f"H-infinity Riccati solution is not positive definite for th={th} {where} "
            f"(smallest eigenvalue {eig_p.min():.3g}): {why}")
    filt = A - P @ C.T @ Rinv @ C
    game = A - P @ (C.T @ Rinv @ C - th * Lw.T @ S @ Lw)
    for label, M in (("filter", filt), ("game closed loop", game)):
        worst = np.linalg.eigvals(M).real.max()
        if worst >= 0:
            raise NoStabilisingSolution(
                f"H-infinity {label} not stable for th={th} {where} (eigenvalue real part "
                f"{worst:.3g}); lower th.")
    return P


def place_observer(A: np.ndarray, C: np.ndarray, poles) -> np.ndarray:
    """Observer gain ``K`` with ``eig(A - K C) = poles`` (1/s).

    One output (``C`` a single row): the gain is unique, Ackermann's formula
    (:func:`ackermann_observer`, a few small matrix products). Several outputs: scipy
    ``place_poles`` on the dual (the gain is not unique; scipy's choice), as for one output
    inside :func:`reference_solvers`.
    """
    C = np.atleast_2d(C)
    if C.shape[0] == 1 and not _REFERENCE:
        K = ackermann_observer(A, C, poles)
        if K is not None:
            return K
    # imported here: scipy.signal pulls in scipy.stats (~1.3 s, ~20 MB) for every user of
    # roadbank.estimators, while only the pole-placement designs need it
    from scipy.signal import place_poles

    return place_poles(A.T, C.T, np.asarray(poles)).gain_matrix.T


def ackermann_observer(A: np.ndarray, C: np.ndarray, poles) -> np.ndarray | None:
    r"""Gain ``K`` (n, 1) with ``eig(A - K C) = poles`` for one output ``C`` (1, n) (Ackermann):

    .. math::
        K = \varphi(A)\, \mathcal{O}^{-1} e_n,\qquad
        \varphi(s) = \prod_i (s - p_i),\quad \mathcal{O} = [C; C A; \dots; C A^{n-1}]

    ``poles`` (1/s) must be closed under conjugation. None when ``(A, C)`` is numerically not
    observable (condition number of :math:`\mathcal{O}` above 1e10) or the poles are not
    ``n`` values closed under conjugation: then the caller takes scipy's ``place_poles``.
    """
    n = A.shape[0]
    p = np.asarray(poles, dtype=complex).ravel()
    coef = np.poly(p)
    if p.size != n or np.abs(coef.imag).max() > 1e-9 * np.abs(coef).max():
        return None
    rows = [np.atleast_2d(C)]
    for _ in range(n - 1):
        rows.append(rows[-1] @ A)
    O = np.vstack(rows)
    if not np.linalg.cond(O) < 1e10:
        return None
    phi = np.zeros_like(A, dtype=float)
    for c in coef.real:                    # Horner: phi = (..((A + c1) A + c2) A ..) + cn
        phi = phi @ A + c * np.eye(n)
    e = np.zeros((n, 1))
    e[-1, 0] = 1.0
    return phi @ np.linalg.solve(O, e)

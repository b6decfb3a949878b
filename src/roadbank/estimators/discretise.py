r"""Exact discretisation of the scheduled observers for a fixed sample interval (the fixed-rate path).

For ``x' = F x + G e(t)`` with the input varying linearly between two samples
``e(0) = e0``, ``e(h) = e1`` (first-order hold: the same input assumption as the
general trapezoidal path), the exact solution after one interval ``h`` is

.. math::
    x(h) = \Phi x(0) + \Gamma_0 e_0 + \Gamma_1 e_1,\qquad
    \exp\left(h\begin{bmatrix} F & G & 0\\ 0 & 0 & I\\ 0 & 0 & 0\end{bmatrix}\right)
    = \begin{bmatrix} \Phi & A_1 & A_2\\ 0 & I & hI\\ 0 & 0 & I\end{bmatrix},\quad
    \Gamma_1 = A_2/h,\ \Gamma_0 = A_1 - A_2/h

(the augmented state ``[x, e, de/dt]`` with ``de/dt = (e1 - e0)/h`` constant).
:func:`roadbank.estimators.expm.foh_blocks` evaluates the exponential (:func:`foh_grid`: of a
whole speed grid at once, the same numbers as :func:`foh` per grid point); inside
:func:`roadbank.estimators.synthesis.reference_solvers` it is ``scipy.linalg.expm`` of the
whole matrix, the exponential the batched one is compared with (they agree to about 1e-15
relative).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm as scipy_expm

from .expm import foh_blocks
from .synthesis import using_reference_solvers


def _blocks(F: np.ndarray, G: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Phi, A1, A2)`` of stacks ``F`` (g, n, n), ``G`` (g, n, m) (module docstring), n > 0."""
    if not using_reference_solvers():
        return foh_blocks(F, G, h)
    g, n, m = G.shape
    M = np.zeros((g, n + 2 * m, n + 2 * m))
    M[:, :n, :n] = F
    M[:, :n, n:n + m] = G
    M[:, n:n + m, n + m:] = np.eye(m)
    E = scipy_expm(M * h)
    return E[:, :n, :n], E[:, :n, n:n + m], E[:, :n, n + m:]


def foh(F: np.ndarray, G: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Phi, Gam0, Gam1)`` of ``x' = F x + G e`` over ``h`` seconds with ``e`` linear in time.

    Parameters
    ----------
    F : (n, n) array (1/s)
    G : (n, m) array
    h : float
        Sample interval (s), > 0.

    Returns
    -------
    Phi : (n, n) array, Gam0, Gam1 : (n, m) arrays
        ``x(h) = Phi x(0) + Gam0 e(0) + Gam1 e(h)``.
    """
    n, m = G.shape
    if n == 0:
        return np.zeros((0, 0)), np.zeros((0, m)), np.zeros((0, m))
    Phi, A1, A2 = _blocks(np.asarray(F, dtype=float)[None], np.asarray(G, dtype=float)[None], h)
    return Phi[0], A1[0] - A2[0] / h, A2[0] / h


def foh_grid(F: np.ndarray, G: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`foh` of a stack of systems: ``F`` (g, n, n) (1/s), ``G`` (g, n, m), ``h`` (s) > 0.

    Returns ``Phi`` (g, n, n), ``Gam0``, ``Gam1`` (g, n, m): one batched exponential of the whole
    stack instead of one per system.
    """
    g, n, m = G.shape
    if n == 0:
        return np.zeros((g, 0, 0)), np.zeros((g, 0, m)), np.zeros((g, 0, m))
    Phi, A1, A2 = _blocks(F, G, h)
    return Phi, A1 - A2 / h, A2 / h

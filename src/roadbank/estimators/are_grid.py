r"""The filter (game-type) algebraic Riccati equation on a whole grid of small systems at once.

Solves, at every point ``k`` of a grid (speeds, or speed x excitation),

.. math::
    A_k P + P A_k^T + W_k - P \Gamma_k P = 0,\qquad
    \Gamma_k = C_k^T R^{-1} C_k - \theta L_w^T S L_w

for the stabilising solution, as :func:`roadbank.estimators.synthesis.game_are_reference` does
one point at a time with scipy, and applies the same acceptance checks (``P`` positive definite,
the filter ``A - P C^T R^{-1} C`` and the game closed loop ``A - P Gamma`` Hurwitz). Every step
is a numpy operation on the stack of all points (LAPACK per small matrix, no Python loop per
point and nothing to compile):

1. starts on a coarse subgrid (every :data:`COARSE_STRIDE`-th speed, and the last): the stable
   invariant subspace of the Hamiltonian ``[[A^T, -Gamma], [-W, -A]]`` from its matrix sign
   function (Newton's iteration ``Z <- (c Z + (c Z)^{-1}) / 2`` with determinant scaling ``c``,
   to :data:`SIGN_TOL`; a point still far from converging after :data:`SIGN_SLOW_AFTER`
   iterations has eigenvalues on the imaginary axis to rounding and is given up on),
   with ``P`` scaled so that ``W`` and ``Gamma`` weigh alike; the first speed first, alone;
2. Newton's method on the Riccati equation (Kleinman's iteration written for an indefinite
   ``Gamma``): ``P_{j+1}`` solves the Lyapunov equation
   ``(A - P_j Gamma) P + P (A - P_j Gamma)^T + W + P_j Gamma P_j = 0`` (as a linear system in
   the ``n (n + 1) / 2`` entries of the symmetric ``P``), which
   converges quadratically, until the update is below :data:`NEWTON_TOL` relative: first on the
   coarse points, then on the others, each started from the coarse solutions around it
   interpolated by a cubic through four of them (linearly between two where not all four are
   solved; the solutions are smooth in speed: two iterations, mostly);
3. the checks: ``P`` positive definite (Cholesky), a closed loop ``M`` Hurwitz when the solution
   of ``M X + X M^T + I = 0`` is positive definite (Lyapunov's theorem; cheaper than the
   eigenvalues of the scipy path on a stack, the same decision).

A point that does not converge or fails a check is reported, not raised: the caller solves it
again with scipy, which either finds the solution or raises the error that names the speed.
Beyond the first coarse speed without an accepted solution (or without a start) nothing is
solved (reported as not solved): where no stabilising solution exists the caller's error comes
at or before it. So a design whose ``th`` has no solution costs little more than the points up
to the first speed without one: the ``th`` halvings of the default-tuned PIFs are cheap.
"""

from __future__ import annotations

import functools

import numpy as np

#: coarse subgrid of the sign-function starts: every this many speeds
COARSE_STRIDE = 4
#: Newton stops at an update of at most this relative to ``P`` (max norms); the error left is
#: of the order of its square (quadratic convergence)
NEWTON_TOL = 1e-9
#: Newton iterations before a point counts as not converged
NEWTON_MAX_ITER = 8
#: the sign iteration stops at a change of at most this relative (1-norms): a start for Newton,
#: which converges quadratically from there
SIGN_TOL = 1e-6
#: sign-function iterations before a point counts as not converged: the estimators' grids converge
#: in 4 to 8; points whose Hamiltonian has eigenvalues on the imaginary axis to rounding (no
#: stabilising solution) take 30 or more, so they are given up on here (the caller's per-point
#: path decides them)
SIGN_MAX_ITER = 16
#: ... and a point still changing by more than :data:`SIGN_SLOW_CHANGE` (relative) after this many
#: iterations is given up on as well: the points that converge are in the quadratic regime by then
SIGN_SLOW_AFTER = 10
SIGN_SLOW_CHANGE = 1e-2


def _solve(M: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``X`` with ``M X = B`` for each matrix of a stack, and ``ok`` (g,): ``M`` finite and not
    singular (``X`` is NaN where not)."""
    finite = np.isfinite(M).all(axis=(1, 2)) & np.isfinite(B).all(axis=(1, 2))
    if not finite.all():
        M = np.where(finite[:, None, None], M, np.eye(M.shape[1]))
        B = np.where(finite[:, None, None], B, 0.0)
    try:
        return np.linalg.solve(M, B), finite
    except np.linalg.LinAlgError:          # a singular matrix in the stack: solve the others
        pass
    sign, _ = np.linalg.slogdet(M)          # the same LU: an exactly singular one has sign 0
    finite &= sign != 0
    X = np.full(B.shape, np.nan)
    try:
        X[finite] = np.linalg.solve(M[finite], B[finite])
    except np.linalg.LinAlgError:          # not found singular by its determinant: one by one
        for i in np.flatnonzero(finite):
            try:
                X[i] = np.linalg.solve(M[i], B[i])
            except np.linalg.LinAlgError:
                finite[i] = False
    return X, finite


def _rows(X: np.ndarray, live: np.ndarray) -> np.ndarray:
    """``X[live]``, or ``X`` itself when ``live`` is every index of it in order (no copy)."""
    return X if live.size == X.shape[0] else X[live]


def _max_abs(X: np.ndarray) -> np.ndarray:
    """Largest ``|X|`` of each matrix of a stack (..., n, m)."""
    return np.abs(X).max(axis=(-2, -1))


def sign_start(A: np.ndarray, Gam: np.ndarray, W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Approximate stabilising solutions of a stack (g, n, n) from the Hamiltonian's sign function.

    Returns ``P`` (g, n, n) and ``ok`` (g,): the iteration converged and ``P`` is finite.
    """
    g, n, _ = A.shape
    wmax, gmax = _max_abs(W), _max_abs(Gam)
    s = np.where((wmax > 0) & (gmax > 0), np.sqrt(wmax / np.where(gmax > 0, gmax, 1.0)), 1.0)
    Z = np.empty((g, 2 * n, 2 * n))
    Z[:, :n, :n] = np.swapaxes(A, 1, 2)
    Z[:, :n, n:] = -s[:, None, None] * Gam
    Z[:, n:, :n] = -W / s[:, None, None]
    Z[:, n:, n:] = -A
    done = np.zeros(g, dtype=bool)
    failed = np.zeros(g, dtype=bool)        # singular or not finite: no start, iterated no further
    with np.errstate(all="ignore"):
        for it in range(SIGN_MAX_ITER):
            live = np.flatnonzero(~done & ~failed)
            if live.size == 0:
                break
            Zl = Z[live]
            sign, logdet = np.linalg.slogdet(Zl)
            bad = ~(sign != 0) | ~np.isfinite(logdet)
            if bad.any():
                failed[live[bad]] = True
                Z[live[bad]] = np.nan
                keep = ~bad
                live, Zl, logdet = live[keep], Zl[keep], logdet[keep]
                if live.size == 0:
                    break
            c = np.exp(-logdet / (2 * n))[:, None, None]
            try:
                Zi = np.linalg.inv(Zl)
            except np.linalg.LinAlgError:   # singular to LAPACK although its determinant is not 0
                Zi, fin = _solve(Zl, np.broadcast_to(np.eye(2 * n), Zl.shape))
                failed[live[~fin]] = True
            Zn = 0.5 * (c * Zl + Zi / c)
            change = np.abs(Zn - Zl).sum(axis=(1, 2)) / np.abs(Zn).sum(axis=(1, 2))
            Z[live] = Zn
            failed[live[~np.isfinite(change)]] = True
            if it + 1 >= SIGN_SLOW_AFTER:
                failed[live[change > SIGN_SLOW_CHANGE]] = True
            done[live[change <= SIGN_TOL]] = True
        done &= ~failed
        eye = np.eye(n)
        M = np.concatenate([Z[:, :n, n:], Z[:, n:, n:] + eye], axis=1)        # (g, 2n, n)
        N = -np.concatenate([Z[:, :n, :n] + eye, Z[:, n:, :n]], axis=1)
        Mt = np.swapaxes(M, 1, 2)
        MtM = np.where(done[:, None, None], Mt @ M, eye)
        X, solved = _solve(MtM, Mt @ N)
    P = s[:, None, None] * 0.5 * (X + np.swapaxes(X, 1, 2))
    ok = done & solved & np.all(np.isfinite(P), axis=(1, 2))
    return np.where(ok[:, None, None], P, 0.0), ok


@functools.cache
def _lyapunov_map(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For symmetric ``X`` (n, n) and its ``m = n (n + 1) / 2`` entries on and above the diagonal
    (``X[iu, ju]``): ``T`` (n^2, m^2) with ``vec(M) @ T`` the (m, m) matrix of
    ``X -> (M X + X M^T)`` on those entries, and ``iu``, ``ju``."""
    iu, ju = np.triu_indices(n)
    m = iu.size
    col = np.empty((n, n), dtype=int)
    col[iu, ju] = col[ju, iu] = np.arange(m)
    T = np.zeros((n, n, m, m))
    for r, (i, j) in enumerate(zip(iu, ju)):
        for k in range(n):
            T[i, k, r, col[k, j]] += 1.0          # (M X)[i, j] = sum_k M[i, k] X[k, j]
            T[j, k, r, col[i, k]] += 1.0          # (X M^T)[i, j] = sum_k X[i, k] M[j, k]
    return T.reshape(n * n, m * m), iu, ju


def _lyapunov(M: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Symmetric ``X`` with ``M X + X M^T + Q = 0`` for each matrix of a stack (``Q`` symmetric),
    and ``ok`` (g,): solved (not singular, finite)."""
    g, n, _ = M.shape
    T, iu, ju = _lyapunov_map(n)
    m = iu.size
    K = (M.reshape(g, n * n) @ T).reshape(g, m, m)
    x, ok = _solve(K, -Q[:, iu, ju][:, :, None])
    X = np.empty((g, n, n))
    X[:, iu, ju] = X[:, ju, iu] = x[:, :, 0]
    return X, ok


def newton(A: np.ndarray, Gam: np.ndarray, W: np.ndarray, P0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Newton's iteration on the Riccati equations of a stack from the starts ``P0`` (g, n, n).

    Returns ``P`` and ``ok`` (g,): converged to :data:`NEWTON_TOL` with a finite result.
    """
    g = A.shape[0]
    P = P0.copy()
    done = np.zeros(g, dtype=bool)
    failed = np.zeros(g, dtype=bool)
    with np.errstate(all="ignore"):
        for _ in range(NEWTON_MAX_ITER):
            live = np.flatnonzero(~done & ~failed)
            if live.size == 0:
                break
            Pl = _rows(P, live)
            PG = Pl @ _rows(Gam, live)
            Q = _rows(W, live) + PG @ Pl
            Pn, finite = _lyapunov(_rows(A, live) - PG, 0.5 * (Q + np.swapaxes(Q, 1, 2)))
            step = _max_abs(Pn - Pl)
            size = _max_abs(Pn)
            good = finite & np.isfinite(size)
            if live.size == g:
                P = Pn
            else:
                P[live] = Pn
            failed[live[~good]] = True
            done[live[good & (step <= NEWTON_TOL * size)]] = True
    return P, done & ~failed


def _positive_definite(X: np.ndarray) -> np.ndarray:
    """Each symmetric matrix of a stack (g, n, n) positive definite (g,): Cholesky of the whole
    stack, the smallest eigenvalue where that fails for some."""
    try:
        np.linalg.cholesky(X)
        return np.ones(X.shape[0], dtype=bool)
    except np.linalg.LinAlgError:
        pass
    # Sylvester's criterion finds the candidates (every leading minor > 0), Cholesky decides on them
    ok = np.ones(X.shape[0], dtype=bool)
    for k in range(1, X.shape[1] + 1):
        ok &= np.linalg.slogdet(X[:, :k, :k])[0] > 0
    try:
        np.linalg.cholesky(X[ok])
        return ok
    except np.linalg.LinAlgError:
        return np.linalg.eigvalsh(X)[:, 0] > 0


def _hurwitz(M: np.ndarray) -> np.ndarray:
    """Every eigenvalue of each matrix of a stack in the open left half-plane (g,): the solution
    of ``M X + X M^T + I = 0`` exists and is positive definite (Lyapunov)."""
    g, n, _ = M.shape
    X, ok = _lyapunov(M, np.broadcast_to(np.eye(n), (g, n, n)))
    ok &= np.all(np.isfinite(X), axis=(1, 2))
    ok[ok] = _positive_definite(X[ok])
    return ok


def accepted(A: np.ndarray, Gam0: np.ndarray, Gam: np.ndarray, P: np.ndarray) -> np.ndarray:
    """The scipy path's checks per point (g,): ``P`` positive definite, the filter ``A - P Gam0``
    and the game closed loop ``A - P Gam`` Hurwitz."""
    ok = np.all(np.isfinite(P), axis=(1, 2))
    Ps = P if ok.all() else np.where(ok[:, None, None], P, np.eye(P.shape[1]))
    ok &= _positive_definite(Ps)
    for G in (Gam0, Gam):
        ok &= _hurwitz(A - Ps @ G)
    return ok


def _refine(A, Gam0, Gam, W, P0, start) -> tuple[np.ndarray, np.ndarray]:
    """Newton from ``P0`` on the points with a ``start`` (g,) and the checks on those it converged
    on: ``P`` (g, n, n) and ``ok`` (g,); the points without a start or a converged, accepted
    solution are not ok (and cost no Newton step or check)."""
    P = np.zeros_like(A)
    ok = np.zeros(A.shape[0], dtype=bool)
    live = np.flatnonzero(start)
    if live.size:
        Pl, conv = newton(_rows(A, live), _rows(Gam, live), _rows(W, live), _rows(P0, live))
        live, Pl = live[conv], _rows(Pl, np.flatnonzero(conv))
        if live.size:
            ok[live] = accepted(_rows(A, live), _rows(Gam0, live), _rows(Gam, live), Pl)
            P[live] = Pl
    return P, ok


def _coarse_starts(A, Gam, W, n_inner: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sign_start` of the coarse points (outer-major, ``n_inner`` per outer value), up to
    the first outer value that lacks a start at some inner point: nothing beyond it is solved
    (see :func:`solve_grid`), so the points there have none. The first outer value is started
    on its own: a design whose ``th`` has no solution at the lowest speed costs the sign
    iterations of that speed only."""
    P, ok = sign_start(A[:n_inner], Gam[:n_inner], W[:n_inner])
    if A.shape[0] > n_inner and ok.all():
        Pr, okr = sign_start(A[n_inner:], Gam[n_inner:], W[n_inner:])
        P, ok = np.concatenate([P, Pr]), np.concatenate([ok, okr])
    else:
        P = np.concatenate([P, np.zeros_like(A[n_inner:])])
        ok = np.concatenate([ok, np.zeros(A.shape[0] - n_inner, dtype=bool)])
    complete = ok.reshape(-1, n_inner).all(axis=1)
    if not complete.all():
        ok[(int(np.argmin(complete)) + 1) * n_inner:] = False
    return P, ok


def _fine_starts(coarse, fine, n_inner: int, Pc, okc):
    """Starts of the points at the outer indices ``fine`` (each with its ``n_inner`` points) from
    the coarse solutions ``Pc`` (``okc``: accepted) at the outer indices ``coarse``.

    Returns ``P0`` (f * n_inner, n, n), ``start`` (which have one) and ``(linear, retry)``: the
    linear interpolation between the coarse points on either side (the nearer one where the
    other is missing), which ``P0`` is wherever the cubic one is not available, and the points
    whose ``P0`` is the cubic one and that have a linear start too.
    """
    n = Pc.shape[1]
    Pc = Pc.reshape(len(coarse), n_inner, n, n)
    okc = okc.reshape(len(coarse), n_inner)
    hi = np.searchsorted(coarse, fine)
    lo = hi - 1
    a = ((fine - coarse[lo]) / (coarse[hi] - coarse[lo]))[:, None]
    ok_lo, ok_hi = okc[lo], okc[hi]
    w_hi = np.where(ok_lo & ok_hi, a, np.where(ok_hi, 1.0, 0.0))[:, :, None, None]
    lin = ((1.0 - w_hi) * Pc[lo] + w_hi * Pc[hi]).reshape(-1, n, n)
    lin_ok = (ok_lo | ok_hi).ravel()
    if len(coarse) < 4:
        return lin, lin_ok, (lin, lin_ok)
    first = np.clip(lo - 1, 0, len(coarse) - 4)
    nodes = first[:, None] + np.arange(4)                       # (f, 4) coarse positions
    x = coarse[nodes].astype(float)
    w = np.ones((len(fine), 4))                                 # Lagrange weights at each fine index
    for j in range(4):
        for m in range(4):
            if m != j:
                w[:, j] *= (fine - x[:, m]) / (x[:, j] - x[:, m])
    cub_ok = okc[nodes].all(axis=1)                             # (f, n_inner)
    cub = np.einsum("fj,fjiab->fiab", w, np.where(okc[nodes][..., None, None], Pc[nodes], 0.0))
    use = cub_ok.ravel()
    P0 = np.where(use[:, None, None], cub.reshape(-1, n, n), lin)
    return P0, use | lin_ok, (lin, lin_ok & use)


def solve_grid(A: np.ndarray, Gam0: np.ndarray, Gam: np.ndarray, W: np.ndarray,
               n_inner: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Stabilising solutions at every point of a grid (see the module docstring).

    Parameters
    ----------
    A, Gam0, Gam, W : (g, n, n) arrays
        ``A``, ``C^T R^{-1} C``, ``Gamma`` and ``W`` of each point, in the units of the equation;
        ``g = n_outer * n_inner`` points ordered outer-major (speed outer).
    n_inner : int
        Points per outer grid value (1 for a speed grid; the excitations of a speed x excitation
        grid). The coarse starts are taken along the outer axis.

    Returns
    -------
    P : (g, n, n) array
        The solutions (where ``ok``).
    ok : (g,) bool array
        Converged and accepted; the other points must be solved another way.
    """
    g, n, _ = A.shape
    n_outer = g // n_inner
    inner = np.arange(n_inner)
    coarse = np.unique(np.r_[np.arange(0, n_outer, COARSE_STRIDE), n_outer - 1])
    idx = (coarse[:, None] * n_inner + inner).ravel()
    Pc, okc = _refine(A[idx], Gam0[idx], Gam[idx], W[idx], *_coarse_starts(A[idx], Gam[idx], W[idx], n_inner))
    # beyond the first coarse speed without a solution nothing is solved here: the caller's
    # per-point path raises at the first point without one (the points after it are not needed)
    bad = coarse[~okc.reshape(len(coarse), n_inner).all(axis=1)]
    limit = bad[0] if bad.size else n_outer
    okc &= np.repeat(coarse <= limit, n_inner)
    P = np.zeros_like(A)
    ok = np.zeros(g, dtype=bool)
    P[idx], ok[idx] = Pc, okc
    # the other points start from the coarse solutions around them, interpolated in the outer
    # index: cubic through the four nearest where all four are solved, else linear between the
    # two on either side (the nearer one where the other is missing); then Newton. A point
    # Newton does not take from the cubic start is tried again from the linear one.
    fine = np.setdiff1d(np.arange(min(limit, n_outer)), coarse)
    if fine.size:
        jdx = (fine[:, None] * n_inner + inner).ravel()
        P0, start, lin = _fine_starts(coarse, fine, n_inner, Pc, okc)
        Pf, okf = _refine(A[jdx], Gam0[jdx], Gam[jdx], W[jdx], P0, start)
        lin_P0, retry = lin
        retry &= ~okf
        if retry.any():
            k = jdx[retry]
            Pf[retry], okf[retry] = _refine(A[k], Gam0[k], Gam[k], W[k], lin_P0[retry], np.ones(k.size, dtype=bool))
        P[jdx], ok[jdx] = Pf, okf
    return P, ok

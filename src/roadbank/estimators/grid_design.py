"""Whole-grid designs of the Riccati-designed observers: every grid point of the schedule at once.

The estimators define their observer one frozen speed at a time (``observer(vx)``: the design
model, the Riccati equation, the gain). Solved point by point with scipy that costs 0.3-2 s per
design. :func:`pif_speed`, :func:`pif_adaptive` and :func:`kalman_speed` build the same table for the
steady-state PIFs (``pif-modified``, ``pif-original``, ``pif-rate``, ``pif-adaptive``,
``pif-rate-adaptive``, the filters of ``pif-gated`` and the forward pass of ``pif-smoother``)
and the Kalman peer in one pass: the
design models point by point (the estimators' own), then every Riccati equation of the grid at
once (:func:`roadbank.estimators.are_grid.solve_grid`), the gains, observers and equilibrium
maps as stacked numpy operations. A grid point the grid solver does not accept is designed by
the estimator's own per-point path (scipy), which finds the solution or raises the error that
names the speed, exactly as before. Each estimator decides whether its observer is built the way
these functions assume (``_grid_design``), so this module imports none of them; any other
estimator, and a subclass that redefines how its observer is built, is designed by its own loop.

:func:`roadbank.estimators.synthesis.reference_solvers` switches the whole-grid path off (the
comparisons and the benchmark).

A design is a function of its inputs alone, whatever the process designed before:
:func:`pif_solution` gives a steady PIF's Riccati solution at a grid speed from the whole-grid
solution of that PIF's own design (solved again when the design came from a cache), never from
another design's grid. (A whole-grid solution differs from scipy's per-point one by rounding,
and each point's depends on the grid: Newton starts from its neighbours' solutions. Answering
an equation from whichever grid a process had solved last made a design depend on what was
designed before it, and a disk-cached design differ from a fresh one in the last bits.)
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import cache
from . import base, synthesis
from .are_grid import solve_grid
from .base import augmented_design_model


#: design models of recent grids (:func:`_grid_models`)
_MODELS: dict = {}
#: the process-noise densities of the last grid designed (:func:`_grid_noise`)
_NOISE: dict = {}
#: the whole-grid Riccati solutions ``(P, ok)`` of recent steady PIF designs, by estimator class
#: and design inputs (:func:`pif_solution`)
_SOLUTIONS: dict = {}


def clear_memos(models: bool = True) -> None:
    """Forget every design this process has memoised (the tables, the fixed-rate tables, the grid's
    noise densities and Riccati solutions; ``models``: the car's design models too), so that the
    next design of anything is made anew, as in a fresh process (the disk cache is apart:
    ``ROADBANK_CACHE_DIR=off``). For benchmarks that time designs."""
    base._DESIGN_CACHE.clear()
    base._DISCRETE_CACHE.clear()
    _NOISE.clear()
    _SOLUTIONS.clear()
    if models:
        _MODELS.clear()
        base._augmented_design_model.cache_clear()


def _grid_models(key: tuple, build) -> tuple:
    """``build()``, the design models of every grid point, stacked (``A, B, C, Dy, Lw``, each
    (g, ., .)) and memoised on what they depend on (``key``: the car, the model and the grid; no
    weight enters them): a new noise level, or the retries of a default ``th`` halved until it is
    solvable, build no model again."""
    hit = _MODELS.get(key)
    if hit is None:
        models = build()
        if len(_MODELS) >= 16:
            _MODELS.clear()
        hit = _MODELS[key] = (tuple(np.array([m[i] for m in models]) for i in range(5)), models)
    return hit


def _grid_noise(est, models: tuple, own: bool) -> np.ndarray:
    """``est.process_density`` of every model (g, n, n), memoised on the estimator class and its
    design inputs but ``th`` where ``own`` (the noise model is PIF's own, which does not use ``th``:
    the retries of a halved ``th`` compute none again)."""
    d = est.design
    key = (type(est), cache.canonical(replace(d, th=0.0) if own else d))   # a subclass's own noise may use th
    hit = _NOISE.get(key)
    if hit is None or hit[0] is not models:
        _NOISE.clear()
        hit = _NOISE[key] = (models, _stacked_noise(est, models) if own else
                             np.array([est.process_density(m) for m in models[1]]))
    return hit[1]


def _stacked_noise(est, models: tuple) -> np.ndarray:
    """:meth:`PIF.process_density <roadbank.estimators.pif.PIF.process_density>` of every model at
    once: ``process_noise(Ew)`` (one call per distinct ``Ew``; the augmented models share one) plus
    ``Q_ay b b^T``, ``b`` the ``ay`` column of each ``B``."""
    listed = models[1]
    Ew = np.array([m[5] for m in listed])
    first = Ew[0]
    if not np.array_equal(Ew, np.broadcast_to(first, Ew.shape)):
        return np.array([est.process_density(m) for m in listed])
    b = models[0][1][:, :, 1]
    return est.process_noise(first) + est.design.Q_ay * (b[:, :, None] * b[:, None, :])


def pif_speed(est, own_noise: bool):
    """The ``lpv`` table ``(rows, number of states, extra)`` of a steady-state PIF's design inputs
    (``est.design``) over its speed grid at once (``est`` builds its observer as
    :class:`~roadbank.estimators.pif.PIF` does; ``own_noise``: its process noise is PIF's own);
    None inside :func:`~roadbank.estimators.synthesis.reference_solvers`."""
    if synthesis.using_reference_solvers():
        return None
    models, P, ok = _pif_grid(est, own_noise)
    speeds = [float(v) for v in est.design.vgrid]
    tab = observer_rows(models, P, ok, est.design.R_matrix, lambda k: est.observer(speeds[k]))
    return tab, models[0].shape[1], np.zeros(0)


def _pif_grid(est, own_noise: bool) -> tuple:
    """``(models, P, ok)`` of a steady-state PIF's design over its speed grid: the stacked design
    models, the whole-grid Riccati solutions and which of them the grid solver accepted (kept
    for :func:`pif_solution`)."""
    d = est.design
    vgrid = d.vgrid
    speeds = [float(v) for v in vgrid]
    key = (type(est)._model_at, repr(d.params), d.model, vgrid.tobytes())
    models = _grid_models(key, lambda: [est.design_model(v) for v in speeds])
    P, ok = grid_solutions(models[0], _grid_noise(est, models, own_noise), d.R_matrix, d.S, d.th)
    if len(_SOLUTIONS) >= 4:
        _SOLUTIONS.clear()
    _SOLUTIONS[(type(est), cache.canonical(d))] = (P, ok)
    return models[0], P, ok


def pif_solution(est, own_noise: bool, vx: float) -> np.ndarray | None:
    """The Riccati solution ``P`` of a steady-state PIF's own whole-grid design at the grid speed
    ``vx`` (m/s), as its table uses it; None where the design does not use one (``vx`` not on the
    grid, a point the grid solver did not accept, or inside
    :func:`~roadbank.estimators.synthesis.reference_solvers`): the caller solves that point itself."""
    if synthesis.using_reference_solvers():
        return None
    d = est.design
    vgrid = d.vgrid
    k = int(np.searchsorted(vgrid, vx))
    if k >= len(vgrid) or vgrid[k] != vx:
        return None
    hit = _SOLUTIONS.get((type(est), cache.canonical(d)))
    P, ok = hit if hit is not None else _pif_grid(est, own_noise)[1:]
    return P[k].copy() if ok[k] else None


def pif_adaptive(est, own_noise: bool):
    """The table of :meth:`PIFAdaptive._design <roadbank.estimators.pif.PIFAdaptive._design>` (speed x
    excitation grid, speed outer) at once; None inside :func:`~roadbank.estimators.synthesis.reference_solvers`."""
    if synthesis.using_reference_solvers():
        return None
    d = est.design
    vgrid = d.vgrid
    speeds, ne = [float(v) for v in vgrid], len(d.egrid)

    def build():
        cars = [replace(d.params, Cr=est.rear_stiffness(e)) for e in d.egrid]
        return [est._model_at(car, v) for v in speeds for car in cars]
    key = (type(est)._model_at, repr(d.params), d.model, vgrid.tobytes(), tuple(d.egrid), d.mu,
           type(est).rear_stiffness)
    models = _grid_models(key, build)
    P, ok = grid_solutions(models[0], _grid_noise(est, models, own_noise), d.R_matrix, d.S, d.th, n_inner=ne)
    tab = observer_rows(models[0], P, ok, d.R_matrix, lambda k: est.observer_at(speeds[k // ne], d.egrid[k % ne]))
    eg = d.egrid
    extra = [eg[0], (eg[1] - eg[0]) if len(eg) > 1 else 1.0, float(len(eg)), d.tau, d.tf]
    return tab, len(est.state_names), np.array(extra)


def kalman_speed(est):
    """The table of the Kalman peer (augmented original model, ``W = diag(q)``, ``R``, no game term)
    over its speed grid at once; None inside :func:`~roadbank.estimators.synthesis.reference_solvers`."""
    if synthesis.using_reference_solvers():
        return None
    d = est.design
    vgrid = d.vgrid
    speeds = [float(v) for v in vgrid]
    key = ("original", repr(d.params), vgrid.tobytes())
    models = _grid_models(key, lambda: [augmented_design_model(d.params, v, "original") for v in speeds])
    W = np.broadcast_to(np.diag(np.asarray(d.q, dtype=float)), (len(speeds), 3, 3))
    R = np.diag(np.asarray(d.R, dtype=float))
    P, ok = grid_solutions(models[0], W, R, 1.0, 0.0)
    tab = observer_rows(models[0], P, ok, R, lambda k: est.observer(speeds[k]))
    return tab, models[0][0].shape[1], np.zeros(0)


def grid_solutions(models, W, R, S, th, n_inner: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The stabilising Riccati solutions of a grid's steady-state filters.

    Parameters
    ----------
    models : tuple of arrays ``(A, B, C, Dy, Lw)``
        The design model of each grid point stacked, (g, n, n), (g, n, 3), (g, p, n), (g, p, 3),
        (g, 1, n) (:func:`~roadbank.estimators.base.augmented_design_model`).
    W : (g, n, n) array
        Process-noise density of each point (units of the state rates squared times s).
    R : (p, p) array, S : float or (1, 1) array, th : float
        Measurement-noise density, disturbance weight and H-infinity level (as
        :func:`~roadbank.estimators.synthesis.game_are`).
    n_inner : int
        Points per speed (outer-major order), see :func:`~roadbank.estimators.are_grid.solve_grid`.

    Returns
    -------
    P : (g, n, n) array
        The solutions (units of the states squared), where ``ok``.
    ok : (g,) bool array
        Accepted by the grid solver; the other points must be designed point by point.
    """
    A, B, C, Dy, Lw = models
    R = np.atleast_2d(np.asarray(R, dtype=float))
    Rinv = np.linalg.inv(R)
    S = np.atleast_2d(np.asarray(S, dtype=float))
    Ct = np.swapaxes(C, 1, 2)
    Gam0 = Ct @ Rinv @ C
    Gam = Gam0 - th * (np.swapaxes(Lw, 1, 2) @ S @ Lw)
    return solve_grid(A, Gam0, Gam, W, n_inner)


def observer_rows(models, P, ok, R, fallback) -> np.ndarray:
    """``lpv`` table rows ``[F, G, H, D, J]`` of the steady-state filters of a grid.

    Parameters
    ----------
    models : tuple of arrays ``(A, B, C, Dy, Lw)``
        The design model of each grid point stacked (as :func:`grid_solutions`).
    P, ok : (g, n, n) and (g,) arrays
        The grid's Riccati solutions and which are accepted (:func:`grid_solutions`).
    R : (p, p) array
        Measurement-noise density.
    fallback : callable
        ``fallback(k) -> (F, G, H, D)``: the per-point design of point ``k``, for the points the
        grid solver does not accept (it raises where no stabilising solution exists).

    Returns
    -------
    (g, k) array
        ``F = A - K C``, ``G = B + K Dy``, ``H = Lw``, ``D = 0``, ``J = -F^{-1} G``, with
        ``K = P C^T R^{-1}``, flattened row by row.
    """
    A, B, C, Dy, Lw = models
    g = A.shape[0]
    Rinv = np.linalg.inv(np.atleast_2d(np.asarray(R, dtype=float)))
    Ct = np.swapaxes(C, 1, 2)
    bad = np.flatnonzero(~ok)
    own = [fallback(int(k)) for k in bad]       # in grid order: the first unsolvable point raises
    K = P @ Ct @ Rinv
    F = A - K @ C
    G = B + K @ Dy
    H = Lw.copy()
    D = np.zeros((g, 1, B.shape[2]))
    for k, rows in zip(bad, own):
        F[k], G[k], H[k], D[k] = rows
    J = -np.linalg.solve(F, G)
    return np.ascontiguousarray(np.hstack([F.reshape(g, -1), G.reshape(g, -1), H.reshape(g, -1),
                                           D.reshape(g, -1), J.reshape(g, -1)]))

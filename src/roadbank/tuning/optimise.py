"""Tune estimator options on a training set with scipy's differential evolution.

The optimiser (``scipy.optimize.differential_evolution``, seeded, so a run is deterministic
for a seed) varies a :class:`~.spaces.SearchSpace` and minimises
:func:`~.objective.objective_value` over the *training* drives only. Its population is
evaluated in parallel by a mapper: local worker processes (:class:`LocalMapper`, forked so
they inherit the training set) or a Dask cluster (:class:`DaskMapper`, the set is sent to
every worker once). A design without a stabilising Riccati solution
(:class:`~roadbank.estimators.NoStabilisingSolution`, e.g. ``th`` too large for ``Q``) or
any invalid option is infeasible: it scores :data:`INFEASIBLE`. At the optimum the roll
model of the roll separation (``roll``, :data:`ROLL_CHOICES`) is chosen on the training set.

The search designs the gain schedules on a coarse grid (:data:`SEARCH_V_STEP`, the whole
speed range, so a weight without a stabilising solution at some speed is infeasible there
too), about 8x cheaper than the full 0.25 m/s grid; the optimum is then designed and scored
on the full grid, which is what is reported and used. Should the full grid find a speed
without a stabilising solution between the coarse grid's points, the optimum is moved
halfway back towards the (feasible) start until it is feasible.
"""

from __future__ import annotations

import math
import multiprocessing
import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import differential_evolution

from .. import estimators
from ..campaign.execute import open_client
from ..params import VehicleParams
from .objective import SetScores, drive_errors, objective_value, score_set
from .spaces import SearchSpace

#: objective of an infeasible point (deg): worse than any feasible one
INFEASIBLE = 1e3
#: speed-grid spacing (m/s) of the designs during the search
SEARCH_V_STEP = 2.0
#: roll models tried at the optimum (the estimators' ``roll`` option)
ROLL_CHOICES = ("static", "dynamic")
#: smallest population of scipy's differential evolution (members), hence the smallest budget
MIN_POPULATION = 5

#: drive sets by key, in every process that evaluates objectives (see the module docstring)
_DRIVES: dict = {}


def register_drives(key: str, drives) -> None:
    """Make ``drives`` available to :class:`Objective` under ``key`` in this process."""
    _DRIVES[key] = drives


@dataclass(frozen=True)
class Objective:
    """``x -> J`` (deg) of estimator options ``space.options(x)`` on the drives registered
    under ``key``; picklable (holds the key, not the drives)."""

    space: SearchSpace
    params: VehicleParams | None
    key: str
    grid: tuple = ()

    def __call__(self, x) -> float:
        try:
            est = estimators.make(self.space.name, self.params, **self.space.options(x), **dict(self.grid))
        except (estimators.NoStabilisingSolution, ValueError, np.linalg.LinAlgError):
            return INFEASIBLE
        rms, mx = drive_errors(est, _DRIVES[self.key])
        value = objective_value(rms, mx)
        return value if math.isfinite(value) else INFEASIBLE


class LocalMapper:
    """``map`` over ``jobs`` forked worker processes (1: in this process). Use as a context
    manager, after :func:`register_drives` (the workers inherit the registry)."""

    def __init__(self, jobs: int = 2, progress=None):
        self.jobs = max(1, int(jobs))
        self.progress = progress
        self._pool = None

    def __enter__(self):
        if self.jobs > 1:
            self._pool = multiprocessing.get_context("fork").Pool(self.jobs)
        return self

    def __exit__(self, *exc):
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None

    def __call__(self, func, iterable):
        items = list(iterable)
        out = self._pool.map(func, items, chunksize=1) if self._pool is not None else [func(x) for x in items]
        if self.progress is not None:
            self.progress(len(items))
        return out


class DaskMapper:
    """``map`` on the Dask scheduler at ``address``; :meth:`share` sends a drive set to
    every worker once."""

    def __init__(self, address: str, progress=None, timeout: float = 20.0):
        self.client, _ = open_client(address, 1, timeout)   # DaskMissing / ConnectionError with a clear message
        self.progress = progress

    def share(self, key: str, drives) -> None:
        self.client.run(register_drives, key, drives)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.client.close()

    def __call__(self, func, iterable):
        items = list(iterable)
        out = self.client.gather(self.client.map(func, items, pure=False))
        if self.progress is not None:
            self.progress(len(items))
        return out


@dataclass
class TuneResult:
    """Outcome of :func:`tune_estimator`.

    Attributes
    ----------
    name : str
    options : dict
        The tuned keyword options of :func:`roadbank.estimators.make`.
    x : ndarray
        The optimum in the search space's coordinates.
    train : SetScores
        Scores of the tuned options on the training set.
    start_objective : float
        Objective of the starting point (the current default), deg.
    evaluations : int
        Objective evaluations of the search, the start point included: at most the budget. The
        optimum's scoring on the full grid with each roll model (:data:`ROLL_CHOICES`) comes on top.
    seconds : float
    """

    name: str
    options: dict
    x: np.ndarray
    train: SetScores
    start_objective: float
    evaluations: int
    seconds: float


def _feasible_design(space: SearchSpace, params, x, x0, tries: int = 12):
    """``x`` if its full-grid design exists, else ``x`` moved halfway back towards ``x0``
    (repeatedly) until the full grid has a stabilising solution everywhere."""
    for _ in range(tries):
        try:
            estimators.make(space.name, params, **space.options(x))
            return x
        except estimators.NoStabilisingSolution:
            x = x0 + 0.5 * (x - x0)
    return x0


def population_plan(budget: int, ndim: int) -> tuple[int, int]:
    """``(popsize, maxiter)`` of differential evolution for at most ``budget`` evaluations (counts).

    The population has ``max(5, popsize * ndim)`` members (``6 * ndim``, at least 8, when the
    budget allows); it is evaluated once at the start (the start point is one of its members) and
    once per generation, so the evaluations are ``members * (maxiter + 1)``, at most ``budget``.
    A budget below the smallest population (``max(5, ndim)``) raises ValueError.
    """
    smallest = max(MIN_POPULATION, ndim)
    if budget < smallest:
        raise ValueError(f"budget must be >= {smallest} evaluations (the smallest population of differential "
                         f"evolution over {ndim} weights), got {budget}")
    popsize = max(1, min(max(8, 6 * ndim), budget) // ndim)
    pop = max(MIN_POPULATION, popsize * ndim)
    return popsize, budget // pop - 1


def tune_estimator(space: SearchSpace, params, key: str, *, budget: int, seed: int = 0,
                   mapper=map, x0=None) -> TuneResult:
    """Minimise the training objective of ``space`` on the drives registered under ``key``.

    Parameters
    ----------
    space : SearchSpace
    params : VehicleParams
        Design parameters of the estimator.
    key : str
        Key of the training drives (:func:`register_drives`, in every worker).
    budget : int
        At most this many objective evaluations, the start point included (:func:`population_plan`).
    seed : int
        Seed of the optimiser.
    mapper : callable ``(func, iterable) -> list``
        Evaluates a population (e.g. :class:`LocalMapper`).
    x0 : sequence, optional
        Starting point (default ``space.start()``, the current default); a member of the
        first population, and the result if nothing better is found.
    """
    t0 = time.perf_counter()
    objective = Objective(space, params, key, (("v_step", SEARCH_V_STEP),))
    x0 = space.start() if x0 is None else np.clip(np.asarray(x0, float), *np.array(space.bounds).T)
    popsize, maxiter = population_plan(budget, len(x0))
    n_evals = [0]
    start = [math.nan]   # the start point's objective, read off the first population (x0 is a member)

    def counted(func, iterable):
        items = list(iterable)
        out = list(mapper(func, items))
        if n_evals[0] == 0:
            at_x0 = [v for xi, v in zip(items, out) if np.allclose(xi, x0, rtol=1e-9, atol=1e-12)]
            start[0] = at_x0[0] if at_x0 else math.nan
        n_evals[0] += len(items)
        return out

    res = differential_evolution(objective, space.bounds, seed=seed, popsize=popsize, maxiter=maxiter,
                                 tol=0.0, atol=0.0, polish=False, init="latinhypercube", x0=x0,
                                 updating="deferred", workers=counted)
    start_value = start[0]
    if math.isnan(start_value):  # not met in the population (scipy puts x0 there): evaluated on its own
        start_value = objective(x0)
        n_evals[0] += 1
    x = np.asarray(res.x) if res.fun <= start_value else x0
    x = _feasible_design(space, params, x, x0)
    # the roll model that separates body roll from theta (a choice, not a weight): keep the
    # better one on the training set
    best = None
    for roll in ROLL_CHOICES:
        options = {**space.options(x), "roll": roll}
        scores = score_set(estimators.make(space.name, params, **options), _DRIVES[key])
        if best is None or scores.objective < best[1].objective:
            best = (options, scores)
    # ROLL_CHOICES is not empty: best is set
    return TuneResult(space.name, best[0], x, best[1], start_value,  # type: ignore[index]
                      n_evals[0], time.perf_counter() - t0)

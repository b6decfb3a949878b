"""Reproduce the paper's simulation study: every estimator on every scenario x condition.

Pipeline: :func:`roadbank.sim.run_scenario` -> :func:`roadbank.evaluation.evaluate`
-> tables (:mod:`.tables`), figures (:mod:`.figures`) and the report
(:mod:`.document`). Cells run in parallel processes (``jobs``).
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import estimators
from ..evaluation import evaluate
from ..sim import CONDITIONS_BY_SCENARIO, run_scenario
from ..vehicle import tuning_of
from .document import write_report
from .tables import write_tables


@dataclass
class CellResult:
    """One scenario x condition: time base, driver inputs, reference bank and estimates (rad)."""

    scenario: str
    condition: str
    t: np.ndarray
    inputs: dict
    reference: np.ndarray
    phi_b: dict
    theta: dict
    rows: list
    seconds: float = 0.0


@dataclass
class Study:
    """All cells of a reproduction run, with the tidy metric rows."""

    cells: dict = field(default_factory=dict)     # (scenario, condition) -> CellResult
    rows: list = field(default_factory=list)
    wall_s: float = 0.0
    vehicle: str = "suv-paper"                    # the car simulated and designed for

    def by_scenario(self) -> dict:
        out: dict = {}
        for (sc, cond), cell in self.cells.items():
            out.setdefault(sc, {})[cond] = cell
        return out


def plan(scenarios=None) -> list[tuple[str, str]]:
    """The paper's (scenario, condition) cells (docs/simulator.md, Scenarios and conditions),
    optionally restricted to ``scenarios``."""
    names = list(CONDITIONS_BY_SCENARIO) if not scenarios else list(scenarios)
    unknown = [s for s in names if s not in CONDITIONS_BY_SCENARIO]
    if unknown:
        raise ValueError(f"unknown scenario(s) {unknown}; choose from {list(CONDITIONS_BY_SCENARIO)}")
    return [(s, c) for s in names for c in CONDITIONS_BY_SCENARIO[s]]


#: every column of a full study, in report order: the estimators, with ``pif-paper`` (the
#: modified-model PIF with the paper's Table 4, with which the paper's claims are checked)
#: before ``pif-modified`` (roadbank's default tuning). Each column is ``estimators.make(name)``,
#: the filter and tuning ``roadbank estimate -e name`` runs (which also sets the default-tuned
#: PIFs' noise weights from the log: :func:`roadbank.vehicle.for_log`).
COLUMNS = tuple(n for name in estimators.NAMES
                for n in (("pif-paper", name) if name == "pif-modified" else (name,)))


def check_estimators(names) -> None:
    """Raise ValueError naming any of ``names`` that is not an estimator or study column."""
    unknown = [n for n in names if n not in COLUMNS]
    if unknown:
        raise ValueError(f"unknown estimator(s) {unknown}; choose from {list(COLUMNS)}")


def _evaluate_columns(sim, names, settle: float, vehicle=None):
    """:func:`evaluate` for the study columns ``names``, each ``estimators.make(name)``.

    With a ``vehicle`` (:class:`roadbank.vehicle.Vehicle`) every estimator is designed for
    its parameters and its ``[tuning]`` tables apply as ``roadbank estimate`` reads them
    (:func:`roadbank.vehicle.tuning_of`: the column of that name, under it the table of the filter it runs,
    ``[tuning.pif-modified]`` for ``pif-gated``, ``pif-smoother`` and ``kinematic-pif``; ``pif-paper`` has none: it is
    Table 4 as published).
    """
    params = vehicle.params if vehicle is not None else None
    car_tuning = {name: tuning_of(vehicle.tuning, name) for name in names} if vehicle is not None else {}
    return evaluate(sim, list(names), params, settle=settle, tuning=car_tuning)


def run_cell(scenario: str, condition: str, names=COLUMNS, seed: int = 0,
             settle: float = 2.0, vehicle=None) -> CellResult:
    """Simulate one cell and evaluate the study columns ``names`` on it.

    ``vehicle`` (a :class:`roadbank.vehicle.Vehicle`, default the paper's SUV) is both the
    simulated car (plant and sensors) and the one the estimators are designed for.
    """
    t0 = time.perf_counter()
    if vehicle is None:
        sim = run_scenario(scenario, condition, seed=seed)
    else:
        sim = vehicle.simulate(scenario, condition, seed=seed)
    ev = _evaluate_columns(sim, list(names), settle, vehicle)
    tr = sim.truth
    inputs = {"steering_wheel_angle": tr.steering_wheel_angle, "vx": tr.vx, "throttle": tr.throttle}
    return CellResult(scenario, condition, sim.signals.t, inputs, ev.references["bank"],
                      {n: e.phi_b for n, e in ev.estimates.items()},
                      {n: e.theta for n, e in ev.estimates.items()}, ev.rows,
                      time.perf_counter() - t0)


def run_study(scenarios=None, names=COLUMNS, *, jobs: int | None = None, seed: int = 0,
              progress=None, vehicle=None) -> Study:
    """Run every cell (in ``jobs`` processes; default: all cores) and collect the results.

    ``progress`` is an optional callable invoked with each finished :class:`CellResult`;
    ``vehicle`` the car simulated and designed for (see :func:`run_cell`; default the paper SUV).
    """
    cells = plan(scenarios)
    check_estimators(names)
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(cells)))
    study = Study(vehicle=vehicle.name if vehicle is not None else "suv-paper")
    t0 = time.perf_counter()
    # The first cell runs here: it compiles/loads the numba kernels and designs the
    # estimators' gain schedules once, and forked workers inherit both (without this
    # warm-up each worker paid them again: 24 s instead of 7 s on 2 cores).
    _collect(study, run_cell(*cells[0], names, seed, vehicle=vehicle), progress)
    rest = cells[1:]
    if jobs == 1 or not rest:
        for s, c in rest:
            _collect(study, run_cell(s, c, names, seed, vehicle=vehicle), progress)
    else:
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            futures = [pool.submit(run_cell, s, c, tuple(names), seed, vehicle=vehicle) for s, c in rest]
            # while the workers run: load matplotlib here once, so that the figure
            # workers forked later (write_outputs) inherit it instead of each importing it
            from . import figures  # noqa: F401
            for fut in as_completed(futures):
                _collect(study, fut.result(), progress)
    study.cells = {k: study.cells[k] for k in cells}          # plan order
    study.rows = [r for k in cells for r in study.cells[k].rows]
    study.wall_s = time.perf_counter() - t0
    return study


def _collect(study: Study, res: CellResult, progress) -> None:
    study.cells[(res.scenario, res.condition)] = res
    if progress is not None:
        progress(res)


def _figure_tasks(by_sc: dict, figdir: Path, names=None) -> list[tuple]:
    """``(key, kind, scenario, cells, path, names)`` of every figure, the most work (lines) first."""
    from .figures import ROBUSTNESS_CONDITIONS
    tasks = []
    for sc, cells in by_sc.items():
        tasks.append((sc, "scenario", sc, cells, figdir / sc, names))
        rob = {c: cells[c] for c in ROBUSTNESS_CONDITIONS if c in cells}
        if len(rob) >= 2:
            tasks.append((f"{sc}-cf-robustness", "robustness", sc, rob, figdir / f"{sc}-cf-robustness", None))
    return sorted(tasks, key=lambda t: -sum(len(c.t) * (1 + len(c.phi_b)) for c in t[3].values()))


def _draw(kind: str, sc: str, cells: dict, path: Path, names=None):
    from .figures import FIGURE_SET, robustness_figure, scenario_figure
    if kind == "robustness":
        return robustness_figure(sc, cells, path)
    return scenario_figure(sc, cells, path, names=FIGURE_SET if names is None else names)


def write_outputs(study: Study, outdir: Path, *, docs_results: Path | None = None,
                  jobs: int | None = 1, figure_names=None, started: float | None = None) -> dict:
    """Write tables, figures (scenarios in ``jobs`` processes) and the report into ``outdir``.

    ``figure_names`` are the estimators the scenario figures draw (default
    :data:`roadbank.report.figures.FIGURE_SET`, those the study has); ``started`` the
    ``time.perf_counter()`` at the start of the command, for the wall time the report states
    (default: the cells' time only).
    Returns the written paths by kind: ``tables``, ``figures`` (name -> paths), ``report``.
    """
    outdir = Path(outdir)
    figdir = outdir / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    by_sc = study.by_scenario()
    tasks = _figure_tasks(by_sc, figdir, None if figure_names is None else tuple(figure_names))
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(tasks)))
    drawn: dict = {}
    written: dict[str, Any]
    if jobs == 1:
        written = {"tables": write_tables(study.rows, outdir)}
        for key, *args in tasks:
            drawn[key] = _draw(*args)
    else:       # one task per figure, the longest first, so that the workers finish together
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            futures = {key: pool.submit(_draw, *args) for key, *args in tasks}
            written = {"tables": write_tables(study.rows, outdir)}
            drawn = {key: fut.result() for key, fut in futures.items()}
    # report order: each scenario, then its robustness panel
    order = [k for sc in by_sc for k in (sc, f"{sc}-cf-robustness")]
    figs = {k: drawn[k] for k in order if drawn.get(k)}
    written["figures"] = figs
    wall = None if started is None else time.perf_counter() - started
    written["report"] = write_report(study, outdir, figs, docs_results=docs_results, command_s=wall)
    return written

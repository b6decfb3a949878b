"""Tune a car's estimators end to end: draw the sets, optimise on training, score on validation.

:func:`tune_car` is what ``roadbank tune`` runs. The validation set is drawn and scored only
after every optimisation has finished; the optimiser never sees it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from .. import estimators
from ..estimators.pif import SENSOR_R_ESTIMATORS
from ..params import VehicleParams
from ..sim import PlantParams, SensorConfig
from ..sim.scenarios import LOST_CONTROL_DEG
from .manoeuvres import drive_set
from .objective import score_set
from .optimise import DaskMapper, LocalMapper, population_plan, register_drives, tune_estimator
from .spaces import TUNABLE, search_space

#: default objective evaluations per estimator, the start point included (``roadbank tune --budget``)
DEFAULT_BUDGET = 240
#: default sizes of the sets (drives of 20 s)
DEFAULT_TRAIN = 48
DEFAULT_VALIDATION = 40


@dataclass
class TuningOutcome:
    """What :func:`tune_car` found.

    Attributes
    ----------
    options : dict
        Estimator -> tuned keyword options, as written to the vehicle file (:func:`written_options`).
    scores : dict
        Estimator -> flat scores (``train_*``, ``validation_*``, ``before_validation_*`` in deg,
        ``evaluations``, ``budget``, ``seed``, ``seconds``) as written to ``[scores.<name>]``.
    validation : dict
        Every estimator compared (tuned ones with their new options, others with their
        defaults, ``pif-modified (Table 4)``) -> :class:`~.objective.SetScores` on validation.
    seconds : float
        Wall time of the whole run.
    left_out : dict
        ``{"train": k, "validation": m}``: drives left out of both sets because the simulated car lost control
        (:attr:`~.manoeuvres.Drive.lost_control`; a car that oversteers with the drawn tyres), whose errors say
        nothing of an estimator and had driven the objective.
    """

    options: dict = field(default_factory=dict)
    scores: dict = field(default_factory=dict)
    validation: dict = field(default_factory=dict)
    seconds: float = 0.0
    left_out: dict = field(default_factory=dict)


def written_options(name: str, options: dict) -> dict:
    """The tuned ``options`` as written to ``[tuning.<name>]``: without ``R`` and ``Q_ay`` for the
    PIFs whose noise densities are the car's sensors' (:data:`roadbank.estimators.pif.SENSOR_R_ESTIMATORS`;
    the search holds them at the sensors' densities, and :meth:`roadbank.vehicle.Vehicle.make`
    supplies them again for each log), the others unchanged."""
    if name in SENSOR_R_ESTIMATORS:
        return {k: v for k, v in options.items() if k not in ("R", "Q_ay")}
    return dict(options)


def _in_control(drives: list, kind: str, out: "TuningOutcome") -> list:
    """The ``drives`` on which the car kept control; how many were left out recorded in ``out.left_out``. A
    ValueError when none is left (the car is not drivable as described)."""
    kept = [d for d in drives if not d.lost_control]
    out.left_out[kind] = len(drives) - len(kept)
    if not kept:
        raise ValueError(f"the car lost control (sideslip above {LOST_CONTROL_DEG:g} deg) on every {kind} drive: "
                         "check its tyres and geometry (an understeer gradient below 0 spins)")
    return kept


def tune_car(params=None, plant=None, sensors=None, *, names=TUNABLE, budget: int = DEFAULT_BUDGET,
             seed: int = 0, n_train: int = DEFAULT_TRAIN, n_validation: int = DEFAULT_VALIDATION,
             jobs: int = 2, scheduler: str | None = None, current: dict | None = None,
             compare=("kinematic", "uio", "pio-original", "pif-original"), progress=None) -> TuningOutcome:
    """Tune ``names`` for one car and score them on the validation set.

    Parameters
    ----------
    params : VehicleParams
        The car's design parameters (default: the paper's SUV).
    plant : roadbank.sim.PlantParams, optional
        The car in the simulator (default built from ``params``).
    sensors : roadbank.sim.SensorConfig, optional
        Its sensors (default the paper's ESP sensors).
    names : estimators to tune (:data:`~.spaces.TUNABLE`).
    budget : int
        Objective evaluations per estimator, at most (the start point included; at least 5).
    seed : int
        Seed of the sets and the optimiser: the same seed gives the same result.
    n_train, n_validation : int
        Drives in the training / validation set.
    jobs : int
        Local worker processes (ignored with ``scheduler``).
    scheduler : str, optional
        Dask scheduler address: evaluate the populations there.
    current : dict, optional
        Estimator -> options in use before (e.g. the vehicle file's); scored on validation as
        ``before_validation_*``.
    compare : estimators scored on validation with their defaults, for the comparison.
    progress : callable ``(stage: str, done: int, total: int)``, optional
    """
    t0 = time.perf_counter()
    params = params or VehicleParams()
    plant = plant or PlantParams(vehicle=params)
    sensors = sensors or SensorConfig()
    current = current or {}
    for name in names:
        # unknown / untunable names and a budget below the smallest population fail before any work
        population_plan(budget, len(search_space(name).start()))
    report = progress or (lambda stage, done, total: None)

    total = budget * len(names)
    done = [0]

    def step(n):
        done[0] += n
        report("tuning", min(done[0], total), total)

    out = TuningOutcome()
    results = {}
    # a DaskMapper connects when made, so an unreachable scheduler fails before the training set is
    # drawn; a LocalMapper forks on entering, after register_drives (its workers inherit the drives)
    mapper = DaskMapper(scheduler, step) if scheduler else LocalMapper(jobs, step)
    report("training set", 0, n_train)
    train = _in_control(drive_set("train", n_train, seed, params, plant, sensors), "train", out)
    key = f"train-{seed}-{n_train}"
    register_drives(key, train)
    with mapper:
        if scheduler:
            mapper.share(key, train)  # type: ignore[union-attr]  # a scheduler: a DaskMapper
        for name in names:
            results[name] = tune_estimator(search_space(name, sensors), params, key, budget=budget,
                                           seed=seed, mapper=mapper)
    report("validation set", 0, n_validation)
    valid = _in_control(drive_set("validation", n_validation, seed, params, plant, sensors), "validation", out)
    for name, res in results.items():
        tuned = score_set(estimators.make(name, params, **res.options), valid)
        before = score_set(estimators.make(name, params, **current.get(name, {})), valid)
        out.options[name] = written_options(name, res.options)
        out.validation[name] = tuned
        out.scores[name] = {**res.train.as_dict("train_"), **tuned.as_dict("validation_"),
                            **{k: v for k, v in before.as_dict("before_validation_").items()
                               if not k.endswith("drives")},
                            "evaluations": res.evaluations, "budget": int(budget), "seed": int(seed),
                            "seconds": round(res.seconds, 1)}
    for name in compare:
        out.validation[name] = score_set(estimators.make(name, params), valid)
    if "pif-modified" in names:
        out.validation["pif-modified (Table 4)"] = score_set(
            estimators.make("pif-modified", params, tuning="paper"), valid)
        out.scores["pif-modified"].update(
            {k: v for k, v in out.validation["pif-modified (Table 4)"].as_dict("table4_validation_").items()
             if not k.endswith("drives")})
    out.seconds = time.perf_counter() - t0
    return out

"""The simulated validation set with the car known and with the car not described (``roadbank validate sim``).

For each shipped car (:data:`roadbank.tuning.real.SIM_CARS`) the drives are ``roadbank tune``'s
*validation* set (:func:`roadbank.tuning.drive_set`, the car's design parameters; road families,
plant perturbations and the car changes training never sees: :mod:`roadbank.tuning.manoeuvres`).
Every estimator is built for each drive's log as the command line builds it
(:func:`roadbank.vehicle.for_log`), in two modes (:data:`MODES`):

* ``"known"``: for the car, ``for_log(name, signals, vehicle=load_vehicle(car))`` (``--vehicle``);
* ``"undescribed"``: ``for_log(name, signals)``, what ``roadbank estimate`` builds with no car
  (:func:`roadbank.vehicle.undescribed_params`).

A drive's error is its bank RMS error (deg) as ``roadbank tune`` scores it
(:func:`roadbank.tuning.objective.drive_errors`). Summaries: the median and the 95th percentile
(numpy's default, linear interpolation) per car and pooled over the drives of every car.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import estimators
from ..evaluation.targets import Target
from ..vehicle import load_vehicle
from .manoeuvres import PERTURBATIONS, VALIDATION_CAR_CHANGES, drive_set
from .objective import drive_errors
from .pipeline import DEFAULT_VALIDATION
from .real import SIM_CARS, per_log

#: how the estimator is built: for the drive's car, or for a car nobody described
MODES = ("known", "undescribed")
#: the targets of the default estimator with the car known (deg): median and 95th percentile
#: of the per-drive bank RMS error, per car and pooled
TARGET_MEDIAN_DEG = 0.30
TARGET_P95_DEG = 0.65
#: the set the targets were first stated on: ``roadbank tune``'s validation set (seed 0) of the paper's SUV
TARGET_CAR = "suv-paper"
TARGET_DRIVES = DEFAULT_VALIDATION
#: the groups of plant perturbations (:data:`roadbank.tuning.manoeuvres.PERTURBATIONS`) that :func:`error_sources`
#: holds at the design value, by label
ERROR_SOURCES = {"the roll stiffness": ("roll-stiffness",),
                 "the tyre stiffnesses (Cf, Cr)": ("front-stiffness", "rear-stiffness"),
                 "the changes only validation draws (tyre shape, yaw inertia, roll stiffness)": VALIDATION_CAR_CHANGES,
                 "every perturbation": tuple(PERTURBATIONS)}
#: the estimators ``roadbank validate sim`` scores when none are named
DEFAULT_NAMES = ("kinematic-pif", "kinematic-lp", "pif-modified", "pif-adaptive", "pif-gated", "pif-smoother",
                 "kinematic-smoother")


@dataclass(frozen=True)
class Summary:
    """Median and 95th percentile (deg) of ``n`` per-drive bank RMS errors."""

    median_deg: float
    p95_deg: float
    n: int

    @property
    def meets_target(self) -> bool:
        """Median <= :data:`TARGET_MEDIAN_DEG` and p95 <= :data:`TARGET_P95_DEG`."""
        return self.median_deg <= TARGET_MEDIAN_DEG and self.p95_deg <= TARGET_P95_DEG


def summarise(errors) -> Summary:
    """:class:`Summary` of per-drive errors (deg): ``numpy.median`` and ``numpy.percentile(.., 95)``."""
    e = np.asarray(errors, dtype=float)
    return Summary(float(np.median(e)), float(np.percentile(e, 95)), int(e.size))


@dataclass(frozen=True)
class SimulatedScores:
    """Per-drive errors of :func:`score_simulated`.

    Attributes
    ----------
    names : tuple of str
        Estimator names, in the order given.
    cars : tuple of str
        Shipped cars (plant and, in mode ``"known"``, design car).
    n, seed : int
        Drives per car and the set's seed.
    roads : dict
        ``{car: (road family of drive 0, 1, ...)}``.
    errors : dict
        ``{(name, mode, car): ndarray}``: bank RMS error (deg) of each drive of ``roads[car]``.
    """

    names: tuple[str, ...]
    cars: tuple[str, ...]
    n: int
    seed: int
    roads: dict
    errors: dict

    def pooled(self, name: str, mode: str) -> np.ndarray:
        """Errors (deg) of ``name`` in ``mode`` over the drives of every car (cars in order)."""
        return np.concatenate([self.errors[(name, mode, car)] for car in self.cars])

    def summary(self, name: str, mode: str, car: str | None = None) -> Summary:
        """:class:`Summary` of ``name`` in ``mode`` on ``car`` (``None``: pooled over every car)."""
        return summarise(self.pooled(name, mode) if car is None else self.errors[(name, mode, car)])

    def families(self) -> tuple[str, ...]:
        """The road families of the drives, in order of first appearance."""
        return tuple(dict.fromkeys(r for car in self.cars for r in self.roads[car]))

    def family_median(self, name: str, mode: str, road: str) -> float:
        """Median error (deg) of ``name`` in ``mode`` over the drives of family ``road`` of every car."""
        roads = np.concatenate([np.asarray(self.roads[car]) for car in self.cars])
        return float(np.median(self.pooled(name, mode)[roads == road]))


def score_simulated(names, cars=SIM_CARS, n: int = DEFAULT_VALIDATION, seed: int = 0) -> SimulatedScores:
    """Score the estimators ``names`` on the simulated validation set of each car of ``cars``
    (module docstring), ``n`` drives per car drawn with ``seed``; errors in deg.

    Raises
    ------
    ValueError
        An unknown estimator or car name, or ``n < 1``.
    """
    names = tuple(names)
    bad = [nm for nm in names if nm not in estimators.NAMES]
    if bad:
        raise ValueError(f"unknown estimator(s) {bad}")
    roads, errors = {}, {}
    for car in cars:
        v = load_vehicle(car)
        drives = drive_set("validation", n, seed, v.params)
        roads[car] = tuple(d.road for d in drives)
        for nm in names:
            builds = {"known": per_log(nm, vehicle=v), "undescribed": per_log(nm, described=False)}
            for mode in MODES:
                errors[(nm, mode, car)] = np.array([drive_errors(builds[mode](d.signals), [d])[0][0]
                                                    for d in drives])
    return SimulatedScores(names, tuple(cars), int(n), int(seed), roads, errors)


def error_sources(name: str = estimators.DEFAULT, cars=SIM_CARS, n: int = DEFAULT_VALIDATION, seed: int = 0,
                  groups=None) -> dict:
    """What the error of ``name`` with the car known owes to the plant's perturbations: the validation set of
    :func:`score_simulated` (the same drives: roads, drivers, noise) with each group of ``groups`` (label -> names of
    :data:`~roadbank.tuning.manoeuvres.PERTURBATIONS`; default :data:`ERROR_SOURCES`) held at the design value.
    Returns ``{label: Summary}`` of the per-drive bank RMS error (deg) pooled over ``cars``."""
    out = {}
    for label, nominal in (ERROR_SOURCES if groups is None else groups).items():
        errs = []
        for car in cars:
            v = load_vehicle(car)
            build = per_log(name, vehicle=v)
            errs += [drive_errors(build(d.signals), [d])[0][0]
                     for d in drive_set("validation", n, seed, v.params, nominal=nominal)]
        out[label] = summarise(errs)
    return out


def _summary_json(s: Summary) -> dict:
    return {"median_deg": s.median_deg, "p95_deg": s.p95_deg, "n": s.n}


def to_json(scores: SimulatedScores, sources: dict | None = None) -> dict:
    """The summaries of ``scores`` as plain data (deg): per estimator and mode, ``"cars"`` (each
    car), ``"all"`` (pooled) and ``"families"`` (median per road family, pooled over the cars);
    the targets and the default estimator; with ``sources`` (:func:`error_sources` of the default) its
    ``"error_sources"`` (label -> pooled summary)."""
    out: dict = {"n": scores.n, "seed": scores.seed, "cars": list(scores.cars), "default": estimators.DEFAULT,
                 "targets": {"median_deg": TARGET_MEDIAN_DEG, "p95_deg": TARGET_P95_DEG}, "estimators": {}}
    for nm in scores.names:
        entry: dict = {"offline": nm in estimators.OFFLINE}
        for mode in MODES:
            entry[mode] = {"cars": {car: _summary_json(scores.summary(nm, mode, car)) for car in scores.cars},
                           "all": _summary_json(scores.summary(nm, mode)),
                           "families": {r: scores.family_median(nm, mode, r) for r in scores.families()}}
        out["estimators"][nm] = entry
    if sources:
        out["error_sources"] = {label: _summary_json(s) for label, s in sources.items()}
    return out


def sim_targets(scores: SimulatedScores, name: str = estimators.DEFAULT) -> list[Target]:
    """The simulated targets of ``name`` with the car known (:class:`~roadbank.evaluation.targets.Target`): on the set
    they were first stated on (:data:`TARGET_CAR`, its first :data:`TARGET_DRIVES` drives of seed 0: only where
    ``scores`` holds them) and over every car of ``scores`` pooled; none where ``scores`` lacks ``name``."""
    if name not in scores.names:
        return []
    aim = f"car known: median <= {TARGET_MEDIAN_DEG:.2f}, p95 <= {TARGET_P95_DEG:.2f} deg"
    pooled = scores.summary(name, "known")
    out = [Target(f"simulated validation set, {len(scores.cars)} shipped cars pooled ({pooled.n} drives)", aim,
                  f"{pooled.median_deg:.3f} / {pooled.p95_deg:.3f} deg", pooled.meets_target)]
    if TARGET_CAR in scores.cars and scores.seed == 0 and scores.n >= TARGET_DRIVES:
        own = summarise(scores.errors[(name, "known", TARGET_CAR)][:TARGET_DRIVES])
        out.insert(0, Target(f"simulated validation set, {TARGET_CAR} ({own.n} drives, where it was stated)", aim,
                             f"{own.median_deg:.3f} / {own.p95_deg:.3f} deg", own.meets_target))
    return out

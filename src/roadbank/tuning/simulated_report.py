"""The markdown document of ``roadbank validate sim`` (docs/sim-validation.md) from
:class:`~roadbank.tuning.simulated.SimulatedScores`."""

from __future__ import annotations

import numpy as np

from .. import defaults, estimators
from .manoeuvres import DURATION, TRAIN_ROADS
from .objective import SETTLE
from ..report.tables import targets_markdown
from .simulated import (MODES, TARGET_CAR, TARGET_DRIVES, TARGET_MEDIAN_DEG, TARGET_P95_DEG, SimulatedScores,
                        Summary, sim_targets)

#: what each validation road family is (:mod:`roadbank.tuning.manoeuvres`)
ROAD_TEXT = {
    "banked-lane-weave": "weave over two lanes of different bank (-6..+20 %)",
    "hairpin": "rural hairpin, radius 25-60 m, superelevation 3-8 %",
    "reverse-curves": "highway S: curve left then right, superelevation switching sign through the transition",
    "tyre-limit-banked": "open-loop steering near the friction limit on a banked straight",
}


def _label(name: str) -> str:
    tags = (["default"] if name == estimators.DEFAULT else []) + (["offline"] if name in estimators.OFFLINE else [])
    return name + (f" ({', '.join(tags)})" if tags else "")


def _cell(s: Summary) -> str:
    return f"{s.median_deg:.3f} / {s.p95_deg:.3f}"


def _verdict(s: Summary) -> str:
    return "met" if s.meets_target else "not met"


def _intro(scores: SimulatedScores) -> list[str]:
    cars = ", ".join(f"`{c}`" for c in scores.cars)
    roads = "\n".join(f"* `{r}`: {ROAD_TEXT.get(r, 'see roadbank.tuning.manoeuvres')}" for r in scores.families())
    return [
        "## The set",
        "",
        f"For each shipped car ({cars}), {scores.n} drives of `roadbank tune`'s validation set (seed "
        f"{scores.seed}; `roadbank.tuning.drive_set(\"validation\", ...)` with the car's design parameters and the "
        f"paper's ESP sensors), {DURATION:g} s each. The road families cycle over the drives; none of them "
        f"is used in tuning (the training roads are {', '.join(f'`{r}`' for r in TRAIN_ROADS)}):",
        "",
        roads,
        "",
        "Every drive perturbs the simulated plant around the car's data sheet, while the estimators keep the "
        "design values: front cornering stiffness x U(0.5, 1.5), rear x U(0.8, 1.2), mass x U(0.8, 1.2), an "
        "accelerometer yaw misalignment U(-2, 2) deg, and what training never changes: the tyre shape "
        "(`Cy`, `Ey`), the yaw inertia x U(0.8, 1.2) and the roll stiffness x U(0.75, 1.25).",
        "",
        "## The two modes",
        "",
        "Each estimator is built for each drive's log as the command line builds it "
        "(`roadbank.vehicle.for_log`: a default-tuned PIF designed for the log's sample rate and the road noise "
        "measured on its `ay` and yaw rate):",
        "",
        "* **car known**: `for_log(name, signals, vehicle=load_vehicle(car))`, the drive's car with its "
        "parameters, sensors and `[tuning]` tables, as `roadbank estimate LOG --vehicle CAR` builds it;",
        "* **car not described**: `for_log(name, signals)`, as `roadbank estimate LOG` builds it: the data "
        "sheet's sensors and the shipped car that fits the drive (`roadbank.vehicle.design_car`: "
        f"`{defaults.VEHICLE}` unless another fits its first minute clearly better), whatever the plant's car.",
        "",
        f"A drive's score is its bank RMS error (deg) as `roadbank tune` scores it: `phi_b` estimated against "
        f"the true bank on the samples every estimator can use (finite inputs, `vx >= v_min`) after the first "
        f"{SETTLE:g} s. Summaries: the median and the 95th percentile (numpy's default, linear interpolation) "
        f"per car and pooled over the drives of every car. Offline estimators also use the samples after each "
        f"instant (post-processing, not for an ECU).",
        "",
    ]


def _same_modes(scores: SimulatedScores) -> list[str]:
    """The cars on which both modes gave the same error on every drive for every estimator."""
    return [car for car in scores.cars
            if all(np.array_equal(*(scores.errors[(nm, mode, car)] for mode in MODES)) for nm in scores.names)]


def _summary_table(scores: SimulatedScores) -> list[str]:
    same = _same_modes(scores)
    note = (f" On {', '.join(f'`{c}`' for c in same)} the two modes give the same error on every drive."
            if same else "")
    rows = ["## Summary", "",
            f"Bank RMS error per drive, median / p95 (deg).{note}", "",
            "| estimator | car | car known | car not described |", "|---|---|---:|---:|"]
    for nm in scores.names:
        for car in (*scores.cars, None):
            cells = [_cell(scores.summary(nm, mode, car)) for mode in MODES]
            rows.append(f"| {_label(nm)} | {car or 'all cars'} | {' | '.join(cells)} |")
    return rows + [""]


def _target_section(scores: SimulatedScores) -> list[str]:
    name = estimators.DEFAULT
    head = ["## Targets", "",
            f"The default estimator `{name}`, car known: median <= {TARGET_MEDIAN_DEG:.2f} deg and "
            f"p95 <= {TARGET_P95_DEG:.2f} deg of the per-drive bank RMS error. It was first stated on "
            f"`roadbank tune`'s own validation set, the paper's SUV (`{TARGET_CAR}`) with its first "
            f"{TARGET_DRIVES} drives, seed 0, where the default PIF then had 0.299 / 0.643 deg; it is checked here "
            "on each car and pooled too.", ""]
    if name not in scores.names:
        return head + [f"`{name}` was not among the estimators scored.", ""]
    rows = ["| car | median (deg) | p95 (deg) | target |", "|---|---:|---:|---|"]
    met = 0
    for car in (*scores.cars, None):
        s = scores.summary(name, "known", car)
        met += bool(car and s.meets_target)
        rows.append(f"| {car or 'all cars'} | {s.median_deg:.3f} | {s.p95_deg:.3f} | {_verdict(s)} |")
    tail = (f"Met on {met} of {len(scores.cars)} cars. With the car not described the same set gives, pooled, "
            f"{_cell(scores.summary(name, 'undescribed'))} deg (median / p95; no target).")
    return head + rows + ["", *targets_markdown(sim_targets(scores, name)), tail, ""]


def _sources_section(scores: SimulatedScores, sources: dict | None) -> list[str]:
    """Where the default's error with the car known comes from (:func:`~roadbank.tuning.simulated.error_sources`)."""
    if not sources or estimators.DEFAULT not in scores.names:
        return []
    drawn = scores.summary(estimators.DEFAULT, "known")
    rows = ["## Where the error comes from", "",
            f"The default `{estimators.DEFAULT}` with the car known on the same drives (roads, drivers, noise), with "
            "perturbations of the plant held at the car's data sheet "
            "(`roadbank.tuning.simulated.error_sources`), pooled over the cars:", "",
            "| held at the data sheet | median (deg) | p95 (deg) | target |", "|---|---:|---:|---|",
            f"| nothing (the set as drawn) | {drawn.median_deg:.3f} | {drawn.p95_deg:.3f} | {_verdict(drawn)} |"]
    rows += [f"| {label} | {s.median_deg:.3f} | {s.p95_deg:.3f} | {_verdict(s)} |" for label, s in sources.items()]
    return rows + ["", "The body's roll stiffness sets the roll that is told from the bank (`phi_b = theta - roll`); "
                   "no estimator that reads `ay`, the yaw rate and the speed can learn it, since a road banked into "
                   "the turn and a softer body look the same to them. The tyre stiffnesses are the lateral model's "
                   "error.", ""]


def _family_table(scores: SimulatedScores) -> list[str]:
    fams = scores.families()
    counts = {r: sum(r == x for car in scores.cars for x in scores.roads[car]) for r in fams}
    rows = ["## Per road family", "",
            "Median bank RMS error (deg) over the drives of each family of every car, car known / car not "
            "described:", "",
            "| estimator | " + " | ".join(f"{r} ({counts[r]} drives)" for r in fams) + " |",
            "|---|" + "---:|" * len(fams)]
    for nm in scores.names:
        cells = [" / ".join(f"{scores.family_median(nm, mode, r):.3f}" for mode in MODES) for r in fams]
        rows.append(f"| {_label(nm)} | " + " | ".join(cells) + " |")
    return rows + [""]


def markdown(scores: SimulatedScores, command: str, sources: dict | None = None) -> str:
    """The document of ``scores``; ``command`` is the command line that generated it; ``sources``: the default's
    :func:`~roadbank.tuning.simulated.error_sources` (a section where given)."""
    lines = ["# Simulated validation: the car known and the car not described", "",
             f"_Generated by `{command}`; do not edit by hand._", "",
             "The estimators below on simulated drives whose true bank is known, each built once for the "
             f"drive's car and once as for a car nobody described: {len(scores.cars)} cars x {scores.n} drives, "
             f"seed {scores.seed}.", ""]
    lines += (_intro(scores) + _target_section(scores) + _sources_section(scores, sources) + _summary_table(scores)
              + _family_table(scores))
    return "\n".join(lines)

"""The sixty-fourth, sixty-fifth and sixty-seventh stages: the map's low-pass smoother through hard manoeuvres
(docs/estimators.md).

``roadbank map``'s offline default is the kinematic estimate low-passed both ways (``kinematic-smoother``) on a loud
log, and since the sixty-third stage on a quiet log of a car nobody described too. It has no gate to a model: on the
simulator's hard manoeuvres (near the tyres' limit, lane changes) it reads the sideslip acceleration that the
kinematic estimate neglects as bank. The causal default has such a gate (the blend's PIF while the yaw accelerates).
Candidates (:data:`roadbank.vehicle.conditions.SMOOTHER_GATE`): A, ``False`` (shipped); B, ``True``: where the map
builds the low-pass smoother, its output moves to ``pif-smoother`` designed for the same log and car where an offline
gate is open (:class:`roadbank.estimators.GatedSmoother`: the causal blend's gate measure, held open both ways).

Sets (training only): (1) the eight KITTI training drives with their ESP channels as recorded (loud) and as the two
smooth roads of the sixty-second stage (quiet), 24 logs, raw RMS of theta against the INS roll on the scored samples,
the smoother as ``roadbank map`` builds it without a vehicle file; (2) each shipped car's quiet simulated training
drives of the sixty-second stage (24 on the data sheet's sensors, 48 with the ESP-class roll-rate gyro), the car not
described; (3) each car's 24 ESP training drives with :data:`~.roads.BACK_LOUD_AY` m/s^2 of white noise on ``ay``
(loud: a shaking accelerometer), built with the car's vehicle file; bank RMS as ``roadbank tune`` scores it.
Objective: the median over (1) plus the median over the cars of each car's median over (2) and (3) pooled. Tail: the
95th percentile (numpy's default) of the bank RMS over every simulated drive of (2) and (3), all cars pooled.
Rule: B ships if (a) its median over (1) is not above A's by more than :data:`GATE_REAL_LOSS_DEG`, and (b) its
objective is below A's by more than :data:`GATE_GAIN_DEG`, or its objective is not above A's by more than
:data:`GATE_REAL_LOSS_DEG` and its tail is below A's by more than :data:`GATE_TAIL_GAIN` of A's; otherwise A. Guard:
the eight training drives with their INS roll rate (the gyro-aided smoother) and each car's ESP drives built with its
vehicle file that its design reads quiet (``pif-smoother``: 95 of the 96; corrected before any score was computed, the
guard as first written having failed on the one van drive that reads loud) give the same outputs under both.

The sixty-fifth (:func:`choose_gate_speed`): the lowest speed at which the gate's measure counts. On the training drive
0034 (and, reported after the sixty-fourth stage, on the validation drive 0020) the gate opens on tight turns at 4-14
m/s (yaw rate up to 40 deg/s), where the model smoother of a car nobody described errs by 1.5-2.5 deg and the
low-pass smoother by 0.3-0.5: a tyre model is for a car at speed. Candidates :data:`GATE_SPEEDS`; the rule weighs the
real drives by their mean, since the cost is a tail over drives that a median does not see.

The sixty-seventh (:func:`choose_gate_hold`): how long the gate stays open before and after each ramp. The sixty-fourth
fixed it at the causal blend's release time constant, 8 s, without a search. The low-pass smoother it corrects
spreads a manoeuvre's sideslip acceleration over only a few of its time constants (0.5 Hz both ways: 1/(2 pi 0.5) =
0.32 s), and in a steady turn the sideslip acceleration is gone; on the training drive 0034 (and, reported after the
sixty-fifth stage, on the validation drive 0020) the 8 s reach from a turn at speed into the slow stretches around
it, where the model smoother of a car nobody described errs. Candidates :data:`GATE_HOLDS_S`; the sixty-fifth stage's
sets, scores and eligibility, ties going to the longer hold.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...estimators import PIFSmoother
from ...vehicle import load_vehicle
from .common import (BEFORE_65, BEFORE_67, BEFORE_69, SIM_CARS, cars_median, design_settings, log_errors, lowest_tied,
                     per_log, sim_errors, simulated_sets, training_logs, within)
from .esp import QUIET_GYRO_OFFSETS, gyro_sim_sets
from .roads import (BACK_LOUD_AY, STEEP_ROAD_CUTOFF_HZ, STEEP_ROAD_ORDER, _in_force, _same_in_force,
                    smooth_road_logs)

#: the rule: B's real median may be above A's by at most this (deg), and so may its objective where the tail decides
GATE_REAL_LOSS_DEG = 0.005
#: ... B ships on the objective where it is below A's by more than this (deg) ...
GATE_GAIN_DEG = 0.02
#: ... or on the tail where its simulated 95th percentile is below A's by more than this share of A's (-)
GATE_TAIL_GAIN = 0.10
#: the seed of the white ``ay`` noise of set (3)
SHAKEN_SEED = 0


def shaken_sets(sim_sets, seed: int = SHAKEN_SEED) -> list:
    """Each drive of ``sim_sets`` (per car, a list of simulated drives) with :data:`~.roads.BACK_LOUD_AY` m/s^2 of white
    noise added to ``ay`` (one numpy generator, ``seed``, in the sets' order): a shaking accelerometer."""
    rng = np.random.default_rng(seed)
    return [[dataclasses.replace(d, signals=dataclasses.replace(
        d.signals, ay=d.signals.ay + BACK_LOUD_AY * rng.standard_normal(len(d.signals)))) for d in drives]
        for drives in sim_sets]


def stage_sets(data_dir) -> tuple[list, list, list, list]:
    """The sixty-fourth and sixty-fifth stages' sets from the KITTI drives under ``data_dir``: ``(real, quiet,
    shaken, sims)``, set (1) (the eight training drives' ESP channels as recorded, as the sixtieth stage's smooth road
    and as the sixty-second's steep one), set (2) (per car, its 24 training drives and the same with the ESP-class gyro
    at each of :data:`~.esp.QUIET_GYRO_OFFSETS`), set (3) (:func:`shaken_sets` of the 24) and the 24 per car as
    drawn."""
    logs = training_logs(data_dir)
    real = logs + smooth_road_logs(logs) + smooth_road_logs(logs, STEEP_ROAD_ORDER, STEEP_ROAD_CUTOFF_HZ)
    sims = simulated_sets()
    gyro = [gyro_sim_sets(o) for o in QUIET_GYRO_OFFSETS]
    quiet = [list(sims[k]) + [d for g in gyro for d in g[k]] for k in range(len(sims))]
    return real, quiet, shaken_sets(sims), sims


def choose_smoother_gate(logs, quiet_sets, shaken, kept_logs, known_quiet, cars=SIM_CARS) -> tuple:
    """The sixty-fourth stage (module docstring): ``kinematic-smoother`` as ``roadbank map`` builds it with
    :data:`roadbank.vehicle.conditions.SMOOTHER_GATE` False (A) and True (B). ``logs``: set (1) (``(signals, reference
    roll rad, scored mask)``); ``quiet_sets``: set (2), per car of ``cars`` a list of drives; ``shaken``: set (3),
    per car (:func:`shaken_sets`); ``kept_logs`` (signals) and ``known_quiet`` (per car, drives built with its file):
    the guard. Returns ``(chosen, {choice: (objective, tail)}, {choice: (raw RMS per log, per car: bank RMS per drive
    of (2), of (3))})``; a ValueError where the guard fails."""
    as_ran = {**BEFORE_65, **BEFORE_67, **BEFORE_69}
    undescribed = within(per_log("kinematic-smoother", described=False), **as_ran)
    known = {car: within(per_log("kinematic-smoother", vehicle=load_vehicle(car)), **as_ran) for car in cars}
    setting = "smoother_gate"
    pairs = ([(undescribed, s) for s in kept_logs]
             + [(known[car], d.signals) for car, drives in zip(cars, known_quiet) for d in drives
                if isinstance(known[car](d.signals), PIFSmoother)])       # the drives its design reads quiet
    _same_in_force(setting, (False, True), pairs,
                   "a log with a usable roll rate, or a quiet one of a car described, was read otherwise: the stage's "
                   "guard fails")

    def shaken_errors():
        return [sim_errors(known[car], [drives])[0] for car, drives in zip(cars, shaken)]

    errs = {c: (_in_force(setting, c, log_errors, undescribed, logs),
                _in_force(setting, c, sim_errors, undescribed, quiet_sets),
                _in_force(setting, c, shaken_errors)) for c in (False, True)}
    scores = {}
    for c, (real, quiet, loud) in errs.items():
        pooled = [list(q) + list(s) for q, s in zip(quiet, loud)]
        scores[c] = (float(np.median(real)) + cars_median(pooled),
                     float(np.percentile(np.concatenate(pooled), 95)))
    (obj_a, tail_a), (obj_b, tail_b) = scores[False], scores[True]
    real_ok = np.median(errs[True][0]) <= np.median(errs[False][0]) + GATE_REAL_LOSS_DEG
    gains = obj_b < obj_a - GATE_GAIN_DEG or (obj_b <= obj_a + GATE_REAL_LOSS_DEG
                                              and tail_b < (1.0 - GATE_TAIL_GAIN) * tail_a)
    return bool(real_ok and gains), scores, errs




#: the sixty-fifth stage's candidates: the lowest speed (m/s) at which the offline gate's measure counts
#: (:data:`roadbank.vehicle.conditions.SMOOTHER_GATE_V_MIN`; 0, the first, as the sixty-fourth shipped)
GATE_SPEEDS = (0.0, 10.0, 15.0, 20.0)
#: its rule: a candidate is eligible where its simulated 95th percentile is not above the shipped one's by more than
#: this share (-) ...
GATE_SPEED_TAIL_LOSS = 0.10
#: ... and its median over the cars not above the shipped one's by more than this (deg)
GATE_SPEED_SIM_LOSS_DEG = 0.01


def choose_gate_speed(logs, quiet_sets, shaken, speeds=GATE_SPEEDS, cars=SIM_CARS) -> tuple:
    """The sixty-fifth stage (docs/estimators.md): ``kinematic-smoother`` as ``roadbank map`` builds it, its gate's
    measure counted only at ``vx >=`` each of ``speeds`` (m/s; :data:`~roadbank.vehicle.conditions.SMOOTHER_GATE_V_MIN`,
    the shipped first), on the sixty-fourth stage's sets (:func:`choose_smoother_gate`). Scores per candidate: the
    mean raw RMS (deg) over the real logs, the median over the cars of each car's median over its simulated drives
    (quiet and shaken pooled) and the 95th percentile over all of them. Rule: among the candidates whose simulated
    95th percentile is not above the shipped one's by more than :data:`GATE_SPEED_TAIL_LOSS` of it and whose median
    over the cars is not above the shipped one's by more than :data:`GATE_SPEED_SIM_LOSS_DEG`, the lowest real mean
    wins, ties within :data:`~.common.TIE_DEG` going to the lower speed. Returns ``(chosen, {speed: (real mean, sims
    median, sims p95)}, {speed: (raw RMS per log, per car: bank RMS per drive, quiet then shaken)})``."""
    scores, errs = _offline_gate_scores("smoother_gate_v_min", speeds, logs, quiet_sets, shaken, cars, BEFORE_67)
    return lowest_eligible(scores, speeds, GATE_SPEED_TAIL_LOSS, GATE_SPEED_SIM_LOSS_DEG), scores, errs


def _offline_gate_scores(setting: str, choices, logs, quiet_sets, shaken, cars, before: dict) -> tuple[dict, dict]:
    """The sixty-fifth and sixty-seventh stages' scores: ``kinematic-smoother`` as ``roadbank map`` builds it, with the
    design setting ``setting`` at each of ``choices`` (and the settings ``before`` throughout, as the stage ran, the car
    never trimmed to the log: :data:`~.common.BEFORE_69`), on the
    sixty-fourth stage's sets. Returns ``({choice: (real mean, sims median over the cars, sims p95)}, {choice: (raw
    RMS per log, per car: bank RMS per drive, quiet then shaken)})`` (deg)."""
    undescribed = per_log("kinematic-smoother", described=False)
    known = {car: per_log("kinematic-smoother", vehicle=load_vehicle(car)) for car in cars}

    def shaken_errors():
        return [sim_errors(known[car], [drives])[0] for car, drives in zip(cars, shaken)]

    def measure():
        real = log_errors(undescribed, logs)
        pooled = [list(q) + list(s) for q, s in zip(sim_errors(undescribed, quiet_sets), shaken_errors())]
        return real, pooled

    with design_settings(**before, **BEFORE_69):
        errs = {c: _in_force(setting, c, measure) for c in choices}
    scores = {c: (float(np.mean(real)), cars_median(pooled), float(np.percentile(np.concatenate(pooled), 95)))
              for c, (real, pooled) in errs.items()}
    return scores, errs


def lowest_eligible(scores: dict, choices, tail_loss: float, sim_loss_deg: float, order=lambda v: v) -> float:
    """The sixty-fifth to sixty-seventh stages' rule: of ``choices`` (the shipped first), those whose simulated 95th
    percentile (``scores[v][2]``, deg) is not above the shipped one's by more than ``tail_loss`` of it and whose
    simulated median (``scores[v][1]``) not above it by more than ``sim_loss_deg``; the lowest real score
    (``scores[v][0]``) of those, ties within :data:`~.common.TIE_DEG` going to the first by ``order`` (a sort key;
    default the lowest value: the lower speed)."""
    first = scores[choices[0]]
    eligible = [v for v in choices if scores[v][2] <= (1.0 + tail_loss) * first[2]
                and scores[v][1] <= first[1] + sim_loss_deg]
    return lowest_tied({v: scores[v][0] for v in eligible}, order)


#: the sixty-seventh stage's candidates: how long (s) the offline gate stays open before and after each ramp
#: (:data:`roadbank.vehicle.conditions.SMOOTHER_GATE_HOLD_S`; 8, the first, as the sixty-fourth shipped)
GATE_HOLDS_S = (8.0, 4.0, 2.0, 1.0)


def choose_gate_hold(logs, quiet_sets, shaken, holds=GATE_HOLDS_S, cars=SIM_CARS) -> tuple:
    """The sixty-seventh stage (docs/estimators.md): ``kinematic-smoother`` as ``roadbank map`` builds it, its gate
    held open ``hold`` s before and after each ramp for each of ``holds`` (s; the shipped first), on the sixty-fourth
    stage's sets (:func:`choose_smoother_gate`) with the sixty-fifth stage's scores and eligibility
    (:func:`choose_gate_speed`: :data:`GATE_SPEED_TAIL_LOSS`, :data:`GATE_SPEED_SIM_LOSS_DEG`): among the eligible
    candidates the lowest real mean wins, ties within :data:`~.common.TIE_DEG` going to the longer hold. Returns
    ``(chosen, {hold: (real mean, sims median, sims p95)}, {hold: (raw RMS per log, per car: bank RMS per drive)})``."""
    scores, errs = _offline_gate_scores("smoother_gate_hold_s", holds, logs, quiet_sets, shaken, cars, {})
    return lowest_eligible(scores, holds, GATE_SPEED_TAIL_LOSS, GATE_SPEED_SIM_LOSS_DEG, lambda h: -h), scores, errs


__all__ = ["GATE_GAIN_DEG", "GATE_REAL_LOSS_DEG", "GATE_TAIL_GAIN", "SHAKEN_SEED", "choose_smoother_gate",
           "shaken_sets", "stage_sets", "GATE_SPEEDS", "GATE_SPEED_TAIL_LOSS", "GATE_SPEED_SIM_LOSS_DEG",
           "choose_gate_speed", "lowest_eligible", "GATE_HOLDS_S", "choose_gate_hold"]

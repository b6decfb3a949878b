"""The fifty-eighth to sixty-first stages: a design decided again as a log's roads change (docs/estimators.md).

A log's design is read on its first minute of driving; a smooth first minute holds a long drive to the car's model
over rough roads. Candidates (:data:`roadbank.vehicle.conditions.ROAD_CHANGE`): A, decided once; B, a log designed
quiet handed to the design of its first loud stretch (:class:`roadbank.estimators.HandOver`). Sets: long logs of the
KITTI training drives after a smooth start (:func:`smooth_start_logs`), with the ESP channels and with the roll rate,
and long quiet simulated logs of each shipped car (:func:`long_quiet_sets`); the rule in :func:`choose_road_change`.
The fifty-ninth (:func:`choose_road_change_gyro`): the roll-rate path after a hand-over; the sixtieth
(:func:`choose_quiet_ins`): a quiet log with an INS's roll rate; the sixty-first (:func:`choose_road_change_back`): a
loud design handed back to the car's model where the roads turn quiet
(:data:`~roadbank.vehicle.conditions.ROAD_CHANGE_BACK`); the sixty-second (:func:`choose_undescribed_quiet`): the car's
model on a quiet log whose car nobody described (:data:`~roadbank.vehicle.conditions.UNDESCRIBED_KEEPS_MODEL`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...estimators import OFFLINE
from ...estimators.offsets import with_online_offsets
from ...evaluation.compare import usable_samples
from ...evaluation.metrics import error_metrics
from ...vehicle import load_vehicle
from ...signals import Signals, concat_signals
from ...validation.roads import SMOOTH_ROADS, smooth_road
from ..objective import FAILED_DEG, SETTLE
from .common import BEFORE_64, BEFORE_69, cars_median, design_settings, log_errors, per_log, sim_errors, within
from .esp import _with_settings, same_outputs, two_choice_rule

#: the rule: B ships if its median over the ESP long logs is below A's by more than this (deg) ...
ROAD_CHANGE_GAIN_DEG = 0.05
#: ... and its median over the long logs with the roll rate, and its median over the cars on the long simulated logs,
#: are not above A's by more than this (deg)
ROAD_CHANGE_LOSS_DEG = 0.005
#: the smooth start: how many drives, the centred moving mean (samples at KITTI's 10 Hz) and the white noise added to
#: ``ay`` (m/s^2) and to the yaw and roll rates (rad/s): a smooth road on a data sheet's sensors
SMOOTH_DRIVES = 2
SMOOTH_SAMPLES = 20
SMOOTH_AY_NOISE = 0.02
SMOOTH_RATE_NOISE = 0.002
#: the time (s) between drives stitched on one clock: KITTI drives (one road after another), simulated drives (the
#: filter starts again after each, as after a gap)
KITTI_GAP_S = 0.1
SIM_GAP_S = 2.0


def smoothed_drive(s: Signals, seed: int) -> Signals:
    """``s`` as a smooth road on a data sheet's sensors: ``ay``, ``r`` and ``p`` (where it has one) through a centred
    moving mean of :data:`SMOOTH_SAMPLES` samples plus white noise (:data:`SMOOTH_AY_NOISE` m/s^2,
    :data:`SMOOTH_RATE_NOISE` rad/s)."""
    rng = np.random.default_rng(seed)
    k = np.ones(SMOOTH_SAMPLES) / SMOOTH_SAMPLES

    def mean(x, noise):
        return np.convolve(np.asarray(x, dtype=np.float64), k, mode="same") + noise * rng.standard_normal(len(x))
    out = {"ay": mean(s.ay, SMOOTH_AY_NOISE), "r": mean(s.r, SMOOTH_RATE_NOISE)}
    if s.p is not None:
        out["p"] = mean(s.p, SMOOTH_RATE_NOISE)
    return Signals(**{c: out.get(c, getattr(s, c)) for c in s.channels}, fixed=s.fixed, unbiased=s.unbiased)


def on_one_clock(parts: list[Signals], gap: float) -> tuple[Signals, list[int]]:
    """``parts`` one after another on one clock, ``gap`` (s) between the last stamp of one and the first of the next;
    and the first row of each."""
    out, starts, t0, row = [], [], 0.0, 0
    for s in parts:
        t = np.asarray(s.t, dtype=np.float64)
        out.append(Signals(**{c: t - t[0] + t0 if c == "t" else getattr(s, c) for c in s.channels},
                           fixed=s.fixed, unbiased=s.unbiased))
        starts.append(row)
        row += len(s)
        t0 += float(t[-1] - t[0]) + gap
    return concat_signals(out), starts


def smooth_start_logs(logs, gap: float = KITTI_GAP_S) -> list:
    """Long logs of ``logs`` (``(signals, reference roll rad, scored mask)`` of each KITTI drive, in order:
    :func:`~roadbank.tuning.real.training_logs`): log ``k`` is drives ``k`` to ``k + SMOOTH_DRIVES - 1`` (mod their
    number) smoothed (:func:`smoothed_drive`), then every drive as recorded from drive ``k`` on, ``gap`` (s) apart;
    as ``(signals, reference roll, mask)``, the mask that of the drives as recorded (the smooth start unscored)."""
    n = len(logs)
    out = []
    for k in range(n):
        order = [logs[(k + i) % n] for i in range(n)]
        smooth = [(smoothed_drive(logs[(k + i) % n][0], seed=i), logs[(k + i) % n][1], False)
                  for i in range(SMOOTH_DRIVES)]
        parts = smooth + [(s, ref, m) for s, ref, m in order]
        signals, _ = on_one_clock([p[0] for p in parts], gap)
        ref = np.concatenate([p[1] for p in parts])
        mask = np.concatenate([np.zeros(len(p[0]), bool) if p[2] is False else p[2] for p in parts])
        out.append((signals, ref, mask))
    return out


def long_quiet_sets(sim_sets) -> list:
    """Each set of ``sim_sets`` (lists of simulated drives, :func:`~roadbank.tuning.real.simulated_sets`) on one clock,
    :data:`SIM_GAP_S` apart: ``(signals, drives, first row of each)`` per set."""
    out = []
    for drives in sim_sets:
        signals, starts = on_one_clock([d.signals for d in drives], SIM_GAP_S)
        out.append((signals, drives, starts))
    return out


def long_sim_errors(build, long_sets) -> list[list[float]]:
    """The bank RMS error (deg) of each simulated drive in the long logs ``long_sets`` (:func:`long_quiet_sets`), as
    ``roadbank tune`` scores it (after :data:`~roadbank.tuning.objective.SETTLE` s of each drive, on its usable
    samples), of one run of ``build(signals)`` over the long log."""
    out = []
    for signals, drives, starts in long_sets:
        est = build(signals)
        e = est.run(signals)
        errs = []
        for d, a in zip(drives, starts):
            b = a + len(d.signals)
            m = error_metrics(d.signals.t, e.phi_b[a:b], d.phi_b, usable_samples(d.signals, est.v_min), settle=SETTLE)
            errs.append(float(m.rms_deg) if np.isfinite(m.rms_deg) else FAILED_DEG)
        out.append(errs)
    return out


def road_change_build(choice: bool | str):
    """``build``: ``kinematic-pif`` as ``roadbank estimate`` runs it (designed for the log, behind the online offset
    learner) with :data:`roadbank.vehicle.conditions.ROAD_CHANGE` ``choice``, as the fifty-eighth and fifty-ninth stages
    ran: before the sixtieth, a quiet log kept the car's model whatever its roll rate (``QUIET_READS_ROLL_RATE``
    False)."""
    at = _with_settings(road_change=choice, quiet_reads_roll_rate=False)
    return lambda s: with_online_offsets(at(s))


def choose_road_change(esp_logs, gyro_logs, esp_long, gyro_long, sim_sets, long_sets) -> tuple:
    """The fifty-eighth stage (docs/estimators.md) with :data:`roadbank.vehicle.conditions.ROAD_CHANGE` False (A) and
    True (B), on the long logs ``esp_long`` and ``gyro_long`` (:func:`smooth_start_logs` of the KITTI training drives
    with the ESP channels and with the roll rate) and ``long_sets`` (:func:`long_quiet_sets`). Returns ``(chosen,
    {choice: (raw RMS per ESP long log, per gyro long log (deg), per car: bank RMS per drive (deg))})``. The drives as
    recorded (``esp_logs``, ``gyro_logs``) and the simulated drives of ``sim_sets`` one by one must give the same
    outputs under both: a ValueError where they do not."""
    kept = [s for s, _, _ in esp_logs + gyro_logs] + [d.signals for drives in sim_sets for d in drives]
    same_outputs(road_change_build, kept, (False, True),
                 "a log whose roads do not change was read otherwise: the stage's guard fails")
    errs = {c: (log_errors(road_change_build(c), esp_long), log_errors(road_change_build(c), gyro_long),
                long_sim_errors(road_change_build(c), long_sets)) for c in (False, True)}
    (a1, a2, a3), (b1, b2, b3) = errs[False], errs[True]
    ships = (np.median(b1) < np.median(a1) - ROAD_CHANGE_GAIN_DEG
             and np.median(b2) <= np.median(a2) + ROAD_CHANGE_LOSS_DEG
             and cars_median(b3) <= cars_median(a3) + ROAD_CHANGE_LOSS_DEG)
    return bool(ships), errs


#: the fifty-ninth stage: B ships if its median is below A's by more than this (deg)
ROAD_CHANGE_GYRO_GAIN_DEG = 0.005
#: ... on long logs whose drives are this far apart (s): longer than the filters' ``max_gap``, so each starts again
RESTART_GAP_S = 2.0


def choose_road_change_gyro(esp_long, gyro_long) -> tuple:
    """The fifty-ninth stage (docs/estimators.md): :data:`roadbank.vehicle.conditions.ROAD_CHANGE` ``True`` (A, a
    hand-over to the gyro-aided filter where the log has a usable roll rate) and ``"esp"`` (B, none there), on the long
    logs ``gyro_long`` (:func:`smooth_start_logs` of the KITTI training drives with their roll rate,
    :data:`RESTART_GAP_S` apart). Returns ``(chosen setting, {setting: raw RMS per long log (deg)})``. The same logs
    with the ESP channels alone (``esp_long``) must give the same outputs under both: a ValueError where not."""
    return two_choice_rule(road_change_build, [s for s, _, _ in esp_long], (True, "esp"),
                           "a log without a roll rate was handed over otherwise: the stage's guard fails", gyro_long,
                           ROAD_CHANGE_GYRO_GAIN_DEG)


#: the sixtieth stage's smooth road: ``ay`` and the yaw rate through a zero-phase Butterworth low-pass of this order and
#: cut-off (Hz), plus the white noise of the ESP sensors' data sheet (:class:`roadbank.sim.sensors.SensorConfig`)
SMOOTH_ROAD_ORDER, SMOOTH_ROAD_CUTOFF_HZ = SMOOTH_ROADS["0.5 Hz"]
#: its rule: B ships if its median is below A's by more than this (deg)
QUIET_INS_GAIN_DEG = 0.005


def smooth_road_logs(logs, order: int = SMOOTH_ROAD_ORDER, cutoff: float = SMOOTH_ROAD_CUTOFF_HZ) -> list:
    """``logs`` (``(signals, reference roll rad, scored mask)``, :func:`~roadbank.tuning.real.training_logs`) as the
    same drives on a smooth road read by a data sheet's sensors (:func:`roadbank.validation.roads.smooth_road` of
    ``order`` at ``cutoff`` Hz, default the sixtieth stage's, :data:`SMOOTH_ROAD_ORDER` at
    :data:`SMOOTH_ROAD_CUTOFF_HZ`, seeded by the drive's place in ``logs``); the reference and the mask as they are."""
    return [(smooth_road(s, order, cutoff, seed=i), ref, mask) for i, (s, ref, mask) in enumerate(logs)]


def choose_quiet_ins(gyro_logs, smooth_logs, sim_gyro_sets) -> tuple:
    """The sixtieth stage (docs/estimators.md): ``kinematic-pif`` as ``roadbank estimate`` runs it (designed for each
    log, behind the online offset learner) with :data:`roadbank.vehicle.conditions.QUIET_READS_ROLL_RATE` False (A) and
    ``"unbiased"`` (B), on ``smooth_logs`` (:func:`smooth_road_logs` of the KITTI training drives with their INS roll
    rate). Returns ``(chosen setting, {setting: raw RMS per log (deg)})``. The drives as recorded (``gyro_logs``) and
    the simulated drives with an ESP-class roll-rate gyro (``sim_gyro_sets``: lists, per offset, of drive sets) must
    give the same outputs under both: a ValueError where they do not."""
    def build(choice):
        at = _with_settings(quiet_reads_roll_rate=choice)
        return lambda s: with_online_offsets(at(s))

    kept = [s for s, _, _ in gyro_logs] + [d.signals for sets in sim_gyro_sets for drives in sets for d in drives]
    why = "a log without an INS's roll rate, or a loud one, was read otherwise: the stage's guard fails"
    return two_choice_rule(build, kept, (False, "unbiased"), why, smooth_logs, QUIET_INS_GAIN_DEG)


#: the sixty-second stage's second smooth road: a steep zero-phase Butterworth low-pass (order, cut-off Hz) that keeps
#: the car's motion up to about 0.7 Hz and leaves the KITTI training drives quiet (0.71-1.45 times the density)
STEEP_ROAD_ORDER, STEEP_ROAD_CUTOFF_HZ = SMOOTH_ROADS["0.8 Hz, steep"]
#: its rule: B ships if its objective is below A's by more than this (deg)
UNDESCRIBED_GAIN_DEG = 0.02


def choose_undescribed_quiet(smooth_logs, sim_quiet_sets, kept_logs, known_sets, name: str = "kinematic-pif",
                             setting: str = "undescribed_keeps_model") -> tuple:
    """The sixty-second stage (docs/estimators.md): ``kinematic-pif`` as ``roadbank estimate`` runs it without a
    vehicle file (designed for each log, behind the online offset learner) with
    :data:`roadbank.vehicle.conditions.UNDESCRIBED_KEEPS_MODEL` True (A) and False (B); the sixty-third: ``name``
    ``"kinematic-smoother"`` as ``roadbank map`` runs it (no offset learner: an offline estimator) with ``setting``
    ``"undescribed_smoother_keeps_model"`` (:data:`~roadbank.vehicle.conditions.UNDESCRIBED_SMOOTHER_KEEPS_MODEL`),
    the causal default as shipped. Objective: the median raw RMS
    (deg) over ``smooth_logs`` (the KITTI training drives as two smooth roads, ESP channels) plus the median over the
    cars of each car's median bank RMS (deg) over its drives in ``sim_quiet_sets`` (per car, a list of drives: its
    quiet simulated training drives with every sensor set pooled). Returns ``(chosen, {choice: objective}, {choice: (raw
    RMS per smooth log, per car: bank RMS per drive)})``. ``kept_logs`` (signals) and the drives of ``known_sets``
    (``(car name, drives)``, each built with that car's file) must give the same outputs under both: a ValueError
    where they do not."""
    offline = name in OFFLINE
    build = within(per_log(name, described=False), **BEFORE_64)     # the map's smoother as it ran then

    def online(s):
        return build(s) if offline else with_online_offsets(build(s))

    def known(car):
        made = within(per_log(name, vehicle=load_vehicle(car)), **BEFORE_64, **BEFORE_69)
        return lambda s: made(s) if offline else with_online_offsets(made(s))

    pairs = [(online, s) for s in kept_logs] + [(known(car), d.signals) for car, drives in known_sets for d in drives]
    _same_in_force(setting, (True, False), pairs,
                   "a loud log, or a car described, was read otherwise: the stage's guard fails")
    errs = {c: (_in_force(setting, c, log_errors, online, smooth_logs),
                _in_force(setting, c, sim_errors, online, sim_quiet_sets)) for c in (True, False)}
    obj = {c: float(np.median(e[0])) + cars_median(e[1]) for c, e in errs.items()}
    return (False if obj[False] < obj[True] - UNDESCRIBED_GAIN_DEG else True), obj, errs


__all__ = ["STEEP_ROAD_ORDER", "STEEP_ROAD_CUTOFF_HZ", "UNDESCRIBED_GAIN_DEG", "choose_undescribed_quiet",
           "BACK_LOUD_AY", "ROAD_CHANGE_BACK_GAIN_DEG", "ROAD_CHANGE_BACK_LOSS_DEG", "ROAD_CHANGE_BACK_WORSE_DEG",
           "choose_road_change_back", "loud_and_quiet_logs", "loud_then_quiet_sets",
           "on_one_clock", "smoothed_drive", "choose_quiet_ins", "smooth_road_logs", "QUIET_INS_GAIN_DEG",
           "choose_road_change_gyro", "ROAD_CHANGE_GYRO_GAIN_DEG", "RESTART_GAP_S", "choose_road_change",
           "smooth_start_logs", "long_quiet_sets", "long_sim_errors", "road_change_build",
           "ROAD_CHANGE_GAIN_DEG", "ROAD_CHANGE_LOSS_DEG"]


def _in_force(setting: str, choice, measure, *args):
    """``measure(*args)`` with the design setting ``setting`` (:func:`~roadbank.tuning.real.design_settings`' keyword)
    at ``choice`` while it runs, not only while the estimators are built: a hand-over designs anew mid-log."""
    with design_settings(**{setting: choice}):
        return measure(*args)


def _theta(build, s):
    return build(s).run(s).theta


def _same_in_force(setting: str, choices, pairs, why: str) -> None:
    """A stage's guard with ``setting`` in force while each log runs (:func:`_in_force`): every ``(build, signals)``
    of ``pairs`` gives the same ``theta`` under each of ``choices``; a ValueError saying ``why`` where not."""
    for build, s in pairs:
        first, *others = (_in_force(setting, c, _theta, build, s) for c in choices)
        if not all(np.array_equal(first, o, equal_nan=True) for o in others):
            raise ValueError(why)


#: the sixty-first stage's sets: the drives as recorded (loud) and as a smooth road (quiet) in two orders, and the loud
#: simulated drives' white ``ay`` noise (m/s^2, a shaking accelerometer, as tests/test_handover.py builds them)
BACK_LOUD_AY = 0.5
#: its rule: B ships if its median over the real long logs is below A's by more than this (deg) ...
ROAD_CHANGE_BACK_GAIN_DEG = 0.02
#: ... its median over the cars on each simulated set, and its median over the drives as recorded, are not above A's by
#: more than this (deg) ...
ROAD_CHANGE_BACK_LOSS_DEG = 0.005
#: ... and no drive as recorded is worse than under A by more than this (deg)
ROAD_CHANGE_BACK_WORSE_DEG = 0.02


def loud_and_quiet_logs(logs, smooth) -> tuple[list, list]:
    """The sixty-first stage's real long logs from ``logs`` (``(signals, reference roll rad, scored mask)`` of each
    KITTI drive, in order) and ``smooth`` (the same drives as a smooth road, :func:`smooth_road_logs`), on one clock
    :data:`KITTI_GAP_S` apart, every drive scored on its own mask: ``(loud then quiet, quiet then loud then quiet)``,
    log ``k`` of the first drives ``k`` and ``k + 1`` (mod their number) as recorded and the others from ``k + 2`` on
    smooth, of the second drives ``k``, ``k + 1`` smooth, ``k + 2``, ``k + 3`` as recorded, the others smooth."""
    n = len(logs)

    def joined(parts):
        signals, _ = on_one_clock([p[0] for p in parts], KITTI_GAP_S)
        return signals, np.concatenate([p[1] for p in parts]), np.concatenate([p[2] for p in parts])

    def order(k, loud):
        return [(logs if (i in loud) else smooth)[(k + i) % n] for i in range(n)]
    return ([joined(order(k, (0, 1))) for k in range(n)], [joined(order(k, (2, 3))) for k in range(n)])


def loud_then_quiet_sets(sim_sets, seed: int = 0) -> list:
    """Each set of ``sim_sets`` (lists of simulated drives) as one long log (:func:`long_quiet_sets`' form,
    :data:`SIM_GAP_S` apart): its first half with :data:`BACK_LOUD_AY` m/s^2 of white noise added to ``ay`` (one numpy
    generator, ``seed``, in the sets' order), then its second half as simulated."""
    rng = np.random.default_rng(seed)
    out = []
    for drives in sim_sets:
        half = len(drives) // 2
        loud = [dataclasses.replace(d, signals=dataclasses.replace(
            d.signals, ay=d.signals.ay + BACK_LOUD_AY * rng.standard_normal(len(d.signals)))) for d in drives[:half]]
        out += long_quiet_sets([loud + list(drives[half:])])
    return out


def choose_road_change_back(esp_logs, gyro_logs, loud_quiet, quiet_loud_quiet, sim_sets, sim_loud_quiet,
                            gyro_loud_quiet) -> tuple:
    """The sixty-first stage (docs/estimators.md): ``kinematic-pif`` as ``roadbank estimate`` runs it (designed for
    each log, behind the online offset learner) with :data:`roadbank.vehicle.conditions.ROAD_CHANGE_BACK` False (A) and
    True (B), the setting in force while the logs run (a hand-over designs anew). Sets: ``loud_quiet`` and
    ``quiet_loud_quiet`` (:func:`loud_and_quiet_logs` of the KITTI training drives, ESP channels), ``sim_loud_quiet``
    and ``gyro_loud_quiet`` (:func:`loud_then_quiet_sets` of the simulated training drives, and of those with an
    ESP-class roll-rate gyro). Returns ``(chosen, {choice: (raw RMS per real long log, per ESP drive as recorded
    (deg), per car: bank RMS per drive (deg), the same with the gyro)})``. The drives with their INS roll rate
    (``gyro_logs``) and the simulated drives of ``sim_sets`` one by one must give the same outputs under both: a
    ValueError where they do not."""
    build = per_log("kinematic-pif")

    def online(s):
        return with_online_offsets(build(s))

    setting = "road_change_back"
    kept = [s for s, _, _ in gyro_logs] + [d.signals for drives in sim_sets for d in drives]
    _same_in_force(setting, (False, True), [(online, s) for s in kept],
                   "a log whose roads do not turn quiet was read otherwise: the stage's guard fails")
    errs = {c: (_in_force(setting, c, log_errors, online, loud_quiet + quiet_loud_quiet),
                _in_force(setting, c, log_errors, online, esp_logs),
                _in_force(setting, c, long_sim_errors, online, sim_loud_quiet),
                _in_force(setting, c, long_sim_errors, online, gyro_loud_quiet))
            for c in (False, True)}
    (a1, a2, a3, a4), (b1, b2, b3, b4) = errs[False], errs[True]
    ships = (np.median(b1) < np.median(a1) - ROAD_CHANGE_BACK_GAIN_DEG
             and cars_median(b3) <= cars_median(a3) + ROAD_CHANGE_BACK_LOSS_DEG
             and cars_median(b4) <= cars_median(a4) + ROAD_CHANGE_BACK_LOSS_DEG
             and np.median(b2) <= np.median(a2) + ROAD_CHANGE_BACK_LOSS_DEG
             and not np.any(np.array(b2) > np.array(a2) + ROAD_CHANGE_BACK_WORSE_DEG))
    return bool(ships), errs

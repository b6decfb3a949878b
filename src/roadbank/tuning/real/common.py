r"""The machinery of the choices made on training data (:mod:`roadbank.tuning.real`): the KITTI training drives
and the simulated sets, the objective, ties and pieces, and the
constants that stages ran with before a later stage changed them (pinned, so that each stage's test runs it again).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ... import vehicle
from ...io.kitti import load_kitti_oxts
from ...validation.kitti import KITTI_SCORING
from ...validation.scoring import SHORT_PIECES_S, masks, scored_pieces
from ...validation.splits import KITTI_TRAINING
from ...vehicle import conditions, load_vehicle
from ..manoeuvres import drive_set
from ..objective import drive_errors


#: how the stages before the thirty-eighth ran ``kinematic-gyro``: no pitch before the grade window had passed
BEFORE_38 = {"grade_first_span": math.inf}
#: the thirty-ninth stage's bandwidth (rad/s) of the pitch observer for an unbiased pitch rate, as the fortieth to
#: forty-fourth stages ran it (the forty-fifth chose anew)
BANDWIDTH_39 = 0.5
#: the fortieth stage's start of the pitch observer for an unbiased pitch rate, as the forty-first to forty-fourth
#: stages ran it (the forty-fourth replaced it by the anchored start)
START_40 = (3.0, 3.0)
#: the thirty-sixth stage's constants of the gyro-aided filter for a roll rate free of offset (cut-off Hz, offset time
#: constant s), as the thirty-seventh to forty-third stages ran it (the forty-third chose anew)
UNBIASED_36 = {"cutoff": 0.07, "bias_tau": 40.0}
#: the design settings (:func:`~roadbank.tuning.real.design_settings`) as the stages before the sixty-fourth ran
#: ``kinematic-smoother``: the low-pass both ways, no gate to ``pif-smoother``
BEFORE_64 = {"smoother_gate": False}
#: ... and as the sixty-fourth ran it: the gate's measure counted at every speed
BEFORE_65 = {"smoother_gate_v_min": 0.0}
#: ... and as the sixty-fourth and sixty-fifth ran it: held open 8 s before and after each ramp
BEFORE_67 = {"smoother_gate_hold_s": 8.0}
#: a car not trimmed to the log (as every stage before the sixty-eighth ran, and as a fitted car is read)
BEFORE_69 = {"rear_trim": False}
#: objectives closer than this (deg) count as equal
TIE_DEG = 0.002
#: the rule's simulated tie-break counts medians as equal to this (deg): the size of float rounding
EQUAL_DEG = 1e-9
#: the shipped cars of the simulated part, and the number of training drives per car
SIM_CARS = ("suv-paper", "sedan", "compact", "van")
SIM_DRIVES = 24


@contextmanager
def design_settings(**settings):
    """Within the block, the settings of :mod:`roadbank.vehicle.conditions` that the stages from the eighteenth on
    choose (``QUIET_FLOOR_RATE``, ``QUIET_FLOOR_SIGNAL``, ``NOISE_AT_SOURCE``, ``NOISE_OCTAVE``, ``NOISE_OCTAVE_TOP``:
    keyword names in lower case) as given, restored after: every command's design reads them, so a stage runs each
    candidate as it would ship. A value that is not one of the setting's choices is refused when a design reads it."""
    names = {k: k.upper() for k in settings}
    unknown = [k for k, n in names.items() if n not in _DESIGN_SETTINGS]
    if unknown:
        raise ValueError(f"not a design setting: {', '.join(unknown)} (one of {', '.join(_DESIGN_SETTINGS).lower()})")
    before = {n: getattr(conditions, n) for n in names.values()}
    for k, n in names.items():
        setattr(conditions, n, settings[k])
    try:
        yield
    finally:
        for n, v in before.items():
            setattr(conditions, n, v)


#: the module settings of :mod:`roadbank.vehicle.conditions` that :func:`design_settings` sets
_DESIGN_SETTINGS = ("QUIET_FLOOR_RATE", "QUIET_FLOOR_SIGNAL", "NOISE_AT_SOURCE", "NOISE_OCTAVE", "NOISE_OCTAVE_TOP",
                    "TRUST_FIXED_CHANNELS", "GATE_AT_SOURCE", "READ_AT_SOURCE", "QUIET_READS_ROLL_RATE",
                    "SOURCE_ROUNDING", "ROAD_CHANGE", "ROAD_CHANGE_BACK", "UNDESCRIBED_KEEPS_MODEL",
                    "UNDESCRIBED_SMOOTHER_KEEPS_MODEL", "SMOOTHER_GATE", "SMOOTHER_GATE_V_MIN",
                    "BLEND_GATE_V_MIN", "SMOOTHER_GATE_HOLD_S", "REAR_TRIM")


def within(build, **settings):
    """``build`` (signals -> estimator) run within :func:`design_settings` ``(**settings)``: a design read at build
    time, as a stage ran it."""
    def at(signals):
        with design_settings(**settings):
            return build(signals)
    return at


def lowest_tied(obj: dict, order):
    """The key of ``obj`` (key -> objective, deg) whose objective is the lowest, the keys within :data:`TIE_DEG` of
    it going to the first by ``order`` (a sort key of the keys)."""
    best = min(obj.values())
    return min((k for k, v in obj.items() if v <= best + TIE_DEG), key=order)


def training_logs(data_dir, scoring=KITTI_SCORING, roll_rate: bool = False, pitch_rate: bool = False):
    """``(signals, reference roll rad, scored mask)`` of each KITTI training drive found under ``data_dir``
    (the mask of ``scoring``, default :data:`~roadbank.validation.kitti.KITTI_SCORING`). Without ``roll_rate`` the
    signals are the ESP channels alone (``p`` None): the stages before the twenty-fourth read none, and ran so;
    without ``pitch_rate`` they have no ``q``: the stages before the thirty-ninth read none."""
    out = []
    for name in KITTI_TRAINING:
        found = [p for p in Path(data_dir).glob(f"*/{name}") if p.is_dir()]
        if not found:
            continue
        log = load_kitti_oxts(found[0])
        s = log.signals if pitch_rate else dataclasses.replace(log.signals, q=None)
        out.append((s, log.reference_roll, masks(s.t, s.vx, scoring)[1]))
    return out if roll_rate else without_roll_rate(out)


def simulated_sets(cars=SIM_CARS, n=SIM_DRIVES):
    """``roadbank tune``'s training drives (seed 0) of each car in ``cars`` (shipped vehicle names)."""
    return [drive_set("train", n, 0, load_vehicle(car).params) for car in cars]


def objective(build, logs, sim_sets) -> float:
    """The rule's objective (deg) of the estimator that ``build(signals)`` makes for each log
    (module docstring): a fixed estimator, or one designed for each log
    (:func:`roadbank.vehicle.for_log`, as the command line builds it)."""
    errs = log_errors(build, logs)
    return (float(np.median(errs)) if errs else 0.0) + (cars_median(sim_errors(build, sim_sets)) if sim_sets else 0.0)


def sim_errors(build, sim_sets) -> list[list[float]]:
    """The bank RMS error (deg) of each simulated drive as ``roadbank tune`` scores it, per set of ``sim_sets``
    (:func:`simulated_sets`), the estimator ``build(signals)`` makes for the drive."""
    return [[float(drive_errors(build(d.signals), [d])[0][0]) for d in drives] for drives in sim_sets]


def cars_median(errs) -> float:
    """The median over the sets (the cars) of each set's median (deg) of :func:`sim_errors`."""
    return float(np.median([np.median(e) for e in errs]))


def guarded(chosen, first, mean: dict):
    """The fourteenth stage's guard: ``chosen`` where it is ``first`` or its mean drive score is lower than
    ``first``'s (``mean``: key -> mean, deg), else ``first``."""
    return chosen if chosen == first or mean[chosen] < mean[first] else first


def log_errors(build, logs) -> list[float]:
    """The raw RMS error (deg) of ``theta`` against the INS roll on each log's scored samples (``logs`` from
    :func:`training_logs`), the estimator ``build(signals)`` makes for it."""
    return [rms_deg(build(s).run(s).theta[m], ref[m]) for s, ref, m in logs]


def rms_deg(theta, ref) -> float:
    """RMS (deg) of ``theta - ref`` (rad)."""
    return float(np.degrees(np.sqrt(np.mean((theta - ref) ** 2))))


def fixed(est):
    """``build`` for :func:`objective` of one estimator that needs no design per log."""
    return lambda signals: est


def per_log(name: str, car_margin: float | None = None, **options):
    """``build`` for :func:`objective`: ``name`` designed for each log as the command line does
    (no car given: :func:`roadbank.vehicle.undescribed_params` of the log; ``car_margin`` (-) other than
    the shipped :data:`~roadbank.vehicle.CAR_MARGIN`: with that margin, ``inf`` the static car, as the
    stages before the eighth ran, never trimmed to the log: :data:`BEFORE_69`), that car read as described (its
    model kept on a quiet log, as every stage before the sixty-second ran) unless the options say
    ``described=False`` (as the command line reads it since,
    :data:`~roadbank.vehicle.conditions.UNDESCRIBED_KEEPS_MODEL`)."""
    options = {"described": True, **options}
    def build(signals):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            if car_margin is not None and "params" not in options and "vehicle" not in options:
                with design_settings(**BEFORE_69):      # the fitted car given as params: no user described it
                    return vehicle.for_log(name, signals, vehicle.undescribed_params(signals, car_margin), **options)
            return vehicle.for_log(name, signals, **options)
    return build


def without_roll_rate(logs) -> list:
    """``logs`` (:func:`training_logs`) with their ESP channels alone (``p`` and ``ax`` None)."""
    return [(dataclasses.replace(s, p=None, ax=None), ref, m) for s, ref, m in logs]


def whole_and_pieces(logs, lengths=SHORT_PIECES_S) -> list:
    """``[logs, pieces...]``: ``logs`` (:func:`training_logs`) whole, then cut into each of ``lengths`` (s) by
    :func:`check_pieces`, each piece ``(signals, reference roll rad, scored mask)``: the parts of
    :func:`lengths_objective`."""
    return [logs] + [[(p, ref, m) for p, ref, m, _ in check_pieces(logs, n)] for n in lengths]


def lengths_objective(build, parts) -> float:
    """The mean over ``parts`` (:func:`whole_and_pieces`) of the median raw RMS (deg) of the estimator
    ``build(signals)`` makes: the objective of the thirty-fourth to thirty-eighth stages, per set."""
    return float(np.mean([np.median(log_errors(build, part)) for part in parts]))


def check_pieces(logs, length: float) -> list:
    """``logs`` (:func:`training_logs`) cut into consecutive whole pieces of ``length`` (s), each ``(signals, reference
    roll rad, scored mask, (drive index, first sample, end sample))`` with the KITTI scoring within the piece; pieces
    with no scored sample left out."""
    return [(piece, ref[a:b], m, (i, a, b)) for i, (s, ref, _) in enumerate(logs)
            for a, b, piece, m in scored_pieces(s, length, KITTI_SCORING)]

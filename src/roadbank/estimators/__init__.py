"""Bank-angle estimators behind one interface (docs/estimators.md).

>>> from roadbank import estimators
>>> est = estimators.make("pif-modified")
>>> estimate = est.run(signals)           # doctest: +SKIP

``NAMES`` lists the estimators (the paper's, the Kalman peer, the low-passed kinematic estimates
``kinematic-lp`` and ``kinematic-ff``, ``kinematic-pif`` (the default of every command,
:data:`DEFAULT`), ``pif-rate``, ``pif-adaptive``, ``pif-rate-adaptive``, ``pif-gated`` and the offline
``pif-smoother`` and ``kinematic-smoother``); ``make(name, params, **tuning)`` builds one,
:func:`roadbank.vehicle.for_log` builds one for a log as the command line does.
``PRESETS`` are further names ``make`` accepts: ``pif-paper`` is ``pif-modified`` with the paper's
Table 4 weights (``pif-modified`` itself is roadbank's default tuning). A named tuning other than the
estimator's own shows in its name, so in its outputs' columns: ``make("pif-modified", tuning="paper-deg")``
is ``pif-modified[paper-deg]``.
Each has ``run(signals) -> Estimate``, ``step(t, vx, ay, r, delta_f)`` and ``reset()``.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

from ..defaults import ESTIMATOR
from ..params import VehicleParams
from .base import Estimator, StepResult
from .dfc import DFC
from .gated import KinematicPIF, PIFGated
from .gyro import KinematicGyro, KinematicGyroSmoother
from .gated_smoother import GatedSmoother
from .handover import HandOver
from .held import AtSource
from .kalman import Kalman
from .kinematic import Kinematic
from .kinematic_smoother import KinematicSmoother
from .lowpass import KinematicFeedForward, KinematicLowPass
from .offsets import OffsetSettings, OnlineOffsets, with_online_offsets
from .pif import PIF, SENSOR_R_ESTIMATORS, PIFAdaptive, PIFRate, PIFRateAdaptive
from .pio import PIO
from .smoother import PIFSmoother
from .synthesis import NoStabilisingSolution
from .uio import UIO

_FACTORIES: dict[str, Callable[..., Estimator]] = {
    "kinematic": Kinematic,
    "kinematic-lp": KinematicLowPass,
    "kinematic-ff": KinematicFeedForward,
    "kinematic-pif": KinematicPIF,
    "dfc": DFC,
    "uio": UIO,
    "pio-original": partial(PIO, model="original"),
    "pio-modified": partial(PIO, model="modified"),
    "pif-modified": partial(PIF, model="modified"),
    "pif-original": partial(PIF, model="original"),
    "kalman": Kalman,
    "pif-rate": PIFRate,
    "pif-adaptive": PIFAdaptive,
    "pif-rate-adaptive": PIFRateAdaptive,
    "pif-gated": PIFGated,
    "pif-smoother": PIFSmoother,
    "kinematic-smoother": KinematicSmoother,
    "pif-paper": partial(PIF, model="modified", tuning="paper"),
    "kinematic-gyro": KinematicGyro,
    "kinematic-gyro-smoother": KinematicGyroSmoother,
}

#: further names :func:`make` accepts: an estimator of :data:`NAMES` with a named tuning
#: (``pif-paper``: ``pif-modified`` with the paper's Table 4 weights, SI reading). Not in
#: :data:`NAMES`: the same filter as one there, so the suites that try every estimator
#: (and ``-e all``) would only run it twice.
PRESETS = ("pif-paper",)
#: estimators that also read a roll-rate gyro (:attr:`roadbank.Signals.p`), for logs that carry one (an INS, a
#: phone, a six-axis IMU). Not in :data:`NAMES`: an ESP log has no roll rate, so the suites and reports that run
#: every estimator on ESP signals leave them out; ``make`` builds them, and on a loud log whose roll rate follows its
#: ``ay`` :func:`roadbank.vehicle.for_log` builds them for ``kinematic-pif`` and ``kinematic-smoother``
#: (:data:`roadbank.vehicle.conditions.GYRO_MODELS`; docs/estimators.md)
GYRO = ("kinematic-gyro", "kinematic-gyro-smoother")
#: names of all estimators, in the order the reports list them
NAMES = tuple(n for n in _FACTORIES if n not in PRESETS + GYRO)
#: estimators whose ``run()`` also uses the samples after each instant (post-processing, not
#: for an ECU); their ``step()`` is causal (see :mod:`roadbank.estimators.smoother`)
OFFLINE = tuple(n for n, f in _FACTORIES.items() if getattr(f, "offline", False))
#: the estimator of every command and of :func:`roadbank.vehicle.for_log` when none is named: the best by a rule
#: written before measuring, on training data only (real KITTI training drives and simulated
#: drives of cars that are not described; docs/estimators.md, :mod:`roadbank.tuning.real`)
DEFAULT = ESTIMATOR
#: estimators that run another's filter with its weights (``pif-gated``: as its slow filter): a
#: vehicle file's ``[tuning.<that one>]`` table applies to them too, under their own table's keys
TUNED_AS = {"pif-smoother": "pif-modified", "pif-gated": "pif-modified", "kinematic-pif": "pif-modified"}


#: sample rate (Hz) of the data sheet's sensors that ``make`` designs the sensor-weighted PIFs for
SHEET_RATE_HZ = 100.0
#: the named tuning (``tuning=``) an estimator has when none is given, where that is not ``"default"``
OWN_TUNING = {"pif-original": "paper", "pif-paper": "paper"}


def make(name: str, params: VehicleParams | None = None, **tuning) -> Estimator:
    """Build the estimator ``name`` (one of :data:`NAMES`, :data:`PRESETS` or :data:`GYRO`) for ``params``.

    ``tuning`` are the estimator's keyword options (see each class) plus the
    common ones ``v_min`` (m/s), ``roll``, ``max_substep`` (s), ``max_gap`` (s). A named tuning
    (``tuning="paper-deg"``) other than the estimator's own (:data:`OWN_TUNING`) is added to its
    ``name`` in brackets, ``"pif-modified[paper-deg]"``: the name its estimates and their columns carry.
    """
    try:
        factory = _FACTORIES[name]
    except KeyError:
        raise ValueError(f"unknown estimator {name!r}; choose one of {', '.join(NAMES + PRESETS + GYRO)}") from None
    try:
        est = factory(params, **tuning)
    except TypeError as exc:
        raise ValueError(f"{name}: bad tuning option ({exc})") from None
    named = tuning.get("tuning")
    if named is not None and named != OWN_TUNING.get(name, "default"):
        est.name = f"{name}[{named}]"      # two tunings of one filter must not share their output columns
    elif name in PRESETS:
        est.name = name            # its outputs' columns say which tuning made them
    if name in SENSOR_R_ESTIMATORS and "R" not in tuning and tuning.get("tuning", "default") == "default":
        est.sheet_rate = SHEET_RATE_HZ      # designed for the data sheet's sensor at its own rate
    return est


__all__ = ["NAMES", "PRESETS", "DEFAULT", "OFFLINE", "TUNED_AS", "make", "Estimator", "StepResult",
           "NoStabilisingSolution", "GYRO", "KinematicGyro", "KinematicGyroSmoother",
           "Kinematic", "KinematicLowPass", "KinematicFeedForward", "KinematicPIF", "DFC",
           "UIO", "PIO", "PIF", "PIFRate", "PIFAdaptive", "PIFRateAdaptive", "PIFGated", "PIFSmoother",
           "Kalman", "KinematicSmoother", "with_online_offsets", "OnlineOffsets", "OffsetSettings",
           "AtSource", "GatedSmoother", "HandOver"]

"""Estimators for a log as every command builds them: the car a log is driven with, or the undescribed car.

A log whose car is not described is designed for one of the shipped passenger cars
(:data:`UNDESCRIBED_CARS`), the one that fits the log (:func:`design_car`): not one car's tyres
for every log. Without a log to look at, the car is :data:`roadbank.defaults.VEHICLE`.
"""

from __future__ import annotations

import functools
import math
from typing import cast

import numpy as np

from .. import defaults
from ..params import VehicleParams
from ..signals import Signals, sample_rate
from .conditions import (default_reads_roll_rate, design_span, esp_conditions, is_quiet, log_conditions,
                         make_estimator, quiet_noise_ratio, rear_trim_scales, source_rates)
from .file import load_vehicle, tuning_of
from .sensors import SensorSpec

__all__ = ["UNDESCRIBED_CARS", "CAR_MARGIN", "FIT_BAND_HZ", "undescribed_car", "undescribed_params", "design_car",
           "bank_band_power", "design_record", "car_for_log", "for_conditions", "for_log", "rear_trim", "described_car",
           "trims_rear"]

#: the shipped cars a log whose car is not described may be designed for: the range of passenger cars
UNDESCRIBED_CARS = ("suv-paper", "sedan", "compact", "van")
#: another car replaces :data:`roadbank.defaults.VEHICLE` only where its misfit (:func:`bank_band_power`)
#: is this many times smaller (-; chosen by the rule of :mod:`roadbank.tuning.real`, its eighth stage)
CAR_MARGIN = 1.25
#: band (Hz) of the default estimate whose power measures how badly a design car fits a log
FIT_BAND_HZ = (0.2, 3.0)
#: seconds at the start of the design span that the misfit leaves out (the filters settle)
FIT_SETTLE_S = 2.0
#: how :func:`design_record` names a car :func:`design_car` chose: by the misfits, or without a fit
FITTED, NOT_FITTED = "fitted to the log", "not fitted: the default reads the roll rate"
#: ... and where the user described it (a vehicle file, parameters given)
FROM_FILE, FROM_PARAMS = "vehicle file", "parameters given"


def is_described(design: dict) -> bool:
    """Whether the car of a log's :func:`design_record` ``design`` was described by the user (:data:`FROM_FILE`,
    :data:`FROM_PARAMS`), not chosen for the log."""
    return design.get("car_from") in (FROM_FILE, FROM_PARAMS)


@functools.lru_cache(maxsize=None)
def _car(name: str) -> VehicleParams:
    return load_vehicle(name).params


def undescribed_car(signals=None, margin: float = CAR_MARGIN, cond: dict | None = None) -> str:
    """The shipped car (its name) a log whose car is not described is designed for.

    Without ``signals`` (or with an infinite ``margin``): :data:`roadbank.defaults.VEHICLE` (the static
    rule). With the log's ``signals``: :func:`design_car` (``margin`` and ``cond`` as there).
    """
    if signals is None or margin == math.inf:
        return defaults.VEHICLE
    return design_car(signals, margin, cond)


def undescribed_params(signals=None, margin: float = CAR_MARGIN, cond: dict | None = None) -> VehicleParams:
    """The parameters of :func:`undescribed_car` (same arguments); immutable."""
    return _car(undescribed_car(signals, margin, cond))


def bank_band_power(signals, estimate) -> float:
    r"""Misfit (-, mean square of :math:`\sin\theta`) of a design car to a log: the mean square of the
    estimate's ``w`` (the estimator's :class:`~roadbank.signals.Estimate` over ``signals``) band-passed
    without phase over :data:`FIT_BAND_HZ`, on its valid samples after the first :data:`FIT_SETTLE_S`.

    The band-pass is applied in the frequency domain to the detrended series (samples in order, at the
    log's median rate; not-valid samples held at the last valid value), with the gain
    :math:`G = \frac{(f/f_1)^4}{1 + (f/f_1)^4} \frac{1}{1 + (f/f_2)^4}`: second-order Butterworth
    high- and low-passes run forward and backward, as :func:`roadbank.signals.road_noise_std` does.

    Roads bank and the body rolls slowly; a filter designed for the wrong car reads its model error at
    every yaw transient as bank (spikes at the steering ramps, docs/estimators.md), so the design that
    fits the car leaves the least power in this band. Infinite where fewer than 10 samples count.
    """
    rate = sample_rate(signals.t)
    lo, hi = FIT_BAND_HZ
    t = np.asarray(signals.t, dtype=np.float64)
    valid = np.asarray(estimate.valid, dtype=bool) & np.isfinite(estimate.w)
    m = valid & (t >= t[0] + FIT_SETTLE_S) if len(t) else np.zeros(0, bool)
    if not math.isfinite(rate) or m.sum() < 10:
        return math.inf
    w = np.asarray(estimate.w, dtype=np.float64)
    idx = np.maximum.accumulate(np.where(valid, np.arange(len(w)), 0))      # hold the last valid value
    w = np.where(valid[idx], w[idx], w[valid][0])
    k = np.arange(len(w))
    w = w - np.polyval(np.polyfit(k, w, 1), k)
    f = np.fft.rfftfreq(len(w), d=1.0 / rate)
    q = (f / lo) ** 4
    band = np.fft.irfft(np.fft.rfft(w) * q / (1.0 + q) / (1.0 + (f / hi) ** 4), len(w))
    return float(np.mean(band[m] ** 2))


def design_car(signals, margin: float = CAR_MARGIN, cond: dict | None = None) -> str:
    """The shipped car (a name of :data:`UNDESCRIBED_CARS`) that a log whose car is not described is
    designed for: identification from the log before filtering, on its ``ay``, yaw rate and speed.

    On the log's design span (its first minute of driving, :func:`~roadbank.vehicle.design_span`, the
    span its noise is measured on) the default estimator (:data:`roadbank.defaults.ESTIMATOR`) is built
    for each car and the log's conditions, as every command builds it, and run; the car with the lowest
    misfit (:func:`bank_band_power`) is chosen where it is ``margin`` times below that of
    :data:`roadbank.defaults.VEHICLE`, which is kept otherwise (and where the span tells nothing: every
    misfit infinite). On a loud log the default is the car-free low-pass almost throughout, the misfits
    are nearly equal and the static car stays. ``cond``: the log's :func:`log_conditions` where the caller has
    them (they are measured on this same span), else measured here. A roll rate in the log is left out: the car is
    for the estimators that model it. Where the default itself reads the roll rate
    (:func:`~roadbank.vehicle.conditions.default_reads_roll_rate`: a loud log) nothing is run and the static car
    stays: the gyro-aided default has no car model, and on a loud log the four misfits are within the margin
    (on the 16 KITTI drives and the comma2k19 segment within 7 % of the sedan's, docs/estimators.md), so the fit
    would only cost its four designs and runs (and, on a first run, the compilation of the ESP default's kernels).
    """
    power = _misfits(signals, {car: _car(car) for car in UNDESCRIBED_CARS}, cond)
    if power is None:
        return defaults.VEHICLE
    return _fits_better(power, defaults.VEHICLE, margin)


def _misfits(signals, cars: dict, cond: dict | None, build=None, sensors: SensorSpec | None = None,
             tuning=None) -> dict | None:
    """``{key: misfit}`` (:func:`bank_band_power`) of the default estimator built for each car of ``cars`` (key ->
    :class:`VehicleParams`) and the log's conditions (its ESP channels alone), run over the log's design span
    (:func:`~roadbank.vehicle.design_span`); inf for a design the conditions leave without a solution. None where the
    default reads the log's roll rate (it has no car model: nothing to fit). ``cond``: the log's conditions, measured
    on that span where None. ``sensors`` and ``tuning`` (a described car's :class:`SensorSpec` and ``[tuning]``
    tables; default the data sheet's sensors, no tables): the default is built with them, as :meth:`Vehicle.make`
    builds the estimator the log then gets. ``build`` (a car -> an estimator): a caller that builds its estimators its
    own way (the campaign: once per process, for its car's sensors and tuning at the data sheet's rate) builds these
    too; the log's conditions are then not read."""
    n = design_span(signals)
    span = signals[:n] if n < len(signals) else signals
    if build is None:
        if cond is None:
            cond = log_conditions(span)
        if default_reads_roll_rate(cond):
            return None
        esp = esp_conditions(cond)

        options = tuning_of(tuning or {}, defaults.ESTIMATOR)

        def build(car):
            return make_estimator(defaults.ESTIMATOR, car, sensors=sensors, **esp, **options)
    power = {}
    for key, car in cars.items():
        try:
            power[key] = bank_band_power(span, build(car).run(span))
        except ValueError:          # a design the log's conditions leave without a solution: not this car
            power[key] = math.inf
    return power


def _fits_better(power: dict, kept, margin: float):
    """The key of ``power`` (key -> misfit) with the lowest misfit where it is ``margin`` times below that of
    ``kept``, else ``kept`` (also where every misfit is infinite)."""
    best = min(power, key=lambda c: power[c])
    return best if power[best] * margin < power[kept] else kept


def rear_trim(signals, params: VehicleParams, margin: float = CAR_MARGIN, cond: dict | None = None,
              build=None, scales: tuple | None = None, sensors: SensorSpec | None = None, tuning=None) -> float:
    """The scale (-) of a described car's rear cornering stiffness ``params.Cr`` that a log is designed for: the
    undescribed car's rule (:func:`design_car`) over the scales of it that
    :data:`~roadbank.vehicle.conditions.REAR_TRIM` says (:func:`~roadbank.vehicle.conditions.rear_trim_scales`), the
    rest of ``params`` as described. The scale whose default estimate of the log's design span has the lowest
    misfit (:func:`bank_band_power`) where it is ``margin`` times below the described car's, else 1 (and 1 where the
    default reads the log's roll rate, or the trim is off).

    Real tyres are not their data sheet's: worn, at another pressure, on another load, a rear axle's stiffness is
    off by tens of per cent, and the modified model, which keeps only the rear tyres, reads the error at every
    yaw transient as bank (docs/campaign.md). ``cond``: as :func:`design_car`; ``build``, ``sensors`` and ``tuning``
    (the described car's, with which the trials are built): as :func:`_misfits`; ``scales``: those tried, default
    :func:`~roadbank.vehicle.conditions.rear_trim_scales` (the campaign's: its options')."""
    scales = rear_trim_scales() if scales is None else scales
    if not scales:
        return 1.0
    cars = {k: params.replace(Cr=params.Cr * k) if k != 1.0 else params for k in dict.fromkeys((*scales, 1.0))}
    power = _misfits(signals, cars, cond, build, sensors, tuning)
    return 1.0 if power is None else float(_fits_better(power, 1.0, margin))


def described_car(signals, params: VehicleParams, cond: dict | None = None, trim: bool = True,
                  sensors: SensorSpec | None = None, tuning=None) -> VehicleParams:
    """``params`` (a described car) with its rear cornering stiffness trimmed to the log ``signals``
    (:func:`rear_trim`; ``cond``, and the car's ``sensors`` and ``[tuning]`` tables ``tuning``, as there); ``params``
    itself where the scale is 1, or where ``trim`` is False (a stiffness measured on the car: :func:`trims_rear`)."""
    if not trim:
        return params
    k = rear_trim(signals, params, cond=cond, sensors=sensors, tuning=tuning)
    return params if k == 1.0 else params.replace(Cr=params.Cr * k)


def trims_rear(vehicle) -> bool:
    """Whether a described car's rear cornering stiffness is trimmed to each log (:func:`described_car`): always, but
    for a :class:`Vehicle` whose ``Cr`` was measured on the car (:attr:`Vehicle.rear_measured`: ``roadbank
    identify``'s, or a file's ``[identified.Cr]``), which is used as it is."""
    return vehicle is None or not vehicle.rear_measured


def design_record(cond: dict, car: str, car_from: str, sensors: SensorSpec | None = None,
                  sources: dict | None = None) -> dict:
    """What a log's estimators are designed for, to report: ``car`` (a name) and ``car_from`` (where it
    came from: :data:`FITTED`, :data:`NOT_FITTED`, "vehicle file", "parameters given"), ``quiet`` (bool,
    :func:`~roadbank.vehicle.is_quiet` with ``sensors``, default the data sheet's), ``ay_noise`` and
    ``ay_floor`` (m/s^2) from ``cond`` (:func:`~roadbank.vehicle.log_conditions`), and ``ay_floor_ratio``
    (-, :func:`~roadbank.vehicle.conditions.quiet_noise_ratio`: what ``quiet`` compares with
    :data:`~roadbank.vehicle.QUIET_RATIO`; NaN when not measured); where ``sources``
    (:func:`~roadbank.vehicle.conditions.source_rates`) names channels written faster than their sensor,
    ``source`` says which and at what rate their noise was read (e.g. ``"ay 10 Hz, r 10 Hz"``), unless the log was
    written by holding its sensors' frames (``log_held``): then ``held``, the rate (Hz) it is read at; ``roll_rate`` (-)
    where the log carries a roll rate: how it follows the roll in ``ay`` (``log_roll_rate``,
    :func:`~roadbank.vehicle.conditions.roll_rate_slope`; where usable, the default on a loud log is the gyro-aided
    filter); ``ax`` (-) where it carries a longitudinal acceleration: how it follows the speed (``log_ax``,
    :func:`~roadbank.vehicle.conditions.ax_slope`; where usable, that filter corrects the roll rate for the grade);
    ``roll_rate_unbiased`` (True) where that roll rate is documented free of offset (``log_gyro_unbiased``);
    ``pitch_rate`` (-) where it carries a pitch rate documented free of offset: how it follows the pitch
    (``log_pitch_rate``, :func:`~roadbank.vehicle.conditions.pitch_rate_slope`; where usable, that filter's pitch
    comes from it)."""
    sensors = sensors or SensorSpec()
    noise, floor = cond.get("log_ay_noise"), cond.get("log_ay_floor")
    ratio = quiet_noise_ratio(sensors, cond.get("log_rate"), noise, floor)
    record = {"car": car, "car_from": car_from, "quiet": bool(is_quiet(sensors, cond.get("log_rate"), noise,
                                                                       log_ay_floor=floor)),
              "ay_noise": noise, "ay_floor": floor, "ay_floor_ratio": float(f"{ratio:.3g}")}
    if cond.get("log_held"):        # read at its sensors' rate, where the noise was read too
        record["held"] = float(f"{cond['log_rate']:.3g}")
    elif sources:
        record["source"] = ", ".join(f"{ch} {hz:.3g} Hz" for ch, hz in sources.items())
    for key, name in (("log_roll_rate", "roll_rate"), ("log_ax", "ax"), ("log_pitch_rate", "pitch_rate")):
        if cond.get(key) is not None:
            record[name] = cond[key]
    if cond.get("log_gyro_unbiased"):
        record["roll_rate_unbiased"] = True
    return record


def car_for_log(signals, cond: dict, params: VehicleParams | None = None, vehicle=None,
                sensors: SensorSpec | None = None, trim: bool | None = None,
                tuning=None) -> tuple[VehicleParams, dict]:
    """The car a log's estimators are designed for, and its :func:`design_record` (``cond``: the log's
    :func:`log_conditions`): ``vehicle``'s (a :class:`Vehicle`), else ``params`` (with ``sensors`` and the ``[tuning]``
    tables ``tuning``), each with its rear cornering stiffness trimmed to the log (:func:`described_car`, its trials
    built with that car's sensors and tuning; the record's ``rear_trim``, the scale, where
    it is not 1) unless ``trim`` is False (default: :func:`trims_rear` of ``vehicle``; the record's ``rear_measured``
    where the vehicle's was measured), else :func:`undescribed_car` of the log's ``signals`` (the one that fits it)."""
    sources = source_rates(signals)
    if vehicle is not None or params is not None:
        given = vehicle.params if vehicle is not None else cast(VehicleParams, params)
        if vehicle is not None:
            sensors, tuning = vehicle.sensors, vehicle.tuning
        car = described_car(signals, given, cond, trims_rear(vehicle) if trim is None else trim, sensors, tuning)
        record = (design_record(cond, vehicle.name, FROM_FILE, vehicle.sensors, sources) if vehicle is not None
                  else design_record(cond, "-", FROM_PARAMS, sensors, sources))
        if car is not given:
            record["rear_trim"] = float(f"{car.Cr / given.Cr:.3g}")
        elif vehicle is not None and vehicle.rear_measured:
            record["rear_measured"] = True
        return car, record
    name = undescribed_car(signals, cond=cond)
    how = NOT_FITTED if default_reads_roll_rate(cond) else FITTED
    return _car(name), design_record(cond, name, how, sources=sources)


def for_conditions(name: str, cond: dict, params: VehicleParams | None = None, *, vehicle=None,
                   described: bool | None = None, **tuning):
    """Build the estimator ``name`` for a log's conditions ``cond`` (:func:`log_conditions`).

    The car is ``vehicle`` (a :class:`Vehicle`: its parameters, sensors and tuning tables; with ``params`` too, those
    in place of its own: the car :func:`car_for_log` trimmed to the log) or
    ``params`` with the data sheet's sensors; neither: :func:`undescribed_params` without a log
    (the callers that have the log pass ``undescribed_params(signals)`` as ``params``, and ``described=False``: a car
    nobody described, :data:`~roadbank.vehicle.conditions.UNDESCRIBED_KEEPS_MODEL`; default: described where
    ``vehicle`` or ``params`` is given). What ``roadbank estimate``, ``map`` and :func:`for_log` build.
    """
    if vehicle is not None:
        if params is not None and params != vehicle.params:     # its car trimmed to the log (car_for_log)
            vehicle = vehicle.replace(params=params)
        return vehicle.make(name, **cond, **tuning)
    if described is None:
        described = params is not None
    return make_estimator(name, params if params is not None else undescribed_params(), described=described, **cond,
                          **tuning)


def for_log(name: str, signals, params: VehicleParams | None = None, *, vehicle=None, described: bool | None = None,
            **tuning):
    """Build the estimator ``name`` for the log ``signals`` as ``roadbank estimate`` does.

    A default-tuned PIF is designed for the log's sample rate and the road noise measured on
    its ``ay`` and yaw rate (:func:`log_conditions`); the car as :func:`for_conditions`, a car that is
    not described chosen for the log (:func:`undescribed_params` of ``signals``), a car described with its rear
    cornering stiffness trimmed to the log (:func:`described_car`; a vehicle's measured one kept,
    :func:`trims_rear`). ``for_log(name, s).run(s)`` is what the command
    line writes for the log ``s`` with ``--no-online-offsets``; by default it adds the online offset learner
    (``with_online_offsets(for_log(name, s), est.params).run(s)``), which differs after a standstill.
    ``described`` (default: whether ``params`` or ``vehicle`` is given): True reads the car chosen for the log as one
    described (:func:`for_conditions`).
    """
    if not isinstance(signals, Signals):
        raise TypeError(f"for_log() expects a roadbank.Signals, got {type(signals).__name__}")
    cond = log_conditions(signals)
    if described is None:
        described = params is not None or vehicle is not None
    if params is None and vehicle is None:
        params = undescribed_params(signals, cond=cond)
    else:       # a car described: its rear stiffness trimmed to the log, as car_for_log does
        on_car = (vehicle.sensors, vehicle.tuning) if vehicle is not None else (None, None)
        params = described_car(signals, params if params is not None else vehicle.params, cond, trims_rear(vehicle),
                               *on_car)
    return for_conditions(name, cond, params, vehicle=vehicle, described=described, **tuning)

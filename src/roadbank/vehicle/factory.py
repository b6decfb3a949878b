"""Estimators for a log as every command builds them: the car a log is driven with, or the undescribed car."""

from __future__ import annotations

import functools

from .. import defaults
from ..params import VehicleParams
from .conditions import log_conditions, make_estimator
from .file import load_vehicle

__all__ = ["undescribed_params", "for_conditions", "for_log"]


@functools.lru_cache(maxsize=1)
def undescribed_params() -> VehicleParams:
    """The car parameters for a log whose car is not described (:data:`roadbank.defaults.VEHICLE`;
    read once, the parameters are immutable)."""
    return load_vehicle(defaults.VEHICLE).params


def for_conditions(name: str, cond: dict, params: VehicleParams | None = None, *, vehicle=None, **tuning):
    """Build the estimator ``name`` for a log's conditions ``cond`` (:func:`log_conditions`).

    The car is ``vehicle`` (a :class:`Vehicle`: its parameters, sensors and tuning tables) or
    ``params`` with the data sheet's sensors; neither: the car for a log whose car is not
    described (:func:`undescribed_params`). What ``roadbank estimate``, ``map`` and
    :func:`for_log` build.
    """
    if vehicle is not None:
        return vehicle.make(name, **cond, **tuning)
    return make_estimator(name, params if params is not None else undescribed_params(), **cond, **tuning)


def for_log(name: str, signals, params: VehicleParams | None = None, *, vehicle=None, **tuning):
    """Build the estimator ``name`` for the log ``signals`` as ``roadbank estimate`` does.

    A default-tuned PIF is designed for the log's sample rate and the road noise measured on
    its ``ay`` and yaw rate (:func:`log_conditions`); the car as :func:`for_conditions`.
    ``for_log(name, s).run(s)`` is what the command line writes for the log ``s``.
    """
    return for_conditions(name, log_conditions(signals), params, vehicle=vehicle, **tuning)

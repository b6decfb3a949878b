"""roadbank: road bank angle estimation from ESP signals.

Data path: parameters (:mod:`roadbank.params`) -> models (:mod:`roadbank.models`)
-> estimators (:mod:`roadbank.estimators`) -> evaluation (:mod:`roadbank.evaluation`)
-> report (:mod:`roadbank.report`); the simulator (:mod:`roadbank.sim`) and the
log readers (:mod:`roadbank.io`) produce the :class:`Signals` the estimators eat.
"""

from .params import G, VehicleParams
from .signals import Estimate, Signals, road_wheel_angle

__all__ = ["G", "VehicleParams", "Signals", "Estimate", "road_wheel_angle"]
__version__ = "0.1.0"

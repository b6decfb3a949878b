"""roadbank: road bank angle estimation from ESP signals.

Data path: parameters (:mod:`roadbank.params`) -> models (:mod:`roadbank.models`)
-> estimators (:mod:`roadbank.estimators`) -> evaluation (:mod:`roadbank.evaluation`)
-> report (:mod:`roadbank.report`); the simulator (:mod:`roadbank.sim`) and the
log readers (:mod:`roadbank.io`) produce the :class:`Signals` the estimators eat.

The top-level names are imported on first use, so ``import roadbank.cli`` can
configure the process (BLAS threads) before numpy loads.
"""

import importlib

_EXPORTS = {"G": "params", "VehicleParams": "params", "Signals": "signals", "Estimate": "signals",
            "road_wheel_angle": "signals"}

__all__ = list(_EXPORTS)
__version__ = "0.1.0"


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module 'roadbank' has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + __all__)

"""roadbank: road bank angle estimation from ESP signals.

Data path: parameters (:mod:`roadbank.params`) -> models (:mod:`roadbank.models`)
-> estimators (:mod:`roadbank.estimators`) -> evaluation (:mod:`roadbank.evaluation`)
-> report (:mod:`roadbank.report`); the simulator (:mod:`roadbank.sim`) and the
log readers (:mod:`roadbank.io`) produce the :class:`Signals` the estimators eat.

The top-level names and the public submodules are imported on first use
(``roadbank.vehicle.load_vehicle("sedan")`` works after a bare ``import roadbank``),
so ``import roadbank`` stays fast and ``import roadbank.cli`` can configure the
process (BLAS threads) before numpy loads.
"""

import importlib

_EXPORTS = {"G": "constants", "VehicleParams": "params", "Signals": "signals", "Estimate": "signals",
            "road_wheel_angle": "signals"}
#: public submodules, imported when first used as an attribute of the package
SUBMODULES = ("bench", "cache", "campaign", "constants", "estimators", "evaluation", "export", "faults", "fleet",
              "identification", "io", "mapping", "models", "params", "report", "signals", "sim", "tuning",
              "units", "validation", "vehicle")

__all__ = list(_EXPORTS) + list(SUBMODULES)
__version__ = "0.1.0"


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    if name in SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'roadbank' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))

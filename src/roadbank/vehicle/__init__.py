"""Vehicles: a car's parameters, sensors and estimator tuning in one TOML file, and the estimators for its logs.

A :class:`Vehicle` holds everything roadbank needs to know about one car:

* ``params`` -- the :class:`~roadbank.params.VehicleParams` (bicycle model, roll data, geometry),
* ``sensors`` -- its ESP cluster (:class:`SensorSpec`: rate, noise, resolution, range),
* ``plant`` -- optional simulator-only data (drive/brake limits, drag; see :class:`PlantParams`),
* ``tuning`` -- keyword options per estimator (``estimators.make(name, params, **tuning[name])``),
* ``scores`` / ``identified`` -- what ``roadbank tune`` / ``roadbank identify`` found.

It is read from and written to TOML (format reference: ``docs/vehicles.md``)::

    [meta]
    name = "sedan"
    description = "BMW 320i (CommonRoad vehicle 2)"
    sources = ["Althoff & Wuersching, CommonRoad: Vehicle Models, 2020"]

    [vehicle]            # SI numbers, or "value unit" strings ("1093 kg", "128 kN/rad")
    m = 1093.3
    Iz = "1791.6 kg m^2"
    ...
    [sensors]
    r_resolution = "0.3 deg/s"
    [tuning.pif-modified]
    Q = 30.0
    th = 0.5

Every problem in a file -- TOML syntax, an unknown table or key (with the close
match), a wrong type, an unknown or incompatible unit, an impossible or
implausible value, an unknown estimator or tuning option -- raises
:class:`VehicleFileError` naming the file and the key.

``load_vehicle(None)`` is the paper's SUV; ``load_vehicle("sedan")`` a shipped car
(:data:`BUILTINS`); ``load_vehicle("car.toml")`` a file.

The package, one job a module (every name below is importable from ``roadbank.vehicle``):

* :mod:`~roadbank.vehicle.file` -- the vehicle file format: :class:`Vehicle`, reading and
  writing TOML, the shipped cars (:func:`load_vehicle`, :func:`builtin_names`);
* :mod:`~roadbank.vehicle.sensors` -- :class:`SensorSpec`, the ESP sensor cluster;
* :mod:`~roadbank.vehicle.plausibility` -- the keys of each table, their dimension and plausible
  range (:data:`PLAUSIBLE`, :data:`SENSOR_FIELDS`, :data:`PLANT_FIELDS`) and the checks;
* :mod:`~roadbank.vehicle.conditions` -- what a log tells the design (:func:`log_conditions`), the
  sensor-noise rule (:func:`noise_densities`) and :func:`make_estimator`;
* :mod:`~roadbank.vehicle.factory` -- the estimator for a log as every command builds it
  (:func:`for_log`, :func:`for_conditions`) and the car of a log whose car is not described
  (:func:`undescribed_params`, :func:`design_car`: the shipped car that fits the log);
* :mod:`~roadbank.vehicle.errors`, :mod:`~roadbank.vehicle.tomltext` -- :class:`VehicleFileError`;
  TOML text of values.

Units (``"value unit"`` strings, :func:`parse_quantity`) are :mod:`roadbank.units`, the one
table of units the log readers use too.
"""

from __future__ import annotations

from ..units import SI_UNIT, UNITS, parse_quantity
from .conditions import (DESIGN_MAX_S, DESIGN_SPAN_S, QUIET_FILTER, QUIET_RATIO, default_reads_roll_rate, design_span,
                         has_design_span, is_quiet, log_conditions, make_estimator, noise_densities)
from .errors import VehicleFileError
from .factory import (CAR_MARGIN, UNDESCRIBED_CARS, bank_band_power, car_for_log, design_car, design_record,
                      for_conditions, for_log, undescribed_car, undescribed_params, rear_trim,
                      described_car, trims_rear)
from .file import (BUILTINS, DEFAULT_VEHICLE, META_KEYS, OFFSET_CHANNELS, REQUIRED_VEHICLE_KEYS, TABLES, Vehicle,
                   builtin_names, load_vehicle, tuning_of)
from .plausibility import PLANT_FIELDS, PLAUSIBLE, SENSOR_FIELDS, WHEELBASE_RANGE
from .sensors import SensorSpec

__all__ = ["Vehicle", "SensorSpec", "VehicleFileError", "load_vehicle", "builtin_names", "BUILTINS",
           "UNITS", "PLAUSIBLE", "parse_quantity",
           # the rest of the package's public names
           "SI_UNIT", "DEFAULT_VEHICLE", "TABLES", "META_KEYS", "REQUIRED_VEHICLE_KEYS", "OFFSET_CHANNELS",
           "WHEELBASE_RANGE", "SENSOR_FIELDS", "PLANT_FIELDS", "DESIGN_SPAN_S", "DESIGN_MAX_S", "design_span",
           "has_design_span", "log_conditions", "noise_densities", "QUIET_RATIO",
           "QUIET_FILTER", "is_quiet", "make_estimator", "for_conditions", "for_log", "rear_trim",
           "described_car", "trims_rear", "tuning_of", "undescribed_car",
           "undescribed_params", "UNDESCRIBED_CARS", "CAR_MARGIN", "design_car", "design_record", "car_for_log",
           "bank_band_power", "default_reads_roll_rate"]

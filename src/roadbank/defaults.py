"""What roadbank assumes when the user says nothing (no import cost: plain constants).

* :data:`ESTIMATOR` — the estimator of every command (``estimate``, ``map`` streams, the fleet) and
  of :func:`roadbank.estimators.for_log` when none is named: ``kinematic-ff``, the best by a rule
  written before measuring, on training data only (the KITTI training drives and simulated drives
  of cars that are not described; docs/estimators.md, :mod:`roadbank.tuning.real`). It uses no tyre
  data, so it does not rest on one car.
* A log whose car is not described: the estimators that need a car model are designed for the
  paper's SUV (:class:`roadbank.params.VehicleParams` defaults, shipped as ``suv-paper``) in every
  command and in the Python API; ``--vehicle`` / a :class:`roadbank.vehicle.Vehicle` replaces it.
"""

#: name of the default estimator
ESTIMATOR = "kinematic-ff"
#: shipped vehicle that stands for a car nobody described
VEHICLE = "suv-paper"

"""What roadbank assumes when the user says nothing (no import cost: plain constants).

* :data:`ESTIMATOR` — the estimator of every command (``estimate``, ``map`` streams, the fleet) when
  none is named (``roadbank.vehicle.for_log(ESTIMATOR, signals)`` builds it as they do):
  ``kinematic-pif`` (``kinematic-ff``, handed to the default PIF while the yaw rate changes fast), chosen
  on training data only by the real-roads-first rule of :mod:`roadbank.tuning.real` (the KITTI training
  drives first, the simulated drives of cars that are not described to break ties; docs/estimators.md). Its
  low-pass uses no tyre data. On a quiet log of a car described (a vehicle file, parameters given) it is
  ``pif-adaptive`` (:func:`roadbank.vehicle.is_quiet`; a car nobody described keeps the blend: the sixty-second
  stage of :mod:`roadbank.tuning.real`); on a
  loud log that carries a roll rate it is ``kinematic-gyro`` (the complementary filter of the kinematic estimate and
  the roll-rate gyro; :data:`roadbank.vehicle.conditions.GYRO_FILTER`).
* :data:`MAP_ESTIMATOR` — the estimator of ``roadbank map`` (a map is built after the drives, so it
  may use the samples after each instant): ``kinematic-smoother``, the kinematic estimate low-passed
  forward and backward; on a quiet log of a car described (a vehicle file) ``pif-smoother``.
* :data:`VEHICLE` — a log whose car is not described: the estimators that need a car model are
  designed for the parameters of this shipped car (with the data sheet's ESP sensors) in every
  command that reads logs (``estimate``, ``map``, ``validate``) and in
  :func:`roadbank.vehicle.for_log`, unless another shipped car fits the log clearly better
  (:func:`roadbank.vehicle.design_car`; :func:`roadbank.vehicle.undescribed_params`). Chosen by a
  rule on training data: of the four shipped cars, the design car with the lowest objective of
  the default-tuned PIF (median raw error on the KITTI training drives + median over the four
  plant cars of the simulated training drives; docs/estimators.md). ``--vehicle`` / a
  :class:`roadbank.vehicle.Vehicle` replaces it. (:func:`roadbank.estimators.make` without
  parameters builds the paper's SUV, the car of the paper's study.)
"""

#: name of the default estimator
ESTIMATOR = "kinematic-pif"
#: name of the estimator of ``roadbank map`` (offline): chosen among the offline estimators by the same
#: real-roads-first rule on training data (:mod:`roadbank.tuning.real`, docs/estimators.md)
MAP_ESTIMATOR = "kinematic-smoother"
#: shipped vehicle whose parameters stand for a car nobody described
VEHICLE = "sedan"

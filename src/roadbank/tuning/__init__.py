"""Automatic tuning of the estimators on randomised simulated drives (``roadbank tune``).

Modules: :mod:`.manoeuvres` (training and validation drive sets), :mod:`.objective`
(what is minimised), :mod:`.spaces` (which options vary), :mod:`.optimise` (differential
evolution, local or Dask workers), :mod:`.pipeline` (:func:`tune_car`, the whole run),
:mod:`.real` (the rules that chose the defaults on real and simulated training drives),
:mod:`.simulated` and :mod:`.simulated_report` (``roadbank validate sim``: the simulated
validation set, car known and not described).
"""

from .manoeuvres import TRAIN_ROADS, VALIDATION_ROADS, Drive, drive_set
from .objective import SetScores, objective_value, score_set
from .optimise import INFEASIBLE, Objective, TuneResult, register_drives, tune_estimator
from .pipeline import DEFAULT_BUDGET, TuningOutcome, tune_car
from .spaces import TUNABLE, SearchSpace, search_space

__all__ = ["TRAIN_ROADS", "VALIDATION_ROADS", "Drive", "drive_set", "SetScores", "objective_value", "score_set",
           "INFEASIBLE", "Objective", "TuneResult", "register_drives", "tune_estimator", "DEFAULT_BUDGET",
           "TuningOutcome", "tune_car", "TUNABLE", "SearchSpace", "search_space"]

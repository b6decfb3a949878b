"""Physical constants roadbank uses, each defined once (SI).

Every module that needs gravity imports :data:`G` from here (or its re-export
``roadbank.G`` / :data:`roadbank.params.G`), so a change of the value reaches the
models, the estimators, the simulator, the unit ``g`` of the log and vehicle-file
readers and the plausibility checks alike.
"""

from __future__ import annotations

#: Standard gravity used throughout roadbank (m/s^2). The DFC gain checks in
#: tests/test_models.py (Haw0 = 4.4647 at 22.2 m/s) use 9.81.
G = 9.81

#: Largest magnitude a passenger car's lateral acceleration (m/s^2; 3 g, beyond the tyres' grip with any bank and
#: roll; an ESP sensor's range is about 2 g), yaw rate (rad/s; 5, beyond a spin; an ESP sensor's range is 1.7-2.6) and
#: speed (m/s) can have: a sample beyond them is a glitch (a CAN value of all ones, a bit error), which the log
#: readers read as a dropout and every estimator, in Python and in C, holds as it holds a NaN.
AY_MAX = 3.0 * G
YAW_RATE_MAX = 5.0
SPEED_MAX = 120.0

#: Plausible steering ratio of a road vehicle (steering-wheel angle per road-wheel angle, -): a vehicle file, a
#: channel map's ``steering_ratio`` and ``--steering-ratio`` outside it are refused (a unit or typing mistake).
STEERING_RATIO_RANGE = (5.0, 30.0)

#: Longest interval (s) between two samples the estimators integrate over; after a longer one they start again from
#: the next sample (the default ``max_gap`` of every estimator), and the noise design counts it as no time.
MAX_GAP_S = 1.0

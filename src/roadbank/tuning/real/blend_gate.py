"""The sixty-sixth stage: the lowest speed of the causal blend's gate (docs/estimators.md).

The default ``kinematic-pif`` on a log without a usable roll rate is the low-pass blend: the low-passed kinematic
estimate, moved to the PIF (the car's model) while the yaw part of the lateral jerk ``vx |r'|`` ramps its gate open.
The sixty-fifth stage found the map smoother's gate opening on tight turns at 4-14 m/s (yaw rate up to 40 deg/s), where
the model of a car nobody described errs by 1.5-2.5 deg and the low-passed kinematic estimate by 0.3-0.5; the causal
gate reads the same measure. Candidates (:data:`roadbank.vehicle.conditions.BLEND_GATE_V_MIN`): the blend's gate
measure counts only at ``vx >=`` each of :data:`BLEND_GATE_SPEEDS` (m/s; 0, the first, shipped).

Sets (training only), ``kinematic-pif`` as ``roadbank estimate`` builds it without a vehicle file (``described=False``),
behind the online offset learner: (1) the eight KITTI training drives with their ESP channels as recorded, whole and
cut into 8, 12 and 20 s pieces (:func:`~.common.whole_and_pieces`), raw RMS of theta against the INS roll on the
scored samples; (2) each shipped car's 24 ``roadbank tune`` training drives on the data sheet's sensors (quiet: a car
nobody described, designed loud since the sixty-second stage), and (3) the same drives with
:data:`~.roads.BACK_LOUD_AY` m/s^2 of white noise on ``ay`` (:func:`~.offline.shaken_sets`), bank RMS as ``roadbank
tune`` scores it. Scores per candidate: the real one, the mean over the four lengths (whole, 8, 12, 20 s) of the mean
raw RMS over the drives or pieces (a mean: the cost is a tail over drives); the median over the cars of each car's
median over (2) and (3) pooled; the 95th percentile over every simulated drive. Rule: among the candidates whose
simulated 95th percentile is not above the shipped one's by more than :data:`BLEND_GATE_TAIL_LOSS` of it and whose
median over the cars is not above the shipped one's by more than :data:`BLEND_GATE_SIM_LOSS_DEG`, the lowest real
score wins, ties within :data:`~.common.TIE_DEG` going to the lower speed.
"""

from __future__ import annotations

import numpy as np

from ...estimators.offsets import with_online_offsets
from .common import cars_median, log_errors, per_log, sim_errors
from .offline import lowest_eligible
from .roads import _in_force

#: the candidates (m/s), the shipped first
BLEND_GATE_SPEEDS = (0.0, 10.0, 15.0, 20.0)
#: the rule: a candidate is eligible where its simulated 95th percentile is not above the shipped one's by more than
#: this share (-) ...
BLEND_GATE_TAIL_LOSS = 0.10
#: ... and its median over the cars not above the shipped one's by more than this (deg)
BLEND_GATE_SIM_LOSS_DEG = 0.01


def choose_blend_gate_speed(parts, sim_sets, shaken, speeds=BLEND_GATE_SPEEDS) -> tuple:
    """The sixty-sixth stage (module docstring). ``parts``: set (1) as :func:`~.common.whole_and_pieces` gives it
    (the drives whole, then their pieces of each length); ``sim_sets``: set (2), per shipped car
    (:data:`~.common.SIM_CARS`); ``shaken``: set (3). Returns ``(chosen speed, {speed: (real score, sims median, sims
    p95)}, {speed: (raw RMS per log of each part, per car: bank RMS per drive, plain then shaken)})``."""
    build = per_log("kinematic-pif", described=False)

    def online(s):
        return with_online_offsets(build(s))

    def measure():
        real = [log_errors(online, part) for part in parts]
        pooled = [list(a) + list(b) for a, b in zip(sim_errors(online, sim_sets), sim_errors(online, shaken))]
        return real, pooled

    errs = {v: _in_force("blend_gate_v_min", v, measure) for v in speeds}
    scores = {v: (float(np.mean([np.mean(e) for e in real])), cars_median(pooled),
                  float(np.percentile(np.concatenate(pooled), 95))) for v, (real, pooled) in errs.items()}
    return lowest_eligible(scores, speeds, BLEND_GATE_TAIL_LOSS, BLEND_GATE_SIM_LOSS_DEG), scores, errs


__all__ = ["BLEND_GATE_SPEEDS", "BLEND_GATE_TAIL_LOSS", "BLEND_GATE_SIM_LOSS_DEG", "choose_blend_gate_speed"]

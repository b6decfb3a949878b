r"""Kinematic estimate (paper eq 9): :math:`\hat w_v = (a_y - v_x r)/g`.

Exact only when :math:`\dot v_y = 0`; the baseline every other method improves
on. No state: the output is a direct function of the current sample. It holds at any speed (a
car at rest on a bank reads :math:`a_y = g \sin\theta`), so the kinematic estimators run down to
:data:`KINEMATIC_V_MIN`, not to the model-based filters' 5 m/s.
"""

from __future__ import annotations

import numpy as np

from .base import DesignInputs, ScheduledObserver

#: lowest speed (m/s) of the kinematic estimators (``kinematic``, ``kinematic-lp``, ``kinematic-ff``
#: and the blend of ``kinematic-pif``): the value the fifth stage of :mod:`roadbank.tuning.real` chose
#: for ``kinematic-pif``, where it matters most (a low-pass that stops at 5 m/s starts again from
#: one noisy sample each time the car pulls away)
KINEMATIC_V_MIN = 1.0


def kinematic_observer(d: DesignInputs, vx: float):
    """``(F, G, H, D)`` of the kinematic estimate at ``vx`` (m/s): no state, ``D = [0, 1/g, -vx/g]``."""
    g = d.params.g
    return np.zeros((0, 0)), np.zeros((0, 3)), np.zeros((1, 0)), np.array([[0.0, 1.0 / g, -vx / g]])


class Kinematic(ScheduledObserver):
    """``w = (ay - vx r) / g`` sample by sample (no filtering)."""

    name = "kinematic"
    uses = (False, True, True)
    default_v_min = KINEMATIC_V_MIN

    def observer(self, vx: float):
        """``(F, G, H, D)`` of the kinematic estimate at ``vx`` (m/s): no states, ``w = (ay - vx r) / g``."""
        return kinematic_observer(self.design, vx)

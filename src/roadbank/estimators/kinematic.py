r"""Kinematic estimate (paper eq 9): :math:`\hat w_v = (a_y - v_x r)/g`.

Exact only when :math:`\dot v_y = 0`; the baseline every other method improves
on. No state: the output is a direct function of the current sample.
"""

from __future__ import annotations

import numpy as np

from .base import DesignInputs, ScheduledObserver


def kinematic_observer(d: DesignInputs, vx: float):
    """``(F, G, H, D)`` of the kinematic estimate at ``vx`` (m/s): no state, ``D = [0, 1/g, -vx/g]``."""
    g = d.params.g
    return np.zeros((0, 0)), np.zeros((0, 3)), np.zeros((1, 0)), np.array([[0.0, 1.0 / g, -vx / g]])


class Kinematic(ScheduledObserver):
    """``w = (ay - vx r) / g`` sample by sample (no filtering)."""

    name = "kinematic"
    uses = (False, True, True)

    def observer(self, vx: float):
        return kinematic_observer(self.design, vx)

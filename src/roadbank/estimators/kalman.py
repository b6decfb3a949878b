r"""Kalman baseline: a Kalman-Bucy filter on the original bicycle model
augmented with ``w`` as a random walk — the standard approach of the
literature and of production stacks, a peer to beat, not the paper's method.

States ``[vy, r, w]``, input ``delta_f``, outputs ``[ay, r]``. Process noise
spectral densities ``q = (q_vy, q_r, q_w)`` cover model error on the two
dynamic states and the bank rate; measurement noise ``R = diag(r_ay, r_r)``
matches the ESP sensors (ay ~ 0.1 m/s^2, r ~ 0.005 rad/s rms). The steady-state
gain (algebraic Riccati equation per speed, the H-infinity ARE with ``th = 0``)
is scheduled on speed. Default ``q`` chosen by a sweep over the paper's
scenarios on our plant (mean bank RMS over the 17 cells 2.7 deg, against 10.3
deg for q = (0.5^2, 0.05^2, 0.1^2), which fails on the low-mu banked road):
large model-error noise on vy and r, because the original model's front tyre
is often far from its linear range.
"""

from __future__ import annotations

import numpy as np

from dataclasses import dataclass
from typing import TYPE_CHECKING

from . import grid_design
from .base import DesignInputs, ScheduledObserver, augmented_design_model, frozen_array
from .synthesis import game_are

DEFAULT_Q = (4.0**2, 0.4**2, 0.3**2)
DEFAULT_R = (0.1**2, 0.005**2)


@dataclass(frozen=True)
class KalmanDesign(DesignInputs):
    """Design inputs of :class:`Kalman`: the process-noise densities ``q`` and the diagonal ``R`` of
    the measurement-noise densities (units as :class:`Kalman`'s parameters)."""

    q: tuple
    R: tuple


def kalman_observer(d: KalmanDesign, vx: float):
    """``(F, G, H, D)`` of the steady-state Kalman filter at ``vx`` (m/s)."""
    Rm = np.diag(np.asarray(d.R, dtype=float))
    A, B, C, Dy, Lw, _ = augmented_design_model(d.params, vx, "original")
    P = game_are(A, C, Lw, np.diag(np.asarray(d.q, dtype=float)), Rm, np.eye(1), 0.0,
                 where=f"at vx={vx:.2f} m/s (kalman)")
    Kg = P @ C.T @ np.linalg.inv(Rm)
    return A - Kg @ C, B + Kg @ Dy, Lw, np.zeros((1, 3))


class Kalman(ScheduledObserver):
    """Steady-state Kalman filter on the augmented original model.

    Parameters
    ----------
    q : 3 floats
        Process-noise spectral densities of vy ((m/s^2)^2 s), r ((rad/s^2)^2 s)
        and w (1/s).
    R : 2 floats
        Measurement-noise variances x sample time of ay ((m/s^2)^2 s) and r
        ((rad/s)^2 s).
    """

    name = "kalman"
    uses = (True, True, True)
    state_names = ("vy", "r", "w")
    design_type = KalmanDesign
    if TYPE_CHECKING:
        @property
        def design(self) -> KalmanDesign: ...     # an instance of design_type

    def __init__(self, params=None, *, q=DEFAULT_Q, R=DEFAULT_R, **kw):
        self.q = np.asarray(q, float)
        self.Rm = np.diag(np.asarray(R, float))
        if self.q.shape != (3,) or np.any(self.q < 0) or np.any(np.diag(self.Rm) <= 0):
            raise ValueError("kalman: q must be 3 values >= 0 and R 2 values > 0")
        super().__init__(params, **kw)

    def _design_fields(self) -> dict:
        return dict(q=frozen_array(self.q), R=frozen_array(np.diag(self.Rm)))

    def _grid_design(self):
        """The whole grid at once where the observer is this class's own."""
        return grid_design.kalman_speed(self) if type(self).observer is Kalman.observer else None

    def observer(self, vx: float):
        """``(F, G, H, D)`` at ``vx`` (m/s) (:func:`kalman_observer`)."""
        return kalman_observer(self.design, vx)

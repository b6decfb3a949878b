r"""The kinematic estimate through a causal first-order low-pass (``kinematic-lp``, ``kinematic-ff``).

On real roads the lateral accelerometer carries far more than a data sheet says: road
vibration, aliased into a 10 Hz log, of 0.1-0.35 m/s^2 above 1 Hz on the shared KITTI
drives, while the sideslip acceleration :math:`\dot v_y` that the kinematic estimate
(paper eq 9) neglects is a few hundredths of that in ordinary driving. Smoothing the
kinematic estimate is then the estimator to beat; ``kinematic-lp`` is it:

.. math::
    \tau \dot x = -x + \frac{a_y - v_x r}{g}, \qquad \hat w = x, \qquad \tau = \frac{1}{2\pi f_c}

``kinematic-ff`` keeps the part of :math:`\theta` that follows the centripetal acceleration
out of the low-pass, so that it has no lag: body roll (the sprung mass rolls out of the
turn, in proportion to the lateral acceleration) and the superelevation that roads build
into curves both move with :math:`v_x r`, which the yaw-rate gyro measures almost without
noise. With :math:`a = v_x r / g` and a gain :math:`\kappa` (-, ``w`` per g of centripetal
acceleration):

.. math::
    \tau \dot x = -x + \frac{a_y - v_x r}{g} - \kappa a, \qquad \hat w = x + \kappa a

Both are linear, scheduled on speed (``lpv`` kernel: fixed-rate tables, ``step()``, the C
export); they read ``ay``, ``r`` and ``vx`` only. :math:`f_c` and :math:`\kappa` were chosen
by a written rule on training data only — the KITTI training drives and ``roadbank tune``'s
simulated training drives of the four shipped cars, built without the car
(:func:`roadbank.tuning.real.choose_lowpass`, docs/estimators.md): they describe roads and
passenger cars, not one car's tyres. In a steady turn the feed-forward cancels
(:math:`\hat w` = the low-passed kinematic estimate); it acts only while :math:`v_x r` changes,
as a lead :math:`\kappa\, \tau s/(\tau s + 1)\, a`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import DesignInputs, ScheduledObserver

#: ``kinematic-lp``'s cut-off (Hz): the rule of :mod:`roadbank.tuning.real` with kappa = 0
LP_CUTOFF_HZ = 0.5
#: ``kinematic-ff``'s cut-off (Hz) and centripetal gain (-): the rule of :mod:`roadbank.tuning.real`
FF_CUTOFF_HZ = 0.6
FF_KAPPA = 0.2


@dataclass(frozen=True)
class LowPassDesign(DesignInputs):
    """Design inputs of :class:`KinematicLowPass`: the cut-off ``cutoff`` (Hz) and the centripetal
    feed-forward gain ``kappa`` (-)."""

    cutoff: float
    kappa: float


def lowpass_observer(d: LowPassDesign, vx: float):
    """``(F, G, H, D)`` of the low-passed kinematic estimate at ``vx`` (m/s); inputs ``[delta_f, ay, r]``."""
    g, wc, k = d.params.g, 2.0 * np.pi * d.cutoff, d.kappa
    F = np.array([[-wc]])
    G = np.array([[0.0, wc / g, -wc * (1.0 + k) * vx / g]])
    return F, G, np.array([[1.0]]), np.array([[0.0, 0.0, k * vx / g]])


class KinematicLowPass(ScheduledObserver):
    """The kinematic estimate low-passed, optionally with the centripetal feed-forward (module docstring).

    Parameters
    ----------
    params : VehicleParams, optional
        Only ``g`` and the roll model (for ``phi_b``) are used.
    cutoff : float, optional
        Cut-off frequency ``f_c`` of the first-order low-pass (Hz, > 0).
    kappa : float, optional
        Centripetal feed-forward gain (-: ``w`` per g of ``vx r``); 0 gives ``kinematic-lp``.
    **kw
        Common options of :class:`~roadbank.estimators.base.Estimator`.
    """

    uses = (False, True, True)
    state_names = ("w_lp",)
    label = "kinematic-lp"
    defaults = dict(cutoff=LP_CUTOFF_HZ, kappa=0.0)
    design_type = LowPassDesign

    def __init__(self, params=None, *, cutoff=None, kappa=None, **kw):
        self.cutoff = float(self.defaults["cutoff"] if cutoff is None else cutoff)
        self.kappa = float(self.defaults["kappa"] if kappa is None else kappa)
        if not (np.isfinite(self.cutoff) and self.cutoff > 0):
            raise ValueError(f"{self.label}: cutoff must be > 0 Hz, got {cutoff}")
        if not np.isfinite(self.kappa):
            raise ValueError(f"{self.label}: kappa must be finite, got {kappa}")
        self.name = self.label
        super().__init__(params, **kw)

    def _design_fields(self) -> dict:
        return dict(cutoff=self.cutoff, kappa=self.kappa)

    def observer(self, vx: float):
        """``(F, G, H, D)`` at ``vx`` (m/s); inputs ``[delta_f, ay, r]`` (:func:`lowpass_observer`)."""
        return lowpass_observer(self.design, vx)


class KinematicFeedForward(KinematicLowPass):
    """``kinematic-ff``: :class:`KinematicLowPass` with the centripetal feed-forward (:data:`FF_KAPPA`)."""

    label = "kinematic-ff"
    defaults = dict(cutoff=FF_CUTOFF_HZ, kappa=FF_KAPPA)

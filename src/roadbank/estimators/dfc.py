r"""DFC — dynamic filter compensation (Tseng 2001; paper eq 9-15).

The kinematic estimate :math:`w_v = (a_y - v_x r)/g` is trusted only as far as
the car is near steady state. With the original model's steady-state gains
(:func:`roadbank.models.steady_state_gains`) the DFC indicator

.. math::
    DFC = H_{aw0}(w_a - w_v) + v_x H_{rw0}(w_r - w_v),\quad
    w_a = (a_y - H_{au0}\delta_f)/H_{aw0},\quad w_r = (r - H_{ru0}\delta_f)/H_{rw0}

is zero in steady state when the model is right and approximates
:math:`\dot v_y` in transients (m/s^2). Update law (our reading of the
garbled eq 10, the one consistent with its eq 14, docs/estimators.md):

.. math::
    w_{dfc} = w_v \max(0, 1 - |DFC|/a_{ref})

followed by the paper's first-order low-pass (time constant 2/3 s). With a
wrong ``Cf`` the gains are wrong, DFC stays non-zero in steady state (eq 14)
and the estimate keeps a steady-state error that grows with the error.
``a_ref`` defaults to 4.0 m/s^2 (a transient with |DFC| >= 4 m/s^2 discards the
kinematic estimate entirely). Chosen by a sweep over the paper's scenarios on
our plant (mean bank RMS over the 17 cells: a_ref 0.5 -> 8.4 deg, 1 -> 6.9,
2 -> 5.5, 4 -> 4.3, 10 -> 3.3); larger values make DFC a low-passed kinematic
estimate and hide the method's character, so 4 is the compromise.
"""

from __future__ import annotations

import math

import numpy as np

from ..models.bicycle import steady_state_gains
from . import layout as L
from .base import DesignInputs, Estimator, Tables
from .settle import SETTLE_SHARE

A_REF = 4.0
TAU_LPF = 2.0 / 3.0


def dfc_tables(d: DesignInputs) -> Tables:
    """The ``dfc`` kernel's :class:`~roadbank.estimators.base.Tables`: the original model's
    steady-state gains at each grid speed (``a_ref`` and the low-pass enter the kernel's cfg only)."""
    tab = np.array([steady_state_gains(d.params, float(v)) for v in d.vgrid])
    return Tables(np.ascontiguousarray(tab), 2, np.zeros(0))


class DFC(Estimator):
    """Dynamic filter compensation. States: ``w_lpf`` (low-passed estimate), ``dfc`` (m/s^2)."""

    name = "dfc"
    kernel = "dfc"
    uses = (True, True, True)
    state_names = ("w_lpf", "dfc")

    @property
    def settle_time(self) -> float:
        """Settling time (s) of the paper's first-order low-pass: ``tau ln(1 / share)``
        (:mod:`roadbank.estimators.settle`; ``tau`` is not a design input, so not through the design-keyed cache)."""
        return self.tau * math.log(1.0 / SETTLE_SHARE)

    def __init__(self, params=None, *, a_ref=A_REF, tau=TAU_LPF, **kw):
        if not (a_ref > 0 and tau > 0):
            raise ValueError("dfc: a_ref and tau must be > 0")
        self.a_ref, self.tau = float(a_ref), float(tau)
        super().__init__(params, **kw)

    def _design(self):
        return dfc_tables(self.design)

    def _fill_cfg_head(self, head):
        head[L.C_AREF] = self.a_ref
        head[L.C_TAU] = self.tau

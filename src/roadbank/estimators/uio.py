r"""UIO — unknown input observer (Imsland et al. 2006; paper eq 16-25, Table 2).

On the original model with :math:`y = y_o - D_o\delta_f = C_o x`:

.. math::
    \dot z = N z + L y + G \delta_f,\qquad \hat x = z - E y

    E = -E_o (C_oE_o)^+ + Q_{uio}(I - C_oE_o (C_oE_o)^+),\quad
    N = (I + E C_o) A_o - M_{uio} C_o,\quad G = (I + E C_o) B_o,\quad L = M_{uio} - N E

so that :math:`(I + E C_o) E_o = 0` and the error :math:`e = x - \hat x` obeys
:math:`\dot e = N e` whatever ``w`` is. (With :math:`\hat x = z - E y` this
``L = M - N E`` follows from :math:`\dot e = N e + (M - N E - L) C_o x`; the
paper's "N E + M" differs only by its lost signs.) The disturbance is recovered
from the output derivative, taken through :math:`s/(\tau s + 1)`:

.. math::
    \hat w = (C_oE_o)^+ (\dot{\hat y} - C_o A_o \hat x - C_o B_o \delta_f)

Table 2 gives only magnitudes (``|M| = 10``, ``|Q| = 1``, ``tau = 1/9 s``).
Recovered signs: ``M = [[-10, 10], [10, 10]]``, ``Q = [[1, 1], [1, 1]]`` — of
the 64 sign patterns this one gives the most stable ``N`` over 5-70 m/s
(max real part -16.2 1/s); the first column of ``Q`` has no effect
(it multiplies a zero row of ``I - C_oE_o(C_oE_o)^+``). E depends on ``vx``; the
observer is designed for frozen speed (the ``-dE/dt y`` term is neglected).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..models.bicycle import original_model
from .base import DesignInputs, ScheduledObserver, embed_inputs, frozen_array

M_UIO = ((-10.0, 10.0), (10.0, 10.0))
Q_UIO = ((1.0, 1.0), (1.0, 1.0))
TAU_UIO = 1.0 / 9.0


def uio_matrices(params, vx: float, M=M_UIO, Q=Q_UIO):
    """``(E, N, L, G, pinv)`` of the UIO at ``vx`` (m/s); ``pinv = (C_o E_o)^+`` (1 x 2)."""
    A, B, Eo, C, _ = original_model(params, vx)
    M = np.asarray(M, float)
    Q = np.asarray(Q, float)
    CE = C @ Eo
    pinv = np.linalg.pinv(CE)
    E = -Eo @ pinv + Q @ (np.eye(2) - CE @ pinv)
    IEC = np.eye(2) + E @ C
    N = IEC @ A - M @ C
    return E, N, M - N @ E, IEC @ B, pinv


@dataclass(frozen=True)
class UIODesign(DesignInputs):
    """Design inputs of :class:`UIO`: the design matrices ``M``, ``Q`` (2 x 2, as nested tuples) and
    the derivative filter's time constant ``tau`` (s)."""

    M: tuple
    Q: tuple
    tau: float


def uio_observer(d: UIODesign, vx: float):
    """``(F, G, H, D)`` of the UIO with its output-derivative filters at ``vx`` (m/s)."""
    A, B, Eo, C, D = original_model(d.params, vx)
    E, N, L, Gu, pinv = uio_matrices(d.params, vx, d.M, d.Q)
    Sy = embed_inputs({0: -D[:, 0], 1: [1.0, 0.0], 2: [0.0, 1.0]}, 2)   # y = y_o - D delta
    Ed = embed_inputs({0: [1.0]}, 1)                                    # delta selector
    tau = d.tau
    F = np.zeros((4, 4))
    F[:2, :2] = N
    F[2:, 2:] = -np.eye(2) / tau
    G = np.vstack([L @ Sy + Gu @ Ed, Sy / tau])
    CA = C @ A
    H = np.hstack([-pinv @ CA, -pinv / tau])
    Dw = pinv @ (Sy / tau + CA @ E @ Sy - C @ B @ Ed)
    return F, G, H, Dw


class UIO(ScheduledObserver):
    """Unknown input observer. States ``[z1, z2, q1, q2]``: ``z`` of the observer
    and ``q`` of the output-derivative filters.

    Parameters
    ----------
    M, Q : 2x2 arrays
        Design matrices (defaults: Table 2 with recovered signs).
    tau : float
        Time constant (s) of the derivative filter ``s/(tau s + 1)``.
    """

    name = "uio"
    uses = (True, True, True)
    state_names = ("z1", "z2", "q_ay", "q_r")
    design_type = UIODesign
    if TYPE_CHECKING:
        @property
        def design(self) -> UIODesign: ...     # an instance of design_type

    def __init__(self, params=None, *, M=M_UIO, Q=Q_UIO, tau=TAU_UIO, **kw):
        if not tau > 0:
            raise ValueError(f"uio: tau must be > 0, got {tau}")
        self.M, self.Q, self.tau = np.asarray(M, float), np.asarray(Q, float), float(tau)
        super().__init__(params, **kw)

    def _design_fields(self) -> dict:
        return dict(M=frozen_array(self.M), Q=frozen_array(self.Q), tau=self.tau)

    def observer(self, vx: float):
        """``(F, G, H, D)`` at ``vx`` (m/s) (:func:`uio_observer`)."""
        return uio_observer(self.design, vx)

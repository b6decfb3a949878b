r"""Body roll models used to split the observers' angle into bank and roll
(docs/estimators.md, Roll separation).

The observers estimate :math:`\theta = \phi_b + \phi`. The body roll relative
to the road is driven by the lateral specific force the accelerometer measures:

.. math::
    I_{xx} \ddot\phi + c_\phi \dot\phi + (k_\phi - m_s g h)\phi = m_s h a_y

(``h`` the roll arm, ``phi`` positive right side down, as ``ay`` positive to
the left pushes the body outward). Its steady state gives the static gain
:math:`k_{roll} = m_s h / (k_\phi - m_s g h)` (rad per m/s^2).
"""

from __future__ import annotations

import numpy as np

from ..params import VehicleParams

#: Roll models offered by the estimators.
ROLL_MODELS = ("static", "dynamic", "none")


def steady_roll_gain(p: VehicleParams) -> float:
    """Static roll gain ``d phi / d ay`` (rad per m/s^2)."""
    return p.ms * p.h_roll / (p.k_roll - p.ms * p.g * p.h_roll)


def roll_stiffness_for_gain(p: VehicleParams, gain: float) -> float:
    """The roll stiffness ``k_roll`` (N m/rad) that gives ``p`` the static roll gain ``gain`` (rad per m/s^2): the
    inverse of :func:`steady_roll_gain`, the sprung mass and roll-centre height kept."""
    return p.ms * p.h_roll * (1.0 / gain + p.g)


def roll_state_space(p: VehicleParams, model: str = "static"):
    r"""Roll model as a linear system ``z' = F z + G ay``, ``phi = H z + D ay``.

    Parameters
    ----------
    p : VehicleParams
    model : {"static", "dynamic", "none"}
        ``static``: :math:`\phi = k_{roll} a_y` (no state); ``dynamic``: the
        second-order model above, states ``[phi (rad), phi' (rad/s)]``;
        ``none``: :math:`\phi = 0` (report theta as bank).

    Returns
    -------
    F (n, n), G (n, 1), H (n,), D (1,) : arrays, ``n`` = 0 or 2.
    """
    if model == "static":
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros(0), np.array([steady_roll_gain(p)])
    if model == "none":
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros(0), np.zeros(1)
    if model == "dynamic":
        k_eff = p.k_roll - p.ms * p.g * p.h_roll
        F = np.array([[0.0, 1.0], [-k_eff / p.Ixx, -p.c_roll / p.Ixx]])
        G = np.array([[0.0], [p.ms * p.h_roll / p.Ixx]])
        return F, G, np.array([1.0, 0.0]), np.zeros(1)
    raise ValueError(f"unknown roll model {model!r}; choose one of {ROLL_MODELS}")

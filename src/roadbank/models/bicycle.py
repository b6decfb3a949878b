"""Linear bicycle models of the lateral/yaw dynamics (docs/models.md).

All functions take a :class:`~roadbank.params.VehicleParams` and the
longitudinal speed ``vx`` (m/s, > 0) and return numpy arrays; states are
``vy`` (m/s) and ``r`` (rad/s), the disturbance is ``w = sin(theta)`` (-),
ISO 8855 signs.

The models are linear parameter-varying in ``vx`` (entries contain ``1/vx``)
and singular at ``vx = 0``; callers must not use them below a minimum speed.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..params import VehicleParams


class StateSpace(NamedTuple):
    """Continuous-time model ``x' = A x + B u + E w``, ``y = C x + D u``."""

    A: np.ndarray
    B: np.ndarray
    E: np.ndarray
    C: np.ndarray
    D: np.ndarray


def _check_speed(vx: float) -> float:
    vx = float(vx)
    if not np.isfinite(vx) or vx <= 0:
        raise ValueError(f"vx must be a finite speed > 0 m/s, got {vx}")
    return vx


def original_model(p: VehicleParams, vx: float) -> StateSpace:
    r"""Original bicycle model (paper eq 4).

    .. math::
        \dot x = A_o x + B_o \delta_f + E_o w,\qquad y_o = [a_y, r]^T = C_o x + D_o \delta_f

    with :math:`x = [v_y, r]^T`, input the front road-wheel angle
    :math:`\delta_f` (rad) and :math:`E_o = [-g, 0]^T`. The first output row is
    :math:`(F_{yf} + F_{yr})/m`: the accelerometer measures the tyre forces.
    """
    vx = _check_speed(vx)
    m, Iz, Lf, Lr, Cf, Cr, g = p.m, p.Iz, p.Lf, p.Lr, p.Cf, p.Cr, p.g
    a11 = -(Cf + Cr) / (m * vx)
    a12 = -vx - (Lf * Cf - Lr * Cr) / (m * vx)
    A = np.array([[a11, a12],
                  [-(Lf * Cf - Lr * Cr) / (Iz * vx), -(Lf**2 * Cf + Lr**2 * Cr) / (Iz * vx)]])
    B = np.array([[Cf / m], [Lf * Cf / Iz]])
    E = np.array([[-g], [0.0]])
    C = np.array([[a11, -(Lf * Cf - Lr * Cr) / (m * vx)],
                  [0.0, 1.0]])
    D = np.array([[Cf / m], [0.0]])
    return StateSpace(A, B, E, C, D)


def modified_model(p: VehicleParams, vx: float) -> StateSpace:
    r"""Modified bicycle model (paper eq 5-6), free of the front cornering stiffness.

    The front tyre force is eliminated with the measured lateral acceleration,
    which becomes the input:

    .. math::
        \dot v_y = a_y - v_x r - g w,\qquad
        I_z \dot r = L_f m a_y + (L_f + L_r) C_r (v_y - L_r r)/v_x

    so ``u_m = ay`` (m/s^2), ``y_m = r`` (rad/s); ``D`` is zero.
    """
    vx = _check_speed(vx)
    m, Iz, Lf, Lr, Cr, g = p.m, p.Iz, p.Lf, p.Lr, p.Cr, p.g
    L = Lf + Lr
    A = np.array([[0.0, -vx],
                  [L * Cr / (Iz * vx), -L * Lr * Cr / (Iz * vx)]])
    B = np.array([[1.0], [Lf * m / Iz]])
    E = np.array([[-g], [0.0]])
    C = np.array([[0.0, 1.0]])
    D = np.zeros((1, 1))
    return StateSpace(A, B, E, C, D)


def augment(model: StateSpace) -> StateSpace:
    r"""Augment a model with ``w`` as a state driven by an unknown rate ``n = dw/dt``.

    .. math::
        x_w = [x; w],\quad A_w = \begin{bmatrix} A & E \\ 0 & 0 \end{bmatrix},\quad
        B_w = [B; 0],\quad C_w = [C\ 0],\quad E_w = [0; 1],\quad L_w = [0 \dots 0\ 1]

    ``E`` of the returned tuple is ``E_w`` (the input matrix of ``n``). For the
    modified model this is the paper's eq 33.
    """
    n = model.A.shape[0]
    Aw = np.zeros((n + 1, n + 1))
    Aw[:n, :n] = model.A
    Aw[:n, n:] = model.E
    Bw = np.zeros((n + 1, model.B.shape[1]))        # (slices, not vstack/hstack: a design builds
    Bw[:n] = model.B                                 # a thousand of these models)
    Ew = np.zeros((n + 1, 1))
    Ew[n, 0] = 1.0
    Cw = np.zeros((model.C.shape[0], n + 1))
    Cw[:, :n] = model.C
    return StateSpace(Aw, Bw, Ew, Cw, model.D.copy())


def augmented_model(p: VehicleParams, vx: float) -> StateSpace:
    """Augmented modified model of the paper's eq 33 (states ``[vy, r, w]``)."""
    return augment(modified_model(p, vx))


def disturbance_output(n_states: int) -> np.ndarray:
    """Row ``L_w`` selecting ``w`` (the last state) of an augmented model."""
    Lw = np.zeros((1, n_states))
    Lw[0, -1] = 1.0
    return Lw


def understeer_gradient(p: VehicleParams) -> float:
    r"""Understeer gradient (rad s^2/m), paper eq 15:
    :math:`K_{us} = \frac{L_r m}{(L_f+L_r) C_f} - \frac{L_f m}{(L_f+L_r) C_r}`."""
    L = p.Lf + p.Lr
    return p.Lr * p.m / (L * p.Cf) - p.Lf * p.m / (L * p.Cr)


class SteadyStateGains(NamedTuple):
    """DC gains of the original model (paper eq 11, 15).

    ``Hau0`` (m/s^2 per rad) and ``Hru0`` (1/s) from ``delta_f`` to ``ay`` and
    ``r``; ``Haw0`` (m/s^2) and ``Hrw0`` (rad/s) from ``w`` to ``ay`` and ``r``.
    """

    Haw0: float
    Hrw0: float
    Hau0: float
    Hru0: float


def steady_state_gains(p: VehicleParams, vx: float) -> SteadyStateGains:
    r"""Steady-state gains of the original model computed from its state space,
    :math:`H(0) = -C_o A_o^{-1} B + D`.

    With ISO signs they match the paper's closed forms (eq 15) up to the sign of
    the ``r`` channel: :math:`H_{aw0} = g L/(L + K_{us} v_x^2)` and
    :math:`v_x H_{rw0} = -g K_{us} v_x^2/(L + K_{us} v_x^2)`, so that
    :math:`H_{aw0} - v_x H_{rw0} = g` (steady state: ``ay = vx r + g w``).
    """
    A, B, E, C, D = original_model(p, vx)
    Hw = -C @ np.linalg.solve(A, E)
    Hu = -C @ np.linalg.solve(A, B) + D
    return SteadyStateGains(float(Hw[0, 0]), float(Hw[1, 0]), float(Hu[0, 0]), float(Hu[1, 0]))


def observability_matrix(A: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Observability matrix ``[C; C A; ...; C A^(n-1)]``."""
    n = A.shape[0]
    rows = [C]
    for _ in range(n - 1):
        rows.append(rows[-1] @ A)
    return np.vstack(rows)


def is_observable(A: np.ndarray, C: np.ndarray, tol: float | None = None) -> bool:
    """True when ``(A, C)`` is observable (full-rank observability matrix, SVD rank test)."""
    O = observability_matrix(A, C)
    s = np.linalg.svd(O, compute_uv=False)
    tol = s[0] * max(O.shape) * np.finfo(float).eps if tol is None else tol
    return int(np.sum(s > tol)) == A.shape[0]

r"""Reference angles for evaluation (the paper's eq 45).

In simulation the reference is the plant's truth (road bank ``phi_b`` from the
contact-point heights, or ``theta = phi_b + phi``). On a vehicle test the paper
uses

.. math::
    \theta_{ref} = \arcsin\frac{a_y - \dot v_y - v_x r}{g}

with :math:`\dot v_y` from an optical ground-speed sensor, low-passed by a
first-order filter of time constant 2/3 s (also applied to the DFC output).
"""

from __future__ import annotations

import numpy as np

from ..constants import G

#: time constant (s) of the paper's reference / DFC low-pass filter
TAU_REFERENCE = 2.0 / 3.0


def first_order_lowpass(t: np.ndarray, x: np.ndarray, tau: float = TAU_REFERENCE) -> np.ndarray:
    r"""First-order low-pass :math:`\tau \dot y + y = x` on samples ``x`` at times ``t`` (s).

    Exact for a piecewise-linear input (works for irregular sampling); starts at
    ``y[0] = x[0]`` (no start-up transient). Non-finite samples hold the output.
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    if tau <= 0:
        raise ValueError(f"tau must be > 0 s, got {tau}")
    y = np.empty_like(x)
    if len(x) == 0:
        return y
    y[0] = x[0] if np.isfinite(x[0]) else 0.0
    prev = y[0]
    xprev = prev
    for k in range(1, len(x)):
        xk = x[k]
        if not np.isfinite(xk):
            y[k] = prev
            continue
        h = t[k] - t[k - 1]
        a = np.exp(-h / tau)
        # exact response to a ramp from xprev to xk over h
        b = (1.0 - a) * tau / h if h > 0 else 1.0
        prev = a * prev + (1.0 - b) * xk + (b - a) * xprev
        xprev = xk
        y[k] = prev
    return y


def theta_reference(t, ay, dvy_dt, vx, r, *, g: float = G, tau: float | None = TAU_REFERENCE) -> np.ndarray:
    """The paper's test reference (eq 45), rad: ``asin((ay - dvy/dt - vx r)/g)``, low-passed.

    Inputs in SI (s, m/s^2, m/s^2, m/s, rad/s). ``tau=None`` skips the low-pass.
    """
    arg = (np.asarray(ay) - np.asarray(dvy_dt) - np.asarray(vx) * np.asarray(r)) / g
    theta = np.arcsin(np.clip(arg, -1.0, 1.0))
    return theta if tau is None else first_order_lowpass(t, theta, tau)

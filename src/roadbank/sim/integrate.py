"""Fixed-step integration of plant + driver, entirely in compiled code.

Classic RK4 on the plant states with the driver's inputs held constant over a
step (the driver is a discrete controller at the integration rate, 1 kHz by
default). Python only allocates the result arrays.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .driver import ND, driver_step
from .plant import NAUX, NU, NX, plant_eval


@njit(cache=True)
def rk4_step(x, u, road, p, dt, k1, k2, k3, k4, tmp, aux):
    """One RK4 step in place on ``x`` (work arrays passed in: no allocation)."""
    plant_eval(x, u, road, p, k1, aux, False)
    h2 = 0.5 * dt
    for i in range(NX):
        tmp[i] = x[i] + h2 * k1[i]
    plant_eval(tmp, u, road, p, k2, aux, False)
    for i in range(NX):
        tmp[i] = x[i] + h2 * k2[i]
    plant_eval(tmp, u, road, p, k3, aux, False)
    for i in range(NX):
        tmp[i] = x[i] + dt * k3[i]
    plant_eval(tmp, u, road, p, k4, aux, False)
    c = dt / 6.0
    for i in range(NX):
        x[i] += c * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])


@njit(cache=True)
def simulate_core(x0, d0, t0, n_steps, dt, road, drv, p, X, U):
    """Integrate ``n_steps`` steps from state ``x0`` (driver state ``d0``) at time ``t0``.

    Fills ``X`` (n_steps+1, NX) with the states and ``U`` (n_steps+1, NU) with
    the inputs applied from each state. Returns the final driver state.
    """
    x = x0.copy()
    d = d0.copy()
    u = np.zeros(NU)
    k1 = np.empty(NX)
    k2 = np.empty(NX)
    k3 = np.empty(NX)
    k4 = np.empty(NX)
    tmp = np.empty(NX)
    aux = np.empty(NAUX)
    for k in range(n_steps):
        t = t0 + k * dt
        driver_step(t, x, d, drv, road, u, dt)
        for i in range(NX):
            X[k, i] = x[i]
        for i in range(NU):
            U[k, i] = u[i]
        rk4_step(x, u, road, p, dt, k1, k2, k3, k4, tmp, aux)
    driver_step(t0 + n_steps * dt, x, d, drv, road, u, dt)
    for i in range(NX):
        X[n_steps, i] = x[i]
    for i in range(NU):
        U[n_steps, i] = u[i]
    return d


def simulate(x0, d0, t0: float, duration: float, dt: float, road_packed, drv_packed, p):
    """Allocate and integrate; returns ``(t, X, U, d_final)`` at the integration rate."""
    n_steps = int(round(duration / dt))
    X = np.empty((n_steps + 1, NX))
    U = np.empty((n_steps + 1, NU))
    d = simulate_core(np.asarray(x0, dtype=np.float64), np.asarray(d0, dtype=np.float64), float(t0),
                      n_steps, float(dt), road_packed, drv_packed, p, X, U)
    t = t0 + dt * np.arange(n_steps + 1)
    return t, X, U, d


@njit(cache=True)
def outputs_at(X, U, idx, road, p):
    """Plant auxiliary outputs (``A_*`` of :mod:`roadbank.sim.plant`) at rows ``idx``."""
    out = np.empty((idx.shape[0], NAUX))
    dx = np.empty(NX)
    aux = np.empty(NAUX)
    for j in range(idx.shape[0]):
        plant_eval(X[idx[j]], U[idx[j]], road, p, dx, aux, True)
        for i in range(NAUX):
            out[j, i] = aux[i]
    return out

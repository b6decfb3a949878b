"""Fixed-step integration of plant + driver, entirely in compiled code.

Classic RK4 on the plant states with the driver's inputs held constant over a
step (the driver is a discrete controller at the integration rate, 1 kHz by
default). Python only allocates the result arrays.

Performance layout (see docs/simulator.md, "Speed"): the plant is inlined once
into a loop over the four RK4 stages (one copy of the code, no calls with array
arguments, hence no reference counting), the state-independent constants are
derived once per run (:func:`roadbank.sim.plant.prepare`) and the
input-dependent ones (steer angle, its sine and cosine, brake torques) once per
step (:func:`roadbank.sim.plant.step_inputs`), which is exact because the
inputs are held over the step.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .driver import driver_step
from .plant import NAUX, NC, NU, NX, plant_core, prepare, step_inputs

# RK4 stage weights: stage j is evaluated at x + _A[j] dt k_j-1
_A1, _A2, _A3 = 0.5, 0.5, 1.0


@njit(cache=True, fastmath=True, error_model="numpy")
def rk4_step(x, u, road, p, dt, k1, k2, k3, k4, tmp, aux):
    """One RK4 step in place on ``x`` (convenience entry; the loop in :func:`simulate_core` is fused)."""
    q = prepare(p)
    c = np.empty(NC)
    step_inputs(u, q, c)
    k = np.empty((4, NX))
    dx = np.empty(NX)
    _rk4_fused(x, road, q, c, dt, k, tmp, dx, aux)
    for i in range(NX):
        k1[i] = k[0, i]
        k2[i] = k[1, i]
        k3[i] = k[2, i]
        k4[i] = k[3, i]


@njit(cache=True, inline="always", fastmath=True, error_model="numpy")
def _rk4_fused(x, road, q, c, dt, k, tmp, dx, aux):
    """RK4 step on ``x`` with the plant inlined once in a loop over the stages; ``k`` is (4, NX)."""
    for i in range(NX):
        tmp[i] = x[i]
    for j in range(4):
        plant_core(tmp, road, q, c, dx, aux, False)
        a = (_A1 if j == 0 else (_A2 if j == 1 else _A3)) * dt
        for i in range(NX):
            k[j, i] = dx[i]
            tmp[i] = x[i] + a * dx[i]
    w = dt / 6.0
    for i in range(NX):
        x[i] += w * (k[0, i] + 2.0 * (k[1, i] + k[2, i]) + k[3, i])


@njit(cache=True, fastmath=True, error_model="numpy")
def simulate_core(x0, d0, t0, n_steps, dt, road, drv, p, X, U):
    """Integrate ``n_steps`` steps from state ``x0`` (driver state ``d0``) at time ``t0``.

    Fills ``X`` (n_steps+1, NX) with the states and ``U`` (n_steps+1, NU) with
    the inputs applied from each state. Returns the final driver state.
    """
    x = x0.copy()
    d = d0.copy()
    u = np.zeros(NU)
    q = prepare(p)
    c = np.empty(NC)
    k = np.empty((4, NX))
    tmp = np.empty(NX)
    dx = np.empty(NX)
    aux = np.empty(NAUX)
    for n in range(n_steps):
        t = t0 + n * dt
        driver_step(t, x, d, drv, road, u, dt)
        for i in range(NX):
            X[n, i] = x[i]
        for i in range(NU):
            U[n, i] = u[i]
        step_inputs(u, q, c)
        _rk4_fused(x, road, q, c, dt, k, tmp, dx, aux)
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


@njit(cache=True, fastmath=True, error_model="numpy")
def outputs_at(X, U, idx, road, p):
    """Plant auxiliary outputs (``A_*`` of :mod:`roadbank.sim.plant`) at rows ``idx``."""
    out = np.empty((idx.shape[0], NAUX))
    q = prepare(p)
    c = np.empty(NC)
    dx = np.empty(NX)
    aux = np.empty(NAUX)
    for j in range(idx.shape[0]):
        step_inputs(U[idx[j]], q, c)
        plant_core(X[idx[j]], road, q, c, dx, aux, True)
        for i in range(NAUX):
            out[j, i] = aux[i]
    return out

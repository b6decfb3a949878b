"""Fixed-step integration of plant + driver, entirely in compiled code.

Classic RK4 on the plant states with the driver's inputs held constant between
driver updates: the driver is a discrete controller with its own sample time
(every ``drv_every`` integration steps, 2 ms by default, see
:func:`roadbank.sim.scenarios.driver_every`), so the integration step can be
refined without changing the simulated system, and RK4 keeps its fourth order
between updates. Python only allocates the result arrays.

Performance layout (see docs/simulator.md, "Speed"): the plant is inlined once
into a loop over the four RK4 stages (one copy of the code, no calls; the
helpers are marked ``forceinline=True``, which LLVM does on compiled code,
rather than numba's ``inline="always"``, which re-types the inlined IR at every
call site and cost about 12 s of a 18 s cold compilation), the
loop works on reference-count-free views of caller-owned arrays (no atomic
increments/decrements), the state-independent constants are
derived once per run (:func:`roadbank.sim.plant.prepare`) and the
input-dependent ones (steer angle, its sine and cosine, brake torques) once per
step (:func:`roadbank.sim.plant.step_inputs`), which is exact because the
inputs are held over the step.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.core import cgutils
from numba.extending import intrinsic

from .driver import driver_step
from .plant import NAUX, NC, NU, NX, _fill_aux, plant_core, prepare, step_inputs


@intrinsic
def _borrow(typingctx, arr):
    """The same array without its reference count (NULL meminfo), so passing it around costs no
    atomic increments/decrements (~100 ns per RK4 step otherwise).

    Only for arrays that the *caller of the compiled function* owns for the whole call.
    """
    def codegen(context, builder, signature, args):
        src = context.make_array(arr)(context, builder, args[0])
        dst = context.make_array(arr)(context, builder)
        dst.meminfo = cgutils.get_null_value(src.meminfo.type)
        dst.parent = cgutils.get_null_value(src.parent.type)
        dst.nitems = src.nitems
        dst.itemsize = src.itemsize
        dst.data = src.data
        dst.shape = src.shape
        dst.strides = src.strides
        return dst._getvalue()
    return arr(arr), codegen


# RK4 stage weights: stage j is evaluated at x + _A[j] dt k_j-1
_A1, _A2, _A3 = 0.5, 0.5, 1.0


@njit(cache=True, fastmath=True, error_model="numpy")
def simulate_core(x, d, t0, n_steps, dt, drv_every, road, drv, q, X, U, u, c, k, tmp, dx, aux):
    """Integrate ``n_steps`` steps in place from state ``x`` (driver state ``d``) at time ``t0``.

    The driver runs before every ``drv_every``-th step, with sample time
    ``drv_every * dt``; its inputs are held in between.

    Fills ``X`` (n_steps+1, NX) with the states and ``U`` (n_steps+1, NU) with
    the inputs applied from each state. ``q`` is :func:`~roadbank.sim.plant.prepare`'s
    array (also the wheel loop's scratch); ``u`` (NU), ``c`` (NC), ``k`` (4, NX),
    ``tmp``, ``dx`` (NX) and ``aux`` (NAUX) are work arrays. All arrays are owned
    by the caller (:func:`simulate`), so the loop can use reference-count-free
    views of them (:func:`_borrow`).
    """
    x = _borrow(x)
    d = _borrow(d)
    road = _borrow(road)
    drv = _borrow(drv)
    q = _borrow(q)
    X = _borrow(X)
    U = _borrow(U)
    u = _borrow(u)
    c = _borrow(c)
    k = _borrow(k)
    tmp = _borrow(tmp)
    dx = _borrow(dx)
    aux = _borrow(aux)
    dt_drv = drv_every * dt
    for n in range(n_steps):
        if n % drv_every == 0:
            driver_step(t0 + n * dt, x, d, drv, road, u, dt_drv)
            step_inputs(u, q, c)
        for i in range(NX):
            X[n, i] = x[i]
        for i in range(NU):
            U[n, i] = u[i]
        # RK4 with the plant inlined once in a loop over the four stages (k is (4, NX))
        for i in range(NX):
            tmp[i] = x[i]
        for j in range(4):
            plant_core(tmp, road, q, c, dx)
            a = (_A1 if j == 0 else (_A2 if j == 1 else _A3)) * dt
            for i in range(NX):
                k[j, i] = dx[i]
                tmp[i] = x[i] + a * dx[i]
        w = dt / 6.0
        for i in range(NX):
            x[i] += w * (k[0, i] + 2.0 * (k[1, i] + k[2, i]) + k[3, i])
    if n_steps % drv_every == 0:
        driver_step(t0 + n_steps * dt, x, d, drv, road, u, dt_drv)
    for i in range(NX):
        X[n_steps, i] = x[i]
    for i in range(NU):
        U[n_steps, i] = u[i]


def simulate(x0, d0, t0: float, duration: float, dt: float, road_packed, drv_packed, p, drv_every: int = 1):
    """Allocate and integrate; returns ``(t, X, U, d_final)`` at the integration rate.

    ``t0``, ``duration`` and ``dt`` in s; the driver runs every ``drv_every`` steps.
    """
    n_steps = int(round(duration / dt))
    X = np.empty((n_steps + 1, NX))
    U = np.empty((n_steps + 1, NU))
    x = np.array(x0, dtype=np.float64)
    d = np.array(d0, dtype=np.float64)
    simulate_core(x, d, float(t0), n_steps, float(dt), int(drv_every),
                  np.ascontiguousarray(road_packed, dtype=np.float64),
                  np.ascontiguousarray(drv_packed, dtype=np.float64), prepare(p),
                  X, U, np.zeros(NU), np.zeros(NC), np.zeros((4, NX)), np.zeros(NX), np.zeros(NX), np.zeros(NAUX))
    t = t0 + dt * np.arange(n_steps + 1)
    return t, X, U, d


def outputs_at(X, U, idx, road, p) -> np.ndarray:
    """Plant auxiliary outputs (``A_*`` of :mod:`roadbank.sim.plant`) at rows ``idx`` of ``X``, ``U``.

    Returns an array (len(idx), NAUX); the units are those of the ``A_*`` entries.
    """
    X = np.ascontiguousarray(X, dtype=np.float64)
    U = np.ascontiguousarray(U, dtype=np.float64)
    idx = np.ascontiguousarray(idx, dtype=np.int64)
    out = np.empty((idx.shape[0], NAUX))
    _outputs_into(X, U, idx, np.ascontiguousarray(road, dtype=np.float64), prepare(p), out,
                  np.empty(NC), np.empty(NX), np.empty(NAUX))
    return out


@njit(cache=True, fastmath=True, error_model="numpy", no_cfunc_wrapper=True)
def _outputs_into(X, U, idx, road, q, out, c, dx, aux):
    """:func:`outputs_at` into ``out`` with the prepared constants ``q`` and work arrays ``c``, ``dx``, ``aux``."""
    for j in range(idx.shape[0]):
        x = X[idx[j]]
        step_inputs(U[idx[j]], q, c)
        plant_core(x, road, q, c, dx)
        _fill_aux(x, q, c, dx, aux)
        for i in range(NAUX):
            out[j, i] = aux[i]

"""Linear observers scheduled on speed (the ``lpv`` family) and their one observer update.

The observer update of a sample (:func:`observer_update`: restart at the equilibrium, fixed-rate
map or trapezoidal step, then the output ``w = H xi + D eta``) is written once and serves the
per-sample step (:func:`lpv_step`), the batch runs (:func:`lpv_loop`: :func:`lpv_run`, and :func:`lpv3_run`
for a three-state observer, whose samples off the three-state fixed-rate loop go through :func:`lpv_step`)
and the families built on it (``adaptive``, ``gated``). The two batch runs differ in a constant that numba
prunes before typing (``batch3``), so an observer of another size never compiles the three-state loop. A
three-state observer's fixed-rate map is :func:`fixed3` in the step and in the batch loop
(:func:`lpv3_fixed_run`) alike, so ``run()`` and ``step()`` are the same arithmetic by construction. The order
of their sums is the update description of :mod:`roadbank.estimators.update_spec` (from which the exported C is
generated); tests/test_update_spec.py checks these kernels against it bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...constants import AY_MAX, SPEED_MAX, YAW_RATE_MAX
from ..layout import (C_DTFIX, C_DTOL, C_DV, C_GAP, C_LIM, C_N, C_NG, C_NR, C_SUB, C_USE, C_V0, C_VMIN, C_WMAX, M_AY,
                      M_ETA, M_INIT, M_PHI, M_PHIB, M_THETA, M_TLAST, M_W, M_X, NETA, batch3_block, lpv_row,
                      roll_states)
from ._jit import ENTRY, HELPER, optimise_for_size
from .linalg import tustin
from .sample import (ROLL0, ROLL2, angles, begin, finish, grid, interp, limited_ay, noise_update, roll_fixed2, roll_map,
                     sample_valid, scale_update, store)
from .simd import interp4, map4

#: offsets of the batch loop's block in a three-state lpv row (layout.batch3_block)
_B3 = batch3_block()
_B3_DELTA = _B3.dM - _B3.M           # from an entry of M or W to its difference to the next row
_BLOCK = 256                         # samples per block of the batch loop (recursion, then angles)


@njit(inline="always", **HELPER)
def observer_update(mem, cfg, work, n, eta, dt, restart, fixed):
    """The observer's state update and output for one used sample; returns ``w``.

    ``work`` holds the schedule interpolated at ``vx`` at the offsets of
    :func:`roadbank.estimators.layout.lpv_row` (the parts the path reads; scratch after
    ``lpv_row(n).end``). At a restart ``xi = J eta``; on the fixed-rate path
    ``xi = Phi xi + Gam0 eta- + Gam1 eta``; otherwise the trapezoidal rule on ``F, G`` over
    ``dt`` with the inputs linear between ``eta-`` (``mem[M_ETA:]``) and ``eta``. Then
    ``w = H xi + D eta`` and ``eta`` becomes the previous inputs.
    """
    row = lpv_row(n)
    oS = row.end                                # scratch after the row
    if restart:
        for p in range(n):
            s = 0.0
            for q in range(NETA):
                s += work[row.J + p * NETA + q] * eta[q]
            mem[M_X + p] = s
    elif fixed:
        for p in range(n):
            s = 0.0
            for q in range(NETA):
                s += work[row.Gam0 + p * NETA + q] * mem[M_ETA + q] + work[row.Gam1 + p * NETA + q] * eta[q]
            for j in range(n):
                s += work[row.Phi + p * n + j] * mem[M_X + j]
            work[oS + p] = s
        for p in range(n):
            mem[M_X + p] = work[oS + p]
    else:
        for q in range(NETA):
            work[oS + q] = eta[q]
        tustin(mem, M_X, n, work, row.F, row.G, NETA, mem, M_ETA, work, oS, dt, cfg[C_SUB], work, oS + NETA)
    w = 0.0
    for q in range(NETA):
        w += work[row.D + q] * eta[q]
        mem[M_ETA + q] = eta[q]
    for p in range(n):
        w += work[row.H + p] * mem[M_X + p]
    return w


@njit(inline="always", **HELPER)
def fixed3(ri, a, p0, p1, p2, u0, u1, u2, x0, x1, x2):
    """:func:`observer_update`'s fixed-rate path for three states, from the row's batch block
    (:func:`roadbank.estimators.layout.batch3_block`); returns ``(x0, x1, x2, w)``.

    Each column of ``[Gam0 | Gam1 | Phi]`` is four lanes, interpolated as ``M + a dM`` (the same
    numbers as ``M[i] + a (M[i+1] - M[i])``), so that each state row's sum, in
    :func:`observer_update`'s order, runs in one lane of a SIMD register (:func:`map4`).
    ``ri``: the table row below ``vx``, ``a`` the weight, ``p`` the previous and ``u`` the
    current inputs, ``x`` the state.
    """
    x0, x1, x2, _ = map4(ri, np.int64(_B3.M), np.int64(_B3_DELTA), a, p0, u0, p1, u1, p2, u2, x0, x1, x2)
    # w = D eta + H xi, in observer_update's order (D and H at vx)
    d0, d1, d2, _ = interp4(ri, np.int64(_B3.W), np.int64(_B3_DELTA), a)
    h0, h1, h2, _ = interp4(ri, np.int64(_B3.W + 4), np.int64(_B3_DELTA), a)
    w = 0.0
    w += d0 * u0
    w += d1 * u1
    w += d2 * u2
    w += h0 * x0
    w += h1 * x1
    w += h2 * x2
    return x0, x1, x2, w


@njit(**ENTRY)
def lpv_step(mem, cfg, tab, work, t, vx, d, ay, r):
    """One sample of a scheduled linear observer: returns ``(w, theta, phi_b, valid)``.

    ``tab`` rows as :func:`roadbank.estimators.layout.lpv_row`: continuous
    ``F, G, H, D, J``, then (when ``cfg[C_DTFIX] > 0``) the fixed-rate
    ``Phi, Gam0, Gam1`` (and for three states the batch block, :func:`fixed3`).
    ``work`` (:func:`~roadbank.estimators.layout.work_size` floats) receives the
    interpolated row at the same offsets, then scratch. A limited low-pass (``cfg[C_LIM] > 0``) reads
    :func:`~roadbank.estimators.kernels.sample.limited_ay` in the steering's slot, then updates its running
    noise (:func:`~roadbank.estimators.kernels.sample.noise_update`).
    """
    optimise_for_size()
    if cfg[C_LIM] > 0.0:
        d = limited_ay(mem, cfg, t, vx, ay, r)
    if not sample_valid(mem, cfg, t, vx, d, ay, r):
        return mem[M_W], mem[M_THETA], mem[M_PHIB], False
    n = np.int64(cfg[C_N])
    i, a = grid(cfg, vx)
    row = lpv_row(n)
    eta = (d if cfg[C_USE] > 0 else 0.0, ay if cfg[C_USE + 1] > 0 else 0.0, r if cfg[C_USE + 2] > 0 else 0.0)
    dt, restart, fixed = begin(mem, cfg, t)
    rho = noise_update(mem, cfg, vx, ay, r, dt, restart) if cfg[C_LIM] > 0.0 else 1.0
    if fixed and n == 3 and cfg[C_LIM] == 0.0:
        x0, x1, x2, w = fixed3(tab[i], a, mem[M_ETA], mem[M_ETA + 1], mem[M_ETA + 2], eta[0], eta[1], eta[2],
                               mem[M_X], mem[M_X + 1], mem[M_X + 2])
        mem[M_X] = x0
        mem[M_X + 1] = x1
        mem[M_X + 2] = x2
        for q in range(NETA):
            mem[M_ETA + q] = eta[q]
    else:
        # the parts of the row the path reads: H, D, Phi, Gam0 and Gam1; H, D and J; or F, G, H and D
        if fixed:
            interp(tab, i, a, row.H, row.J, work)
            interp(tab, i, a, row.Phi, row.end, work)
        else:
            interp(tab, i, a, row.F if not restart else row.H, row.J if not restart else row.cont, work)
        x0 = mem[M_X]
        x1 = mem[M_X + 1] if n > 1 else 0.0
        w = observer_update(mem, cfg, work, n, eta, dt, restart, fixed)
        if rho != 1.0:          # a limited low-pass following its running noise
            w = scale_update(mem, cfg, work, row.H, x0, x1, rho, w)
    ok = finish(mem, cfg, w, ay, dt, restart, fixed)
    return mem[M_W], mem[M_THETA], mem[M_PHIB], ok


@njit(**HELPER)
def lpv3_fixed_run(mem, cfg, tab, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid, out_x, k0):
    """The fixed-rate path of a three-state observer over consecutive samples from ``k0``.

    Runs while the samples are valid and exactly one fixed interval apart (within
    ``DT_REL_TOL``) and returns the index of the first sample it did not take
    (the caller hands that one to :func:`lpv_step`). Per sample the observer is
    :func:`fixed3` and the roll model :func:`roll_fixed2`, as in :func:`lpv_step`, with what
    is constant over a log read once: the flags, the grid, the roll model, and the state kept in
    registers between samples (written back to ``mem`` on return); theta, phi_b and valid per
    block of samples (:func:`~roadbank.estimators.kernels.sample.angles`). The estimator must be
    initialised (``mem[M_INIT] > 0``), ``n == 3``, ``nr`` 0 or 2, ``cfg[C_DTFIX] > 0``, and ``tab``
    must have the batch block.
    """
    N = t.shape[0]
    nr = np.int64(cfg[C_NR])
    h = cfg[C_DTFIX]
    htol = cfg[C_DTOL] * h
    gap = cfg[C_GAP]
    vmin = cfg[C_VMIN]
    use_d = cfg[C_USE] > 0
    use_ay = cfg[C_USE + 1] > 0
    use_r = cfg[C_USE + 2] > 0
    wmax = cfg[C_WMAX]
    v0 = cfg[C_V0]
    inv_dv = 1.0 / cfg[C_DV]
    last = np.int64(cfg[C_NG]) - 1
    # roll model (layout.roll_block); zeros when there is none
    rb = ROLL2 if nr == 2 else ROLL0
    rD = cfg[rb.D]
    rH0 = cfg[rb.H] if nr == 2 else 0.0
    rH1 = cfg[rb.H + 1] if nr == 2 else 0.0
    rm = roll_map(cfg) if nr == 2 else (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    oz = roll_states(np.int64(3))
    z0 = mem[oz] if nr == 2 else 0.0
    z1 = mem[oz + 1] if nr == 2 else 0.0
    x0 = mem[M_X]
    x1 = mem[M_X + 1]
    x2 = mem[M_X + 2]
    p0 = mem[M_ETA]
    p1 = mem[M_ETA + 1]
    p2 = mem[M_ETA + 2]
    ay0 = mem[M_AY]
    tlast = mem[M_TLAST]
    w = mem[M_W]
    phi = mem[M_PHI]
    k = k0
    kend = k0
    while k == kend and k < N:
        # blocks of samples: the recursion, then the angles of the block
        kb = k
        kend = k + _BLOCK if N - k > _BLOCK else N
        while k < kend:
            ku = np.uint64(k)           # an unsigned index: no negative-index wraparound code
            tk = t[ku]
            vk = vx[ku]
            dk = d[ku]
            ak = ay[ku]
            rk = r[ku]
            # sample_valid, then begin's restart and fixed-interval tests
            if not (math.isfinite(tk) and vmin <= vk <= SPEED_MAX):
                break
            if (use_d and not math.isfinite(dk)) or (use_ay and not abs(ak) <= AY_MAX) \
                    or (use_r and not abs(rk) <= YAW_RATE_MAX):
                break
            if tk <= tlast:
                break
            dt = tk - tlast
            if dt > gap or not abs(dt - h) <= htol:
                break
            tlast = tk
            u0 = dk if use_d else 0.0
            u1 = ak if use_ay else 0.0
            u2 = rk if use_r else 0.0
            # grid, with 1/dv read once
            s = (vk - v0) * inv_dv
            if last == 0 or s <= 0.0:
                i = 0
                a = 0.0
            elif s >= last:
                i = last - 1
                a = 1.0
            else:
                i = np.int64(s)
                a = s - i
            x0, x1, x2, w = fixed3(tab[np.uint64(i)], a, p0, p1, p2, u0, u1, u2, x0, x1, x2)
            p0 = u0
            p1 = u1
            p2 = u2
            # finish, fixed: roll model and output
            if nr == 2:
                z0, z1 = roll_fixed2(rm, z0, z1, ay0, ak)
            ay0 = ak
            phi = rD * ak
            if nr == 2:
                phi += rH0 * z0
                phi += rH1 * z1
            out_w[ku] = w
            out_phi[ku] = phi
            out_x[ku, 0] = x0
            out_x[ku, 1] = x1
            out_x[ku, 2] = x2
            k += 1
        angles(out_w, out_phi, out_theta, out_phib, out_valid, wmax, kb, k)
    if k > k0:
        mem[M_TLAST] = tlast
        mem[M_X] = x0
        mem[M_X + 1] = x1
        mem[M_X + 2] = x2
        if nr == 2:
            mem[oz] = z0
            mem[oz + 1] = z1
        mem[M_ETA] = p0
        mem[M_ETA + 1] = p1
        mem[M_ETA + 2] = p2
        mem[M_AY] = ay0
        mem[M_W] = w
        mem[M_THETA] = out_theta[np.uint64(k - 1)]
        mem[M_PHI] = phi
        mem[M_PHIB] = out_phib[np.uint64(k - 1)]
    return k


@njit(inline="always", **HELPER)
def lpv_loop(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid, out_x, batch3):
    """:func:`lpv_step` over every sample; with ``batch3`` (a constant of the caller, so that each batch kernel
    compiles only the code it runs) the runs of samples on the fixed-rate path of a three-state observer go through
    :func:`lpv3_fixed_run`."""
    n = np.int64(cfg[C_N])
    nr = np.int64(cfg[C_NR])
    N = t.shape[0]
    k = np.int64(0)              # not a literal: one compiled lpv3_fixed_run
    while k < N:
        if batch3:
            if (n == 3 and (nr == 0 or nr == 2) and cfg[C_DTFIX] > 0.0 and cfg[C_LIM] == 0.0
                    and mem[M_INIT] > 0.0):
                k = lpv3_fixed_run(mem, cfg, tab, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
                                   out_x, k)
                if k >= N:
                    break
        ok = lpv_step(mem, cfg, tab, work, t[k], vx[k], d[k], ay[k], r[k])[3]
        store(mem, k, n, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x)
        k += 1


@njit(**ENTRY)
def lpv_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid, out_x):
    """Batch version of :func:`lpv_step` (same arithmetic, sample by sample)."""
    lpv_loop(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid, out_x, False)


@njit(**ENTRY)
def lpv3_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid, out_x):
    """:func:`lpv_run` of a three-state observer (roll model of 0 or 2 states): the runs of samples on the
    fixed-rate path go through :func:`lpv3_fixed_run`, every other sample through :func:`lpv_step`."""
    lpv_loop(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid, out_x, True)

"""The update description (roadbank.estimators.update_spec) is what the compiled kernels compute.

Every used sample of ``step()`` on a log with fixed-rate stretches, jitter, a gap and invalid
samples is recomputed from the description (grid point, interpolated blocks, the path's update,
the output, for the observer and the roll model) from the kernel's memory before the sample:
the restart and fixed-rate paths and the outputs agree bit for bit, the trapezoidal path (a solver,
checked against dense solves) to 1e-12. The exported C follows the same description: on restart
and fixed-rate samples its ``w`` and ``phi`` are the kernel's bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from roadbank import estimators as E
from roadbank.estimators import update_spec as U
from roadbank.estimators.layout import (C_DTFIX, C_DTOL, C_DV, C_GAP, C_NG, C_NR, C_SUB, C_USE, C_V0, M_AY, M_ETA,
                                        M_INIT, M_PHI, M_TLAST, M_W, M_X, NETA, lpv_row, roll_block, roll_states)


def _log(n=1500):
    """15 s at 100 Hz: regular stretches, jitter, a 2 s gap, speeds beyond both grid ends, a dip
    below v_min and NaN inputs."""
    t = np.arange(n) / 100.0
    t[300:420] += 0.004 * np.abs(np.sin(np.arange(120)))
    t[420:] += 0.004 * np.abs(np.sin(119.0))
    t[700:] += 2.0
    t[1100:1200] += np.cumsum(np.full(100, 0.013))
    t[1200:] += 1.3
    vx = 20.0 + 8.0 * np.sin(np.arange(n) / 150.0)
    vx[500:520] = 3.0
    vx[520:540] = 200.0
    ay = 2.0 * np.sin(np.arange(n) / 40.0) + 0.3
    ay[900] = np.nan
    r = 0.05 * np.sin(np.arange(n) / 55.0)
    d = 0.02 * np.sin(np.arange(n) / 60.0 + 0.4)
    d[950:955] = np.nan
    return t, vx, ay, r, d


def _blocks(values, offsets, ns, m):
    """The named blocks of a system (its entries, row-major) from a flat array at the layout's offsets."""
    out = {}
    for b in ("F", "G", "H", "D", "J", "Phi", "Gam0", "Gam1"):
        rows, cols = U.block_shape(b, ns, m)
        o = getattr(offsets, b)
        out[b] = [float(v) for v in values[o:o + rows * cols]]
    return out


def _path(mem, cfg, t):
    restart = mem[M_INIT] == 0.0 or (t - mem[M_TLAST]) > cfg[C_GAP]
    dt = 0.0 if restart else t - mem[M_TLAST]
    h = cfg[C_DTFIX]
    fixed = (not restart) and h > 0.0 and abs(dt - h) <= cfg[C_DTOL] * h
    return ("restart" if restart else "fixed" if fixed else "general"), dt


def _update(path, blocks, x, e, e_prev, dt, max_sub):
    """The state after the path's update, by the description."""
    if path == "general":
        ns, m = len(x), len(e)
        F = np.reshape(blocks["F"], (ns, ns))
        G = np.reshape(blocks["G"], (ns, m))
        return list(U.trapezoid(F, G, np.array(x), np.array(e_prev), np.array(e), dt, max_sub))
    return U.evaluate(U.PATHS[path], blocks, {"x": x, "e": e, "e_prev": e_prev}, len(x))


def _check_system(name, path, blocks, before, after, e, e_prev, dt, max_sub, y_after, what):
    """The state update and the output of one system against the description."""
    x_new = _update(path, blocks, before, e, e_prev, dt, max_sub)
    if path == "general":
        np.testing.assert_allclose(after, x_new, rtol=1e-12, atol=1e-15, err_msg=f"{what} {name} {path}")
    else:
        assert list(after) == x_new, f"{what} {name} {path}: {list(after)} != {x_new}"
    # the output from the kernel's new state, in the description's order: bit for bit on every path
    y = U.evaluate(U.OUTPUT, blocks, {"x": [float(v) for v in after], "e": e, "e_prev": e_prev}, len(before))
    assert y_after == y[0], f"{what} {name} output on the {path} path: {y_after} != {y[0]}"


@pytest.mark.parametrize("name", ["kinematic", "kinematic-lp", "pif-modified", "kalman", "uio", "pif-rate"])
@pytest.mark.parametrize("rate", [100.0, None])
def test_the_kernels_compute_the_description(name, rate):
    est = E.make(name, sample_rate=None)
    est.set_sample_rate(rate)
    est.reset()
    n, nr = est._nstate, int(est._cfg[C_NR])
    cfg, tab = est._cfg, est._tab
    row, rb, oz = lpv_row(n), roll_block(nr), roll_states(n)
    roll = _blocks(cfg, rb, nr, 1)
    paths = set()
    for t, vx, ay, r, d in zip(*_log()):
        before = est._mem.copy()
        path, dt = _path(before, cfg, t)
        est.step(t, vx, ay, r, d)
        mem = est._mem
        if mem[M_TLAST] == before[M_TLAST] and before[M_INIT] > 0:
            assert np.array_equal(mem, before)               # an unused sample leaves the state alone
            continue
        paths.add(path)
        what = f"{name} rate={rate} t={t:.3f}"
        i, a = U.grid_point(vx, cfg[C_V0], cfg[C_DV], int(cfg[C_NG]))
        sched = U.interpolate(tab[i], tab[min(i + 1, tab.shape[0] - 1)], a)
        e = [v if cfg[C_USE + q] > 0 else 0.0 for q, v in enumerate((d, ay, r))]
        _check_system("observer", path, _blocks(sched, row, n, NETA), before[M_X:M_X + n], mem[M_X:M_X + n],
                      e, [float(v) for v in before[M_ETA:M_ETA + NETA]], dt, cfg[C_SUB], mem[M_W], what)
        assert list(mem[M_ETA:M_ETA + NETA]) == e                    # e becomes e-
        _check_system("roll", path, roll, before[oz:oz + nr], mem[oz:oz + nr], [ay], [float(before[M_AY])],
                      dt, cfg[C_SUB], mem[M_PHI], what)
    assert paths == ({"restart", "fixed", "general"} if rate else {"restart", "general"})


def test_blocks_read_are_the_kernels_interpolated_ranges():
    """The blocks of each path and the output, as contiguous ranges of a row, are the ranges the
    ``lpv`` step interpolates: H..J and Phi..end (fixed), H..cont (restart), F..J (general)."""
    for n in (1, 3, 4):
        row = lpv_row(n)
        assert U.row_ranges("fixed", row, n, NETA) == [(row.H, row.J), (row.Phi, row.end)]
        assert U.row_ranges("restart", row, n, NETA) == [(row.H, row.cont)]
        assert U.row_ranges("general", row, n, NETA) == [(row.F, row.J)]


def test_evaluate_is_the_matrix_algebra():
    """The ordered sums are the matrix products they name (numpy, to rounding)."""
    rng = np.random.default_rng(1)
    ns, m = 4, 3
    blocks = {b: list(rng.normal(size=int(np.prod(U.block_shape(b, ns, m))))) for b in
              ("F", "G", "H", "D", "J", "Phi", "Gam0", "Gam1")}
    x, e, e0 = rng.normal(size=ns), rng.normal(size=m), rng.normal(size=m)
    vec = {"x": list(x), "e": list(e), "e_prev": list(e0)}
    M = {b: np.reshape(v, U.block_shape(b, ns, m)) for b, v in blocks.items()}
    np.testing.assert_allclose(U.evaluate(U.RESTART, blocks, vec, ns), M["J"] @ e, rtol=1e-13)
    np.testing.assert_allclose(U.evaluate(U.FIXED, blocks, vec, ns),
                               M["Gam0"] @ e0 + M["Gam1"] @ e + M["Phi"] @ x, rtol=1e-13)
    np.testing.assert_allclose(U.evaluate(U.OUTPUT, blocks, vec, ns), M["D"] @ e + M["H"] @ x, rtol=1e-13)


def test_trapezoid_converges_to_the_exact_solution():
    """Against scipy's matrix exponential for a constant input: second order in the substep."""
    from scipy.linalg import expm

    F = np.array([[-2.0, 1.0], [-3.0, -0.5]])
    G = np.array([[1.0], [0.5]])
    x0, e = np.array([0.3, -0.2]), np.array([0.7])
    xe = -np.linalg.solve(F, G @ e)
    exact = xe + expm(F * 0.5) @ (x0 - xe)
    err = [np.max(np.abs(U.trapezoid(F, G, x0, e, e, 0.5, 0.5 / k) - exact)) for k in (10, 20)]
    assert 3.5 < err[0] / err[1] < 4.5


def test_grid_point_clamps_and_interpolates():
    assert U.grid_point(3.0, 5.0, 0.25, 10) == (0, 0.0)
    assert U.grid_point(99.0, 5.0, 0.25, 10) == (8, 1.0)
    i, a = U.grid_point(5.6, 5.0, 0.25, 10)
    assert i == 2 and abs(a - 0.4) < 1e-12
    assert U.grid_point(7.0, 5.0, 0.25, 1) == (0, 0.0)


@pytest.mark.parametrize("name", ["pif-modified", "uio", "kinematic-lp"])
def test_exported_c_follows_the_description_bit_for_bit(name, tmp_path):
    """On a regular 100 Hz log with a gap (restarts and fixed-rate samples only) the generated C's
    w and phi are the kernel's, bit for bit: the same grid, interpolation and order of sums."""
    from roadbank.export import CModule, export_c

    est = E.make(name, sample_rate=None)
    est.set_sample_rate(100.0)
    n = 1200
    t = np.arange(n) / 100.0
    t[600:] += 1.5
    vx = 20.0 + 8.0 * np.sin(np.arange(n) / 150.0)
    vx[300:320] = 110.0                     # beyond the grid (clamped schedule), within a car's limits
    ay = 2.0 * np.sin(np.arange(n) / 40.0) + 0.3
    r = 0.05 * np.sin(np.arange(n) / 55.0)
    d = 0.02 * np.sin(np.arange(n) / 60.0 + 0.4)
    res = export_c(est, tmp_path, rate=100.0, discrete=True)
    c = CModule(res.source, tmp_path).run(t, vx, ay, r, d)
    est.reset()
    w, phi = np.empty(n), np.empty(n)
    for k in range(n):
        est.step(t[k], vx[k], ay[k], r[k], d[k])
        w[k], phi[k] = est._mem[M_W], est._mem[M_PHI]
    assert np.array_equal(c["w"], w), np.max(np.abs(c["w"] - w))
    assert np.array_equal(c["phi"], phi), np.max(np.abs(c["phi"] - phi))

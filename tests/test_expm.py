"""The batched matrix exponential of the fixed-rate discretisation (estimators/expm.py) against
closed forms and scipy.linalg.expm, and the discretised observers and their output with it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm as scipy_expm

from roadbank import estimators as E
from roadbank.estimators import base, discretise
from roadbank.estimators import layout as L
from roadbank.estimators.discretise import foh, foh_grid
from roadbank.estimators.expm import THETA13, expm_stack, squarings
from roadbank.estimators.synthesis import reference_solvers

KITTI = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts" / "2011_09_26_drive_0070"
needs_kitti = pytest.mark.skipif(not KITTI.is_dir(), reason=f"KITTI drive absent at {KITTI}")


def _norm_rel(a, b) -> float:
    """Largest over the stack of ||a - b||_1 / ||b||_1."""
    a, b = np.asarray(a).reshape(-1, *a.shape[-2:]), np.asarray(b).reshape(-1, *b.shape[-2:])
    return float(np.max(np.abs(a - b).sum(axis=-2).max(axis=-1) / np.abs(b).sum(axis=-2).max(axis=-1)))


def test_closed_forms():
    w = np.array([0.1, 1.0, 7.0, 40.0])                       # rotations: cos, sin (squarings for the big ones)
    A = np.zeros((4, 2, 2))
    A[:, 0, 1], A[:, 1, 0] = -w, w
    R = expm_stack(A)
    np.testing.assert_allclose(R[:, 0, 0], np.cos(w), atol=1e-14)
    np.testing.assert_allclose(R[:, 1, 0], np.sin(w), atol=1e-14)
    N = np.diag([2.0, 2.0, 2.0], 1)                          # nilpotent: I + N + N^2/2 + N^3/6
    np.testing.assert_allclose(expm_stack(N), np.eye(4) + N + N @ N / 2 + N @ N @ N / 6, rtol=1e-15, atol=1e-15)
    rng = np.random.default_rng(3)                            # diagonalisable with known eigenvalues
    V = rng.normal(size=(5, 5)) + 3 * np.eye(5)
    lam = np.array([-80.0, -12.0, -1.0, -0.01, 0.5])
    M = V @ np.diag(lam) @ np.linalg.inv(V)
    np.testing.assert_allclose(expm_stack(M), V @ np.diag(np.exp(lam)) @ np.linalg.inv(V), rtol=0, atol=1e-12)


def test_squarings_bring_the_norm_under_theta13():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(200, 6, 6)) * rng.uniform(1e-3, 3e3, size=(200, 1, 1))
    s = squarings(A)
    nrm = np.abs(A).sum(axis=-2).max(axis=-1)
    assert np.all(nrm / 2.0 ** s <= THETA13)
    assert np.all((s == 0) | (nrm / 2.0 ** (s - 1) > THETA13))  # the smallest such s


@pytest.mark.parametrize("n", [1, 4, 7, 9, 10, 11, 13])
def test_agrees_with_scipy_on_random_stacks(n):
    rng = np.random.default_rng(n)
    A = rng.normal(size=(60, n, n))
    A -= 2.0 * np.eye(n)                                       # mostly stable, as the observers are
    A *= rng.uniform(1e-3, 50.0, size=(60, 1, 1)) / np.abs(A).sum(axis=-2).max(axis=-1)[:, None, None]
    got = expm_stack(A)                                         # one stack, each its own number of squarings
    assert len(set(squarings(A))) > 2
    assert _norm_rel(got, scipy_expm(A)) < 1e-12
    for k in (0, 17, 59):                                       # a matrix alone gives the same as in the stack
        np.testing.assert_allclose(expm_stack(A[k]), got[k], rtol=1e-15, atol=1e-300)


def test_shapes_and_non_finite():
    assert expm_stack(np.zeros((0, 3, 3))).shape == (0, 3, 3)
    assert expm_stack(np.zeros((2, 0, 0))).shape == (2, 0, 0)
    np.testing.assert_array_equal(expm_stack(np.zeros((2, 3, 4, 4))), np.broadcast_to(np.eye(4), (2, 3, 4, 4)))
    A = np.zeros((2, 3, 3))
    A[1, 0, 1] = np.nan
    with np.errstate(invalid="ignore"):
        R = expm_stack(A)
    np.testing.assert_array_equal(R[0], np.eye(3))
    assert np.isnan(R[1]).any()
    with pytest.raises(ValueError, match="square"):
        expm_stack(np.zeros((3, 2)))


def _observer_grid(name: str, dt: float):
    est = E.make(name)
    n, row = est._nstate, L.lpv_row(est._nstate)
    tab, g = est._tab_cont, est._tab_cont.shape[0]
    return tab[:, row.F:row.G].reshape(g, n, n), tab[:, row.G:row.H].reshape(g, n, L.NETA)


@pytest.mark.parametrize("name", ["pif-modified", "pif-rate", "pio-modified", "kinematic-pif", "kalman"])
@pytest.mark.parametrize("dt", [0.01, 0.1, 0.137])
def test_foh_grid_agrees_with_scipy_on_the_observer_grids(name, dt):
    F, G = _observer_grid(name, dt)
    got = foh_grid(F, G, dt)
    with reference_solvers():                 # scipy.linalg.expm, matrix by matrix
        ref = foh_grid(F, G, dt)
    for a, b in zip(got, ref):
        assert np.max(np.abs(a - b)) <= 1e-12 * max(1.0, np.max(np.abs(b)))
    Phi, G0, G1 = foh(F[5], G[5], dt)           # one grid point: the numbers of the grid
    np.testing.assert_allclose(Phi, got[0][5], rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(G1, got[2][5], rtol=1e-14, atol=1e-16)


@needs_kitti
@pytest.mark.parametrize("name", ["pif-modified", "pif-gated", "kinematic-pif", "pif-smoother"])
def test_a_shared_kitti_drive_gives_the_output_of_scipys_exponential(name, monkeypatch):
    from roadbank.estimators import smoother
    from roadbank.io.kitti import load_kitti_oxts
    from roadbank.vehicle import for_log

    s = load_kitti_oxts(KITTI).signals

    def run():
        base._DISCRETE_CACHE.clear()
        smoother._TABLES.clear()
        est = for_log(name, s)                  # as `roadbank validate kitti` designs it
        out = est.run(s)
        return out, (est.discrete_tables(0.1) if est.kernel in base.FIXED_RATE_KERNELS else None)

    fast, tab_fast = run()
    monkeypatch.setattr(discretise, "_expm", scipy_expm)
    slow, tab_slow = run()
    base._DISCRETE_CACHE.clear()
    smoother._TABLES.clear()
    v = fast.valid & slow.valid
    assert v.sum() > 0.5 * len(v)
    np.testing.assert_array_equal(fast.valid, slow.valid)
    assert np.max(np.abs(fast.theta[v] - slow.theta[v])) <= 1e-12      # rad
    if tab_fast is not None:
        for k in ("Phi", "Gam0", "Gam1", "Phi_r", "Gam0_r", "Gam1_r"):
            assert np.max(np.abs(tab_fast[k] - tab_slow[k])) <= 1e-13 * max(1.0, np.max(np.abs(tab_slow[k]))), k

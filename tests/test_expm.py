"""The batched exponential of the fixed-rate discretisation (estimators/expm.py) against closed
forms and scipy.linalg.expm, and the discretised observers and their output with it."""

from __future__ import annotations

from pathlib import Path

import dataclasses
import numpy as np
import pytest
from scipy.linalg import expm as scipy_expm

from roadbank import estimators as E
from roadbank.estimators import base, discretise
from roadbank.estimators import layout as L
from roadbank.estimators.discretise import foh, foh_grid
from roadbank.estimators.expm import foh_blocks
from roadbank.estimators.synthesis import reference_solvers

KITTI = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts" / "2011_09_26_drive_0070"
needs_kitti = pytest.mark.skipif(not KITTI.is_dir(), reason=f"KITTI drive absent at {KITTI}")


def _augmented(F, G, h):
    g, n, m = G.shape
    M = np.zeros((g, n + 2 * m, n + 2 * m))
    M[:, :n, :n], M[:, :n, n:n + m], M[:, n:n + m, n + m:] = F, G, np.eye(m)
    return M * h


def _norm_rel_to_scipy(F, G, h) -> float:
    """Largest over the stack of ||top block row of foh_blocks - scipy's|| / ||scipy's exp(hM)||_1."""
    n = F.shape[1]
    E = scipy_expm(_augmented(F, G, h))
    got = np.concatenate(foh_blocks(F, G, h), axis=2)
    return float(np.max(np.abs(got - E[:, :n]).sum(axis=-2).max(axis=-1) / np.abs(E).sum(axis=-2).max(axis=-1)))


def test_closed_forms():
    # scalar x' = -a x + e: Phi = e^{-ah}, A1 = (1 - e^{-ah}) / a, A2 = h/a - (1 - e^{-ah}) / a^2
    a = np.array([1e-3, 0.5, 3.0, 40.0, 900.0])           # the large ones need squarings
    h = 0.1
    Phi, A1, A2 = foh_blocks(-a[:, None, None], np.ones((5, 1, 1)), h)
    e = np.exp(-a * h)
    np.testing.assert_allclose(Phi[:, 0, 0], e, rtol=1e-13)
    np.testing.assert_allclose(A1[:, 0, 0], -np.expm1(-a * h) / a, rtol=1e-12)
    np.testing.assert_allclose(A2[:, 0, 0], h / a + np.expm1(-a * h) / a ** 2, rtol=1e-9, atol=1e-15)
    # F = 0: Phi = I, A1 = h G, A2 = h^2/2 G (exactly: the powers end)
    G = np.arange(6.0).reshape(1, 2, 3)
    Phi, A1, A2 = foh_blocks(np.zeros((1, 2, 2)), G, 0.25)
    np.testing.assert_array_equal(Phi[0], np.eye(2))
    np.testing.assert_allclose(A1, 0.25 * G, rtol=1e-15)
    np.testing.assert_allclose(A2, 0.25 ** 2 / 2 * G, rtol=1e-15)
    # a rotation: Phi = [[cos, -sin], [sin, cos]]
    w = 30.0
    Phi, _, _ = foh_blocks(np.array([[[0.0, -w], [w, 0.0]]]), np.zeros((1, 2, 1)), 0.1)
    np.testing.assert_allclose(Phi[0], [[np.cos(3.0), -np.sin(3.0)], [np.sin(3.0), np.cos(3.0)]], atol=1e-14)


@pytest.mark.parametrize(("n", "m"), [(1, 1), (2, 3), (3, 3), (4, 3), (5, 3), (7, 3), (4, 1)])
def test_agrees_with_scipy_on_random_stacks(n, m):
    rng = np.random.default_rng(10 * n + m)
    F = rng.normal(size=(80, n, n)) - 2.0 * np.eye(n)       # mostly stable, as the observers are
    F *= rng.uniform(1e-2, 400.0, size=(80, 1, 1)) / np.abs(F).sum(axis=-2).max(axis=-1)[:, None, None]
    G = rng.normal(size=(80, n, m)) * rng.uniform(0.1, 50.0, size=(80, 1, 1))
    for h in (0.01, 0.1, 0.14):                            # one stack, each its own number of squarings
        assert _norm_rel_to_scipy(F, G, h) < 1e-12
    got = foh_blocks(F, G, 0.1)
    for k in (0, 41, 79):                                   # a system alone gives the same as in the stack
        one = foh_blocks(F[k:k + 1], G[k:k + 1], 0.1)
        for a, b in zip(one, got):
            np.testing.assert_array_equal(a[0], b[k])


def test_shapes_and_non_finite():
    for F, G in ((np.zeros((0, 3, 3)), np.zeros((0, 3, 2))), (np.zeros((2, 3, 3)), np.zeros((2, 3, 0)))):
        Phi, A1, A2 = foh_blocks(F, G, 0.1)
        assert Phi.shape == F.shape and A1.shape == A2.shape == G.shape
    F = np.zeros((2, 3, 3))
    F[1, 0, 1] = np.nan
    Phi, A1, _ = foh_blocks(F, np.ones((2, 3, 1)), 0.1)
    np.testing.assert_array_equal(Phi[0], np.eye(3))
    assert np.isnan(Phi[1]).any() and np.isnan(A1[1]).any()


def _scipy_blocks(F, G, h):
    n, m = F.shape[1], G.shape[2]
    E = scipy_expm(_augmented(F, G, h))
    return E[:, :n, :n], E[:, :n, n:n + m], E[:, :n, n + m:]


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
    with reference_solvers():                 # scipy.linalg.expm of the whole matrix, one by one
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

    s = dataclasses.replace(load_kitti_oxts(KITTI).signals, p=None)   # the ESP channels: the blend for kinematic-pif

    def run():
        base._DISCRETE_CACHE.clear()
        smoother._TABLES.clear()
        est = for_log(name, s)                  # as `roadbank validate kitti` designs it
        out = est.run(s)
        return out, (est.discrete_tables(0.1) if est.kernel in base.FIXED_RATE_KERNELS else None)

    fast, tab_fast = run()
    monkeypatch.setattr(discretise, "foh_blocks", _scipy_blocks)
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

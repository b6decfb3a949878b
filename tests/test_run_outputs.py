"""run() hands out output arrays it may reuse later (Estimator._outputs): results the caller
still holds, or any view of them, must never change; dropped results must not leak into new ones."""

import gc

import numpy as np
import pytest

from roadbank import Signals, estimators


def _log(seed, n):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    vx = 20.0 + rng.normal(size=n).cumsum() * 0.01
    ay = np.sin(t) + 0.05 * rng.normal(size=n)
    r = ay / vx
    return Signals(t, vx, ay, r, 0.05 * r)


# 140000 samples: arrays above base._POPULATE_MIN_BYTES (memory-mapped), 500: plain numpy arrays
@pytest.mark.parametrize("name, n", [("pif-modified", 500), ("dfc", 500), ("pif-modified", 140_000)])
def test_held_results_and_views_never_change(name, n):
    est = estimators.make(name)
    a, b = _log(1, n), _log(2, n)
    first = est.run(a)
    snapshot = {k: getattr(first, k).copy() for k in ("w", "theta", "phi_b", "valid")}
    second = est.run(a)
    kept_views = [second.states[k] for k in second.states] + [second.w[::3], second.phi_b[1:][::2]]
    view_copies = [v.copy() for v in kept_views]
    del second                                     # only views of the second result are kept
    for _ in range(3):
        est.run(b)                                 # results dropped at once: their memory may be reused
    for k, v in snapshot.items():
        np.testing.assert_array_equal(getattr(first, k), v)
    for v, c in zip(kept_views, view_copies):
        np.testing.assert_array_equal(v, c)


@pytest.mark.slow
def test_reused_memory_gives_the_same_numbers_as_a_fresh_estimator():
    a, b = _log(3, 140_000), _log(4, n=300)
    est = estimators.make("pif-modified")
    for sig in (a, a, b, a):                       # same length (reuse) and another length (new arrays)
        got = est.run(sig)
        ref = estimators.make("pif-modified").run(sig)
        for k in ("w", "theta", "phi_b", "valid"):
            np.testing.assert_array_equal(getattr(got, k), getattr(ref, k))
            assert getattr(got, k).flags.writeable
        for k in ref.states:
            np.testing.assert_array_equal(got.states[k], ref.states[k])
        assert got.t is sig.t and not got.t.flags.writeable
        del got, ref
        gc.collect()


def test_batch_angles_beyond_the_polynomial_equal_step():
    """Samples with |w| beyond asin_fast's polynomial (banks over 17.5 deg) take libm's asin in the
    batch loop's angle pass as in step(): run() and step() agree bit for bit on both sides of it."""
    from roadbank.estimators.kernels import ASIN_POLY_MAX
    n = 1200
    t = np.arange(n) * 0.01
    bank = np.deg2rad(np.where((np.arange(n) // 300) % 2 == 1, 25.0, 5.0))   # steps across the range
    vx = np.full(n, 20.0)
    ay = 9.81 * np.sin(bank)
    sig = Signals(t, vx, ay, np.zeros(n), np.zeros(n))
    batch = estimators.make("pif-modified").run(sig)
    assert np.any(np.abs(batch.w) > ASIN_POLY_MAX) and np.any(np.abs(batch.w) < ASIN_POLY_MAX)
    est = estimators.make("pif-modified")
    out = [est.step(t[k], vx[k], ay[k], 0.0, 0.0) for k in range(n)]
    for field in ("w", "theta", "phi_b", "valid"):
        assert np.array_equal(getattr(batch, field), [getattr(o, field) for o in out]), field

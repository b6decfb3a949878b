"""Compiled-kernel helpers checked against independent references (libm, exact series bounds)."""

import math
from fractions import Fraction

import numpy as np
import pytest
from numba import njit

from roadbank.estimators.kernels import ASIN_POLY_MAX, asin_fast
from roadbank.estimators.layout import (adaptive_block, adaptive_state, gate_states, gated_block, lpv_row,
                                        riccati_block, riccati_p, riccati_row, riccati_work, roll_block, roll_states,
                                        smooth_fixed_row, smooth_row)


@njit(cache=False)
def _asin_many(x, out):
    for k in range(x.shape[0]):
        out[k] = asin_fast(x[k])


def _ulp(y):
    return np.spacing(np.abs(y))


def test_asin_series_truncation_bound():
    """The neglected tail of the (positive-term) Taylor series is below 5e-17 rad at the range end."""
    x = Fraction(ASIN_POLY_MAX)
    c13 = Fraction(math.factorial(26), 4 ** 13 * math.factorial(13) ** 2 * 27)
    assert float(c13 * x ** 27 / (1 - x * x)) < 5e-17


def test_asin_fast_within_two_ulp_of_libm():
    """Dense grid over the polynomial's range (and its edges): within 2 ulp of libm's asin
    (itself within 1 ulp of the exact angle); outside the range it is libm's asin."""
    inner = np.concatenate([np.linspace(-ASIN_POLY_MAX, ASIN_POLY_MAX, 1_000_001),
                            np.geomspace(1e-300, ASIN_POLY_MAX, 20_000), [0.0, -0.0]])
    out = np.empty_like(inner)
    _asin_many(inner, out)
    ref = np.arcsin(inner)
    assert np.all(np.abs(out - ref) <= 2 * _ulp(ref))
    assert np.array_equal(np.signbit(out), np.signbit(ref))
    outer = np.concatenate([np.linspace(ASIN_POLY_MAX, 1.0, 10_001)[1:], -np.linspace(ASIN_POLY_MAX, 1.0, 10_001)[1:]])
    out2 = np.empty_like(outer)
    _asin_many(outer, out2)
    assert np.array_equal(out2, np.array([math.asin(v) for v in outer]))


def _mixed_log():
    """20 s at 100 Hz: uniform stretches (fixed-rate batch loop), jitter and a gap (general path,
    re-initialisation), a speed dip below v_min and a NaN (invalid samples)."""
    from roadbank import Signals
    n = 2000
    t = np.arange(n) / 100.0
    t[600:800] += 0.003 * np.sin(np.arange(200))
    t[1200:] += 2.0
    vx = 20.0 + 5.0 * np.sin(t / 3.0)
    vx[900:910] = 3.0
    ay = 2.0 * np.sin(t) + 0.3
    ay[1500] = np.nan
    r = ay / vx
    return Signals(t, vx, ay, r, 2.6 * ay / vx ** 2)


#: keyword options of the estimators built under another name in the kernel tests
_BUILT = {"riccati": ("pif-modified", {"variant": "riccati"}),
          "kinematic-lp-limited": ("kinematic-lp", {"clip": 2.0, "bank_rate": 0.01, "Q_ay": 0.01, "R": 1e-5})}


def _make(name, **kw):
    from roadbank import estimators
    base, extra = _BUILT.get(name, (name, {}))
    return estimators.make(base, **extra, **kw)


@pytest.mark.parametrize("name", ["kinematic", "dfc", "uio", "pio-original", "pio-modified", "pif-modified",
                                  "pif-original", "kalman", "pif-rate", "pif-adaptive", "riccati", "pif-gated",
                                  "kinematic-pif", "kinematic-lp-limited"])
@pytest.mark.parametrize("roll", ["static", "dynamic"])
def test_run_equals_step_bit_for_bit(name, roll):
    """The batch kernels (including the fixed-rate batch loop) and the per-sample step are the same
    arithmetic: identical outputs, for every estimator and roll model, across path switches, limited low-passes
    included."""
    make = lambda: _make(name, roll=roll)   # noqa: E731
    s = _mixed_log()
    batch = make().run(s)
    est = make()
    out = [est.step(s.t[k], s.vx[k], s.ay[k], s.r[k], s.delta_f[k]) for k in range(len(s))]
    for field in ("w", "theta", "phi_b", "valid"):
        assert np.array_equal(getattr(batch, field), [getattr(o, field) for o in out]), field


@pytest.mark.parametrize("name", ["kinematic", "kinematic-lp", "kinematic-ff", "kinematic-lp-limited", "uio",
                                  "pio-modified", "pif-modified", "kalman", "pif-gated", "kinematic-pif",
                                  "pif-adaptive", "dfc", "riccati"])
def test_each_estimator_runs_the_batch_kernel_of_its_size(name):
    """The batch kernel an estimator calls (:func:`roadbank.estimators.kernels.entries`) is the three-state loop's
    (``lpv3_run``) exactly for a three-state ``lpv`` observer whose roll model has 0 or 2 states, and its family's
    otherwise."""
    from roadbank.estimators import kernels as K
    from roadbank.estimators.layout import C_N, C_NR
    est = _make(name, sample_rate=100.0)
    three = est.kernel == "lpv" and est._cfg[C_N] == 3 and est._cfg[C_NR] in (0, 2) and est.batch3_loop
    assert (est._run_fn is K.lpv3_run) == three
    assert (est._run_fn, est._step_fn) == K.ENTRIES["lpv3" if three else est.kernel]


def test_three_state_batch_loop_equals_the_plain_loop():
    """``lpv3_run`` (fixed-rate samples in the three-state batch loop) and ``lpv_run`` (every sample through
    ``lpv_step``) give the same outputs to the bit on a log that switches paths."""
    from roadbank.estimators import kernels as K
    s = _mixed_log()
    batch = _make("pif-modified", roll="dynamic", sample_rate=100.0)
    plain = _make("pif-modified", roll="dynamic", sample_rate=100.0)
    assert batch._run_fn is K.lpv3_run
    plain._run_fn = K.lpv_run
    a, b = batch.run(s), plain.run(s)
    for field in ("w", "theta", "phi_b", "valid"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field


def test_the_smoothers_forward_pass_takes_the_general_loop_and_is_the_pif():
    """``pif-smoother``'s forward pass runs through ``lpv_run`` (``batch3_loop`` False: no three-state loop to compile
    for ``roadbank map``), and gives what ``pif-modified``, its causal filter in the three-state loop, gives, to the
    bit, on a log that switches paths."""
    from roadbank.estimators import PIF
    from roadbank.estimators import kernels as K
    s = _mixed_log()
    smoother, pif = _make("pif-smoother", sample_rate=100.0), _make("pif-modified", sample_rate=100.0)
    assert smoother._run_fn is K.lpv_run and pif._run_fn is K.lpv3_run
    a, b = PIF.run(smoother, s), pif.run(s)
    for field in ("w", "theta", "phi_b", "valid"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field


_COMPILED_BY_KINEMATIC = """
import numpy as np
from roadbank import Signals, estimators
from roadbank.estimators.kernels import lpv
n = 50
s = Signals(np.arange(n) * 0.01, np.full(n, 20.0), np.full(n, 0.5), np.full(n, 0.01), np.full(n, np.nan))
estimators.make("kinematic").run(s)
print(bool(lpv.lpv_step.signatures), bool(lpv.lpv_run.signatures), bool(lpv.lpv3_fixed_run.signatures))
"""


def test_an_observer_of_another_size_does_not_compile_the_three_state_loop(tmp_path):
    """A fresh process (empty numba cache) that runs the kinematic estimate (an ``lpv`` observer without states)
    compiles ``lpv_step`` and ``lpv_run`` but not the three-state batch loop: the variant keeps that code out of
    its first run."""
    import os
    import subprocess
    import sys
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    out = subprocess.run([sys.executable, "-c", _COMPILED_BY_KINEMATIC], capture_output=True, text=True, env=env,
                         timeout=300, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["True", "True", "False"]


@njit(cache=False)
def _compiled_offsets(n, p, nr):
    """The layout helpers as the kernels call them (compiled)."""
    return (lpv_row(n), roll_block(nr), riccati_block(n, p, nr), riccati_row(n, p), riccati_work(n, p),
            adaptive_block(nr), gated_block(n, nr), smooth_row(n), smooth_fixed_row(n), roll_states(n),
            riccati_p(n, nr), adaptive_state(n, nr), gate_states(n, nr))


def _python_offsets(n, p, nr):
    from roadbank.estimators import layout as L
    return (L.lpv_row(n), L.roll_block(nr), L.riccati_block(n, p, nr), L.riccati_row(n, p), L.riccati_work(n, p),
            L.adaptive_block(nr), L.gated_block(n, nr), L.smooth_row(n), L.smooth_fixed_row(n), L.roll_states(n),
            L.riccati_p(n, nr), L.adaptive_state(n, nr), L.gate_states(n, nr))


@pytest.mark.parametrize("n, p, nr", [(0, 1, 0), (1, 1, 0), (3, 1, 2), (4, 2, 2), (7, 2, 0)])
def test_layout_is_one_description_for_python_and_compiled_code(n, p, nr):
    """The kernels call the layout's offset functions compiled; Python builds the arrays with the same
    functions: the offsets agree, and the blocks of each array follow one another without overlap."""
    from roadbank.estimators import layout as L
    compiled = _compiled_offsets(np.int64(n), np.int64(p), np.int64(nr))
    python = _python_offsets(n, p, nr)
    assert [tuple(c) if isinstance(c, tuple) else c for c in compiled] == \
           [tuple(c) if isinstance(c, tuple) else c for c in python]
    row = L.lpv_row(n)                                    # F | G | H | D | J | Phi | Gam0 | Gam1
    sizes = [n * n, n * L.NETA, n, L.NETA, n * L.NETA, n * n, n * L.NETA, n * L.NETA]
    assert list(np.diff([row.F, row.G, row.H, row.D, row.J, row.Phi, row.Gam0, row.Gam1, row.end])) == sizes
    rw = L.riccati_work(n, p)
    assert rw.K == L.riccati_row(n, p).end and rw.S <= L.work_size(n)
    assert L.gate_state(n, nr) + 2 <= L.mem_size(n, nr) and L.riccati_p(n, nr) + n * n <= L.mem_size(n, nr)


def test_kernel_cache_entries_go_stale_with_any_kernel_source(tmp_path):
    """A kernel holds code of the package's other modules and of the layout: its cache stamp covers
    every one of those files, so an edit to any of them invalidates the cached machine code."""
    from roadbank.estimators import kernels as K
    from roadbank.estimators.kernels import _jit
    names = {p.name for p in _jit.SOURCES}
    assert {"sample.py", "lpv.py", "linalg.py", "simd.py", "layout.py"} <= names
    files = [tmp_path / f"m{k}.py" for k in range(3)]
    for f in files:
        f.write_text("x = 1\n")
    before = _jit.sources_stamp(files)
    files[1].write_text("x = 2\n")
    assert _jit.sources_stamp(files) != before
    loc = K.lpv_run._cache._impl.locator              # numba's cache of the lpv batch kernel
    assert isinstance(loc, _jit.KernelCacheLocator)
    assert loc.get_source_stamp()[1] == _jit.sources_stamp(_jit.SOURCES)

"""Whole-log decisions on a log read in chunks: the exact median of :class:`ExactMedian` equals
``numpy.median`` of all the numbers at once, and the ``time_base = "auto"`` rule decided in passes
over chunks equals the rule on the whole log (:func:`roadbank.io.resample.common_time_base`),
also where the medians sit at the 1 % limit and the first pass cannot tell."""

from __future__ import annotations

import numpy as np
import pytest

from roadbank.io.resample import common_time_base
from roadbank.io.survey import ExactMedian, auto_uses_clock


def _median_in_passes(x, chunk):
    m = ExactMedian()
    passes = 0
    while not m.exact:
        for i in range(0, len(x), chunk):
            m.add(x[i:i + chunk])
        m.end_pass()
        passes += 1
    lo, hi = m.bounds()
    assert lo == hi
    return lo, passes


@pytest.mark.parametrize("n", [1, 2, 7, 1000, 1001])
@pytest.mark.parametrize("kind", ["spread", "jitter", "repeated"])
def test_exact_median_equals_numpy(n, kind):
    rng = np.random.default_rng(n)
    x = {"spread": np.exp(rng.uniform(-20, 5, n)),                # many octaves
         "jitter": 0.01 + rng.uniform(-1e-9, 1e-9, n),            # all in one coarse bin
         "repeated": rng.choice([0.01, 0.02, 0.0100000001], n)}[kind]
    got, passes = _median_in_passes(x, 97)
    assert got == float(np.median(x)) and passes == 3


def test_bounds_hold_the_median_after_each_pass():
    rng = np.random.default_rng(5)
    x = 0.02 + rng.uniform(-1e-3, 1e-3, 5000)
    m = ExactMedian()
    widths = []
    while not m.exact:
        m.add(x)
        m.end_pass()
        lo, hi = m.bounds()
        assert lo <= np.median(x) <= hi
        widths.append(hi - lo)
    assert widths[0] > widths[1] > widths[2] == 0.0


def _table(ratio, n=4001, seed=0):
    """A 100 Hz clock; the role valid on every row but with a speed channel whose valid samples come
    at ``ratio`` times the clock's median period in the middle of the log."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(np.full(n, 0.01) + rng.uniform(-1e-6, 1e-6, n))
    a = np.sin(t)
    v = np.full(n, np.nan)
    step = 0.01 * ratio            # valid stamps on a grid `step` apart: the nearest clock rows
    want = np.arange(t[0], t[-1], step)
    v[np.unique(np.searchsorted(t, want))[:-1]] = 1.0
    return t, {"a": a, "v": v}


def _whole_rule(t, vals):
    base = common_time_base({r: (t, v) for r, v in vals.items()}, "auto", shared_clock=t)
    return base is t


@pytest.mark.parametrize("ratio", [1.0, 1.0098, 1.01, 1.0102, 1.5])
@pytest.mark.parametrize("chunk", [50, 4001])
def test_auto_rule_in_chunks_equals_the_whole_rule(ratio, chunk):
    t, vals = _table(ratio)
    calls = []

    def passes():
        calls.append(1)
        return ((t[i:i + chunk], {r: v[i:i + chunk] for r, v in vals.items()}) for i in range(0, len(t), chunk))

    assert auto_uses_clock(passes, list(vals)) == _whole_rule(t, vals)
    assert 1 <= len(calls) <= 3


@pytest.mark.parametrize("over", [1e-8, -1e-8])
def test_rule_at_the_limit_needs_a_finer_pass(over):
    # clock steps: 600 of 0.01 s (its median) and 400 of B = 0.0101 s (1 + over); the speed channel
    # skips the row between two 0.01 s steps, so its median step is B: 1 % above the clock's to
    # within 1e-8, which the first pass's bins (2^-16 wide) cannot tell apart from 1 %
    b = 0.0101 * (1 + over)
    steps = np.array([0.01, 0.01, b] * 300 + [b] * 100)
    t = np.concatenate(([0.0], np.cumsum(steps)))
    v = np.ones(len(t))
    v[1:900:3] = np.nan                     # the row between the two 0.01 s steps of each triple
    vals = {"a": np.ones(len(t)), "v": v}
    calls = []

    def passes():
        calls.append(1)
        return [(t[:500], {r: x[:500] for r, x in vals.items()}), (t[500:], {r: x[500:] for r, x in vals.items()})]

    assert auto_uses_clock(passes, ["a", "v"]) == _whole_rule(t, vals) == (over < 0)
    assert len(calls) >= 2

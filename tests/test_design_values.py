"""A design is a value: an estimator's design inputs (a frozen dataclass) are the whole key of its
tables; one sample-rate rule serves the time base and the fixed-rate path."""

import dataclasses

import numpy as np
import pytest

from roadbank import Signals
from roadbank import estimators as E
from roadbank.estimators import base
from roadbank.estimators.dfc import DFC
from roadbank.estimators.synthesis import NoStabilisingSolution
from roadbank.signals import interval_rate, sample_rate

GRID = {"v_step": 2.5, "v_max": 30.0}          # a short grid: each design takes milliseconds


class NotedDFC(DFC):
    """A user's subclass that keeps a note of its own before ``Estimator.__init__``: not a design input."""

    def __init__(self, params=None, *, note="", **kw):
        self.note = note
        super().__init__(params, **kw)


@pytest.fixture
def disk(tmp_path, monkeypatch):
    """An empty cache directory and an empty in-process memo (the global one is left alone)."""
    monkeypatch.setenv("ROADBANK_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(base, "_DESIGN_CACHE", {})
    return tmp_path / "design"


def _log(n=2000, h=0.01):
    rng = np.random.default_rng(5)
    t = 3.0 + np.arange(n) * h
    vx = 18.0 + 4.0 * np.sin(t / 5.0)
    r = 0.15 * np.sin(t / 1.5)                                  # weaving: transients for DFC
    bank = np.deg2rad(4.0) * np.sin(t / 4.0)
    ay = vx * r + 9.81 * np.sin(bank) + 0.8 * np.cos(t / 1.5) + 0.05 * rng.normal(size=n)
    return Signals(t, vx, ay, r, 0.06 * r)


def test_a_subclass_attribute_that_is_no_design_field_leaves_the_key_and_shares_the_design(disk, monkeypatch):
    first = NotedDFC(note="first", **GRID)

    def no_design(self):
        raise AssertionError("designed again for a setting that is not a design input")
    monkeypatch.setattr(NotedDFC, "_design", no_design)
    second = NotedDFC(note="second", **GRID)
    assert second.note == "second"
    assert second.design == first.design
    assert second._design_key() == first._design_key() and second._disk_key() == first._disk_key()
    assert second._tab_cont is first._tab_cont
    assert len(list(disk.glob("*.npz"))) == 1
    base._DESIGN_CACHE.clear()                         # a new process: the disk entry serves it
    third = NotedDFC(note="third", **GRID)
    assert np.array_equal(third._tab_cont, first._tab_cont)


def test_equal_design_inputs_share_one_design_and_settings_beyond_them_still_act(disk, monkeypatch):
    """DFC's a_ref only enters its kernel: two DFCs that differ in it share the tables and still
    estimate differently; a PIF's P0 only sets the Riccati variant's initial memory."""
    a = E.make("dfc", a_ref=1.0, **GRID)
    b = E.make("dfc", a_ref=3.0, **GRID)
    assert a.design == b.design and b._tab_cont is a._tab_cont
    sig = _log()
    assert not np.allclose(a.run(sig).theta, b.run(sig).theta)

    p = E.make("pif-modified", tuning="paper", variant="riccati", **GRID)
    q = E.make("pif-modified", tuning="paper", variant="riccati", P0=(0.0, 0.0, 5.0), R=[0.0035], **GRID)
    assert p.design == q.design and q._tab_cont is p._tab_cont
    assert len(list(disk.glob("*.npz"))) == 2
    assert not np.allclose(p.run(sig).theta, q.run(sig).theta)


def test_the_design_is_a_frozen_value_and_each_field_keys_it(disk):
    est = E.make("pif-modified", tuning="paper", **GRID)
    d = est.design
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.Q = 1.0
    assert d.Q == est.Q and d.th == est.th and d.R == (0.0035,) and np.array_equal(d.vgrid, est.vgrid)
    keys = {est._disk_key()}
    for change in ({"Q": 0.2}, {"th": 0.5}, {"R": (0.004,)}, {"v_step": 2.0}, {"model": "original"}):
        est._inputs = dataclasses.replace(d, **change)
        keys.add(est._disk_key())
    est._inputs = d
    assert len(keys) == 6


def test_a_default_th_is_halved_over_design_values_in_one_construction(monkeypatch):
    """No retry of ``Estimator.__init__``: the th halving runs over design values; the th it stops
    at is solvable, twice it is not, and an explicit PIF with that th has the same tables."""
    calls = []
    real = base.Estimator.__init__

    def counted(self, *a, **k):
        calls.append(1)
        real(self, *a, **k)
    monkeypatch.setattr(base.Estimator, "__init__", counted)
    start = 1e7                                  # unsolvable on this grid; 3e5 is solvable
    est = E.make("pif-modified", th=start, adapt_th=True, **GRID)
    assert calls == [1]
    assert 0.0 < est.th < start and est.design.th == est.th
    monkeypatch.undo()
    with pytest.raises(NoStabilisingSolution):
        E.make("pif-modified", th=2.0 * est.th, **GRID)
    again = E.make("pif-modified", th=est.th, **GRID)
    assert np.array_equal(again._tab_cont, est._tab_cont)


@pytest.mark.parametrize("h", [0.01, 0.02, 0.1, 1.0 / 3.0, 0.005])
def test_one_sample_rate_rule_for_the_time_base_and_the_fixed_rate_path(h):
    """On a uniform log the median interval is the first: the log's rate and the rate the
    fixed-rate path takes at its first interval are the same number, a whole Hz where 1/h is one."""
    sig = _log(n=600, h=h)
    est = E.make("pif-modified", tuning="paper", **GRID)
    est.run(sig)
    assert est.fixed_dt == 1.0 / interval_rate(sig.t[1] - sig.t[0])
    assert sample_rate(sig.t) == 1.0 / est.fixed_dt
    if abs(1.0 / h - round(1.0 / h)) < 1e-9:
        assert sample_rate(sig.t) == round(1.0 / h)


def test_interval_rate_is_the_median_rule():
    dt = np.array([0.1, 0.06, 0.14, 0.1, np.nan, -0.2, 0.0, 0.11])
    assert interval_rate(dt) == pytest.approx(1.0 / np.median([0.1, 0.06, 0.14, 0.1, 0.11]), rel=1e-15)
    assert np.isnan(interval_rate([])) and np.isnan(interval_rate([0.0, -1.0]))
    assert interval_rate(0.25) == 4.0

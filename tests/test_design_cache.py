"""The on-disk cache of gain-schedule designs (roadbank.cache, Estimator._cached_design)."""

import os
import threading

import numpy as np
import pytest

from roadbank import VehicleParams, cache
from roadbank import estimators as E
from roadbank.estimators import base
from roadbank.vehicle import load_vehicle

GRID = {"v_step": 2.5, "v_max": 30.0}          # a short grid: each design takes milliseconds


@pytest.fixture
def disk(tmp_path, monkeypatch):
    """An empty cache directory and an empty in-process memo (the global one is left alone)."""
    monkeypatch.setenv("ROADBANK_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(base, "_DESIGN_CACHE", {})
    return tmp_path / "design"


def _fresh(name, **kw):
    """An estimator built from scratch: no memo, no disk."""
    est = E.make(name, **GRID, **kw)
    return est._design()


def _entries(folder):
    return sorted(folder.glob("*.npz")) if folder.exists() else []


@pytest.mark.parametrize("name,kw", [("pif-modified", {"tuning": "paper"}), ("dfc", {}), ("uio", {})])
def test_disk_hit_returns_identical_tables_without_designing(disk, monkeypatch, name, kw):
    first = E.make(name, **GRID, **kw)
    assert len(_entries(disk)) == 1
    base._DESIGN_CACHE.clear()                              # as in a new process

    def no_design(self):
        raise AssertionError("designed again despite a disk entry")
    monkeypatch.setattr(type(first), "_design", no_design)
    second = E.make(name, **GRID, **kw)
    monkeypatch.undo()
    tab, n, extra = _fresh(name, **kw)                      # independent: a new design
    assert np.array_equal(second._tab_cont, tab) and second._tab_cont.dtype == np.float64
    assert second._nstate == n == first._nstate and type(second._nstate) is int
    assert np.array_equal(second._extra, extra)
    assert second._tab_cont.flags.c_contiguous


def test_damaged_entry_is_ignored_and_rewritten(disk):
    E.make("pif-modified", tuning="paper", **GRID)
    (entry,) = _entries(disk)
    for junk in (b"", b"not an npz file", entry.read_bytes()[:200]):
        entry.write_bytes(junk)
        base._DESIGN_CACHE.clear()
        est = E.make("pif-modified", tuning="paper", **GRID)
        assert np.array_equal(est._tab_cont, _fresh("pif-modified", tuning="paper")[0])
        with np.load(entry, allow_pickle=False) as z:        # rewritten, readable again
            assert np.array_equal(z["tab"], est._tab_cont)


def test_different_settings_get_different_entries(disk):
    heavy = VehicleParams(m=VehicleParams().m * 1.2)
    a = E.make("pif-modified", tuning="paper", **GRID)
    b = E.make("pif-modified", VehicleParams(m=heavy.m), tuning="paper", **GRID)
    c = E.make("pif-modified", **GRID)                                # default tuning
    d = E.make("pif-modified", tuning="paper", v_step=2.0, v_max=30.0)  # another grid
    assert len(_entries(disk)) == 4
    assert not np.array_equal(a._tab_cont, b._tab_cont)
    assert not np.array_equal(a._tab_cont, c._tab_cont)
    assert a._tab_cont.shape != d._tab_cont.shape


def test_key_is_exact_where_repr_rounds():
    x = np.array([1.0, 2.0])
    y = x + 1e-12                                          # repr shows the same digits
    assert repr(x) == repr(y)
    assert cache.canonical(x) != cache.canonical(y)
    assert cache.canonical(0.1) != cache.canonical(np.nextafter(0.1, 1.0))
    assert cache.canonical(VehicleParams()) == cache.canonical(VehicleParams())


def test_entry_with_another_key_is_a_miss(disk):
    cache.store("design", "key-a", {"tab": np.ones(3)})
    (entry,) = _entries(disk)
    path_b = cache._entry("design", "key-b")[0]
    path_b.write_bytes(entry.read_bytes())                 # right name, wrong content
    assert cache.load("design", "key-b") is None
    assert np.array_equal(cache.load("design", "key-a")["tab"], np.ones(3))


def test_off_disables_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ROADBANK_CACHE_DIR", "off")
    monkeypatch.setattr(base, "_DESIGN_CACHE", {})
    assert cache.cache_dir() is None
    assert cache.store("design", "k", {"a": np.ones(2)}) is None
    E.make("dfc", **GRID)
    assert not any(tmp_path.iterdir())


def test_concurrent_writers_and_readers_see_whole_entries(disk):
    """Writers replace the entry atomically: a reader gets the complete arrays or a miss."""
    big = np.arange(200_000, dtype=float)
    seen = []

    def write():
        for _ in range(10):
            cache.store("design", "shared", {"tab": big})

    done = threading.Event()

    def read():
        last = False
        while not last:                 # while the writers write, and once after they have finished
            last = done.is_set()
            z = cache.load("design", "shared")
            if z is not None:
                seen.append(np.array_equal(z["tab"], big))

    writers = [threading.Thread(target=write) for _ in range(2)]
    readers = [threading.Thread(target=read) for _ in range(2)]
    for t in writers + readers:
        t.start()
    for t in writers:
        t.join()
    done.set()
    for t in readers:
        t.join()
    assert len(seen) >= 2 and all(seen)
    assert len(_entries(disk)) == 1 and not list(disk.glob(".tmp-*"))


def test_store_keeps_only_the_newest_entries(disk, monkeypatch):
    monkeypatch.setattr(cache, "MAX_ENTRIES", 3)
    monkeypatch.setattr(cache, "PRUNE_EVERY", 1)                 # counted at every store
    for k in range(5):
        p = cache.store("design", f"k{k}", {"a": np.full(2, k)})
        os.utime(p, (1000 + k, 1000 + k))
    kept = {int(cache.load("design", f"k{k}")["a"][0]) for k in range(5) if cache.load("design", f"k{k}") is not None}
    assert kept == {2, 3, 4}


def test_no_home_directory_means_no_cache_not_an_error(monkeypatch):
    monkeypatch.delenv("ROADBANK_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setattr(base, "_DESIGN_CACHE", {})

    def no_home():
        raise RuntimeError("Could not determine home directory.")
    monkeypatch.setattr(cache.Path, "home", staticmethod(no_home))
    assert cache.cache_dir() is None
    est = E.make("dfc", **GRID)
    assert np.array_equal(est._tab_cont, _fresh("dfc")[0])


def test_user_subclass_is_keyed_on_its_source_file(disk, tmp_path, monkeypatch):
    """An estimator defined outside roadbank: editing its file must not return stale tables;
    one without a source file (defined interactively) is never cached on disk."""
    import importlib
    import sys
    src = tmp_path / "my_observer.py"
    code = ("from roadbank.estimators.dfc import DFC\n"
            "class Mine(DFC):\n"
            "    def _design(self):\n"
            "        tab, n, extra = super()._design()\n"
            "        return tab * {f}, n, extra\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    tabs = []
    for k, f in enumerate((1.0, 2.0)):
        src.write_text(code.format(f=f))
        os.utime(src, ns=(10**18 + k, 10**18 + k))         # a distinct modification time
        sys.modules.pop("my_observer", None)
        importlib.invalidate_caches()
        mod = importlib.import_module("my_observer")
        base._DESIGN_CACHE.clear()
        tabs.append(mod.Mine(**GRID)._tab_cont)
    assert np.array_equal(tabs[1], 2.0 * tabs[0])
    assert len(_entries(disk)) == 2
    Interactive = type("Interactive", (E.dfc.DFC,), {"__module__": "not_a_module"})
    assert cache.code_stamp(Interactive) is None
    base._DESIGN_CACHE.clear()
    Interactive(**GRID)
    assert len(_entries(disk)) == 2


@pytest.mark.slow
def test_an_unsolvable_design_is_remembered_so_the_th_retry_costs_nothing_next_time(disk, monkeypatch):
    """pif-rate-adaptive's default th has no stabilising solution for the paper SUV, so it is
    halved; the failed attempt costs as many AREs as a design and is remembered (memo and disk)."""
    from roadbank.estimators import pif
    calls = []
    real = pif.game_are

    def counted(*a, **k):
        calls.append(1)
        return real(*a, **k)
    monkeypatch.setattr(pif, "game_are", counted)
    first = E.make("pif-rate-adaptive")          # the full grid: the th fails at high speed
    assert first.th < pif.RATE_ADAPTIVE_TUNING["th"]          # the retry happened
    assert len(calls) > 0 and len(_entries(disk)) == 2        # the failure and the solution
    for clear_memo in (False, True):                          # same process; a new process
        if clear_memo:
            base._DESIGN_CACHE.clear()
        calls.clear()
        again = E.make("pif-rate-adaptive")
        assert calls == [] and again.th == first.th
        assert np.array_equal(again._tab_cont, first._tab_cont)
    with pytest.raises(pif.NoStabilisingSolution):            # an explicit th is not retried,
        E.make("pif-rate-adaptive", th=pif.RATE_ADAPTIVE_TUNING["th"])   # and the memo says so
    assert calls == []


#: designs every table of a few estimators in a new process and saves them (``np.savez``): ``argv``
#: the output file and the estimators' names, in the order they are designed ("riccati":
#: ``pif-modified`` paper tuning on the Riccati ODE, whose equations the steady filter solves too)
_DESIGN_SCRIPT = """
import sys
import numpy as np
from roadbank import estimators as E
KW = {"riccati": ("pif-modified", {"tuning": "paper", "variant": "riccati"}),
      "steady": ("pif-modified", {"tuning": "paper"})}
out = {}
for name in sys.argv[2:]:
    n, kw = KW.get(name, (name, {}))
    est = E.make(n, **kw)
    out[name + ".tab"], out[name + ".extra"] = est._tab_cont, est._extra
    out[name + ".nstate"] = np.int64(est._nstate)
    if hasattr(est, "_smooth_tab"):
        out[name + ".smooth"] = est._smooth_tab
np.savez(sys.argv[1], **out)
"""


def _designed_in_a_new_process(cache_dir, out, names):
    import subprocess
    import sys
    from pathlib import Path
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = {**os.environ, "ROADBANK_CACHE_DIR": str(cache_dir),
           "PYTHONPATH": os.pathsep.join([src, *filter(None, [os.environ.get("PYTHONPATH")])])}
    subprocess.run([sys.executable, "-c", _DESIGN_SCRIPT, str(out), *names], env=env, check=True)
    with np.load(out) as z:
        return {k: z[k] for k in z.files}


@pytest.mark.slow
def test_a_cached_design_is_bit_identical_to_a_fresh_one_whatever_was_designed_before(tmp_path):
    """A design depends on its inputs alone: designed after others and read from the disk cache
    (the smoother's backward table designed again over a forward design read from disk), it
    equals to the bit the same design made first in a new process without a cache."""
    names = ["steady", "riccati", "pif-smoother", "kalman", "pif-adaptive", "dfc"]
    disk = tmp_path / "cache"
    _designed_in_a_new_process(disk, tmp_path / "a.npz", names)             # fills the cache
    for entry in (disk / "smoother").glob("*.npz"):
        entry.unlink()
    cached = _designed_in_a_new_process(disk, tmp_path / "b.npz", names)
    fresh = {}
    for name in ("riccati", "pif-smoother", "pif-adaptive", "kalman", "dfc", "steady"):   # each first
        fresh.update(_designed_in_a_new_process("off", tmp_path / "c.npz", [name]))
    assert cached.keys() == fresh.keys() and "pif-smoother.smooth" in fresh
    for k in fresh:
        assert cached[k].dtype == fresh[k].dtype and np.array_equal(cached[k], fresh[k]), k


@pytest.mark.parametrize("name", ["kinematic-lp", "kinematic-ff"])
def test_cars_that_differ_beyond_g_share_one_low_pass_design(disk, name):
    """A low-pass's tables read only g of the car: designed for another car (other mass, tyres,
    roll), the same tables come from the memo and one disk entry, equal to a fresh design for it;
    another g is another design."""
    suv, sedan = VehicleParams(), load_vehicle("sedan").params
    assert sedan.g == suv.g and sedan != suv
    first = E.make(name, suv, **GRID)
    second = E.make(name, sedan, **GRID)
    assert len(_entries(disk)) == 1
    fresh = type(second)(sedan, **GRID)._design()               # _design() itself: no memo, no disk
    assert np.array_equal(second._tab_cont, fresh[0]) and np.array_equal(second._extra, fresh[2])
    assert np.array_equal(first._tab_cont, second._tab_cont)
    assert second.design.params is sedan                        # the estimator keeps its own car
    E.make(name, VehicleParams(g=9.78), **GRID)
    assert len(_entries(disk)) == 2

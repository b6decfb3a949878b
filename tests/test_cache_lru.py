"""The on-disk design cache keeps what a run uses: least recently used entries go first, and a
validation of 16 drives with every estimator fits beside the entries of older code."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from roadbank import cache
from roadbank.estimators import base

KITTI = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts"


@pytest.fixture
def disk(tmp_path, monkeypatch):
    """A fresh cache folder whose entries are counted at every store (cache.PRUNE_EVERY 1)."""
    monkeypatch.setenv("ROADBANK_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(base, "_DESIGN_CACHE", {})
    monkeypatch.setattr(cache, "PRUNE_EVERY", 1)
    monkeypatch.setattr(cache, "_STORES", {})
    return tmp_path / "design"


def _age(path, seconds):
    os.utime(path, (seconds, seconds))


def test_an_entry_read_again_outlives_older_unread_ones(disk, monkeypatch):
    monkeypatch.setattr(cache, "MAX_ENTRIES", 3)
    paths = [cache.store("design", f"k{k}", {"a": np.full(2, k)}) for k in range(3)]
    for k, p in enumerate(paths):
        _age(p, 1000 + k)                         # written in the order k0, k1, k2
    assert cache.load("design", "k0")["a"][0] == 0    # k0 is used again: now the most recent
    cache.store("design", "k3", {"a": np.full(2, 3)})
    kept = {k for k in range(4) if cache.load("design", f"k{k}") is not None}
    assert kept == {0, 2, 3}                      # the least recently used (k1) went, not the oldest write


def test_a_full_folder_is_pruned_below_its_limit_so_the_next_stores_only_count(disk, monkeypatch):
    monkeypatch.setattr(cache, "MAX_ENTRIES", 16)
    for k in range(17):
        _age(cache.store("design", f"k{k}", {"a": np.zeros(1)}), 1000 + k)
    left = sorted(disk.glob("*.npz"))
    assert len(left) == 16 - 16 // 8
    kept = {k for k in range(17) if cache.load("design", f"k{k}") is not None}
    assert kept == set(range(17 - len(left), 17))          # the newest ones


def test_counted_every_few_stores_the_folder_never_exceeds_its_limit(disk, monkeypatch):
    """Counting a folder reads every entry, so a process counts it at its first store and every PRUNE_EVERY stores
    after it; the prune then leaves room for the stores until the next count."""
    monkeypatch.setattr(cache, "MAX_ENTRIES", 16)
    monkeypatch.setattr(cache, "PRUNE_EVERY", 4)
    counts, real = [], cache._prune
    monkeypatch.setattr(cache, "_prune", lambda folder, keep=None: counts.append(keep) or real(folder, keep))
    sizes = []
    for k in range(40):
        _age(cache.store("design", f"k{k}", {"a": np.zeros(1)}), 1000 + k)
        sizes.append(len(list(disk.glob("*.npz"))))
    assert counts == [16 - 3] * 10                                  # stores 1, 5, 9, ... 37
    assert max(sizes) <= 16 and sizes[-1] > 16 - 16 // 8            # full use of the room, never beyond it
    kept = {k for k in range(40) if cache.load("design", f"k{k}") is not None}
    assert kept == set(range(40 - sizes[-1], 40))                   # the newest ones


def _designs_of_one_drive(tmp_path, monkeypatch) -> int:
    """Entries a validation of one shared KITTI drive stores (every estimator, sensitivity runs)."""
    from roadbank.validation.kitti import validate_kitti_drive
    stored = []
    real = cache.store

    def counted(kind, key, arrays):
        path = real(kind, key, arrays)
        if path is not None:                                # written (not inside cache.not_stored)
            stored.append(kind)
        return path
    monkeypatch.setattr(cache, "store", counted)
    monkeypatch.setenv("ROADBANK_CACHE_DIR", str(tmp_path / "count"))
    monkeypatch.setattr(base, "_DESIGN_CACHE", {})          # every design made (and stored) here
    validate_kitti_drive(next(KITTI.glob("*/oxts")).parent)
    monkeypatch.undo()
    return stored.count("design")


@pytest.mark.slow
@pytest.mark.skipif(not any(KITTI.glob("*/oxts")), reason=f"KITTI oxts drives absent at {KITTI}")
def test_a_16_drive_validation_keeps_every_design_it_stores(tmp_path, monkeypatch):
    per_drive = _designs_of_one_drive(tmp_path, monkeypatch)
    assert per_drive > 50                         # every estimator, its th retries, the sensitivity runs
    monkeypatch.setenv("ROADBANK_CACHE_DIR", str(tmp_path / "cache"))
    folder = tmp_path / "cache" / "design"
    folder.mkdir(parents=True)
    for k in range(cache.MAX_ENTRIES):            # a full cache of an older version's entries
        p = folder / f"{k:064x}.npz"
        p.write_bytes(b"stale")
        _age(p, 1000 + k)
    keys = [f"drive{d}-design{j}" for d in range(16) for j in range(per_drive)]
    for key in keys:
        cache.store("design", key, {"tab": np.zeros(4)})
    assert all(cache.load("design", key) is not None for key in keys)      # the first drives' too
    assert len(list(folder.glob("*.npz"))) <= cache.MAX_ENTRIES


def test_the_in_process_memo_drops_the_least_recently_used(monkeypatch):
    """Beyond MEMO_SIZE designs the memo forgets the one used longest ago, not all of them."""
    from roadbank import estimators
    from roadbank.estimators import base

    monkeypatch.setattr(base, "_DESIGN_CACHE", {})
    monkeypatch.setattr(base, "MEMO_SIZE", 3)
    monkeypatch.setenv("ROADBANK_CACHE_DIR", "off")
    ests = [estimators.make("kinematic-lp", cutoff=fc) for fc in (0.3, 0.4, 0.5)]
    keys = [e._design_key() for e in ests]
    assert list(base._DESIGN_CACHE) == keys
    estimators.make("kinematic-lp", cutoff=0.3)                 # a hit: 0.3 is now the most recent
    estimators.make("kinematic-lp", cutoff=0.6)                 # a fourth: the least recent (0.4) goes
    assert keys[1] not in base._DESIGN_CACHE and keys[0] in base._DESIGN_CACHE and len(base._DESIGN_CACHE) == 3


def test_nothing_is_stored_inside_not_stored_and_loads_still_hit(disk):
    """cache.not_stored: a store inside the block writes no file (None); an entry stored before loads inside it; the
    block nests, and after it stores write again."""
    before = cache.store("design", "kept", {"a": np.ones(2)})
    with cache.not_stored():
        with cache.not_stored():
            assert cache.store("design", "inner", {"a": np.zeros(2)}) is None
        assert cache.store("design", "one-off", {"a": np.zeros(2)}) is None
        assert cache.load("design", "kept")["a"][0] == 1.0
    assert {p.name for p in disk.glob("*.npz")} == {before.name}
    assert cache.store("design", "after", {"a": np.zeros(2)}) is not None

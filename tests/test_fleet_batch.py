"""Fleets on Dask in batches: many short logs per task, the same results as one log per task and
as in-process, a bad log failing only itself and a failed task only its batch."""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from roadbank.fleet import run as fleet_run
from roadbank.fleet.run import (
    BATCH_BYTES,
    BATCH_MAX_LOGS,
    batches,
    read_summary,
    run_fleet,
)

EST = ("pif-modified",)


def _logs(tmp_path, n=12, bad=(4, 9)):
    rng = np.random.default_rng(0)
    paths = []
    for i in range(n):
        p = tmp_path / "logs" / f"log{i:02d}.parquet"
        p.parent.mkdir(exist_ok=True)
        k = 400 + 10 * i
        t = np.arange(k) * 0.01
        cols = {"t": t, "vx": np.full(k, 20.0 + i), "ay": 9.81 * math.sin(0.01 * i) + (0.05 + 0.01 * i)
                * rng.standard_normal(k), "r": np.zeros(k), "delta_f": np.zeros(k)}
        pq.write_table(pa.table(cols), p)
        if i in bad:
            p.write_bytes(p.read_bytes()[:200])
        paths.append(p)
    return paths


def test_batches_group_consecutive_logs_by_size_and_count(tmp_path):
    small = []
    for i in range(10):
        p = tmp_path / f"s{i}.csv"
        p.write_bytes(b"x" * 1000)
        small.append(p)
    big = tmp_path / "big.csv"
    with open(big, "wb") as fh:
        fh.truncate(BATCH_BYTES + 1)
    d = tmp_path / "drive"
    d.mkdir()
    paths = small[:4] + [big] + small[4:] + [d]
    groups = batches(paths, workers=1)
    assert [i for g in groups for i in g] == list(range(len(paths)))      # consecutive, each once
    assert [4] in groups and [len(paths) - 1] in groups                   # a big log, a directory: alone
    assert max(len(g) for g in groups) <= math.ceil(len(paths) / 4)       # several tasks per worker
    many = [small[0]] * (40 * BATCH_MAX_LOGS)
    assert max(len(g) for g in batches(many, workers=1)) == BATCH_MAX_LOGS
    assert batches(paths, workers=2, size=5) == [list(range(5)), list(range(5, 10)), [10, 11]]
    with pytest.raises(ValueError, match="batch size"):
        batches(paths, workers=1, size=0)


@pytest.fixture
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as c:
        yield c.scheduler_address


def _tables(outdir):
    rows = {r["log"]: r for r in read_summary(outdir)}
    return rows, {log: pq.read_table(r["output"]) for log, r in rows.items() if r["status"] == "ok"}


def test_batched_dask_run_equals_one_log_per_task_and_in_process(tmp_path, cluster):
    paths = _logs(tmp_path)
    runs = {}
    for label, kw in (("inproc", {}), ("one", {"scheduler": cluster, "batch": 1}),
                      ("batched", {"scheduler": cluster, "batch": 5}), ("auto", {"scheduler": cluster})):
        res = run_fleet(paths, tmp_path / label, EST, **kw)
        assert len(res.summaries) == len(paths) and len(res.failed) == 2
        runs[label] = _tables(tmp_path / label)
    _, tabs0 = runs["inproc"]
    for label, (rows, tabs) in runs.items():
        assert set(rows) == {str(p) for p in paths}
        for i in (4, 9):
            r = rows[str(paths[i])]
            assert r["status"] == "error" and paths[i].name in r["error"]
        assert set(tabs) == set(tabs0)
        for log, tab in tabs.items():
            assert tab.equals(tabs0[log]), (label, log)
        # every log was designed for its own ay noise: the outputs differ between logs
    a, b = (tabs0[str(paths[i])].column("pif-modified.theta").to_numpy() for i in (0, 1))
    assert not np.array_equal(a[:300], b[:300])


def test_a_failed_task_fails_its_batch_only(tmp_path, cluster, monkeypatch):
    paths = _logs(tmp_path, bad=())
    real = fleet_run._estimate_batch

    def dies_on_log3(jobs, estimators, kw):
        if any(p.name == "log03.parquet" for p, *_ in jobs):
            raise MemoryError("worker ran out of memory")
        return real(jobs, estimators, kw)
    monkeypatch.setattr(fleet_run, "_estimate_batch", dies_on_log3)
    res = run_fleet(paths, tmp_path / "out", EST, scheduler=cluster, batch=4)
    rows = {r["log"]: r for r in read_summary(tmp_path / "out")}
    assert set(rows) == {str(p) for p in paths}
    failed = {r["log"] for r in rows.values() if r["status"] == "error"}
    assert failed == {str(p) for p in paths[:4]}                 # the batch of log03: logs 0-3
    assert all("worker failed: MemoryError" in rows[log]["error"] for log in failed)
    assert len(res.failed) == 4

"""Local workers (``--workers N``, no scheduler): a pool of spawned processes. Its tasks give what
they give in this process; a worker that dies costs only the task that killed it; the workers'
CPU time is read."""

from __future__ import annotations

import os

from roadbank.fleet.cluster import InProcess, OnProcesses, open_pool


def square_or_die(k: int) -> int:
    """A task: ``k * k``, except that ``k == 3`` kills its worker process."""
    if k == 3:
        os._exit(7)
    return k * k


def burn(n: int) -> int:
    """A task that uses some CPU."""
    s = 0
    for i in range(n):
        s += i * i
    return s


def _run(pool, ks):
    tasks = {pool.submit(square_or_die, k): k for k in ks}
    return {tasks[t]: pool.outcome(t) for t in pool.as_completed(tasks)}


def test_local_workers_are_a_process_pool_and_equal_one_process():
    with open_pool(1) as one:
        assert isinstance(one, InProcess)
        want = _run(one, [0, 1, 2, 4, 5])
    with open_pool(2) as pool:
        assert isinstance(pool, OnProcesses) and pool.workers == 2 and not pool.in_process
        assert pool.startup_s > 0
        assert _run(pool, [0, 1, 2, 4, 5]) == want == {k: (k * k, None) for k in (0, 1, 2, 4, 5)}
        cpu0 = pool.cpu_seconds()
        tasks = [pool.submit(burn, 3_000_000) for _ in range(4)]
        assert all(pool.outcome(t)[1] is None for t in pool.as_completed(tasks))
        cpu1 = pool.cpu_seconds()
        assert len(cpu1) == 2 and sum(cpu1.values()) > sum(cpu0.values())


def test_a_worker_that_dies_costs_only_its_own_task():
    with open_pool(2) as pool:
        got = _run(pool, range(8))
        assert got[3][0] is None and got[3][1].startswith("worker failed")
        assert {k: v for k, v in got.items() if k != 3} == {k: (k * k, None) for k in range(8) if k != 3}
        # the pool goes on after it
        assert _run(pool, [6, 7]) == {6: (36, None), 7: (49, None)}


def say(text: str) -> int:
    """A task that writes to its worker's standard output without a newline or a flush."""
    import sys
    sys.stdout.write(text)
    return len(text)


def test_workers_end_quickly_with_their_output_flushed(tmp_path):
    # a worker ends by os._exit (no interpreter tear-down): what a task printed must still reach
    # the stream, and the process must have ended by the time the pool is closed
    import subprocess
    import sys
    script = ("from roadbank.fleet.cluster import OnProcesses\n"
              "import tests.test_process_pool as t\n"
              "pool = OnProcesses(2)\n"
              "procs = list(pool._ex._processes.values())\n"
              "assert all(pool.outcome(f) == (5, None) for f in [pool.submit(t.say, 'hello') for _ in range(4)])\n"
              "pool.close()\n"
              "assert [p.exitcode for p in procs] == [0, 0], [p.exitcode for p in procs]\n")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=root, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.count("hello") == 4


def test_a_local_pool_cuts_logs_finer_than_dask(tmp_path):
    # a local task costs about a millisecond to send: a few logs each, so the last one is short
    from roadbank.fleet.cluster import LOCAL_BATCH_BYTES, LOCAL_BATCHES_PER_WORKER, batches
    log = tmp_path / "log.parquet"
    log.write_bytes(b"x" * 2**20)                     # a 10-minute 100 Hz log is about 1 MiB
    paths = [log] * 1000
    dask = batches(paths, workers=2)
    with open_pool(2) as pool:
        local = pool.batches(paths)
    for groups in (dask, local):
        assert [i for g in groups for i in g] == list(range(1000))     # consecutive, each once
    assert max(map(len, local)) <= LOCAL_BATCH_BYTES // 2**20
    assert len(local) >= 2 * LOCAL_BATCHES_PER_WORKER
    assert max(map(len, local)) < max(map(len, dask))


def blas_threads() -> tuple:
    """A task: the BLAS thread settings its process was started with."""
    return tuple(os.environ.get(v) for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"))


def test_workers_get_one_blas_thread_unless_the_user_set_it(monkeypatch):
    """Started from a script (no `roadbank` command to set it), each worker still gets one BLAS
    thread: two workers with a thread per core each were slower than one process (docs/io.md).
    A value the user set reaches the workers unchanged; this process's environment is not touched."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("MKL_NUM_THREADS", "3")
    with open_pool(2) as pool:
        tasks = [pool.submit(blas_threads) for _ in range(4)]
        got = {pool.outcome(t) for t in pool.as_completed(tasks)}
    assert got == {(("1", "1", "3"), None)}
    assert "OPENBLAS_NUM_THREADS" not in os.environ and "OMP_NUM_THREADS" not in os.environ
    assert os.environ["MKL_NUM_THREADS"] == "3"

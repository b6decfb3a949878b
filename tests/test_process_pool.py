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

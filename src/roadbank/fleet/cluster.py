"""Where the per-log work runs: in this process, or on Dask workers.

``with open_pool(workers, scheduler) as pool`` gives one object for both:

* ``workers <= 1`` and no ``scheduler``: :class:`InProcess` -- each task runs in this process
  when its result is asked for (in the order asked), exactly as a plain loop would;
* ``workers > 1``, no ``scheduler``: :class:`OnProcesses` -- a pool of that many spawned worker
  processes on this machine (``concurrent.futures``). It costs the workers no CPU beyond the
  tasks' own: a Dask LocalCluster's workers spent 1.2-1.4x one process's CPU on the same logs
  (its event loop, heartbeats and comms), the pool about 1.1x (docs/io.md). A worker that dies
  (memory, a signal) breaks the pool: every task it had not finished is run again, each in a
  pool of its own, so only the task that kills its worker fails;
* a ``scheduler``: :class:`OnDask` -- the running Dask scheduler at that address.

``pool.submit(fn, *args, **kwargs)`` returns a task; ``pool.as_completed(tasks)`` yields them as
they finish (in process: in order); ``pool.batches(paths)`` groups logs into tasks;
``pool.outcome(task)`` is ``(value, None)`` or, when the task could not finish on its worker (the
worker died, or the task raised), ``(None, "worker failed: ...")`` -- the caller reports that
against the task's logs and the others go on. In process, an exception of the task is raised as
it would be in a loop. On Dask, ``pool.cpu_seconds()`` reads the CPU time each worker has
used (what the fleet benchmark reports). ``fn`` and its arguments must be picklable for Dask (module-level
functions, dataclasses). The layers below (validation, mapping) take a pool as an argument and
use only these methods (and ``in_process``), never importing this module.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import multiprocessing.util
import os
import signal
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from .. import runtime

#: input a batch of logs aims at (bytes of log files): one Dask task of about half a second
BATCH_BYTES = 32 * 2**20
#: the most logs in one batch
BATCH_MAX_LOGS = 64
#: batches per worker at least (where there are enough logs), so that the workers end together
#: (the last task of one worker is the others' idle time: an eighth of a share at most)
BATCHES_PER_WORKER = 8
#: the same two for a pool of processes on this machine, whose tasks cost about a millisecond
#: each to send (a Dask task tens): tasks of a few logs, so that the last one keeps one worker
#: busy for a fraction of a second, not the seconds a Dask-sized batch of 64 logs takes
LOCAL_BATCH_BYTES = 4 * 2**20
LOCAL_BATCHES_PER_WORKER = 64


def _input_bytes(p: Path, whole: int = BATCH_BYTES) -> int:
    """Size of a log on disk (bytes); a log directory counts as a whole batch (``whole``)."""
    try:
        return p.stat().st_size if p.is_file() else whole
    except OSError:
        return 0


def batches(paths: list, workers: int, size: int | None = None, *, max_bytes: int = BATCH_BYTES,
            per_worker: int = BATCHES_PER_WORKER) -> list[list[int]]:
    """Indices of ``paths`` in consecutive groups, one task each.

    ``size``: that many logs per group. None: groups of about ``max_bytes`` of input, at
    most :data:`BATCH_MAX_LOGS` logs and at most ``len(paths) / (per_worker * workers)``
    (so that every worker gets several tasks and they finish together); a log of
    ``max_bytes`` or more is a group of its own. The defaults are for Dask
    (:data:`BATCH_BYTES`, :data:`BATCHES_PER_WORKER`); a local pool uses
    :data:`LOCAL_BATCH_BYTES` and :data:`LOCAL_BATCHES_PER_WORKER`.
    """
    n = len(paths)
    if size is not None:
        if size < 1:
            raise ValueError(f"batch size must be >= 1, got {size}")
        return [list(range(i, min(i + size, n))) for i in range(0, n, size)]
    cap = max(1, min(BATCH_MAX_LOGS, math.ceil(n / (per_worker * max(1, workers)))))
    out: list[list[int]] = []
    cur: list[int] = []
    used = 0
    for i, p in enumerate(paths):
        b = _input_bytes(Path(p), max_bytes)
        if cur and (used + b > max_bytes or len(cur) >= cap):
            out.append(cur)
            cur, used = [], 0
        cur.append(i)
        used += b
    if cur:
        out.append(cur)
    return out


def worker_failure(exc: BaseException) -> str:
    """The one-line reason given for every log of a task that failed on its worker."""
    return f"worker failed: {type(exc).__name__}: {exc}"


class _Thunk:
    """A task of :class:`InProcess`: run once, when its outcome is first asked for."""

    __slots__ = ("fn", "args", "kwargs", "done", "value")

    def __init__(self, fn, args, kwargs):
        self.fn, self.args, self.kwargs, self.done, self.value = fn, args, kwargs, False, None

    def result(self):
        if not self.done:
            self.value = self.fn(*self.args, **self.kwargs)
            self.done, self.fn, self.args, self.kwargs = True, None, None, None
        return self.value


class InProcess:
    """Tasks run in this process, one after another (see the module doc)."""

    workers = 1
    startup_s = 0.0
    in_process = True

    def batches(self, paths) -> list[list[int]]:
        """All of ``paths`` (indices) in one group: in process nothing is gained by cutting."""
        return [list(range(len(paths)))] if len(paths) else []

    def submit(self, fn, *args, **kwargs) -> _Thunk:
        return _Thunk(fn, args, kwargs)

    def as_completed(self, tasks):
        yield from tasks

    def outcome(self, task: _Thunk):
        return task.result(), None


class OnDask:
    """Tasks on a Dask client (see the module doc); ``pending`` holds the futures not yet
    collected, cancelled if the caller's block raises."""

    in_process = False

    def __init__(self, client, pending: dict, startup_s: float):
        self.client, self.pending, self.startup_s = client, pending, startup_s
        self.workers = sum(client.nthreads().values())

    def batches(self, paths) -> list[list[int]]:
        """Indices of ``paths`` in consecutive groups, one task each (:func:`batches`)."""
        return batches(paths, self.workers)

    def submit(self, fn, *args, **kwargs):
        fut = self.client.submit(fn, *args, pure=False, **kwargs)
        self.pending[fut] = None
        return fut

    def as_completed(self, tasks):
        from ..campaign.execute import completed

        yield from completed(self.client, tasks)

    def cpu_seconds(self) -> dict:
        """CPU seconds each worker process has used so far (``time.process_time`` there), by
        worker address; empty if the workers cannot be asked."""
        try:
            return self.client.run(time.process_time)
        except Exception:       # a worker gone, or not answering: no reading
            return {}

    def outcome(self, fut):
        self.pending.pop(fut, None)
        try:
            return fut.result(), None
        except Exception as exc:    # the worker died (memory, signal) or the task raised
            return None, worker_failure(exc)


def _quick_exit() -> None:
    """End a pool process without tearing its interpreter down: its standard streams flushed,
    then ``os._exit(0)``. A worker that has loaded numba, scipy and pyarrow spends 0.4-0.5 s
    in interpreter finalization (freeing modules and compiled code) that nobody needs; the
    pool's shutdown waits for it. Nothing else is pending by then: the pool's result queue is
    written synchronously, and multiprocessing has run every other finalizer before this one
    (the lowest priority)."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(0)


def _warm_worker(warm) -> None:
    """A pool process's initializer: ``warm`` (``(fn, *args)`` or None) once, its failure left to the
    tasks (they report it against their logs); the process will end by :func:`_quick_exit`."""
    multiprocessing.util.Finalize(None, _quick_exit, exitpriority=-1000)
    signal.signal(signal.SIGINT, signal.SIG_IGN)    # Ctrl-C is the command's to handle: it stops the pool
    parent = multiprocessing.parent_process()
    runtime.end_with_parent(None if parent is None else parent.pid)    # a command killed leaves no worker behind
    runtime.keep_freed_memory()       # a fresh process, like the parent once it has run a few logs
    if warm is not None:
        try:
            warm[0](*warm[1:])
        except Exception:
            pass


def _process_cpu(pid: int) -> float | None:
    """CPU seconds (user + system) the process ``pid`` has used, from ``/proc`` (None elsewhere)."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


class OnProcesses:
    """Tasks on a pool of ``workers`` spawned processes on this machine (see the module doc)."""

    in_process = False

    def __init__(self, workers: int, warm=None):
        self.workers, self._warm = int(workers), warm
        self._tasks: dict = {}          # future -> (fn, args, kwargs), to run again if the pool breaks
        t0 = time.perf_counter()
        self._ex = self._start(self.workers)
        self.startup_s = time.perf_counter() - t0

    def _start(self, n: int) -> ProcessPoolExecutor:
        with runtime.one_blas_thread_in_children():
            ex = ProcessPoolExecutor(n, mp_context=multiprocessing.get_context("spawn"), initializer=_warm_worker,
                                     initargs=(self._warm,))
            try:
                # every worker started and warmed up before the first task: each takes a short wait
                for f in [ex.submit(time.sleep, 0.2) for _ in range(n)]:
                    f.result()
            except BaseException:         # Ctrl-C while they start
                _terminate(ex)
                raise
        return ex

    def batches(self, paths) -> list[list[int]]:
        """Indices of ``paths`` in consecutive groups of a few logs, one task each (:func:`batches`
        with the local pool's sizes)."""
        return batches(paths, self.workers, max_bytes=LOCAL_BATCH_BYTES, per_worker=LOCAL_BATCHES_PER_WORKER)

    def submit(self, fn, *args, **kwargs):
        try:
            fut = self._ex.submit(fn, *args, **kwargs)
        except BrokenProcessPool:     # a worker died earlier: a new pool for the tasks from now on
            self._ex.shutdown(wait=True, cancel_futures=True)
            self._ex = self._start(self.workers)
            fut = self._ex.submit(fn, *args, **kwargs)
        self._tasks[fut] = (fn, args, kwargs)
        return fut

    def as_completed(self, tasks):
        yield from as_completed(list(tasks))

    def cpu_seconds(self) -> dict:
        """CPU seconds each worker process has used so far, by process id (empty where ``/proc`` is not)."""
        pids = list(getattr(self._ex, "_processes", None) or {})
        cpu = {pid: _process_cpu(pid) for pid in pids}
        return {pid: c for pid, c in cpu.items() if c is not None}

    def outcome(self, fut):
        fn, args, kwargs = self._tasks.pop(fut, (None, (), {}))
        try:
            return fut.result(), None
        except BrokenProcessPool:     # a worker died: this task again, alone, in a pool of its own
            return self._alone(fn, args, kwargs)
        except Exception as exc:      # the task raised on its worker
            return None, worker_failure(exc)

    def _alone(self, fn, args, kwargs):
        if fn is None:
            return None, "worker failed: its process died"
        ex = self._start(1)
        try:
            return ex.submit(fn, *args, **kwargs).result(), None
        except Exception as exc:
            return None, worker_failure(exc)
        finally:
            ex.shutdown(wait=True, cancel_futures=True)

    def close(self) -> None:
        self._ex.shutdown(wait=True, cancel_futures=True)

    def abort(self) -> None:
        """Stop now (Ctrl-C, an error in the client): the workers ended mid-task, the tasks not started dropped."""
        _terminate(self._ex)


def _terminate(ex: ProcessPoolExecutor, wait_s: float = 10.0) -> None:
    """End the pool ``ex`` at once: its worker processes sent SIGTERM (they ignore SIGINT, :func:`_warm_worker`),
    waited for up to ``wait_s`` seconds, then killed; its queued tasks cancelled."""
    procs = list((getattr(ex, "_processes", None) or {}).values())
    for p in procs:
        with contextlib.suppress(Exception):
            p.terminate()
    ex.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        with contextlib.suppress(Exception):
            p.join(wait_s)
            if p.is_alive():
                p.kill()
                p.join(wait_s)


@contextlib.contextmanager
def open_pool(workers: int = 1, scheduler: str | None = None, connect_timeout: float = 20.0, warm=None):
    """``with open_pool(...) as pool``: :class:`InProcess`, :class:`OnProcesses` or :class:`OnDask` (module doc).

    Parameters
    ----------
    workers : int
        1: in this process. More: a pool of that many worker processes on this machine.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``); overrides ``workers``.
    connect_timeout : float
        Seconds to wait for the scheduler.
    warm : tuple, optional
        ``(fn, *args)`` run once on every worker before the first task (designs, compiled
        kernels, readers); its time counts in ``pool.startup_s`` (s).

    Raises
    ------
    roadbank.campaign.execute.DaskMissing
        With a ``scheduler`` but without dask.distributed (a RuntimeError).
    ConnectionError
        The scheduler is unreachable.
    """
    if scheduler is None and int(workers) <= 1:
        yield InProcess()
        return
    if scheduler is None:
        pool = OnProcesses(int(workers), warm)
        try:
            yield pool
        except BaseException:         # Ctrl-C, an error in the client: stop at once, no worker left waiting
            pool.abort()
            raise
        pool.close()
        return
    from ..campaign.execute import dask_session

    t0 = time.perf_counter()
    with dask_session(scheduler, int(workers), connect_timeout) as (client, pending):
        if warm is not None:
            client.run(*warm)
        yield OnDask(client, pending, time.perf_counter() - t0)

"""Run a campaign on dask.distributed, storing each finished batch at once.

``run_campaign(outdir, runs)`` draws the specs of runs ``0 .. runs-1`` not yet
stored, cuts them into batches (one Dask task each, to amortise the per-task
overhead), submits them to a cluster — a :class:`distributed.LocalCluster` of
``workers`` single-threaded processes by default, or the scheduler at
``scheduler`` — and writes every batch as one Parquet part the moment it
finishes (:mod:`.store`). Interrupting (Ctrl-C, a crash, a killed machine)
loses at most the batches in flight; ``resume=True`` continues with the
missing run ids.

Dask is imported here, lazily: without it :class:`DaskMissing` says how to install it.
"""

from __future__ import annotations

import contextlib
import logging
import sys
import time
from dataclasses import dataclass, field

from .. import runtime
from . import store
from .runner import RunOptions, run_batch, warm_up
from .sampling import draw


class DaskMissing(RuntimeError):
    """dask.distributed is not installed."""


def _distributed():
    try:
        import distributed
    except ImportError:
        raise DaskMissing("campaigns run on dask.distributed, which is not installed: "
                          "pip install 'roadbank[campaign]'  (or: pip install 'dask[distributed]')") from None
    return distributed


@dataclass
class CampaignResult:
    """What one call of :func:`run_campaign` did.

    Attributes
    ----------
    outdir : str
    requested : int
        Runs asked for (ids 0 .. requested-1).
    already_stored : int
        Runs skipped because a previous call stored them (resume).
    completed : int
        Runs computed and stored by this call.
    failed_runs : list of (run_id, seed, error)
        Runs whose simulation or an estimator raised (stored with their error).
    workers : int
        Worker processes (threads) of the cluster used.
    startup_s : float
        Seconds to start / connect to the cluster and warm every worker up
        (load or compile the numba kernels, build the estimators).
    wall_s : float
        Seconds from the first submission to the last stored part.
    interrupted : bool
    """

    outdir: str
    requested: int
    already_stored: int = 0
    completed: int = 0
    failed_runs: list = field(default_factory=list)
    workers: int = 0
    startup_s: float = 0.0
    wall_s: float = 0.0
    interrupted: bool = False

    @property
    def runs_per_s(self) -> float:
        """Throughput of this call (runs / s of ``wall_s``), NaN if nothing ran."""
        return self.completed / self.wall_s if self.completed and self.wall_s > 0 else float("nan")


def open_client(scheduler: str | None, workers: int, connect_timeout: float = 20.0):
    """``(client, cluster)``: a Dask client on the scheduler at ``scheduler``, or on a new
    LocalCluster of ``workers`` single-threaded processes (``cluster`` None when connecting).

    Raises DaskMissing without dask.distributed, ConnectionError if the scheduler is unreachable or
    Dask cannot connect to a well-formed address (TypeError, ValueError: ``tls://`` without a TLS
    configuration, ``ucx://`` without UCX installed).
    """
    dd = _distributed()
    if scheduler is None:
        import dask

        # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers by default; that turns off
        # glibc's dynamic mmap threshold, so every chunk-sized array is mmap'ed, zero-filled and
        # unmapped again: a streamed log took twice the CPU in a worker (0.135 s vs 0.07 s per 1 h
        # log). Our tasks allocate the same sizes over and over, so glibc's default is right here.
        with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
            cluster = dd.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                      dashboard_address=None, silence_logs=logging.ERROR,
                                      env={**dict.fromkeys(runtime.BLAS_THREAD_VARS, "1"), "NUMBA_NUM_THREADS": "1"})
        return dd.Client(cluster), cluster
    try:
        return dd.Client(scheduler, timeout=f"{connect_timeout}s"), None
    except (OSError, TimeoutError, TypeError, ValueError) as exc:
        raise ConnectionError(f"cannot connect to the Dask scheduler at {scheduler}: {exc}") from None


@contextlib.contextmanager
def dask_session(scheduler: str | None, workers: int, connect_timeout: float = 20.0):
    """``with dask_session(...) as (client, pending)``: a client from :func:`open_client` and a
    dict for the submitted futures. If the block raises (also ``KeyboardInterrupt``), every
    future still in ``pending`` is cancelled before the exception goes on; the client and the
    LocalCluster it started are closed on leaving the block."""
    client, cluster = open_client(scheduler, workers, connect_timeout)
    pending: dict = {}
    try:
        yield client, pending
    except BaseException:
        for fut in list(pending):
            fut.cancel()
        raise
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


#: seconds the scheduler may go without any worker while tasks wait before the wait is said (once per such spell)
NO_WORKER_PATIENCE_S = 30.0
#: seconds between two looks for finished tasks (the client's latency only; the workers never wait for it)
_POLL_S = 0.05


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def completed(client, futures, patience_s: float = NO_WORKER_PATIENCE_S, say=_say):
    """``futures`` as they finish (as ``distributed.as_completed``). A scheduler left without workers (all of
    them died, or none was started) holds its tasks until one joins; while that lasts ``patience_s`` seconds
    (s), ``say`` gets one line saying so and how to go on, then again only after a worker has come and gone."""
    ac = _distributed().as_completed(list(futures))
    alone_since, said, next_look = None, False, 0.0
    while not ac.is_empty():
        if ac.has_ready():
            yield from ac.next_batch(block=False)
            continue
        time.sleep(_POLL_S)
        now = time.monotonic()
        if now < next_look:
            continue
        next_look = now + 1.0
        if client.nthreads():
            alone_since, said = None, False
        elif alone_since is None:
            alone_since = now
        elif not said and now - alone_since >= patience_s:
            said = True
            say(f"the Dask scheduler has had no worker for {now - alone_since:.0f} s and {ac.count()} task(s) "
                f"wait for one: start workers (dask worker ADDRESS), or stop with Ctrl-C (stored results stay)")


def settings_of(runs: int, seed: int, options: RunOptions) -> dict:
    """The campaign settings recorded in ``campaign.json`` (``runs`` may grow on resume)."""
    return {"runs": int(runs), "seed": int(seed), "options": options.as_dict(),
            "sampler": "roadbank.campaign.sampling.draw/1"}


def _batches(ids: list[int], size: int) -> list[list[int]]:
    return [ids[i:i + size] for i in range(0, len(ids), size)]


def run_campaign(outdir, runs: int, *, seed: int = 0, options: RunOptions | None = None,
                 scheduler: str | None = None, workers: int = 2, batch_size: int = 50,
                 resume: bool = False, sampler=draw, on_part=None, progress=None,
                 connect_timeout: float = 20.0) -> CampaignResult:
    """Run (or resume) a campaign of ``runs`` randomised runs into ``outdir``.

    Parameters
    ----------
    outdir : path-like
        Campaign directory (see :mod:`.store`).
    runs : int
        Number of runs; run ids are ``0 .. runs-1``.
    seed : int
        Campaign seed (run ``k`` is ``sampler(k, seed)``).
    options : RunOptions
        Estimators, scenario duration scale, plant integration step, scoring.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``). Default: start
        a LocalCluster of ``workers`` processes with one thread each.
    workers : int
        Worker processes of the LocalCluster (ignored with ``scheduler``).
    batch_size : int
        Runs per Dask task.
    resume : bool
        Continue a campaign already in ``outdir`` (skip stored run ids).
    sampler : callable ``(run_id, seed) -> RunSpec``
        Draws the runs (default :func:`.sampling.draw`); runs on the client.
    on_part : callable ``(path, rows)``, optional
        Called after each part is stored (progress, tests).
    progress : callable ``(done, total)``, optional
    connect_timeout : float
        Seconds to wait for the scheduler at ``scheduler``.

    Returns
    -------
    CampaignResult

    An exception (e.g. ``KeyboardInterrupt``) raised while waiting is re-raised
    after the in-flight tasks are cancelled and the cluster is shut down; the
    parts stored so far stay, and ``resume=True`` continues from them.
    """
    runs, batch_size, workers = int(runs), int(batch_size), int(workers)
    if runs < 1:
        raise ValueError("runs must be >= 1")
    if batch_size < 1:
        raise ValueError("batch_size must be >= 1")
    if scheduler is None and workers < 1:
        raise ValueError("workers must be >= 1")
    options = options or RunOptions()
    _distributed()              # DaskMissing before anything else
    store.check_settings(outdir, settings_of(runs, seed, options), resume)
    done_ids = store.stored_run_ids(outdir) if resume else set()
    todo = [i for i in range(runs) if i not in done_ids]
    result = CampaignResult(str(outdir), runs, already_stored=runs - len(todo))
    if not todo:
        return result

    t0 = time.perf_counter()
    try:
        with dask_session(scheduler, workers, connect_timeout) as (client, futures):
            result.workers = sum(client.nthreads().values())
            client.run(warm_up, options)          # load / compile the kernels on every worker
            result.startup_s = time.perf_counter() - t0
            t1 = time.perf_counter()
            for ids in _batches(todo, batch_size):
                specs = [sampler(i, seed) for i in ids]
                fut = client.submit(run_batch, specs, options, pure=False)
                futures[fut] = ids
            for fut in completed(client, futures):
                ids = futures.pop(fut)
                rows = fut.result()
                path = store.write_part(outdir, rows, f"{ids[0]:07d}")
                result.completed += len(ids)
                seen = set()
                for row in rows:
                    if row["error"] and row["run_id"] not in seen:
                        seen.add(row["run_id"])
                        result.failed_runs.append((row["run_id"], row["noise_seed"], row["error"]))
                result.wall_s = time.perf_counter() - t1
                if on_part is not None:
                    on_part(path, rows)
                if progress is not None:
                    progress(result.already_stored + result.completed, runs)
    except BaseException:
        result.interrupted = True
        raise
    return result

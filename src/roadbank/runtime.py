"""Process-wide settings of the ``roadbank`` command and of its worker processes.

Called before numpy is imported (:func:`configure`, by :mod:`roadbank.cli`) and at the start of
every worker of a local pool (:func:`keep_freed_memory`, by :mod:`roadbank.fleet.cluster`). Imports
nothing but the standard library.

* **One BLAS thread.** The command line works on small matrices (3x3 to 13x13 designs, per-sample
  kernels) and parallelises with processes: a multi-threaded BLAS only spins there (designing the
  Kalman + PIF schedules took 3-8 s instead of 0.5 s on a loaded 2-core machine).
* **Arrow buffers from the C allocator** rather than Arrow's default mimalloc pool, which keeps
  its segments: 10-18 MiB less peak memory when a long log is streamed (docs/io.md), no
  measurable cost at these buffer sizes.
* **Freed memory kept for the next log** (glibc only): a log's arrays (a few hundred KiB to a few
  MiB each) are freed when it is done and the next log's take their place. With glibc's defaults
  a fresh process returns them to the system and faults new pages in for every log, about 1100
  page faults a 10-minute 100 Hz log; an estimate of 200 such logs spent 0.72 s of system time
  in a fresh process and 0.3 s in one that had run them before, and a fresh worker process was
  15 % slower per log than the long-lived parent. :func:`keep_freed_memory` keeps allocations
  below :data:`MMAP_THRESHOLD` in the heap and freed heap memory below :data:`TRIM_THRESHOLD`
  mapped: 16 000 instead of 115 000 page faults per worker over 100 logs.

An explicit setting of the user (environment variable) wins.
"""

from __future__ import annotations

import contextlib
import functools
import ctypes
import ctypes.util
import os
import signal
from collections.abc import Iterator

#: allocations below this many bytes come from the heap, not from their own mapping (glibc ``M_MMAP_THRESHOLD``)
MMAP_THRESHOLD = 32 * 2**20
#: freed memory at the top of the heap is returned to the system beyond this many bytes (``M_TRIM_THRESHOLD``)
TRIM_THRESHOLD = 256 * 2**20
#: glibc's ``mallopt`` parameter numbers (malloc.h)
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
#: Linux ``prctl`` option: the signal a process gets when its parent ends (:func:`end_with_parent`)
_PR_SET_PDEATHSIG = 1
#: the environment variables that set the BLAS libraries' thread counts (read when numpy loads)
BLAS_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
#: the environment variables by which a user sets those two himself
_MALLOC_ENV = ("MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_THRESHOLD_", "GLIBC_TUNABLES")


def configure() -> None:
    """The command's settings (module doc): environment defaults for BLAS threads and Arrow's
    allocator (read when numpy and pyarrow load, so call this first), and :func:`keep_freed_memory`."""
    for var in BLAS_THREAD_VARS:
        os.environ.setdefault(var, "1")
    os.environ.setdefault("ARROW_DEFAULT_MEMORY_POOL", "system")
    keep_freed_memory()


@contextlib.contextmanager
def one_blas_thread_in_children() -> Iterator[None]:
    """Processes started inside the block get one BLAS thread each (module doc), whatever this
    process was started with; a setting of the user wins, and this process's environment is as
    before on leaving. For pools of spawned processes, which read the environment when they
    start: from a Python script (no :func:`configure`), two fleet workers with the BLAS default
    of a thread per core each ran 200 logs in 48.9 s against one process's 35.4 s on 2 idle
    cores; with one thread each in 19.4 s."""
    added = [var for var in BLAS_THREAD_VARS if var not in os.environ]
    for var in added:
        os.environ[var] = "1"
    try:
        yield
    finally:
        for var in added:
            os.environ.pop(var, None)


@functools.cache
def _libc() -> ctypes.CDLL:
    """The C library, loaded once (``find_library`` runs ``ldconfig``); OSError where there is none to load."""
    return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")


def end_with_parent(parent_pid: int | None = None) -> bool:
    """Have the kernel send this process SIGTERM when the process that started it ends (Linux
    ``prctl(PR_SET_PDEATHSIG)``): a pool worker then never outlives a command that was killed (SIGTERM, SIGKILL)
    before it could stop its pool. ``parent_pid``: the parent's process id, to end at once where the parent ended
    before this call (the kernel would never send the signal then). Returns whether it was set (False without
    Linux's prctl)."""
    try:
        prctl = _libc().prctl
    except (OSError, AttributeError):
        return False
    prctl.argtypes, prctl.restype = (ctypes.c_int, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong,
                                     ctypes.c_ulong), ctypes.c_int
    done = prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0) == 0
    if done and parent_pid is not None and os.getppid() != parent_pid:
        os.kill(os.getpid(), signal.SIGTERM)
    return done


def keep_freed_memory() -> bool:
    """Keep freed memory in this process for the next allocations (module doc): glibc's
    ``mallopt`` with :data:`MMAP_THRESHOLD` and :data:`TRIM_THRESHOLD` (bytes). Returns whether
    it was set: False without glibc, or where the user set glibc's malloc himself."""
    if any(v in os.environ for v in _MALLOC_ENV):
        return False
    try:
        libc = _libc()
        mallopt = libc.mallopt
    except (OSError, AttributeError):     # not glibc (macOS, Windows, musl without mallopt)
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD))

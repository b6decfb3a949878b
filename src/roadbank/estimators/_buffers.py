"""The output arrays of an estimator's ``run()``, handed out again once the caller dropped them.

A loop over logs then writes into memory it already has instead of paying the page faults of
fresh memory (about as much as the estimation itself). Arrays the caller still holds, or any view
of them, are never reused: reuse is decided on reference counts. Large new arrays are backed by
an anonymous memory map whose pages the kernel maps in one call (:func:`new_array`).
"""

from __future__ import annotations

import mmap
import sys

import numpy as np

#: arrays from this size on are allocated with their pages mapped at once (:func:`new_array`)
POPULATE_MIN_BYTES = 1 << 20


def new_array(shape: tuple, dtype) -> np.ndarray:
    """An uninitialised array; from :data:`POPULATE_MIN_BYTES` on, backed by an anonymous memory map
    whose pages the kernel maps in one call (``MAP_POPULATE``, Linux).

    Written for the first time, fresh memory costs one page fault per 4 KiB page, which on
    virtual machines costs more than the estimation itself (about 1 ns per byte measured on
    the benchmark machine, a third of that populated at once). Elsewhere, for small arrays
    or when the map fails (e.g. too many maps), plain ``np.empty``. Also separate arrays
    rather than one block: numpy asks for huge pages from 4 MiB on, and their first writes
    cost more still there.
    """
    dt = np.dtype(dtype)
    nbytes = int(np.prod(shape)) * dt.itemsize
    populate = getattr(mmap, "MAP_POPULATE", None)
    anonymous = getattr(mmap, "MAP_ANONYMOUS", None)
    if populate is None or anonymous is None or nbytes < POPULATE_MIN_BYTES:
        return np.empty(shape, dtype=dt)
    try:
        mm = mmap.mmap(-1, nbytes, flags=mmap.MAP_PRIVATE | anonymous | populate)
    except (OSError, ValueError):
        return np.empty(shape, dtype=dt)
    return np.ndarray(shape, dtype=dt, buffer=mm)    # views of it have it as their base


def _refcounts(arrays) -> list[int]:
    """``sys.getrefcount`` of each element of the tuple ``arrays`` (as counted from here)."""
    return [sys.getrefcount(a) for a in arrays]


#: what :func:`_refcounts` reports for an element that nothing but its tuple refers to
_UNSHARED_REFS = _refcounts((np.empty(1),))[0]


class OutputBuffers:
    """The output arrays ``w, theta, phi_b, phi, valid, xs`` of the last :meth:`take`, kept for reuse."""

    def __init__(self) -> None:
        self._last: tuple[np.ndarray, ...] | None = None

    def take(self, n: int, ns: int) -> tuple:
        """Output arrays for ``n`` samples and ``ns`` states: float64 ``(n,)`` x 4, bool ``(n,)``,
        float64 ``(n, ns)``; those of the last call when each is referenced by its tuple only
        (as ``_UNSHARED_REFS`` calibrates: nothing of the caller's, a held view counts through
        its base) and the shapes match, else new ones (:func:`new_array`)."""
        old = self._last
        if (old is not None and old[0].shape[0] == n and old[5].shape[1] == ns
                and all(c == _UNSHARED_REFS for c in _refcounts(old))):
            return old
        f8 = np.float64
        out = (new_array((n,), f8), new_array((n,), f8), new_array((n,), f8), new_array((n,), f8),
               new_array((n,), np.bool_), new_array((n, ns), f8))
        self._last = out
        return out

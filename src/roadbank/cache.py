"""A small on-disk cache of float arrays in the user's cache directory.

Used for results that are expensive to compute and fully determined by their
inputs, such as the estimators' gain schedules (one Riccati/ARE solution per
grid speed). Entries are ``.npz`` files named by a SHA-256 of a canonical key;
each file also stores the key text, checked on load. The key always includes
roadbank's version and a fingerprint of its installed sources (so an edited
checkout never reads results of older code), numpy's and scipy's versions.

An entry holds the arrays bit for bit (``.npz``: float64 as stored), so a cached result is the
fresh one exactly when what is cached is a function of its key alone. The estimators' designs
are: none depends on what the process designed before it (a Riccati solution at a grid speed
is the one of the design's own whole-grid solution, :func:`roadbank.estimators.grid_design.pif_solution`).

Safe under concurrent processes: a file is written under a temporary name and
renamed into place (atomic), so a reader sees a complete entry or none.
Unreadable or damaged entries count as misses and are rewritten; any failure
to write (read-only disk, no permission) only costs the speed-up.

Location: ``$ROADBANK_CACHE_DIR`` if set (``off`` disables the cache), else
``$XDG_CACHE_HOME/roadbank`` or ``~/.cache/roadbank`` (``%LOCALAPPDATA%`` on
Windows, ``~/Library/Caches`` on macOS).
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import scipy

from . import __version__

#: the most entries kept per kind; the least recently used ones are removed (by modification
#: time: a hit touches its entry). A validation of 16 KITTI drives with every estimator and the
#: sensitivity runs stores about 1540 designs (96 a drive, 85 kB each on average): 4096 keep
#: two such runs, or one and the entries of an older version of the code (never used again,
#: so removed first)
MAX_ENTRIES = 4096
_FINGERPRINT: str | None = None


def cache_dir() -> Path | None:
    """The cache directory (may not exist yet), or None when disabled (``ROADBANK_CACHE_DIR=off``)."""
    env = os.environ.get("ROADBANK_CACHE_DIR")
    if env is not None and env.strip():
        return None if env.strip().lower() == "off" else Path(env).expanduser()
    try:
        if sys.platform == "win32":
            base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
        elif sys.platform == "darwin":
            base = Path.home() / "Library" / "Caches"
        else:
            base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    except RuntimeError:      # no home directory: no cache
        return None
    return base / "roadbank"


def source_fingerprint() -> str:
    """Version of roadbank, numpy and scipy and a hash of every roadbank source file's
    path, size and modification time (computed once per process)."""
    global _FINGERPRINT
    if _FINGERPRINT is None:
        h = hashlib.sha256(f"{__version__}|{np.__version__}|{scipy.__version__}".encode())
        root = Path(__file__).resolve().parent
        for p in sorted(root.rglob("*.py")):
            st = p.stat()
            h.update(f"{p.relative_to(root).as_posix()}|{st.st_size}|{st.st_mtime_ns}\n".encode())
        _FINGERPRINT = h.hexdigest()
    return _FINGERPRINT


def code_stamp(cls: type) -> str | None:
    """Identity of the code of ``cls`` and its bases for a key: roadbank's own classes are
    covered by :func:`source_fingerprint`; any other class by its module file's path, size and
    modification time. None when a class has no source file (defined interactively): then
    results built with it must not be cached on disk."""
    stamps = []
    for c in cls.__mro__:
        mod = sys.modules.get(c.__module__)
        if mod is None:
            return None
        if mod.__name__.split(".")[0] in ("roadbank", "builtins"):
            continue
        path = getattr(mod, "__file__", None)
        if path is None:
            return None
        try:
            st = os.stat(path)
        except (TypeError, OSError):
            return None
        stamps.append(f"{c.__module__}.{c.__qualname__}@{os.path.abspath(path)}|{st.st_size}|{st.st_mtime_ns}")
    return ";".join(stamps)


def canonical(obj) -> str:
    """Exact, repeatable text of ``obj`` for cache keys: floats in hex, arrays by dtype,
    shape and a hash of their bytes (``repr`` rounds and elides them), dataclasses by fields."""
    if isinstance(obj, np.ndarray):
        a = np.ascontiguousarray(obj)
        return f"nd({a.dtype.str},{a.shape},{hashlib.sha256(a.tobytes()).hexdigest()})"
    if isinstance(obj, (bool, np.bool_)) or obj is None:
        return repr(bool(obj) if obj is not None else None)
    if isinstance(obj, (float, np.floating)):
        return float(obj).hex()
    if isinstance(obj, (int, np.integer)):
        return str(int(obj))
    if isinstance(obj, (list, tuple)):
        return type(obj).__name__ + "(" + ",".join(canonical(v) for v in obj) + ")"
    if isinstance(obj, dict):
        items = sorted(obj.items(), key=lambda kv: repr(kv[0]))
        return "{" + ",".join(f"{canonical(k)}:{canonical(v)}" for k, v in items) + "}"
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return (type(obj).__qualname__ + "(" + ",".join(f"{f.name}={canonical(getattr(obj, f.name))}"
                                                         for f in dataclasses.fields(obj)) + ")")
    return repr(obj)


def _entry(kind: str, key: str) -> tuple[Path, str] | None:
    base = cache_dir()
    if base is None:
        return None
    text = f"{source_fingerprint()}|{kind}|{key}"
    return base / kind / (hashlib.sha256(text.encode()).hexdigest() + ".npz"), text


def load(kind: str, key: str) -> dict[str, np.ndarray] | None:
    """The arrays stored under ``key`` (text, see :func:`canonical`) in ``kind``, or None."""
    entry = _entry(kind, key)
    if entry is None:
        return None
    path, text = entry
    try:
        with np.load(path, allow_pickle=False) as z:
            if str(z["__key__"]) != text:
                return None
            arrays = {k: z[k] for k in z.files if k != "__key__"}
    except Exception:     # missing, truncated, damaged or foreign file: a miss
        return None
    try:
        os.utime(path)    # used now: the last to be pruned
    except OSError:       # a read-only cache: pruned by age of writing
        pass
    return arrays


#: how many :func:`not_stored` blocks are open in this process: while any is, :func:`store` writes nothing
_NOT_STORED = 0


@contextmanager
def not_stored():
    """Within the block, :func:`store` writes nothing (loads still hit): for one-off results, such as the designs of
    a validation's short pieces (each with its own noise and car), that would push the entries a user reuses out of
    the cache (:data:`MAX_ENTRIES`)."""
    global _NOT_STORED
    _NOT_STORED += 1
    try:
        yield
    finally:
        _NOT_STORED -= 1


def store(kind: str, key: str, arrays: dict[str, np.ndarray]) -> Path | None:
    """Store ``arrays`` under ``key`` in ``kind`` (atomically); the path, or None if not written (inside
    :func:`not_stored` too)."""
    entry = _entry(kind, key)
    if entry is None or _NOT_STORED:
        return None
    path, text = entry
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".npz", dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            # numpy's hints take ** for its own keyword options, not the arrays' names
            np.savez(f, __key__=np.array(text), **arrays)  # type: ignore[arg-type]
        os.replace(tmp, path)
        tmp = None
        _prune_now_and_then(path.parent)
        return path
    except OSError:
        return None
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass


#: stores in a folder between two counts of its entries (a count reads the whole folder: 4 ms at 4096 entries)
PRUNE_EVERY = 64
_STORES: dict[Path, int] = {}


def _prune_now_and_then(folder: Path) -> None:
    """:func:`_prune` at a process's first store into ``folder`` and every :data:`PRUNE_EVERY` stores after it, to
    ``PRUNE_EVERY - 1`` entries below :data:`MAX_ENTRIES`, so that the stores between two counts never take the
    folder beyond it (in one process)."""
    n = _STORES.get(folder, 0)
    _STORES[folder] = n + 1
    if n % PRUNE_EVERY == 0:
        _prune(folder, MAX_ENTRIES - (PRUNE_EVERY - 1))


def _prune(folder: Path, keep: int | None = None) -> None:
    """Beyond ``keep`` entries (default :data:`MAX_ENTRIES`), remove the least recently used
    down to ``keep - keep // 8`` (so that the next stores only count the entries; another
    process may remove them first)."""
    keep = MAX_ENTRIES if keep is None else keep
    try:
        names = [e for e in os.scandir(folder) if e.name.endswith(".npz") and not e.name.startswith(".tmp-")]
        if len(names) <= keep:        # (counted without a stat per entry: the common case)
            return
        entries = [(e.stat().st_mtime, e.path) for e in names]
    except OSError:
        return
    for _, p in sorted(entries)[:len(entries) - (keep - keep // 8)]:
        try:
            os.unlink(p)
        except OSError:
            pass

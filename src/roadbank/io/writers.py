"""Writing estimation results: one table per log, CSV or Parquet; whether an output path can be written
(:func:`output_problem`), and errors that name it (:func:`write_error`).

Columns (SI): ``t`` (s), then for every estimator ``<name>.theta`` (rad, bank +
body roll), ``<name>.phi_b`` (rad, road bank), ``<name>.valid`` (0/1: the sample was usable),
``<name>.settled`` (0/1: valid, and the estimator's settling time after its last (re)start:
:attr:`roadbank.signals.Estimate.settled`), and ``reference_roll`` (rad) when the log has one. ``t`` is the log's
own clock as its reader gives it (``Log.signals.t``), not shifted here: what it counts from is the format's (seconds
since the epoch, from the recording's start, or as a file's numeric time column is written; docs/io.md).
"""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path
from typing import Any, TextIO

import numpy as np

OUTPUT_FORMATS = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}


def estimate_table(t, estimates, reference_roll=None) -> dict[str, np.ndarray]:
    """Columns of the output table, in order (see module doc): ``t`` (s, the log's own clock as read), then per
    estimator its ``theta`` and ``phi_b`` (rad) and its ``valid`` and ``settled`` flags, and ``reference_roll``
    (rad)."""
    cols = {"t": np.asarray(t, dtype=np.float64)}
    for est in estimates:
        cols[f"{est.name}.theta"] = np.asarray(est.theta, dtype=np.float64)
        cols[f"{est.name}.phi_b"] = np.asarray(est.phi_b, dtype=np.float64)
        cols[f"{est.name}.valid"] = np.asarray(est.valid, dtype=bool)
        cols[f"{est.name}.settled"] = np.asarray(est.settled, dtype=bool)
    if reference_roll is not None:
        cols["reference_roll"] = np.asarray(reference_roll, dtype=np.float64)
    return cols


def write_table(path, cols: dict[str, np.ndarray], metadata: dict | None = None,
                format: str | None = None) -> Path:
    """Write ``cols`` to ``path`` as CSV (header line) or Parquet (``metadata`` in the schema)."""
    p = Path(path)
    fmt = format or OUTPUT_FORMATS.get(p.suffix.lower())
    if fmt not in ("csv", "parquet"):
        raise ValueError(f"{p}: output must end in .csv or .parquet")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        if fmt == "parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq
            meta = {k: (v if isinstance(v, str) else json.dumps(v)) for k, v in (metadata or {}).items()}
            table = pa.table({k: pa.array(v) for k, v in cols.items()})
            table = table.replace_schema_metadata(meta)
            pq.write_table(table, p, use_dictionary=False)   # float columns: dictionaries cost 15x the time
        else:
            with open(p, "w", newline="") as fh:
                csv.writer(fh).writerow(list(cols))
                _csv_rows(fh, cols)
    except OSError as exc:      # named: the path and why (a full disk, a file where a folder should be)
        raise write_error(p, exc) from exc
    return p


def _csv_rows(fh, cols: dict[str, np.ndarray]) -> None:
    """Append the rows of ``cols``: floats as repr (exact round trip), booleans as 0/1."""
    arrays = [v.astype(int) if v.dtype == bool else v for v in cols.values()]
    w = csv.writer(fh)
    for row in zip(*arrays):
        w.writerow([repr(float(x)) if isinstance(x, (float, np.floating)) else int(x) for x in row])


def _to_arrow(v):
    """1-D numpy array -> pyarrow array, zero-copy for numbers, without ``pa.array``'s
    pandas checks (they import pandas, ~40 MB resident, into every streamed estimate)."""
    import pyarrow as pa

    v = np.ascontiguousarray(v)
    if v.dtype == np.bool_:
        bits = np.packbits(v, bitorder="little")
        return pa.Array.from_buffers(pa.bool_(), len(v), [None, pa.py_buffer(bits)])
    if v.dtype.kind in "fiu":
        return pa.Array.from_buffers(pa.from_numpy_dtype(v.dtype), len(v), [None, pa.py_buffer(v)])
    return pa.array(v)


class TableWriter:
    """Write an output table chunk by chunk: Parquet row groups or CSV lines appended.

    ``write(cols)`` takes the columns of one chunk (same names and types every
    time, as :func:`estimate_table` makes them); memory holds one chunk only.
    The file is written under a temporary name and renamed into place by
    :meth:`close`, so an interrupted run never leaves a complete-looking file;
    :meth:`abort` removes the partial file. Use as a context manager.

    Parameters
    ----------
    path : path-like
        ``.csv`` or ``.parquet`` (or ``format``).
    metadata : dict, optional
        Parquet schema metadata (values JSON-encoded unless text).
    format : {"csv", "parquet"}, optional
    """

    def __init__(self, path, metadata: dict | None = None, format: str | None = None):
        self.path = Path(path)
        self.format = format or OUTPUT_FORMATS.get(self.path.suffix.lower())
        if self.format not in ("csv", "parquet"):
            raise ValueError(f"{self.path}: output must end in .csv or .parquet")
        self.metadata = {k: (v if isinstance(v, str) else json.dumps(v)) for k, v in (metadata or {}).items()}
        self.tmp = self.path.with_name(self.path.name + ".partial")
        self.rows = 0
        self.chunks = 0
        self._pq: Any = None                     # pyarrow.parquet.ParquetWriter, opened on the first chunk
        self._fh: TextIO | None = None
        self._names: list[str] | None = None

    def write(self, cols: dict[str, np.ndarray]) -> None:
        """Append one chunk (dict name -> 1-D array, all the same length). An ``OSError`` (a full disk, a
        path that cannot be created) names the output file (:func:`write_error`)."""
        try:
            self._write(cols)
        except OSError as exc:
            raise write_error(self.path, exc) from exc

    def _write(self, cols: dict[str, np.ndarray]) -> None:
        if self._names is None:
            self._names = list(cols)
            self.path.parent.mkdir(parents=True, exist_ok=True)
        elif list(cols) != self._names:
            raise ValueError(f"{self.path}: chunk columns {list(cols)} differ from {self._names}")
        n = len(next(iter(cols.values()))) if cols else 0
        if self.format == "parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq
            table = pa.table({k: _to_arrow(v) for k, v in cols.items()})
            if self._pq is None:
                self._pq = pq.ParquetWriter(self.tmp, table.schema.with_metadata(self.metadata),
                                            use_dictionary=False)
            self._pq.write_table(table.replace_schema_metadata(self.metadata))
        else:
            if self._fh is None:
                self._fh = open(self.tmp, "w", newline="")
                csv.writer(self._fh).writerow(self._names)
            _csv_rows(self._fh, cols)
        self.rows += n
        self.chunks += 1

    def close(self) -> Path:
        """Finish the file and move it into place; returns its path."""
        if self._names is None:
            raise ValueError(f"{self.path}: nothing was written")
        try:
            if self._pq is not None:
                self._pq.close()
            if self._fh is not None:
                self._fh.close()
            os.replace(self.tmp, self.path)
        except OSError as exc:
            raise write_error(self.path, exc) from exc
        return self.path

    def abort(self) -> None:
        """Close and delete the partial file (never raises: the error that made the caller abort is the one
        to report)."""
        for h in (self._pq, self._fh):
            try:
                if h is not None:
                    h.close()
            except Exception:
                pass
        try:
            self.tmp.unlink(missing_ok=True)
        except OSError:     # not there to remove: its folder is a file, the name a directory, ...
            pass

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        else:
            self.abort()
        return False


def output_problem(path, directory: bool = False) -> str | None:
    """Why ``path`` cannot be written as a file (``directory``: created as a directory), as far as can be
    told without writing: ``"cannot write 'a.csv/o.csv': 'a.csv' is a file, not a directory"``; None if it can be.

    A file is written under ``<name>.partial`` first (:class:`roadbank.io.writers.TableWriter`), so that
    name being a directory is a problem too.
    """
    p = Path(path)
    start = "cannot write"
    if directory:
        start = "cannot write into directory" if p.is_dir() else "cannot create directory"

    def problem(reason: str) -> str:
        return f"{start} '{p}': {reason}"
    if directory and p.exists() and not p.is_dir():
        return problem("it is a file, not a directory")
    if not directory:
        if p.is_dir():
            return problem("it is a directory")
        tmp = p.with_name(p.name + ".partial")
        if tmp.is_dir():
            return problem(f"its temporary file '{tmp}' is a directory (remove it)")
    q = p if directory and p.is_dir() else p.parent
    while not q.exists() and q != q.parent:
        q = q.parent
    if q.exists() and not q.is_dir():
        return problem(f"'{q}' is a file, not a directory")
    if q.is_dir() and not os.access(q, os.W_OK | os.X_OK):
        return problem(f"'{q}' is not writable (permission denied)")
    return None


class WriteError(OSError):
    """An output file could not be written: the message names it and why (:func:`write_error`)."""


def write_error(path, exc: OSError) -> OSError:
    """A :class:`WriteError` whose message names ``path`` and why writing it failed (the error ``exc``
    writing it raised: a full disk, or what :func:`output_problem` finds); ``exc`` itself if it is one."""
    if isinstance(exc, WriteError):
        return exc
    err = WriteError(output_problem(path) or f"cannot write '{path}': {exc.strerror or exc}")
    err.errno = exc.errno
    return err

"""Many logs: in-process or on dask.distributed, a summary table appended as each log finishes.

Layout of an output directory::

    OUTDIR/<stem>.bank.parquet   one result table per log (or .csv)
    OUTDIR/summary.csv           one row per finished log (LogSummary columns), appended and
                                 flushed the moment the log finishes

    OUTDIR/settings.json         what every log was estimated with (estimators, formats, channel
                                 map, car): a resume with other settings is refused

``resume=True`` reads ``summary.csv`` and skips every log whose row says
``ok`` and whose output file exists; logs that failed are tried again (a fixed
file then goes through). A last row cut off mid-line (the run was killed while
writing it) is dropped from the file and its log estimated again; a summary that
is not one (not UTF-8 text, no header) is a :class:`LogError` naming it. A log keeps
the output name its summary row gives, and a log new to the folder takes a name no
other log has had (:func:`fleet_output_names`), so logs added between two calls never
overwrite another's result. After a resumed call ``summary.csv`` holds one row per log,
its latest. A log is known again by what it reads (:func:`log_identity`), whether given
by a relative or an absolute path.
"""

from __future__ import annotations

import csv
import glob
import hashlib
import io
import json
import math
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..defaults import ESTIMATOR as DEFAULT
from ..io import detect_format, read_channel_map
from ..io.errors import LogError
from ..io.files import present
from ..io.kitti import broken_drive, drive_name, find_oxts_dirs, is_oxts_dir
from ..io.stream import stream_log
from ..io.writers import output_problem, write_error
from .cluster import BATCH_BYTES, BATCH_MAX_LOGS, BATCHES_PER_WORKER, batches  # noqa: F401  (public here too)
from .cluster import open_pool
from .process import SUMMARY_COLUMNS, LogSummary, estimate_log

SUMMARY = "summary.csv"
#: the longest log name (bytes) in an output file's name: with ``-<n>.bank.parquet.partial`` it stays below the 255
#: bytes a file name may have
MAX_STEM_BYTES = 200
#: the settings of the logs in an output directory (:func:`check_settings`)
SETTINGS = "settings.json"
#: suffixes of log files picked up when a directory is given
LOG_SUFFIXES = {".csv", ".parquet", ".pq", ".mf4", ".mdf", ".blf", ".asc", ".trc", ".log", ".bag", ".mcap"}


def _is_log_dir(p: Path) -> bool:
    """A directory that is itself one log: a comma2k19 segment, a ROS 2 bag, a KITTI drive folder or its
    ``oxts/`` folder. A folder that holds drives is not one: its logs are listed (:func:`_logs_in`)."""
    try:
        fmt = detect_format(p)
    except LogError:
        return False
    return fmt != "kitti-oxts" or find_oxts_dirs(p) in ([p], [p / "oxts"])


def enclosing_log(p: Path, levels: int = 3) -> Path | None:
    """The log directory (a comma2k19 segment, a ROS 2 bag, a KITTI drive) that ``p`` lies inside, up to ``levels``
    folders up (``processed_log/`` of a segment, ``oxts/data/`` of a drive); None if none."""
    for parent in list(Path(p).resolve().parents)[:levels]:
        if _is_log_dir(parent):
            return parent
    return None


def _is_log_file(p: Path) -> bool:
    """A file a folder contributes: a log suffix (:data:`LOG_SUFFIXES`), not an output of ``estimate``."""
    return p.suffix.lower() in LOG_SUFFIXES and not is_own_output(p)


def is_own_output(p: Path) -> bool:
    """Whether the file ``p`` is named as ``estimate`` names what it writes into an output directory (a result table
    ``<stem>.bank.csv`` or ``.parquet``, ``summary.csv``): never read as a log from a folder or a pattern."""
    return p.name.endswith((".bank.csv", ".bank.parquet")) or p.name == SUMMARY


def _logs_in(d: Path, seen: set | None = None, left_out: list | None = None) -> list[Path]:
    """Every log the directory ``d`` holds, ``d`` not being one log itself: its log files, its log
    sub-directories (comma2k19 segments, ROS 2 bags, KITTI drives; a drive short of a file too, to be
    reported) and the logs of its other sub-directories, recursively.

    A folder whose only log is one readable KITTI drive (a KITTI date folder) is that log: ``[d]``,
    named after the drive (:func:`output_names`), as :func:`~roadbank.io.load_log` reads it. A folder that
    cannot be listed is returned as a log, for the reader to report (:func:`roadbank.io.files.must_exist`);
    a folder reached again through a link (``seen``: the resolved folders so far) is not listed twice. Files
    named as ``estimate``'s outputs are appended to ``left_out`` (:func:`is_own_output`).
    """
    seen = set() if seen is None else seen
    try:
        real = d.resolve()
        if real in seen:
            return []
        seen.add(real)
        entries = sorted(d.iterdir())
    except OSError:
        return [d]
    out: list[Path] = []
    for c in entries:
        try:
            folder = c.is_dir()
        except OSError:             # in a folder that can be listed, not searched: the reader says so
            out.append(c)
            continue
        if folder:
            out += [c] if _is_log_dir(c) or broken_drive(c) else _logs_in(c, seen, left_out)
        elif _is_log_file(c):
            out.append(c)
        elif left_out is not None and is_own_output(c):
            left_out.append(c)
    if len(out) == 1 and out[0].parent == d and is_oxts_dir(out[0] / "oxts"):
        return [d]
    return out


def expand_logs(args, left_out: list | None = None) -> list[Path]:
    """Log paths from command-line arguments: files, log directories, directories of logs, glob patterns.

    A directory that is not itself a log (comma2k19 segment, ROS 2 bag, KITTI drive or its ``oxts/``
    folder) gives every log it holds (:func:`_logs_in`): its files with a log suffix
    (:data:`LOG_SUFFIXES`), each of its KITTI drives, comma2k19 segments and ROS 2 bags, recursively,
    so a drive beside other logs never hides them; a folder holding one KITTI drive and no other log
    stays that one log. A KITTI drive short of a file (:func:`~roadbank.io.kitti.broken_drive`)
    counts as a log, to be reported. A pattern with ``*``, ``?`` or ``[`` that is not an existing
    path is expanded (``**`` recursive), each directory it matches as if given; of the files it matches, those named
    as ``estimate``'s own outputs (:func:`is_own_output`) are left out, as a folder leaves them out, and appended to
    ``left_out`` when it is given (for the caller to say so). A folder reached twice through links is listed once.
    Sorted, unique.
    """
    out: list[Path] = []
    seen: set = set()
    for a in args:
        p = Path(a)
        pattern = not present(p) and any(ch in str(a) for ch in "*?[")
        found = [Path(x) for x in sorted(glob.glob(str(a), recursive=True))] if pattern else [p]
        for q in found:
            if pattern and q.is_file() and is_own_output(q):
                if left_out is not None:
                    left_out.append(q)
                continue
            out += _logs_in(q, seen, left_out) if q.is_dir() and not _is_log_dir(q) and not broken_drive(q) else [q]
    return sorted(dict.fromkeys(out))


def log_identity(p: Path) -> str:
    """What a log path reads, as one string for telling two paths of one log apart: its real path, and for a KITTI
    drive given as its folder, its ``oxts/`` folder or a folder holding only it, the real path of that ``oxts/``."""
    try:
        if p.is_dir():
            found = find_oxts_dirs(p)
            if len(found) == 1:
                return os.path.realpath(found[0])
    except OSError:             # cannot be looked at: its path is all there is
        pass
    return os.path.realpath(p)


def _estimate_batch(jobs, estimators, kw) -> list[LogSummary]:
    """:func:`estimate_log` on each job ``(path, output, metadata, plot)`` in turn, in one worker
    (its estimator designs and compiled kernels serve them all); a bad log costs only its own row."""
    return [estimate_log(p, out, estimators, metadata=meta, plot=png, **kw) for p, out, meta, png in jobs]


def _stem(p: Path) -> str:
    """A log's name: a file's stem, a directory's name; a KITTI drive (its folder, its ``oxts/`` folder or a folder
    holding only it): the drive's; cut to :data:`MAX_STEM_BYTES` (:func:`_short`)."""
    try:
        if p.is_file():
            return _short(p.stem)
    except OSError:             # cannot be looked at (the reader says so): named as a file
        return _short(p.stem)
    found = find_oxts_dirs(p)
    return _short(drive_name(found[0]) if len(found) == 1 else p.name)


def _short(stem: str) -> str:
    """``stem`` as it is up to :data:`MAX_STEM_BYTES` bytes (UTF-8); a longer one cut there, less room for ``~`` and 8
    hex digits of its digest, so that two long names that share their start stay apart."""
    raw = stem.encode("utf-8", "surrogateescape")
    if len(raw) <= MAX_STEM_BYTES:
        return stem
    head = raw[:MAX_STEM_BYTES - 9].decode("utf-8", "ignore")      # (a character cut in two is left out)
    return f"{head}~{hashlib.sha256(raw).hexdigest()[:8]}"


def output_names(paths: list[Path], suffix: str, given: dict[str, str] | None = None) -> dict[Path, str]:
    """``<stem>.bank.<suffix>`` per log, made unique in the order of ``paths``; a log whose :func:`log_identity` has a
    name in ``given`` (an earlier call's, :func:`fleet_output_names`) keeps it, and no other log takes one of those."""
    given = given or {}
    used: set[str] = {name.split(".bank.")[0] for name in given.values()}      # stems taken
    names = {}
    for p in paths:
        had = given.get(log_identity(p)) if given else None
        if had is not None and had.endswith(f".bank.{suffix}"):
            names[p] = had
            continue
        stem = _stem(p)
        s, k = stem, 1
        while s in used:
            k += 1
            s = f"{stem}-{k}"
        used.add(s)
        names[p] = f"{s}.bank.{suffix}"
    return names


def _parse_summary(f: Path) -> tuple[list[str], list[dict], int | None]:
    """``(columns, rows, cut)`` of the summary file ``f``: its header and complete rows, and the bytes
    to keep when its last row was cut off mid-line (None: the file is whole; ``columns`` empty: nothing
    to keep). LogError naming ``f`` if it is not a summary."""
    data = f.read_bytes()
    again = "delete it to start the batch again, or give another -o"
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise LogError(f"{f}: not a readable summary (not UTF-8 text: byte 0x{data[exc.start]:02x} at position "
                       f"{exc.start}); {again}") from None
    lines = list(io.StringIO(text, newline=""))
    reader = csv.reader(lines)
    rows, ends = [], []
    try:
        for row in reader:
            if row:
                rows.append(row)
                ends.append(reader.line_num)
    except csv.Error as exc:
        raise LogError(f"{f}: not a readable summary ({exc}); {again}") from None
    whole = text.endswith(("\n", "\r"))
    if len(rows) < 1 + (not whole):     # empty, or a header cut off: nothing to keep
        return [], [], None
    if not {"log", "status", "output"} <= set(rows[0]):
        raise LogError(f"{f}: not a roadbank summary (no log, status and output columns in its first line); "
                       f"{again}")
    cut = None
    if not whole:       # the run stopped while writing the last row: that log is estimated again
        rows.pop()
        cut = len("".join(lines[:ends[-2]]).encode("utf-8"))
    return rows[0], [dict(zip(rows[0], r)) for r in rows[1:]], cut


def fleet_output_names(paths: list[Path], outdir, suffix: str, resume: bool) -> dict[Path, str]:
    """The output file names of ``paths`` in ``outdir``: :func:`output_names`, resuming with the names that its
    ``summary.csv`` gives the logs it lists."""
    return output_names(paths, suffix, _given_names(read_summary(outdir) if resume else []))


def _given_names(rows: list[dict]) -> dict[str, str]:
    """:func:`log_identity` -> output file name of the summary rows ``rows`` that have an output."""
    return {log_identity(Path(row["log"])): Path(row["output"]).name for row in rows if row.get("output")}


def fleet_settings(estimators, output_format: str, format: str | None, channels, params, vehicle,
                   online_offsets: bool) -> dict[str, str]:
    """What a fleet's logs are estimated with, as :data:`SETTINGS` records it: the estimators, the output and log
    formats, whether offsets are learnt online, and a digest of the channel map, the car parameters and the vehicle
    file (their text would not fit a message)."""
    def digest(text: str) -> str:
        return hashlib.sha256(text.encode()).hexdigest()[:16]
    return {"estimators": ",".join(estimators), "output format": output_format, "log format": format or "by suffix",
            "online offsets": str(bool(online_offsets)),
            "channel map": "none" if channels is None else digest(repr(channels)),
            "car parameters": "default" if params is None else digest(repr(params)),
            "vehicle file": "none" if vehicle is None else digest(vehicle.dumps())}


def check_settings(outdir: Path, settings: dict[str, str], resume: bool) -> None:
    """Record ``settings`` (:func:`fleet_settings`) in ``outdir``'s :data:`SETTINGS`; resuming, a LogError first where
    that file records others (the folder would mix results of two settings; a folder without the file, written
    before it was kept, is taken as it is)."""
    f = outdir / SETTINGS
    if resume and f.exists():
        try:
            old = json.loads(f.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            raise LogError(f"{f}: not readable ({exc}); delete it to resume with the settings given now") from None
        changed = [k for k in settings if k in old and old[k] != settings[k]]
        if changed:
            said = "; ".join(f"{k}: {old[k]} then, {settings[k]} now" if k in ("estimators", "output format",
                                                                                 "log format", "online offsets")
                             else f"{k} changed" for k in changed)
            raise LogError(f"{outdir}: its logs were estimated with other settings ({said}): --resume would mix "
                           "them; resume with the same settings, run without --resume to estimate every log again, "
                           "or give another -o")
    try:
        tmp = f.with_name(f.name + ".partial")
        tmp.write_text(json.dumps(settings, indent=1) + "\n", encoding="utf-8")
        os.replace(tmp, f)
    except OSError as exc:
        raise write_error(f, exc) from None


def compact_summary(outdir) -> None:
    """Rewrite ``OUTDIR/summary.csv`` with one row per log, its latest, in the order logs first appear (a resumed
    call appends a row for each log it runs again)."""
    f = Path(outdir) / SUMMARY
    if not f.exists():
        return
    columns, rows, _ = _parse_summary(f)
    latest: dict[str, dict] = {}
    for row in rows:
        latest[log_identity(Path(row["log"]))] = row      # (a key keeps its first place)
    if len(latest) == len(rows):
        return
    tmp = f.with_name(f.name + ".partial")
    try:
        with open(tmp, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
            w.writeheader()
            w.writerows(latest.values())
        os.replace(tmp, f)
    except OSError as exc:
        raise write_error(f, exc) from None


def read_summary(outdir) -> list[dict]:
    """Complete rows of ``OUTDIR/summary.csv`` (empty list if there is none; a last row cut off mid-line
    is left out). LogError naming the file if it is not a summary (binary, not UTF-8, no header)."""
    f = Path(outdir) / SUMMARY
    if not f.exists():
        return []
    return _parse_summary(f)[1]


class _SummaryFile:
    """``summary.csv``, appended row by row and flushed at once. Resuming, a last row cut off mid-line
    is removed first (``notes`` says so) and the rows go on after the complete ones."""

    def __init__(self, outdir: Path, resume: bool):
        self.path = outdir / SUMMARY
        self.notes: list[str] = []
        columns, cut = list(SUMMARY_COLUMNS), None
        new = not (resume and self.path.exists())
        if not new:         # appending: the existing file's columns (one written before a column was added)
            old, _, cut = _parse_summary(self.path)
            columns, new = old or columns, not old
        try:
            if cut is not None:
                with open(self.path, "r+b") as fh:
                    fh.truncate(cut)
                self.notes.append(f"{self.path}: its last row was cut off (an interrupted run?): removed, "
                                  "that log is estimated again")
            self.fh = open(self.path, "w" if new else "a", newline="")
        except OSError as exc:
            raise write_error(self.path, exc) from None
        self.w = csv.DictWriter(self.fh, fieldnames=columns, extrasaction="ignore")
        if new:
            self.w.writeheader()
            self.fh.flush()

    def add(self, s: LogSummary) -> None:
        row = s.row()
        row = {k: (f"{v:.6g}" if isinstance(v, float) and not math.isnan(v) else
                   ("" if isinstance(v, float) else v)) for k, v in row.items()}
        self.w.writerow(row)
        self.fh.flush()

    def close(self):
        self.fh.close()


@dataclass
class FleetResult:
    """What :func:`run_fleet` did.

    Attributes
    ----------
    summaries : list of LogSummary
        One per log processed by this call, in completion order.
    skipped : list of str
        Logs skipped because a previous call finished them (resume).
    workers : int
        Worker processes used (1: in-process, no Dask).
    startup_s : float
        Seconds to start / connect to the Dask cluster and warm its workers up (0 in-process).
    wall_s : float
        Seconds from the first log submitted to the last one finished (start-up excluded).
    cpu_s : float
        CPU seconds the workers spent over that time (in-process: this process; on Dask: the
        sum over the workers, every thread of each); NaN where not measured.
    client_cpu_s : float
        CPU seconds of this process over that time on workers (the client); 0 in-process (it is
        ``cpu_s``).
    notes : list of str
        What was done to ``summary.csv`` besides appending (a cut-off last row removed).
    """

    summaries: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    workers: int = 1
    startup_s: float = 0.0
    wall_s: float = 0.0
    cpu_s: float = math.nan
    client_cpu_s: float = 0.0
    notes: list = field(default_factory=list)

    @property
    def failed(self) -> list[LogSummary]:
        return [s for s in self.summaries if s.status != "ok"]


def _first_of_each_format(paths) -> list[Path]:
    """The first log of each kind in ``paths`` (by file suffix; a log directory is a kind of its own)."""
    seen: dict[str, Path] = {}
    for p in map(Path, paths):
        seen.setdefault(p.suffix.lower() if not p.is_dir() else "/", p)
    return list(seen.values())


def _read_first_chunk(path, channels=None, format=None, params=None) -> None:
    """Read the first chunk of ``path`` and drop it (its reader and the reader's libraries loaded,
    asammdf for MDF4 say); any failure is left to the log's own run to report."""
    chunks = None
    try:
        chunks = stream_log(path, channels=channels, format=format, params=params, chunk_rows=1024)
        next(iter(chunks), None)
    except Exception:       # a bad log is reported when it is estimated
        pass
    finally:
        close = getattr(chunks, "close", None)
        if close is not None:
            close()


def _warm(names, params, vehicle=None, samples=(), channels=None, format=None):
    """Estimate a small generated Parquet log once on a worker, as every log will be (designs for
    the car, compiled kernels, the reader, the time-base checks and the writer: what a first log
    would otherwise pay inside the timed run), then read the first chunk of each of ``samples``
    (a log of each format of the run: :func:`_first_of_each_format`) for their readers."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    n = 300
    t = np.arange(n) * 0.01
    cols = {"t": t, "vx": np.full(n, 20.0), "ay": 0.05 * np.sin(7.0 * t), "r": np.zeros(n), "delta_f": np.zeros(n)}
    with tempfile.TemporaryDirectory(prefix="roadbank-warm-") as tmp:
        pq.write_table(pa.table(cols), f"{tmp}/warm.parquet")
        estimate_log(f"{tmp}/warm.parquet", f"{tmp}/warm.bank.parquet", names, params=params, vehicle=vehicle)
    for path in samples:
        _read_first_chunk(path, channels, format, params)
    return True


def run_fleet(logs, outdir, estimators=(DEFAULT,), *, channels=None, format: str | None = None,
              params=None, vehicle=None, output_format: str = "parquet", workers: int = 1,
              scheduler: str | None = None, resume: bool = False, chunk_rows: int | None = None,
              metadata: dict | None = None, plot_dir=None, on_result=None,
              connect_timeout: float = 20.0, online_offsets: bool = True,
              batch: int | None = None) -> FleetResult:
    """Estimate the bank on many logs, writing each result and a summary row as soon as a log finishes.

    Parameters
    ----------
    logs : sequence of path-like
        Log paths (see :func:`expand_logs` for directories and patterns).
    outdir : path-like
        Output directory (module doc).
    estimators : sequence of str
    channels : ChannelMap or path, optional
    format : str, optional
    params : VehicleParams, optional
    vehicle : roadbank.vehicle.Vehicle, optional
        Builds the estimators (see :func:`estimate_log`).
    output_format : {"parquet", "csv"}
    workers : int
        1: in this process, one log after another. More: that many worker processes on this
        machine (:class:`roadbank.fleet.cluster.OnProcesses`), at most one per log to run (a worker
        without a log would only cost its start).
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``); overrides ``workers``.
    resume : bool
        Skip logs ``summary.csv`` lists as ok whose output exists (module doc: a damaged summary).
    chunk_rows : int, optional
        Streaming chunk size (rows).
    metadata : dict, optional
        Extra Parquet metadata of every output (``source`` is added per log).
    plot_dir : path-like, optional
        One PNG of theta / phi_b per log, ``<stem>.png``.
    on_result : callable(LogSummary), optional
        Called in the client as each log finishes (on Dask: as each batch of logs finishes).
    batch : int, optional
        Logs per Dask task (default: automatic, :func:`batches`): short logs are processed many
        to a task, so the scheduling cost per task is paid once per batch. A worker that dies
        (memory, signal) fails its whole batch; a bad log fails only itself.

    Returns
    -------
    FleetResult
    """
    outdir = Path(outdir)
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(output_problem(outdir, directory=True) or f"cannot create directory '{outdir}': "
                      f"{exc.strerror or exc}") from None
    if channels is not None and not hasattr(channels, "channels"):
        channels = read_channel_map(channels)
    paths = [Path(p) for p in logs]
    check_settings(outdir, fleet_settings(estimators, output_format, format, channels, params, vehicle,
                                          online_offsets), resume)
    rows = read_summary(outdir) if resume else []
    names = output_names(paths, output_format, _given_names(rows))
    done = set()
    for row in rows:
        if row.get("status") == "ok" and row.get("output") and Path(row["output"]).exists():
            done.add(log_identity(Path(row["log"])))
        else:
            done.discard(log_identity(Path(row["log"])))    # its latest row failed
    finished = {p for p in paths if log_identity(p) in done} if done else set()
    todo = [p for p in paths if p not in finished]
    result = FleetResult(skipped=[str(p) for p in paths if p in finished])
    summary = _SummaryFile(outdir, resume)
    result.notes += summary.notes
    jobs = [(p, outdir / names[p], dict(metadata or {}, source=str(p)),
             None if plot_dir is None else Path(plot_dir) / (names[p].split(".bank.")[0] + ".png"))
            for p in todo]
    kw = dict(channels=channels, format=format, params=params, vehicle=vehicle, chunk_rows=chunk_rows,
              online_offsets=online_offsets)

    def finish(s: LogSummary):
        summary.add(s)
        result.summaries.append(s)
        if on_result is not None:
            on_result(s)

    workers = min(int(workers), max(len(jobs), 1))
    t0 = time.perf_counter()
    try:
        if scheduler is None and workers <= 1:
            c0 = time.process_time()
            for p, out, meta, png in jobs:
                finish(estimate_log(p, out, estimators, metadata=meta, plot=png, **kw))
            result.cpu_s = time.process_time() - c0
        elif jobs:
            _run_dask(jobs, estimators, kw, workers, scheduler, connect_timeout, finish, result, batch)
    finally:
        summary.close()
        result.wall_s = time.perf_counter() - t0 - result.startup_s
        if resume:
            compact_summary(outdir)
    return result


def _run_dask(jobs, estimators, kw, workers, scheduler, connect_timeout, finish, result, batch=None):
    warm = (_warm, list(estimators), kw["params"], kw["vehicle"], _first_of_each_format(j[0] for j in jobs),
            kw["channels"], kw["format"])
    with open_pool(workers, scheduler, connect_timeout, warm=warm) as pool:
        result.workers, result.startup_s = pool.workers, pool.startup_s
        cpu0, client0 = pool.cpu_seconds(), time.process_time()
        groups = {}
        logs = [j[0] for j in jobs]
        for idx in (pool.batches(logs) if batch is None else batches(logs, result.workers, batch)):
            group = [jobs[i] for i in idx]
            groups[pool.submit(_estimate_batch, group, list(estimators), kw)] = group
        for task in pool.as_completed(groups):
            summaries, failure = pool.outcome(task)
            if failure is not None:     # the worker died (memory, signal): this batch only
                summaries = [LogSummary(log=str(p), status="error", error=failure) for p, *_ in groups[task]]
            for s in summaries:
                finish(s)
        result.client_cpu_s = time.process_time() - client0
        result.cpu_s = _cpu_spent(cpu0, pool.cpu_seconds())


def _cpu_spent(before: dict, after: dict) -> float:
    """CPU seconds between two :meth:`OnDask.cpu_seconds` readings, summed over the workers
    present in both (NaN if none)."""
    common = before.keys() & after.keys()
    return sum(after[w] - before[w] for w in common) if common else math.nan

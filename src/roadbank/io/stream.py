"""Long logs in bounded memory: :func:`stream_log` yields a log as consecutive chunks.

Parquet files are read in record batches (pyarrow ``iter_batches``) and MDF4
files in windows of ``chunk_rows`` records per channel group (asammdf ``select``
with ``record_offset``/``record_count``, every wanted channel of the group at once),
so memory stays bounded by the chunk size whatever the log's length. Other
formats (CSV, raw CAN, ROS bags, comma2k19, ...) are read whole and yielded as
one chunk.

Each chunk is a :class:`~roadbank.io.Log` whose signals continue the previous
chunk's; feeding them to ``Estimator.run(chunk.signals, reset=False)`` gives
the same numbers as one run over :func:`~roadbank.io.load_log`'s result. The
time base follows :mod:`roadbank.io.resample` exactly, computed incrementally
by :class:`StreamResampler`: channels are buffered only until every channel has
passed a grid time, then interpolated with the same gap rule and dropped.

Differences from :func:`~roadbank.io.load_log`, all documented in docs/io.md:
``time_base = "auto"`` decides whether the table clock is used from the first
chunk (not the whole file); unit plausibility is checked per chunk and the
cross-channel consistency check on the first chunk; truth columns are carried
only when the table clock is used.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from ..params import VehicleParams
from ..signals import Signals, concat_signals
from . import readers
from .channels import ChannelMap, check_plausible, default_channel_map, read_channel_map
from .consistency import check_consistency
from .errors import LogError, channel_error
from .files import open_mdf
from .log import (FLAGGED_ROLES, GNSS_MAX_GAP_S, gnss_extra, gnss_roles, load_log, missing_column, repair_counts,
                  repair_stamps, select_roles, steering_delta_f)
from .resample import clean_series, interpolate
from .timebase import MISSING, OUT_OF_ORDER, add_counts
from .types import Log

#: default rows per chunk (records per channel group for MDF4): 20 000 samples = 3.3 min at 100 Hz
#: (memory vs per-chunk overhead: each 10 000 rows cost about 3.5 MiB of peak memory, docs/io.md)
CHUNK_ROWS = 20_000
STREAMED = ("parquet", "mdf4")
#: rows at the end of each streamed chunk held back for the next one, so that a bad time stamp at a
#: chunk's end is repaired knowing the stamps after it, as in the whole file
HOLD_ROWS = 4


class ChunkRepair:
    """The time-stamp repair of :func:`~roadbank.io.timebase.repair_time` on a streamed channel.

    Each chunk is repaired after the last good stamp of the chunks before it, with the last
    :data:`HOLD_ROWS` rows held back and repaired with the next chunk. :meth:`feed` takes the stamps
    (s) and the arrays that go with them (same length) and returns them repaired; ``counts``
    adds up what was done (kind -> int, ``flagged`` too); ``warning`` is the message of the first
    chunk that needed a repair (given once).
    """

    def __init__(self, source, column: str, label: str, row_label: str = "row"):
        self.source, self.column, self.label, self.row_label = source, column, label, row_label
        self.after = None
        self.held = None         # (row0, t, {name: array}) rows waiting for the next chunk
        self.carry = False       # the row before the held ones was dropped: flag the first one kept
        self.counts: dict = {}
        self.warned = False

    def feed(self, t: np.ndarray, cols: dict, row0: int, last: bool):
        """``(t, cols, flagged, warnings)`` of the rows that are final; ``last`` for the final chunk."""
        if self.held is not None:
            h0, ht, hc = self.held
            t = np.concatenate([ht, t])
            cols = {c: np.concatenate([hc[c], a]) for c, a in cols.items()}
            row0 = h0
            self.held = None
        n = len(t)
        rep, warns = repair_stamps(self.source, self.column, t, label=self.label, after=self.after,
                                   rownums=range(row0, row0 + n), row_label=self.row_label)
        if self.carry and len(rep.keep):     # as the whole file's repair: the sample after a dropped one
            rep.flagged[0] = True
        self.carry = False
        if not last and _odd_tail(t, rep):
            cut = max(n - HOLD_ROWS, 0)
            late = np.flatnonzero(rep.keep >= cut)
            c0 = min(cut, int(rep.keep[late[0]:].min())) if len(late) else cut
            self.carry = bool(0 < c0 < n and rep.kind[c0 - 1] in (MISSING, OUT_OF_ORDER))
            rep = rep.head(c0, t, self.after)
            if c0 < n:
                self.held = (row0 + c0, t[c0:], {c: a[c0:] for c, a in cols.items()})
        self.counts = add_counts(self.counts, repair_counts(rep))
        if rep.changed and not self.warned:
            self.warned = True
        else:
            warns = []
        keep = rep.keep
        if len(keep):
            self.after = float(t[keep[-1]])
        return t[keep], {c: a[keep] for c, a in cols.items()}, rep.flagged, warns

    @property
    def holding(self) -> bool:
        """Rows are held back (a final :meth:`feed` with ``last=True`` releases them)."""
        return self.held is not None


def _odd_tail(t: np.ndarray, rep) -> bool:
    """True if the last :data:`HOLD_ROWS` stamps of a chunk were repaired or end in an odd step
    (backwards, repeated, or longer than 1.5 median steps): they wait for the next chunk (a clean
    chunk is passed whole)."""
    n = len(t)
    if n == 0:
        return False
    tail = n - HOLD_ROWS
    if np.any(rep.kind[max(tail, 0):] != 0) or np.any(rep.keep[rep.flagged] >= tail):
        return True
    d = np.diff(t[-HOLD_ROWS - 8:])
    d = d[np.isfinite(d)]
    # 1.5 periods: the later stamp of a pair swapped across the boundary makes a double step
    return bool(len(d) and (d[-1] <= 0 or d[-1] > 1.5 * float(np.median(d))))


def _final_empty(chunks, columns):
    """``(row0, cols, False)`` for each ``(row0, cols)`` table chunk, then an empty final one
    ``(rows, {column: []}, True)`` that releases the rows :class:`ChunkRepair` held back."""
    end = 0
    for row0, cols in chunks:
        end = row0 + len(next(iter(cols.values()))) if cols else row0
        yield row0, cols, False
    yield end, {c: np.zeros(0) for c in columns}, True


class StreamResampler:
    """Incremental version of :func:`~roadbank.io.resample.common_time_base` + ``resample``.

    Parameters
    ----------
    roles : list of str
        Channels that define the time base's span (their overlap).
    aux : dict name -> max gap (s)
        Channels interpolated onto the base with their own gap limit that do
        not limit its span (GNSS).
    time_base : "uniform" or a role name
    rate_hz, max_gap_s : float
        As in the channel map.

    Feed chunks with :meth:`add` (any channel, any span, time-ordered per
    channel), mark exhausted channels with :meth:`finish`, collect output with
    :meth:`emit` (dict name -> array on ``"t"``). Memory: each channel keeps only
    the samples after the last emitted grid time (plus one before it).
    """

    def __init__(self, roles, aux=None, time_base="uniform", rate_hz=100.0, max_gap_s=0.5):
        self.roles = list(roles)
        self.aux = dict(aux or {})
        self.time_base = time_base
        self.rate = float(rate_hz)
        self.max_gap = float(max_gap_s)
        names = self.roles + list(self.aux)
        self.t = {k: np.zeros(0) for k in names}
        self.v = {k: np.zeros(0) for k in names}
        self.first = {k: None for k in names}
        self.last = {k: None for k in names}
        self.done = {k: False for k in names}
        self.t0 = None       # grid start: latest first valid sample of the span roles
        self.k_next = 0      # next uniform grid index
        self.t_next = -np.inf   # role time base: next time not emitted yet

    def add(self, name: str, t: np.ndarray, v: np.ndarray) -> None:
        t, v = clean_series(t, v)
        if len(t) and self.last[name] is not None:
            keep = t > self.last[name]          # duplicates across the chunk boundary: first kept
            t, v = t[keep], v[keep]
        if len(t) == 0:
            return
        if self.first[name] is None:
            self.first[name] = t[0]
        self.last[name] = t[-1]
        self.t[name] = np.concatenate([self.t[name], t])
        self.v[name] = np.concatenate([self.v[name], v])

    def finish(self, name: str) -> None:
        self.done[name] = True

    def buffered(self) -> int:
        """Samples held in the buffers (for memory checks)."""
        return sum(len(x) for x in self.t.values())

    def _ready_until(self):
        """Latest time every channel has data for (inf if all are finished, None if one has none yet)."""
        lim = np.inf
        for k in self.t:
            if self.done[k]:
                if k in self.roles and self.last[k] is not None:
                    lim = min(lim, self.last[k])      # a finished channel ends the overlap
                continue
            if self.last[k] is None:
                return None
            lim = min(lim, self.last[k])
        return lim

    def emit(self) -> dict[str, np.ndarray] | None:
        """Grid samples that no later chunk can change; None if there are none yet."""
        for k in self.roles:
            if self.first[k] is None:
                if self.done[k]:
                    raise LogError(f"channel '{k}': no valid (finite) samples")
                return None
        if self.t0 is None:
            self.t0 = max(self.first[k] for k in self.roles)
        ready = self._ready_until()
        if ready is None:
            return None
        if all(self.done[k] for k in self.roles):
            t1 = min(self.last[k] for k in self.roles)
            if not t1 > self.t0:
                late = max(self.roles, key=lambda k: self.first[k])
                early = min(self.roles, key=lambda k: self.last[k])
                raise LogError(f"channels do not overlap in time: '{late}' starts at {self.first[late]:.3f} s "
                               f"but '{early}' ends at {self.last[early]:.3f} s")
            ready = min(ready, t1)
        if self.time_base == "uniform":
            k_end = int(np.floor((ready - self.t0) * self.rate + 1e-9)) + 1 if np.isfinite(ready) else self.k_next
            if k_end <= self.k_next:
                return None
            grid = self.t0 + np.arange(self.k_next, k_end) / self.rate
            self.k_next = k_end
        else:
            tb = self.t[self.time_base]
            grid = tb[(tb >= max(self.t0, self.t_next)) & (tb <= ready)]
            if len(grid) == 0:
                return None
            self.t_next = np.nextafter(grid[-1], np.inf)
        out = {"t": grid}
        for k in self.t:
            out[k] = interpolate(self.t[k], self.v[k], grid, self.aux.get(k, self.max_gap))
            # keep the last sample at or before the next grid time (it brackets it) and everything after
            nxt = grid[-1]
            i = max(int(np.searchsorted(self.t[k], nxt, side="right")) - 1, 0)
            self.t[k], self.v[k] = self.t[k][i:], self.v[k][i:]
        return out


def _parquet_chunks(p: Path, cols: list[str], labels: dict, chunk_rows: int):
    """(row0, {column: float64 array}) per record batch; schema names and metadata first."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        # no pre-buffering, one thread: 5x faster here and ~60 MB less than pyarrow's defaults on a 24 h file
        pf = pq.ParquetFile(p, pre_buffer=False)
        batches = pf.iter_batches(batch_size=chunk_rows, columns=cols, use_threads=False)
        row0 = 0
        for b in batches:
            yield row0, {c: readers.arrow_column_floats(p, c, labels.get(c, c), b.column(c), row0)
                         for c in cols}
            row0 += b.num_rows
    except (pa.ArrowException, OSError) as exc:
        raise LogError(f"{p}: not a readable Parquet file (truncated or corrupt?): {exc}") from None


def _schema(p: Path, fmt: str) -> tuple[list[str], dict]:
    """Column / channel names and file metadata, without reading the data."""
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq
        try:
            pf = pq.ParquetFile(p)
        except (pa.ArrowException, OSError, ValueError) as exc:
            raise LogError(f"{p}: not a readable Parquet file (truncated or corrupt?): {exc}") from None
        if pf.metadata.num_rows == 0:
            raise LogError(f"{p}: no data rows")
        return list(pf.schema_arrow.names), readers.parquet_metadata(pf.schema_arrow)
    return [], {}


class _Mdf4Channels:
    """MDF4 channels read window by window: ``chunk_rows`` records of a channel group at a
    time (asammdf ``select`` with ``record_offset``/``record_count``), every wanted channel
    of that group from one pass over its data, each with its master time stamps.

    One window of one group is in memory at a time: a per-channel ``iter_get`` keeps
    one data block (4 MiB as asammdf writes them) and one read buffer alive per
    channel (about 6.5 MiB each). Channels of the group not asked for yet wait as
    converted arrays (one window each).

    The file is opened as a Python file object rather than by name: asammdf then reads
    with ``read()`` instead of memory-mapping the file, whose touched pages would
    otherwise count in the process's resident memory as the log is read (page cache,
    reclaimable, but a 24 h log would show 400 MB more).
    """

    def __init__(self, p: Path, chunk_rows: int):
        self.p = p
        self.fh = open(p, "rb")
        try:
            self.mdf = open_mdf(p, self.fh)
        except LogError:
            self.fh.close()
            raise
        self.names = [n for n in self.mdf.channels_db if n not in ("time", "t")]
        self.chunk = max(1, int(chunk_rows))
        rec = max((int(g.channel_group.samples_byte_nr) + int(g.channel_group.invalidation_bytes_nr)
                   for g in self.mdf.groups), default=8)
        self.mdf.configure(read_fragment_size=self.chunk * max(rec, 8))   # read buffer: one window
        self.wanted: dict = {}       # key -> (group, index, label)
        self.offset: dict = {}       # group -> next record to read
        self.waiting: dict = {}      # key -> [(t, v)] read along with another channel of its group

    def want(self, key, name: str, label: str) -> None:
        """Read channel ``name`` as ``key`` (e.g. its role); call for every channel before :meth:`read`."""
        where = self.mdf.whereis(name)
        if len(where) != 1:
            what = "not in the file" if not where else f"in {len(where)} channel groups {sorted(g for g, _ in where)}"
            raise LogError(f"{self.p}: {label}: cannot read channel '{name}': it is {what}")
        group, index = where[0]
        self.wanted[key] = (int(group), int(index), label)
        self.offset.setdefault(int(group), 0)

    def read(self, key):
        """Next window of channel ``key``: (t, v), or None when exhausted."""
        queue = self.waiting.get(key)
        if queue:
            return queue.pop(0)
        group, _, label = self.wanted[key]
        start = self.offset[group]
        if start >= int(self.mdf.groups[group].channel_group.cycles_nr):
            return None
        keys = [k for k, w in self.wanted.items() if w[0] == group]
        try:
            sigs = self.mdf.select([(None, group, self.wanted[k][1]) for k in keys], record_offset=start,
                                   record_count=self.chunk, copy_master=False)
        except Exception as exc:
            raise LogError(f"{self.p}: {label}: cannot read (truncated or corrupt?): {exc}") from None
        self.offset[group] = start + self.chunk
        got = None
        for k, sig in zip(keys, sigs):
            s = np.asarray(sig.samples)
            if s.dtype.kind not in "fiub":
                raise LogError(f"{self.p}: {self.wanted[k][2]}: not numeric ({s.dtype})")
            tv = np.asarray(sig.timestamps, dtype=np.float64), np.asarray(s, dtype=np.float64)
            if k == key:
                got = tv
            else:
                self.waiting.setdefault(k, []).append(tv)
        return got

    def close(self):
        try:
            self.mdf.close()
        finally:
            self.fh.close()


def stream_log(path, channels: ChannelMap | str | Path | None = None, format: str | None = None,
               params: VehicleParams | None = None, chunk_rows: int = CHUNK_ROWS) -> Iterator[Log]:
    """Read a log as consecutive chunks (bounded memory for Parquet and MDF4).

    Parameters
    ----------
    path, channels, format, params
        As for :func:`~roadbank.io.load_log`.
    chunk_rows : int
        Rows per Parquet record batch, samples per MDF4 channel read.

    Yields
    ------
    Log
        Chunks in time order: ``signals`` (SI, ISO 8855) continuing the previous
        chunk's, ``reference_roll``, ``truth``, ``extra`` (``lat_deg``/``lon_deg``)
        on the chunk's time stamps. ``warnings`` are given once, on the first chunk.

    Raises
    ------
    LogError
        As :func:`~roadbank.io.load_log`, when the bad part is reached.
    """
    p = Path(path)
    fmt = (format or readers.detect_format(p)).lower()
    cmap = channels if isinstance(channels, ChannelMap) else (
        read_channel_map(channels) if channels is not None else None)
    if fmt not in STREAMED or (fmt == "mdf4" and cmap is not None and cmap.dbc is not None):
        yield load_log(p, channels=cmap, format=fmt, params=params)
        return
    if int(chunk_rows) < 2:
        raise ValueError("chunk_rows must be >= 2")
    if not p.exists():
        raise LogError(f"{p}: file not found")
    cmap = cmap or default_channel_map()
    params = params or VehicleParams()
    if fmt == "parquet":
        yield from _stream_table(p, cmap, params, int(chunk_rows))
    else:
        yield from _stream_mdf4(p, cmap, params, int(chunk_rows))


def _chunk_log(p, fmt, cmap, params, roles, vals, meta, warns, truth=None) -> Log:
    delta = steering_delta_f(cmap, params, roles, vals)
    try:
        sig = Signals(vals["t"], vals["speed"], vals["lateral_acceleration"], vals["yaw_rate"], delta)
    except ValueError as exc:
        raise LogError(f"{p}: {exc}") from None
    pos = {r: vals[r] for r in gnss_roles(cmap) if r in vals}
    extra = gnss_extra(p, cmap, pos) if pos else {}
    return Log(signals=sig, reference_roll=vals.get("reference_roll"), source=p, format=fmt, metadata=meta,
               truth=truth or {}, warnings=list(dict.fromkeys(warns)), channel_map=cmap, extra=extra)


def _convert(p, cmap, role, raw_values, t, first: bool, warns: list) -> np.ndarray:
    spec = cmap.channels[role]
    v = cmap.to_si_iso(role, raw_values)
    if role in ("latitude", "longitude", "ecef_x", "ecef_y", "ecef_z"):
        return v
    w = check_plausible(p, role, spec.column, spec.unit, t, v)
    if first:
        warns += w
    return v


def _stream_table(p, cmap, params, chunk_rows):
    names, meta = _schema(p, "parquet")
    if "time" not in cmap.channels:
        raise LogError(f"{cmap.source}: channel map has no 'time' channel (required for parquet)")
    have = set(names)
    roles = select_roles(p, cmap, have, names)
    gnss = gnss_roles(cmap)
    for r in gnss + ["time"]:
        if cmap.channels[r].column not in have:
            raise missing_column(p, r, cmap.channels[r].column, names)
    wanted = {cmap.channels[r].column: r for r in ["time"] + roles + gnss}
    truth_cols = [c for c in names if cmap.truth_prefix and c.startswith(cmap.truth_prefix) and c not in wanted]
    tcol = cmap.channels["time"].column
    labels = {c: f"channel '{r}' (column '{c}')" for c, r in wanted.items()}
    rs = None            # StreamResampler, or False when the table clock is used
    pending: list[str] = []      # warnings, given with the first chunk yielded
    finite = dict.fromkeys(roles, False)
    n_out = 0
    fix = ChunkRepair(p, tcol, "time", "row")
    flag_cols = [cmap.channels[r].column for r in roles if r in FLAGGED_ROLES]
    for row0, cols, last in _final_empty(_parquet_chunks(p, list(wanted) + truth_cols, labels, chunk_rows),
                                         list(wanted) + truth_cols):
        t, cols, flagged, w = fix.feed(cmap.to_si_iso("time", cols[tcol]), cols, row0, last)
        if not len(t):
            continue
        later = []
        (pending if n_out == 0 else later).extend(w)
        for c in flag_cols:
            cols[c][flagged] = np.nan
        if rs is None:
            check_plausible(p, "time", tcol, cmap.channels["time"].unit, None, t)
        vals = {r: _convert(p, cmap, r, cols[cmap.channels[r].column], t, rs is None, pending)
                for r in roles + gnss}
        for r in roles:
            finite[r] = finite[r] or bool(np.isfinite(vals[r]).any())
        if rs is None:
            if cmap.time_base == "auto" and _same_rate(t, vals, roles):
                rs = False
            else:
                rs = StreamResampler(roles, {r: GNSS_MAX_GAP_S for r in gnss},
                                     "uniform" if cmap.time_base == "auto" else cmap.time_base,
                                     cmap.rate_hz, cmap.max_gap_s)
        if rs is False:            # the table clock: values as they are (like load_log)
            out = dict(vals, t=t)
            for r in gnss:
                out[r] = interpolate(t, vals[r], t, GNSS_MAX_GAP_S)
            truth = {c: cols[c] for c in truth_cols}
        else:
            for r in roles + gnss:
                rs.add(r, t, vals[r])
            try:
                out, truth = rs.emit(), {}
            except LogError as exc:
                raise LogError(f"{p}: {exc}") from None
        if out is not None and len(out["t"]):
            log = _chunk_log(p, "parquet", cmap, params, roles, out, meta, later if n_out else pending, truth)
            log.time_repairs, fix.counts = fix.counts, {}
            if n_out == 0:
                log.warnings += check_consistency(log.signals, p, {r: cmap.channels[r].column for r in roles[:3]})
            n_out += 1
            yield log
        else:
            pending += later
    for r in roles:
        if not finite[r]:
            raise channel_error(p, r, cmap.channels[r].column, "no finite values")
    if rs:
        for r in roles + gnss:
            rs.finish(r)
        try:
            out = rs.emit()
        except LogError as exc:
            raise LogError(f"{p}: {exc}") from None
        if out is not None and len(out["t"]):
            n_out += 1
            log = _chunk_log(p, "parquet", cmap, params, roles, out, meta, [] if n_out > 1 else pending)
            log.time_repairs, fix.counts = fix.counts, {}
            yield log
    if n_out == 0:
        raise LogError(f"{p}: fewer than 2 samples on the common time base")


def _same_rate(t, vals, roles) -> bool:
    """``time_base = "auto"`` rule of :func:`~roadbank.io.resample.common_time_base` on one chunk."""
    if len(t) < 2:
        return False
    base = float(np.median(np.diff(t)))
    for r in roles:
        tc, _ = clean_series(t, vals[r])
        d = np.diff(tc)
        if not len(d) or abs(float(np.median(d)) - base) > 0.01 * base:
            return False
    return True


def _add_repaired(rs, r, t, raw_v, flagged, p, cmap, first, warns) -> None:
    """One MDF4 channel window, its stamps repaired, into the resampler (flagged samples as gaps)."""
    if not len(t):
        return
    v = _convert(p, cmap, r, raw_v, t, first, warns)
    if r in FLAGGED_ROLES:
        v[flagged] = np.nan
    rs.add(r, t, v)


def _stream_mdf4(p, cmap, params, chunk_rows):
    src = _Mdf4Channels(p, chunk_rows)
    try:
        have = set(src.names)
        roles = select_roles(p, cmap, have, src.names)
        gnss = gnss_roles(cmap)
        for r in gnss:
            if cmap.channels[r].column not in have:
                raise channel_error(p, r, cmap.channels[r].column, "channel not found in the file "
                                    f"(it has: {', '.join(src.names) or 'nothing'})")
        names = roles + gnss
        for r in names:
            src.want(r, cmap.channels[r].column, f"channel '{r}' (column '{cmap.channels[r].column}')")
        tb = "uniform" if cmap.time_base == "auto" else cmap.time_base
        rs = StreamResampler(roles, {r: GNSS_MAX_GAP_S for r in gnss}, tb, cmap.rate_hz, cmap.max_gap_s)
        last_t = {r: None for r in names}
        fixes = {r: ChunkRepair(p, cmap.channels[r].column, r, "sample") for r in names}
        row = dict.fromkeys(names, 0)
        first = True
        pending: list[str] = []
        meta = {}
        comment = getattr(getattr(src.mdf, "header", None), "comment", None)
        if comment:
            meta["comment"] = str(comment)
        while True:
            active = [r for r in names if not rs.done[r]]
            if not active:
                break
            # read the channel that lags most, so no buffer runs far ahead of the others
            r = min(active, key=lambda k: -np.inf if last_t[k] is None else last_t[k])
            spec = cmap.channels[r]
            got = src.read(r)
            if got is None:
                if last_t[r] is None and r in roles:
                    raise channel_error(p, r, spec.column, "no samples")
                if fixes[r].holding:
                    t, v, flagged, w = fixes[r].feed(np.zeros(0), {"v": np.zeros(0)}, row[r], True)
                    pending += w
                    _add_repaired(rs, r, t, v["v"], flagged, p, cmap, first, pending)
                rs.finish(r)
            else:
                t, raw_v = got
                t, v, flagged, w = fixes[r].feed(t, {"v": np.asarray(raw_v, dtype=np.float64)}, row[r], False)
                row[r] += len(raw_v)
                pending += w
                _add_repaired(rs, r, t, v["v"], flagged, p, cmap, first, pending)
                last_t[r] = got[0][-1]
            try:
                out = rs.emit()
            except LogError as exc:
                raise LogError(f"{p}: {exc}") from None
            if out is not None and len(out["t"]):
                log = _chunk_log(p, "mdf4", cmap, params, roles, out, meta, pending if first else [])
                log.time_repairs = {}
                for k in roles:
                    log.time_repairs = add_counts(log.time_repairs, fixes[k].counts)
                    fixes[k].counts = {}
                if first:
                    log.warnings += check_consistency(log.signals, p, {k: cmap.channels[k].column
                                                                       for k in roles[:3]})
                first = False
                yield log
        if first:
            raise LogError(f"{p}: fewer than 2 samples on the common time base")
    finally:
        src.close()


class ReadAhead:
    """The chunks of a streamed log (iterate over it), with the signals of the chunks after the
    current one on demand: what an offline estimator takes as ``lookahead``
    (:meth:`roadbank.estimators.Estimator.run`). Holds the current chunk and the ones asked for."""

    def __init__(self, chunks: Iterable[Log]):
        self._it = iter(chunks)
        self._ahead: deque[Log] = deque()
        self._end = -np.inf

    def __iter__(self) -> "ReadAhead":
        return self

    def __next__(self) -> Log:
        chunk = self._ahead.popleft() if self._ahead else next(self._it)
        self._end = float(chunk.signals.t[-1])
        return chunk

    def leading(self, current: Signals, seconds: float) -> Signals:
        """``current`` (the current chunk's signals) and the chunks after it, as many as reach
        ``seconds`` (s) past its first sample: the same span of the log whatever the chunk size."""
        rest = seconds - float(current.t[-1] - current.t[0])
        nxt = self.following(rest) if rest > 0 else None
        return current if nxt is None else concat_signals([current, nxt])

    def following(self, seconds: float) -> Signals | None:
        """Signals of the chunks after the current one, as many as reach ``seconds`` (s) past its
        last sample (all that remain when fewer do); None at the log's end."""
        while not self._ahead or self._ahead[-1].signals.t[-1] < self._end + seconds:
            nxt = next(self._it, None)
            if nxt is None:
                break
            self._ahead.append(nxt)
        if not self._ahead:
            return None
        return concat_signals(c.signals for c in self._ahead)

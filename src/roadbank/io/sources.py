"""Sources: a log file as chunks of raw channels, in the file's own units, for the assembler.

A source knows a file format, not physics. Opening one reads what the format says about itself
(the column / channel names, file metadata, warnings of the decoder); :meth:`chunks` then gives
:class:`~roadbank.io.types.RawChunk` s in file order:

* **table sources** (CSV, Parquet, KITTI raw drives): every chunk holds the same columns, row for row
  with the table's time column; the final chunk has ``last`` set (an empty one after Parquet's
  record batches);
* **channel sources** (MDF4, raw CAN, ROS, comma2k19 segments): every channel has its own clock; a
  chunk holds some channels, each with its stamps, and names in ``done`` the channels that have no
  more samples.

Every source has ``path``, ``names`` (the columns), ``metadata``, ``warnings``, ``row_label``,
``shared_clock`` (a table), ``whole`` (read in one chunk) and ``carried``: channels the source derives
itself (column -> the longest gap, s, interpolated across), which go into :attr:`Log.extra` as they
are, and ``time_typed``: the columns whose type carries its own time unit
(:attr:`~roadbank.io.types.RawTable.time_typed`: Arrow timestamps and durations; empty for the other
formats), and ``units``: the units the file states for its columns (a CSV's units row, an MDF4 channel's unit:
:attr:`~roadbank.io.types.RawTable.units`; empty for the other formats). The data sets with a fixed layout
(:mod:`roadbank.io.kitti`, :mod:`roadbank.io.comma2k19`) also bring their ``channel_map``: which column is which
channel, in which unit and sign convention.

Read whole (``chunk_rows=None``) a source gives one chunk: the whole file (the readers of
:mod:`roadbank.io.readers`, :mod:`roadbank.io.can`, :mod:`roadbank.io.ros`). Streamed, Parquet is read
in record batches, MDF4 in windows of records per channel group, a KITTI drive in frames and a CSV file in
blocks of lines (:class:`~roadbank.io.csvtable.CsvLines`; one separated by ``;`` or tabs, not UTF-8 or short is
read whole), so memory stays bounded by the chunk size; the other formats are read whole either way.

An MDF4 source whose channels to read all lie in one channel group shares that group's time stamps: asked by
:meth:`~WholeSource.one_clock` (the assembler asks, knowing which channels it reads), it gives them from then on as a
table, row for row with those stamps under the column :data:`GROUP_CLOCK`, as a logger's raster holds them: the
assembler reads it as it reads a CSV or Parquet table (its clock kept where ``time_base = "auto"`` finds every
channel at its rate), nothing interpolated.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..params import VehicleParams
from . import readers
from .channels import ChannelMap
from .comma2k19 import SegmentSource
from .csvtable import CsvLines
from .errors import LogError
from .fields import column_label, unique_names
from .files import open_mdf
from .formats import CAN_FORMATS, ROS_FORMATS
from .kitti import DriveSource
from .types import GROUP_CLOCK, RawChunk, RawTable


class WholeSource:
    """A file read whole by its reader: one :class:`RawChunk` (a table, or channels with clocks)."""

    def __init__(self, path: Path, table: RawTable, warnings=(), shared_clock: bool = True):
        self.path = path
        self.table = table
        self.names = list(table.names)
        self.metadata = dict(table.metadata)
        self.row_label = table.row_label
        self.warnings = list(table.warnings) + list(warnings)
        self.shared_clock = shared_clock
        self.whole = True
        self.carried: dict[str, float] = {}
        self.time_typed = dict(table.time_typed)
        self.units = dict(table.units)

    def one_clock(self, wanted: dict[str, str]) -> bool:
        """Whether the channels of ``wanted`` (column -> role) all come from one MDF4 channel group; if so the source
        gives them from now on as a table on the group's stamps (column :data:`GROUP_CLOCK`, s), values as read.
        False (nothing changed) for a table, for channels of several groups and for the other channel formats."""
        groups = {self.table.groups.get(c) for c in wanted}
        if self.shared_clock or len(groups) != 1 or None in groups:
            return False
        tab = self.table
        cols = {GROUP_CLOCK: tab.times[next(iter(wanted))], **{c: tab.data[c] for c in wanted}}
        self.table = RawTable(tab.names, cols, metadata=tab.metadata, row_label=tab.row_label, units=tab.units)
        self.shared_clock = True
        return True

    def close(self) -> None:
        """Nothing to close: the file was read when the source was opened."""

    def chunks(self, wanted: dict[str, str], prefix: str | None = None) -> Iterator[RawChunk]:
        """The one chunk (the columns were chosen when the file was read)."""
        tab = self.table
        if self.shared_clock:
            n = len(next(iter(tab.data.values()))) if tab.data else 0
            rows = tab.rownums
            if rows is None or isinstance(rows, range):
                rows = np.arange(n) if rows is None else np.arange(rows.start, rows.stop, rows.step)
            yield RawChunk(dict(tab.data), rownums=rows, last=True)
        else:
            yield RawChunk(dict(tab.data), times=dict(tab.times), done=tuple(tab.data))


class ParquetBatches:
    """A Parquet file in record batches of ``chunk_rows`` rows (pyarrow ``iter_batches``)."""

    shared_clock = True
    row_label = "row"
    whole = False
    carried: dict[str, float] = {}

    def __init__(self, path: Path, chunk_rows: int):
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.path, self.chunk_rows = path, chunk_rows
        self.warnings: list[str] = []
        try:
            pf = pq.ParquetFile(path)
        except (pa.ArrowException, OSError, ValueError) as exc:
            raise LogError(f"{path}: not a readable Parquet file (truncated or corrupt?): {exc}") from None
        if pf.metadata.num_rows == 0:
            raise LogError(f"{path}: no data rows")
        self.names = list(pf.schema_arrow.names)
        unique_names(path, self.names, "in the schema")
        self.metadata = readers.parquet_metadata(pf.schema_arrow)
        self.time_typed = readers.time_typed(pf.schema_arrow)
        self.units: dict[str, str] = {}      # a Parquet schema states no unit roadbank reads

    def close(self) -> None:
        """Nothing to close: each pass opens the file for itself."""

    def chunks(self, wanted: dict[str, str], prefix: str | None = None) -> Iterator[RawChunk]:
        """The batches of the columns in ``wanted`` (column -> role, for messages) or starting with
        ``prefix``, then an empty final chunk."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        p = self.path
        cols = [c for c in self.names if c in wanted or (prefix and c.startswith(prefix))]
        row0 = 0
        try:
            # no pre-buffering, one thread: 5x faster here and ~60 MB less than pyarrow's defaults on a 24 h file
            pf = pq.ParquetFile(p, pre_buffer=False)
            for b in pf.iter_batches(batch_size=self.chunk_rows, columns=cols, use_threads=False):
                data = {c: readers.arrow_column_floats(p, c, column_label(wanted, c), b.column(c), row0,
                                                       flag=c not in wanted) for c in cols}
                yield RawChunk(data, rownums=np.arange(row0, row0 + b.num_rows))
                row0 += b.num_rows
        except (pa.ArrowException, OSError) as exc:
            raise LogError(f"{p}: not a readable Parquet file (truncated or corrupt?): {exc}") from None
        yield RawChunk({c: np.zeros(0) for c in cols}, rownums=np.zeros(0, dtype=np.int64), last=True)


class Mdf4Windows:
    """MDF4 channels read window by window: ``chunk_rows`` records of a channel group at a
    time (asammdf ``select`` with ``record_offset``/``record_count``), every wanted channel
    of that group from one pass over its data, each with its master time stamps. The channel
    that lags most is read next, so no channel runs far ahead of the others.

    One window of one group is in memory at a time: a per-channel ``iter_get`` keeps
    one data block (4 MiB as asammdf writes them) and one read buffer alive per
    channel (about 6.5 MiB each). Channels of the group not asked for yet wait as
    converted arrays (one window each).

    Where the channels to read all lie in one channel group (:meth:`one_clock`), they are given as a table
    instead: one window of the group a chunk, every channel from one pass over its data, row for row with
    the group's stamps.

    The file is opened as a Python file object rather than by name: asammdf then reads
    with ``read()`` instead of memory-mapping the file, whose touched pages would
    otherwise count in the process's resident memory as the log is read (page cache,
    reclaimable, but a 24 h log would show 400 MB more).
    """

    shared_clock = False
    whole = False
    carried: dict[str, float] = {}
    time_typed: dict[str, str] = {}      # MDF4 masters are seconds: no channel's type carries a time unit

    def __init__(self, path: Path, chunk_rows: int):
        self.path = path
        self.warnings: list[str] = []
        self.fh = open(path, "rb")
        try:
            self.mdf = open_mdf(path, self.fh)
        except LogError:
            self.fh.close()
            raise
        self.names = [n for n in self.mdf.channels_db if n not in ("time", "t")]
        self.units = readers.mdf_units(self.mdf, self.names)
        self.chunk = max(1, int(chunk_rows))
        rec = max((int(g.channel_group.samples_byte_nr) + int(getattr(g.channel_group, "invalidation_bytes_nr", 0))
                   for g in self.mdf.groups), default=8)        # (MDF 3 has no invalidation bytes)
        self.mdf.configure(read_fragment_size=self.chunk * max(rec, 8))   # read buffer: one window
        self.metadata = {}
        comment = getattr(getattr(self.mdf, "header", None), "comment", None)
        if comment:
            self.metadata["comment"] = str(comment)
        self.wanted: dict = {}       # column -> (group, index, label)
        self.offset: dict = {}       # group -> next record to read
        self.waiting: dict = {}      # column -> [(t, v)] read along with another channel of its group
        self.row_label = "sample"
        self.clocked: list[str] = []  # the columns given as a table on their group's stamps (one_clock)

    def one_clock(self, wanted: dict[str, str]) -> bool:
        """Whether the channels of ``wanted`` (column -> role) all lie in one channel group; if so :meth:`chunks`
        gives them from now on as a table on the group's stamps (column :data:`GROUP_CLOCK`, s). LogError naming a
        channel that is not in the file or in several groups."""
        groups = set()
        for c in wanted:
            self._want(c, column_label(wanted, c))
            groups.add(self.wanted[c][0])
        if len(groups) != 1:
            return False
        self.shared_clock = True
        self.clocked = list(wanted)
        return True

    def _table_chunks(self) -> Iterator[RawChunk]:
        """The :meth:`one_clock` columns a window of their group at a time, with the group's stamps, from its first
        record (each call: a first pass decides ``time_base = "auto"``); then an empty final chunk."""
        cols = self.clocked
        group = self.wanted[cols[0]][0]
        n = int(self.mdf.groups[group].channel_group.cycles_nr)
        for start in range(0, n, self.chunk):
            try:
                sigs = self.mdf.select([(None, group, self.wanted[c][1]) for c in cols], record_offset=start,
                                       record_count=self.chunk, copy_master=False)
            except Exception as exc:
                raise LogError(f"{self.path}: {self.wanted[cols[0]][2]}: cannot read (truncated or corrupt?): "
                               f"{exc}") from None
            t = np.asarray(sigs[0].timestamps, dtype=np.float64)
            data = {c: readers.mdf_signal_floats(self.path, c, self.wanted[c][2], sig, start)
                    for c, sig in zip(cols, sigs)}
            yield RawChunk({GROUP_CLOCK: t, **data}, rownums=np.arange(start, start + len(t)))
        yield RawChunk({GROUP_CLOCK: np.zeros(0), **{c: np.zeros(0) for c in cols}},
                       rownums=np.zeros(0, dtype=np.int64), last=True)

    def _want(self, name: str, label: str) -> None:
        group, index = readers.mdf_place(self.mdf, self.path, name, label)
        self.wanted[name] = (group, index, label)
        self.offset.setdefault(group, 0)

    def _read(self, name):
        """Next window of channel ``name``: (t, v), or None when exhausted."""
        queue = self.waiting.get(name)
        if queue:
            return queue.pop(0)
        group, _, label = self.wanted[name]
        start = self.offset[group]
        if start >= int(self.mdf.groups[group].channel_group.cycles_nr):
            return None
        keys = [k for k, w in self.wanted.items() if w[0] == group]
        try:
            sigs = self.mdf.select([(None, group, self.wanted[k][1]) for k in keys], record_offset=start,
                                   record_count=self.chunk, copy_master=False)
        except Exception as exc:
            raise LogError(f"{self.path}: {label}: cannot read (truncated or corrupt?): {exc}") from None
        self.offset[group] = start + self.chunk
        got = None
        for k, sig in zip(keys, sigs):
            tv = (np.asarray(sig.timestamps, dtype=np.float64),
                  readers.mdf_signal_floats(self.path, k, self.wanted[k][2], sig, start))
            if k == name:
                got = tv
            else:
                self.waiting.setdefault(k, []).append(tv)
        return got

    def chunks(self, wanted: dict[str, str], prefix: str | None = None) -> Iterator[RawChunk]:
        """The channels of ``wanted`` (column -> role, for messages), one window of one channel a chunk
        (``prefix`` is not used: truth channels go with tables only); the :meth:`one_clock` table where it is one."""
        if self.shared_clock:
            yield from self._table_chunks()
            return
        for c in wanted:
            self._want(c, column_label(wanted, c))
        last_t: dict[str, float | None] = dict.fromkeys(wanted)
        active = list(wanted)
        while active:
            # read the channel that lags most, so no buffer runs far ahead of the others
            c = min(active, key=lambda k: -np.inf if (lt := last_t[k]) is None else lt)
            got = self._read(c)
            if got is None:
                active.remove(c)
                yield RawChunk({}, done=(c,))
            else:
                last_t[c] = got[0][-1]
                yield RawChunk({c: got[1]}, times={c: got[0]})

    def close(self) -> None:
        """Close the file."""
        try:
            self.mdf.close()
        finally:
            self.fh.close()


def open_layout(p: Path, fmt: str, params: VehicleParams, chunk_rows: int | None = None):
    """The source of a data set with a fixed layout (``fmt``: "kitti-oxts" or "comma2k19"), read whole
    (``chunk_rows=None``) or streamed (a KITTI drive, ``chunk_rows`` frames a chunk); its
    ``channel_map`` is the layout's. ``params`` supplies comma2k19's steering ratio."""
    if fmt == "kitti-oxts":
        return DriveSource(p, chunk_rows)
    return SegmentSource(p, params)


def open_source(p: Path, fmt: str, cmap: ChannelMap, chunk_rows: int | None = None):
    """The source of file ``p`` in format ``fmt`` (CSV, Parquet, MDF4, raw CAN, ROS), read whole
    (``chunk_rows=None``) or streamed (Parquet, MDF4 without a DBC, CSV where :meth:`CsvLines.open` can) in chunks
    of ``chunk_rows``."""
    if fmt in CAN_FORMATS:
        from .can import read_can
        table, warns = read_can(p, cmap, fmt)
        return WholeSource(p, table, warns, shared_clock=False)
    if fmt in ROS_FORMATS:
        from .ros import read_ros
        table, warns = read_ros(p, cmap, fmt)
        return WholeSource(p, table, warns, shared_clock=False)
    if chunk_rows is not None and fmt == "parquet":
        return ParquetBatches(p, chunk_rows)
    if chunk_rows is not None and fmt == "mdf4":
        return Mdf4Windows(p, chunk_rows)
    wanted = {spec.column: role for role, spec in cmap.channels.items()}
    lines = CsvLines.open(p, chunk_rows, wanted, cmap.truth_prefix) if chunk_rows is not None and fmt == "csv" else None
    if lines is not None:
        return lines
    return WholeSource(p, readers.READERS[fmt](p, wanted, cmap.truth_prefix), shared_clock=fmt != "mdf4")

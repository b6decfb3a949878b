"""Long logs in bounded memory: :func:`stream_log` yields a log as consecutive chunks.

Parquet files are read in record batches, MDF4 files in windows of ``chunk_rows``
records per channel group, KITTI drives ``chunk_rows`` frames and CSV files ``chunk_rows`` lines at a time
(:mod:`roadbank.io.sources`), so memory stays bounded by the chunk size whatever the log's
length. Other formats (raw CAN, ROS bags, comma2k19 segments), and CSV files that
:class:`~roadbank.io.csvtable.CsvLines` does not stream (separated by ``;`` or tabs, not UTF-8, short), are read
whole and go through the same assembler in one chunk.

Each chunk is a :class:`~roadbank.io.Log` whose signals continue the previous chunk's;
feeding them to ``Estimator.run(chunk.signals, reset=False)`` gives the same numbers as
one run over :func:`~roadbank.io.load_log`'s result, which is the same stream read in one
chunk: one source and one assembler (:mod:`roadbank.io.assemble`) serve both. The time base
follows :mod:`roadbank.io.resample`, computed incrementally by
:class:`~roadbank.io.resample.StreamResampler`: channels are buffered only until every channel
has passed a base time, then interpolated with the same gap rule and dropped.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from ..params import VehicleParams
from ..signals import Signals, concat_signals
from . import readers
from .assemble import assemble
from .channels import ChannelMap, default_channel_map, read_channel_map
from .errors import LogError
from .files import must_exist
from .formats import DATASET_FORMATS, FORMATS
from .mapchoice import choose_map
from .repair import HOLD_ROWS, ChunkRepair  # noqa: F401  (where streaming code looks for them)
from .resample import StreamResampler  # noqa: F401
from .sources import open_layout, open_source
from .types import Log

#: default rows per chunk (records per channel group for MDF4): 20 000 samples = 3.3 min at 100 Hz
#: (memory vs per-chunk overhead: each 10 000 rows cost about 3.5 MiB of peak memory, docs/io.md)
CHUNK_ROWS = 20_000
#: the formats read in chunks (the others are read whole, one chunk)
STREAMED = ("parquet", "mdf4", "kitti-oxts", "csv")


def log_chunks(path, channels: ChannelMap | str | Path | None = None, format: str | None = None,
               params: VehicleParams | None = None, chunk_rows: int | None = CHUNK_ROWS) -> Iterator[Log]:
    """The chunks of one log: its source (:func:`~roadbank.io.sources.open_source`) through the
    assembler (:func:`~roadbank.io.assemble.assemble`); ``chunk_rows=None`` reads it in one chunk.
    Arguments as :func:`stream_log`; comma2k19 segments and KITTI drives (fixed layouts) bring
    their own channel map (``channels`` is not used). Without ``channels`` a table log is read with the map
    :func:`~roadbank.io.mapchoice.choose_map` chooses (the default map, or the one guessed from its columns), the same
    whatever ``chunk_rows``."""
    p = must_exist(path)              # before a format is guessed from a suffix it may not have
    fmt = (format or readers.detect_format(p)).lower()
    if fmt not in FORMATS:
        raise LogError(f"{p}: unknown format '{fmt}' (known: {', '.join(FORMATS)})")
    params = params or VehicleParams()
    rows = chunk_rows if fmt in STREAMED else None
    note = []
    if fmt in DATASET_FORMATS:
        src = open_layout(p, fmt, params, rows)
        cmap = src.channel_map
        if channels is not None:          # said, not passed over: the user may think it applies
            note = [f"{p}: the channel map is not used: a {fmt} log is read with its format's own channels, units "
                    "and axes"]
    else:
        cmap = channels if isinstance(channels, ChannelMap) else (
            read_channel_map(channels) if channels is not None else default_channel_map())
        if fmt == "mdf4" and cmap.dbc is not None:
            fmt = "mdf4-can"                  # an MDF4 file with a DBC: bus logging
        src = open_source(p, fmt, cmap, rows)
        if channels is None:                  # no map given: the default's columns, or the guessed map's
            try:
                chosen, note = choose_map(src, fmt, cmap)
            except BaseException:
                src.close()
                raise
            if chosen is not None:
                src.close()
                cmap = chosen
                src = open_source(p, fmt, cmap, rows)
    try:
        for log in assemble(src, cmap, params, fmt):
            log.warnings, note = note + log.warnings, []
            yield log
    finally:
        src.close()


def stream_log(path, channels: ChannelMap | str | Path | None = None, format: str | None = None,
               params: VehicleParams | None = None, chunk_rows: int = CHUNK_ROWS) -> Iterator[Log]:
    """Read a log as consecutive chunks (bounded memory for Parquet, MDF4 and KITTI drives).

    Parameters
    ----------
    path, channels, format, params
        As for :func:`~roadbank.io.load_log`.
    chunk_rows : int
        Rows per Parquet record batch, samples per MDF4 channel read, frames per KITTI chunk.

    Yields
    ------
    Log
        Chunks in time order: ``signals`` (SI, ISO 8855) continuing the previous
        chunk's, ``reference_roll``, ``truth``, ``extra`` (``lat_deg``/``lon_deg``)
        on the chunk's time stamps, ``time_repairs`` of the chunk's samples (added up
        over the chunks: the whole log's). ``warnings`` are given with the chunk read
        when they were found.

    Raises
    ------
    LogError
        As :func:`~roadbank.io.load_log`, when the bad part is reached.
    """
    fmt = (format or readers.detect_format(Path(path))).lower()
    if fmt in STREAMED and int(chunk_rows) < 2:
        raise ValueError("chunk_rows must be >= 2")
    yield from log_chunks(path, channels, format, params, int(chunk_rows))


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

    def leading(self, current: Signals, seconds: float, enough: Callable[[Signals], bool] | None = None) -> Signals:
        """``current`` (the current chunk's signals) and the chunks after it, as many as reach
        ``seconds`` (s) past its first sample, or fewer: as soon as ``enough(span)`` is true of the
        signals gathered so far. A rule that reads only the span's start (its first ``seconds``, or
        up to where ``enough`` says it has all it needs) sees the same samples whatever the chunk size."""
        def span() -> Signals:
            return current if not self._ahead else concat_signals([current, *(c.signals for c in self._ahead)])

        while True:
            last = float(self._ahead[-1].signals.t[-1] if self._ahead else current.t[-1])
            if last - float(current.t[0]) >= seconds or (enough is not None and enough(span())):
                break
            chunk = next(self._it, None)
            if chunk is None:
                break
            self._ahead.append(chunk)
        return span()

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

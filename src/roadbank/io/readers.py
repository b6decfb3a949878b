"""File readers: CSV (:mod:`roadbank.io.csvtable`), Parquet and MDF4 -> raw numeric columns; a log's format.

A reader knows file formats, not physics: it returns the requested columns as
float64 arrays (missing values as NaN) in the file's own units, and reports
anything it cannot read as a :class:`~roadbank.io.errors.LogError` naming the
file, the column and the line/row.
"""

from __future__ import annotations

import math

import numpy as np

from .csvtable import CsvLines, read_csv, time_text
from .errors import LogError
from .fields import column_label, not_numbers, parse_floats, unique_names
from .files import existing_nonempty, must_exist, open_mdf
from .formats import CAN_FORMATS as CAN_FORMATS
from .formats import FORMATS, SUFFIXES
from .formats import ROS_FORMATS as ROS_FORMATS
from .kitti import broken_drive, find_oxts_dirs
from .types import RawTable


def detect_format(path) -> str:
    """Format of ``path`` from its suffix (or a comma2k19 segment / KITTI raw drive directory); a path that
    does not exist is a :class:`LogError` saying so (:func:`~roadbank.io.files.not_found`)."""
    p = must_exist(path)
    if p.is_dir():
        if (p / "processed_log").is_dir():
            return "comma2k19"
        if (p / "metadata.yaml").is_file():
            return "rosbag2"
        if find_oxts_dirs(p):
            return "kitti-oxts"
        broken = broken_drive(p)
        if broken:              # a KITTI drive short of a file: said so
            raise LogError(broken)
        raise LogError(f"{p}: a directory, but neither a comma2k19 segment (no processed_log/) "
                       "nor a KITTI raw drive (no oxts/timestamps.txt)")
    fmt = SUFFIXES.get(p.suffix.lower())
    if fmt == "mcap" and (p.parent / "metadata.yaml").is_file():
        fmt = "rosbag2"
    if fmt is None:
        raise LogError(f"{p}: cannot tell the format from the suffix '{p.suffix}' "
                       f"(use --format, one of {', '.join(FORMATS)})")
    return fmt


def read_parquet(path, wanted: dict[str, str], prefix: str | None = None) -> RawTable:
    """Read a Parquet file (pyarrow); schema metadata become :attr:`RawTable.metadata`."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    p = existing_nonempty(path)
    try:
        pf = pq.ParquetFile(p)
        schema = pf.schema_arrow
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise LogError(f"{p}: not a readable Parquet file (truncated or corrupt?): {exc}") from None
    names = list(schema.names)
    unique_names(p, names, "in the schema")
    cols = [c for c in names if c in wanted or (prefix and c.startswith(prefix))]
    try:
        table = pf.read(columns=cols)
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise LogError(f"{p}: not a readable Parquet file (truncated or corrupt?): {exc}") from None
    if table.num_rows == 0:
        raise LogError(f"{p}: no data rows")
    data = {c: arrow_column_floats(p, c, column_label(wanted, c), table.column(c), flag=c not in wanted)
            for c in cols}
    return RawTable(names, data, metadata=parquet_metadata(schema), row_label="row",
                    rownums=range(table.num_rows), time_typed=time_typed(schema))


def time_typed(schema) -> dict[str, str]:
    """The columns of an Arrow ``schema`` whose type carries its own time unit (``timestamp``, ``duration``;
    read as s, :func:`arrow_column_floats`): column -> type, e.g. ``"timestamp[us]"``."""
    import pyarrow as pa

    return {f.name: str(f.type) for f in schema if pa.types.is_timestamp(f.type) or pa.types.is_duration(f.type)}


def parquet_metadata(schema) -> dict[str, str]:
    """Schema key/value metadata of a Parquet file as text (pyarrow's own schema entry left out)."""
    meta = {}
    for k, v in (schema.metadata or {}).items():
        key = k.decode("utf-8", "replace")
        if key != "ARROW:schema":
            meta[key] = v.decode("utf-8", "replace")
    return meta


def _to_float_numpy(col) -> np.ndarray:
    """Arrow (chunked) array -> writable float64 numpy array, nulls as NaN (without pyarrow's pandas path).

    Integers beyond 2^53 (an int64 epoch in ns) are rounded to the nearest float64, not refused."""
    import pyarrow as pa
    import pyarrow.compute as pc

    arr = pc.cast(col, pa.float64(), safe=not pa.types.is_integer(col.type))
    if isinstance(arr, pa.ChunkedArray):
        arr = arr.combine_chunks()
    if arr.null_count:
        arr = pc.fill_null(arr, math.nan)
    # read the data buffer directly: Array.to_numpy() imports pandas (0.4 s, ~60 MB) on first use
    return np.frombuffer(arr.buffers()[1], dtype=np.float64, count=len(arr), offset=arr.offset * 8).copy()


#: ticks per second of an Arrow time unit
_TICKS_PER_S = {"s": 1, "ms": 10**3, "us": 10**6, "ns": 10**9}


def _arrow_seconds(col) -> np.ndarray:
    """An Arrow ``timestamp`` (any unit, any time zone: stored as UTC ticks since the epoch) or ``duration``
    column -> float64 seconds (since the epoch / of the duration), nulls as NaN.

    The int64 ticks are split into whole seconds and the rest before converting, so an epoch in ns
    (about 1.7e18 > 2^53) gives the float64 nearest the true seconds."""
    import pyarrow as pa
    import pyarrow.compute as pc

    per = _TICKS_PER_S[col.type.unit]
    ticks = pc.cast(col, pa.int64())            # the column's own unit, no scaling
    if isinstance(ticks, pa.ChunkedArray):
        ticks = ticks.combine_chunks()
    if len(ticks) == 0:
        return np.zeros(0)
    filled = pc.fill_null(ticks, 0) if ticks.null_count else ticks
    v = np.frombuffer(filled.buffers()[1], dtype=np.int64, count=len(filled), offset=filled.offset * 8)
    whole, rest = np.divmod(v, per)
    out = whole.astype(np.float64) + rest / per
    if ticks.null_count:
        out[_to_float_numpy(pc.is_null(ticks)) > 0] = math.nan
    return out


def arrow_column_floats(p, c: str, label: str, col, row0: int = 0, flag: bool = False) -> np.ndarray:
    """One Arrow column -> float64: numbers as they are; ``timestamp`` (any unit and time zone) -> s since the
    epoch; ``duration`` -> s; ``row0`` numbers rows in messages. A ``bool`` column is 0/1 when it is a ``flag``
    (a column no channel of the map names: truth, extras), else refused (:func:`not_numbers`)."""
    import pyarrow as pa

    t = col.type
    if pa.types.is_timestamp(t) or pa.types.is_duration(t):
        return _arrow_seconds(col)
    if pa.types.is_boolean(t) and not flag:
        raise not_numbers(p, label, f"Arrow type {t}")
    if pa.types.is_integer(t) or pa.types.is_floating(t) or pa.types.is_boolean(t) or pa.types.is_decimal(t):
        return _to_float_numpy(col)
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        values = col.to_pylist()
        first = next((v for v in values if v is not None and v.strip()), "")
        kind = time_text(first)
        if kind is not None:
            kinds = {"date-time": "date-times", "time of day": "times of day"}[kind]
            raise LogError(f"{p}: {label}: holds {kinds} as text ({first.strip()!r}, Arrow type {t}), which a Parquet "
                           "log stores as a timestamp column (pandas: df[col] = pd.to_datetime(df[col]), for a time of "
                           "day with its date); a CSV export of it is read as it is")
        return parse_floats(p, c, label, values, "row", range(row0, row0 + len(col)))
    raise LogError(f"{p}: {label}: unsupported column type {t} (need numbers, timestamp or duration)")


def read_mdf4(path, wanted: dict[str, str], prefix: str | None = None) -> RawTable:
    """Read channels of an ASAM MDF4 file (needs the optional ``asammdf``: ``pip install roadbank[mdf]``).

    Each MDF channel carries its own time stamps (its master channel, s), and its channel group is recorded
    (``groups``: the channels of one group share the group's stamps); the channel map's ``time`` entry is not used
    for MDF4.
    """
    p = existing_nonempty(path)
    mdf = open_mdf(p)
    try:
        names = [n for n in mdf.channels_db if n not in ("time", "t")] if hasattr(mdf, "channels_db") else []
        data, times, groups = {}, {}, {}
        units = mdf_units(mdf, names)
        for c in names:
            if c in wanted or (prefix and c.startswith(prefix)):
                groups[c] = mdf_place(mdf, p, c, column_label(wanted, c))[0]   # one group, as the streamed reader
                try:
                    sig = mdf.get(c, ignore_invalidation_bits=True)
                except Exception as exc:
                    raise LogError(f"{p}: {column_label(wanted, c)}: cannot read ({exc})") from None
                data[c] = mdf_signal_floats(p, c, column_label(wanted, c), sig)
                times[c] = np.asarray(sig.timestamps, dtype=np.float64)
                if len(data[c]) == 0:
                    raise LogError(f"{p}: {column_label(wanted, c)}: no samples")
        meta = {}
        comment = getattr(getattr(mdf, "header", None), "comment", None)
        if comment:
            meta["comment"] = str(comment)
    finally:
        mdf.close()
    return RawTable(names, data, times=times, metadata=meta, row_label="sample", rownums=None, units=units,
                    groups=groups)


def mdf_units(mdf, names: list[str]) -> dict[str, str]:
    """Channel -> the unit an open MDF file states for it (its channel block's, as written), for the channels of
    ``names`` held in one channel group (a name in several groups is read by none) with a unit; metadata only."""
    out = {}
    for n in names:
        where = mdf.channels_db.get(n, ())
        if len(where) == 1:
            group, index = where[0]
            unit = str(getattr(mdf.groups[group].channels[index], "unit", "") or "").strip()
            if unit:
                out[n] = unit
    return out


def mdf_place(mdf, p, c: str, label: str) -> tuple[int, int]:
    """``(group, index)`` of the channel ``c`` in the open MDF file ``mdf`` (of file ``p``); LogError naming it (its
    ``label``) where it is not in the file or in several channel groups (which one would be read is not said)."""
    where = mdf.channels_db.get(c, ())
    if len(where) != 1:
        what = "not in the file" if not where else f"in {len(where)} channel groups {sorted(g for g, _ in where)}"
        raise LogError(f"{p}: {label}: cannot read channel '{c}': it is {what}")
    group, index = where[0]
    return int(group), int(index)


def mdf_floats(p, c: str, label: str, samples, row0: int = 0) -> np.ndarray:
    """One MDF channel's samples -> float64; text samples parsed as numbers (LogError naming the
    sample, counted from ``row0``, for one that is not)."""
    s = np.asarray(samples)
    if s.dtype.kind not in "fiub":
        s = parse_floats(p, c, label, [x.decode() if isinstance(x, bytes) else x for x in s],
                          "sample", range(row0, row0 + len(s)))
    return np.asarray(s, dtype=np.float64)


def mdf_signal_floats(p, c: str, label: str, sig, row0: int = 0) -> np.ndarray:
    """An asammdf ``Signal`` of channel ``c`` read with its invalidation bits -> float64 (:func:`mdf_floats`), NaN
    where the file flags a sample invalid: a dropout, at its time stamp, as a whole read and a streamed one see it."""
    v = mdf_floats(p, c, label, sig.samples, row0)
    bits = getattr(sig, "invalidation_bits", None)
    if bits is None:
        return v
    bad = np.asarray(bits, dtype=bool)
    return np.where(bad, np.nan, v) if bad.any() else v


READERS = {"csv": read_csv, "parquet": read_parquet, "mdf4": read_mdf4}


def read_head(path, fmt: str, columns: list[str], rows: int):
    """``(data, times, stated, unread)`` of ``columns`` of the CSV, Parquet or MDF4 log ``path``: their first ``rows``
    rows (MDF4: samples of each channel) as float64 in the file's own units, the MDF4 channels' stamps (s; empty for a
    table), the units the file states, and the columns that cannot be read as numbers (column -> why), left out.

    The same rows whatever chunks the log is read in later: a CSV file streamed (:class:`CsvLines`) gives its first
    block of ``rows`` lines, one read whole (:func:`read_csv`) its first ``rows`` rows; memory is bounded by them.
    What :func:`roadbank.io.guess.guess_channels` reads of a log given without a channel map."""
    data: dict[str, np.ndarray] = {}
    times: dict[str, np.ndarray] = {}
    stated: dict[str, str] = {}
    unread: dict[str, str] = {}
    if not columns:
        return data, times, stated, unread
    read = {"csv": _csv_head, "parquet": _parquet_head, "mdf4": _mdf4_head}[fmt]
    try:
        data, times, stated = read(path, columns, rows)
    except LogError:                        # a column that holds no numbers (a gear as text): the others alone
        for c in columns:
            try:
                d, t, s = read(path, [c], rows)
            except LogError as exc:
                unread[c] = str(exc)
                continue
            data.update(d)
            times.update(t)
            stated.update(s)
    return data, times, stated, unread


def _csv_head(path, columns: list[str], rows: int):
    wanted = {c: c for c in columns}
    p = existing_nonempty(path)
    lines = CsvLines.open(p, rows, wanted)
    if lines is not None:                   # a long file: its first block of lines
        chunk = next(iter(lines.chunks(wanted)))
        return dict(chunk.data), {}, dict(lines.units)
    tab = read_csv(p, wanted)
    return {c: v[:rows] for c, v in tab.data.items()}, {}, dict(tab.units)


def _parquet_head(path, columns: list[str], rows: int):
    import pyarrow as pa
    import pyarrow.parquet as pq

    p = existing_nonempty(path)
    parts: dict[str, list[np.ndarray]] = {c: [] for c in columns}
    n = 0
    try:
        pf = pq.ParquetFile(p, pre_buffer=False)
        for b in pf.iter_batches(batch_size=rows, columns=columns, use_threads=False):
            for c in columns:
                parts[c].append(arrow_column_floats(p, c, f"column '{c}'", b.column(c), n))
            n += b.num_rows
            if n >= rows:
                break
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise LogError(f"{p}: not a readable Parquet file (truncated or corrupt?): {exc}") from None
    return {c: np.concatenate(v)[:rows] if v else np.zeros(0) for c, v in parts.items()}, {}, {}


def _mdf4_head(path, columns: list[str], rows: int):
    p = existing_nonempty(path)
    mdf = open_mdf(p)
    data, times = {}, {}
    try:
        stated = mdf_units(mdf, columns)
        for c in columns:
            label = f"channel '{c}'"
            group, index = mdf_place(mdf, p, c, label)
            try:
                sig = mdf.get(group=group, index=index, record_offset=0, record_count=rows)
            except Exception as exc:
                raise LogError(f"{p}: {label}: cannot read ({exc})") from None
            data[c] = mdf_signal_floats(p, c, label, sig)
            times[c] = np.asarray(sig.timestamps, dtype=np.float64)
    finally:
        mdf.close()
    return data, times, stated


"""The CSV reader: a delimited text file with a header line -> raw numeric columns (:class:`RawTable`).

What a tool's or a logger's export may hold besides a header and numbers, and how each is read: comment lines
(``#``) and a recorder's preamble before the header, a units row under it (:func:`_units_row`), ``;`` or tab
separators with decimal commas, ISO 8601 date-times as time stamps, Windows-1252 text, and a last line cut off
while the log was written. Fields become float64 in the file's own units (missing values NaN); anything that
cannot be read is a :class:`~roadbank.io.errors.LogError` naming the file, the column and the line.
"""

from __future__ import annotations

import codecs
import csv
import itertools
import math
import re
import warnings as _warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..units import FACTORS, normalise_unit, reads_as_number
from .errors import LogError
from .fields import DECIMAL_COMMA, MISSING, column_label, parse_floats, unique_names
from .types import RawChunk, RawTable

#: what a CSV column of date-times is, as :attr:`RawTable.time_typed` names its type (read as s since the epoch)
DATE_TIME_TEXT = "ISO 8601 date-time text"
#: what a CSV column of times of day is (read as s since the first stamp's midnight: :func:`unwrap_days`)
TIME_OF_DAY_TEXT = "time-of-day text (hh:mm:ss)"
#: a time of day as a logger writes it without its date: ``10:00:00.010`` (hours, minutes, seconds and a fraction)
_TIME_OF_DAY = re.compile(r"(\d{1,2}):(\d{2}):(\d{2}(?:\.\d*)?)")
#: a step back of a time of day by more than this (s) is midnight passed: the stamps after it are the next day's
MIDNIGHT_STEP_S = 43_200.0
DAY_S = 86_400.0


#: a whole number (``12``, ``-3e2``): the same with either decimal mark
_WHOLE = re.compile(r"[+-]?\d+([eE][+-]?\d+)?")


def _text_floats(path, column: str, label: str, values: list[str], row_label: str, rownums,
                 decimal_comma: bool = False) -> tuple[np.ndarray, str | None]:
    """:func:`parse_floats` of text fields, converted by numpy in one call where every field is a number
    (numpy parses a text field as ``float()`` does); else field by field, for the missing-value tokens and
    the error naming the first bad field. A column of ISO 8601 date-times (:func:`_date_time_seconds`) is read as
    seconds since the epoch, one of times of day (:func:`_time_of_day_seconds`) as seconds since midnight. With
    ``decimal_comma`` (a file whose fields are not separated by commas) a column whose numbers are all written with
    a decimal comma (:func:`_decimal_comma_column`) is read with it.
    Returns the values and how they were read where it was not as plain numbers: ``"date-time"``,
    ``"time of day"``, ``"decimal comma"``, else None."""
    try:
        return np.array(values, dtype=np.float64), None
    except ValueError:
        pass
    seconds = _date_time_seconds(path, label, values, row_label, rownums)
    if seconds is not None:
        return seconds, "date-time"
    seconds = _time_of_day_seconds(path, label, values, row_label, rownums)
    if seconds is not None:
        return seconds, "time of day"
    if decimal_comma and _decimal_comma_column(values):
        fixed = [v.replace(",", ".") for v in values]
        return _text_floats(path, column, label, fixed, row_label, rownums)[0], "decimal comma"
    return parse_floats(path, column, label, values, row_label, rownums), None


#: an ISO 8601 date and time (``2026-12-06 10:00:00.010``, ``2026-12-06T10:00:00Z``, ``...+01:00``), as a logger
#: or a spreadsheet writes its time stamps
_DATE_TIME = re.compile(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}(:\d{2}(\.\d+)?)?(Z|[+-]\d{2}:?\d{2})?")


def _date_time_seconds(path, label: str, values: list[str], row_label: str, rownums) -> np.ndarray | None:
    """Seconds (float64) since the epoch, UTC, of a column of ISO 8601 date-times (:data:`_DATE_TIME`; a time
    zone's offset applied, none: taken as UTC), missing-value tokens NaN; None unless every other field is written
    as one; a :class:`LogError` naming the first that is no date and time (month 13). The nanoseconds are split into
    whole seconds and the rest before converting, as for an Arrow timestamp."""
    fields = [v.strip() for v in values]
    stamps = [f for f in fields if f.lower() not in MISSING]
    if not stamps or not all(_DATE_TIME.fullmatch(f) for f in stamps):
        return None
    text = [f if f.lower() not in MISSING else "NaT" for f in fields]
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore", UserWarning)     # numpy's note on a time zone it converts
        try:
            ns = np.array(text, dtype="datetime64[ns]")
        except ValueError:
            for i, f in enumerate(text):
                try:
                    np.datetime64(f, "ns")
                except ValueError:
                    raise LogError(f"{path}: {label}: {f!r} at {row_label} {rownums[i]} is no date and time (the "
                                   "column holds ISO 8601 date-times)") from None
            raise
    missing = np.isnat(ns)
    whole, rest = np.divmod(ns.astype(np.int64), 10**9)
    out = whole.astype(np.float64) + rest / 1e9
    out[missing] = math.nan
    return out


def _time_of_day_seconds(path, label: str, values: list[str], row_label: str, rownums) -> np.ndarray | None:
    """Seconds since midnight (float64) of a column of times of day (:data:`_TIME_OF_DAY`: ``10:00:00.010``, as a
    logger writes them without the date), missing-value tokens NaN; None unless every other field is written as one;
    a :class:`LogError` naming the first that is no time of day (``25:00:00``). The days are not counted here
    (:func:`unwrap_days`)."""
    fields = [v.strip() for v in values]
    out = np.full(len(fields), math.nan)
    for i, f in enumerate(fields):
        if f.lower() in MISSING:
            continue
        m = _TIME_OF_DAY.fullmatch(f)
        if m is None:
            return None
        h, mi, sec = int(m[1]), int(m[2]), float(m[3])
        if h > 23 or mi > 59 or sec >= 60.0:
            raise LogError(f"{path}: {label}: {f!r} at {row_label} {rownums[i]} is no time of day (the column holds "
                           "times of day, hh:mm:ss)")
        out[i] = 3600.0 * h + 60.0 * mi + sec
    return out if np.isfinite(out).any() else None


def unwrap_days(seconds: np.ndarray, last: float | None = None) -> tuple[np.ndarray, float | None]:
    """Times of day (s since midnight, NaN missing) as seconds since the first one's midnight: a day (:data:`DAY_S`)
    added after each step back of more than :data:`MIDNIGHT_STEP_S` between consecutive finite stamps (a log that
    runs past midnight). ``last``: the finite stamp before these, as returned for the lines before (None: none).
    Returns the stamps and the last finite one."""
    ok = np.isfinite(seconds)
    v = seconds[ok]
    if not v.size:
        return seconds, last
    base = 0.0 if last is None else DAY_S * math.floor(last / DAY_S)
    ref = v[0] if last is None else last - base
    back = np.diff(np.concatenate([[ref], v])) < -MIDNIGHT_STEP_S
    out = seconds.copy()
    out[ok] = v + base + DAY_S * np.cumsum(back)
    return out, float(out[ok][-1])


def time_text(field: str) -> str | None:
    """What a text field holds if it is a time stamp written as text: ``"date-time"`` (ISO 8601) or
    ``"time of day"`` (hh:mm:ss), else None."""
    f = field.strip()
    return "date-time" if _DATE_TIME.fullmatch(f) else "time of day" if _TIME_OF_DAY.fullmatch(f) else None


def _decimal_comma_column(values: list[str]) -> bool:
    """Whether a column's fields are numbers with a decimal comma (``-0,25``; a whole number, ``12``, reads alike
    either way), at least one of them with the comma, besides missing-value tokens: no field has a decimal
    point, so no field's comma can be a thousands separator of a number written with a point."""
    seen = False
    for v in values:
        s = v.strip()
        if s.lower() in MISSING or _WHOLE.fullmatch(s):
            continue
        if not DECIMAL_COMMA.fullmatch(s):
            return False
        seen = True
    return seen


def _plain_csv(p: Path, lines: list[str], delim: str, wanted: dict[str, str], prefix: str | None,
               first: int = 1) -> RawTable | None:
    """:func:`read_csv`'s result for a plain file, parsed by numpy in C; None for any other file.

    ``lines`` start with the header; ``lines[k]`` (``k >= 1``) is line ``first + k`` of the file (the header is line
    ``first`` after the comment lines before it, :func:`_header_index`, or the line before a units row,
    :func:`_units_row`, that ``lines`` leave out).

    Plain: no quotes after the header, no blank line, every line with the header's number of
    fields, distinct names, at least one data row, and every field of the columns read a number
    that numpy (which parses text as ``float()`` does) reads. Anything else is left to the general
    path, which gives the same values and names the line of any problem.
    """
    try:
        header = [h.strip() for h in next(csv.reader(lines[:1], delimiter=delim))]
    except (csv.Error, StopIteration):
        return None
    n_delim = len(header) - 1
    body = lines[1:]
    # (C loops: a 20 000-line block in 4 ms where a generator took 25)
    if not body or '"' in "".join(body) or set(map(str.count, body, itertools.repeat(delim))) != {n_delim}:
        return None
    cols = [c for c in header if c in wanted or (prefix and c.startswith(prefix))]
    # a blank line has no delimiter: with one column or more it failed the count above
    if len(set(header)) != len(header) or (n_delim == 0 and not all(map(str.strip, body))):
        return None
    try:
        values = np.loadtxt(lines[1:], delimiter=delim, usecols=[header.index(c) for c in cols],
                            dtype=np.float64, ndmin=2, comments=None)
    except ValueError:
        return None
    if values.shape[0] != len(lines) - 1:
        return None
    return RawTable(header, {c: np.ascontiguousarray(values[:, k]) for k, c in enumerate(cols)},
                    row_label="line", rownums=list(range(first + 1, first + len(lines))))


def _cut_last_line(header: str, last: str, ends_newline: bool, data_lines: int, delim: str) -> bool:
    """Whether a CSV's ``last`` line is left out as cut off while the log was written (:func:`_drop_unfinished_line`):
    the file does not end with a newline (``ends_newline``), the line is not blank and has the ``header`` line's
    number of fields, and the file has at least two non-blank lines after its header (``data_lines``)."""
    if ends_newline or not last.strip() or data_lines < 2:
        return False
    try:
        n_fields = [len(next(csv.reader([ln], delimiter=delim))) for ln in (header, last)]
    except csv.Error:
        return False
    return n_fields[0] == n_fields[1]


def _cut_warning(p, lineno: int, cut: str) -> str:
    """The warning for the last line ``cut`` (line ``lineno`` of the file ``p``) left out by :func:`_cut_last_line`."""
    return (f"{p}: line {lineno} was left out: it has no final newline, so it may have been cut off while the log "
            f"was written (it ends {cut.strip()[-40:]!r}): if the file is complete, end it with a newline")


def _drop_unfinished_line(p: Path, text: str, lines: list[str], skip: int, delim: str) -> list[str]:
    """Leave out the last of ``lines`` (the header and the data lines after it, line ``skip + 1`` of the file on)
    when the file ``text`` does not end with a newline and the line holds the header's number of fields: a log
    cut off while it was written ends inside its last line, whose cut number may look right (``-0`` of
    ``-0.00095``). A table keeps the lines before it, so a file that merely lacks its final newline loses one
    row, and the warning returned names the file and the line. A last line short of fields is left in: it is
    refused as truncated, as a short line anywhere is. Nothing is dropped from a file with a single data line."""
    if not _cut_last_line(lines[0], lines[-1], text.endswith(("\n", "\r")), sum(1 for ln in lines[1:] if ln.strip()),
                          delim):
        return []
    cut = lines.pop()
    return [_cut_warning(p, skip + len(lines) + 1, cut)]


def _units_row(line: str, delim: str, n_fields: int) -> list[str] | None:
    """The units of a units row (the line under the header of many loggers' and tools' exports: ``s;km/h;m/s^2``,
    ``[s],[km/h],[deg/s]``), one per field with brackets and blanks stripped; None for any other line. A units row
    has the header's number of fields, none of them a number, and at least one a unit a channel map may declare
    (:data:`roadbank.units.FACTORS`)."""
    try:
        fields = next(csv.reader([line], delimiter=delim))
    except (csv.Error, StopIteration):
        return None
    if len(fields) != n_fields or any(f.strip() and reads_as_number(f) for f in fields):
        return None
    units = [f.strip().strip("[]()").strip() for f in fields]
    if not any(normalise_unit(u) in table for u in units if u for table in FACTORS.values()):
        return None
    return units


def _read_text(p: Path) -> tuple[str, list[str]]:
    """The text of a CSV file and what was said of its encoding: UTF-8 (a byte-order mark dropped), else Windows-1252
    (what a Windows tool writes: a degree sign in a units row is one byte, 0xB0), said in a warning; a file with a
    NUL byte is no text (:class:`LogError`), as is one neither encoding reads. A UTF-8 file is decoded as it is read
    (no copy of its bytes)."""
    try:
        with open(p, newline="", encoding="utf-8-sig") as fh:
            return fh.read(), []
    except FileNotFoundError:
        raise LogError(f"{p}: file not found") from None
    except UnicodeDecodeError:
        pass
    except OSError as exc:
        raise LogError(f"{p}: cannot read ({exc.strerror})") from None
    raw = p.read_bytes()
    try:
        raw.decode("utf-8-sig")
        bad = None
    except UnicodeDecodeError as exc:        # where in the file (the reader's own error counts from its buffer)
        bad = exc
    if bad is not None and b"\0" not in raw:
        try:
            return raw.decode("cp1252"), [f"{p}: not UTF-8 (byte 0x{raw[bad.start]:02X} at {bad.start}): read as "
                                          "Windows-1252, as a Windows tool writes it"]
        except UnicodeDecodeError:
            pass
    where = f" ({bad.reason} at byte {bad.start})" if bad is not None else ""
    raise LogError(f"{p}: not a text (UTF-8) CSV file{where}")


#: a CSV's header comes within this many lines after a preamble (:func:`_after_preamble`)
PREAMBLE_MAX_LINES = 50


def _after_preamble(p, lines: list[str], k: int) -> tuple[int, list[str]]:
    """Index of a CSV's header where ``lines[k]`` opens a preamble (a recorder's, a tool's: ``Recorder: DEWE-43``,
    ``Date: 06.12.2026``), and what is said of it; ``(k, [])`` for a file whose line ``k`` is its header.

    A header is a line of names whose next line (after a units row, :func:`_units_row`) has as many fields, most of
    them numbers: line ``k`` when it is one; else the first such line within :data:`PREAMBLE_MAX_LINES` whose number
    of fields no line before it has (a preamble is not shaped like the table). Anything else is left to the reader's
    own errors."""
    if _opens_table(lines, k):
        return k, []
    for j in range(k + 1, min(len(lines), k + PREAMBLE_MAX_LINES)):
        if not _opens_table(lines, j):
            continue
        n = _fields(lines[j])
        if any(_fields(ln) == n for ln in lines[k:j] if ln.strip()):
            return k, []
        first = next(ln.strip() for ln in lines[k:j] if ln.strip())
        return j, [f"{p}: lines {k + 1}-{j} before the header (line {j + 1}) read as a preamble, not data "
                   f"(they start {first[:40]!r})"]
    return k, []


def _delimiter(line: str) -> str:
    """A line's most frequent delimiter: ``,`` ``;`` or tab (a header's is the file's)."""
    return max((",", ";", "\t"), key=line.count)


def _split(line: str, delim: str | None = None) -> list[str]:
    """The fields of one line (quotes read as the CSV reader reads them) by ``delim``, or by its own
    :func:`_delimiter`; [] for a line the CSV reader cannot read."""
    delim = delim or _delimiter(line)
    try:
        return next(csv.reader([line], delimiter=delim), [])
    except csv.Error:
        return []


def _fields(line: str) -> int:
    """The number of fields of a line (:func:`_split`)."""
    return len(_split(line))


def _opens_table(lines: list[str], j: int) -> bool:
    """Whether line ``j`` reads as a header (:func:`_after_preamble`): two fields or more, not all numbers, and the
    next line after a units row as many fields, more than half of them numbers."""
    if j + 1 >= len(lines):
        return False
    delim = _delimiter(lines[j])
    head = _split(lines[j], delim)
    n = len(head)
    if n < 2 or all(_number_like(f) for f in head):
        return False
    nxt = j + 1 + (j + 2 < len(lines) and _units_row(lines[j + 1], delim, n) is not None)
    fields = _split(lines[nxt], delim) if nxt < len(lines) else []
    return len(fields) == n and 2 * sum(_number_like(f) for f in fields) > n


def _number_like(field: str) -> bool:
    """A field that holds a number as a log writes one: ``float()``'s, a decimal comma, a date-time, a time of day,
    or missing."""
    f = field.strip()
    return (reads_as_number(f) or f.lower() in MISSING or DECIMAL_COMMA.fullmatch(f) is not None
            or _DATE_TIME.fullmatch(f) is not None or _TIME_OF_DAY.fullmatch(f) is not None)


def _is_comment(line: str) -> bool:
    """A comment line: ``#`` after optional whitespace or byte-order mark."""
    return line.lstrip(" \t\ufeff").startswith("#")


def _header_index(lines: list[str]) -> int:
    """Index in ``lines`` of a CSV's header: the first line neither blank nor a comment (:func:`_is_comment`);
    ``len(lines)`` if there is none."""
    for i, line in enumerate(lines):
        if line.strip(" \t\ufeff") and not _is_comment(line):
            return i
    return len(lines)


def read_csv(path, wanted: dict[str, str], prefix: str | None = None) -> RawTable:
    """Read a delimited text file with a header line.

    Lines before the header that are blank or start with ``#`` (after optional whitespace or a
    byte-order mark) are comments, skipped; messages and row numbers count every line of the file.

    Parameters
    ----------
    path : path-like
    wanted : dict column -> role
        Columns to convert (roles are used in error messages).
    prefix : str, optional
        Also convert every column whose name starts with it.
    """
    p = Path(path)
    text, warnings = _read_text(p)
    lines = text.splitlines()
    layout = _layout(p, lines)
    lines = lines[layout.skip:]
    warnings += layout.warnings + _drop_unfinished_line(p, text, lines, layout.skip, layout.delim)
    if layout.units is not None:
        del lines[1]                    # the line numbers below count it
    table = _table(p, lines, layout, wanted, prefix, warnings)
    for c in _times_of_day(table):
        table.data[c] = unwrap_days(table.data[c])[0]
    return table


def _times_of_day(table: RawTable) -> list[str]:
    """The columns of ``table`` read as times of day (:data:`TIME_OF_DAY_TEXT`)."""
    return [c for c, kind in table.time_typed.items() if kind == TIME_OF_DAY_TEXT]


@dataclass(frozen=True)
class _Layout:
    """Where a CSV's table is in its lines: ``lines[skip]`` is the header (comments and a preamble before it), fields
    separated by ``delim``, the units of a units row under it (None without one), and its warnings (a preamble)."""

    skip: int
    delim: str
    units: list[str] | None
    warnings: list[str]

    @property
    def first(self) -> int:
        """The line number of the line before the first data line (its header's, or its units row's)."""
        return self.skip + 1 + (self.units is not None)


def _layout(p: Path, lines: list[str]) -> _Layout:
    """The :class:`_Layout` of a CSV file ``p`` from its ``lines`` (all of them, or enough of the first for its
    comments, preamble, header and units row); LogError for a file with no header."""
    if not any(ln.strip() for ln in lines):
        raise LogError(f"{p}: file is empty")
    skip = _header_index(lines)         # comment lines before the header
    if skip == len(lines):
        raise LogError(f"{p}: no header line (every line is blank or a comment starting with '#')")
    skip, preamble = _after_preamble(p, lines, skip)
    header_line = lines[skip]
    delim = _delimiter(header_line)
    if skip and all(reads_as_number(f) for f in header_line.split(delim)):
        raise LogError(f"{p}: no header line: line {skip + 1} ({header_line.strip()[:40]!r}) holds numbers, not "
                       "column names (the lines before it are blank or comments starting with '#')")
    units = _units_row(lines[skip + 1], delim, header_line.count(delim) + 1) if len(lines) > skip + 1 else None
    return _Layout(skip, delim, units, preamble)


def _table(p: Path, lines: list[str], layout: _Layout, wanted: dict[str, str], prefix: str | None,
           warnings: list[str], first: int | None = None, rows_needed: bool = True) -> RawTable:
    """The table of ``lines`` (the header, then data lines: ``lines[k]``, ``k >= 1``, is line ``first + k`` of the
    file, default :attr:`_Layout.first`): the columns of ``wanted`` (column -> role) and those starting with
    ``prefix``, as float64, with ``warnings``. LogError for a field or line that cannot be read, and, where
    ``rows_needed``, for no data row."""
    delim = layout.delim
    first = layout.first if first is None else first
    fast = _plain_csv(p, lines, delim, wanted, prefix, first=first)
    if fast is not None:
        fast.warnings = warnings
        fast.units = _named_units(fast.names, layout.units)
        return fast
    reader = csv.reader(lines, delimiter=delim)
    try:
        header = [h.strip() for h in next(reader)]
        rows = []
        for lineno, row in enumerate(reader, start=first + 1):
            if not row or not "".join(row).strip():
                continue
            if len(row) != len(header):
                if _is_comment(row[0]):
                    raise LogError(f"{p}: line {lineno} is a comment ({delim.join(row).strip()[:40]!r}): comment "
                                   "lines starting with '#' are read only before the header")
                raise LogError(f"{p}: line {lineno} has {len(row)} field(s) but the header has "
                               f"{len(header)} (truncated or corrupt file)")
            rows.append((lineno, row))
    except csv.Error as exc:
        raise LogError(f"{p}: corrupt CSV ({exc})") from None
    unique_names(p, [h for h in header if h], "in the header")   # unnamed columns (",,") are never read
    if not rows and rows_needed:
        raise LogError(f"{p}: no data rows after the header")
    linenos = [ln for ln, _ in rows]
    cols = [c for c in header if c in wanted or (prefix and c.startswith(prefix))]
    data, commas, dated = {}, [], {}
    for c in cols:
        j = header.index(c)
        data[c], how = _text_floats(p, c, column_label(wanted, c), [row[j] for _, row in rows], "line", linenos,
                                    decimal_comma=delim != ",")
        if how == "decimal comma":
            commas.append(c)
        elif how == "date-time":
            dated[c] = DATE_TIME_TEXT
        elif how == "time of day":
            dated[c] = TIME_OF_DAY_TEXT
    if commas:
        sep = "tabs" if delim == "\t" else repr(delim)
        warnings = warnings + [f"{p}: column(s) {', '.join(repr(c) for c in commas)} read with ',' as the decimal "
                               f"mark (the file separates its fields with {sep})"]
    return RawTable(header, data, row_label="line", rownums=linenos, warnings=warnings,
                    units=_named_units(header, layout.units), time_typed=dated)


def _named_units(names: list[str], units: list[str] | None) -> dict[str, str]:
    """Column -> unit of a units row (:func:`_units_row`; the columns it leaves blank left out)."""
    return {c: u for c, u in zip(names, units) if c and u} if units is not None else {}



#: the first lines of a CSV whose layout (comments, a preamble, the header, a units row) :class:`CsvLines` reads; a
#: file of no more lines than this is read whole
HEAD_LINES = 2 * PREAMBLE_MAX_LINES + 100
#: bytes of a CSV scanned at a time by :func:`CsvLines.open`
SCAN_BYTES = 1 << 20
#: what :meth:`str.splitlines` breaks a line at besides ``\n``, ``\r`` and ``\r\n`` (which the streamed reader's
#: universal newlines break at too), as UTF-8, and a NUL byte: a file with any of them is read whole
_ODD_BREAKS = (b"\x00", b"\x0b", b"\x0c", b"\x1c", b"\x1d", b"\x1e", b"\xc2\x85", b"\xe2\x80\xa8", b"\xe2\x80\xa9")
#: a CSV file of at most this many bytes is read whole even where it is streamed (:meth:`CsvLines.open`): read whole,
#: a CSV costs about five times its size in memory while it is parsed (``roadbank estimate`` on a 1e6-line, 68 MB
#: file: 588 MB peak resident read whole, 227 MB streamed, the process alone about 200 MB; docs/io.md), and streamed
#: its lines are parsed twice where the time base is decided on the whole log (``time_base = "auto"``)
CSV_WHOLE_BYTES = 64 << 20


@dataclass(frozen=True)
class _Scan:
    """What one pass over a CSV's bytes found: ``lines`` (as :meth:`str.splitlines` counts them), whether the text
    ends with a line break (``ends_newline``) and its ``last`` line."""

    lines: int
    ends_newline: bool
    last: str


def _scan(p: Path) -> _Scan | None:
    """One pass over the bytes of ``p``, :data:`SCAN_BYTES` at a time: its lines, and whether it ends with a line
    break; None for a file that is not UTF-8, holds a NUL byte or a line break other than ``\\n``, ``\\r`` and
    ``\\r\\n`` (:data:`_ODD_BREAKS`), or whose last two blocks hold fewer than two lines (its last line may have begun
    before them; such a file is read whole, as :func:`read_csv` reads it)."""
    decoder = codecs.getincrementaldecoder("utf-8-sig")()
    breaks, prev_cr, tail = 0, False, b""
    try:
        with open(p, "rb") as fh:
            while block := fh.read(SCAN_BYTES):
                decoder.decode(block)
                edge = tail[-2:] + block[:2]            # a break of several bytes across two blocks
                if any(b in block or b in edge for b in _ODD_BREAKS):
                    return None
                # \r\n is one break, also where a block ends between the two
                joined = prev_cr and block[:1] == b"\n"
                breaks += block.count(b"\n") + block.count(b"\r") - block.count(b"\r\n") - joined
                prev_cr, tail = block.endswith(b"\r"), tail[-SCAN_BYTES:] + block     # the last two blocks
            decoder.decode(b"", final=True)
    except (UnicodeDecodeError, OSError):
        return None
    ends = tail.endswith((b"\n", b"\r"))
    text = tail.decode("utf-8", errors="replace").splitlines()
    if len(text) < 2:          # the last line may have begun before the last two blocks
        return None
    return _Scan(breaks + (not ends), ends, text[-1])


class CsvLines:
    """A CSV file streamed ``chunk_rows`` lines at a time (a table source, :mod:`roadbank.io.sources`): its layout
    (:func:`_layout`) read from its first :data:`HEAD_LINES` lines, then each block of lines parsed as
    :func:`read_csv` parses the whole file (:func:`_table`), with the same values, line numbers, warnings and
    errors; memory is bounded by the block. Open with :meth:`open`."""

    shared_clock = True
    whole = False
    row_label = "line"
    carried: dict[str, float] = {}

    def __init__(self, p: Path, chunk_rows: int, scan: _Scan, head: list[str], layout: _Layout, table: RawTable):
        self.path, self.chunk_rows, self.scan, self.layout = p, int(chunk_rows), scan, layout
        self.header = head[layout.skip]
        self.names = list(table.names)
        self.units = dict(table.units)
        self.time_typed = dict(table.time_typed)
        self.metadata: dict[str, str] = {}
        data = [ln for ln in head[layout.first:] if ln.strip()]
        self.cut = _cut_last_line(self.header, scan.last, scan.ends_newline, len(data) + (layout.units is not None),
                                  layout.delim)
        self.warnings = list(layout.warnings) + ([_cut_warning(p, scan.lines, scan.last)] if self.cut else [])

    @classmethod
    def open(cls, p: Path, chunk_rows: int, wanted: dict[str, str], prefix: str | None = None) -> CsvLines | None:
        """The streamed source of the CSV file ``p``; None where it is read whole (:func:`read_csv`): a file of at
        most :data:`CSV_WHOLE_BYTES` or :data:`HEAD_LINES` lines, one :func:`_scan` does not pass, one separated by
        ``;`` or tabs (a column there may be written with decimal commas, decided over the whole column), or one with
        fewer than two data lines in its head. ``wanted`` and ``prefix`` as :func:`read_csv`: the head's columns of
        date-times are the whole file's."""
        try:
            if p.stat().st_size <= CSV_WHOLE_BYTES:
                return None
        except OSError:
            return None
        scan = _scan(p)
        if scan is None or scan.lines <= HEAD_LINES:
            return None
        with open(p, encoding="utf-8-sig", newline=None) as fh:
            head = [ln.rstrip("\n") for ln in itertools.islice(fh, HEAD_LINES)]
        if _header_index(head) + 2 * PREAMBLE_MAX_LINES + 3 > len(head):
            return None                         # a long run of comments: the head may not show the table's start
        layout = _layout(p, head)
        lines = [head[layout.skip]] + head[layout.first:]
        if layout.delim != "," or sum(1 for ln in lines[1:] if ln.strip()) < 2:
            return None
        return cls(p, chunk_rows, scan, head, layout, _table(p, lines, layout, wanted, prefix, []))

    def close(self) -> None:
        """Nothing to close: each pass opens the file for itself."""

    def chunks(self, wanted: dict[str, str], prefix: str | None = None) -> Iterator[RawChunk]:
        """The data lines ``chunk_rows`` at a time (the last line left out where :func:`_cut_last_line` says so),
        the columns of ``wanted`` (column -> role, for messages) and those starting with ``prefix``; the final chunk
        has ``last`` set (empty where the lines ran out with the one before)."""
        p, layout = self.path, self.layout
        end = self.scan.lines - self.cut           # lines of the file read: 1 .. end
        lineno = layout.first                      # the line number of the line before the block
        before: dict[str, float | None] = {}       # a column of times of day: its last stamp so far
        with open(p, encoding="utf-8-sig", newline=None) as fh:
            lines = itertools.islice(fh, layout.first, end)
            while True:
                # (universal newlines end each line with \n; the file has no other break, _scan)
                block = "".join(itertools.islice(lines, self.chunk_rows)).splitlines()
                tab = _table(p, [self.header] + block, layout, wanted, prefix, [], first=lineno, rows_needed=False)
                self._same_kinds(tab, lineno)
                for c in _times_of_day(tab):
                    tab.data[c], before[c] = unwrap_days(tab.data[c], before.get(c))
                lineno += len(block)
                last = lineno >= end
                yield RawChunk(tab.data, rownums=np.asarray(tab.rownums, dtype=np.int64), last=last)
                if last:
                    return

    def _same_kinds(self, tab: RawTable, lineno: int) -> None:
        """LogError where a block reads a column as date-times or times of day that the head read as numbers, or
        the other way (read whole, such a column is refused as holding both)."""
        for c in tab.data:
            if tab.time_typed.get(c) != self.time_typed.get(c) and np.isfinite(tab.data[c]).any():
                kind = {DATE_TIME_TEXT: "date-times", TIME_OF_DAY_TEXT: "times of day"}.get(self.time_typed.get(c, ""),
                                                                                            "numbers")
                raise LogError(f"{self.path}: column '{c}' holds {kind} in its first lines but not in lines "
                               f"{lineno + 1}-{lineno + len(tab.data[c])}")

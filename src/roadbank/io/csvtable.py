"""The CSV reader: a delimited text file with a header line -> raw numeric columns (:class:`RawTable`).

What a tool's or a logger's export may hold besides a header and numbers, and how each is read: comment lines
(``#``) and a recorder's preamble before the header, a units row under it (:func:`_units_row`), ``;`` or tab
separators with decimal commas, ISO 8601 date-times as time stamps, Windows-1252 text, and a last line cut off
while the log was written. Fields become float64 in the file's own units (missing values NaN); anything that
cannot be read is a :class:`~roadbank.io.errors.LogError` naming the file, the column and the line.
"""

from __future__ import annotations

import csv
import math
import re
import warnings as _warnings
from pathlib import Path

import numpy as np

from ..units import FACTORS, normalise_unit, reads_as_number
from .errors import LogError
from .fields import DECIMAL_COMMA, MISSING, column_label, parse_floats, unique_names
from .types import RawTable

#: what a CSV column of date-times is, as :attr:`RawTable.time_typed` names its type (read as s since the epoch)
DATE_TIME_TEXT = "ISO 8601 date-time text"


#: a whole number (``12``, ``-3e2``): the same with either decimal mark
_WHOLE = re.compile(r"[+-]?\d+([eE][+-]?\d+)?")


def _text_floats(path, column: str, label: str, values: list[str], row_label: str, rownums,
                 decimal_comma: bool = False) -> tuple[np.ndarray, str | None]:
    """:func:`parse_floats` of text fields, converted by numpy in one call where every field is a number
    (numpy parses a text field as ``float()`` does); else field by field, for the missing-value tokens and
    the error naming the first bad field. A column of ISO 8601 date-times (:func:`_date_time_seconds`) is read as
    seconds since the epoch. With ``decimal_comma`` (a file whose fields are not separated by commas) a column
    whose numbers are all written with a decimal comma (:func:`_decimal_comma_column`) is read with it.
    Returns the values and how they were read where it was not as plain numbers: ``"date-time"``,
    ``"decimal comma"``, else None."""
    try:
        return np.array(values, dtype=np.float64), None
    except ValueError:
        pass
    seconds = _date_time_seconds(path, label, values, row_label, rownums)
    if seconds is not None:
        return seconds, "date-time"
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
    if len(lines) < 2 or any('"' in line or line.count(delim) != n_delim for line in lines[1:]):
        return None
    cols = [c for c in header if c in wanted or (prefix and c.startswith(prefix))]
    if len(set(header)) != len(header) or any(not line.strip() for line in lines[1:]):
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


def _drop_unfinished_line(p: Path, text: str, lines: list[str], skip: int, delim: str) -> list[str]:
    """Leave out the last of ``lines`` (the header and the data lines after it, line ``skip + 1`` of the file on)
    when the file ``text`` does not end with a newline and the line holds the header's number of fields: a log
    cut off while it was written ends inside its last line, whose cut number may look right (``-0`` of
    ``-0.00095``). A table keeps the lines before it, so a file that merely lacks its final newline loses one
    row, and the warning returned names the file and the line. A last line short of fields is left in: it is
    refused as truncated, as a short line anywhere is. Nothing is dropped from a file with a single data line."""
    if text.endswith(("\n", "\r")) or not lines[-1].strip() or sum(1 for ln in lines[1:] if ln.strip()) < 2:
        return []
    try:
        n_fields = [len(next(csv.reader([ln], delimiter=delim))) for ln in (lines[0], lines[-1])]
    except csv.Error:
        return []
    if n_fields[0] != n_fields[1]:
        return []
    cut = lines.pop()
    return [f"{p}: line {skip + len(lines) + 1} was left out: it has no final newline, so it may have been cut "
            f"off while the log was written (it ends {cut.strip()[-40:]!r}): if the file is complete, end it with "
            "a newline"]


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
    """A field that holds a number as a log writes one: ``float()``'s, a decimal comma, a date-time, or missing."""
    f = field.strip()
    return (reads_as_number(f) or f.lower() in MISSING or DECIMAL_COMMA.fullmatch(f) is not None
            or _DATE_TIME.fullmatch(f) is not None)


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
    if not text.strip():
        raise LogError(f"{p}: file is empty")
    lines = text.splitlines()
    skip = _header_index(lines)         # comment lines before the header
    if skip == len(lines):
        raise LogError(f"{p}: no header line (every line is blank or a comment starting with '#')")
    skip, preamble = _after_preamble(p, lines, skip)
    warnings += preamble
    lines = lines[skip:]
    header_line = lines[0]
    delim = _delimiter(header_line)
    warnings += _drop_unfinished_line(p, text, lines, skip, delim)
    if skip and all(reads_as_number(f) for f in header_line.split(delim)):
        raise LogError(f"{p}: no header line: line {skip + 1} ({header_line.strip()[:40]!r}) holds numbers, not "
                       "column names (the lines before it are blank or comments starting with '#')")
    units = _units_row(lines[1], delim, header_line.count(delim) + 1) if len(lines) > 1 else None
    if units is not None:
        del lines[1]                    # the line numbers below count it
    first = skip + 1 + (units is not None)      # the line number of lines[k] is first + k for k >= 1
    fast = _plain_csv(p, lines, delim, wanted, prefix, first=first)
    if fast is not None:
        fast.warnings = warnings
        fast.units = _named_units(fast.names, units)
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
    if not rows:
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
    if commas:
        warnings.append(f"{p}: column(s) {', '.join(repr(c) for c in commas)} read with ',' as the decimal mark (the "
                        f"file separates its fields with {'tabs' if delim == chr(9) else repr(delim)})")
    return RawTable(header, data, row_label="line", rownums=linenos, warnings=warnings,
                    units=_named_units(header, units), time_typed=dated)


def _named_units(names: list[str], units: list[str] | None) -> dict[str, str]:
    """Column -> unit of a units row (:func:`_units_row`; the columns it leaves blank left out)."""
    return {c: u for c, u in zip(names, units) if c and u} if units is not None else {}


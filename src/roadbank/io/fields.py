"""Text fields of a log read as numbers, and how a reader's messages name a column: what the CSV, Parquet and
MDF4 readers share (:mod:`roadbank.io.readers`, :mod:`roadbank.io.csvtable`)."""

from __future__ import annotations

import math
import re

import numpy as np

from .errors import LogError

#: strings read as a missing sample (NaN) rather than an error
MISSING = {"", "nan", "na", "n/a", "null", "none", "-nan", "+nan"}


def column_label(labels: dict[str, str], col: str) -> str:
    """How messages name column ``col``: ``channel 'role' (column 'col')``, or ``column 'col'``
    when ``labels`` (column -> role) gives it no other role name."""
    role = labels.get(col)
    return f"channel '{role}' (column '{col}')" if role and role != col else f"column '{col}'"


def not_numbers(path, label: str, what: str) -> LogError:
    """The error for a channel's column that holds booleans (``what``: the type or the first value): read as
    0/1 they would be taken for a physical quantity."""
    return LogError(f"{path}: {label}: holds booleans ({what}), not numbers")


def parse_floats(path, col: str, label: str, values, row_label: str, rownums) -> np.ndarray:
    """Strings -> float64; missing markers -> NaN; anything else -> LogError with its row (``True`` / ``False``:
    :func:`not_numbers`)."""
    out = np.empty(len(values), dtype=np.float64)
    for i, s in enumerate(values):
        if s is None:
            out[i] = math.nan
            continue
        s = str(s).strip()
        try:
            out[i] = float(s)
        except ValueError:
            if s.lower() in MISSING:
                out[i] = math.nan
            elif s.lower() in ("true", "false"):
                raise not_numbers(path, label, f"{s!r} at {row_label} {rownums[i]}") from None
            else:
                hint = (": it looks like a decimal comma (a spreadsheet's export in a language that writes one); "
                        "write the file with '.' as the decimal mark" if DECIMAL_COMMA.fullmatch(s) else "")
                raise LogError(f"{path}: {label}: non-numeric value {s!r} at {row_label} "
                               f"{rownums[i]}{hint}") from None
    return out


#: a number written with a decimal comma (``-0,25``, ``1,5e-3``), which ``float()`` does not read
DECIMAL_COMMA = re.compile(r"[+-]?\d*,\d+([eE][+-]?\d+)?")


def unique_names(p, names, where: str) -> None:
    """A :class:`LogError` naming the file ``p`` and the column names that ``names`` holds twice (``where``: ``"in
    the header"``, ``"in the schema"``): which of the two is the channel cannot be told."""
    if len(set(names)) != len(names):
        dup = sorted({h for h in names if names.count(h) > 1})
        raise LogError(f"{p}: duplicate column name(s) {dup} {where}")


"""Markdown tables for every generated report: escaped cells, numbers right-aligned,
the best value of a row (or of a column) in bold.

The output is GitHub-flavoured markdown (CommonMark plus the table extension), so
the same text renders in a markdown viewer and through :func:`roadbank.report.html.md_to_html`.

>>> print(md_table(["case", "a", "b"], [["x|y", 1.234, 0.5]], best="min"))
| case | a | b |
|---|---:|---:|
| x\\|y | 1.23 | **0.50** |
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from ..units import reads_as_number

__all__ = ["Markdown", "escape", "md_table", "BEST", "Slugger", "contents"]


class Markdown(str):
    """Cell or text that is already markdown (``**bold**``, ```code```): passed through,
    only its pipes escaped and line breaks joined."""


# characters that can start markup anywhere in a line (pipes end a table cell)
_ALWAYS = re.compile(r"([\\`*|\[\]~])")
# '_' only starts emphasis at a word boundary; '<' only before a tag / autolink; '&' before an entity
_UNDERSCORE = re.compile(r"(?<![0-9A-Za-z])_|_(?![0-9A-Za-z])")
_LT = re.compile(r"<(?=[A-Za-z/!?])")
_AMP = re.compile(r"&(?=[#A-Za-z])")


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def escape(text) -> str:
    """Plain text -> markdown that shows exactly that text (also inside a table cell).

    A :class:`Markdown` value keeps its markup; only its pipes are escaped. Line breaks
    become spaces (a table row is one line).
    """
    if isinstance(text, Markdown):
        return re.sub(r"(?<!\\)\|", r"\\|", _one_line(text))
    s = _ALWAYS.sub(r"\\\1", _one_line(text))
    s = _UNDERSCORE.sub(r"\\_", s)
    s = _LT.sub(r"\\<", s)
    return _AMP.sub(r"\\&", s)


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _finite(v) -> bool:
    return _is_number(v) and math.isfinite(float(v))


#: how to pick the best value of a row: smallest, largest, smallest magnitude
BEST: dict[str, Callable[[float], float]] = {
    "min": lambda v: v,
    "max": lambda v: -v,
    "absmin": abs,
}


def _column_spec(spec, header: Sequence[str], j: int, default):
    """Per-column value from a scalar, a sequence (by position) or a mapping (by header or position)."""
    if spec is None or isinstance(spec, (str, int)):
        return default if spec is None else spec
    if isinstance(spec, Mapping):
        return spec.get(header[j], spec.get(j, default))
    return spec[j]


def md_table(header: Sequence, rows: Sequence[Sequence], *, digits: int | Sequence | Mapping = 2,
             formats: str | Sequence | Mapping | None = None, align: str | Sequence | None = None,
             best: str | Mapping | None = None, best_columns: Sequence | None = None, best_in: str = "row",
             na: str = "n/a") -> str:
    """One markdown table; every cell escaped, numbers formatted and right-aligned.

    Parameters
    ----------
    header : sequence
        Column titles (plain text or :class:`Markdown`).
    rows : sequence of sequences
        Cells: numbers (formatted with ``digits`` / ``formats``; NaN, inf and None show
        as ``na``), plain text (escaped: pipes, ``*``, ``_`` ... show literally) or
        :class:`Markdown` (kept, pipes escaped). Every row must have ``len(header)`` cells.
    digits : int, or per column (sequence, or mapping by title or position)
        Decimals of float cells (default 2). Integers print as integers.
    formats : format spec, or per column
        A ``format()`` spec (e.g. ``"+.2f"``, ``".0%"``) that overrides ``digits``.
    align : str or sequence, optional
        ``"l"``, ``"r"`` or ``"c"`` per column (a string like ``"llrr"`` or a sequence).
        Default: right for columns whose cells are all numbers (or empty), left otherwise.
    best : {"min", "max", "absmin"} or mapping column -> one of them, optional
        Mark the best value of each row (``best_in="row"``) or of each column
        (``best_in="column"``) in bold, among the numeric cells of ``best_columns``
        (titles or positions; default every numeric column, or those of the mapping's
        keys that the table has).
        Values are compared as printed, so equal-looking values are all marked; a
        row or column with fewer than two numbers is left unmarked.
    best_in : {"row", "column"}
        Where the best value is looked for.
    na : str
        Text of a missing or non-finite number.

    Returns
    -------
    str
        The table, lines joined by ``\\n`` (no trailing newline).
    """
    header = list(header)
    ncol = len(header)
    rows = [list(r) for r in rows]
    for i, r in enumerate(rows):
        if len(r) != ncol:
            raise ValueError(f"md_table: row {i} has {len(r)} cells, the header has {ncol}: {r!r}")
    rules = best if isinstance(best, Mapping) else {}
    for rule in (list(rules.values()) if rules else [best] if best is not None else []):
        if rule not in BEST:
            raise ValueError(f"md_table: best must be one of {sorted(BEST)}, not {rule!r}")
    if best_in not in ("row", "column"):
        raise ValueError(f"md_table: best_in must be 'row' or 'column', not {best_in!r}")

    def col(c) -> int:
        return c if isinstance(c, int) else header.index(c)

    def fmt(v, j) -> str:
        if v is None or (_is_number(v) and not _finite(v)):
            return na
        if not _is_number(v):
            return escape(v)
        spec = _column_spec(formats, header, j, None)
        if spec is None:
            spec = "d" if isinstance(v, (int, np.integer)) else f".{_column_spec(digits, header, j, 2)}f"
        return format(v, spec)

    text = [[fmt(v, j) for j, v in enumerate(r)] for r in rows]
    numeric = [all(_is_number(r[j]) or r[j] is None for r in rows) and any(_is_number(r[j]) for r in rows)
               for j in range(ncol)]
    if best is not None:
        cols: Sequence[int]
        if best_columns is not None:
            cols = [col(c) for c in best_columns]
        else:        # a mapping may name columns this table does not have
            cols = [col(c) for c in rules if isinstance(c, int) or c in header] if rules else range(ncol)
        rule_of = {col(c): r for c, r in rules.items() if isinstance(c, int) or c in header}
        if best_in == "row":
            groups = [([(i, j) for j in cols], best) for i in range(len(rows))]
        else:
            groups = [([(i, j) for i in range(len(rows))], rule_of.get(j, best)) for j in cols]
        for cells, rule in groups:    # a rule: best's own, or the mapping's for a column it names
            _mark_best(rows, text, cells, BEST[rule])  # type: ignore[index]
    if align is None:
        align = ["r" if numeric[j] else "l" for j in range(ncol)]
    align = list(align)
    if len(align) != ncol or any(a not in "lrc" for a in align):
        raise ValueError(f"md_table: align needs one of l/r/c for each of the {ncol} columns, got {align!r}")
    sep = {"l": "---", "r": "---:", "c": ":---:"}
    lines = ["| " + " | ".join(escape(h) for h in header) + " |",
             "|" + "|".join(sep[a] for a in align) + "|"]
    lines += ["| " + " | ".join(tr) + " |" for tr in text]
    return "\n".join(lines)


def _mark_best(rows, text, cells, key) -> None:
    """Bold the cells (i, j) whose printed value is best by ``key`` (at least two numbers needed)."""
    cand = [(i, j) for i, j in cells if _finite(rows[i][j])]
    if len(cand) < 2:
        return
    shown = {c: float(text[c[0]][c[1]]) if reads_as_number(text[c[0]][c[1]]) else float(rows[c[0]][c[1]]) for c in cand}
    top = min(key(v) for v in shown.values())
    for (i, j), v in shown.items():
        if key(v) == top:
            text[i][j] = f"**{text[i][j]}**"


# what a heading's anchor drops: everything but letters, digits, '_', '-' and spaces (as GitHub)
_NOT_SLUG = re.compile(r"[^\w\- ]")


class Slugger:
    """Anchors of a document's headings, as GitHub makes them: the heading's text in lower
    case, punctuation dropped, spaces as ``-``; a repeated one gets ``-1``, ``-2`` ...

    >>> s = Slugger()
    >>> s("Bank angle RMS error (deg), after 2 s"), s("Figures"), s("Figures")
    ('bank-angle-rms-error-deg-after-2-s', 'figures', 'figures-1')
    """

    def __init__(self):
        self.seen: dict[str, int] = {}

    def __call__(self, text: str) -> str:
        base = _NOT_SLUG.sub("", str(text).strip().lower()).replace(" ", "-")
        n = self.seen.get(base, 0)
        self.seen[base] = n + 1
        return base if n == 0 else f"{base}-{n}"


def contents(headings) -> list[str]:
    """A linked table of contents: markdown list lines for ``(level, text)`` headings (plain
    text, as shown), level 2 at the left; anchors by :class:`Slugger` over ``headings`` in order,
    so they match :func:`roadbank.report.html.md_to_html`'s ids and GitHub's when ``headings``
    are all the document's headings."""
    slug = Slugger()
    out = []
    for level, text in headings:
        anchor = slug(text)
        if level >= 2:
            out.append("  " * (level - 2) + f"- [{escape(text)}](#{anchor})")
    return out

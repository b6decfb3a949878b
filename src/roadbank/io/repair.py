"""The time-stamp repair of :func:`~roadbank.io.timebase.repair_time` applied to one channel of a
log, chunk by chunk, with the messages that name the file, the channel and the first row touched.

A log read whole is one chunk; a streamed log gives its chunks in order and the repair of each
continues the one before (:class:`ChunkRepair`), so both give the same samples and counts.

A table's clock is repaired once for all its columns. Before that, the rows of one instant are made
one row (:func:`one_instant`, :func:`instants`): a "long" table -- each channel, or each bus message,
on its own rows, blank elsewhere -- writes two channels sampled at the same instant on two rows with
the same stamp, which are one sample of each channel, not a repeated stamp. A stamp repeated for the
same channel stays a duplicate. In such a table the step between rows is no channel's sample period,
so its gaps are counted against the period of its fastest channel (:func:`interleaved_period`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

import numpy as np

from .errors import channel_error, channel_text
from .timebase import MISSING, OUT_OF_ORDER, TimeRepair, UnrepairableTime, add_counts, describe, repair_time

#: the signal roles whose values are set to NaN on a sample flagged by the time-stamp repair
FLAGGED_ROLES = ("speed", "lateral_acceleration", "yaw_rate", "road_wheel_angle", "steering_wheel_angle")
#: rows at the end of each streamed chunk held back for the next one, so that a bad time stamp at a
#: chunk's end is repaired knowing the stamps after it, as in the whole file
HOLD_ROWS = 4


def repair_stamps(source, column: str, t: np.ndarray, label: str = "time", after: float | None = None,
                  rownums=None, row_label: str = "sample",
                  min_period: float | None = None) -> tuple[TimeRepair, list[str]]:
    """:func:`~roadbank.io.timebase.repair_time` of one channel's stamps ``t`` (s), with its message.

    Returns the repair and a warning naming the file, the channel, what was repaired and the first
    line / row / sample it touched (an empty list when nothing was). ``rownums`` number the samples
    in messages (default: 0, 1, ...); ``after`` and ``min_period`` (s) as in
    :func:`~roadbank.io.timebase.repair_time`. Raises :class:`LogError` when the stamps cannot be repaired.
    """
    def row(i: int) -> str:
        return f"{row_label} {rownums[i] if rownums is not None else i}"

    try:
        rep = repair_time(t, after=after, min_period=min_period)
    except UnrepairableTime as exc:
        text = str(exc)
        if exc.at is not None:                   # name the sample by its row
            text = text.replace(f"at sample {exc.at}", f"at {row(exc.at)}")
        elif after is not None and len(t):       # a streamed chunk: say where it is
            lo, hi = (rownums[0], rownums[len(t) - 1]) if rownums is not None else (0, len(t) - 1)
            text += f" ({row_label}s {lo}-{hi})"
        raise channel_error(source, label, column, text) from None
    if not rep.changed:
        return rep, []
    touched = np.ones(len(t), dtype=bool)
    touched[rep.keep] = False
    touched[rep.keep[rep.flagged]] = True
    first = int(np.flatnonzero(touched)[0])
    n_flag = int(rep.flagged.sum())
    return rep, [channel_text(source, label, column, f"time stamps repaired: {describe(rep.counts)} (first at "
                              f"{row(first)}), {n_flag} sample(s) flagged not valid{_restart_note(t, rep, row)}")]


def _restart_note(t: np.ndarray, rep: TimeRepair, row) -> str:
    """`` -- the logger's clock restarts at <row> (...): ... kept <rows> (...), dropped <rows> (...)`` for a repair
    that kept one part of a drive whose clock restarts (``row(i)`` names input sample ``i``): the restart, the part
    kept and the parts dropped before and after it, each with its rows and the span of its stamps (s); '' for
    none."""
    if not rep.restarts or not len(rep.keep):
        return ""
    j = rep.restarts[0]
    before = t[:j][np.isfinite(t[:j])]
    back = f"from {before[-1]:.3f} s back to {t[j]:.3f} s" if len(before) else f"back to {t[j]:.3f} s"
    more = f" (and {len(rep.restarts) - 1} more time(s))" if len(rep.restarts) > 1 else ""
    k0, k1 = int(rep.keep[0]), int(rep.keep[-1])
    dropped = []
    for a, b in ((0, k0), (k1 + 1, len(t))):
        stamps = t[a:b][np.isfinite(t[a:b])]
        if len(stamps):
            dropped.append(f"{row(a)} to {row(b - 1)} ({stamps.min():.3f} to {stamps.max():.3f} s)")
    gone = f", the rest dropped: {' and '.join(dropped)}" if dropped else ""
    return (f" -- the logger's clock restarts at {row(j)} ({back}){more}: the parts are not spliced, only the "
            f"longest is kept: {row(k0)} to {row(k1)} ({t[k0]:.3f} to {t[k1]:.3f} s){gone}")


def repair_counts(rep: TimeRepair) -> dict:
    """The repair's counts (kind -> int) with ``flagged``: the samples flagged not valid."""
    return dict(rep.counts, flagged=int(rep.flagged.sum()))


class ChunkRepair:
    """The time-stamp repair of :func:`~roadbank.io.timebase.repair_time` on one channel, chunk by chunk.

    Each chunk is repaired after the last good stamp of the chunks before it, with the last
    :data:`HOLD_ROWS` rows held back and repaired with the next chunk (a chunk fed with
    ``last=True`` is repaired whole: a log read in one chunk is repaired exactly as
    :func:`~roadbank.io.timebase.repair_time` repairs it). :meth:`feed` takes the stamps (s), the
    arrays that go with them (same length) and the row numbers used in messages, and returns them
    repaired; ``counts`` adds up what was done (kind -> int, ``flagged`` too) until the caller takes
    it; the warning of the first chunk that needed a repair is given once.
    """

    def __init__(self, source, column: str, label: str, row_label: str = "row", hold_last: bool = False):
        self.source, self.column, self.label, self.row_label = source, column, label, row_label
        #: hold back the last row of every chunk, also of one that ends cleanly: the next chunk may open with
        #: a repeat of its stamp, which flags both samples (a table's rows are held so by :func:`instants`)
        self.hold_last = hold_last
        self.after: float | None = None
        #: (rownums, t, {name: array}) rows waiting for the next chunk
        self.held: tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]] | None = None
        self.carry = False       # the row before the held ones was dropped: flag the first one kept
        self.counts: dict = {}
        self.warned = False
        self.rows = 0            # rows fed, and rows kept, so far
        self.kept = 0

    def feed(self, t: np.ndarray, cols: dict, rownums, last: bool, min_period: float | None = None):
        """``(t, cols, flagged, warnings)`` of the rows that are final; ``last`` for the final chunk.

        ``t`` in s; ``rownums`` (one per row) number the rows in messages; ``min_period`` (s): a sample
        period longer than the stamps' median step, for counting gaps
        (:func:`~roadbank.io.timebase.count_gaps`; :func:`interleaved_period`).
        """
        rownums = np.asarray(rownums, dtype=np.int64)
        if self.held is not None:
            hr, ht, hc = self.held
            t = np.concatenate([ht, t])
            cols = {c: np.concatenate([hc[c], a]) for c, a in cols.items()}
            rownums = np.concatenate([hr, rownums])
            self.held = None
        n = len(t)
        rep, warns = repair_stamps(self.source, self.column, t, label=self.label, after=self.after,
                                   rownums=rownums, row_label=self.row_label, min_period=min_period)
        if self.carry and len(rep.keep):     # as the whole file's repair: the sample after a dropped one
            rep.flagged[0] = True
        self.carry = False
        # the dropped part after a clock restart is final: no later stamp brings it back
        after_restart = bool(rep.restarts) and (not len(rep.keep) or int(rep.keep.max()) < rep.restarts[-1])
        odd = not last and not after_restart and _odd_tail(t, rep)
        if odd or (not last and not after_restart and self.hold_last and n):
            cut = max(n - (HOLD_ROWS if odd else 1), 0)
            late = np.flatnonzero(rep.keep >= cut)
            c0 = min(cut, int(rep.keep[late[0]:].min())) if len(late) else cut
            self.carry = bool(0 < c0 < n and rep.kind[c0 - 1] in (MISSING, OUT_OF_ORDER))
            rep = rep.head(c0, t, self.after, min_period)
            if c0 < n:
                self.held = (rownums[c0:], t[c0:], {c: a[c0:] for c, a in cols.items()})
        self.counts = add_counts(self.counts, repair_counts(rep))
        if rep.changed and not self.warned:
            self.warned = True
        else:
            warns = []
        keep = rep.keep
        self.rows += len(rep.kind)
        self.kept += len(keep)
        if last and self.rows and self.kept < 2 and self.label in ("time", *FLAGGED_ROLES):   # (not a GNSS fix)
            raise channel_error(self.source, self.label, self.column, "no increasing time base: fewer than two "
                                f"distinct stamps ({self.rows} {self.row_label}{'s' if self.rows != 1 else ''})")
        if len(keep):
            self.after = float(t[keep[-1]])
        if len(keep) == n and not np.any(rep.kind):      # every row kept, in order: no copies
            return t, dict(cols), rep.flagged, warns
        return t[keep], {c: a[keep] for c, a in cols.items()}, rep.flagged, warns

    def take_counts(self) -> dict:
        """The counts added up since the last call (kind -> int), and start again from none."""
        counts, self.counts = self.counts, {}
        return counts

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


def one_instant(t: np.ndarray, cols: dict, rownums, skip: str) -> tuple[np.ndarray, dict, np.ndarray]:
    """A table's neighbouring rows that share a time stamp and carry different channels, as one row.

    Parameters
    ----------
    t : array (s)
        The table's stamps, row for row.
    cols : dict column -> array
        The columns as stored, row for row; ``skip`` (the time column) is carried along.
    rownums : int array
        The rows' numbers in messages; a merged row keeps its first row's.
    skip : str
        The time column (every row carries it).

    Returns
    -------
    (t, cols, rownums)
        The rows, merged: a row goes into the first row of its stamp that carries none of its columns
        (finite values); each column of a merged row is its value in the row where it is finite. A row
        carrying a column that every earlier row of its stamp carries too stays a row of its own: a
        stamp repeated for the same channel, which the time-stamp repair drops and counts as a
        duplicate. A row with every column blank adds nothing and is merged. The inputs themselves
        when no two neighbouring rows share a stamp.
    """
    n = len(t)
    same = t[1:] == t[:-1]
    if n < 2 or not same.any():
        return t, cols, np.asarray(rownums)
    names = [c for c in cols if c != skip]
    fin = np.zeros((n, len(names)), dtype=bool)
    for j, c in enumerate(names):
        fin[:, j] = np.isfinite(cols[c])
    start = np.concatenate(([True], ~same))
    starts = np.flatnonzero(start)
    ends = np.append(starts[1:], n)
    group = np.cumsum(start) - 1
    slot = np.zeros(n, dtype=np.int64)               # the merged row of its stamp that each row goes into
    n_slots = np.ones(len(starts), dtype=np.int64)
    per_stamp = np.add.reduceat(fin.astype(np.int64), starts, axis=0)     # rows carrying each column, per stamp
    clash = np.any(per_stamp > 1, axis=1)
    for g in np.flatnonzero(clash).tolist():        # a column on two rows of one stamp: first fit, row by row
        taken: list[np.ndarray] = []
        for i in range(int(starts[g]), int(ends[g])):
            k = next((k for k, used in enumerate(taken) if not (used & fin[i]).any()), len(taken))
            if k == len(taken):
                taken.append(fin[i].copy())
            else:
                taken[k] |= fin[i]
            slot[i] = k
        n_slots[g] = len(taken)
    out = np.concatenate(([0], np.cumsum(n_slots)[:-1]))[group] + slot
    first = np.full(int(n_slots.sum()), n, dtype=np.int64)
    np.minimum.at(first, out, np.arange(n))
    merged = {}
    for c, a in cols.items():
        v = a[first]
        if c != skip:
            f = fin[:, names.index(c)]
            v[out[f]] = a[f]
        merged[c] = v
    return t[first], merged, np.asarray(rownums)[first]


def instants(chunks: Iterable, column: str,
             to_s: Callable[[np.ndarray], np.ndarray]) -> Iterator[tuple[bool, np.ndarray, dict, np.ndarray]]:
    """A table source's chunks (:class:`~roadbank.io.types.RawChunk`) with the rows of one instant merged
    (:func:`one_instant`): ``(last, t, columns, rownums)`` per chunk, ``t`` (s) the time ``column``
    converted by ``to_s``.

    A chunk is given when the next one has been read: the rows at the start of the next that share the
    stamp the chunk ends on are moved into it, so an instant that a chunk boundary splits is merged as
    in the whole file. A table without shared stamps keeps its chunks as they are.
    """
    held: tuple[np.ndarray, dict, np.ndarray] | None = None     # (t, columns, rownums) of the chunk before
    for chunk in chunks:
        t, cols, rows = to_s(chunk.data[column]), chunk.data, np.asarray(chunk.rownums)
        if held is not None:
            ht, hc, hr = held
            eq = t == ht[-1] if len(ht) else np.zeros(len(t), dtype=bool)
            k = len(t) if eq.all() else int(np.argmin(eq))
            if k:
                held = (np.concatenate([ht, t[:k]]), {c: np.concatenate([a, cols[c][:k]]) for c, a in hc.items()},
                        np.concatenate([hr, rows[:k]]))
                t, cols, rows = t[k:], {c: a[k:] for c, a in cols.items()}, rows[k:]
            if not len(t) and not chunk.last:     # nothing after that stamp in this chunk: read on
                continue
            yield (False, *one_instant(held[0], held[1], held[2], column))
        held = (t, cols, rows)
        if chunk.last:
            yield (True, *one_instant(t, cols, rows, column))
            return


def interleaved_period(t: np.ndarray, cols: dict, columns) -> float | None:
    """The sample period (s) of the fastest of ``columns`` on a table clock ``t`` (s) whose rows interleave
    the channels' samples: the shortest median step between a column's finite values, when it is more
    than 1 % longer than the clock's median step (the rows do not each carry every channel: a long table,
    channels at different stamps); None otherwise (a channel comes at the clock's rate)."""
    ok = np.isfinite(t)
    d = np.diff(t[ok])
    d = d[d > 0]
    if not len(d):
        return None
    periods = []
    for c in columns:
        if c in cols:
            dc = np.diff(t[ok & np.isfinite(cols[c])])
            dc = dc[dc > 0]
            if len(dc):
                periods.append(float(np.median(dc)))
    if not periods or min(periods) <= 1.01 * float(np.median(d)):
        return None
    return min(periods)

"""The time-stamp repair of :func:`~roadbank.io.timebase.repair_time` applied to one channel of a
log, chunk by chunk, with the messages that name the file, the channel and the first row touched.

A log read whole is one chunk; a streamed log gives its chunks in order and the repair of each
continues the one before (:class:`ChunkRepair`), so both give the same samples and counts.
"""

from __future__ import annotations

import numpy as np

from .errors import channel_error, channel_text
from .timebase import MISSING, OUT_OF_ORDER, TimeRepair, UnrepairableTime, add_counts, describe, repair_time

#: the signal roles whose values are set to NaN on a sample flagged by the time-stamp repair
FLAGGED_ROLES = ("speed", "lateral_acceleration", "yaw_rate", "road_wheel_angle", "steering_wheel_angle")
#: rows at the end of each streamed chunk held back for the next one, so that a bad time stamp at a
#: chunk's end is repaired knowing the stamps after it, as in the whole file
HOLD_ROWS = 4


def repair_stamps(source, column: str, t: np.ndarray, label: str = "time", after: float | None = None,
                  rownums=None, row_label: str = "sample") -> tuple[TimeRepair, list[str]]:
    """:func:`~roadbank.io.timebase.repair_time` of one channel's stamps ``t`` (s), with its message.

    Returns the repair and a warning naming the file, the channel, what was repaired and the first
    line / row / sample it touched (an empty list when nothing was). ``rownums`` number the samples
    in messages (default: 0, 1, ...). Raises :class:`LogError` when the stamps cannot be repaired.
    """
    def row(i: int) -> str:
        return f"{row_label} {rownums[i] if rownums is not None else i}"

    try:
        rep = repair_time(t, after=after)
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
    """`` -- the logger's clock restarts at <row> (...): ... kept <rows> (...)`` for a repair that kept
    one part of a drive whose clock restarts (``row(i)`` names input sample ``i``); '' for none."""
    if not rep.restarts or not len(rep.keep):
        return ""
    j = rep.restarts[0]
    before = t[:j][np.isfinite(t[:j])]
    back = f"from {before[-1]:.3f} s back to {t[j]:.3f} s" if len(before) else f"back to {t[j]:.3f} s"
    more = f" (and {len(rep.restarts) - 1} more time(s))" if len(rep.restarts) > 1 else ""
    k0, k1 = int(rep.keep[0]), int(rep.keep[-1])
    return (f" -- the logger's clock restarts at {row(j)} ({back}){more}: the parts are not spliced, only the "
            f"longest is kept: {row(k0)} to {row(k1)} ({t[k0]:.3f} to {t[k1]:.3f} s)")


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

    def __init__(self, source, column: str, label: str, row_label: str = "row"):
        self.source, self.column, self.label, self.row_label = source, column, label, row_label
        self.after: float | None = None
        #: (rownums, t, {name: array}) rows waiting for the next chunk
        self.held: tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]] | None = None
        self.carry = False       # the row before the held ones was dropped: flag the first one kept
        self.counts: dict = {}
        self.warned = False
        self.rows = 0            # rows fed, and rows kept, so far
        self.kept = 0

    def feed(self, t: np.ndarray, cols: dict, rownums, last: bool):
        """``(t, cols, flagged, warnings)`` of the rows that are final; ``last`` for the final chunk.

        ``rownums`` (one per row) number the rows in messages.
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
                                   rownums=rownums, row_label=self.row_label)
        if self.carry and len(rep.keep):     # as the whole file's repair: the sample after a dropped one
            rep.flagged[0] = True
        self.carry = False
        # the dropped part after a clock restart is final: no later stamp brings it back
        after_restart = bool(rep.restarts) and (not len(rep.keep) or int(rep.keep.max()) < rep.restarts[-1])
        if not last and not after_restart and _odd_tail(t, rep):
            cut = max(n - HOLD_ROWS, 0)
            late = np.flatnonzero(rep.keep >= cut)
            c0 = min(cut, int(rep.keep[late[0]:].min())) if len(late) else cut
            self.carry = bool(0 < c0 < n and rep.kind[c0 - 1] in (MISSING, OUT_OF_ORDER))
            rep = rep.head(c0, t, self.after)
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

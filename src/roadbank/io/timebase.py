"""Repairing a logger's time stamps: one pure rule used by every reader (whole file and streamed).

Loggers write duplicated, swapped and jumping time stamps. :func:`repair_time` keeps every sample
it can place on a strictly increasing time base and says what it did:

* a **missing** stamp (NaN / inf) -- the sample is dropped;
* a **duplicate** stamp (equal to the one before) -- the later sample is dropped, the first kept;
* a **swapped** pair (two neighbours in the wrong order, each in order with the samples around
  them) -- the two samples are put back in time order;
* an **out-of-order** stamp (an isolated bad stamp, or the samples of a short backwards jump) --
  the fewest samples that leave an increasing time base are dropped (the longest increasing run
  of stamps is kept);
* a forward jump (a **gap** longer than :data:`GAP_PERIODS` sample periods) -- kept as it is (the
  estimators re-initialise after a long gap); only counted. The sample period is the median step of
  the stamps, or a longer one the caller knows (``min_period``: a table whose rows interleave the
  samples of channels at different stamps, where the step between rows is no channel's period);
* a **clock restart** -- the stamps go back by more than :data:`GAP_PERIODS` periods and no drop
  of at most that many samples mends them (the clock restarted, e.g. at 0, or stepped back and runs
  on from there; a log written twice): any increasing run would splice two parts of the drive and
  hide the time between them, so the part between restarts with the most samples is kept and the
  others are dropped (counted as out of order; the warning names the restart and what was kept).
  In a log read in chunks the part before a restart may have been passed on already: a restart
  is repaired so within the first chunk only, and refused after it.

Samples next to a repair (a reordered pair, the first sample of a duplicate, the sample after a
dropped one) are *flagged*: the readers set their values to NaN, so the estimators hold their
output there and flag it not valid. Two stamps that end up next to each other after samples
between them were dropped, less than half a period apart (two parts of a drive meeting at
almost the same stamp), are a duplicate: the later one is dropped, the first flagged. A time base
that cannot be repaired -- fewer than two distinct stamps, more than half of the stamps dropped,
or more than half of the kept ones repeated (every stamp written twice, or a clock coarser than
the sample rate: the value of a repeated stamp is not trusted) -- raises :class:`UnrepairableTime`.
"""

from __future__ import annotations

from bisect import bisect_left
from dataclasses import dataclass

import numpy as np

#: a forward step longer than this many median sample periods is counted as a gap
GAP_PERIODS = 5.0
#: repair kinds, in the order they are reported
KINDS = ("missing", "duplicate", "swapped", "out_of_order", "gaps")


class UnrepairableTime(ValueError):
    """The stamps hold no increasing time base (the message says why, without file or channel).

    ``at``: the index of the sample the message is about (a clock restart), or None; the message then
    ends where the caller adds ``at <row>``."""

    def __init__(self, message: str, at: int | None = None):
        super().__init__(message)
        self.at = at


#: per-sample codes of :attr:`TimeRepair.kind`
KEPT, MISSING, DUPLICATE, OUT_OF_ORDER, SWAPPED = 0, 1, 2, 3, 4
_DROP_KINDS = {MISSING: "missing", DUPLICATE: "duplicate", OUT_OF_ORDER: "out_of_order"}


@dataclass(frozen=True)
class TimeRepair:
    """What :func:`repair_time` did to one series of time stamps.

    Attributes
    ----------
    keep : int array
        Indices of the input samples to use, in time order (their stamps strictly increase).
    flagged : bool array, len(keep)
        Kept samples next to a repair, whose values are not to be trusted.
    kind : int8 array, one per input sample
        :data:`KEPT`, :data:`SWAPPED` (kept, reordered) or why it was dropped (:data:`MISSING`,
        :data:`DUPLICATE`, :data:`OUT_OF_ORDER`).
    gaps : int
        Forward jumps longer than :data:`GAP_PERIODS` median periods among the kept stamps (kept).
    restarts : tuple of int
        Input indices where the clock restarts (the first sample after the step back); the samples of
        the parts not kept are dropped as :data:`OUT_OF_ORDER`.
    """

    keep: np.ndarray
    flagged: np.ndarray
    kind: np.ndarray
    gaps: int = 0
    restarts: tuple = ()

    @property
    def counts(self) -> dict:
        """kind -> int for every kind of :data:`KINDS`: ``missing``, ``duplicate``, ``out_of_order``:
        samples dropped; ``swapped``: pairs reordered; ``gaps``: forward jumps kept."""
        c = np.bincount(self.kind, minlength=5)
        return {"missing": int(c[MISSING]), "duplicate": int(c[DUPLICATE]), "swapped": int(c[SWAPPED]) // 2,
                "out_of_order": int(c[OUT_OF_ORDER]), "gaps": int(self.gaps)}

    @property
    def changed(self) -> bool:
        """True if a sample was dropped, reordered or flagged (gaps alone change nothing)."""
        return bool(np.any(self.kind != KEPT) or self.flagged.any())

    def head(self, n: int, t, after: float | None = None, min_period: float | None = None) -> "TimeRepair":
        """The repair of the first ``n`` input samples only (a streamed chunk without the rows held
        back for the next one): kept samples with an index below ``n``, their gaps recounted on
        ``t`` (the stamps repaired, s) after ``after`` (s), as :func:`count_gaps` with ``min_period`` (s)."""
        sel = self.keep < n
        keep = self.keep[sel]
        return TimeRepair(keep, self.flagged[sel], self.kind[:n], count_gaps(np.asarray(t)[keep], after, min_period),
                          tuple(j for j in self.restarts if j < n))


def count_gaps(tk: np.ndarray, after: float | None = None, min_period: float | None = None) -> int:
    """Forward steps of the increasing stamps ``tk`` (s) longer than :data:`GAP_PERIODS` sample periods
    (the step from ``after``, s, when given, included). The sample period is the median step, or
    ``min_period`` (s) when that is longer: the period of the fastest channel of a table whose rows
    interleave channels sampled at different stamps."""
    if after is not None:
        tk = np.concatenate(([after], tk))
    if len(tk) < 3:
        return 0
    d = np.diff(tk)
    period = float(np.median(d))
    if min_period is not None and min_period > period:
        period = float(min_period)
    return int(np.count_nonzero(d > GAP_PERIODS * period))


def _lis(values: np.ndarray) -> np.ndarray:
    """Positions of one longest strictly increasing subsequence of ``values`` (O(n log n))."""
    tails: list[float] = []     # smallest tail value of an increasing run of each length
    tail_pos: list[int] = []
    prev = np.full(len(values), -1, dtype=np.int64)
    for i, v in enumerate(values.tolist()):
        k = bisect_left(tails, v)
        if k == len(tails):
            tails.append(v)
            tail_pos.append(i)
        else:
            tails[k] = v
            tail_pos[k] = i
        prev[i] = tail_pos[k - 1] if k else -1
    out = []
    i = tail_pos[-1] if tail_pos else -1
    while i >= 0:
        out.append(i)
        i = int(prev[i])
    return np.asarray(out[::-1], dtype=np.int64)


def _swap_pairs(t: np.ndarray) -> np.ndarray:
    """Positions i whose pair (i, i+1) is swapped: t[i] > t[i+1], both in order once exchanged."""
    c = np.flatnonzero(t[1:] < t[:-1])
    prev_ok = np.ones(len(c), dtype=bool)
    inner = c > 0
    prev_ok[inner] = t[c[inner] - 1] < t[c[inner] + 1]
    next_ok = np.ones(len(c), dtype=bool)
    inner = c + 2 < len(t)
    next_ok[inner] = t[c[inner]] < t[c[inner] + 2]
    return c[prev_ok & next_ok]


def _isolated(t: np.ndarray) -> np.ndarray:
    """Positions of isolated bad stamps: out of order with a neighbour, while the neighbours on
    either side are in order with each other (a stamp too high or too low on its own)."""
    n = len(t)
    bad = np.zeros(n, dtype=bool)
    if n < 3:
        return np.flatnonzero(bad)
    mid = np.arange(1, n - 1)
    around = t[mid - 1] < t[mid + 1]
    bad[mid] = around & ((t[mid] >= t[mid + 1]) | (t[mid] <= t[mid - 1]))
    # the first and last stamps have one neighbour: out of order with it and not explained by
    # that neighbour being the bad one
    bad[0] = t[0] >= t[1] and not bad[1]
    bad[n - 1] = t[n - 1] <= t[n - 2] and not bad[n - 2]
    return np.flatnonzero(bad)


def repair_time(t, after: float | None = None, min_period: float | None = None) -> TimeRepair:
    """The samples of ``t`` that make a strictly increasing time base, and what was repaired.

    Parameters
    ----------
    t : array (s)
        Time stamps in file order.
    after : float (s), optional
        The last good stamp before ``t`` (a streamed log's previous chunk): samples not later than
        it are dropped as out of order (or as a duplicate when equal to it).
    min_period : float (s), optional
        A sample period longer than the stamps' median step, for counting gaps (:func:`count_gaps`).

    Returns
    -------
    TimeRepair
        ``keep`` indexes ``t``; ``t[keep]`` strictly increases.

    Raises
    ------
    UnrepairableTime
        Fewer than two distinct stamps (without ``after``), more than half the stamps dropped, more
        than half of the kept ones repeated, or (with ``after``) a clock restart.
    """
    t = np.asarray(t, dtype=np.float64)
    n = len(t)
    kind = np.zeros(n, dtype=np.int8)
    follows_drop = np.zeros(n, dtype=bool)     # (original index) the sample after a dropped one
    flag = np.zeros(n, dtype=bool)
    repeated = np.zeros(n, dtype=bool)         # (original index) kept first sample of a repeated stamp
    restarts: tuple = ()
    finite = np.isfinite(t)
    idx = np.flatnonzero(finite)
    kind[~finite] = MISSING
    if not finite.all():
        follows_drop[np.flatnonzero(~finite[:-1] & finite[1:]) + 1] = True

    def drop(pos_mask: np.ndarray, code: int, flag_next: bool = True) -> None:
        nonlocal idx
        if not pos_mask.any():
            return
        kind[idx[pos_mask]] = code
        if flag_next:
            follower = np.flatnonzero(pos_mask) + 1
            follows_drop[idx[follower[follower < len(idx)]]] = True
        idx = idx[~pos_mask]

    if after is not None and len(idx):
        drop(t[idx] == after, DUPLICATE, flag_next=False)
        drop(t[idx] < after, OUT_OF_ORDER)
    if len(idx) > 1 and not np.all(np.diff(t[idx]) > 0):
        # 1. swapped neighbours: exchange them
        sw = _swap_pairs(t[idx])
        if len(sw):
            a, b = idx[sw].copy(), idx[sw + 1].copy()
            idx[sw], idx[sw + 1] = b, a
            kind[a] = kind[b] = SWAPPED
            flag[a] = flag[b] = True
        # 2. repeated stamps: the first kept
        tt = t[idx]
        dup = np.concatenate(([False], tt[1:] == tt[:-1]))
        if dup.any():
            repeated[idx[np.flatnonzero(dup) - 1]] = True
            drop(dup, DUPLICATE, flag_next=False)
        # 3. isolated bad stamps (too high or too low on their own)
        iso = _isolated(t[idx])
        if len(iso):
            m = np.zeros(len(idx), dtype=bool)
            m[iso] = True
            drop(m, OUT_OF_ORDER)
        # 4. what is left out of order (backwards jumps): keep the longest increasing run of one part
        # of the drive (never two parts spliced at a clock restart)
        tt = t[idx]
        if len(tt) > 1 and not np.all(np.diff(tt) > 0):
            period = _period(tt)
            keep, cuts = _one_part(tt, period)
            if cuts and after is not None:
                j = int(idx[cuts[0]])
                raise UnrepairableTime(_restart_refused(float(tt[cuts[0] - 1]), float(t[j]), j), at=j)
            restarts = tuple(int(i) for i in idx[cuts])
            near = _near_joins(tt, keep, period)
            k = np.flatnonzero(keep)
            repeated[idx[k[np.searchsorted(k, np.flatnonzero(near)) - 1]]] = True   # the kept one before
            drop(~keep, OUT_OF_ORDER)
            drop(near[keep], DUPLICATE, flag_next=False)
    if after is not None:
        _check_no_restart(t, idx, after)
    lost = int(np.count_nonzero((kind != KEPT) & (kind != SWAPPED)))
    where = f" (the clock restarts {len(restarts)} time(s), first at sample {restarts[0]})" if restarts else ""
    if n >= 2 and after is None and len(idx) < 2:
        fin = t[finite]
        what = (f"all {n} stamps equal ({float(fin[0])!r})" if len(fin) == n and np.all(fin == fin[0])
                else f"only {len(idx)} of {n} stamps in increasing order")
        raise UnrepairableTime(f"no increasing time base: {what}{where}", at=restarts[0] if restarts else None)
    if n and lost > n / 2:
        raise UnrepairableTime(f"no increasing time base: {lost} of {n} stamps missing, repeated or "
                               f"out of order{where}", at=restarts[0] if restarts else None)
    n_rep = int(np.count_nonzero(repeated[idx]))
    if n_rep > len(idx) / 2:
        what = "every stamp is repeated" if n_rep >= len(idx) - 1 else f"{n_rep} of {len(idx)} stamps repeated"
        raise UnrepairableTime(f"no increasing time base: {what} (every row written twice, or a clock coarser "
                               "than the sample rate?), and the value at a repeated stamp is not trusted")
    flagged = flag[idx] | repeated[idx] | follows_drop[idx]
    usable = int(np.count_nonzero(~flagged))
    if n >= 2 and after is None and usable < 2:    # every kept sample next to a bad stamp
        missing = int(np.count_nonzero(~finite))
        bad = [f"{k} of {n} stamps {why}" for k, why in ((missing, "missing (not numbers)"),
                                                          (lost - missing, "out of order or repeated")) if k]
        raise UnrepairableTime(f"no increasing time base: {' and '.join(bad) or 'stamps swapped or repeated'}; "
                               f"the samples next to them are not trusted, which leaves {usable} of {n} usable")
    return TimeRepair(keep=idx, flagged=flagged, kind=kind,
                      gaps=count_gaps(t[idx], after, min_period), restarts=restarts)


def _period(t: np.ndarray) -> float:
    """The median of the positive steps of stamps ``t`` (s): the sample period; NaN without one."""
    d = np.diff(t)
    d = d[d > 0]
    return float(np.median(d)) if len(d) else np.nan


def _restart_refused(before: float, after: float, j: int) -> str:
    """The message for a clock restart in a log read in chunks (the part before it is passed on already)."""
    return (f"no increasing time base: the clock restarts at sample {j} (from {before:.3f} s back to "
            f"{after:.3f} s), and read in chunks the part before it is passed on already and cannot be dropped "
            "(read the log in one chunk: --chunk-rows above its length)")


def _check_no_restart(t: np.ndarray, idx: np.ndarray, after: float) -> None:
    """UnrepairableTime if a streamed chunk's stamps ``t`` (``idx`` kept), read on from ``after`` (the last
    stamp passed on), hold a clock restart (:func:`_restarts`, ``after`` as the first kept stamp)."""
    if len(t) - len(idx) <= GAP_PERIODS:         # a restart drops more samples than that
        return
    fin = np.flatnonzero(np.isfinite(t))
    kept = np.zeros(len(t), dtype=bool)
    kept[idx] = True
    seg = np.concatenate(([after], t[fin]))
    keep = np.concatenate(([True], kept[fin]))
    p = _period(seg)
    found = _restarts(seg, keep, p) if np.isfinite(p) else []
    if found:
        j = int(fin[found[0] - 1])
        raise UnrepairableTime(_restart_refused(float(seg[found[0] - 1]), float(t[j]), j), at=j)


def _restarts(seg: np.ndarray, keep: np.ndarray, p: float) -> list[int]:
    """Positions in ``seg`` where the clock restarts, given the longest increasing run ``keep`` and the
    period ``p`` (s): more than :data:`GAP_PERIODS` samples dropped between two kept ones (or before the
    first, after the last), among them a step back of more than that many periods, and the dropped
    samples' time not in the kept stamps (their count minus the periods the stamps move on across
    them above :data:`GAP_PERIODS`). The position is that of the largest step back."""
    n = len(seg)
    k = np.flatnonzero(keep)
    a = np.concatenate(([-1], k))
    b = np.concatenate((k, [n]))
    out = []
    for i in np.flatnonzero(b - a - 1 > GAP_PERIODS).tolist():
        lo, hi = max(int(a[i]), 0), min(int(b[i]), n - 1)
        back = seg[lo:hi] - seg[lo + 1:hi + 1]
        j = int(np.argmax(back))
        if back[j] <= GAP_PERIODS * p:
            continue
        if a[i] >= 0 and b[i] < n and (b[i] - a[i]) * p - (seg[b[i]] - seg[a[i]]) <= GAP_PERIODS * p:
            continue                      # the dropped samples' time is in the stamps: a glitch
        out.append(lo + 1 + j)
    return out


def _one_part(tt: np.ndarray, p: float) -> tuple[np.ndarray, list[int]]:
    """(mask of the samples of ``tt`` to keep, positions of the clock restarts): the longest increasing
    run, within the part between restarts with the most samples (the earlier on a tie), found again
    in that part until it has no restart (or holds less than half the samples: refused after)."""
    lo, hi, cuts = 0, len(tt), []
    keep = _in_longest_run(tt)
    found = _restarts(tt, keep, p) if np.isfinite(p) else []
    while found and 2 * (hi - lo) >= len(tt):
        edges = [lo] + [lo + j for j in found] + [hi]
        cuts += edges[1:-1]
        lo, hi = max(zip(edges[:-1], edges[1:]), key=lambda e: e[1] - e[0])
        keep = _in_longest_run(tt[lo:hi])
        found = _restarts(tt[lo:hi], keep, p)
    mask = np.zeros(len(tt), dtype=bool)
    mask[lo:hi] = keep
    return mask, sorted(cuts)


def _near_joins(tt: np.ndarray, keep: np.ndarray, p: float) -> np.ndarray:
    """Mask of the kept samples of ``tt`` less than half a period ``p`` after the kept one before them
    while samples between the two are dropped: two stretches meeting at almost the same stamp."""
    k = np.flatnonzero(keep)
    out = np.zeros(len(tt), dtype=bool)
    if len(k) > 1 and np.isfinite(p):
        join = (np.diff(k) > 1) & (np.diff(tt[k]) < 0.5 * p)
        out[k[1:][join]] = True
    return out


def _in_longest_run(t: np.ndarray) -> np.ndarray:
    """Mask of one longest strictly increasing subsequence of ``t``.

    Only the disordered stretches are searched: a stamp above every stamp before it and below
    every stamp after it belongs to some longest run, and splits the problem.
    """
    pre = np.concatenate(([-np.inf], np.maximum.accumulate(t)[:-1]))
    suf = np.concatenate((np.minimum.accumulate(t[::-1])[::-1][1:], [np.inf]))
    safe = (t > pre) & (t < suf)
    keep = safe.copy()
    bad = np.flatnonzero(~safe)
    if len(bad):
        # runs of consecutive unsafe positions
        breaks = np.flatnonzero(np.diff(bad) > 1)
        starts = np.concatenate(([bad[0]], bad[breaks + 1]))
        ends = np.concatenate((bad[breaks], [bad[-1]])) + 1
        for s, e in zip(starts.tolist(), ends.tolist()):
            keep[s + _lis(t[s:e])] = True
    return keep


def stretch_order(t) -> tuple[np.ndarray, int] | None:
    """The order that puts stretches of rows written out of their place back in time order, where that
    mixes no two parts of the clock; None where there is nothing to move or no such order.

    The stamps ``t`` (s) are cut into increasing runs: at every step that does not go forward, and at
    every forward step longer than :data:`GAP_PERIODS` sample periods (the median forward step), so a
    block of rows written before the rows that come before it in time is a run of its own. Runs whose
    time spans overlap (or touch: a repeated stamp) are one stretch, kept in file order: a swapped pair,
    a repeated stamp or a clock that steps back (the samples after it overlap those before it in time)
    stay for :func:`repair_time`, which never interleaves two parts of a drive. The stretches, which
    then cover disjoint spans of time, are put in the order of their times (a stable sort).

    The order is refused (None) if it would open a forward step longer than :data:`GAP_PERIODS`
    periods between two rows that are not neighbours in the file: the moved rows would not fill a
    hole but stand apart from the others (a clock reset to an earlier time, which :func:`repair_time`
    names a restart). Rows without a finite stamp stay after the finite row before them in the file.

    Parameters
    ----------
    t : array (s)
        Time stamps in file order.

    Returns
    -------
    (order, moved) or None
        ``order``: indices of the rows in their new order (``t[order]``), ``moved``: rows whose place
        changed; None where every row stays.
    """
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    n = len(t)
    fin = np.flatnonzero(np.isfinite(t))
    tf = t[fin]
    d = np.diff(tf)
    if len(tf) < 3 or np.all(d > 0) or not np.any(d > 0):
        return None
    period = float(np.median(d[d > 0]))
    cut = np.flatnonzero((d <= 0) | (d > GAP_PERIODS * period)) + 1
    starts = np.concatenate(([0], cut))
    ends = np.concatenate((cut, [len(tf)]))             # (exclusive)
    lo, hi = tf[starts], tf[ends - 1]
    by_start = np.argsort(lo, kind="stable")
    reach = np.maximum.accumulate(hi[by_start])
    opens = np.concatenate(([True], lo[by_start][1:] > reach[:-1]))     # a run past every span before it
    stretch = np.empty(len(starts), dtype=np.int64)
    stretch[by_start] = np.cumsum(opens) - 1            # stretches numbered in time order
    row_stretch = np.repeat(stretch, ends - starts)
    new = np.argsort(row_stretch, kind="stable")        # (positions among the finite rows)
    if np.array_equal(new, np.arange(len(tf))):
        return None
    long = np.flatnonzero(np.diff(tf[new]) > GAP_PERIODS * period)
    if np.any(new[long + 1] != new[long] + 1):
        return None
    # every row follows its finite row before it in the file (a leading row without one, the first finite row)
    last_finite = np.maximum.accumulate(np.where(np.isfinite(t), np.arange(n), -1))
    last_finite[last_finite < 0] = fin[0]
    key = np.empty(n, dtype=np.int64)
    key[fin] = np.argsort(new)                          # each finite row's new place
    order = np.argsort(key[last_finite], kind="stable")
    return order, int(np.count_nonzero(order != np.arange(n)))


def describe(counts: dict) -> str:
    """``counts`` in words, e.g. ``"2 duplicate stamps dropped, 1 swapped pair reordered"`` ('' if none)."""
    text = {"missing": ("missing stamp", "dropped"), "duplicate": ("duplicate stamp", "dropped"),
            "swapped": ("swapped pair", "reordered"), "out_of_order": ("out-of-order stamp", "dropped"),
            "gaps": ("gap", "kept")}
    parts = []
    for k in KINDS:
        v = int(counts.get(k, 0))
        if v:
            noun, verb = text[k]
            parts.append(f"{v} {noun}{'s' if v != 1 else ''} {verb}")
    return ", ".join(parts)


def add_counts(total: dict, more: dict) -> dict:
    """``total`` with ``more`` added kind by kind (both dicts kind -> int)."""
    out = dict(total)
    for k, v in more.items():
        out[k] = out.get(k, 0) + int(v)
    return out


def add_channel_counts(total: dict, more: dict) -> dict:
    """``total`` with ``more`` added channel by channel, kind by kind (both dicts channel -> kind -> int)."""
    out = dict(total)
    for ch, counts in more.items():
        out[ch] = add_counts(out.get(ch, {}), counts)
    return out


def summed(by_channel: dict) -> dict:
    """The counts of every channel added up (channel -> kind -> int, to kind -> int)."""
    total: dict = {}
    for counts in by_channel.values():
        total = add_counts(total, counts)
    return total

"""Whole-log decisions for a log read in chunks: exact medians in bounded memory.

``time_base = "auto"`` (:func:`~roadbank.io.resample.common_time_base`) keeps a table's clock when
every channel's valid samples come at the clock's median period (to 1 %). On a log read in chunks
that needs the medians of the whole log before its first chunk is given, without holding the log.

:class:`ExactMedian` finds the median of positive numbers passed to it in one pass or more: the
first pass counts them in bins of their leading 28 bits (relative width 2^-16), each further
pass splits the one or two bins holding the middle into 2^18 finer bins, until the third pass
knows the values bit for bit. :func:`auto_uses_clock` asks for a further pass only while the
bounds so found cannot decide the rule; in practice one pass decides.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

import numpy as np

#: bits below each level's bins: 28 leading bits, then 18 + 18 more
SHIFTS = (36, 18, 0)


def _bits(x: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64).view(np.uint64)


def _value(bits: int) -> float:
    return float(np.array([bits], dtype=np.uint64).view(np.float64)[0])


class ExactMedian:
    """The median of a stream of positive finite numbers (``numpy.median``'s), found in passes.

    Each pass: :meth:`add` every number (in chunks, any order), then :meth:`end_pass`.
    :meth:`bounds` gives an interval holding the median; :attr:`exact` says whether it is one point.
    """

    def __init__(self):
        self.n = 0
        self.level = 0
        self.sparse: dict[int, int] = {}
        self.targets: list[list[int]] = []     # per middle rank: [rank, lo bits, count below lo]
        self.hist: list[np.ndarray] = []

    def add(self, x: np.ndarray) -> None:
        u = _bits(x)
        if self.level == 0:
            self.n += len(u)
            keys, counts = np.unique(u >> np.uint64(SHIFTS[0]), return_counts=True)
            for k, c in zip(keys.tolist(), counts.tolist()):
                self.sparse[k] = self.sparse.get(k, 0) + c
            return
        shift, width = SHIFTS[self.level], SHIFTS[self.level - 1]
        for (_, lo, _), h in zip(self.targets, self.hist):
            sel = u[(u >= np.uint64(lo)) & (u < np.uint64(lo + (1 << width)))]
            h += np.bincount(((sel - np.uint64(lo)) >> np.uint64(shift)).astype(np.int64),
                             minlength=len(h))[:len(h)]

    def end_pass(self) -> None:
        """Narrow each middle rank to its bin of this pass."""
        if self.level == 0:
            if self.n == 0:
                self.level = 1
                return
            keys = sorted(self.sparse)
            cum = np.cumsum([self.sparse[k] for k in keys])
            ranks = sorted({(self.n - 1) // 2, self.n // 2})
            self.targets = []
            for r in ranks:
                i = int(np.searchsorted(cum, r, side="right"))
                below = int(cum[i - 1]) if i else 0
                self.targets.append([r, keys[i] << SHIFTS[0], below])
            self.sparse = {}
        else:
            shift = SHIFTS[self.level]
            for tgt, h in zip(self.targets, self.hist):
                cum = tgt[2] + np.cumsum(h)
                b = int(np.searchsorted(cum, tgt[0], side="right"))
                tgt[2] = int(cum[b - 1]) if b else tgt[2]
                tgt[1] += b << shift
        self.level += 1
        if self.level < len(SHIFTS):
            bins = 1 << (SHIFTS[self.level - 1] - SHIFTS[self.level])
            self.hist = [np.zeros(bins, dtype=np.int64) for _ in self.targets]

    @property
    def exact(self) -> bool:
        """The bounds are one point (or, after a pass without numbers, infinite)."""
        return self.level >= len(SHIFTS) or (self.level > 0 and self.n == 0)

    def bounds(self) -> tuple[float, float]:
        """(low, high): the median lies between them (inf, inf for no numbers)."""
        if self.n == 0:
            return np.inf, np.inf
        width = 1 << SHIFTS[self.level - 1] if self.level <= len(SHIFTS) and not self.exact else 1
        los = [_value(lo) for _, lo, _ in self.targets]
        his = [_value(lo + width - 1) for _, lo, _ in self.targets]
        if len(los) == 1:
            return los[0], his[0]
        return float(np.mean(los)), float(np.mean(his))


def _within(r: ExactMedian, c: ExactMedian) -> bool | None:
    """``|median r - median c| <= 0.01 median c`` (the auto rule), or None while the bounds cannot tell."""
    (r0, r1), (c0, c1) = r.bounds(), c.bounds()
    if r.exact and c.exact:
        return bool(abs(r0 - c0) <= 0.01 * c0)
    if not np.isfinite(r1):
        return False
    eps = 1e-12
    if r0 >= 0.99 * c1 * (1 + eps) and r1 <= 1.01 * c0 * (1 - eps):
        return True
    if r0 > 1.01 * c1 * (1 + eps) or r1 < 0.99 * c0 * (1 - eps):
        return False
    return None


def auto_uses_clock(passes: Callable[[], Iterable[tuple[np.ndarray, dict]]], roles, optional=()) -> bool:
    """``time_base = "auto"`` on a whole table read in chunks: True when the table clock is kept.

    ``passes()`` gives one pass over the log: per chunk the repaired clock ``t`` (s) and the roles'
    values (role -> array on ``t``, NaN where not valid), in order. Same rule and result as
    :func:`~roadbank.io.resample.common_time_base` on the whole log. A role of ``optional`` (the steering
    angle) without a finite value in the whole log is left out, as the log is read without it.
    """
    clock = ExactMedian()
    steps = {r: ExactMedian() for r in roles}
    seen: set = set()
    while True:
        for _ in _one_pass(passes(), clock, steps, seen):
            pass
        if clock.n == 0:              # fewer than two stamps
            return False
        verdicts = [_within(steps[r], clock) for r in roles if r in seen or r not in optional]
        if False in verdicts:
            return False
        if None not in verdicts:
            return True


def _one_pass(chunks, clock: ExactMedian, steps: dict, seen: set) -> Iterator[None]:
    """One pass over the log's chunks into the medians of ``clock`` and the roles' ``steps``; ``seen`` gets the
    roles with a finite value."""
    last_t = None
    last_valid: dict[str, float | None] = dict.fromkeys(steps)
    for t, vals in chunks:
        if not len(t):
            continue
        clock.add(np.diff(t) if last_t is None else np.diff(np.concatenate(([last_t], t))))
        last_t = t[-1]
        for r, m in steps.items():
            tv = t[np.isfinite(vals[r])]
            if (lv := last_valid[r]) is not None:
                tv = np.concatenate(([lv], tv))
            if len(tv):
                m.add(np.diff(tv))
                last_valid[r] = tv[-1]
                seen.add(r)
        yield
    clock.end_pass()
    for m in steps.values():
        m.end_pass()

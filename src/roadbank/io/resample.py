"""Put channels sampled on different clocks onto one time base.

Rules (also in docs/io.md):

* Each channel is a series of (time, value) samples; samples whose value is
  not finite are dropped before interpolation (they are gaps).
* The **time base** is chosen by ``time_base``:

  - ``"auto"`` (default): if every channel comes from one table clock and is
    sampled at that clock's rate (its median period between valid samples equals the
    clock's), that clock is used as it is -- no interpolation, NaN samples
    stay NaN (dropouts the estimators skip). Otherwise as ``"uniform"``.
  - ``"uniform"``: a uniform grid at ``rate_hz`` (default 100 Hz) starting at
    the latest first sample of all channels and ending at or before the
    earliest last sample -- the overlap of all channels (in
    :class:`StreamResampler`, of those not ``loose``: the reader's reference roll).
  - a role name (e.g. ``"lateral_acceleration"``): that channel's own valid
    sample times inside the overlap.
  - ``"clock"``: a table's own time column as it is, whatever the channels'
    rates (no interpolation, NaN stays NaN); a log whose channels carry their
    own clocks has no such column and is refused.

* Values are linearly interpolated onto the base. Nothing is extrapolated:
  the base never leaves the overlap. Where the two valid samples bracketing a
  base time are more than ``max_gap_s`` (default 0.5 s) apart, the result is
  NaN rather than a line drawn across the gap.
* A channel sampled slower than ``max_gap_s`` (its **sample period**: the median
  step of its first :data:`PERIOD_STEPS` valid samples) would be NaN between all
  its samples. The speed (:data:`SMOOTH_ROLES`), when its period is at most
  :data:`BRIDGE_MAX_PERIOD_S` (a GNSS speed at 0.5-2 Hz), is interpolated across
  its steps up to :data:`BRIDGE_PERIODS` of its periods instead -- its own
  sampling, never a lost sample: a car's speed changes little in 2 s (at a
  change of acceleration of 1 m/s^3 a straight line between samples 1 s apart is
  off by at most 1/8 m/s, which moves the bank by 0.07 deg at a yaw rate of
  0.1 rad/s), unlike ay and the yaw rate, which carry the turns and the road
  and are never bridged. Either way :attr:`StreamResampler.notes` says so, and
  the reader warns naming the channel.
"""

from __future__ import annotations

import numpy as np

from .errors import LogError


def clean_series(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Valid samples of one channel: finite time and value, duplicate time stamps removed (first kept).

    The time stamps must already be non-decreasing.
    """
    t = np.asarray(t, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    ok = np.isfinite(t) & np.isfinite(v)
    t, v = t[ok], v[ok]
    if len(t) > 1:
        keep = np.concatenate(([True], np.diff(t) > 0))
        t, v = t[keep], v[keep]
    return t, v


def overlap(series: dict[str, tuple[np.ndarray, np.ndarray]]) -> tuple[float, float]:
    """(start, end) of the time span covered by every channel's valid samples.

    Raises
    ------
    LogError
        If a channel has no valid sample or the channels do not overlap.
    """
    starts, ends = {}, {}
    for name, (t, v) in series.items():
        tc, _ = clean_series(t, v)
        if len(tc) == 0:
            raise LogError(f"channel '{name}': no valid (finite) samples")
        starts[name], ends[name] = tc[0], tc[-1]
    t0, t1 = max(starts.values()), min(ends.values())
    if not t1 > t0:
        raise no_overlap(starts, ends)
    return float(t0), float(t1)


def no_overlap(starts: dict, ends: dict) -> LogError:
    """The error for channels whose valid samples (first and last time stamps, s, by channel) share no time
    span: the one that starts last and the one that ends first, or a channel with a single valid sample."""
    late = max(starts, key=lambda k: starts[k])
    early = min(ends, key=lambda k: ends[k])
    if starts[early] == ends[early]:
        return LogError(f"channel '{early}': a single valid (finite) sample, at {ends[early]:.3f} s")
    return LogError(f"channels do not overlap in time: '{late}' starts at {starts[late]:.3f} s "
                    f"but '{early}' ends at {ends[early]:.3f} s")


#: a stretch longer than this (s) in which no channel that spans the base has a sample is a pause of the logger
#: (or a wrong time stamp): the uniform grid leaves it out, whose rows would all be NaN (:func:`pauses`)
PAUSE_S = 60.0


def pauses(times, pause_s: float = PAUSE_S) -> np.ndarray:
    """The pauses of a log: ``(k, 2)`` array of the open intervals ``(a, b)`` (s) longer than ``pause_s`` in which
    none of the arrays of sample times ``times`` (each sorted) has a sample."""
    t = np.unique(np.concatenate([np.asarray(x, dtype=np.float64) for x in times] or [np.zeros(0)]))
    i = np.flatnonzero(np.diff(t) > pause_s)
    return np.column_stack([t[i], t[i + 1]])


def grid_indices(t0: float, rate_hz: float, k0: int, k1: int, gaps=()) -> np.ndarray:
    """The indices ``k0 <= k < k1`` of the uniform grid ``t0 + k / rate_hz`` (s) outside the open intervals
    ``gaps`` (:func:`pauses`), built piece by piece: a pause of days costs no memory."""
    pieces, k = [], k0
    for a, b in gaps:
        ka = int(np.floor((a - t0) * rate_hz + 1e-9)) + 1          # first index after a
        kb = int(np.ceil((b - t0) * rate_hz - 1e-9))                # first index at or after b
        if kb <= k or ka >= k1:
            continue
        pieces.append(np.arange(k, max(k, ka)))
        k = kb
    pieces.append(np.arange(k, max(k, k1)))
    return np.concatenate(pieces)


def uniform_grid(t0: float, t1: float, rate_hz: float, gaps=()) -> np.ndarray:
    """Uniform grid t0, t0 + 1/rate, ... not beyond t1 (tolerance 1e-9 s), outside the ``gaps`` (:func:`pauses`)."""
    n = int(np.floor((t1 - t0) * rate_hz + 1e-9)) + 1
    return t0 + grid_indices(t0, rate_hz, 0, n, gaps) / rate_hz


def interpolate(t: np.ndarray, v: np.ndarray, t_new: np.ndarray, max_gap_s: float) -> np.ndarray:
    """Linear interpolation of one channel onto ``t_new``; NaN outside its span and across long gaps."""
    tc, vc = clean_series(t, v)
    out = np.full(len(t_new), np.nan)
    if len(tc) == 0:
        return out
    inside = (t_new >= tc[0]) & (t_new <= tc[-1])
    if len(tc) == 1:
        out[t_new == tc[0]] = vc[0]
        return out
    out[inside] = np.interp(t_new[inside], tc, vc)
    if not (np.diff(tc) > max_gap_s).any():       # no gap anywhere: the rule below changes nothing
        return out
    # gap rule: bracketing valid samples more than max_gap_s apart -> NaN (exact hits excepted)
    right = np.searchsorted(tc, t_new, side="right")
    idx = np.clip(right, 1, len(tc) - 1)
    gap = tc[idx] - tc[idx - 1]
    exact = tc[np.maximum(right - 1, 0)] == t_new     # the last sample at or before t_new is t_new
    out[(gap > max_gap_s) & ~exact] = np.nan
    return out


#: roles interpolated across their own sample steps when they are sampled slower than ``max_gap_s``
SMOOTH_ROLES = ("speed",)
#: such a role is interpolated across steps up to this many of its sample periods (jitter, not a lost sample)
BRIDGE_PERIODS = 1.5
#: ... when its sample period (s) is at most this long (a speed from GNSS fixes at 0.5 Hz or faster)
BRIDGE_MAX_PERIOD_S = 2.0
#: valid samples' steps at a channel's start whose median is its sample period
PERIOD_STEPS = 20


def bridge_gap(role: str, period: float, max_gap_s: float) -> float | None:
    """The gap (s) role ``role`` is interpolated across when its own sample period ``period`` (s) is
    longer than ``max_gap_s`` (s): :data:`BRIDGE_PERIODS` periods for a role of :data:`SMOOTH_ROLES`
    sampled at least every :data:`BRIDGE_MAX_PERIOD_S`; None (``max_gap_s`` stays) otherwise."""
    if role in SMOOTH_ROLES and max_gap_s < period <= BRIDGE_MAX_PERIOD_S:
        return BRIDGE_PERIODS * period
    return None


def _median_period(t: np.ndarray) -> float:
    d = np.diff(t)
    return float(np.median(d)) if len(d) else np.inf


def common_time_base(series: dict[str, tuple[np.ndarray, np.ndarray]], time_base: str = "auto",
                     rate_hz: float = 100.0, shared_clock: np.ndarray | None = None) -> np.ndarray:
    """Choose the time base (s) for ``series`` (role -> (t, values)); see the module doc.

    Parameters
    ----------
    shared_clock : array, optional
        The table's own time column when all channels come from one table; it
        is the candidate for ``"auto"``.
    """
    t0, t1 = overlap(series)
    if time_base == "auto":
        if shared_clock is not None and len(shared_clock) > 1:
            base = _median_period(shared_clock)
            same_rate = all(abs(_median_period(clean_series(t, v)[0]) - base) <= 0.01 * base
                            for t, v in series.values())
            if same_rate:
                return np.asarray(shared_clock, dtype=np.float64)
        time_base = "uniform"
    if time_base == "uniform":
        return uniform_grid(t0, t1, rate_hz, pauses([clean_series(t, v)[0] for t, v in series.values()]))
    if time_base not in series:
        raise LogError(f"resample.time_base '{time_base}' is not one of the log's channels "
                       f"({', '.join(series)})")
    tc, _ = clean_series(*series[time_base])
    return tc[(tc >= t0) & (tc <= t1)]


def resample(series: dict[str, tuple[np.ndarray, np.ndarray]], t_base: np.ndarray,
             max_gap_s: float = 0.5, shared_clock: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Every channel on ``t_base``. If ``t_base`` is ``shared_clock`` the values are taken as they are."""
    if shared_clock is not None and t_base is shared_clock:
        return {k: np.asarray(v, dtype=np.float64) for k, (_, v) in series.items()}
    return {k: interpolate(t, v, t_base, max_gap_s) for k, (t, v) in series.items()}


class StreamResampler:
    """:func:`common_time_base` + :func:`resample` chunk by chunk: the same time base and values
    whether a log comes in one chunk or in many.

    Parameters
    ----------
    roles : list of str
        Channels that define the time base's span (their overlap), interpolated with ``max_gap_s``.
    aux : dict name -> max gap (s)
        Channels interpolated onto the base with their own gap limit that do not limit its span (GNSS).
    time_base : "uniform", a role name, or "clock"
        "clock": the table's own clock (:meth:`add_clock`) is the base; the roles and the ``raw``
        channels are taken on it as they are (NaN stays NaN).
    rate_hz, max_gap_s : float
        As in the channel map.
    raw : list of str
        Channels on the table clock interpolated with :func:`numpy.interp` (no gap rule, NaN
        spreads to its neighbours): the truth columns of simulated logs.
    loose : list of str
        Roles read as roles (interpolated with ``max_gap_s``, their sample period checked) that do not bound
        the base's span: NaN on the base where they have no sample (the reference roll, which no estimate
        reads: a reference that covers less time than the inputs does not cut the log).

    Feed chunks with :meth:`add` (any channel, any span, time-ordered per channel), mark exhausted
    channels with :meth:`finish`, collect output with :meth:`emit` (dict name -> array on ``"t"``).
    Memory: each channel keeps only the samples after the last emitted base time (plus one before it).

    Each interpolated role's sample period is the median step of its first :data:`PERIOD_STEPS` valid
    samples (all of them if it has fewer), whole or streamed alike; a role sampled slower than
    ``max_gap_s`` gets the gap of :func:`bridge_gap` (the speed) or keeps ``max_gap_s``, and
    :attr:`notes` gets ``(role, period, bridged gap or None)`` (s) for the reader's warning. Until a role's
    period is known, nothing is emitted across a step of it longer than ``max_gap_s``.
    """

    def __init__(self, roles, aux=None, time_base="uniform", rate_hz=100.0, max_gap_s=0.5, raw=(), loose=()):
        self.roles = list(roles)
        self.loose = set(loose) & set(self.roles)
        self.aux = dict(aux or {})
        self.raw = list(raw)
        self.time_base = time_base
        self.rate = float(rate_hz)
        self.max_gap = float(max_gap_s)
        names = self.roles + list(self.aux) + self.raw
        self.t = {k: np.zeros(0) for k in names}
        self.v = {k: np.zeros(0) for k in names}
        self.first = {k: None for k in names}
        self.last = {k: None for k in names}
        self.done = {k: False for k in names}
        self.clock = np.zeros(0)   # "clock": table times not emitted yet
        self.gap = {k: self.aux.get(k, self.max_gap) for k in names}   # the longest step interpolated across (s)
        #: role -> its first valid samples' steps (s), until its period is decided
        self.steps: dict[str, list[np.ndarray]] = {k: [] for k in self.roles if not self._as_is(k)}
        self.long_step = dict.fromkeys(self.steps, False)       # a step above max_gap_s seen before the period
        #: (role, sample period, bridged gap or None), s, for roles sampled slower than max_gap_s
        self.notes: list[tuple[str, float, float | None]] = []
        #: the pauses (s) the uniform grid left out (:func:`pauses`), for the reader's warning
        self.paused: list[tuple[float, float]] = []
        self._pauses_told = 0
        self.t0 = None       # grid start: latest first valid sample of the span roles
        self.k_next = 0      # next uniform grid index
        self.t_next = -np.inf   # role time base: next time not emitted yet

    def _as_is(self, name: str) -> bool:
        """Taken on the base as it is (the table clock), not interpolated."""
        return name in self.raw or (self.time_base == "clock" and name in self.roles)

    def add_clock(self, t: np.ndarray) -> None:
        """The table clock's next times (s), for ``time_base="clock"``."""
        self.clock = np.concatenate([self.clock, np.asarray(t, dtype=np.float64)])

    def add(self, name: str, t: np.ndarray, v: np.ndarray) -> None:
        if self._as_is(name):       # kept whole, row for row with the clock
            t, v = np.asarray(t, dtype=np.float64), np.asarray(v, dtype=np.float64)
            ok = np.isfinite(v)
            if ok.any():
                if self.first[name] is None:
                    self.first[name] = t[ok][0]
                self.last[name] = t[ok][-1]
            self.t[name] = np.concatenate([self.t[name], t])
            self.v[name] = np.concatenate([self.v[name], v])
            return
        t, v = clean_series(t, v)
        if len(t) and self.last[name] is not None:
            keep = t > self.last[name]          # duplicates across the chunk boundary: first kept
            t, v = t[keep], v[keep]
        if len(t) == 0:
            return
        if name in self.steps:
            self._steps(name, t)
        if self.first[name] is None:
            self.first[name] = t[0]
        self.last[name] = t[-1]
        self.t[name] = np.concatenate([self.t[name], t])
        self.v[name] = np.concatenate([self.v[name], v])

    def _steps(self, name: str, t: np.ndarray) -> None:
        """Gather role ``name``'s steps from its new valid samples ``t`` (s) until :data:`PERIOD_STEPS`."""
        prev = self.last[name]
        d = np.diff(t if prev is None else np.concatenate(([prev], t)))
        have = sum(len(x) for x in self.steps[name])
        d = d[:PERIOD_STEPS - have]
        self.steps[name].append(d)
        self.long_step[name] = self.long_step[name] or bool(np.any(d > self.max_gap))
        if have + len(d) >= PERIOD_STEPS:
            self._decide(name)

    def _decide(self, name: str) -> None:
        """Role ``name``'s sample period from the steps gathered, and its gap."""
        d = np.concatenate(self.steps.pop(name))
        self.long_step.pop(name)
        if not len(d):
            return
        period = float(np.median(d))
        if period > self.max_gap:
            bridged = bridge_gap(name, period, self.max_gap)
            if bridged is not None:
                self.gap[name] = bridged
            self.notes.append((name, period, bridged))

    def finish(self, name: str) -> None:
        self.done[name] = True
        if name in self.steps:
            self._decide(name)

    def drop(self, name: str) -> None:
        """Leave out role ``name`` (a steering angle without a finite value in the whole log): the base and the
        output are then those of a log without it; LogError if it is the time base."""
        if name == self.time_base:
            raise LogError(f"resample.time_base '{name}': the channel has no finite value")
        self.roles.remove(name)
        self.loose.discard(name)
        for d in (self.t, self.v, self.first, self.last, self.done, self.gap, self.steps, self.long_step):
            d.pop(name, None)

    def take_notes(self) -> list[tuple[str, float, float | None]]:
        """The :attr:`notes` added since the last call (role, sample period, bridged gap or None; s)."""
        notes, self.notes = self.notes, []
        return notes

    def take_pauses(self) -> list[tuple[float, float]]:
        """The pauses (s) left out of the grid since the last call (:attr:`paused`)."""
        new, self._pauses_told = self.paused[self._pauses_told:], len(self.paused)
        return new

    def buffered(self) -> int:
        """Samples held in the buffers (for memory checks)."""
        return sum(len(x) for x in self.t.values()) + len(self.clock)

    def _ready_until(self):
        """Latest time every channel has data for (inf if all are finished, None if one has none yet)."""
        lim = np.inf
        for k in self.t:
            if self._as_is(k):
                continue
            if self.done[k]:
                if k in self.roles and k not in self.loose and self.last[k] is not None:
                    lim = min(lim, self.last[k])      # a finished channel ends the overlap
                continue
            if self.last[k] is None:
                return None
            lim = min(lim, self.last[k])
        return lim

    def _spanning(self) -> list[str]:
        """The roles whose overlap is the base's span (all but the :attr:`loose` ones)."""
        return [k for k in self.roles if k not in self.loose]

    def _check_overlap(self) -> float:
        """End of the overlap of the roles (s), once every role is finished; LogError as :func:`overlap`."""
        for k in self.roles:
            if self.first[k] is None:
                raise LogError(f"channel '{k}': no valid (finite) samples")
        span = self._spanning()
        t0 = max(self.first[k] for k in span)
        t1 = min(self.last[k] for k in span)
        if not t1 > t0:
            raise no_overlap({k: self.first[k] for k in span}, {k: self.last[k] for k in span})
        return t1

    def emit(self) -> dict[str, np.ndarray] | None:
        """Base samples that no later chunk can change; None if there are none yet."""
        if any(self.long_step.values()):     # wait for that role's period: is the step bridged?
            return None
        if self.time_base == "clock":
            return self._emit_clock()
        for k in self.roles:
            if self.first[k] is None:
                if self.done[k]:
                    raise LogError(f"channel '{k}': no valid (finite) samples")
                return None
        if self.t0 is None:
            self.t0 = max(self.first[k] for k in self._spanning())
        ready = self._ready_until()
        if ready is None:
            return None
        if all(self.done[k] for k in self.roles):
            ready = min(ready, self._check_overlap())
        if self.time_base == "uniform":
            k_end = int(np.floor((ready - self.t0) * self.rate + 1e-9)) + 1 if np.isfinite(ready) else self.k_next
            if k_end <= self.k_next:
                return None
            gaps = pauses([self.t[k] for k in self._spanning() if not self._as_is(k)])
            self.paused += [pair for pair in map(tuple, gaps) if pair not in self.paused]
            grid = self.t0 + grid_indices(self.t0, self.rate, self.k_next, k_end, gaps) / self.rate
            self.k_next = k_end
            if len(grid) == 0:
                return None
        else:
            tb = self.t[self.time_base]
            grid = tb[(tb >= max(self.t0, self.t_next)) & (tb <= ready)]
            if len(grid) == 0:
                return None
            self.t_next = np.nextafter(grid[-1], np.inf)
        return {"t": grid, **{k: self._on(k, grid) for k in self.t}}

    def _on(self, k: str, grid: np.ndarray) -> np.ndarray:
        """Channel ``k`` interpolated onto ``grid``; its buffer then keeps the last sample at or before
        the grid's last time (it brackets the next one) and everything after."""
        if self._as_is(k):
            out = np.interp(grid, self.t[k], self.v[k])
        else:
            out = interpolate(self.t[k], self.v[k], grid, self.gap[k])
        i = max(int(np.searchsorted(self.t[k], grid[-1], side="right")) - 1, 0)
        self.t[k], self.v[k] = self.t[k][i:], self.v[k][i:]
        return out

    def _emit_clock(self) -> dict[str, np.ndarray] | None:
        """``time_base="clock"``: the clock's rows up to where every interpolated channel has data."""
        ready = self._ready_until()
        if all(self.done.values()):
            self._check_overlap()
            ready = np.inf
        if ready is None or not len(self.clock):
            return None
        n = int(np.searchsorted(self.clock, ready, side="right"))
        if n == 0:
            return None
        grid, self.clock = self.clock[:n], self.clock[n:]
        out = {"t": grid}
        for k in self.t:
            if self._as_is(k):          # the clock's own rows
                out[k], self.t[k], self.v[k] = self.v[k][:n], self.t[k][n:], self.v[k][n:]
            else:
                out[k] = self._on(k, grid)
        return out

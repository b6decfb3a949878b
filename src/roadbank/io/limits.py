"""Physical limits of a passenger car's channels: a sample beyond them is a glitch, read as a dropout.

A corrupt sample (a bit error on the bus, a logger's glitch: ``ay`` = 300 m/s^2 in one frame) is not
what the car did. Left in, it would move the estimate as far as a low-pass lets one sample move it, and
the noise measured for the design (:func:`roadbank.vehicle.log_conditions`) with it, for the whole log.
So a value beyond :data:`LIMITS` (SI, ISO 8855) becomes NaN, as a dropout: the estimators hold their
output there and flag it (``valid`` False), and the log's reader warns once, naming the file, the
channel, the count and the first time. The unit check (:func:`roadbank.io.channels.check_plausible`) reads
percentiles and stays what refuses a whole channel in a wrong unit; these limits read single samples.

A logger that writes 0 where a frame is missing (a "fill with zero" export) puts values inside the limits that
are as wrong: in a turn, a yaw rate of 0 reads as ``ay`` with nothing to explain it, a bank of tens of degrees.
So a run of samples exactly 0 of the speed, ``ay`` or the yaw rate, entered from a sample beyond
:data:`ZERO_JUMPS` and left to one beyond it of the same sign, is read as dropouts too: no car goes there and back
between two samples (a speed from 2 m/s to 0 and back is 2 g of braking at 10 Hz; a real channel crossing zero
leaves it with the other sign or near 0). A run at the end of a chunk (or of the log) is judged by the sample
that enters it. That holds at 10 Hz and faster; a slower channel (a GNSS speed at 1-2 Hz) does go from a few m/s to 0
between two samples when the car stops, so the speed's step into (and out of) a run must also be more than 2 g
(:data:`ZERO_RATES`) could change it in the time between the two samples: a car braking to a standstill at 3-5 m/s^2
logged at 1-2 Hz (entering its zeros from 2.5-5 m/s) is a car standing, not a dropout, while at 10 Hz and faster
the rule is as it was (2 g in 0.1 s is 1.96 m/s, under the 2 m/s). The samples of the 16 KITTI drives, the
comma2k19 segment and the paper's scenarios hold no such run; a quantised ``ay`` with heavy road vibration
(Student-t, scale 0.3 m/s^2, resolution 0.005 g) gives about one in 10 000 samples, a harmless NaN each.
"""

from __future__ import annotations

import numpy as np

from ..constants import AY_MAX, SPEED_MAX, YAW_RATE_MAX, G
from .errors import channel_text

#: (lowest, highest) value of each channel role a passenger car can have (SI): speed (m/s; reversing
#: included), lateral acceleration (m/s^2: 3 g, beyond the tyres' grip with any bank and roll; an ESP
#: sensor's range is about 2 g) and yaw rate (rad/s: 5, beyond a spin; an ESP sensor's range is 1.7-2.6)
LIMITS = {"speed": (-30.0, SPEED_MAX), "lateral_acceleration": (-AY_MAX, AY_MAX),
          "yaw_rate": (-YAW_RATE_MAX, YAW_RATE_MAX), "roll_rate": (-5.0, 5.0), "pitch_rate": (-5.0, 5.0),
          "longitudinal_acceleration": (-3.0 * G, 3.0 * G)}
#: per channel role (SI): a run of exact zeros between two samples beyond this of the same sign is a dropout
#: written as 0. Speed 2 m/s (wheel-speed sensors read 0 only below about 0.5 m/s), ``ay`` 1 m/s^2 (6 deg of bank;
#: above road vibration's usual samples), yaw rate 0.02 rad/s (1.1 deg/s, well above a gyro's noise)
ZERO_JUMPS = {"speed": 2.0, "lateral_acceleration": 1.0, "yaw_rate": 0.02}
#: per channel role (SI per second): the step into or out of such a run must also exceed this rate times the time
#: between the two samples; speed: 2 g, twice what braking or pulling away on road tyres reaches
ZERO_RATES = {"speed": 2.0 * G}
#: per channel role (SI): a sample this far from the last valid one, at most :data:`SPIKE_DT_S` before it, is a glitch
#: (:func:`spikes`). Speed 5 m/s (5 g in 0.1 s), ``ay`` 5 m/s^2, yaw and roll rate 0.3 rad/s (17 deg/s): no car's
#: motion jumps so far within 0.25 s and back. The largest jump between two samples of the 16 KITTI drives and the
#: comma2k19 segment is 0.43 m/s, 2.73 m/s^2 (the phone's vibration at 100 Hz), 0.08 and 0.11 rad/s; of `roadbank
#: tune`'s 320 simulated drives 0.13 m/s, 0.49 m/s^2, 0.03 rad/s. The longitudinal acceleration and the pitch rate
#: are left out: a phone's and an INS's jump 7.9 m/s^2 and 0.3 rad/s on rough roads, and the estimators read them
#: only to correct the roll rate for the grade
SPIKE_JUMPS = {"speed": 5.0, "lateral_acceleration": 5.0, "yaw_rate": 0.3, "roll_rate": 0.3}
#: ... within this many seconds (s): a log slower than 4 Hz, or a gap, is not judged so
SPIKE_DT_S = 0.25


def zero_runs(v: np.ndarray, before: float, jump: float, t: np.ndarray | None = None, before_t: float = np.nan,
              rate: float = 0.0) -> tuple[np.ndarray, float]:
    """Which samples of ``v`` are dropouts written as 0: runs of exact zeros entered from a sample beyond
    ``jump`` (the one before ``v`` for a run at its start: ``before``, NaN if none) and left to a sample beyond
    ``jump`` of the same sign, or reaching the end of ``v``; with times ``t`` (s; ``before_t`` that of ``before``)
    and a ``rate`` (units per second), each step into and out of the run must also exceed ``rate`` times the time
    between its two samples (a run reaching the end: the step into it). Returns the mask and the ``before`` of the
    next chunk (the sample entering a run ``v`` ends in, else ``v``'s last sample; :func:`entering_time` gives its
    time). Units: any, ``jump`` in those."""
    v = np.asarray(v, float)
    n = len(v)
    zero = v == 0.0
    if not zero.any():
        return zero, (float(v[-1]) if n else before)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], zero.view(np.int8), [0]))))
    starts, ends = edges[::2], edges[1::2]
    ext = np.concatenate(([before], v))
    entry = ext[starts]                                     # the sample before each run (ext is shifted by one)
    exit_ = np.where(ends < n, v[np.minimum(ends, n - 1)], entry)
    need_in = need_out = np.full(len(starts), float(jump))
    if t is not None and rate > 0.0:
        te = np.concatenate(([before_t], np.asarray(t, float)))
        step_in = te[starts + 1] - te[starts]               # entry sample -> first zero
        step_out = np.where(ends < n, te[np.minimum(ends, n - 1) + 1] - te[ends], step_in)   # last zero -> exit
        with np.errstate(invalid="ignore"):
            need_in, need_out = np.fmax(need_in, rate * step_in), np.fmax(need_out, rate * step_out)
    with np.errstate(invalid="ignore"):
        hit = (np.abs(entry) > need_in) & (np.abs(exit_) > need_out) & (np.sign(entry) == np.sign(exit_))
    mask = np.zeros(n, bool)
    for a, b in zip(starts[hit], ends[hit]):
        mask[a:b] = True
    nxt = float(entry[-1]) if ends[-1] == n else float(v[-1])
    return mask, nxt


def spikes(v: np.ndarray, t: np.ndarray, jump: float, last: tuple = (np.nan, np.nan)) -> tuple[np.ndarray, tuple]:
    """Which samples of ``v`` (times ``t``, s) are glitches inside the limits: a sample more than ``jump`` (units of
    ``v``) from the last valid one, at most :data:`SPIKE_DT_S` before it, and the samples after it until one is back
    within ``jump`` of that valid sample (taken) or :data:`SPIKE_DT_S` has passed since it (taken: the level is the
    car's). Non-finite samples are skipped. ``last``: ``(value, time)`` of the last valid sample before ``v`` (NaN:
    none; the previous chunk's, :meth:`Dropouts.apply`). Returns the mask and the ``last`` of the next chunk. Causal,
    so a log read in chunks gets the mask of the whole."""
    v, t = np.asarray(v, float), np.asarray(t, float)
    n = len(v)
    mask = np.zeros(n, bool)
    finite = np.isfinite(v)
    before = np.maximum.accumulate(np.concatenate(([-1], np.where(finite, np.arange(n), -1)[:-1])))
    pv = np.where(before >= 0, v[np.maximum(before, 0)], last[0])
    pt = np.where(before >= 0, t[np.maximum(before, 0)], last[1])
    with np.errstate(invalid="ignore"):
        candidates = np.flatnonzero(finite & (np.abs(v - pv) > jump) & (t - pt <= SPIKE_DT_S))
    resume = 0
    for k in candidates:           # few: each a short run from the sample before it
        if k < resume:
            continue
        lv, lt = pv[k], pt[k]      # the sample before a candidate is valid: runs end before the next candidate
        j = int(k)
        while j < n and not (finite[j] and (t[j] - lt > SPIKE_DT_S or abs(v[j] - lv) <= jump)):
            mask[j] = finite[j]
            j += 1
        resume = j + 1
    kept = np.flatnonzero(finite & ~mask)
    return mask, ((float(v[kept[-1]]), float(t[kept[-1]])) if len(kept) else last)


def entering_time(v: np.ndarray, t: np.ndarray, before_t: float) -> float:
    """The time (s) of the ``before`` :func:`zero_runs` returns for ``v`` on times ``t`` (s): that of the sample
    entering the run of zeros ``v`` ends in (``before_t``, the time of the one before ``v``, when the run fills
    ``v``), else ``t``'s last."""
    v = np.asarray(v, float)
    if not len(v):
        return before_t
    if v[-1] != 0.0:
        return float(np.asarray(t)[-1])
    nonzero = np.flatnonzero(v != 0.0)
    return float(np.asarray(t)[nonzero[-1]]) if len(nonzero) else before_t


class Dropouts:
    """Counts the samples of one log set to NaN by :meth:`apply` and words the warning (:meth:`warnings`)."""

    def __init__(self, source, columns: dict):
        self.source, self.columns = source, columns
        self.count: dict = {}
        self.first: dict = {}
        self.zeros: dict = {}         # role -> (count, first time) of the dropouts written as 0
        self._before: dict = {}       # role -> the sample entering the next chunk (see zero_runs) and its time (s)
        self.spikes: dict = {}        # role -> (count, first time) of the glitches inside the limits
        self._last: dict = {}         # role -> the last valid sample (value, time s) for the next chunk (see spikes)

    def apply(self, role: str, t: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``v`` (SI) with its samples beyond the role's limits and its dropouts written as 0 (:func:`zero_runs`,
        judged across the chunks of one log in order) NaN (a copy where any is; ``v`` itself otherwise); ``t``
        (s) their times."""
        if role not in LIMITS or not len(v):
            return v
        lo, hi = LIMITS[role]
        with np.errstate(invalid="ignore"):
            bad = (v < lo) | (v > hi)
        n = int(np.count_nonzero(bad))
        if n:
            v = np.where(bad, np.nan, v)
            if role not in self.first:
                self.first[role] = float(np.asarray(t)[np.argmax(bad)])
            self.count[role] = self.count.get(role, 0) + n
        if role in ZERO_JUMPS:
            before, before_t = self._before.get(role, (np.nan, np.nan))
            zero, nxt = zero_runs(v, before, ZERO_JUMPS[role], t, before_t, ZERO_RATES.get(role, 0.0))
            self._before[role] = (nxt, entering_time(v, t, before_t))
            k = int(np.count_nonzero(zero))
            if k:
                v = np.where(zero, np.nan, v)
                count, first = self.zeros.get(role, (0, float(np.asarray(t)[np.argmax(zero)])))
                self.zeros[role] = (count + k, first)
        if role in SPIKE_JUMPS:
            spike, self._last[role] = spikes(v, t, SPIKE_JUMPS[role], self._last.get(role, (np.nan, np.nan)))
            k = int(np.count_nonzero(spike))
            if k:
                v = np.where(spike, np.nan, v)
                count, first = self.spikes.get(role, (0, float(np.asarray(t)[np.argmax(spike)])))
                self.spikes[role] = (count + k, first)
        return v

    def warnings(self) -> list[str]:
        """One warning per channel that had samples beyond its limits, one per channel with dropouts written as 0;
        [] for a clean log."""
        return [channel_text(self.source, role, self.columns.get(role),
                             f"{n} sample(s) outside [{LIMITS[role][0]:g}, {LIMITS[role][1]:g}] (SI), impossible for "
                             f"a car, read as dropouts (the first at t = {self.first[role]:.3f} s)")
                for role, n in self.count.items()] + \
            [channel_text(self.source, role, self.columns.get(role),
                          f"{n} sample(s) exactly 0 between samples beyond +-{ZERO_JUMPS[role]:g} (SI) of the same "
                          f"sign (no car goes there and back between two samples: a logger writing 0 for a missing "
                          f"frame), read as dropouts (the first at t = {first:.3f} s)")
             for role, (n, first) in self.zeros.items()] + \
            [channel_text(self.source, role, self.columns.get(role),
                          f"{n} sample(s) more than {SPIKE_JUMPS[role]:g} (SI) from the one before and back within "
                          f"{SPIKE_DT_S:g} s (no car moves so: a glitch), read as dropouts (the first at t = "
                          f"{first:.3f} s)")
             for role, (n, first) in self.spikes.items()]

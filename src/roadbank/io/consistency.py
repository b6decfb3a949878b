"""Cross-channel unit check: lateral acceleration, speed and yaw rate must agree.

Physics: ``ay = dvy/dt + vx r + g sin(theta)`` (what a lateral accelerometer measures on a
road tilted by ``theta``, bank plus roll). On any drivable road ``|g sin(theta)|``
stays below ``g sin(35 deg)`` (bank + roll) and ``|dvy/dt|`` is small on average, so
over the turning part of a log the median of ``|ay - vx r|`` is well under :data:`LIMIT` (0.8 g). A speed logged in km/h
but declared m/s, a yaw rate in deg/s declared rad/s, or an inverted sign
convention breaks this by far as soon as the car turns — even when each channel
alone looks plausible (60 km/h read as 60 m/s passes the per-channel check).

:func:`check_consistency` tries the usual mistakes and names the channel whose
correction restores the balance. A log that never turns hard (fewer than :data:`MIN_SAMPLES` samples
above :data:`TURN`, as every shared KITTI drive) is still read for the slope of ``ay`` on ``vx r`` over
its gentle turns (above :data:`GENTLE_TURN`): an ``ay`` in g or a flipped sign is warned about there
too, and a speed in km/h or mph where what is left of ``ay`` reads as banks of more than 15 deg root mean square
(:data:`GENTLE_SPEED_TILT`); with too few gentle turns, the slope over every moving sample names an ``ay`` in g.
Driving straight (``vx r`` near 0) shows nothing: then no conclusion is drawn.

Over the whole log (:class:`Sums`, added chunk by chunk, read at its end by :func:`log_verdict`), two more
mistakes that keep the balance's residual small are named:

* a dead channel: ``ay`` or the yaw rate exactly constant over :data:`MIN_SAMPLES` moving samples. Refused
  where the other channel shows turning (its standard deviation above :data:`DEAD_EVIDENCE`); otherwise only
  warned (a yaw rate quantised coarsely on a straight road can hold one value). A speed exactly constant while ``ay``
  varies (standard deviation above :data:`DEAD_EVIDENCE`) is warned about: a stuck or held speed signal, unless the
  log was made at one exact speed (a synthetic one).
* a roll rate exactly constant over :data:`MIN_SAMPLES` moving samples: warned (:func:`dead_roll_rate`).
* a unit that scales ``vx r`` (:data:`UNIT_SCALES`): where ``ay`` and ``vx r`` move together (correlation over
  every moving sample at least :data:`CORR_MIN`), the slope of ``ay`` on ``vx r`` is 0.35-1.6 on the real and
  simulated logs the project has. A slope above :data:`SLOPE_PLAUSIBLE` (``vx r`` several times too small: a
  yaw rate in rad/s declared deg/s, a speed in m/s declared km/h or mph) or about 1/57 (a yaw rate in deg/s
  declared rad/s) that one unit's factor brings into :data:`SLOPE_FIXED` is refused naming the channel; the
  turning samples cannot show them where ``vx r`` is too small to turn.

The speed's scale is read on its own where the log carries a roll rate or a longitudinal acceleration
(:func:`speed_scales`, on its first :data:`SCALE_SPAN_S`): those measure the car's motion without the speed, so a
speed in km/h or mph declared m/s, which ``ay`` and ``vx r`` alone cannot tell from a banked road (a simulated drive
through banked curves has ``ay`` 0.35 times ``vx r``, as a speed in mph would), is refused naming the unit
(:func:`speed_scale_error`). On the same span an ``ay`` that follows the speed's changes, not the turns, is refused
as the car's forward axis (:func:`lateral_axis_error`).

The slope of the turning samples (or the gentle ones) names the same units. A slope between 0.04 and 0.4 is
not read for a unit: roads bank their curves, so ``ay`` stays well below ``vx r`` in step with it (a simulated
drive through banked curves reads 0.35 with a correlation of 0.98), and a speed in km/h declared m/s (0.28) is
then named only by the turning samples' balance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..constants import G
from ..signals import band_inner, band_pass, band_windows, integral_band_fit, running_integral
from .errors import LogError

LIMIT = 0.8 * G          #: median |ay - vx r| above this (m/s^2) is physically impossible
FIXED = 0.45 * G         #: ... and below this after a correction means the correction is right
TURN = 3.0               #: samples with |vx r| above this (m/s^2) are "turning"
MIN_SAMPLES = 100        #: turning samples needed to conclude anything
GENTLE_TURN = 1.0        #: where a log never turns hard, samples with |vx r| above this (m/s^2) give the slope
MIN_GENTLE = 20          #: ... and this many of them are needed for it

#: (channel roles, description, correction of (vx, ay, r)); a sign flip of ``ay`` and one of ``r`` balance
#: alike, so that candidate names both channels
CANDIDATES = (
    (("speed",), "speed looks like km/h declared as m/s", lambda vx, ay, r: (vx / 3.6, ay, r)),
    (("speed",), "speed looks like mph declared as m/s", lambda vx, ay, r: (vx * 0.44704, ay, r)),
    (("yaw_rate",), "yaw rate looks like deg/s declared as rad/s", lambda vx, ay, r: (vx, ay, r * math.pi / 180)),
    (("lateral_acceleration",), "lateral acceleration looks like g declared as m/s^2",
     lambda vx, ay, r: (vx, ay * G, r)),
    (("lateral_acceleration", "yaw_rate"), "one of them has the opposite sign convention (positive right, or "
     "clockwise; these channels cannot tell which)", lambda vx, ay, r: (vx, -ay, r)),
)
#: the slope of ``ay`` on ``vx r`` over the turning samples (-): about 1 (1.1 with the body's roll; less on a
#: banked track, where the bank carries part of the turn). Below :data:`SLOPE_G` with ``G`` times it in
#: :data:`SLOPE_G_RANGE` the lateral acceleration reads like g; below :data:`SLOPE_FLIPPED` its sign or the
#: yaw rate's reads flipped. Both only warn: a car turning near the neutral speed of a steep banked track
#: (or slower than it) reads the same
SLOPE_G, SLOPE_G_RANGE, SLOPE_FLIPPED = 0.2, (0.6, 1.6), -0.5
#: units that scale ``vx r`` by a factor, as the slope names them: (channel roles, description, true ``vx r`` over
#: the one read). A slope ``k`` of ``ay`` on the ``vx r`` read is ``k / factor`` on the true one
UNIT_SCALES = (
    (("speed",), "speed looks like m/s declared as km/h", 3.6),
    (("speed",), "speed looks like m/s declared as mph", 1 / 0.44704),
    (("yaw_rate",), "yaw rate looks like deg/s declared as rad/s", math.pi / 180),
    (("yaw_rate",), "yaw rate looks like rad/s declared as deg/s", 180 / math.pi),
)
#: slopes (-) of ``ay`` on ``vx r`` that a road may give (the 16 KITTI drives 0.76-1.35, ``roadbank tune``'s
#: drives 0.35-1.63, the paper's banked track 0.18-0.74); a unit is named only outside them and only where its
#: factor brings the slope into :data:`SLOPE_FIXED`
SLOPE_PLAUSIBLE = (0.04, 2.5)
SLOPE_FIXED = (0.7, 1.4)
#: a slope (-) of ``ay`` on ``vx r`` over the turning samples below this, that a speed unit's factor
#: (:data:`SPEED_SCALES`) brings into :data:`SLOPE_FIXED`, with a tilt beyond :data:`SPEED_TILT` is warned about
#: (:func:`speed_warnings`): a speed in km/h or mph declared m/s reads so, as does a steep banked track (the paper's,
#: 0.18-0.74), so never refused
SLOPE_SPEED_WARN = 0.6
#: ... the 95th percentile of ``|ay - vx r|`` over those samples (m/s^2; ``g sin`` of the bank and roll it implies)
#: above which: ``g sin 32 deg``, beyond the steepest of the paper's track lanes (30 deg: its lane change reads 4.9
#: m/s^2 with a slope of 0.30) and of ``roadbank tune``'s simulated drives (whose slopes below 0.6 reach at most 2.3
#: m/s^2); a speed in km/h read as m/s on KITTI drives 5.6-6.2 m/s^2 (35-39 deg), in mph on the S-curve 8.1 (56 deg)
SPEED_TILT = G * math.sin(math.radians(32.0))
#: the speed read over the true one (-) for a speed in km/h or in mph (or knots) declared m/s
SPEED_SCALES = (("km/h", 3.6), ("mph", 1 / 0.44704))
#: :data:`SPEED_TILT`'s part for a log that never turns hard: the root mean square of ``|ay - vx r|`` (m/s^2) over the
#: gently turning samples, above which (``g sin 15 deg``: a bank no public road keeps through its turns)
#: :func:`gentle_warnings` warns of a speed unit. The 16 KITTI drives as recorded read 0.22-0.53 (0.85 on one with a
#: single sample), their speed in km/h 1.47-4.81, in mph 0.92-2.80; the paper's bank-lane-change (14 deg bank steps)
#: 1.62-1.69 with a slope of 0.39-0.49, as a speed in mph would read: so it is not warned about
GENTLE_SPEED_TILT = G * math.sin(math.radians(15.0))
#: the correlation of ``ay`` with ``vx r`` over every moving sample from which their slope is read (the shared
#: KITTI drives 0.44-0.98; a straight drive's is its noise's)
CORR_MIN = 0.6
#: a sum of squared deviations below this fraction of the sum of squares (-) is rounding: the channel is
#: constant (summed in float64 over up to 1e9 samples, the rounding stays below 1e-6 of it)
VAR_ROUNDING = 1e-6
#: the lowest speed (m/s) of the samples the whole log's checks read: low, so that a speed read 3.6 times too small
#: (m/s declared km/h) still leaves a city drive's turns in
MOVING = 1.0
#: a channel constant over :data:`MIN_SAMPLES` moving samples is refused as dead where the other channel's
#: standard deviation there is above this (m/s^2: the turning drives of the shared KITTI set have 0.47-0.99, the
#: straight ones 0.16-0.32)
DEAD_EVIDENCE = 0.4


#: the first seconds of a log (s) on which :func:`speed_scales` reads the speed's scale
SCALE_SPAN_S = 300.0
#: the band (s: centred means, the shorter less the longer) in which :func:`speed_scales` compares the channels:
#: about 0.05-0.5 Hz, where a road's bank moves little against the car's turns and speed changes
SCALE_WINDOWS_S = (1.0, 10.0)
#: :func:`speed_scales` reads the roll rate only where ``vx r`` moves in the band (root mean square, m/s^2; the
#: 16 KITTI drives 0.02-0.6), the roll rate's gain on the roll of ``ay`` is that of a roll gyro (-: the 16 KITTI
#: drives 0.71-1.56) and the fit explains this share of the band's ``ay - vx r`` (-: those drives 0.36-0.91 as
#: recorded, a pitch or yaw rate in the roll rate's place 0.0-0.52)
SCALE_MIN_TURN, SCALE_ROLL_GAIN, SCALE_MIN_FIT = 0.05, (0.5, 2.0), 0.3
#: ... and ``ax`` only where the speed moves in the band (root mean square, m/s; the 16 KITTI drives 0.14-1.38) and
#: follows the integrated ``ax`` with this correlation (-: those drives 0.87-1.00; the two below 0.95 read 0.57 and
#: 0.95, so that one in km/h would read as mph)
SCALE_MIN_SPEED, SCALE_MIN_CORR = 0.1, 0.95
#: the speed read over the true one (-) for each unit a speed declared m/s may be in; a channel's reading of it
#: names a unit within :data:`SCALE_FIT` of its factor (the 16 KITTI drives as recorded, on their first 300 s: roll
#: rate 0.88-1.09, ax 0.90-0.99 where read; so their speed in mph read as m/s 1.97-2.44 and 2.0-2.2, in km/h 3.2-3.9
#: and 3.2-3.6)
SCALE_UNITS = (("m/s", 1.0), ("mph", 1 / 0.44704), ("km/h", 3.6))
SCALE_FIT = (0.8, 1.25)
#: what each reading is called in a message
SCALE_EVIDENCE = {"roll_rate": "by its roll rate the speed reads {c:.2f} times too large (ay - vx r matches the roll "
                               "rate's roll only with vx / {c:.2f})",
                  "longitudinal_acceleration": "by its ax the speed reads {c:.2f} times too large (it changes {c:.2f} "
                                               "times the integrated ax)"}


def turning(vx, ay, r, above: float = TURN) -> np.ndarray:
    """Mask of the samples the check reads: finite ``ay`` and ``vx r``, ``|vx r| > above`` (m/s^2, default
    :data:`TURN`), ``vx >= 5`` m/s."""
    with np.errstate(invalid="ignore", over="ignore"):
        return moving(vx, ay, r, 5.0) & (np.abs(vx * r) > above)


def moving(vx, ay, r, v_min: float = MOVING) -> np.ndarray:
    """Mask of the samples whose ``ay`` and ``vx r`` are finite, moving forward (``vx >= v_min`` m/s, default
    :data:`MOVING`)."""
    with np.errstate(invalid="ignore", over="ignore"):
        return np.isfinite(vx * r) & np.isfinite(ay) & (vx >= v_min)


@dataclass(frozen=True)
class Sums:
    """What :func:`log_verdict` reads of a log, summed chunk by chunk (``+``): over the moving samples
    (:func:`moving`) with ``a = vx r`` (m/s^2) and ``ay`` (m/s^2), ``moments = (n, sum a, sum ay, sum a^2, sum ay^2,
    sum a ay)`` and ``ranges = (min ay, max ay, min r, max r, min vx, max vx)`` (m/s^2, rad/s, m/s); ``gentle`` is
    :func:`gentle_sums`;
    ``motion`` counts the samples in motion and those reversing (:func:`reversing_warnings`)."""

    gentle: tuple = (0.0, 0.0, 0, 0.0)
    moments: tuple = (0, 0.0, 0.0, 0.0, 0.0, 0.0)
    ranges: tuple = (math.inf, -math.inf, math.inf, -math.inf, math.inf, -math.inf)
    #: ``(samples in motion, those of them reversing)``: finite ``|vx| >=`` :data:`MOVING`, and ``vx <= -MOVING``
    motion: tuple = (0, 0)
    #: ``(count, min, max)`` of the roll rate (rad/s) over the moving samples where it is finite (a log without one:
    #: no count)
    roll_rate: tuple = (0, math.inf, -math.inf)

    @classmethod
    def of(cls, vx, ay, r, p=None) -> Sums:
        """The sums of one chunk: ``vx`` (m/s), ``ay`` (m/s^2), ``r`` and the roll rate ``p`` (rad/s; None: the log
        has none)."""
        vx, ay, r = (np.asarray(x, dtype=np.float64) for x in (vx, ay, r))
        sel = moving(vx, ay, r)
        a, y, w = vx[sel] * r[sel], ay[sel], r[sel]
        moments = (int(sel.sum()), float(a.sum()), float(y.sum()), float(a @ a), float(y @ y), float(a @ y))
        v = vx[sel]
        ranges = ((float(y.min()), float(y.max()), float(w.min()), float(w.max()), float(v.min()), float(v.max()))
                  if sel.any() else cls.ranges)
        with np.errstate(invalid="ignore"):
            motion = (int(np.count_nonzero(np.abs(vx) >= MOVING)), int(np.count_nonzero(vx <= -MOVING)))
        roll = cls.roll_rate
        if p is not None:
            q = np.asarray(p, dtype=np.float64)[sel]
            q = q[np.isfinite(q)]
            roll = (len(q), float(q.min()), float(q.max())) if len(q) else roll
        return cls(gentle_sums(vx, ay, r), moments, ranges, motion, roll)

    def __add__(self, other: Sums) -> Sums:
        lo = lambda i: min(self.ranges[i], other.ranges[i])      # noqa: E731
        hi = lambda i: max(self.ranges[i], other.ranges[i])      # noqa: E731
        (n, a, b), (m, c, d) = self.roll_rate, other.roll_rate
        return Sums(tuple(x + y for x, y in zip(self.gentle, other.gentle)),
                    tuple(x + y for x, y in zip(self.moments, other.moments)),
                    (lo(0), hi(1), lo(2), hi(3), lo(4), hi(5)),
                    tuple(x + y for x, y in zip(self.motion, other.motion)), (n + m, min(a, c), max(b, d)))


def _unit_error(k: float, what: str, source, named) -> None:
    """LogError naming the units of :data:`UNIT_SCALES` that bring a slope ``k`` (-) of ``ay`` on ``vx r`` from
    outside :data:`SLOPE_PLAUSIBLE` into :data:`SLOPE_FIXED` (``what``: over which samples)."""
    if not math.isfinite(k) or SLOPE_PLAUSIBLE[0] <= k <= SLOPE_PLAUSIBLE[1]:
        return
    fits = [(roles, text) for roles, text, f in UNIT_SCALES if SLOPE_FIXED[0] <= k / f <= SLOPE_FIXED[1]]
    if fits:
        roles = tuple(dict.fromkeys(r for rs, _ in fits for r in rs))
        raise LogError(f"{source}: channel {named(roles)}: {' or '.join(t for _, t in fits)}: ay is {k:.3g} times "
                       f"vx r over {what} (about 1 on a road); fix the unit in the channel map (or the file's units "
                       "row)")


def log_verdict(sums: Sums, decided: bool, source="signals", columns: dict | None = None) -> list[str]:
    """The checks of the whole log (module docstring) from its :class:`Sums`: a dead channel and a unit that scales
    ``vx r``, and where the turning samples never decided (``decided`` False) the gentle turns' slope
    (:func:`gentle_warnings`). Returns warnings; LogError for a refusal."""
    named = _namer(columns)
    out: list[str] = []
    n, sa, sy, saa, syy, say = sums.moments
    if n >= MIN_SAMPLES:
        # sums of squared deviations of vx r and ay from their means, and of their products
        va, vy, cov = max(saa - sa * sa / n, 0.0), max(syy - sy * sy / n, 0.0), say - sa * sy / n
        out = _dead_channels(sums.ranges, n, math.sqrt(va / n), math.sqrt(vy / n), source, named)
        # a channel constant over the log leaves only the rounding of the sums (about n eps saa): no variance
        if va > VAR_ROUNDING * saa and vy > VAR_ROUNDING * syy:
            corr, k = cov / math.sqrt(va * vy), cov / va
            if corr >= CORR_MIN:
                _unit_error(k, f"{n} moving samples (correlation {corr:.2f})", source, named)
                if not decided and sums.gentle[2] < MIN_GENTLE:     # too few turns for the gentle slope: g, a sign
                    out = out + _slope_warnings(k, n, "moving", source, named)
    out += reversing_warnings(sums.motion, source, named) + dead_roll_rate(sums.roll_rate, source, columns)
    return out + ([] if decided else gentle_warnings(sums.gentle, source, columns))


def reversing_warnings(motion: tuple, source, named) -> list[str]:
    """A warning where most of a log's motion is backwards: ``motion = (samples in motion, those reversing)``
    (:attr:`Sums.motion`), at least :data:`MIN_SAMPLES` in motion and more than half of them at ``vx <= -``
    :data:`MOVING` m/s. The estimators need forward driving (``vx >= v_min``) and give no valid sample while
    reversing, so such a log's estimate is mostly not valid; a car that drove forward with a speed logged
    negative (an odd sign convention) is told how to read it."""
    moving_n, back = motion
    if moving_n < MIN_SAMPLES or 2 * back <= moving_n:
        return []
    return [f"{source}: channel {named(('speed',))}: negative on {back} of the {moving_n} samples in motion "
            f"(|speed| >= {MOVING:g} m/s): the estimate is not valid while reversing (if the car drove forward, "
            "the speed's sign is inverted: give it `invert = true` in a channel map)"]


def dead_roll_rate(roll_rate: tuple, source, columns: dict | None = None) -> list[str]:
    """A warning for a roll rate exactly constant over at least :data:`MIN_SAMPLES` moving samples (``roll_rate``:
    :attr:`Sums.roll_rate`): a dead or disconnected gyro, which the default leaves out (it reads a roll rate only
    where it follows the roll in ``ay``) without a word otherwise."""
    n, lo, hi = roll_rate
    if n < MIN_SAMPLES or lo != hi:
        return []
    return [f"{source}: channel {_namer(columns)(('roll_rate',))}: constant at {lo + 0.0:.6g} rad/s over {n} moving "
            "samples: a dead or disconnected gyro, which the estimate leaves out (it reads a roll rate only where it "
            "follows the roll in ay)"]


def _dead_channels(ranges: tuple, n: int, std_a: float, std_ay: float, source, named) -> list[str]:
    """The dead-channel check of :func:`log_verdict` over ``n`` moving samples, from :attr:`Sums.ranges` and the
    standard deviations (m/s^2) of ``vx r`` (``std_a``) and ``ay`` (``std_ay``) there: warnings, or LogError where the
    other channel shows turning."""
    out = []
    lo, hi = ranges[4:6]
    if lo == hi and std_ay > DEAD_EVIDENCE:      # never refused: a simulated or synthetic log may hold its speed
        out.append(f"{source}: channel {named(('speed',))}: constant at {lo + 0.0:.6g} m/s over {n} moving samples "
                   f"while ay varies by {std_ay:.2f} m/s^2 (standard deviation): a stuck or held speed signal, unless "
                   "the log was made at one exact speed")
    for role, (lo, hi), unit, other, std in (("lateral_acceleration", ranges[:2], "m/s^2", "vx r", std_a),
                                             ("yaw_rate", ranges[2:4], "rad/s", "ay", std_ay)):
        if lo != hi:
            continue
        text = f"{source}: channel {named((role,))}: constant at {lo + 0.0:.6g} {unit} over {n} moving samples"
        if std > DEAD_EVIDENCE:
            raise LogError(f"{text} while {other} varies by {std:.2f} m/s^2 (standard deviation): a dead or "
                           "disconnected sensor")
        out.append(f"{text}: a dead sensor, unless the car drove straight and the channel is coarsely quantised")
    return out


def gentle_sums(vx, ay, r) -> tuple[float, float, int, float]:
    """``(sum ay vx r, sum (vx r)^2, count, sum (ay - vx r)^2)`` over the gently turning samples (``|vx r| >``
    :data:`GENTLE_TURN`; ``vx`` m/s, ``ay`` m/s^2, ``r`` rad/s): the slope and tilt of :func:`gentle_warnings`,
    summed chunk by chunk."""
    sel = turning(vx, ay, r, GENTLE_TURN)
    a = vx[sel] * r[sel]
    return float(np.sum(ay[sel] * a)), float(np.sum(a * a)), int(sel.sum()), float(np.sum((ay[sel] - a) ** 2))


def gentle_warnings(sums, source="signals", columns: dict | None = None) -> list[str]:
    """The slope warnings of :func:`check_balance` from :func:`gentle_sums` (added over the log's chunks), for a log
    with fewer than :data:`MIN_SAMPLES` turning samples: a unit or sign (:func:`_slope_warnings`), and a speed that
    reads like km/h or mph where what is left of ``ay`` has the root mean square of a bank no road has
    (:data:`GENTLE_SPEED_TILT`; a KITTI drive whose speed is in km/h had run silent to 45 deg of bank); nothing
    below :data:`MIN_GENTLE` gently turning ones."""
    say, saa, n, sres = sums
    if n < MIN_GENTLE:
        return []
    named = _namer(columns)
    k, tilt = say / saa, math.sqrt(sres / n)
    return (_slope_warnings(k, n, "gently turning", source, named)
            + speed_warnings(k, tilt, n, source, named, "gently turning", GENTLE_SPEED_TILT, "root mean square"))


def _namer(columns: dict | None):
    """Channel roles -> their words in a message, with the column names of ``columns`` (role -> column)."""
    cols = columns or {}
    return lambda roles: " or ".join(f"'{x}'" + (f" (column '{cols[x]}')" if x in cols else "") for x in roles)


def _slope_warnings(k: float, n: int, what: str, source, named) -> list[str]:
    """The warnings for a slope ``k`` (-) of ``ay`` on ``vx r`` over ``n`` samples (``what``: which) of the file
    ``source``: g declared as m/s^2, or a flipped sign (:data:`SLOPE_G`, :data:`SLOPE_FLIPPED`); LogError for a unit
    that scales ``vx r`` (:func:`_unit_error`)."""
    _unit_error(k, f"{n} {what} samples", source, named)
    if k < SLOPE_G and SLOPE_G_RANGE[0] <= G * k <= SLOPE_G_RANGE[1]:
        return [f"{source}: channel {named(('lateral_acceleration',))}: ay is {k:.2f} times vx r over {n} {what} "
                "samples (about 1 on a road): it looks like g declared as m/s^2, unless the car turned on a steep "
                "banked track near its neutral speed"]
    if k < SLOPE_FLIPPED:
        return [f"{source}: channel {named(('lateral_acceleration', 'yaw_rate'))}: ay is {k:.2f} times vx r over "
                f"{n} {what} samples (about +1 on a road): one of them looks like the opposite sign convention, "
                "unless the car turned slowly on a steep banked track"]
    return []


def speed_warnings(k: float, tilt: float, n: int, source, named, what: str = "turning",
                   limit: float = SPEED_TILT, tilt_is: str = "95th percentile") -> list[str]:
    """The warning for a speed that reads like km/h or mph declared as m/s: the slope ``k`` (-) of ``ay`` on ``vx r``
    over ``n`` samples (``what``: which) below :data:`SLOPE_SPEED_WARN` and brought into :data:`SLOPE_FIXED` by a
    unit of :data:`SPEED_SCALES`, with ``tilt`` (m/s^2; ``tilt_is`` says which statistic of ``|ay - vx r|`` there)
    above ``limit`` (default :data:`SPEED_TILT`, a 95th percentile: a bank no public road has)."""
    fits = [u for u, f in SPEED_SCALES if SLOPE_FIXED[0] <= k * f <= SLOPE_FIXED[1]]
    if not (fits and SLOPE_PLAUSIBLE[0] <= k < SLOPE_SPEED_WARN and tilt > limit):
        return []
    deg = math.degrees(math.asin(min(tilt / G, 1.0)))
    return [f"{source}: channel {named(('speed',))}: ay is only {k:.2f} times vx r over {n} {what} samples (0.76-1.35 "
            f"on the real roads the project has), and what is left of ay reads as banks of {deg:.0f} deg ({tilt_is}): "
            f"it reads like a speed in {' or '.join(fits)} declared as m/s, unless the car turned on a steep banked "
            "track. A channel map states the speed's unit (`roadbank channels LOG -o map.toml` guesses it)"]


def _residual(vx, ay, r) -> tuple[float, int, np.ndarray]:
    """Median ``|ay - vx r|`` (m/s^2) over the turning samples, their count and their mask."""
    sel = turning(vx, ay, r)
    n = int(sel.sum())
    return (float(np.median(np.abs(ay[sel] - vx[sel] * r[sel]))) if n else 0.0), n, sel


def _slope(vx, ay, r, sel) -> float:
    """Least-squares slope (-) of ``ay`` on ``vx r`` through the origin over the samples of the mask ``sel``."""
    a = vx[sel] * r[sel]
    return float(np.sum(ay[sel] * a) / np.sum(a * a)) if sel.any() else math.nan


def usable(vx, ay, r) -> np.ndarray:
    """Mask of the samples that are turning as they are or after one of the corrections of
    :data:`CANDIDATES`: :func:`check_balance` of these samples alone decides as of all of them."""
    sel = turning(vx, ay, r)
    for _, _, fix in CANDIDATES:
        sel |= turning(*fix(vx, ay, r))
    return sel


def check_consistency(signals, source="signals", columns: dict | None = None) -> list[str]:
    """Check that ``ay``, ``vx`` and ``r`` of ``signals`` (SI) balance (module docstring).

    Parameters
    ----------
    signals : roadbank.Signals
    source : str or path
        Named in the messages (the file).
    columns : dict role -> column name, optional
        Column names to quote in the messages.

    Returns
    -------
    list of str
        Warnings (inconsistent, but no single correction explains it).

    Raises
    ------
    LogError
        When the log is inconsistent and one correction (unit or sign of one
        channel) makes it consistent, or its roll rate or ``ax`` reads its speed's unit
        (:func:`speed_scale_error`), or its ``ay`` follows the speed's changes (:func:`lateral_axis_error`); the
        message names that channel.
    """
    vx, ay, r = (np.asarray(a, float) for a in (signals.vx, signals.ay, signals.r))
    lateral_axis_error(signals.t, vx, ay, r, source, columns)
    speed_scale_error(speed_scales(signals.t, vx, ay, r, signals.p, signals.ax), source, columns)
    decided = int(turning(vx, ay, r).sum()) >= MIN_SAMPLES
    out = check_balance(vx, ay, r, source, columns) if decided else []
    return out + log_verdict(Sums.of(vx, ay, r, signals.p), decided, source, columns)


def check_balance(vx, ay, r, source="signals", columns: dict | None = None) -> list[str]:
    """The turning samples' part of :func:`check_consistency` on the arrays ``vx`` (m/s), ``ay`` (m/s^2), ``r``
    (rad/s): with fewer than :data:`MIN_SAMPLES` of them, the gentle turns' slope warnings."""
    vx, ay, r = (np.asarray(a, float) for a in (vx, ay, r))
    res, n, sel = _residual(vx, ay, r)
    if n < MIN_SAMPLES:
        return gentle_warnings(gentle_sums(vx, ay, r), source, columns)
    named = _namer(columns)
    if res <= LIMIT:
        k = _slope(vx, ay, r, sel)
        tilt = float(np.percentile(np.abs(ay[sel] - vx[sel] * r[sel]), 95))
        return _slope_warnings(k, n, "turning", source, named) + speed_warnings(k, tilt, n, source, named)
    for roles, text, fix in CANDIDATES:
        fres, fn, _ = _residual(*fix(vx, ay, r))
        if fn >= MIN_SAMPLES and fres <= FIXED:
            raise LogError(f"{source}: channel {named(roles)}: {text}: ay, vx and yaw rate do not balance "
                           f"(median |ay - vx r| = {res:.1f} m/s^2 over {n} turning samples, "
                           f"{fres:.1f} m/s^2 after correcting it); fix the unit or sign in the channel map")
    return [f"{source}: ay, vx and yaw rate do not balance (median |ay - vx r| = {res:.1f} m/s^2 over "
            f"{n} turning samples, more than 0.8 g): check the units and sign conventions of "
            "'speed', 'lateral_acceleration' and 'yaw_rate'"]


def _scale_span(t, vx, ay, r):
    """``((t, vx, ay, r), windows, use)``: the channels (s, m/s, m/s^2, rad/s) over the log's first
    :data:`SCALE_SPAN_S`, the band's windows (:data:`SCALE_WINDOWS_S`, :func:`~roadbank.signals.band_windows`) and
    the samples moving forward inside it (:func:`~roadbank.signals.band_inner`) that :func:`speed_scales` and
    :func:`lateral_axis_error` read; None where there are too few."""
    t, vx, ay, r = (np.asarray(x, dtype=np.float64) for x in (t, vx, ay, r))
    n = int(np.searchsorted(t, t[0] + SCALE_SPAN_S, side="right")) if len(t) else 0    # (t increases)
    if n < 3:
        return None
    t, vx, ay, r = t[:n], vx[:n], ay[:n], r[:n]
    windows = band_windows(t, SCALE_WINDOWS_S)
    use = band_inner(moving(vx, ay, r), windows)
    return None if use is None else ((t, vx, ay, r), windows, use)


def speed_scales(t, vx, ay, r, p=None, ax=None) -> dict[str, float]:
    """The speed read over the true one (-), from each channel of the log that measures the car's motion without it,
    on the samples of its first :data:`SCALE_SPAN_S` moving forward (:func:`moving`), band-passed over
    :data:`SCALE_WINDOWS_S` (:func:`~roadbank.signals.band_pass`): ``t`` (s), ``vx`` (m/s), ``ay`` (m/s^2), ``r`` and
    the roll rate ``p`` (rad/s), ``ax`` (m/s^2); None for a channel the log does not carry.

    * ``"roll_rate"``: with the speed read ``c`` times too large, ``ay - vx r = g phi + (1/c - 1) vx r`` (``phi`` the
      roll and bank, ``dvy/dt`` aside); the least-squares fit of the band's ``ay - vx r`` on ``g`` times the integrated
      roll rate and on ``vx r`` gives ``alpha g phi + beta vx r`` and ``c = 1 / (1 + beta)``. The bank of the road
      is in the roll rate's integral, so a banked curve does not read as a scale. Read where ``vx r`` moves in the
      band (:data:`SCALE_MIN_TURN`), ``alpha`` is a roll gyro's (:data:`SCALE_ROLL_GAIN`) and the fit explains
      :data:`SCALE_MIN_FIT` of it.
    * ``"longitudinal_acceleration"``: the least-squares slope of the band's speed on the integrated ``ax`` (the
      grade's slow part falls out of the band), where the speed moves (:data:`SCALE_MIN_SPEED`) and follows it
      (:data:`SCALE_MIN_CORR`).

    Returns ``{reading: c}`` for the readings made (empty when none can be)."""
    out: dict[str, float] = {}
    span = _scale_span(t, vx, ay, r)
    if span is None:
        return out
    (t, vx, ay, r), windows, use = span
    n = len(t)
    with np.errstate(invalid="ignore", over="ignore"):
        a = band_pass(vx * r, windows)[use]
        if p is not None and np.sqrt(np.mean(a * a)) >= SCALE_MIN_TURN:
            level = band_pass(ay - vx * r, windows)[use]
            roll = G * band_pass(running_integral(t, np.asarray(p, dtype=np.float64)[:n]), windows)[use]
            (alpha, beta), *_ = np.linalg.lstsq(np.c_[roll, a], level, rcond=None)
            explained = 1.0 - float(np.sum((level - alpha * roll - beta * a) ** 2)) / max(float(level @ level), 1e-300)
            if SCALE_ROLL_GAIN[0] <= alpha <= SCALE_ROLL_GAIN[1] and explained >= SCALE_MIN_FIT and 1.0 + beta > 0:
                out["roll_rate"] = float(1.0 / (1.0 + beta))
        fit = None if ax is None else integral_band_fit(t, vx, np.asarray(ax, dtype=np.float64)[:n], use, windows)
        if fit is not None and fit[2] >= SCALE_MIN_SPEED and fit[1] >= SCALE_MIN_CORR:
            out["longitudinal_acceleration"] = fit[0]
    return out


#: :func:`lateral_axis_error` refuses an ``ay`` that follows the speed only where it follows ``vx r`` less than this
#: (correlation in the band, -)
LATERAL_TURN_CORR = 0.6


def lateral_axis_error(t, vx, ay, r, source="signals", columns: dict | None = None) -> None:
    """LogError where ``ay`` (m/s^2) follows the speed's changes as a longitudinal accelerometer does: on the log's
    first :data:`SCALE_SPAN_S` moving forward, band-passed over :data:`SCALE_WINDOWS_S`, the speed ``vx`` (m/s) moves
    (:data:`SCALE_MIN_SPEED`) and follows the integrated ``ay`` with a correlation of at least :data:`SCALE_MIN_CORR`
    in size and a slope of 0.5-2 in size (``t`` s, ``r`` rad/s), while in the same band ``ay`` follows ``vx r`` with a
    correlation below :data:`LATERAL_TURN_CORR`. The lateral channel is then the car's longitudinal axis (a sensor
    mounted turned by 90 deg, the axes swapped in a map), which the balance of ``ay``, ``r`` and ``vx`` alone cannot
    tell from a road whose bank changes (its ``ay`` follows ``vx r`` as loosely over a whole log). On the 16 KITTI
    drives and comma2k19 the speed's correlation is -0.47 to 0.57 and ``ay``'s with ``vx r`` in the band 0.72-0.99;
    with ``-ax`` in ``ay``'s place (a turned IMU) -0.87 to -1.00 and -0.53 to 0.46. A car sliding down a steep bank at
    low friction (the simulator's const-bank and track-lane1 on mu 0.3) changes its speed with its ``ay`` too
    (correlation -0.95, -0.99), but its ``ay`` follows ``vx r`` (1.00, 0.71)."""
    span = _scale_span(t, vx, ay, r)
    if span is None:
        return
    (t, vx, ay, r), windows, use = span
    with np.errstate(invalid="ignore", over="ignore"):
        fit = integral_band_fit(t, vx, ay, use, windows)
        if fit is None or fit[2] < SCALE_MIN_SPEED or abs(fit[1]) < SCALE_MIN_CORR or not 0.5 <= abs(fit[0]) <= 2.0:
            return
        a, y = band_pass(vx * r, windows)[use], band_pass(ay, windows)[use]
        aa, yy = float(a @ a), float(y @ y)
        turns = float(a @ y) / math.sqrt(aa * yy) if aa > 0 and yy > 0 else 0.0
    if turns >= LATERAL_TURN_CORR:
        return
    raise LogError(f"{source}: channel {_namer(columns)(('lateral_acceleration',))}: it follows the speed's changes as "
                   f"a longitudinal accelerometer does (the speed is {fit[0]:.2f} times its integral, correlation "
                   f"{fit[1]:.2f}, over the first {min(SCALE_SPAN_S, float(t[-1] - t[0])):.0f} s), not the car's "
                   f"turns (correlation with vx r {turns:.2f}): it reads the car's forward axis (a sensor mounted "
                   "turned by 90 deg, or the axes swapped in the channel map); map the lateral axis")


def speed_scale_error(scales: dict[str, float], source="signals", columns: dict | None = None) -> None:
    """LogError naming the speed's unit where the readings ``scales`` (:func:`speed_scales`) name one unit of
    :data:`SCALE_UNITS` other than m/s (a reading names the units within :data:`SCALE_FIT` of their factor) and none
    names another: the speed is then in that unit, declared m/s. Nothing otherwise."""
    votes = {name: {u for u, f in SCALE_UNITS if SCALE_FIT[0] <= c / f <= SCALE_FIT[1]} for name, c in scales.items()}
    named = set().union(*votes.values()) if votes else set()
    if len(named) != 1 or named == {"m/s"}:
        return
    unit = named.pop()
    said = " and ".join(SCALE_EVIDENCE[name].format(c=scales[name]) for name in scales if votes[name])
    raise LogError(f"{source}: channel {_namer(columns)(('speed',))}: speed looks like {unit} declared as m/s: "
                   f"{said}; fix the unit in the channel map or the file's units row (if the speed is right, the "
                   "roll rate or ax is not: leave it out of the map)")

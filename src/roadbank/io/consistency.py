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
too. Driving straight (``vx r`` near 0) shows nothing: then no conclusion is drawn.
"""

from __future__ import annotations

import math

import numpy as np

from ..constants import G
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


def turning(vx, ay, r, above: float = TURN) -> np.ndarray:
    """Mask of the samples the check reads: finite ``ay`` and ``vx r``, ``|vx r| > above`` (m/s^2, default
    :data:`TURN`), ``vx >= 5`` m/s."""
    with np.errstate(invalid="ignore", over="ignore"):
        vr = vx * r
        return np.isfinite(vr) & np.isfinite(ay) & (np.abs(vr) > above) & (vx >= 5.0)


def gentle_sums(vx, ay, r) -> tuple[float, float, int]:
    """``(sum ay vx r, sum (vx r)^2, count)`` over the gently turning samples (``|vx r| >`` :data:`GENTLE_TURN`;
    ``vx`` m/s, ``ay`` m/s^2, ``r`` rad/s): the slope of :func:`gentle_warnings`, summed chunk by chunk."""
    sel = turning(vx, ay, r, GENTLE_TURN)
    a = vx[sel] * r[sel]
    return float(np.sum(ay[sel] * a)), float(np.sum(a * a)), int(sel.sum())


def gentle_warnings(sums, source="signals", columns: dict | None = None) -> list[str]:
    """The slope warnings of :func:`check_balance` from :func:`gentle_sums` (added over the log's chunks), for a log
    with fewer than :data:`MIN_SAMPLES` turning samples; nothing below :data:`MIN_GENTLE` gently turning ones."""
    say, saa, n = sums
    if n < MIN_GENTLE:
        return []
    return _slope_warnings(say / saa, n, "gently turning", source, _namer(columns))


def _namer(columns: dict | None):
    """Channel roles -> their words in a message, with the column names of ``columns`` (role -> column)."""
    cols = columns or {}
    return lambda roles: " or ".join(f"'{x}'" + (f" (column '{cols[x]}')" if x in cols else "") for x in roles)


def _slope_warnings(k: float, n: int, what: str, source, named) -> list[str]:
    """The warnings for a slope ``k`` (-) of ``ay`` on ``vx r`` over ``n`` samples (``what``: which) of the file
    ``source``: g declared as m/s^2, or a flipped sign (:data:`SLOPE_G`, :data:`SLOPE_FLIPPED`)."""
    if k < SLOPE_G and SLOPE_G_RANGE[0] <= G * k <= SLOPE_G_RANGE[1]:
        return [f"{source}: channel {named(('lateral_acceleration',))}: ay is {k:.2f} times vx r over {n} {what} "
                "samples (about 1 on a road): it looks like g declared as m/s^2, unless the car turned on a steep "
                "banked track near its neutral speed"]
    if k < SLOPE_FLIPPED:
        return [f"{source}: channel {named(('lateral_acceleration', 'yaw_rate'))}: ay is {k:.2f} times vx r over "
                f"{n} {what} samples (about +1 on a road): one of them looks like the opposite sign convention, "
                "unless the car turned slowly on a steep banked track"]
    return []


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
        channel) makes it consistent; the message names that channel.
    """
    return check_balance(signals.vx, signals.ay, signals.r, source, columns)


def check_balance(vx, ay, r, source="signals", columns: dict | None = None) -> list[str]:
    """:func:`check_consistency` of the arrays ``vx`` (m/s), ``ay`` (m/s^2), ``r`` (rad/s)."""
    vx, ay, r = (np.asarray(a, float) for a in (vx, ay, r))
    res, n, sel = _residual(vx, ay, r)
    if n < MIN_SAMPLES:
        return gentle_warnings(gentle_sums(vx, ay, r), source, columns)
    named = _namer(columns)
    if res <= LIMIT:
        return _slope_warnings(_slope(vx, ay, r, sel), n, "turning", source, named)
    for roles, text, fix in CANDIDATES:
        fres, fn, _ = _residual(*fix(vx, ay, r))
        if fn >= MIN_SAMPLES and fres <= FIXED:
            raise LogError(f"{source}: channel {named(roles)}: {text}: ay, vx and yaw rate do not balance "
                           f"(median |ay - vx r| = {res:.1f} m/s^2 over {n} turning samples, "
                           f"{fres:.1f} m/s^2 after correcting it); fix the unit or sign in the channel map")
    return [f"{source}: ay, vx and yaw rate do not balance (median |ay - vx r| = {res:.1f} m/s^2 over "
            f"{n} turning samples, more than 0.8 g): check the units and sign conventions of "
            "'speed', 'lateral_acceleration' and 'yaw_rate'"]

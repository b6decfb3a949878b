"""Simulated mixed drives with known parameters, to check the identification.

:func:`mixed_drive` builds a :class:`roadbank.sim.Scenario` of a few minutes of
ordinary driving: straights at several speeds (with speed changes and lane
changes), left and right corners of constant radius entered through clothoid
transitions, a road crown on the straights and superelevation in the corners.
The corners are sized for a target lateral acceleration at the speed driven
through them, so the drive stays in the tyres' linear range by construction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .driver import Driver
from .road import Road
from .scenario import Scenario

LANE_WIDTH = 3.5  #: lateral offset of a lane change (m)


@dataclass(frozen=True)
class DriveSpec:
    """Shape of a :func:`mixed_drive` (SI).

    Parameters
    ----------
    n_corners : int
        Number of constant-radius corners (alternating sides, random order).
    speeds : (float, float)
        Range of the speeds driven (m/s), drawn per leg.
    ay_corner : (float, float)
        Range of the lateral acceleration in the corners (m/s^2).
    corner_time : (float, float)
        Range of the time spent on each arc (s).
    straight_time : (float, float)
        Range of the time spent on each straight (s).
    lane_change_prob : float
        Probability that a straight contains a lane change (-).
    crown : float
        Bank of the straights (rad, ISO: left side up), e.g. ``atan(0.02)``
        for a right-hand-traffic lane draining to the right.
    superelevation : float
        Bank of the corners (rad, towards the inside of the corner).
    """

    n_corners: int = 8
    speeds: tuple = (12.0, 30.0)
    ay_corner: tuple = (1.0, 3.0)
    corner_time: tuple = (5.0, 9.0)
    straight_time: tuple = (8.0, 14.0)
    lane_change_prob: float = 0.6
    crown: float = 0.0
    superelevation: float = 0.0


def mixed_drive(seed: int = 0, spec: DriveSpec | None = None, name: str = "mixed-drive") -> Scenario:
    """A seeded :class:`~roadbank.sim.Scenario` of mixed driving (see the module docstring).

    Parameters
    ----------
    seed : int
        Seed of the leg speeds, corner sides, radii and durations.
    spec : DriveSpec, optional
    name : str

    Returns
    -------
    Scenario
        Road with curvature (1/m) and bank (rad) profiles along the path, a
        closed-loop driver with a speed schedule (m/s against s) and a lane
        path (m against m); its ``duration`` (s) covers the whole drive.
    """
    spec = spec or DriveSpec()
    rng = np.random.default_rng(seed)
    transition_t = 2.0
    t, s = 0.0, 0.0
    v = float(rng.uniform(*spec.speeds))
    sp_t, sp_v = [0.0], [v]          # speed target against time
    cs, ck = [0.0], [0.0]            # curvature against path distance
    bs, bf = [0.0], [spec.crown]     # bank factor against path distance (profile = 1 rad)
    ps, pn = [0.0], [0.0]            # lateral path against path distance
    lane = 0.0
    sides = np.resize([1.0, -1.0], spec.n_corners)
    rng.shuffle(sides)

    def straight(v_new: float) -> None:
        nonlocal t, s, v, lane
        T = float(rng.uniform(*spec.straight_time))
        # hold, ramp to the new speed in the middle third, hold
        t1, t2 = t + T / 3.0, t + 2.0 * T / 3.0
        sp_t.extend([t1, t2]); sp_v.extend([v, v_new])
        s1 = s + v * T / 3.0
        s2 = s1 + 0.5 * (v + v_new) * T / 3.0
        s_end = s2 + v_new * T / 3.0
        if rng.random() < spec.lane_change_prob:
            # a lane change (3 s long) in the first third, at constant speed
            target = LANE_WIDTH if lane == 0.0 else 0.0
            a = s + 0.2 * (s1 - s)
            ps.extend([a, a + 3.0 * v]); pn.extend([lane, target])
            lane = target
        t, s, v = t + T, s_end, v_new

    for side in sides:
        straight(float(rng.uniform(*spec.speeds)))
        ay = float(rng.uniform(*spec.ay_corner))
        kappa = side * ay / v**2
        T = float(rng.uniform(*spec.corner_time))
        bank = -side * spec.superelevation
        s_in, s_arc = s + transition_t * v, s + (transition_t + T) * v
        s_out = s_arc + transition_t * v
        cs.extend([s, s_in, s_arc, s_out]); ck.extend([0.0, kappa, kappa, 0.0])
        bs.extend([s, s_in, s_arc, s_out]); bf.extend([spec.crown, bank, bank, spec.crown])
        t += 2.0 * transition_t + T
        s = s_out
        sp_t.append(t); sp_v.append(v)
    straight(float(rng.uniform(*spec.speeds)))
    road = Road(curvature=(cs, ck), bank_profile=((0.0,), (1.0,)), bank_factor=(bs, bf),
                lanes={"right": 0.0, "left": LANE_WIDTH}, name=name)
    path = (ps, pn) if len(ps) > 1 else ((0.0,), (0.0,))
    driver = Driver(speed=(sp_t, sp_v), path=path)
    return Scenario(name, road, driver, duration=t,
                    description=f"mixed drive, seed {seed}: {spec.n_corners} corners, {t:.0f} s")



@dataclass(frozen=True)
class ProcedureSpec:
    """The identification drive of :func:`identification_drive` (SI).

    Parameters
    ----------
    speeds : tuple of float
        The speeds of the steady-state circles (m/s), one stage each, slowest first.
    ay_left, ay_right : float
        Lateral acceleration (m/s^2) of the left and of the right half circle of every stage:
        two levels within the tyres' linear range (below ``IdentifySettings.ay_max``).
    straight_time : float
        Time on each straight (s); a lane change in its first third (a yaw transient).
    transition_time : float
        Clothoid entry and exit of each half circle (s): the yaw transients that separate
        ``Cf`` from ``Cr``.
    cross_slope : float
        Cross slope of the straights (rad): one straight out, one back over the same
        pavement, so the car sees it as ``+cross_slope`` and ``-cross_slope`` in turn and it
        averages out of the accelerometer offset. Above about 0.015 one of the two directions
        no longer counts as straight ahead (``IdentifySettings.straight_ay``).
    """

    speeds: tuple = (12.0, 17.0, 22.0)
    ay_left: float = 2.5
    ay_right: float = 3.5
    straight_time: float = 20.0
    transition_time: float = 2.0
    cross_slope: float = 0.01


def identification_drive(spec: ProcedureSpec | None = None, name: str = "identification-drive") -> Scenario:
    """The drive ``roadbank identify`` needs, as a test-track procedure on a vehicle dynamics area.

    For each speed of ``spec.speeds``: a straight out (lane change in it), a left half circle
    (180 deg) at ``ay_left``, the straight back (another lane change), a right half circle at
    ``ay_right``; the speed changes to the next stage on the first straight of each stage.
    The half circles are entered and left through clothoids of ``transition_time``. About
    4.4 minutes with the defaults (docs/identification.md, "A drive to identify from").

    Returns
    -------
    Scenario
        Road with curvature (1/m) and bank (rad) profiles along the path, a closed-loop driver
        with a speed schedule (m/s against s) and a lane path (m against m).
    """
    spec = spec or ProcedureSpec()
    tt = spec.transition_time
    v = float(spec.speeds[0])
    t, s = 0.0, 0.0
    sp_t, sp_v = [0.0], [v]
    cs, ck = [0.0], [0.0]
    bs, bf = [], []                  # bank factor against path distance (profile = 1 rad)
    ps, pn = [0.0], [0.0]
    lane = 0.0

    def straight(v_new: float, slope: float) -> None:
        nonlocal t, s, v, lane
        T = spec.straight_time
        t1, t2 = t + T / 3.0, t + 2.0 * T / 3.0        # hold, change speed, hold
        sp_t.extend([t1, t2]); sp_v.extend([v, v_new])
        s1 = s + v * T / 3.0
        s_end = s1 + 0.5 * (v + v_new) * T / 3.0 + v_new * T / 3.0
        target = LANE_WIDTH if lane == 0.0 else 0.0   # a 3 s lane change in the first third
        a = s + 0.1 * (s1 - s)
        ps.extend([a, a + 3.0 * v]); pn.extend([lane, target])
        lane = target
        bs.extend([s, s_end]); bf.extend([slope, slope])
        t, s, v = t + T, s_end, v_new

    def half_circle(side: float, ay: float) -> None:
        nonlocal t, s
        kappa = side * ay / v**2
        arc = max(np.pi * v / ay - tt, 0.0)             # heading: kappa v (arc + tt) = pi
        s_in, s_arc = s + tt * v, s + (tt + arc) * v
        s_out = s_arc + tt * v
        cs.extend([s, s_in, s_arc, s_out]); ck.extend([0.0, kappa, kappa, 0.0])
        bs.extend([s_in, s_arc]); bf.extend([0.0, 0.0])
        t += 2.0 * tt + arc
        s = s_out
        sp_t.append(t); sp_v.append(v)

    for v_stage in spec.speeds:
        straight(float(v_stage), spec.cross_slope)
        half_circle(1.0, spec.ay_left)
        straight(float(v_stage), -spec.cross_slope)
        half_circle(-1.0, spec.ay_right)
    straight(v, spec.cross_slope)
    road = Road(curvature=(cs, ck), bank_profile=((0.0,), (1.0,)), bank_factor=(bs, bf),
                lanes={"right": 0.0, "left": LANE_WIDTH}, name=name)
    return Scenario(name, road, Driver(speed=(sp_t, sp_v), path=(ps, pn)), duration=t,
                    description=f"identification drive: half circles at {', '.join(f'{x:g}' for x in spec.speeds)} "
                                f"m/s ({spec.ay_left:g} and {spec.ay_right:g} m/s^2), straights out and back, "
                                f"{t:.0f} s")

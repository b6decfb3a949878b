"""Thresholds and assumptions of the identification (one documented place; see docs/identification.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields


@dataclass(frozen=True)
class IdentifySettings:
    """Settings of :func:`roadbank.identification.identify` (SI units).

    Parameters
    ----------
    v_min : float
        Samples below this speed (m/s) are not used (slip angles ~ 1/vx). Default 8.
    ay_max : float
        Linear range: samples with |ay| above this (m/s^2) are left out of the
        stiffness regression. Default 4 (about 0.4 g; see the docs for the check).
    ax_max : float
        Samples with |dvx/dt| above this (m/s^2) are left out (longitudinal load
        transfer and combined slip). Default 2.
    f_cut : float
        Cut-off (Hz) of the zero-phase low-pass applied to every signal. Default 2.
    min_run : float
        Shortest stretch of usable driving (s) that is kept. Default 4.
    edge : float
        Time (s) dropped at both ends of each stretch (filter start-up). Default 1.
    block : float
        Block length (s) of the block bootstrap. Default 5.
    n_boot : int
        Bootstrap replicates. Default 1000.
    seed : int
        Seed of the bootstrap (results are deterministic for a seed).
    straight_r : float
        A straight: |yaw rate - its most common value| below this (rad/s) ...
        Default 0.005 (0.29 deg/s, a 4 km radius at 20 m/s).
    straight_ay : float
        ... and |ay - its most common value| below this (m/s^2), default 0.4 ...
    straight_min : float
        ... for at least this long (s). Default 3.
    min_straight : float
        Straight driving (s) needed for the sensor offsets. Default 10.
    corner_ay : float
        A quasi-steady corner: |ay| of at least this (m/s^2), default 1 ...
    corner_rdot : float
        ... with |yaw acceleration| below this (rad/s^2; of the yaw rate low-passed at
        ``1 / corner_min`` Hz, so gyro noise does not break a corner), default 0.02 ...
    corner_min : float
        ... for at least this long (s). Default 2.
    min_corners : int
        Quasi-steady corners needed for the understeer gradient. Default 3.
    min_blocks : int
        Bootstrap blocks needed for any regression. Default 8.
    max_rel_std : float
        A stiffness or understeer gradient whose relative standard uncertainty
        exceeds this is refused (not excited enough). Default 0.2.
    roll_gain_rel_std : float
        Relative uncertainty of the base vehicle's roll gain (used to turn ``ay``
        into tyre forces when the log has no roll reference), propagated into
        ``Kus``, ``Cf``, ``Cr``. Default 0.1.
    straight_bank : float
        Assumed mean bank (rad, ISO: left side up) of the straights driven; the ay
        offset is relative to it. Default 0 (flat; a 2 % crown is 0.02).
    """

    v_min: float = 8.0
    ay_max: float = 4.0
    ax_max: float = 2.0
    f_cut: float = 2.0
    min_run: float = 4.0
    edge: float = 1.0
    block: float = 5.0
    n_boot: int = 1000
    seed: int = 0
    straight_r: float = 0.005
    straight_ay: float = 0.4
    straight_min: float = 3.0
    min_straight: float = 10.0
    corner_ay: float = 1.0
    corner_rdot: float = 0.02
    corner_min: float = 2.0
    min_corners: int = 3
    min_blocks: int = 8
    max_rel_std: float = 0.2
    roll_gain_rel_std: float = 0.1
    straight_bank: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise ValueError(f"IdentifySettings.{f.name} must be a finite number, got {v!r}")
            if f.name != "straight_bank" and f.name != "seed" and v <= 0:
                raise ValueError(f"IdentifySettings.{f.name} must be > 0, got {v!r}")
        if abs(self.straight_bank) >= math.radians(20):
            raise ValueError("IdentifySettings.straight_bank must be below 20 deg")

r"""Sensor offsets of the yaw rate and the lateral accelerometer from straight driving.

On a straight the true yaw rate is zero, so the mean measured yaw rate is its
offset. The accelerometer on a straight reads its offset plus the tyre force
that holds the car on the road's cross slope, tilted by the body roll that
slope causes:

.. math::
    \bar a_y = b_{ay} + g \sin\bar\phi_b\,(1 + g k_\phi)

The mean bank :math:`\bar\phi_b` of the straights driven cannot be told from
the ESP signals (a crowned road and an accelerometer offset look alike), so it
is an assumption (``IdentifySettings.straight_bank``, default 0): the offset is
relative to it. Uncertainties: block bootstrap over the straight blocks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .blocks import chop, robust_std
from .results import Quantity, refused
from .segments import Segmented
from .settings import IdentifySettings


@dataclass(frozen=True)
class Offsets:
    """Offsets applied to one log: yaw rate (rad/s) and lateral acceleration (m/s^2)."""

    r: float
    ay: float


def _block_sums(seg: Segmented, s: IdentifySettings) -> np.ndarray:
    """Rows ``(n, sum r, sum ay)`` of every straight block of a log."""
    rows = []
    for p in seg.pieces:
        for a, b in chop(p.straight, int(round(s.block * seg.fs)), 1):
            rows.append((b - a, p.r[a:b].sum(), p.ay[a:b].sum()))
    return np.array(rows, dtype=float).reshape(-1, 3)


def straight_offsets(segs: list[Segmented], s: IdentifySettings, g: float, roll_gain: float
                     ) -> tuple[list[Offsets | None], Quantity, Quantity]:
    """Offsets per log and pooled over all logs.

    Parameters
    ----------
    segs : list of Segmented
    s : IdentifySettings
    g : float
        Gravity (m/s^2).
    roll_gain : float
        Steady body roll per lateral acceleration (rad per m/s^2), for the tilt term.

    Returns
    -------
    per_log : list of Offsets or None
        Offsets of each log that has at least ``s.min_straight`` s of straight driving.
    yaw_rate_offset, ay_offset : Quantity
        Pooled estimates (rad/s, m/s^2) with block-bootstrap standard deviations, or refusals.
    """
    bank_term = g * np.sin(s.straight_bank) * (1.0 + g * roll_gain)
    per_log, all_rows, used = [], [], 0.0
    for seg in segs:
        rows = _block_sums(seg, s)
        if rows[:, 0].sum() / seg.fs >= s.min_straight:
            used += rows[:, 0].sum() / seg.fs
            per_log.append(Offsets(rows[:, 1].sum() / rows[:, 0].sum(),
                                   rows[:, 2].sum() / rows[:, 0].sum() - bank_term))
            all_rows.append(rows)
        else:
            per_log.append(None)
    secs = sum(seg.seconds["straight"] for seg in segs)
    if not all_rows or len(np.concatenate(all_rows)) < 2:
        why = (f"no straight driving to read the offsets from: {secs:.1f} s of straight "
               f"(|yaw rate| within {np.degrees(s.straight_r):.2f} deg/s and |ay| within "
               f"{s.straight_ay} m/s^2 of straight ahead for >= {s.straight_min:g} s, at >= {s.v_min:g} m/s) "
               f"in a log; needs >= {s.min_straight:g} s")
        return per_log, refused("yaw_rate_offset", "rad/s", why), refused("ay_offset", "m/s^2", why)
    rows = np.concatenate(all_rows)
    rng = np.random.default_rng(s.seed)
    k = len(rows)
    counts = rng.multinomial(k, np.full(k, 1.0 / k), size=s.n_boot)
    tot = counts @ rows
    br_boot = tot[:, 1] / tot[:, 0]
    ba_boot = tot[:, 2] / tot[:, 0] - bank_term
    n = rows[:, 0].sum()
    note = f"mean over {used:.0f} s of straight driving; block bootstrap"
    q_r = Quantity("yaw_rate_offset", float(rows[:, 1].sum() / n), robust_std(br_boot), "rad/s", note)
    q_a = Quantity("ay_offset", float(rows[:, 2].sum() / n - bank_term), robust_std(ba_boot), "m/s^2",
                   note + f"; relative to an assumed mean bank of the straights of "
                          f"{np.degrees(s.straight_bank):.2f} deg")
    return per_log, q_r, q_a

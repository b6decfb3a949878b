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
from .prepare import runs
from .quantisation import mean_bias_bound, quantisation_step
from .results import Quantity, measured, refused
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


def straight_bias_bound(segs: list[Segmented], channel: str, s: IdentifySettings) -> float:
    """Largest quantisation bias (:func:`.quantisation.mean_bias_bound`) of ``channel``
    (``"r"``, ``"ay"`` or ``"delta"``) over the straights of the logs (its units; ``inf`` when the
    channel never changes in a log, so its resolution cannot be told)."""
    bounds = [mean_bias_bound([getattr(p, channel)[a:b] for p in seg.pieces for a, b in runs(p.straight)],
                              quantisation_step(np.concatenate([getattr(p, channel) for p in seg.pieces])))
              for seg in segs]
    return max(bounds, default=0.0)


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
        Pooled estimates (rad/s, m/s^2) with block-bootstrap standard deviations (and the
        quantisation bias bound in quadrature), or refusals.
    """
    bank_term = g * np.sin(s.straight_bank) * (1.0 + g * roll_gain)
    per_log: list[Offsets | None] = []
    all_rows, used = [], 0.0
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
    note = f"mean over {used:.0f} s of straight driving; block bootstrap + quantisation bias bound"
    sd_r = float(np.hypot(robust_std(br_boot), straight_bias_bound(segs, "r", s)))
    sd_a = float(np.hypot(robust_std(ba_boot), straight_bias_bound(segs, "ay", s)))
    q_r = measured("yaw_rate_offset", float(rows[:, 1].sum() / n), sd_r, "rad/s", note)
    q_a = measured("ay_offset", float(rows[:, 2].sum() / n - bank_term), sd_a, "m/s^2",
                   note + f"; relative to an assumed mean bank of the straights of "
                          f"{np.degrees(s.straight_bank):.2f} deg")
    return per_log, q_r, q_a


def straight_steering_offset(segs: list[Segmented], kus: float, s: IdentifySettings, g: float) -> Quantity:
    r"""Steering offset (rad, road-wheel angle) from the straights alone.

    On a straight, :math:`\delta_f = b_\delta + K_{us}\, g\sin\bar\phi_b` (the
    steady-state relation with :math:`r = 0` and the tyre force that holds the car
    on the assumed mean bank), so :math:`b_\delta` is the mean steering angle less
    that term. Used when the logs have no cornering to run the regression of
    :mod:`.stiffness`; ``kus`` (rad s^2/m) is then the base vehicle's, an assumption, so the term's size is
    added to the uncertainty (in quadrature).
    """
    blocks = []
    for seg in segs:
        for p in seg.pieces:
            for a, b in chop(p.straight, int(round(s.block * seg.fs)), 1):
                blocks.append((b - a, p.delta[a:b].sum()))
    rows = np.array(blocks, dtype=float).reshape(-1, 2)
    secs = sum(seg.seconds["straight"] for seg in segs)
    if len(rows) < 2 or secs < s.min_straight:
        return refused("steering_offset", "rad",
                       f"needs straight driving (>= {s.min_straight:g} s, found {secs:.1f} s) or cornering")
    turn = kus * g * np.sin(s.straight_bank)
    rng = np.random.default_rng(s.seed)
    counts = rng.multinomial(len(rows), np.full(len(rows), 1.0 / len(rows)), size=s.n_boot)
    tot = counts @ rows
    # the bank term rests on the base vehicle's Kus, which the logs did not tell: its size is in the uncertainty
    # (a sports car's logs with a base Kus 2.4 times its own had the offset 0.04 deg off, 12 stated sigmas)
    sd = float(np.sqrt(robust_std(tot[:, 1] / tot[:, 0]) ** 2 + straight_bias_bound(segs, "delta", s) ** 2
                       + turn ** 2))
    return measured("steering_offset", float(rows[:, 1].sum() / rows[:, 0].sum() - turn), sd, "rad",
                    f"mean road-wheel angle over {secs:.0f} s of straight driving (measured minus true), "
                    f"base vehicle's Kus for the bank term ({np.degrees(turn):.3g} deg, in the uncertainty); "
                    f"block bootstrap + quantisation bias bound")

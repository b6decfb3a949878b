"""Find what kind of driving a log contains: usable stretches, straights, quasi-steady corners.

:func:`segment` turns one log's signals into a :class:`Segmented` log: the
stretches driven at ``v_min`` or faster (``pieces``), and per piece the masks of
straight driving, quasi-steady cornering and the samples the stiffness
regression may use (linear range, no hard acceleration or braking, away from
the filter's start-up at the ends). Offsets of the sensors are not known yet
here, so straights and corners are found relative to the most common yaw rate
and lateral acceleration of the log (the straight-ahead values). A corner's
steady yaw rate is read from the yaw rate low-passed at ``1 / corner_min``: the
yaw acceleration of the ``f_cut`` low-pass carries enough of a noisy gyro's
noise to break every corner into pieces shorter than ``corner_min``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .prepare import Grid, derivative, lowpass, runs
from .settings import IdentifySettings


@dataclass
class Piece:
    """One stretch of usable driving (raw and low-passed signals, SI) and its masks."""

    vx: np.ndarray
    ay: np.ndarray
    r: np.ndarray
    delta: np.ndarray
    roll: np.ndarray | None
    ay_f: np.ndarray
    r_f: np.ndarray
    rdot_f: np.ndarray
    vxdot_f: np.ndarray
    # the masks: set by :func:`segment` before any use
    straight: np.ndarray = field(default=None)  # type: ignore[arg-type]
    corner: np.ndarray = field(default=None)  # type: ignore[arg-type]
    regress: np.ndarray = field(default=None)  # type: ignore[arg-type]


@dataclass
class Segmented:
    """A log cut into :class:`Piece` s, with the totals the excitation checks need.

    ``seconds``: durations (s) of ``total``, ``usable`` (>= v_min), ``straight``,
    ``corners``; ``n_corners``: quasi-steady corners; ``speed_range`` (m/s) of
    the usable driving; ``fs`` (Hz).
    """

    pieces: list
    fs: float
    seconds: dict
    n_corners: int
    speed_range: tuple


def _mode(x: np.ndarray, width: float) -> float:
    """Most common value of ``x`` (centre of the fullest histogram bin of ``width``)."""
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return 0.0
    lo = np.floor(x.min() / width) * width
    nb = max(1, int(np.ceil((x.max() - lo) / width)) + 1)
    h, e = np.histogram(x, bins=nb, range=(lo, lo + nb * width))
    k = int(np.argmax(np.convolve(h, [1, 2, 1])[1:-1]))  # same length as h, smoothed
    return float(0.5 * (e[k] + e[k + 1]))


def _hold(mask: np.ndarray, n: int) -> np.ndarray:
    """``mask`` with the True stretches shorter than ``n`` samples cleared."""
    out = np.zeros_like(mask, dtype=bool)
    for a, b in runs(mask, n):
        out[a:b] = True
    return out


def _grow(mask: np.ndarray, n: int) -> np.ndarray:
    """``mask`` widened by ``n`` samples on both sides of every True sample."""
    if n <= 0 or not mask.any():
        return mask.copy()
    c = np.convolve(mask.astype(float), np.ones(2 * n + 1), mode="same")
    return c > 0.5


def segment(grid: Grid, s: IdentifySettings) -> Segmented:
    """Cut a :class:`~.prepare.Grid` into usable pieces and classify their samples.

    Parameters
    ----------
    grid : Grid
    s : IdentifySettings

    Returns
    -------
    Segmented
    """
    fs = grid.fs
    finite = np.isfinite(grid.vx) & np.isfinite(grid.ay) & np.isfinite(grid.r) & np.isfinite(grid.delta)
    if grid.roll is not None:
        finite &= np.isfinite(grid.roll)
    usable = finite & (grid.vx >= s.v_min)
    pieces = []
    for a, b in runs(usable, int(round(s.min_run * fs))):
        sl = slice(a, b)
        ay_f, r_f = lowpass(grid.ay[sl], fs, s.f_cut), lowpass(grid.r[sl], fs, s.f_cut)
        vx_f = lowpass(grid.vx[sl], fs, s.f_cut)
        pieces.append(Piece(grid.vx[sl], grid.ay[sl], grid.r[sl], grid.delta[sl],
                            None if grid.roll is None else grid.roll[sl],
                            ay_f, r_f, derivative(r_f, fs), derivative(vx_f, fs)))
    seconds = {"total": len(grid.t) / fs, "usable": sum(len(p.vx) for p in pieces) / fs,
               "straight": 0.0, "corners": 0.0}
    if not pieces:
        return Segmented([], fs, seconds, 0, (float("nan"), float("nan")))
    r0 = _mode(np.concatenate([p.r_f for p in pieces]), s.straight_r / 2)
    a0 = _mode(np.concatenate([p.ay_f for p in pieces]), s.straight_ay / 4)
    n_edge = int(round(s.edge * fs))
    n_corners = 0
    for p in pieces:
        inner = np.zeros(len(p.vx), dtype=bool)
        inner[n_edge:len(p.vx) - n_edge] = True
        calm = np.abs(p.vxdot_f) <= s.ax_max
        p.straight = _hold(inner & calm & (np.abs(p.r_f - r0) < s.straight_r)
                           & (np.abs(p.ay_f - a0) < s.straight_ay), int(round(s.straight_min * fs)))
        # the yaw rate's trend over a corner's shortest duration: white gyro noise of 0.7 deg/s at 100 Hz
        # spreads rdot_f by about 0.016 rad/s^2 (near corner_rdot, 0.02), this by about 0.002
        rdot_c = derivative(lowpass(p.r, fs, 1.0 / s.corner_min), fs)
        steady = (inner & calm & (np.abs(p.ay_f - a0) >= s.corner_ay) & (np.abs(p.ay_f) <= s.ay_max)
                  & (np.abs(rdot_c) < s.corner_rdot))
        p.corner = _hold(steady, int(round(s.corner_min * fs)))
        n_corners += len(runs(p.corner))
        # the filter spreads a short excursion beyond ay_max over about 1/f_cut: keep clear of it
        wild = _grow((np.abs(p.ay) > s.ay_max) | (np.abs(p.vxdot_f) > s.ax_max), int(round(fs / s.f_cut)))
        p.regress = inner & ~wild
    seconds["straight"] = sum(p.straight.sum() for p in pieces) / fs
    seconds["corners"] = sum(p.corner.sum() for p in pieces) / fs
    vx = np.concatenate([p.vx for p in pieces])
    return Segmented(pieces, fs, seconds, n_corners, (float(vx.min()), float(vx.max())))

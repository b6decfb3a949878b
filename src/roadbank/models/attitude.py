r"""Attitude kinematics of a car body: its pitch from the longitudinal accelerometer, and the rate of its roll angle.

A body-fixed gyro measures the body rates :math:`(p, q, r)` about the car's own axes (ISO 8855: x forward, y left,
z up). The roll *angle* :math:`\theta` (the Euler angle of the yaw-pitch-roll sequence, what an INS reports and
what the bank estimators estimate) changes at

.. math::
    \dot\theta = p + (q \sin\theta + r \cos\theta) \tan\vartheta \approx p + r \tan\vartheta

with :math:`\vartheta` the pitch (positive nose down, ISO). On a grade, turning rotates pitch into roll: a car
that circles on a tilted plane has :math:`p = q = 0` while its roll angle swings with its heading. So a filter that
integrates :math:`p` needs the pitch, and a log with a longitudinal accelerometer gives it: the specific force along
the forward axis is :math:`a_x = \dot v_x - g \sin\vartheta` (no lateral-velocity term to speak of: :math:`v_y r`
is below 0.01 m/s^2 in normal driving), so over a window :math:`[t - W, t]`

.. math::
    \sin\hat\vartheta(t) = \frac{v_x(t) - v_x(t - W) - \int_{t-W}^{t} a_x \,dt}{g\, W}

a causal mean of :math:`(\dot v_x - a_x)/g` that needs no derivative of the speed. A mount tilted about y adds
the same angle to :math:`\hat\vartheta` as it moves :math:`r` into the measured roll rate, so the correction
compensates it too (to first order).

A log with a pitch-rate gyro as well gives the pitch without the window's lag: the Euler pitch changes at

.. math::
    \dot\vartheta = q \cos\theta - r \sin\theta

(:func:`euler_pitch_rate`; the roll :math:`\theta` there can be the kinematic one, :func:`kinematic_roll`: its
noise is integrated and so averages out), which an observer fuses with the accelerometer's slow reading
(:mod:`roadbank.estimators.pitch`).
"""

from __future__ import annotations

import math

import numpy as np

from ..constants import G

__all__ = ["MAX_SIN_PITCH", "running_area", "grade_pitch", "euler_roll_rate", "euler_pitch_rate", "kinematic_roll"]

#: the sine of the steepest pitch :func:`grade_pitch` reports (20 deg; a steeper reading is a fault, not a road)
MAX_SIN_PITCH = 0.34


def running_area(t, vx, ax, start: tuple[float, float] = (0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """The running integral of ``ax`` (m/s; trapezoidal over the times ``t``, s) and the running count of intervals
    that touch a non-finite ``vx`` or ``ax`` (taken as 0 in the integral), from ``start`` (both, at the first
    sample): a log read in pieces continues from the values at a piece's first sample, to the last bit."""
    t, vx, ax = (np.asarray(a, dtype=np.float64) for a in (t, vx, ax))
    bad = ~(np.isfinite(vx) & np.isfinite(ax))
    a = np.where(bad, 0.0, ax)
    area = np.cumsum(np.concatenate([[start[0]], 0.5 * (a[1:] + a[:-1]) * np.diff(t)]))   # sequential: exact carry
    nbad = np.cumsum(np.concatenate([[start[1]], bad[1:] | bad[:-1]]))
    return area, nbad


def grade_pitch(t, vx, ax, window: float, g: float = G, area=None, first_span: float = math.inf,
                max_gap: float = math.inf) -> np.ndarray:
    r"""The pitch (rad, positive nose down) from the speed and the longitudinal accelerometer, causal (module
    docstring).

    Parameters
    ----------
    t : array (s)
        Sample times, increasing.
    vx : array (m/s)
        Longitudinal speed.
    ax : array (m/s^2)
        Longitudinal specific force (positive forward).
    window : float
        ``W`` (s, > 0): the span each estimate averages, ending at its own sample.
    g : float, optional
        Gravity (m/s^2).
    area : tuple of arrays, optional
        :func:`running_area` of these samples (default: from 0 at the first).
    first_span : float, optional
        Before the log (its first sample here) has lasted ``window``, the span (s, > 0) after which the estimate
        averages from the first sample instead (a window growing to ``window``); ``inf`` (default): none.
    max_gap : float, optional
        An interval between consecutive samples longer than this (s, > 0) starts the log again: the samples before
        it are not read (no window reaches back across it, the speed's change across it is no grade) and
        ``first_span`` counts from the first sample after it. The filter's own restart gap
        (:class:`~roadbank.estimators.gyro.KinematicGyro`'s ``max_gap``); ``inf`` (default): none.

    Returns
    -------
    array (rad)
        NaN where the log (since its last restart) has not yet lasted ``window`` (or ``first_span``), where a
        non-finite ``vx`` or ``ax`` lies in the window (its ends included) or where the reading is steeper than
        :data:`MAX_SIN_PITCH`.
    """
    t, vx, ax = (np.asarray(a, dtype=np.float64) for a in (t, vx, ax))
    area, nbad = running_area(t, vx, ax) if area is None else area
    bad = ~(np.isfinite(vx) & np.isfinite(ax))
    n = len(t)
    with np.errstate(invalid="ignore"):
        restart = np.concatenate([[True], np.diff(t) > max_gap])[:n]
    first = np.maximum.accumulate(np.where(restart, np.arange(n), 0))   # the (re)start each sample's log began at
    start = np.searchsorted(t, t - window, side="right") - 1     # the last sample at least the window back
    inside = start >= first                                      # ... since that (re)start
    ok = inside | (t - t[first] >= first_span)                   # else: from the (re)start, once first_span in
    m = np.where(inside, start, first)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = (vx - vx[m] - (area - area[m])) / (g * (t - t[m]))
    ok &= (nbad - nbad[m] == 0) & ~bad & ~bad[m] & (np.abs(s) <= MAX_SIN_PITCH)
    return np.where(ok, np.arcsin(np.clip(s, -1.0, 1.0)), np.nan)


def euler_roll_rate(p, r, pitch) -> np.ndarray:
    r"""The rate of the roll angle (rad/s) from the body roll rate ``p`` and yaw rate ``r`` (rad/s) and the pitch
    (rad, positive nose down): :math:`p + r \tan\vartheta` (module docstring; :math:`\cos\theta` taken as 1 and the
    :math:`q \sin\theta` term, a product of the roll angle and the pitch rate, left out). Where the pitch is not
    finite, ``p`` as it is."""
    p, r, pitch = (np.asarray(a, dtype=np.float64) for a in (p, r, pitch))
    with np.errstate(invalid="ignore"):
        lean = r * np.tan(pitch)
    return np.where(np.isfinite(lean), p + lean, p)


def euler_pitch_rate(q, r, roll) -> np.ndarray:
    r"""The rate of the pitch angle (rad/s, positive nose down) from the body pitch rate ``q`` and yaw rate ``r``
    (rad/s) and the roll angle (rad, positive left side up): :math:`q \cos\theta - r \sin\theta` (module
    docstring)."""
    q, r, roll = (np.asarray(a, dtype=np.float64) for a in (q, r, roll))
    return q * np.cos(roll) - r * np.sin(roll)


def kinematic_roll(vx, ay, r, g: float = G) -> np.ndarray:
    r"""The kinematic roll (rad): :math:`\arcsin((a_y - v_x r)/g)`, the argument clipped to [-1, 1]; ``vx`` (m/s),
    ``ay`` (m/s^2), ``r`` (rad/s), ``g`` (m/s^2). It carries the sideslip acceleration and the road's vibration; for
    :func:`euler_pitch_rate` that is enough."""
    vx, ay, r = (np.asarray(a, dtype=np.float64) for a in (vx, ay, r))
    with np.errstate(invalid="ignore"):
        return np.arcsin(np.clip((ay - vx * r) / g, -1.0, 1.0))

r"""The start of ``kinematic-gyro``: the Kalman filter whose steady state is the complementary filter.

At a (re)start the complementary filter of :mod:`roadbank.estimators.gyro` takes the first sample's kinematic
estimate :math:`k_0` as its state and no offset, and its fixed gains then treat that one sample as if it were as good
as a state built from many: the offset state learns about a tenth of :math:`k_0`'s error and takes :math:`T_b` to
forget it. The Kalman filter of the filter's own model,

.. math::
    \theta_n = \theta_{n-1} + \Delta t\,(\bar p_n - b_{n-1}) + w_{1}, \qquad b_n = b_{n-1} + w_{2},
    \qquad k_n = \theta_n + v_n,

(:math:`\bar p_n` the mean roll rate of the interval, rad/s; :math:`v` of variance :math:`\sigma_k^2` per sample;
:math:`w` of covariance :math:`\Delta t\, Q` with the densities :math:`R = \sigma_k^2 \Delta t` and
:math:`Q = R\,\mathrm{diag}(\omega_c^2 - 2 k_i,\ k_i^2)`, :math:`k_i = \omega_c / T_b`) has in steady state the
complementary filter's gains :math:`[\omega_c, -k_i]` (the continuous filter Riccati equation of
:math:`\dot\theta = p - b`, :math:`\dot b = 0` with these densities; tested against scipy), whatever
:math:`\sigma_k`. Started from :math:`x = k_0`, :math:`b = 0`, :math:`P = \mathrm{diag}(\sigma_k^2, \sigma_b^2)`,
it knows that its state is one sample: its first gains average the samples (about :math:`1/n`), and its offset
learns what the samples show, no more than its prior :math:`\sigma_b` allows. Only the ratio
:math:`\sigma_b / \sigma_k` matters; :math:`\sigma_k` is :data:`START_NOISE` (1 deg per sample: what a 10 Hz
``ay`` on a real road carries above the vehicle's band, 0.17-0.22 m/s^2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: the kinematic estimate's noise per sample (rad) that the start's Kalman filter assumes (module docstring)
START_NOISE = math.radians(1.0)


@dataclass(frozen=True)
class KalmanStart:
    """The start's Kalman filter after a sample: time ``t`` (s) of the sample, of the (re)start ``t0`` (s), the roll
    rate ``p`` (rad/s) read there, the state ``x`` (the estimate, sine of the roll) and ``b`` (the roll rate's offset,
    rad/s) and its covariance ``P`` (2x2: -, rad/s)."""

    t: float
    t0: float
    p: float
    x: float
    b: float
    P: np.ndarray


def kalman_begin(t: float, k: float, p: float, offset_sd: float, noise: float = START_NOISE) -> KalmanStart:
    """The filter at a (re)start at time ``t`` (s): the kinematic estimate ``k`` (-) as its state, no offset; the
    roll rate ``p`` (rad/s) read there; the prior of the offset ``offset_sd`` (rad/s) and the noise ``noise`` (-)."""
    return KalmanStart(t, t, p, k, 0.0, np.diag([noise ** 2, offset_sd ** 2]))


def kalman_next(s: KalmanStart, t: float, k: float, p: float, cutoff: float, bias_tau: float,
                noise: float = START_NOISE) -> KalmanStart:
    """The filter after the next sample: time ``t`` (s), kinematic estimate ``k`` (-), roll rate ``p`` (rad/s), for the
    complementary filter of cross-over ``cutoff`` (Hz) and offset time constant ``bias_tau`` (s, > 0) (module
    docstring)."""
    dt = t - s.t
    wc = 2.0 * math.pi * cutoff
    ki = wc / bias_tau
    R = noise ** 2
    Q = R * dt * dt * np.array([max(wc * wc - 2.0 * ki, 0.0), ki * ki])
    A = np.array([[1.0, -dt], [0.0, 1.0]])
    x = s.x + dt * (0.5 * (s.p + p) - s.b)
    P = A @ s.P @ A.T + np.diag(Q)
    gain = P[:, 0] / (P[0, 0] + R)
    innovation = k - x
    P = P - np.outer(gain, P[0, :])
    return KalmanStart(t, s.t0, p, x + gain[0] * innovation, s.b + gain[1] * innovation, 0.5 * (P + P.T))


def first_restart(t, vx, inputs, v_min: float, max_gap: float, started: bool, t_last: float) -> int:
    """The index of the first sample of ``t`` (s) at which an estimator (re)starts (``len(t)``: none), as the compiled
    kernels decide it (:func:`roadbank.estimators.kernels.sample.sample_valid` and ``begin``): a sample is used if its
    time, ``vx`` (m/s, >= ``v_min``) and ``inputs`` (arrays, each the length of ``t``) are finite and its time is after
    the last used one; it starts the estimator if none was used before (``started`` False) or the last used (at
    ``t_last`` s, then the samples before it) is more than ``max_gap`` s earlier."""
    t = np.asarray(t, dtype=np.float64)
    ok = np.isfinite(t) & np.isfinite(vx) & (np.asarray(vx) >= v_min)
    for u in inputs:
        ok &= np.isfinite(u)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return len(t)
    tc = t[idx]
    before = np.maximum.accumulate(np.concatenate([[t_last if started else -math.inf], tc]))[:-1]
    used = tc > before
    gap = np.where(np.isfinite(before), tc - before, math.inf)
    hit = np.flatnonzero(used & (gap > max_gap))
    return int(idx[hit[0]]) if hit.size else len(t)

r"""How far quantisation can bias the mean of a sensor channel (a floor for the offset uncertainties).

A quantiser with step :math:`q` reading a constant value :math:`x` plus white
Gaussian noise :math:`\sigma` has a mean error that is periodic in :math:`x`:
the sawtooth :math:`x - Q(x)` expanded in its Fourier series, each harmonic
damped by the noise's characteristic function (Widrow & Kollar, *Quantization
Noise*, 2008, ch. 5), so

.. math::
    |E[Q(x + n)] - x| \le \min\Big(\frac{q}{2},\ \sum_{k \ge 1} \frac{q}{\pi k} e^{-2\pi^2 k^2\sigma^2/q^2}\Big)

A noise-free channel (typical for a steering angle sensor) can be off by up to
:math:`q/2` on a straight however long it is, while a noisy one averages the
steps away (``sigma = q/3`` leaves 3.5 % of ``q``). Averaging cannot beat this bias, so it is added (in
quadrature) to the bootstrap uncertainty of the offsets.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize
from scipy.stats import norm


def quantisation_step(x: np.ndarray) -> float:
    """Smallest spacing of the distinct finite values of ``x`` (its quantisation step; ~0 if
    continuous; ``nan`` if ``x`` takes a single value, so its step cannot be told)."""
    v = np.unique(x[np.isfinite(x)])
    if len(v) < 2:
        return float("nan")
    d = np.diff(v)
    d = d[d > 1e-9 * max(1.0, float(np.abs(v).max()))]
    return float(d.min()) if len(d) else 0.0


def dither_sigma(x: np.ndarray, q: float) -> float:
    """Spread (std, units of ``x``) of the signal + noise in front of a quantiser, from its output.

    Maximum-likelihood fit of a normal law to the counts of the quantisation
    levels of ``x`` (binned likelihood), which stays right when the spread is
    smaller than ``q``, where the sample variance minus ``q^2/12`` does not.
    A single level gives 0.
    """
    k = np.round(np.asarray(x, dtype=float) / q).astype(np.int64)
    levels, counts = np.unique(k, return_counts=True)
    if len(levels) < 2:
        return 0.0
    edges_lo, edges_hi = (levels - 0.5) * q, (levels + 0.5) * q

    def nll(z):
        mu, sig = z[0], np.exp(z[1])
        pr = norm.cdf((edges_hi - mu) / sig) - norm.cdf((edges_lo - mu) / sig)
        return -float(np.sum(counts * np.log(np.maximum(pr, 1e-300))))

    z0 = [float(np.mean(x)), math.log(max(float(np.std(x)), q / 20))]
    z = minimize(nll, z0, method="Nelder-Mead", options={"xatol": 1e-4 * q, "fatol": 1e-6}).x
    return float(min(np.exp(z[1]), 10 * q))


def mean_bias_bound(x_parts: list[np.ndarray], q: float) -> float:
    """Bound on the quantisation bias of the mean of a channel (its units).

    Parameters
    ----------
    x_parts : list of arrays
        Raw samples of stretches where the true value is constant (e.g. the yaw
        rate on straights) of one channel.
    q : float
        Quantisation step of the channel (:func:`quantisation_step` of all its samples);
        ``nan`` when it cannot be told (a channel that never changes): the bound is then ``inf``.

    Returns
    -------
    float
        The bound of the module docstring, with the dither ``sigma`` the median of
        :func:`dither_sigma` over the stretches.
    """
    parts = [np.asarray(x, dtype=float) for x in x_parts if len(x) > 8]
    if not parts:
        return 0.0
    if not np.isfinite(q):
        return float("inf")
    if q <= 0.0:
        return 0.0
    sigma = float(np.median([dither_sigma(x, q) for x in parts]))
    k = np.arange(1, 201)
    series = float(np.sum(q / (np.pi * k) * np.exp(-2.0 * np.pi**2 * k**2 * sigma**2 / (q * q))))
    return min(0.5 * q, series)

r"""How close a causal estimator is to the best causal linear filter of the same signals.

The kinematic estimate :math:`k = (a_y - v_x r)/g` (``sin`` of theta, the road's bank and the
body's roll) and the centripetal term :math:`a = v_x r / g` are what the real-road filters read
(:mod:`roadbank.estimators.lowpass`: ``w = LP(k - \kappa a) + \kappa a``). Any causal, time-invariant
linear filter of them is a pair of impulse responses; truncated to ``taps`` samples,

.. math::  \hat w_n = \sum_{j<L} h_j\, k_{n-j} + \sum_{j<L} c_j\, a_{n-j},

with :math:`\sum h_j = 1` and :math:`\sum c_j = 0`, so that a constant bank is read exactly and a
steady turn adds no bias (the two constraints every filter of the library meets). The taps that
fit the reference roll best in least squares over *other* logs, scored on the held-out one
(:func:`causal_fir_bound`, leave one log out), are a bound measured, not assumed: what a causal
linear filter of these two signals, tuned on the other drives, reaches. An estimator whose error is
close to it has little left to gain from the shape of its filter; what remains is in the signals.

Units: rad inside, deg in the results; logs at one sample rate (the taps are in samples).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constants import G


@dataclass(frozen=True)
class FirBound:
    """Result of :func:`causal_fir_bound`.

    Attributes
    ----------
    rms_deg : tuple of float
        Raw RMS error (deg) of theta on each log's scored samples, with the taps fitted on the
        other logs.
    median_deg : float
        Their median (deg).
    taps_k, taps_a : ndarray
        The taps (-) fitted on all logs: of the kinematic estimate and of the centripetal term,
        newest sample first.
    """

    rms_deg: tuple
    median_deg: float
    taps_k: np.ndarray
    taps_a: np.ndarray


def _regressors(signals, taps: int) -> np.ndarray:
    """Columns ``k_{n-j}`` and ``a_{n-j}``, ``j < taps`` (before the first sample: the first sample)."""
    vx, ay, r = (np.asarray(x, dtype=np.float64) for x in (signals.vx, signals.ay, signals.r))
    k, a = (ay - vx * r) / G, vx * r / G
    n = len(k)
    cols = []
    for x in (k, a):
        for j in range(taps):
            c = np.empty(n)
            c[:j] = x[0]
            c[j:] = x[:n - j]
            cols.append(c)
    return np.column_stack(cols)


def _fit(rows: np.ndarray, target: np.ndarray, taps: int) -> np.ndarray:
    """Least-squares taps under ``sum(h) = 1``, ``sum(c) = 0`` (the normal equations with two
    Lagrange multipliers; a ridge of 1e-9 times the mean diagonal keeps them regular)."""
    m = 2 * taps
    ata = rows.T @ rows
    ata += 1e-9 * np.trace(ata) / m * np.eye(m)
    con = np.zeros((2, m))
    con[0, :taps] = 1.0
    con[1, taps:] = 1.0
    kkt = np.block([[ata, con.T], [con, np.zeros((2, 2))]])
    rhs = np.concatenate([rows.T @ target, [1.0, 0.0]])
    return np.linalg.solve(kkt, rhs)[:m]


def causal_fir_bound(logs, taps: int = 30) -> FirBound:
    """The best causal linear filter of the kinematic estimate and the centripetal term, leave one
    log out (module docstring).

    Parameters
    ----------
    logs : sequence of (Signals, ndarray, ndarray)
        ``(signals, reference theta (rad), scored mask)`` per log, all at one sample rate, as
        :func:`roadbank.tuning.real.training_logs` gives them; at least two logs.
    taps : int
        Length of each impulse response (samples; 30 is 3 s at 10 Hz).

    Returns
    -------
    FirBound
        Per-log held-out RMS (deg), their median and the taps fitted on all logs.
    """
    if len(logs) < 2:
        raise ValueError("causal_fir_bound: needs at least two logs (one is held out)")
    if taps < 1:
        raise ValueError(f"causal_fir_bound: taps must be >= 1, got {taps}")
    data = []
    for signals, ref, mask in logs:
        x = _regressors(signals, taps)
        y = np.sin(np.asarray(ref, dtype=np.float64))
        use = np.asarray(mask, dtype=bool) & np.isfinite(y) & np.all(np.isfinite(x), axis=1)
        data.append((x, y, use))
    rms = []
    for i, (x, _, use) in enumerate(data):
        h = _fit(np.vstack([d[0][d[2]] for j, d in enumerate(data) if j != i]),
                 np.concatenate([d[1][d[2]] for j, d in enumerate(data) if j != i]), taps)
        theta = np.arcsin(np.clip(x[use] @ h, -1.0, 1.0))
        ref = np.asarray(logs[i][1], dtype=np.float64)[use]
        rms.append(float(np.degrees(np.sqrt(np.mean((theta - ref) ** 2)))))
    h = _fit(np.vstack([d[0][d[2]] for d in data]), np.concatenate([d[1][d[2]] for d in data]), taps)
    return FirBound(tuple(rms), float(np.median(rms)), h[:taps].copy(), h[taps:].copy())

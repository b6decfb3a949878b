r"""How long an estimate takes to settle after a (re)start, and which samples have settled.

At a (re)start -- the first usable sample, or the first after more than ``max_gap`` seconds without
one -- an observer begins at the equilibrium of that one sample's inputs (``xi = J eta``), so its
output starts where that sample's noise puts it (on a shaking road, degrees off) and converges as
the observer's error dynamics decay. ``valid`` says that a sample was usable; ``settled`` says, in
addition, that the estimator has run for its settling time since its last (re)start.

The settling time of a linear observer ``xi' = F xi + G eta``, ``w = H xi + D eta`` is that of the
step response of ``w`` to its inputs: started at the equilibrium of one sample, the output's error
decays as the step response to input ``j`` approaches its final value,

.. math::
    e(t) = H F^{-1} e^{F t} G_j, \qquad w_\infty = D_j - H F^{-1} G_j,

and the settling time is the last instant at which :math:`|e(t)| > s\,|w_\infty|`, ``s`` =
:data:`SETTLE_SHARE` (5 %: three time constants of a first-order low-pass, :math:`\tau \ln 20`), the
longest over the inputs ``eta = [delta_f, ay, r]`` that the output follows (a one-sample error may sit in
any of them; which slot carries ``ay`` differs between families).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm, solve_continuous_lyapunov

#: the share (-) of the step response's final value within which an estimate counts as settled
SETTLE_SHARE = 0.05
#: the longest settling time (s) looked for: an observer slower than this never settles in a drive
SETTLE_HORIZON_S = 120.0
#: time step (s) at which the step response is read
SETTLE_STEP_S = 0.01
#: samples of the step response read per matrix product (a power of 2; the horizon's 12000 in 47 products)
_BLOCK = 256


def settling_time(F, G, H, D, share: float = SETTLE_SHARE, horizon: float = SETTLE_HORIZON_S) -> float:
    """Settling time (s) of the output ``w`` of ``xi' = F xi + G eta``, ``w = H xi + D eta`` (``F`` 1/s): the
    longest over the inputs (the columns of ``G``, ``D``) of :func:`step_settling_time`; 0 for an observer without
    states, ``inf`` for one that is not stable."""
    F = np.atleast_2d(np.asarray(F, dtype=np.float64))
    n = F.shape[0] if F.size else 0
    if n == 0:
        return 0.0
    if np.max(np.linalg.eigvals(F).real) >= 0.0:
        return math.inf
    G = np.asarray(G, dtype=np.float64).reshape(n, -1)
    D = np.asarray(D, dtype=np.float64).reshape(-1)
    step = expm(F * SETTLE_STEP_S)
    return max(step_settling_time(F, G[:, j], H, D[j], share, horizon, step) for j in range(G.shape[1]))


def step_settling_time(F, g, H, d: float, share: float = SETTLE_SHARE, horizon: float = SETTLE_HORIZON_S,
                       step=None) -> float:
    r"""Settling time (s) of the output ``w = H xi + d u`` of a stable ``xi' = F xi + g u`` to a step in ``u`` (module
    docstring): the last instant at which its distance to the final value exceeds ``share`` of that value; 0 where
    the output does not follow the input through the states; ``inf`` where it has not settled within ``horizon``
    seconds. ``step``: ``expm(F SETTLE_STEP_S)`` where the caller has it.

    The search stops once the state can no longer carry the output beyond the limit: with ``P`` the solution of
    :math:`F^T P + P F = -I`, :math:`x^T P x` never grows, and :math:`|h x|^2 \le (h^T P^{-1} h)\, x^T P x`."""
    F = np.atleast_2d(np.asarray(F, dtype=np.float64))
    h = np.asarray(H, dtype=np.float64).reshape(-1)
    x = np.linalg.solve(F, np.asarray(g, dtype=np.float64).reshape(-1))     # F^-1 g: e(t) = H e^{Ft} F^-1 g
    final = d - float(h @ x)
    limit = share * abs(final)
    if limit == 0.0 or abs(float(h @ x)) <= limit:
        return 0.0
    step = expm(F * SETTLE_STEP_S) if step is None else step
    # the response at the samples of a block of _BLOCK steps, h e^{F k dt} x for k = 1.._BLOCK, in one product
    rows, jump = (h @ step)[None, :], step             # rows[k] = h step^(k+1); jump = step^len(rows)
    while len(rows) < _BLOCK:                           # doubled: 8 products for 256 rows
        rows, jump = np.vstack([rows, rows @ jump]), jump @ jump
    P = solve_continuous_lyapunov(F.T, -np.eye(len(x)))
    reach = float(h @ np.linalg.solve(P, h))                 # |h x|^2 <= reach x' P x, which never grows
    n_steps = int(horizon / SETTLE_STEP_S)
    last = 0.0
    for start in range(0, n_steps, _BLOCK):
        m = min(_BLOCK, n_steps - start)
        over = np.flatnonzero(np.abs(rows[:m] @ x) > limit)
        if over.size:
            last = (start + int(over[-1]) + 1) * SETTLE_STEP_S
        x = (jump if m == _BLOCK else np.linalg.matrix_power(step, m)) @ x
        if reach * float(x @ P @ x) <= limit * limit:
            return last
    return math.inf


def settled_flags(t, valid, settle_s: float, max_gap: float, last: tuple[float, float] = (math.nan, math.nan)):
    """Which samples have settled: ``valid`` and at least ``settle_s`` seconds after the estimator's last
    (re)start, the first valid sample or the first whose valid predecessor is more than ``max_gap`` seconds
    earlier (times ``t``, s). ``last`` carries a streamed log over from the previous chunk: ``(time of the last
    valid sample, time of the last restart)`` (s; NaN: none yet). Returns ``(settled bool array, last)``.

    A sample the estimator used but flagged not valid (an implausible output) counts as not used here, so a
    restart is read after a long run of them where the estimator made none: the flags err on the side of
    "not settled"."""
    t = np.asarray(t, dtype=np.float64)
    valid = np.asarray(valid, dtype=bool)
    every = bool(valid.all())
    tv = t if every else t[valid]
    if tv.size == 0:
        return np.zeros(t.shape, dtype=bool), last
    first = tv[0] if not tv[0] - last[0] <= max_gap else last[1]       # NaN last: the first sample, a restart
    later = np.flatnonzero(np.diff(tv) > max_gap) + 1                   # restarts after a gap within the chunk
    if later.size == 0:                                                 # the usual chunk: one (re)start time
        flags = tv >= first + settle_s
        since = first
    else:
        since_all = np.full(tv.shape, -math.inf)
        since_all[0] = first
        since_all[later] = tv[later]
        since_all = np.maximum.accumulate(since_all)
        flags = tv - since_all >= settle_s
        since = float(since_all[-1])
    if every:
        return flags, (float(tv[-1]), float(since))
    out = np.zeros(t.shape, dtype=bool)
    out[valid] = flags
    return out, (float(tv[-1]), float(since))

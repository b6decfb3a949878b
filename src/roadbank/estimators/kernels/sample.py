"""Sample handling shared by the per-sample families: validity, timing, the speed grid, the roll
model, the output angles and the batch outputs (see :mod:`roadbank.estimators.kernels`)."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from numba import njit

from ...constants import AY_MAX, SPEED_MAX, YAW_RATE_MAX
from ..layout import (C_DTFIX, C_DTOL, C_DV, C_GAP, C_LIM, C_N, C_NG, C_NR, C_SUB, C_USE, C_V0, C_VMIN, C_WMAX,
                      M_AY, M_INIT, M_PHI, M_PHIB, M_THETA, M_TLAST, M_W, M_X, limit_block, limit_states, roll_block,
                      roll_states)
from ._jit import HELPER, INLINE

#: the roll block's offsets in ``cfg`` for the two roll models (``nr`` 0: static gain or none; 2: dynamic),
#: as constants of the compiled code
ROLL0, ROLL2 = roll_block(0), roll_block(2)

# asin(x) = x + x^3 (c_1 + c_2 x^2 + ... + c_12 x^22) + R for |x| <= ASIN_POLY_MAX, the Taylor
# coefficients c_k = (2k)! / (4^k (k!)^2 (2k+1)) (exact fractions, rounded once);
# 0 <= R <= c_13 x^27 / (1 - x^2) <= 4.9e-17 rad at |x| = 0.3 (the series' terms are positive).
ASIN_POLY_MAX = 0.3
(_AS1, _AS2, _AS3, _AS4, _AS5, _AS6, _AS7, _AS8, _AS9, _AS10, _AS11, _AS12) = (
    float(Fraction(math.factorial(2 * k), 4 ** k * math.factorial(k) ** 2 * (2 * k + 1))) for k in range(1, 13))


@njit(**INLINE)
def asin_fast(x):
    """``asin(x)`` (rad) for ``|x| <= 1``: a polynomial for ``|x| <= ASIN_POLY_MAX`` (0.3, i.e. 17.5 deg), libm beyond.

    The polynomial is the Taylor series to ``x^23`` (Estrin's scheme): truncation
    below 4.9e-17 rad, so with rounding the result is within 1 ulp of the
    correctly rounded angle (tests/test_kernels.py checks 2 ulp against libm on a dense
    grid). About 2 ns instead of libm's 7 ns per call; road bank plus body roll
    is almost always inside the polynomial's range.
    """
    if not abs(x) <= ASIN_POLY_MAX:
        return math.asin(x)
    return _asin_poly(x)


@njit(**INLINE)
def _asin_poly(x):
    """The polynomial of :func:`asin_fast` (its value for ``|x| <= ASIN_POLY_MAX``)."""
    u = x * x
    u2 = u * u
    u4 = u2 * u2
    p = (((_AS1 + _AS2 * u) + (_AS3 + _AS4 * u) * u2) + ((_AS5 + _AS6 * u) + (_AS7 + _AS8 * u) * u2) * u4
         + ((_AS9 + _AS10 * u) + (_AS11 + _AS12 * u) * u2) * (u4 * u4))
    return x + x * u * p


@njit(**HELPER)
def angles(out_w, out_phi, out_theta, out_phib, out_valid, wmax, k0, k1):
    """``theta = asin_fast(clip(w, -1, 1))``, ``phi_b = theta - phi`` and ``valid = |w| <= wmax``
    for the samples ``k0 <= k < k1`` of the batch arrays, as :func:`output` computes them.

    A loop without branches over samples already computed, so that it runs on SIMD
    registers (several samples at once): the polynomial everywhere, then libm's ``asin``
    again for the few samples beyond its range.
    """
    nbig = 0
    for k in range(k0, k1):
        ku = np.uint64(k)
        w = out_w[ku]
        wc = w if w > -1.0 else -1.0
        wc = wc if wc < 1.0 else 1.0
        th = _asin_poly(wc)
        out_theta[ku] = th
        out_phib[ku] = th - out_phi[ku]
        out_valid[ku] = abs(w) <= wmax
        nbig += 0 if abs(wc) <= ASIN_POLY_MAX else 1
    if nbig > 0:
        for k in range(k0, k1):
            ku = np.uint64(k)
            w = out_w[ku]
            wc = w if w > -1.0 else -1.0
            wc = wc if wc < 1.0 else 1.0
            if not abs(wc) <= ASIN_POLY_MAX:
                th = math.asin(wc)
                out_theta[ku] = th
                out_phib[ku] = th - out_phi[ku]


@njit(**INLINE)
def grid(cfg, vx):
    """Index and weight of ``vx`` on the speed grid (clamped at both ends).

    ``(vx - v0) * (1/dv)``: a batch loop computes ``1/dv`` once
    (:func:`roadbank.estimators.kernels.lpv.lpv3_fixed_run`), bit for bit the same.
    """
    s = (vx - cfg[C_V0]) * (1.0 / cfg[C_DV])
    last = np.int64(cfg[C_NG]) - 1
    if last == 0 or s <= 0.0:
        return 0, 0.0
    if s >= last:
        return last - 1, 1.0
    i = np.int64(s)
    return i, s - i


@njit(**INLINE)
def interp(tab, i, a, lo, hi, row):
    """``row[k] = tab[i, k] + a (tab[i+1, k] - tab[i, k])`` for ``lo <= k < hi`` (schedule at ``vx``)."""
    i1 = i + 1 if i + 1 < tab.shape[0] else tab.shape[0] - 1
    for k in range(lo, hi):
        row[k] = tab[i, k] + a * (tab[i1, k] - tab[i, k])


@njit(**INLINE)
def sample_valid(mem, cfg, t, vx, d, ay, r):
    """Whether the sample is used: finite time after the last valid one, ``v_min <= vx <= SPEED_MAX``, finite inputs
    where used, ``ay`` and ``r`` within a car's limits (:data:`roadbank.constants.AY_MAX`, ``YAW_RATE_MAX``: a glitch
    beyond them is held as a NaN is; the comparisons are False for NaN too)."""
    if not (math.isfinite(t) and cfg[C_VMIN] <= vx <= SPEED_MAX):
        return False
    if cfg[C_USE] > 0 and not math.isfinite(d):
        return False
    if cfg[C_USE + 1] > 0 and not abs(ay) <= AY_MAX:
        return False
    if cfg[C_USE + 2] > 0 and not abs(r) <= YAW_RATE_MAX:
        return False
    if mem[M_INIT] > 0 and t <= mem[M_TLAST]:
        return False
    return True


@njit(**INLINE)
def begin(mem, cfg, t):
    """Common start of a valid sample: returns ``(dt, restart, fixed)`` and records the time.

    ``fixed``: not a restart and the interval is the fixed rate's within the tolerance.
    """
    restart = mem[M_INIT] == 0.0 or (t - mem[M_TLAST]) > cfg[C_GAP]
    dt = 0.0 if restart else t - mem[M_TLAST]
    h = cfg[C_DTFIX]
    fixed = (not restart) and h > 0.0 and abs(dt - h) <= cfg[C_DTOL] * h
    mem[M_INIT] = 1.0
    mem[M_TLAST] = t
    return dt, restart, fixed


@njit(inline="always", **HELPER)
def roll_map(cfg):
    """The two-state roll model's fixed-rate map from ``cfg`` (:data:`ROLL2`):
    ``(Phi00, Phi01, Phi10, Phi11, Gam0_0, Gam0_1, Gam1_0, Gam1_1)``."""
    rb = ROLL2
    return (cfg[rb.Phi], cfg[rb.Phi + 1], cfg[rb.Phi + 2], cfg[rb.Phi + 3],
            cfg[rb.Gam0], cfg[rb.Gam0 + 1], cfg[rb.Gam1], cfg[rb.Gam1 + 1])


@njit(inline="always", **HELPER)
def roll_fixed2(m, z0, z1, ay0, ay):
    """One fixed-rate step of the two-state roll model, ``z+ = Phi z + Gam0 ay- + Gam1 ay``, with
    ``m`` = :func:`roll_map`, in the order the step and the batch loop both use."""
    s0 = m[4] * ay0 + m[6] * ay
    s0 += m[0] * z0
    s0 += m[1] * z1
    s1 = m[5] * ay0 + m[7] * ay
    s1 += m[2] * z0
    s1 += m[3] * z1
    return s0, s1


@njit(inline="always", **HELPER)
def output(mem, cfg, w, phi):
    """Hold the outputs of a used sample: ``w``, ``theta = asin(clip(w, -1, 1))``, ``phi`` and
    ``phi_b = theta - phi``. Returns whether the output is plausible, ``|w| <= sin(max_angle)``."""
    wc = w if w > -1.0 else -1.0        # min(1, max(-1, w)), NaN -> -1 as Python's
    wc = wc if wc < 1.0 else 1.0
    theta = asin_fast(wc)
    mem[M_W] = w
    mem[M_THETA] = theta
    mem[M_PHI] = phi
    mem[M_PHIB] = theta - phi
    return abs(w) <= cfg[C_WMAX]


@njit(**INLINE)
def finish(mem, cfg, w, ay, dt, restart, fixed):
    """Roll separation and output of one used sample: updates the held outputs.

    Returns whether the output is plausible: ``|w| <= sin(max_angle)``
    (``w = sin theta``). Beyond that the model has failed (e.g. a saturated
    front tyre in an original-model observer; ``|w| > 1`` has no angle at all
    and theta is clipped to +-90 deg) and the caller flags the sample not valid.

    The roll block (:func:`roadbank.estimators.layout.roll_block`; ``nr`` is 0 or 2) is
    advanced by its fixed-rate map (:func:`roll_fixed2`) when ``fixed``, else by the
    trapezoidal rule.
    """
    nr = np.int64(cfg[C_NR])
    rb = ROLL2 if nr == 2 else ROLL0
    oz = roll_states(np.int64(cfg[C_N]))
    if restart:
        for i in range(nr):
            mem[oz + i] = cfg[rb.J + i] * ay
    elif nr == 2 and fixed:
        mem[oz], mem[oz + 1] = roll_fixed2(roll_map(cfg), mem[oz], mem[oz + 1], mem[M_AY], ay)
    elif nr == 2:
        # trapezoidal rule, substeps, ay linear in time; (I - hh F)^-1 by its adjugate
        nsub = np.int64(math.ceil(dt / cfg[C_SUB] - 1e-9))
        if nsub < 1:
            nsub = 1
        hh = 0.5 * (dt / nsub)
        f00 = cfg[rb.F]
        f01 = cfg[rb.F + 1]
        f10 = cfg[rb.F + 2]
        f11 = cfg[rb.F + 3]
        g0 = cfg[rb.G]
        g1 = cfg[rb.G + 1]
        m00 = 1.0 - hh * f00
        m01 = -hh * f01
        m10 = -hh * f10
        m11 = 1.0 - hh * f11
        inv = 1.0 / (m00 * m11 - m01 * m10)
        z0 = mem[oz]
        z1 = mem[oz + 1]
        ay0 = mem[M_AY]
        for k in range(nsub):
            u = 2.0 * ay0 + ((2.0 * k + 1.0) / nsub) * (ay - ay0)
            b0 = z0 + hh * (f00 * z0 + f01 * z1) + hh * g0 * u
            b1 = z1 + hh * (f10 * z0 + f11 * z1) + hh * g1 * u
            z0 = (m11 * b0 - m01 * b1) * inv
            z1 = (m00 * b1 - m10 * b0) * inv
        mem[oz] = z0
        mem[oz + 1] = z1
    mem[M_AY] = ay
    phi = cfg[rb.D] * ay
    for i in range(nr):
        phi += cfg[rb.H + i] * mem[oz + i]
    return output(mem, cfg, w, phi)


@njit(**INLINE)
def store(mem, k, n, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x):
    """Copy sample ``k``'s outputs and first ``n`` states from ``mem`` into the batch arrays."""
    out_valid[k] = ok
    out_w[k] = mem[M_W]
    out_theta[k] = mem[M_THETA]
    out_phib[k] = mem[M_PHIB]
    out_phi[k] = mem[M_PHI]
    for p in range(n):
        out_x[k, p] = mem[M_X + p]


@njit(**INLINE)
def limited_ay(mem, cfg, t, vx, ay, r):
    r"""The ``ay`` (m/s^2) a limited kinematic low-pass reads (``cfg[C_LIM] > 0``, the caller checks; its
    :class:`~roadbank.estimators.layout.LimitBlock`): ``ay`` less what the kinematic estimate's innovation
    exceeds ``CLIP`` standard deviations of its white noise by.

    The observer's first state :math:`x` (``mem[M_X]``) is the kinematic estimate :math:`(a_y - v_x r)/g`
    low-passed (``kinematic-lp`` without feed-forward, or the split low-pass,
    :mod:`roadbank.estimators.lowpass`), its prediction; the innovation in ``ay`` units is
    :math:`e = a_y - (g x + v_x r)`, its limit :math:`s = c \sqrt{m (Q_{ay} + v_x^2 R) / \Delta t}` (the noise
    the low-pass is designed for, sampled at the interval :math:`\Delta t`, times the running noise ratio
    :math:`m` of :func:`noise_update`, its shorter one with ``TS > 0``; 1 without one), and the result
    :math:`a_y - (e - \mathrm{clip}(e, -s, s))`:
    a Huber-type update, linear within ``s``. At a (re)start ``ay`` itself. NaN in, NaN out. The observer
    reads it in the steering's input slot.
    """
    lb = limit_block(np.int64(cfg[C_LIM]))
    dt = t - mem[M_TLAST]
    if mem[M_INIT] == 0.0 or not (dt > 0.0) or dt > cfg[C_GAP]:
        return ay
    ls = limit_states(np.int64(cfg[C_N]), np.int64(cfg[C_NR]))
    m = (mem[ls.NS] if cfg[lb.TS] > 0.0 else mem[ls.NV]) if cfg[lb.TN] > 0.0 else 1.0
    e = ay - (cfg[lb.GRAV] * mem[M_X] + vx * r)
    s = cfg[lb.CLIP] * math.sqrt((cfg[lb.QAY] + vx * vx * cfg[lb.RR]) * m / dt)
    ec = e if e < s else s
    ec = ec if ec > -s else -s
    return ay - (e - ec)


#: the running noise estimate's Huber limit: a squared difference counts at most this many times the running
#: variance (3 standard deviations), so that one pothole moves it little (:func:`noise_update`)
NOISE_HUBER = 9.0
#: bounds (-) of the running noise ratio (:func:`noise_update`): the low-pass's gain moves at most by a factor 2
NOISE_RATIO_MIN, NOISE_RATIO_MAX = 0.125, 8.0


@njit(**INLINE)
def noise_update(mem, cfg, vx, ay, r, dt, restart):
    r"""The running noise ratio :math:`m` of a limited low-pass (``cfg[C_LIM] > 0``, the caller checks) at a
    used sample; returns the factor :math:`\rho = m^{-1/3}` (-) on its low-pass states' update
    (:func:`scale_update`): 1 at a (re)start and unless the limit's ``TN > 0``.

    With :math:`a = a_y - v_x r` (m/s^2, the kinematic acceleration, whose first difference over a 10 Hz
    log is road vibration and sensor noise far more than manoeuvre) and ``REF`` its white-noise variance
    over the design span (:func:`roadbank.signals.diff_noise_std` squared), the ratio

    .. math::
        m \mathrel{+}= \frac{\Delta t}{T_N + \Delta t}\left(\min\left(\frac{(\Delta a)^2}{2\,\mathrm{REF}},
        H m\right) - m\right), \qquad H = 9,

    clipped to [:data:`NOISE_RATIO_MIN`, :data:`NOISE_RATIO_MAX`]: a Huber-type running variance (a
    spike counts at most 3 of its standard deviations) with time constant :math:`T_N`, relative to the
    design's; 1 at the first sample, kept over a restart (the road's noise outlasts a gap in the log). With
    the limit's ``TS > 0`` a second ratio of the same recursion with time constant ``TS``, which only the
    limit reads (:func:`limited_ay`; its own Huber limit, its own state ``NS``). The
    low-pass's cut-off for :math:`m` times the designed noise is
    :math:`m^{-1/3}` times the designed one (:func:`~roadbank.estimators.lowpass.cutoff_for_noise`), and so,
    for a slow filter (:math:`2\pi f_c \Delta t \ll 1`), its gain. The states are in ``mem``
    (:func:`~roadbank.estimators.layout.limit_states`).
    """
    lb = limit_block(np.int64(cfg[C_LIM]))
    if not cfg[lb.TN] > 0.0:
        return 1.0
    ls = limit_states(np.int64(cfg[C_N]), np.int64(cfg[C_NR]))
    a = ay - vx * r
    if restart:             # m is kept (0 only before the first sample)
        mem[ls.NV] = mem[ls.NV] if mem[ls.NV] > 0.0 else 1.0
        mem[ls.NS] = mem[ls.NS] if mem[ls.NS] > 0.0 else 1.0
        mem[ls.KA] = a
        return 1.0
    da = a - mem[ls.KA]
    mem[ls.KA] = a
    u = da * da / (2.0 * cfg[lb.REF])
    if cfg[lb.TS] > 0.0:
        mem[ls.NS] = ratio_step(mem[ls.NS], u, dt, cfg[lb.TS])
    m = ratio_step(mem[ls.NV], u, dt, cfg[lb.TN])
    mem[ls.NV] = m
    return 1.0 / m ** (1.0 / 3.0)


@njit(**INLINE)
def ratio_step(m, u, dt, tau):
    """One step of a running noise ratio (:func:`noise_update`): ``m`` (-) towards the sample's ``u`` (-), at most
    :data:`NOISE_HUBER` ``m``, with time constant ``tau`` over ``dt`` (s), clipped to its bounds."""
    u = u if u < NOISE_HUBER * m else NOISE_HUBER * m
    m = m + dt / (tau + dt) * (u - m)
    m = m if m > NOISE_RATIO_MIN else NOISE_RATIO_MIN
    return m if m < NOISE_RATIO_MAX else NOISE_RATIO_MAX


@njit(**INLINE)
def scale_update(mem, cfg, work, h, x0, x1, rho, w):
    """The update of a limited low-pass's first ``NLP`` states (its :class:`~roadbank.estimators.layout.LimitBlock`;
    1 or 2, from ``x0``, ``x1`` before the update) times ``rho`` (:func:`noise_update`), and the output ``w``
    moved with them (``work[h:]``: the output row ``H`` at ``vx``); returns ``w``."""
    nlp = np.int64(cfg[limit_block(np.int64(cfg[C_LIM])).NLP])
    for p in range(nlp):
        xo = x0 if p == 0 else x1
        xs = xo + rho * (mem[M_X + p] - xo)
        w += work[h + p] * (xs - mem[M_X + p])
        mem[M_X + p] = xs
    return w


def step_by_run(run, mem, cfg, tab, work, t, vx, d, ay, r):
    """One sample through a family's batch kernel ``run`` (one-sample arrays, read-only inputs as
    ``Signals``' arrays are, so that the compiled version is the one ``run()`` uses); returns
    ``(w, theta, phi_b, valid)``. The ``step`` of the families compiled as one function (Python)."""
    n = np.int64(cfg[C_N])
    inp = np.array([t, vx, d, ay, r], dtype=np.float64)
    inp.flags.writeable = False
    out = np.empty((4, 1))
    valid = np.empty(1, dtype=np.bool_)
    run(mem, cfg, tab, work, inp[0:1], inp[1:2], inp[2:3], inp[3:4], inp[4:5], out[0], out[1], out[2], out[3], valid,
        np.empty((1, max(n, 2))))
    return float(out[0, 0]), float(out[1, 0]), float(out[2, 0]), bool(valid[0])

"""Magic-Formula-type tyre forces, compiled with numba.

The Magic Formula ``D sin(C atan(B x - E (B x - atan(B x))))`` is evaluated with
two polynomial kernels instead of libm calls, which is what lets the four-tyre
plant run thousands of times faster than real time:

* :func:`fast_atan`: range reduction to [0, 1] (``atan x = pi/2 - atan(1/x)``)
  and an odd polynomial of degree 19 fitted by least squares on Chebyshev
  nodes; slope exactly 1 at 0 (so B C D is exactly the slip stiffness);
  max error 1.2e-9 rad.
* :func:`fast_sin`: Taylor series to x^15, error < 5e-8 for |x| <= 2.6
  (the argument ``C atan(...)`` stays within ``C pi/2 <= 2.6`` for C <= 1.65).

Units: forces N, slips dimensionless (``tan(alpha)``, ``kappa``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_HALF_PI = 0.5 * math.pi
# atan(z) = z (1 + z^2 q(z^2)) on [0, 1]; q's coefficients, lowest order first.
_A0, _A1, _A2, _A3, _A4, _A5, _A6, _A7, _A8 = (
    -0.33333261734726116, 0.1999758230433201, -0.1425504640838398, 0.10908072333339078,
    -0.08283311141632073, 0.056017513166873534, -0.029337922724756306, 0.009967855270865323,
    -0.0015896368777204358)


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def fast_atan(x):
    """Arc tangent (rad), |error| < 2e-9, branch-free (vectorises over the four wheels).

    ``z = min(|x|, 1) / max(|x|, 1)`` is ``|x|`` or ``1/|x|`` exactly, so one
    division serves both ranges.
    """
    a = abs(x)
    inv = a > 1.0
    z = (1.0 if 1.0 < a else a) / (1.0 if 1.0 > a else a)   # min(a, 1) / max(a, 1)
    u = z * z
    # q(u) by Estrin's scheme (shorter dependency chain than Horner)
    u2 = u * u
    u4 = u2 * u2
    q = (((_A0 + u * _A1) + u2 * (_A2 + u * _A3)) + u4 * ((_A4 + u * _A5) + u2 * (_A6 + u * _A7))
         + (u4 * u4) * _A8)
    r = z * (1.0 + u * q)
    r = _HALF_PI - r if inv else r
    return math.copysign(r, x)


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def fast_sin(x):
    """Sine for |x| <= 2.6 (Taylor to x^15, error < 5e-8)."""
    u = x * x
    u2 = u * u
    # Estrin's scheme (shorter dependency chain than Horner)
    p03 = (1.0 + u * (-1.0 / 6.0)) + u2 * (1.0 / 120.0 + u * (-1.0 / 5040.0))
    p47 = (1.0 / 362880.0 + u * (-1.0 / 39916800.0)) + u2 * (1.0 / 6227020800.0 + u * (-1.0 / 1307674368000.0))
    return x * (p03 + (u2 * u2) * p47)


_PIO2_HI = 1.5707963267341256     # pi/2 split for the range reduction of fast_sincos
_PIO2_LO = 6.077100506506192e-11  # (Cody-Waite: k * _PIO2_HI is exact for |k| < 2^20)
_TWO_OVER_PI = 2.0 / math.pi


# fastmath without reassociation, set explicitly (else inherited from fastmath callers): the
# two-part reduction must not be folded into k * (hi + lo); FMA contraction keeps it exact
@njit(cache=True, forceinline=True, fastmath={"nnan", "ninf", "nsz", "arcp", "contract", "afn"}, error_model="numpy")
def fast_sincos(a):
    """``(sin a, cos a)`` for any |a| < 1e5 rad, error < 1e-15 (no libm call).

    Reduction to ``r = a - k pi/2`` in [-pi/4, pi/4] (two-part pi/2), Taylor
    series of sin to r^17 and cos to r^18 there (truncation < 3e-18), then the
    quadrant ``k mod 4``.
    """
    k = math.floor(a * _TWO_OVER_PI + 0.5)
    r = (a - k * _PIO2_HI) - k * _PIO2_LO
    q = np.int64(k) & 3
    # (sin, cos) of r in [-pi/4, pi/4]: Taylor polynomials by Estrin's scheme, then the quadrant
    u = r * r
    u2 = u * u
    u4 = u2 * u2
    s = r * (((1.0 + u * (-1.0 / 6.0)) + u2 * (1.0 / 120.0 + u * (-1.0 / 5040.0)))
             + u4 * (((1.0 / 362880.0 + u * (-1.0 / 39916800.0)) + u2 * (1.0 / 6227020800.0 + u * (
                 -1.0 / 1307674368000.0))) + u4 * (1.0 / 355687428096000.0)))
    c = (((1.0 + u * (-0.5)) + u2 * (1.0 / 24.0 + u * (-1.0 / 720.0)))
         + u4 * (((1.0 / 40320.0 + u * (-1.0 / 3628800.0)) + u2 * (1.0 / 479001600.0 + u * (
             -1.0 / 87178291200.0))) + u4 * (1.0 / 20922789888000.0 + u * (-1.0 / 6402373705728000.0))))
    if q == 0:
        return s, c
    if q == 1:
        return c, -s
    if q == 2:
        return -s, -c
    return -c, s


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def magic_formula(x, K, C, D, E):
    """Pure-slip Magic Formula force.

    Parameters
    ----------
    x : float
        Slip (``tan(alpha)`` or ``kappa``).
    K : float
        Slip stiffness dF/dx at x = 0 (N per unit slip).
    C, E : float
        Shape and curvature factors.
    D : float
        Peak force (N), ``mu Fz``; must be > 0.

    Returns
    -------
    float
        ``D sin(C atan(B x - E (B x - atan(B x))))`` with ``B = K/(C D)``.
    """
    B = K / (C * D)
    bx = B * x
    return D * fast_sin(C * fast_atan(bx - E * (bx - fast_atan(bx))))


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def magic_formula_b(x, B, C, D, E):
    """:func:`magic_formula` with the stiffness factor ``B = K/(C D)`` given."""
    bx = B * x
    return D * fast_sin(C * fast_atan(bx - E * (bx - fast_atan(bx))))


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def load_stiffness_factor(fz, fz0, pky2):
    """Cornering stiffness at load ``fz`` relative to the one at ``fz0`` (-).

    ``sin(2 atan(fz/(pky2 fz0))) / sin(2 atan(1/pky2))`` written algebraically
    (``sin(2 atan y) = 2y/(1+y^2)``): 1 at ``fz0``, peaks at ``pky2 fz0``.
    """
    y = fz / (pky2 * fz0)
    y0 = 1.0 / pky2
    return (y / (1.0 + y * y)) * ((1.0 + y0 * y0) / y0)


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def tyre_core(tan_alpha, kappa, fz, mu, ky0, inv_fz0, ky_norm, inv_fzpk, Cy, Ey, pdy2,
              kx_per_fz, Cx, Ex, pdx2, rby1_sq, rby2, rbx1_sq, rbx2):
    """Branch-free body of :func:`tyre_forces` on precomputed constants.

    ``inv_fz0 = 1/fz0``, ``inv_fzpk = 1/(pky2 fz0)``, ``ky_norm = (1 + y0^2)/y0``
    with ``y0 = 1/pky2``, ``rby1_sq = rby1^2``, ``rbx1_sq = rbx1^2``. Written
    without branches or calls so that the plant's loop over the four wheels
    compiles to SIMD code. The combined-slip weights use
    ``1/sqrt(1 + (B k)^2)`` with ``B = b1/sqrt(A)`` = ``sqrt(A / (A + b1^2 k^2))``
    (one square root and one division instead of two of each).
    """
    on = fz > 0.0
    fzc = fz if on else 1.0  # placeholder load of a lifted wheel (its forces are masked to 0)
    dfz = fzc * inv_fz0 - 1.0
    dy = mu * (1.0 + pdy2 * dfz) * fzc
    dx = mu * (1.0 + pdx2 * dfz) * fzc
    y = fzc * inv_fzpk
    # B = K/(C D) with K = ky0 ky_norm y/(1 + y^2) (lateral), K = kx_per_fz Fz (longitudinal):
    # one division each
    by = (ky0 * ky_norm * y) / ((1.0 + y * y) * (Cy * dy))
    bxk = (kx_per_fz * fzc) / (Cx * dx)
    fy0 = magic_formula_b(tan_alpha, by, Cy, dy, Ey)
    fx0 = magic_formula_b(kappa, bxk, Cx, dx, Ex)
    ta2 = tan_alpha * tan_alpha
    k2 = kappa * kappa
    ay = 1.0 + rby2 * rby2 * ta2
    ax = 1.0 + rbx2 * rbx2 * k2
    fy = fy0 * math.sqrt(ay / (ay + rby1_sq * k2))
    fx = fx0 * math.sqrt(ax / (ax + rbx1_sq * ta2))
    return (fx if on else 0.0), (fy if on else 0.0)


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def tyre_forces(tan_alpha, kappa, fz, mu, ky0, fz0, pky2, Cy, Ey, pdy2,
                kx_per_fz, Cx, Ex, pdx2, rby1, rby2, rbx1, rbx2):
    """Combined-slip tyre forces in the wheel frame.

    Parameters
    ----------
    tan_alpha : float
        Lateral slip ``tan(alpha) = -v_y,wheel / |v_x,wheel|``; positive gives a
        force to the left (ISO: y left).
    kappa : float
        Longitudinal slip (positive = driving).
    fz : float
        Vertical load (N); forces are zero for fz <= 0 (wheel lifted).
    mu : float
        Road friction coefficient.
    ky0, fz0 : float
        Cornering stiffness (N/rad) at the static load fz0 (N).
    others
        See :class:`roadbank.sim.params.TyreParams`.

    Returns
    -------
    (Fx, Fy) : tuple of float
        Longitudinal and lateral force (N) in the wheel frame.
    """
    y0 = 1.0 / pky2
    return tyre_core(tan_alpha, kappa, fz, mu, ky0, 1.0 / fz0, (1.0 + y0 * y0) / y0, 1.0 / (pky2 * fz0),
                     Cy, Ey, pdy2, kx_per_fz, Cx, Ex, pdx2, rby1 * rby1, rby2, rbx1 * rbx1, rbx2)

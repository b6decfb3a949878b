r"""Compiled per-sample recursions of all estimators (numba, ``cache=True``).

This is the only module with compiled estimator code; Python prepares the
arrays, whose layout :mod:`roadbank.estimators.layout` defines. The families
share the same sample handling:

* ``lpv``  — linear observers with a speed-scheduled table (kinematic, UIO,
  PIO, steady-state PIF, Kalman): :math:`\xi' = F(v_x)\xi + G(v_x)\eta`,
  :math:`w = H(v_x)\xi + D(v_x)\eta` with :math:`\eta = [\delta_f, a_y, r]`.
* ``riccati`` — the PIF with the time-varying Riccati ODE (paper eq 43).
* ``dfc`` — dynamic filter compensation (nonlinear gate + low-pass).
* ``adaptive`` — linear observers scheduled on speed *and* excitation
  (``pif-adaptive``): the ``lpv`` recursion with the matrices interpolated
  bilinearly in ``(vx, e)``, ``e`` a peak follower of the low-passed ``|ay|``; general
  (trapezoidal) path only, no fixed-rate tables.
* ``smooth`` — the backward pass of the offline ``pif-smoother`` (:func:`smooth_backward`),
  run over a whole log after its forward ``lpv`` pass; no per-sample ``step()``.

Sample handling (every per-sample family): a sample is *valid* when the time is finite
and later than the last valid sample, ``vx`` is finite and ``>= v_min`` and
every input channel the estimator uses is finite. Invalid samples leave the
state untouched and repeat the last outputs. After a gap longer than
``max_gap`` (or at the first valid sample) the state is re-initialised at the
observer's equilibrium for the current inputs, ``xi = -F^{-1} G eta``.

Schedules are interpolated linearly in ``vx`` (the current sample's speed)
between the two neighbouring grid speeds, entry by entry:
``M(vx) = M[i] + a (M[i+1] - M[i])``, ``i = floor((vx - v0)/dv)``, ``a`` the
remainder, clamped at both ends of the grid.

**Fixed-rate path** (``lpv``, when the estimator has tables for a sample
interval ``h`` and the sample's interval equals ``h`` within ``DT_REL_TOL``
relative; what an ECU runs). Per sample, with the previous inputs ``eta-``::

    xi  = Phi(vx) xi + Gam0(vx) eta- + Gam1(vx) eta
    w   = H(vx) xi + D(vx) eta
    z   = Phi_r z + Gam0_r ay- + Gam1_r ay          (roll model, speed independent)
    phi = H_r z + D_r ay
    theta = asin(clip(w, -1, 1)),  phi_b = theta - phi,  valid = |w| <= sin(max_angle)

``Phi, Gam0, Gam1`` are the exact discretisation of the continuous observer at
each grid speed for inputs varying linearly between samples (first-order hold,
:meth:`Estimator.discrete_tables`), so this path is exact for a frozen speed.
In a batch, consecutive samples on this path of a three-state observer run in
:func:`_lpv3_fixed_run` (constants read once, the state in registers, the three
state rows in the lanes of one SIMD register, :func:`_map4`; theta, phi_b and
valid per block of samples in a SIMD loop, :func:`_angles`; per sample the same
operations in the same order as :func:`lpv_step`, so ``run()`` and ``step()``
agree bit for bit). ``asin`` is :func:`asin_fast` (a polynomial within 2 ulp up
to 17 deg, libm beyond) on every path.

**General path** (any other interval: irregular sampling, jitter, after a
gap): the trapezoidal rule (Tustin), which is A-stable — for a frozen ``vx``
the discrete map :math:`(I - hF/2)^{-1}(I + hF/2)` is a contraction whenever
``F`` is Hurwitz, at any step ``h`` — with the step split into substeps of at
most ``max_substep`` seconds so that the stiff low-speed poles (about -150
1/s) are not mapped close to -1 at low sample rates, on the interpolated
continuous matrices, the input interpolated linearly between the previous and
the current sample. The Riccati ODE is advanced with the same trapezoidal
rule applied to its linear Hamiltonian form
:math:`[X; Y]' = \mathcal{H}[X; Y]`, :math:`P = Y X^{-1}`.

Compile time (a fresh process with an empty cache compiles each family in a few
seconds; ``python -m roadbank.bench.cold``): every function is compiled once as a
normal numba function (no numba-IR inlining, no ``fastmath``; LLVM inlines the
small helpers marked ``forceinline``) and in one specialisation only: no literal
arguments (``np.int64`` offsets, not ``0``), no ``int()``/``min()``/``max()``
(each an overload numba compiles per flag set; ``np.int64`` casts and conditional
expressions instead), helpers without Python or C wrappers
(``no_cpython_wrapper``), no array views or allocation (``_nrt=False``: nothing
reference-counted in the per-sample loops). Numba links every callee's code into
each caller and optimises and emits it again there, so the size of what a kernel
reaches counts as much as the number of functions: the Riccati PIF is one
function (``riccati_step`` runs ``riccati_run`` on one sample), and the general
path has no per-dimension special cases.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from .layout import (C_AREF, C_DTFIX, C_DTOL, C_DV, C_G, C_GAP, C_N, C_NG, C_NR, C_OFAM, C_P, C_ROLL,  # noqa: F401
                     C_SUB, C_TAU, C_USE, C_V0, C_VMIN, C_WMAX, M_AY, M_ETA, M_GATED, M_INIT, M_PHI, M_PHIB,
                     M_THETA, M_TLAST, M_W, M_X, NETA, DT_REL_TOL, batch3_block)

#: offsets of the batch loop's block in a three-state lpv row (layout.batch3_block)
_B3 = batch3_block()
_B3_M, _B3_W, _B3_DM = _B3.M, _B3.W, _B3.dM
_B3_DELTA = _B3.dM - _B3.M           # from an entry of M or W to its difference to the next row
_BLOCK = 256                         # samples per block of the batch loop (recursion, then _angles)

# asin(x) = x + x^3 (c_1 + c_2 x^2 + ... + c_12 x^22) + R for |x| <= ASIN_POLY_MAX, the Taylor
# coefficients c_k = (2k)! / (4^k (k!)^2 (2k+1)) (exact fractions, rounded once);
# 0 <= R <= c_13 x^27 / (1 - x^2) <= 4.9e-17 rad at |x| = 0.3 (the series' terms are positive).
ASIN_POLY_MAX = 0.3
(_AS1, _AS2, _AS3, _AS4, _AS5, _AS6, _AS7, _AS8, _AS9, _AS10, _AS11, _AS12) = (
    float(Fraction(math.factorial(2 * k), 4 ** k * math.factorial(k) ** 2 * (2 * k + 1))) for k in range(1, 13))


# ---------------------------------------------------------------------------------
# four lanes at once (the batch loop's three state rows): numba leaves straight-line code
# scalar (its LLVM pipeline runs no SLP vectoriser), so these two write the vector code
# themselves; per lane the same IEEE operations in the same order as the scalar code
# ---------------------------------------------------------------------------------

_V4 = ir.VectorType(ir.DoubleType(), 4)
_LANES = [ir.Constant(ir.IntType(32), k) for k in range(4)]


def _splat(builder, x):
    v = builder.insert_element(ir.Constant(_V4, ir.Undefined), x, _LANES[0])
    return builder.shuffle_vector(v, v, ir.Constant(ir.VectorType(ir.IntType(32), 4), [0, 0, 0, 0]))


def _load4(builder, data, off):
    p = builder.bitcast(builder.gep(data, [off]), _V4.as_pointer())
    return builder.load(p, align=8, typ=_V4)


def _column(builder, data, o, delta, a):
    """``row[o + l] + a * row[o + delta + l]`` for the four lanes ``l``."""
    return builder.fadd(_load4(builder, data, o), builder.fmul(a, _load4(builder, data, builder.add(o, delta))))


def _lanes(context, builder, sig, v):
    return context.make_tuple(builder, sig.return_type, [builder.extract_element(v, k) for k in _LANES])


@intrinsic
def _interp4(typingctx, row, o, delta, a):
    """``(row[o + l] + a * row[o + delta + l] for l in 0..3)``: four schedule entries at ``vx``."""
    sig = types.UniTuple(types.float64, 4)(row, o, delta, a)

    def codegen(context, builder, signature, args):
        data = context.make_array(signature.args[0])(context, builder, args[0]).data
        return _lanes(context, builder, signature, _column(builder, data, args[1], args[2], _splat(builder, args[3])))
    return sig, codegen


@intrinsic
def _map4(typingctx, row, o, delta, a, y0, y1, y2, y3, y4, y5, y6, y7, y8):
    """Four lanes of ``s = 0; s += (c0 y0 + c1 y1); s += (c2 y2 + c3 y3); s += (c4 y4 + c5 y5);
    s += c6 y6; s += c7 y7; s += c8 y8`` with column ``c_k`` = :func:`_interp4` at ``o + 4 k``."""
    sig = types.UniTuple(types.float64, 4)(row, o, delta, a, y0, y1, y2, y3, y4, y5, y6, y7, y8)

    def codegen(context, builder, signature, args):
        data = context.make_array(signature.args[0])(context, builder, args[0]).data
        o, delta = args[1], args[2]
        av = _splat(builder, args[3])
        four = ir.Constant(o.type, 4)

        def term(k):
            col = _column(builder, data, builder.add(o, builder.mul(four, ir.Constant(o.type, k))), delta, av)
            return builder.fmul(col, _splat(builder, args[4 + k]))
        s = _splat(builder, ir.Constant(ir.DoubleType(), 0.0))
        for k in (0, 2, 4):
            s = builder.fadd(s, builder.fadd(term(k), term(k + 1)))
        for k in (6, 7, 8):
            s = builder.fadd(s, term(k))
        return _lanes(context, builder, signature, s)
    return sig, codegen


# ---------------------------------------------------------------------------------
# linear algebra on small matrices
# ---------------------------------------------------------------------------------

@njit(cache=True, _nrt=False, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _lu_flat(M, o, piv, op, n):
    """:func:`_lu` on the row-major ``n x n`` matrix stored in ``M[o:o + n*n]`` (pivots in ``piv[op:]``)."""
    for k in range(n):
        p = k
        big = abs(M[o + k * n + k])
        for i in range(k + 1, n):
            if abs(M[o + i * n + k]) > big:
                big = abs(M[o + i * n + k])
                p = i
        piv[op + k] = p
        if p != k:
            for j in range(n):
                tmp = M[o + k * n + j]
                M[o + k * n + j] = M[o + p * n + j]
                M[o + p * n + j] = tmp
        d = M[o + k * n + k]
        if d == 0.0:
            continue
        for i in range(k + 1, n):
            M[o + i * n + k] /= d
            f = M[o + i * n + k]
            for j in range(k + 1, n):
                M[o + i * n + j] -= f * M[o + k * n + j]


@njit(cache=True, _nrt=False, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _lu_solve_flat(M, o, piv, op, b, ob, n):
    """:func:`_lu_solve` on flat storage: solves in place in ``b[ob:ob + n]``."""
    for k in range(n):
        p = np.int64(piv[op + k])
        if p != k:
            tmp = b[ob + k]
            b[ob + k] = b[ob + p]
            b[ob + p] = tmp
    for i in range(n):
        s = b[ob + i]
        for j in range(i):
            s -= M[o + i * n + j] * b[ob + j]
        b[ob + i] = s
    for i in range(n - 1, -1, -1):
        s = b[ob + i]
        for j in range(i + 1, n):
            s -= M[o + i * n + j] * b[ob + j]
        b[ob + i] = s / M[o + i * n + i]


@njit(cache=True, _nrt=False, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _tustin_flat(x, ox, n, A, oF, oG, m, E0, oe0, E1, oe1, dt, max_sub, W, oM):
    """:func:`_tustin` on flat storage (the general path of the ``lpv`` family and the roll model).

    State ``x[ox:ox+n]``; ``F`` (n x n) at ``A[oF:]`` and ``G`` (n x m) at
    ``A[oG:]``, row-major; inputs ``e0``/``e1`` at ``E0[oe0:]``/``E1[oe1:]``;
    scratch ``W[oM:]`` of ``n*n + 2n`` floats (matrix, pivots, right-hand side).
    Same arithmetic, in the same order, as :func:`_tustin`.
    """
    if n == 0:
        return
    opiv = oM + n * n
    orhs = opiv + n
    nsub = np.int64(math.ceil(dt / max_sub - 1e-9))
    if nsub < 1:
        nsub = 1
    h = dt / nsub
    hh = 0.5 * h
    for i in range(n):
        for j in range(n):
            W[oM + i * n + j] = -hh * A[oF + i * n + j]
        W[oM + i * n + i] += 1.0
    _lu_flat(W, oM, W, opiv, n)
    for k in range(nsub):
        a = (2.0 * k + 1.0) / nsub  # e0*(1-a0)+e1*a0 + e0*(1-a1)+e1*a1 = 2 e0 + (e1-e0)*(a0+a1)
        for i in range(n):
            s = x[ox + i]
            for j in range(n):
                s += hh * A[oF + i * n + j] * x[ox + j]
            for j in range(m):
                s += hh * A[oG + i * m + j] * (2.0 * E0[oe0 + j] + a * (E1[oe1 + j] - E0[oe0 + j]))
            W[orhs + i] = s
        _lu_solve_flat(W, oM, W, opiv, W, orhs, n)
        for i in range(n):
            x[ox + i] = W[orhs + i]


# ---------------------------------------------------------------------------------
# sample handling shared by the families
# ---------------------------------------------------------------------------------

@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cfunc_wrapper=True)
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


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _asin_poly(x):
    """The polynomial of :func:`asin_fast` (its value for ``|x| <= ASIN_POLY_MAX``)."""
    u = x * x
    u2 = u * u
    u4 = u2 * u2
    p = (((_AS1 + _AS2 * u) + (_AS3 + _AS4 * u) * u2) + ((_AS5 + _AS6 * u) + (_AS7 + _AS8 * u) * u2) * u4
         + ((_AS9 + _AS10 * u) + (_AS11 + _AS12 * u) * u2) * (u4 * u4))
    return x + x * u * p


@njit(cache=True, _nrt=False, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _angles(out_w, out_phi, out_theta, out_phib, out_valid, wmax, k0, k1):
    """``theta = asin_fast(clip(w, -1, 1))``, ``phi_b = theta - phi`` and ``valid = |w| <= wmax``
    for the samples ``k0 <= k < k1`` of the batch arrays, as :func:`_finish` computes them.

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


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _grid(cfg, vx):
    """Index and weight of ``vx`` on the speed grid (clamped at both ends).

    ``(vx - v0) * (1/dv)``: a batch loop computes ``1/dv`` once (:func:`_lpv3_fixed_run`), bit for bit the same.
    """
    s = (vx - cfg[C_V0]) * (1.0 / cfg[C_DV])
    last = np.int64(cfg[C_NG]) - 1
    if last == 0 or s <= 0.0:
        return 0, 0.0
    if s >= last:
        return last - 1, 1.0
    i = np.int64(s)
    return i, s - i


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _sample_valid(mem, cfg, t, vx, d, ay, r):
    if not (math.isfinite(t) and math.isfinite(vx)) or vx < cfg[C_VMIN]:
        return False
    if cfg[C_USE] > 0 and not math.isfinite(d):
        return False
    if cfg[C_USE + 1] > 0 and not math.isfinite(ay):
        return False
    if cfg[C_USE + 2] > 0 and not math.isfinite(r):
        return False
    if mem[M_INIT] > 0 and t <= mem[M_TLAST]:
        return False
    return True


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _begin(mem, cfg, t):
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


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _finish(mem, cfg, w, ay, dt, restart, fixed, work, o):
    """Roll separation and output of one used sample: updates the held outputs.

    Returns whether the output is plausible: ``|w| <= sin(max_angle)``
    (``w = sin theta``). Beyond that the model has failed (e.g. a saturated
    front tyre in an original-model observer; ``|w| > 1`` has no angle at all
    and theta is clipped to +-90 deg) and the caller flags the sample not valid.

    The roll block (offsets as :func:`roadbank.estimators.layout.roll_block`;
    ``nr`` is 0 or 2) is advanced by its fixed-rate map when ``fixed``, else by
    the trapezoidal rule. ``work[o:]`` is scratch of at least ``nr`` floats.
    """
    n = np.int64(cfg[C_N])
    nr = np.int64(cfg[C_NR])
    oF = C_ROLL
    oG = oF + nr * nr
    oH = oG + nr
    oD = oH + nr
    oJ = oD + 1
    oPhi = oJ + nr
    oG0 = oPhi + nr * nr
    oG1 = oG0 + nr
    oz = M_X + n
    if restart:
        for i in range(nr):
            mem[oz + i] = cfg[oJ + i] * ay
    elif fixed:
        ay0 = mem[M_AY]
        for i in range(nr):
            s = cfg[oG0 + i] * ay0 + cfg[oG1 + i] * ay
            for j in range(nr):
                s += cfg[oPhi + i * nr + j] * mem[oz + j]
            work[o + i] = s
        for i in range(nr):
            mem[oz + i] = work[o + i]
    elif nr == 2:
        # trapezoidal rule, substeps, ay linear in time; (I - hh F)^-1 by its adjugate
        nsub = np.int64(math.ceil(dt / cfg[C_SUB] - 1e-9))
        if nsub < 1:
            nsub = 1
        hh = 0.5 * (dt / nsub)
        f00 = cfg[oF]
        f01 = cfg[oF + 1]
        f10 = cfg[oF + 2]
        f11 = cfg[oF + 3]
        g0 = cfg[oG]
        g1 = cfg[oG + 1]
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
    phi = cfg[oD] * ay
    for i in range(nr):
        phi += cfg[oH + i] * mem[oz + i]
    wc = w if w > -1.0 else -1.0        # min(1, max(-1, w)), NaN -> -1 as Python's
    wc = wc if wc < 1.0 else 1.0
    theta = asin_fast(wc)
    mem[M_W] = w
    mem[M_THETA] = theta
    mem[M_PHI] = phi
    mem[M_PHIB] = theta - phi
    return abs(w) <= cfg[C_WMAX]


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _store(mem, k, n, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x):
    """Copy sample ``k``'s outputs and first ``n`` states from ``mem`` into the batch arrays."""
    out_valid[k] = ok
    out_w[k] = mem[M_W]
    out_theta[k] = mem[M_THETA]
    out_phib[k] = mem[M_PHIB]
    out_phi[k] = mem[M_PHI]
    for p in range(n):
        out_x[k, p] = mem[M_X + p]


# ---------------------------------------------------------------------------------
# LPV observers
# ---------------------------------------------------------------------------------

@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _interp(tab, i, a, lo, hi, row):
    """``row[k] = tab[i, k] + a (tab[i+1, k] - tab[i, k])`` for ``lo <= k < hi`` (schedule at ``vx``)."""
    i1 = i + 1 if i + 1 < tab.shape[0] else tab.shape[0] - 1
    for k in range(lo, hi):
        row[k] = tab[i, k] + a * (tab[i1, k] - tab[i, k])


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _restart_state(mem, work, oJ, n, eta):
    """``xi = J eta`` (the observer's equilibrium) with ``J`` (n x 3) at ``work[oJ:]``.

    This and the next two helpers are the restart, general path and output of
    :func:`lpv_step`, written out there (calling them from ``lpv_step`` costs about
    0.45 s more compile time of the ``lpv`` family) and used by :func:`adaptive_step`.
    """
    for p in range(n):
        s = 0.0
        for q in range(NETA):
            s += work[oJ + p * NETA + q] * eta[q]
        mem[M_X + p] = s


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _general_advance(mem, cfg, work, oG, oS, n, eta, dt):
    """General path: trapezoidal rule on ``F`` (at ``work[0:]``), ``G`` (at ``work[oG:]``) over ``dt``."""
    for q in range(NETA):
        work[oS + q] = eta[q]
    _tustin_flat(mem, M_X, n, work, 0, oG, NETA, mem, M_ETA, work, oS, dt, cfg[C_SUB], work, oS + NETA)


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _output(mem, work, oH, oD, n, eta):
    """``w = H xi + D eta`` (``H``, ``D`` at ``work[oH:]``, ``work[oD:]``); records ``eta`` as the previous inputs."""
    w = 0.0
    for q in range(NETA):
        w += work[oD + q] * eta[q]
        mem[M_ETA + q] = eta[q]
    for p in range(n):
        w += work[oH + p] * mem[M_X + p]
    return w


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cfunc_wrapper=True)
def lpv_step(mem, cfg, tab, work, t, vx, d, ay, r):
    """One sample of a scheduled linear observer: returns ``(w, theta, phi_b, valid)``.

    ``tab`` rows as :func:`roadbank.estimators.layout.lpv_row`: continuous
    ``F, G, H, D, J``, then (when ``cfg[C_DTFIX] > 0``) the fixed-rate
    ``Phi, Gam0, Gam1``. ``work`` (:func:`~roadbank.estimators.layout.work_size`
    floats) receives the interpolated row at the same offsets, then scratch.
    """
    if not _sample_valid(mem, cfg, t, vx, d, ay, r):
        return mem[M_W], mem[M_THETA], mem[M_PHIB], False
    n = np.int64(cfg[C_N])
    i, a = _grid(cfg, vx)
    # row offsets (layout.lpv_row(n)); F at 0
    oG = n * n
    oH = oG + n * NETA
    oD = oH + n
    oJ = oD + NETA
    oPhi = oJ + n * NETA
    oG0 = oPhi + n * n
    oG1 = oG0 + n * NETA
    oS = oG1 + n * NETA             # scratch after the row
    eta = (d if cfg[C_USE] > 0 else 0.0, ay if cfg[C_USE + 1] > 0 else 0.0, r if cfg[C_USE + 2] > 0 else 0.0)
    dt, restart, fixed = _begin(mem, cfg, t)
    if restart:
        # xi = J(vx) eta
        _interp(tab, i, a, oH, oPhi, work)
        for p in range(n):
            s = 0.0
            for q in range(NETA):
                s += work[oJ + p * NETA + q] * eta[q]
            mem[M_X + p] = s
    elif fixed:
        # xi = Phi(vx) xi + Gam0(vx) eta- + Gam1(vx) eta
        _interp(tab, i, a, oH, oJ, work)
        _interp(tab, i, a, oPhi, oS, work)
        for p in range(n):
            s = 0.0
            for q in range(NETA):
                s += work[oG0 + p * NETA + q] * mem[M_ETA + q] + work[oG1 + p * NETA + q] * eta[q]
            for j in range(n):
                s += work[oPhi + p * n + j] * mem[M_X + j]
            work[oS + p] = s
        for p in range(n):
            mem[M_X + p] = work[oS + p]
    else:
        # general path: trapezoidal rule on the interpolated F, G (F at oF = 0)
        _interp(tab, i, a, oG - n * n, oJ, work)
        for q in range(NETA):
            work[oS + q] = eta[q]
        _tustin_flat(mem, M_X, n, work, 0, oG, NETA, mem, M_ETA, work, oS, dt, cfg[C_SUB], work, oS + NETA)
    # w = H(vx) xi + D(vx) eta
    w = 0.0
    for q in range(NETA):
        w += work[oD + q] * eta[q]
        mem[M_ETA + q] = eta[q]
    for p in range(n):
        w += work[oH + p] * mem[M_X + p]
    ok = _finish(mem, cfg, w, ay, dt, restart, fixed, work, oS)
    return mem[M_W], mem[M_THETA], mem[M_PHIB], ok


@njit(cache=True, _nrt=False, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _lpv3_fixed_run(mem, cfg, tab, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid, out_x, k0):
    """The fixed-rate path of a three-state observer over consecutive samples from ``k0``.

    Runs while the samples are valid and exactly one fixed interval apart (within
    ``DT_REL_TOL``) and returns the index of the first sample it did not take
    (the caller hands that one to :func:`lpv_step`). The same arithmetic, in the
    same order, as :func:`lpv_step` on that path (so ``run()`` and ``step()`` agree
    bit for bit), with what is constant over a log read once: the flags, the
    grid, the roll model, and the state kept in registers between samples
    (written back to ``mem`` on return). The matrices come from the rows' batch
    block (:func:`roadbank.estimators.layout.batch3_block`): each column of
    ``[Gam0 | Gam1 | Phi]`` as four lanes, interpolated as ``M + a dM`` (the same
    numbers as ``M[i] + a (M[i+1] - M[i])``), so that each state row's sum, in
    ``lpv_step``'s order, runs in one lane of a SIMD register (:func:`_map4`). The estimator must be initialised
    (``mem[M_INIT] > 0``), ``n == 3``, ``nr`` 0 or 2, ``cfg[C_DTFIX] > 0``, and ``tab``
    must have the batch block.
    """
    N = t.shape[0]
    nr = np.int64(cfg[C_NR])
    h = cfg[C_DTFIX]
    htol = cfg[C_DTOL] * h
    gap = cfg[C_GAP]
    vmin = cfg[C_VMIN]
    use_d = cfg[C_USE] > 0
    use_ay = cfg[C_USE + 1] > 0
    use_r = cfg[C_USE + 2] > 0
    wmax = cfg[C_WMAX]
    v0 = cfg[C_V0]
    inv_dv = 1.0 / cfg[C_DV]
    last = np.int64(cfg[C_NG]) - 1
    # roll block (layout.roll_block(nr)); zeros when there is no roll model
    oD = C_ROLL + nr * nr + 2 * nr
    rD = cfg[oD]
    rH0 = rH1 = rP00 = rP01 = rP10 = rP11 = rA0 = rA1 = rB0 = rB1 = 0.0
    if nr == 2:
        rH0 = cfg[oD - 2]
        rH1 = cfg[oD - 1]
        oPhi = oD + 1 + nr
        rP00 = cfg[oPhi]
        rP01 = cfg[oPhi + 1]
        rP10 = cfg[oPhi + 2]
        rP11 = cfg[oPhi + 3]
        rA0 = cfg[oPhi + 4]
        rA1 = cfg[oPhi + 5]
        rB0 = cfg[oPhi + 6]
        rB1 = cfg[oPhi + 7]
    oz = M_X + 3
    z0 = mem[oz] if nr == 2 else 0.0
    z1 = mem[oz + 1] if nr == 2 else 0.0
    x0 = mem[M_X]
    x1 = mem[M_X + 1]
    x2 = mem[M_X + 2]
    p0 = mem[M_ETA]
    p1 = mem[M_ETA + 1]
    p2 = mem[M_ETA + 2]
    ay0 = mem[M_AY]
    tlast = mem[M_TLAST]
    w = mem[M_W]
    phi = mem[M_PHI]
    k = k0
    kend = k0
    while k == kend and k < N:
        # blocks of samples: the recursion, then the angles of the block (_angles)
        kb = k
        kend = k + _BLOCK if N - k > _BLOCK else N
        while k < kend:
            ku = np.uint64(k)           # an unsigned index: no negative-index wraparound code
            tk = t[ku]
            vk = vx[ku]
            dk = d[ku]
            ak = ay[ku]
            rk = r[ku]
            # _sample_valid, then _begin's restart and fixed-interval tests
            if not (math.isfinite(tk) and math.isfinite(vk)) or vk < vmin:
                break
            if (use_d and not math.isfinite(dk)) or (use_ay and not math.isfinite(ak)) \
                    or (use_r and not math.isfinite(rk)):
                break
            if tk <= tlast:
                break
            dt = tk - tlast
            if dt > gap or not abs(dt - h) <= htol:
                break
            tlast = tk
            u0 = dk if use_d else 0.0
            u1 = ak if use_ay else 0.0
            u2 = rk if use_r else 0.0
            # _grid
            s = (vk - v0) * inv_dv
            if last == 0 or s <= 0.0:
                i = 0
                a = 0.0
            elif s >= last:
                i = last - 1
                a = 1.0
            else:
                i = np.int64(s)
                a = s - i
            # fixed rate, as lpv_step's loops: xi = Phi xi + Gam0 eta- + Gam1 eta, one state row per lane
            ri = tab[np.uint64(i)]
            x0, x1, x2, _ = _map4(ri, np.int64(_B3_M), np.int64(_B3_DELTA), a, p0, u0, p1, u1, p2, u2, x0, x1, x2)
            # w = D eta + H xi, in lpv_step's order (D and H at vx)
            d0, d1, d2, _ = _interp4(ri, np.int64(_B3_W), np.int64(_B3_DELTA), a)
            h0, h1, h2, _ = _interp4(ri, np.int64(_B3_W + 4), np.int64(_B3_DELTA), a)
            w = 0.0
            w += d0 * u0
            w += d1 * u1
            w += d2 * u2
            w += h0 * x0
            w += h1 * x1
            w += h2 * x2
            p0 = u0
            p1 = u1
            p2 = u2
            # _finish, fixed: roll model and output
            if nr == 2:
                s0 = rA0 * ay0 + rB0 * ak
                s0 += rP00 * z0
                s0 += rP01 * z1
                s1 = rA1 * ay0 + rB1 * ak
                s1 += rP10 * z0
                s1 += rP11 * z1
                z0 = s0
                z1 = s1
            ay0 = ak
            phi = rD * ak
            if nr == 2:
                phi += rH0 * z0
                phi += rH1 * z1
            out_w[ku] = w
            out_phi[ku] = phi
            out_x[ku, 0] = x0
            out_x[ku, 1] = x1
            out_x[ku, 2] = x2
            k += 1
        _angles(out_w, out_phi, out_theta, out_phib, out_valid, wmax, kb, k)
    if k > k0:
        mem[M_TLAST] = tlast
        mem[M_X] = x0
        mem[M_X + 1] = x1
        mem[M_X + 2] = x2
        if nr == 2:
            mem[oz] = z0
            mem[oz + 1] = z1
        mem[M_ETA] = p0
        mem[M_ETA + 1] = p1
        mem[M_ETA + 2] = p2
        mem[M_AY] = ay0
        mem[M_W] = w
        mem[M_THETA] = out_theta[np.uint64(k - 1)]
        mem[M_PHI] = phi
        mem[M_PHIB] = out_phib[np.uint64(k - 1)]
    return k


@njit(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
def lpv_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
            out_x):
    """Batch version of :func:`lpv_step` (same arithmetic, sample by sample).

    Runs of samples on the fixed-rate path of a three-state observer go through
    :func:`_lpv3_fixed_run`; every other sample through :func:`lpv_step`.
    """
    n = np.int64(cfg[C_N])
    nr = np.int64(cfg[C_NR])
    fast = n == 3 and (nr == 0 or nr == 2) and cfg[C_DTFIX] > 0.0
    N = t.shape[0]
    k = np.int64(0)              # not a literal: one compiled _lpv3_fixed_run
    while k < N:
        if fast and mem[M_INIT] > 0.0:
            k = _lpv3_fixed_run(mem, cfg, tab, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
                                out_x, k)
            if k >= N:
                break
        ok = lpv_step(mem, cfg, tab, work, t[k], vx[k], d[k], ay[k], r[k])[3]
        _store(mem, k, n, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x)
        k += 1


# ---------------------------------------------------------------------------------
# observers scheduled on speed and excitation
# ---------------------------------------------------------------------------------

@njit(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
def adaptive_step(mem, cfg, tab, work, t, vx, d, ay, r):
    r"""One sample of an observer scheduled on speed and excitation; returns ``(w, theta, phi_b, valid)``.

    Excitation ``e`` (m/s^2): ``|ay|`` through a first-order low-pass of time constant
    ``tf`` (the tyre forces build up with a lag), :math:`a_f \mathrel{+}= (1 -
    e^{-\Delta t/t_f})(|a_y| - a_f)`, then a peak follower that rises at once and decays
    with the release time constant ``tau``: :math:`e_k = \max(a_f, e_{k-1}
    e^{-\Delta t/\tau})`; ``a_f = e = |ay|`` at a (re)start. ``tab`` rows
    (``layout.lpv_row(n)``, continuous part) for speed point
    ``iv`` and excitation point ``ie`` at row ``iv * ne + ie``; the matrices at
    ``(vx, e)`` are interpolated bilinearly (clamped at the ends of both grids), then the
    state advances as on the general path of :func:`lpv_step`: trapezoidal rule with
    substeps, the inputs linear between samples, the matrices frozen over the interval.
    Grid, ``tau`` and ``tf`` at ``cfg[C_OFAM]``
    (:func:`roadbank.estimators.layout.adaptive_block`); ``e``, ``a_f`` in ``mem`` after
    the roll states (:func:`~roadbank.estimators.layout.excitation_state`).
    """
    if not _sample_valid(mem, cfg, t, vx, d, ay, r):
        return mem[M_W], mem[M_THETA], mem[M_PHIB], False
    n = np.int64(cfg[C_N])
    nr = np.int64(cfg[C_NR])
    o = np.int64(cfg[C_OFAM])          # layout.adaptive_block: E0, DE, NE, TAU, TF
    oe = M_X + n + nr             # layout.excitation_state: e, a_f
    eta = (d if cfg[C_USE] > 0 else 0.0, ay if cfg[C_USE + 1] > 0 else 0.0, r if cfg[C_USE + 2] > 0 else 0.0)
    dt, restart, _ = _begin(mem, cfg, t)
    if restart:
        af = abs(ay)
        e = af
    else:
        af = mem[oe + 1] + (1.0 - math.exp(-dt / cfg[o + 4])) * (abs(ay) - mem[oe + 1])
        e = mem[oe] * math.exp(-dt / cfg[o + 3])
        e = e if e > af else af               # max(af, e)
    mem[oe] = e
    mem[oe + 1] = af
    # bilinear interpolation of the row at (vx, e)
    iv, av = _grid(cfg, vx)
    nv = np.int64(cfg[C_NG])
    ne = np.int64(cfg[o + 2])
    se = (e - cfg[o]) / cfg[o + 1]
    if ne == 1 or se <= 0.0:
        ie, ae = 0, 0.0
    elif se >= ne - 1:
        ie, ae = ne - 2, 1.0
    else:
        ie = np.int64(se)
        ae = se - ie
    iv1 = iv + 1 if iv + 1 < nv else nv - 1
    ie1 = ie + 1 if ie + 1 < ne else ne - 1
    r00 = iv * ne + ie
    r01 = iv * ne + ie1
    r10 = iv1 * ne + ie
    r11 = iv1 * ne + ie1
    oG = n * n
    oH = oG + n * NETA
    oD = oH + n
    oJ = oD + NETA
    oS = oJ + n * NETA            # scratch after the row
    for k in range(oS):
        lo = tab[r00, k] + av * (tab[r10, k] - tab[r00, k])
        hi = tab[r01, k] + av * (tab[r11, k] - tab[r01, k])
        work[k] = lo + ae * (hi - lo)
    if restart:
        _restart_state(mem, work, oJ, n, eta)
    else:
        _general_advance(mem, cfg, work, oG, oS, n, eta, dt)
    w = _output(mem, work, oH, oD, n, eta)
    ok = _finish(mem, cfg, w, ay, dt, restart, False, work, oS)
    return mem[M_W], mem[M_THETA], mem[M_PHIB], ok


@njit(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
def adaptive_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
                 out_x):
    """Batch version of :func:`adaptive_step` (same arithmetic, sample by sample)."""
    n = np.int64(cfg[C_N])
    for k in range(t.shape[0]):
        ok = adaptive_step(mem, cfg, tab, work, t[k], vx[k], d[k], ay[k], r[k])[3]
        _store(mem, k, n, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x)


# ---------------------------------------------------------------------------------
# two observers, the output switched on the yaw acceleration
# ---------------------------------------------------------------------------------

@njit(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
def gated_step(mem, cfg, tab, work, t, vx, d, ay, r):
    r"""One sample of two stacked observers whose outputs are blended by a gate; returns
    ``(w, theta, phi_b, valid)``.

    The states of both observers form one block-diagonal ``lpv`` observer (the table and the
    fixed-rate path of :func:`lpv_step`, whose output ``H xi + D eta`` is the first observer's
    ``w_s``); the second's is ``w_f = H_f xi`` (``H_f`` constant, at ``cfg[C_OFAM]``,
    :func:`roadbank.estimators.layout.gated_block`). The gate ``g`` in [0, 1] follows the
    yaw acceleration: the yaw rate through a first-order low-pass (time constant ``tf``),
    :math:`r_f \mathrel{+}= (1 - e^{-\Delta t/t_f})(r - r_f)`, its rate of change times the
    speed, :math:`j = v_x |\Delta r_f| / \Delta t` (m/s^3, the yaw part of the lateral jerk),
    the ramp :math:`g_k = \min(1, \max(0, (j - j_{on}) / j_{span}))` and a peak follower that
    rises at once and falls back with the release time constant ``tau``:
    :math:`g \leftarrow g_k` if :math:`g_k > g`, else :math:`g \mathrel{+}= (1 -
    e^{-\Delta t/\tau})(g_k - g)`. At a (re)start ``r_f = r``, ``g = 0``. Output
    :math:`w = w_s + g (w_f - w_s)`, :math:`\theta = \arcsin w`, :math:`\phi_b = \theta - \phi`.
    ``r_f`` and ``g`` in ``mem`` after the roll states (:func:`~roadbank.estimators.layout.gate_state`).
    """
    if not _sample_valid(mem, cfg, t, vx, d, ay, r):
        return mem[M_W], mem[M_THETA], mem[M_PHIB], False
    restart = mem[M_INIT] == 0.0 or (t - mem[M_TLAST]) > cfg[C_GAP]
    dt = t - mem[M_TLAST]
    lpv_step(mem, cfg, tab, work, t, vx, d, ay, r)
    n = np.int64(cfg[C_N])
    o = np.int64(cfg[C_OFAM])              # layout.gated_block: H_f (n), TF, TAU, ON, SPAN
    og = M_X + n + np.int64(cfg[C_NR])     # layout.gate_state: r_f, g
    if restart:
        rf = r
        g = 0.0
    else:
        rf0 = mem[og]
        rf = rf0 + (1.0 - math.exp(-dt / cfg[o + n])) * (r - rf0)
        gk = (vx * abs(rf - rf0) / dt - cfg[o + n + 2]) / cfg[o + n + 3]
        gk = gk if gk > 0.0 else 0.0
        gk = gk if gk < 1.0 else 1.0
        g = mem[og + 1]
        g = gk if gk > g else g + (1.0 - math.exp(-dt / cfg[o + n + 1])) * (gk - g)
    mem[og] = rf
    mem[og + 1] = g
    wf = 0.0
    for p in range(n):
        wf += cfg[o + p] * mem[M_X + p]
    w = mem[M_W] + g * (wf - mem[M_W])
    wc = w if w > -1.0 else -1.0
    wc = wc if wc < 1.0 else 1.0
    theta = asin_fast(wc)
    mem[M_W] = w
    mem[M_THETA] = theta
    mem[M_PHIB] = theta - mem[M_PHI]
    return w, theta, mem[M_PHIB], abs(w) <= cfg[C_WMAX]


@njit(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
def gated_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
              out_x):
    """Batch version of :func:`gated_step` (same arithmetic, sample by sample)."""
    n = np.int64(cfg[C_N])
    for k in range(t.shape[0]):
        ok = gated_step(mem, cfg, tab, work, t[k], vx[k], d[k], ay[k], r[k])[3]
        _store(mem, k, n, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x)


# ---------------------------------------------------------------------------------
# DFC
# ---------------------------------------------------------------------------------

@njit(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
def dfc_step(mem, cfg, tab, work, t, vx, d, ay, r):
    r"""One sample of the DFC estimator (returns ``(w, theta, phi_b, valid)``). ``tab`` rows: Haw0, Hrw0, Hau0, Hru0.

    .. math::
        w_v = (a_y - v_x r)/g,\quad
        DFC = H_{aw0}(w_a - w_v) + v_x H_{rw0}(w_r - w_v)
            = (a_y - H_{au0}\delta) + v_x (r - H_{ru0}\delta) - (H_{aw0} + v_x H_{rw0}) w_v

    (the second form avoids dividing by ``Hrw0``, which vanishes for a neutral
    steer car), gate :math:`w_v \max(0, 1 - |DFC|/a_{ref})`, then a first-order
    low-pass :math:`x' = (g - x)/\tau` of time constant ``tau`` (trapezoidal rule,
    substeps, gate linear between samples). State ``mem[M_X]`` is the low-pass
    output, ``mem[M_X+1]`` the DFC indicator (m/s^2).
    """
    if not _sample_valid(mem, cfg, t, vx, d, ay, r):
        return mem[M_W], mem[M_THETA], mem[M_PHIB], False
    i, a = _grid(cfg, vx)
    i1 = i + 1 if i + 1 < tab.shape[0] else tab.shape[0] - 1
    haw = tab[i, 0] + a * (tab[i1, 0] - tab[i, 0])
    hrw = tab[i, 1] + a * (tab[i1, 1] - tab[i, 1])
    hau = tab[i, 2] + a * (tab[i1, 2] - tab[i, 2])
    hru = tab[i, 3] + a * (tab[i1, 3] - tab[i, 3])
    wv = (ay - vx * r) / cfg[C_G]
    dfc = (ay - hau * d) + vx * (r - hru * d) - (haw + vx * hrw) * wv
    gate = 1.0 - abs(dfc) / cfg[C_AREF]
    gated = wv * (gate if gate > 0.0 else 0.0)
    dt, restart, fixed = _begin(mem, cfg, t)
    if restart:
        x = gated
    else:
        x = mem[M_X]
        g0 = mem[M_GATED]
        f = -1.0 / cfg[C_TAU]
        gg = 1.0 / cfg[C_TAU]
        nsub = np.int64(math.ceil(dt / cfg[C_SUB] - 1e-9))
        if nsub < 1:
            nsub = 1
        hh = 0.5 * (dt / nsub)
        m = 1.0 - hh * f
        for k in range(nsub):
            s = (2.0 * k + 1.0) / nsub
            x = (x + hh * f * x + hh * gg * (2.0 * g0 + s * (gated - g0))) / m
    mem[M_X] = x
    mem[M_GATED] = gated
    mem[M_X + 1] = dfc
    ok = _finish(mem, cfg, x, ay, dt, restart, False, work, 0)
    return mem[M_W], mem[M_THETA], mem[M_PHIB], ok


@njit(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
def dfc_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
            out_x):
    """Batch version of :func:`dfc_step`."""
    for k in range(t.shape[0]):
        ok = dfc_step(mem, cfg, tab, work, t[k], vx[k], d[k], ay[k], r[k])[3]
        _store(mem, k, 2, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x)


# ---------------------------------------------------------------------------------
# PIF with the time-varying Riccati equation
# --------------------------------------------------------------------------

@njit(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
def riccati_run(mem, cfg, tab, work, t, vx, d, ay, r, out_w, out_theta, out_phib, out_phi, out_valid,
                out_x):
    r"""The PIF with the Riccati ODE (paper eq 42-43) over a batch of samples (outputs as :func:`lpv_run`).

    ``tab`` rows: A (n*n), B (n*3), C (p*n), Dy (p*3), J (n*3) where the
    innovation is ``Dy eta - C x``. ``cfg`` holds ``R^-1``, ``W = Ew Q Ew^T`` and
    ``Mneg = th Lw^T S Lw`` (:func:`roadbank.estimators.layout.riccati_block`). Gain ``K = P C^T R^-1``;
    :math:`\dot P = AP + PA^T + W - P(C^T R^{-1} C - \theta L^T S L)P`.
    States after the observer and roll states: P (n*n). If P stops being
    finite (no bounded solution for this ``th``) the sample is flagged invalid
    and P restarts from its initial value held in ``cfg`` (not reached with
    the default tuning).

    All matrices are row-major blocks of the flat arrays (no array views):
    ``work`` holds the interpolated row at its table offsets, then ``K``, ``F``,
    ``G``, the Hamiltonian ``Hm`` (2n x 2n), its trapezoidal matrix ``Mw`` with
    pivots, ``Z = [X; Y]`` (2n x n), ``X^T`` with pivots and a column buffer.

    The whole recursion is written out in this one function: it is the only compiled
    code of the family (:func:`riccati_step` runs it on one-sample arrays), which halves
    the family's compile time; the variant is not latency-critical (about 2 us per sample).
    """
    n = np.int64(cfg[C_N])
    p = np.int64(cfg[C_P])
    nr = np.int64(cfg[C_NR])
    oR = np.int64(cfg[C_OFAM])      # layout.riccati_block: R^-1 (p*p), W (n*n), Mneg (n*n)
    oW = oR + p * p
    oMn = oW + n * n
    oP = M_X + n + nr               # layout.riccati_p
    # work: the row (A, B, C, Dy, J) at its table offsets, then the scratch blocks
    oA = 0
    oB = oA + n * n
    oC = oB + n * NETA
    oDy = oC + p * n
    oJ = oDy + p * NETA
    oK = oJ + n * NETA
    oF = oK + n * p
    oG = oF + n * n
    oHm = oG + n * NETA
    oMw = oHm + 4 * n * n
    opiv = oMw + 4 * n * n
    oZ = opiv + 2 * n
    oXt = oZ + 2 * n * n
    opx = oXt + n * n
    ocol = opx + n                  # 2n (>= 2 * NETA) floats
    oe = ocol + 2 * n + 2 * NETA    # current inputs eta (3)
    oS = oe + NETA                  # scratch of _finish
    for k in range(t.shape[0]):
        vxk = vx[k]
        if not _sample_valid(mem, cfg, t[k], vxk, d[k], ay[k], r[k]):
            _store(mem, k, n, False, out_w, out_theta, out_phib, out_phi, out_valid, out_x)
            continue
        i, a = _grid(cfg, vxk)
        i1 = i + 1 if i + 1 < tab.shape[0] else tab.shape[0] - 1
        for c in range(oK):
            work[c] = tab[i, c] + a * (tab[i1, c] - tab[i, c])
        work[oe] = d[k] if cfg[C_USE] > 0 else 0.0
        work[oe + 1] = ay[k] if cfg[C_USE + 1] > 0 else 0.0
        work[oe + 2] = r[k] if cfg[C_USE + 2] > 0 else 0.0
        dt, restart, _ = _begin(mem, cfg, t[k])
        ok = True
        if restart:
            for q in range(n):
                s = 0.0
                for j in range(NETA):
                    s += work[oJ + q * NETA + j] * work[oe + j]
                mem[M_X + q] = s
        else:
            nsub = np.int64(math.ceil(dt / cfg[C_SUB] - 1e-9))
            if nsub < 1:
                nsub = 1
            h = dt / nsub
            for sub in range(nsub):
                # gain from the current P, then the state over the substep
                for q in range(n):
                    for j in range(p):
                        s = 0.0
                        for l in range(n):
                            for mm in range(p):
                                s += mem[oP + q * n + l] * work[oC + mm * n + l] * cfg[oR + mm * p + j]
                        work[oK + q * p + j] = s
                for q in range(n):
                    for j in range(n):
                        s = work[oA + q * n + j]
                        for l in range(p):
                            s -= work[oK + q * p + l] * work[oC + l * n + j]
                        work[oF + q * n + j] = s
                    for j in range(NETA):
                        s = work[oB + q * NETA + j]
                        for l in range(p):
                            s += work[oK + q * p + l] * work[oDy + l * NETA + j]
                        work[oG + q * NETA + j] = s
                a0 = sub / nsub
                a1 = (sub + 1.0) / nsub
                for j in range(NETA):
                    work[ocol + j] = mem[M_ETA + j] + a0 * (work[oe + j] - mem[M_ETA + j])
                    work[ocol + NETA + j] = mem[M_ETA + j] + a1 * (work[oe + j] - mem[M_ETA + j])
                _tustin_flat(mem, M_X, n, work, oF, oG, NETA, work, ocol, work, ocol + NETA, h, h, work, oMw)
                # Riccati via the Hamiltonian: Z' = Hm Z, Hm = [[-A^T, M], [W, A]], Z = [I; P]
                m2 = 2 * n
                for q in range(n):
                    for j in range(n):
                        mpos = 0.0
                        for l in range(p):
                            for mm in range(p):
                                mpos += work[oC + l * n + q] * cfg[oR + l * p + mm] * work[oC + mm * n + j]
                        work[oHm + q * m2 + j] = -work[oA + j * n + q]
                        work[oHm + q * m2 + n + j] = mpos - cfg[oMn + q * n + j]
                        work[oHm + (n + q) * m2 + j] = cfg[oW + q * n + j]
                        work[oHm + (n + q) * m2 + n + j] = work[oA + q * n + j]
                for q in range(m2):
                    for j in range(m2):
                        work[oMw + q * m2 + j] = -0.5 * h * work[oHm + q * m2 + j]
                    work[oMw + q * m2 + q] += 1.0
                _lu_flat(work, oMw, work, opiv, m2)
                for j in range(n):
                    for q in range(m2):
                        if q >= n:
                            zq = mem[oP + (q - n) * n + j]
                        else:
                            zq = 1.0 if q == j else 0.0
                        s = zq
                        for l in range(m2):
                            if l < n:
                                zl = 1.0 if l == j else 0.0
                            else:
                                zl = mem[oP + (l - n) * n + j]
                            s += 0.5 * h * work[oHm + q * m2 + l] * zl
                        work[ocol + q] = s
                    _lu_solve_flat(work, oMw, work, opiv, work, ocol, m2)
                    for q in range(m2):
                        work[oZ + q * n + j] = work[ocol + q]
                # P = Y X^-1  <=>  X^T P^T = Y^T ; P symmetric
                for q in range(n):
                    for j in range(n):
                        work[oXt + q * n + j] = work[oZ + j * n + q]
                _lu_flat(work, oXt, work, opx, n)
                for j in range(n):
                    for q in range(n):
                        work[ocol + q] = work[oZ + (n + j) * n + q]
                    _lu_solve_flat(work, oXt, work, opx, work, ocol, n)
                    for q in range(n):
                        work[oF + j * n + q] = work[ocol + q]
                ok = True
                for q in range(n):
                    for j in range(n):
                        v = 0.5 * (work[oF + q * n + j] + work[oF + j * n + q])
                        if not math.isfinite(v):
                            ok = False
                        mem[oP + q * n + j] = v
                if not ok:
                    break
        if ok:          # P finite: record the inputs, separate the roll
            for q in range(NETA):
                mem[M_ETA + q] = work[oe + q]
            ok = _finish(mem, cfg, mem[M_X + n - 1], ay[k], dt, restart, False, work, oS)
        _store(mem, k, n, ok, out_w, out_theta, out_phib, out_phi, out_valid, out_x)


def riccati_step(mem, cfg, tab, work, t, vx, d, ay, r):
    """One sample of :func:`riccati_run`; returns ``(w, theta, phi_b, valid)`` (Python: one-sample arrays)."""
    n = np.int64(cfg[C_N])
    inp = np.array([t, vx, d, ay, r], dtype=np.float64)
    inp.flags.writeable = False        # as Signals' arrays: the same compiled version as run()
    out = np.empty((4, 1))
    valid = np.empty(1, dtype=np.bool_)
    riccati_run(mem, cfg, tab, work, inp[0:1], inp[1:2], inp[2:3], inp[3:4], inp[4:5], out[0], out[1], out[2],
                out[3], valid, np.empty((1, max(n, 2))))
    return float(out[0, 0]), float(out[1, 0]), float(out[2, 0]), bool(valid[0])


# ---------------------------------------------------------------------------------
# smoother: the backward pass of the offline PIF (roadbank.estimators.smoother)
# ---------------------------------------------------------------------------------

@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _grid_point(v, v0, dv, ng):
    """Rows ``i``, ``i1`` and weight ``fa`` of speed ``v`` (m/s) on the grid ``v0 + j dv``
    (``ng`` points), clamped at both ends: the schedule at ``v`` is ``(1 - fa) row i + fa row i1``."""
    x = (v - v0) / dv
    i = np.int64(math.floor(x)) if x > 0.0 else np.int64(0)
    if i > ng - 2:
        i = ng - 2 if ng > 1 else np.int64(0)
    fa = x - i
    fa = 0.0 if fa < 0.0 else (1.0 if fa > 1.0 else fa)
    i1 = i + 1 if i + 1 < ng else i
    return i, i1, fa


@njit(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
def smooth_backward(tab, ftab, hfix, v0, dv, n, max_sub, t, vx, ay, xf, a, b, out, work):
    r"""Backward pass of the smoother over the samples ``a .. b-1`` (one segment of a log).

    Integrates :math:`\dot x_s = A x_s + b\,a_y + M (x_s - \hat x)` from ``t[b-1]`` back to
    ``t[a]``, starting at ``x_s = \hat x`` (``xf``, the forward filter's states, shape (N, n)),
    i.e. in reversed time :math:`\tau` the stable system :math:`x_s' = S x_s + M \hat x - b\,a_y`
    with ``S = -(A + M)``; ``vx``, ``ay`` and ``xf`` linear across each sample interval, the
    matrices at the interval's (substep's) mid speed, interpolated between grid speeds
    ``v0 + i dv``. ``tab`` rows: ``S`` (n x n), ``M`` (n x n), ``b`` (n).

    An interval of ``hfix`` seconds (relative tolerance ``DT_REL_TOL``; ``hfix = 0``: none) takes
    the exact step for a frozen speed, ``ftab`` rows ``Phi`` (n x n), ``Gam0``, ``Gam1`` (n x
    (n + 1)): :math:`z_k = \Phi z_{k+1} + \Gamma_0 e_{k+1} + \Gamma_1 e_k`,
    :math:`e = [\hat x, a_y]` (first-order hold, :func:`roadbank.estimators.discretise.foh`).
    Any other interval: the trapezoidal rule in substeps of at most ``max_sub`` seconds. Writes
    ``out[a:b]``; ``work`` holds at least ``3 n^2 + 4 n`` floats.
    """
    nn = n * n
    oS, oM, ob = np.int64(0), nn, 2 * nn          # the interpolated row
    oA = 2 * nn + n                                # I - h/2 S, then the right-hand side
    orhs = oA + nn
    ng = tab.shape[0]
    ne = n + 1                                     # fixed-rate inputs e = [xf, ay]
    oG0 = nn
    oG1 = nn + n * ne
    for p in range(n):
        out[b - 1, p] = xf[b - 1, p]
    for k in range(b - 2, a - 1, -1):
        h = t[k + 1] - t[k]
        if hfix > 0.0 and abs(h - hfix) <= DT_REL_TOL * hfix:
            i, i1, fa = _grid_point(0.5 * (vx[k] + vx[k + 1]), v0, dv, ng)
            for p in range(n):
                acc = 0.0
                for q in range(n):
                    c = ftab[i, p * n + q] + fa * (ftab[i1, p * n + q] - ftab[i, p * n + q])
                    acc += c * out[k + 1, q]
                for q in range(ne):
                    e0 = xf[k + 1, q] if q < n else ay[k + 1]
                    e1 = xf[k, q] if q < n else ay[k]
                    c0 = ftab[i, oG0 + p * ne + q] + fa * (ftab[i1, oG0 + p * ne + q] - ftab[i, oG0 + p * ne + q])
                    c1 = ftab[i, oG1 + p * ne + q] + fa * (ftab[i1, oG1 + p * ne + q] - ftab[i, oG1 + p * ne + q])
                    acc += c0 * e0 + c1 * e1
                work[orhs + n + p] = acc
            for p in range(n):
                out[k, p] = work[orhs + n + p]
            continue
        m = np.int64(math.ceil(h / max_sub)) if h > max_sub else np.int64(1)
        hs = h / m
        for j in range(m):
            s0 = 1.0 - j / m                      # fractions of the interval from t[k]
            s1 = 1.0 - (j + 1) / m
            sm = 0.5 * (s0 + s1)
            i, i1, fa = _grid_point(vx[k] + sm * (vx[k + 1] - vx[k]), v0, dv, ng)
            for q in range(2 * nn + n):
                work[q] = tab[i, q] + fa * (tab[i1, q] - tab[i, q])
            ay0 = ay[k] + s0 * (ay[k + 1] - ay[k])
            ay1 = ay[k] + s1 * (ay[k + 1] - ay[k])
            for p in range(n):
                acc = out[k + 1, p] if j == 0 else work[orhs + n + p]
                work[orhs + 2 * n + p] = acc          # z (the state at s0)
            for p in range(n):
                r = work[orhs + 2 * n + p] - 0.5 * hs * work[ob + p] * (ay0 + ay1)
                for q in range(n):
                    sz = work[oS + p * n + q]
                    r += 0.5 * hs * sz * work[orhs + 2 * n + q]
                    x0 = xf[k, q] + s0 * (xf[k + 1, q] - xf[k, q])
                    x1 = xf[k, q] + s1 * (xf[k + 1, q] - xf[k, q])
                    r += 0.5 * hs * work[oM + p * n + q] * (x0 + x1)
                    work[oA + p * n + q] = (1.0 if p == q else 0.0) - 0.5 * hs * sz
                work[orhs + p] = r
            # Gaussian elimination with partial pivoting: (I - h/2 S) z = rhs -> work[orhs + n:]
            for c in range(n):
                piv = c
                for p in range(c + 1, n):
                    if abs(work[oA + p * n + c]) > abs(work[oA + piv * n + c]):
                        piv = p
                if piv != c:
                    for q in range(n):
                        tmp = work[oA + c * n + q]
                        work[oA + c * n + q] = work[oA + piv * n + q]
                        work[oA + piv * n + q] = tmp
                    tmp = work[orhs + c]
                    work[orhs + c] = work[orhs + piv]
                    work[orhs + piv] = tmp
                for p in range(c + 1, n):
                    f = work[oA + p * n + c] / work[oA + c * n + c]
                    for q in range(c, n):
                        work[oA + p * n + q] -= f * work[oA + c * n + q]
                    work[orhs + p] -= f * work[orhs + c]
            for p in range(n - 1, -1, -1):
                acc = work[orhs + p]
                for q in range(p + 1, n):
                    acc -= work[oA + p * n + q] * work[orhs + n + q]
                work[orhs + n + p] = acc / work[oA + p * n + p]
        for p in range(n):
            out[k, p] = work[orhs + n + p]

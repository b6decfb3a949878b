"""Four lanes at once: the batch loop's three state rows in one SIMD register.

numba leaves straight-line code scalar (its LLVM pipeline runs no SLP vectoriser), so these
two intrinsics write the vector code themselves; per lane they do the same IEEE operations in
the same order as the scalar code. Used by :func:`roadbank.estimators.kernels.lpv.fixed3`.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

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
def interp4(typingctx, row, o, delta, a):
    """``(row[o + l] + a * row[o + delta + l] for l in 0..3)``: four schedule entries at ``vx``."""
    sig = types.UniTuple(types.float64, 4)(row, o, delta, a)

    def codegen(context, builder, signature, args):
        data = context.make_array(signature.args[0])(context, builder, args[0]).data
        return _lanes(context, builder, signature, _column(builder, data, args[1], args[2], _splat(builder, args[3])))
    return sig, codegen


@intrinsic
def map4(typingctx, row, o, delta, a, y0, y1, y2, y3, y4, y5, y6, y7, y8):
    """Four lanes of ``s = 0; s += (c0 y0 + c1 y1); s += (c2 y2 + c3 y3); s += (c4 y4 + c5 y5);
    s += c6 y6; s += c7 y7; s += c8 y8`` with column ``c_k`` = :func:`interp4` at ``o + 4 k``."""
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

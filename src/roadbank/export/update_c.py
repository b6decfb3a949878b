"""C loops from the update description (:mod:`roadbank.estimators.update_spec`).

:func:`c_sum` writes one :class:`~roadbank.estimators.update_spec.Sum` as C99 in the
description's order of operations (per row, then per group and column ``acc += (products)``),
with a comment giving the equation in the system's own names; :class:`CSystem` says where the
generated C keeps a system's blocks, inputs and state. :mod:`roadbank.export.ccode` builds the
exported observer and roll model from these, so the generated C and the compiled kernels follow
one description.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable

from ..estimators.update_spec import Product, Sum, block_shape


@dataclass(frozen=True)
class CSystem:
    """How the generated C reads one linear system of the description.

    ``ns``, ``m``: states and inputs, with the C names of those sizes (``ns_c``, ``m_c``: an enum
    constant or a literal); ``block(name, index)``: the C expression of a block's entry at a
    row-major index expression; ``inputs[name](index)``: the C expression of an entry of ``e``
    or ``e_prev``; ``state``: the C array of the state before the sample (what an update reads),
    ``new``: the local array of the state after it (what an update writes and the output reads);
    ``names``: the system's names of ``x, e, e_prev, y`` for comments.
    """

    ns: int
    ns_c: str
    m: int
    m_c: str
    block: Callable[[str, str], str]
    inputs: dict[str, Callable[[str], str]]
    state: str
    new: str
    names: dict[str, str]

    def vector(self, name: str, index: str, after: bool) -> str:
        """C expression of an entry of ``x`` (before or ``after`` the update), ``e`` or ``e_prev``."""
        if name == "x":
            return f"{self.new if after else self.state}[{index}]"
        return self.inputs[name](index)

    def size(self, vector: str) -> tuple[int, str]:
        """Length of a vector, and its C name."""
        return (self.ns, self.ns_c) if vector == "x" else (self.m, self.m_c)

    def equation(self, text: str) -> str:
        """A description formula in the system's names (``x = J e`` -> ``xi = J eta``)."""
        return re.sub(r"(?<!\w)(e_prev|e-|e|x|y)(?!\w)", lambda mo: self.names[mo.group(1).replace("e-", "e_prev")],
                      text)


def _index(row: str | None, col: str | None, ncols_c: str) -> str:
    """Row-major index of an entry; ``None`` stands for the index of a dimension of size 1."""
    if row is None:
        return col or "0"
    return row if col is None else f"{row} * {ncols_c} + {col}"


def _terms(group: tuple[Product, ...], sy: CSystem, row: str | None, col: str | None, after: bool) -> str:
    """``B1[row, col] v1[col] + B2[row, col] v2[col] + ...`` of one group (``None``: a dimension of size 1)."""
    out = []
    for prod in group:
        brows, bcols = block_shape(prod.block, sy.ns, sy.m)
        b = sy.block(prod.block, _index(row if brows > 1 else None, col if bcols > 1 else None,
                                        sy.size(group[0].vector)[1]))
        out.append(f"{b} * {sy.vector(prod.vector, col or '0', after=after)}")
    return " + ".join(out)


def _sum_body(groups, sy: CSystem, acc: str, decl: str, row: str | None, after: bool, pad: str,
              used: set[str]) -> list[str]:
    """The running sum of ``groups`` into ``acc`` (declared as ``decl`` at its first product)."""
    body: list[str] = []
    for group in groups:
        ncol, ncol_c = sy.size(group[0].vector)
        if ncol == 0:
            continue
        lo = 0
        if not body:                        # the first product starts the sum
            body.append(f"{pad}{decl} = {_terms(group, sy, row, '0' if ncol > 1 else None, after)};")
            lo = 1
        if ncol - lo == 1:
            body.append(f"{pad}{acc} += {_terms(group, sy, row, str(lo) if ncol > 1 else None, after)};")
        elif ncol - lo > 1:
            used.add("q")
            body += [f"{pad}for (q = {lo}; q < {ncol_c}; ++q) {{",
                     f"{pad}    {acc} += {_terms(group, sy, row, 'q', after)};", f"{pad}}}"]
    if not body:
        body.append(f"{pad}{decl} = 0.0_R;")
    return body


def c_sum(s: Sum, sy: CSystem, target: str | None = None, indent: str = "    ") -> str:
    """C statements computing ``s`` for the system ``sy``.

    An ``x`` target (an update: it reads the state before the sample) is written into
    ``sy.new``; a ``y`` target (the output: it reads the state after the update) into the scalar
    lvalue ``target``. The running sum starts from the first product instead of ``0 +`` it (the
    same number; only a zero sum's sign may differ), its column loop from 1. Groups of no
    columns and targets of no rows emit nothing. The statements sit in their own block (their
    locals).
    """
    return _emit(s, sy, target, indent, None)


def c_update_output(update: Sum, output: Sum, sy: CSystem, target: str, indent: str = "    ") -> str:
    """:func:`c_sum` of an update and then of the output into ``target``, in one row loop where
    the order of operations allows it: when only the output's last group reads the state, its
    sum up to there comes first and row ``p`` adds its term right after the new ``x[p]`` -- the
    same operations in the same order, without storing and reloading the new state in between."""
    lead, last = output.groups[:-1], output.groups[-1] if output.groups else ()
    fusable = (update.target == "x" and output.target == "y" and sy.ns > 0 and lead and last
               and all(p.vector == "x" for p in last)
               and not any(p.vector == "x" for g in lead for p in g))
    if not fusable:
        return c_sum(update, sy, indent=indent) + c_sum(output, sy, target=target, indent=indent)
    head = Sum("y", lead, output.equation)
    return (c_sum(head, sy, target=target, indent=indent).replace(f"/* {sy.equation(output.equation)} */",
                                                                   f"/* {sy.equation(output.equation)}: the "
                                                                   f"first terms (the rest in the next loop) */")
            + _emit(update, sy, None, indent, (last, target)))


def _emit(s: Sum, sy: CSystem, target: str | None, indent: str, fused) -> str:
    """:func:`c_sum`, with ``fused = (group, lvalue)``: ``lvalue += group[p]`` after each new row."""
    rows = sy.ns if s.target == "x" else 1
    if rows == 0:
        return ""
    prow = "p" if (s.target == "x" and rows > 1) else None
    acc = "acc" if s.target == "x" else target
    if acc is None:
        raise ValueError("a y target needs a C lvalue")
    pad = indent + ("        " if s.target == "x" else "    ")
    used = {"p"} if prow else set()
    body = _sum_body(s.groups, sy, acc, "real_t acc" if s.target == "x" else acc, prow, s.target == "y", pad,
                     used)
    eq = sy.equation(s.equation)
    if fused:
        term = " + ".join(f"{p.block} {sy.names[p.vector]}" for p in fused[0])
        eq += f"; each new row then adds its {term} term to {fused[1]}"
    out = [f"{indent}/* {eq} */", f"{indent}{{"]
    out += [f"{indent}    int {v};" for v in sorted(used)]
    if s.target == "x":
        k = prow or "0"
        inner = body + [f"{pad}{sy.new}[{k}] = acc;"]
        if fused:
            inner.append(f"{pad}{fused[1]} += {_terms(fused[0], sy, None, prow, True)};")
        if prow:
            out += [f"{indent}    for (p = 0; p < {sy.ns_c}; ++p) {{"] + inner + [f"{indent}    }}"]
        else:
            out += [f"{indent}    {{"] + inner + [f"{indent}    }}"]
    else:
        out += body
    out.append(f"{indent}}}")
    return "\n".join(out) + "\n"

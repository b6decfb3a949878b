"""C loops from the update description (:mod:`roadbank.estimators.update_spec`).

:func:`c_sum` writes one :class:`~roadbank.estimators.update_spec.Sum` as C99 in the
description's order of operations (``acc = 0``, then per group and column ``acc += (products)``),
with a comment giving the equation in the system's own names. :mod:`roadbank.export.ccode` builds the exported
observer and roll model from these, so the generated C and the compiled kernels follow one
description.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable

from ..estimators.update_spec import Sum, block_shape


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


def c_sum(s: Sum, sy: CSystem, target: str | None = None, indent: str = "    ") -> str:
    """C statements computing ``s`` for the system ``sy``.

    An ``x`` target (an update: it reads the state before the sample) is written into
    ``sy.new``; a ``y`` target (the output: it reads the state after the update) into the scalar
    lvalue ``target``. The running sum starts from the first product instead of ``0 +`` it (the
    same number; only a zero sum's sign may differ), its column loop from 1. Groups of no
    columns and targets of no rows emit nothing. The statements sit in their own block (their
    locals).
    """
    rows = sy.ns if s.target == "x" else 1
    if rows == 0:
        return ""
    prow = "p" if (s.target == "x" and rows > 1) else None
    acc = "acc" if s.target == "x" else target
    if acc is None:
        raise ValueError("a y target needs a C lvalue")
    pad = indent + ("        " if s.target == "x" else "    ")
    body: list[str] = []
    used = {"p"} if prow else set()

    def terms(group, col):
        out = []
        for prod in group:
            brows, bcols = block_shape(prod.block, sy.ns, sy.m)
            b = sy.block(prod.block, _index(prow if brows > 1 else None, col if bcols > 1 else None,
                                            sy.size(group[0].vector)[1]))
            out.append(f"{b} * {sy.vector(prod.vector, col or '0', after=s.target == 'y')}")
        return " + ".join(out)

    for group in s.groups:
        ncol, ncol_c = sy.size(group[0].vector)
        if ncol == 0:
            continue
        lo = 0
        if not body:                        # the first product starts the sum
            decl = "real_t acc" if s.target == "x" else acc
            body.append(f"{pad}{decl} = {terms(group, '0' if ncol > 1 else None)};")
            lo = 1
        if ncol - lo == 1:
            body.append(f"{pad}{acc} += {terms(group, str(lo) if ncol > 1 else None)};")
        elif ncol - lo > 1:
            used.add("q")
            body += [f"{pad}for (q = {lo}; q < {ncol_c}; ++q) {{", f"{pad}    {acc} += {terms(group, 'q')};",
                     f"{pad}}}"]
    if not body:
        body.append(f"{pad}{'real_t acc' if s.target == 'x' else acc} = 0.0_R;")
    out = [f"{indent}/* {sy.equation(s.equation)} */", f"{indent}{{"]
    out += [f"{indent}    int {v};" for v in sorted(used)]
    if s.target == "x":
        inner = body + [f"{pad}{sy.new}[{prow or '0'}] = acc;"]
        if prow:
            out += [f"{indent}    for (p = 0; p < {sy.ns_c}; ++p) {{"] + inner + [f"{indent}    }}"]
        else:
            out += [f"{indent}    {{"] + inner + [f"{indent}    }}"]
    else:
        out += body
    out.append(f"{indent}}}")
    return "\n".join(out) + "\n"

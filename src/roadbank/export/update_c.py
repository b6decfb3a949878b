"""C loops from the update description (:mod:`roadbank.estimators.update_spec`).

:func:`c_sum` writes one :class:`~roadbank.estimators.update_spec.Sum` as C99 in the
description's order of operations (``acc = 0``, then per group and column ``acc += (products)``),
with a comment giving the equation in the system's own names; :func:`interp_ranges` lists the
contiguous parts of a kernel row a path reads. :mod:`roadbank.export.ccode` builds the exported
observer and roll model from these, so the generated C and the compiled kernels follow one
description.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable

from ..estimators.update_spec import Sum, block_shape, blocks_read


@dataclass(frozen=True)
class CSystem:
    """How the generated C reads one linear system of the description.

    ``ns``, ``m``: states and inputs, with the C names of those sizes (``ns_c``, ``m_c``: an enum
    constant or a literal); ``block(name, index)``: the C expression of a block's entry at a
    row-major index expression; ``vector[name](index)``: the C expression of an entry of ``x``,
    ``e`` or ``e_prev``; ``state``: the C array of the state (written by an ``x`` target);
    ``names``: the system's names of ``x, e, e_prev, y`` for comments.
    """

    ns: int
    ns_c: str
    m: int
    m_c: str
    block: Callable[[str, str], str]
    vector: dict[str, Callable[[str], str]]
    state: str
    names: dict[str, str]

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

    An ``x`` target is written into ``sy.state`` (through a scratch ``y`` when the sum reads
    the state); a ``y`` target into the scalar lvalue ``target``. Groups of no columns and
    targets of no rows emit nothing. The statements sit in their own block (their locals).
    """
    rows = sy.ns if s.target == "x" else 1
    if rows == 0:
        return ""
    prow = "p" if (s.target == "x" and rows > 1) else None
    acc = "acc" if s.target == "x" else target
    if acc is None:
        raise ValueError("a y target needs a C lvalue")
    body, used = [], set()
    pad = indent + ("        " if prow else "    ")
    for group in s.groups:
        ncol, ncol_c = sy.size(group[0].vector)
        if ncol == 0:
            continue
        col = "q" if ncol > 1 else None
        terms = []
        for prod in group:
            brows, bcols = block_shape(prod.block, sy.ns, sy.m)
            b = sy.block(prod.block, _index(prow if brows > 1 else None, col if bcols > 1 else None, ncol_c))
            terms.append(f"{b} * {sy.vector[prod.vector](col or '0')}")
        line = f"{acc} += {' + '.join(terms)};"
        if col:
            used.add("q")
            body += [f"{pad}for (q = 0; q < {ncol_c}; ++q) {{", f"{pad}    {line}", f"{pad}}}"]
        else:
            body.append(f"{pad}{line}")
    scratch = s.target == "x" and s.reads("x")
    out = [f"{indent}/* {sy.equation(s.equation)} */", f"{indent}{{"]
    if prow:
        used.add("p")
    decl = [f"{indent}    int {v};" for v in sorted(used)]
    if scratch:
        decl.append(f"{indent}    real_t y[{sy.ns_c}];")
    out += decl
    dest = (lambda k: f"y[{k}]") if scratch else (lambda k: f"{sy.state}[{k}]")
    if s.target == "x":
        k = prow or "0"
        inner = [f"{pad}real_t acc = 0.0_R;"] + body + [f"{pad}{dest(k)} = acc;"]
        if prow:
            out += [f"{indent}    for (p = 0; p < {sy.ns_c}; ++p) {{"] + inner + [f"{indent}    }}"]
        else:
            out += [f"{indent}    {{"] + [f"    {ln}" for ln in inner] + [f"{indent}    }}"]
        if scratch:
            if prow:
                out += [f"{indent}    for (p = 0; p < {sy.ns_c}; ++p) {{",
                        f"{indent}        {sy.state}[p] = y[p];", f"{indent}    }}"]
            else:
                out.append(f"{indent}    {sy.state}[0] = y[0];")
    else:
        out += [f"{pad}{acc} = 0.0_R;"] + body
    out.append(f"{indent}}}")
    return "\n".join(out) + "\n"


def interp_ranges(path: str, row, n: int, m: int) -> list[tuple[int, int]]:
    """The contiguous ranges ``[lo, hi)`` of a kernel row (offsets ``row``, e.g.
    :func:`~roadbank.estimators.layout.lpv_row`) holding the blocks ``path`` reads."""
    idx = sorted({k for b in blocks_read(path)
                  for k in range(getattr(row, b), getattr(row, b) + block_shape(b, n, m)[0] * block_shape(b, n, m)[1])})
    out: list[tuple[int, int]] = []
    for k in idx:
        if out and out[-1][1] == k:
            out[-1] = (out[-1][0], k + 1)
        else:
            out.append((k, k + 1))
    return out

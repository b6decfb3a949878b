r"""The update of one sample, written down once: the description the compiled kernels follow and
the exported C is generated from.

Every per-sample estimator on the ``lpv`` kernel advances two scheduled linear systems of the same
form, ``ns`` states ``x``, ``m`` inputs ``e``, one output ``y``::

    x' = F x + G e,    y = H x + D e,    equilibrium x = J e,
    fixed-rate map     x+ = Phi x + Gam0 e- + Gam1 e     (e-: the previous sample's inputs)

========  =====================================  ===========================================
system    x, e, y                                blocks (offsets)
========  =====================================  ===========================================
observer  ``xi`` (n), ``eta = [delta_f, ay, r]``  a table row at the speed ``vx``
          (3), ``w = sin(theta)``                (:func:`~roadbank.estimators.layout.lpv_row`)
roll      ``z`` (nr), ``ay`` (1), ``phi`` (rad)   constants (:func:`~roadbank.estimators.layout.roll_block`)
========  =====================================  ===========================================

The block names below are the fields of :class:`~roadbank.estimators.layout.LpvRow` and
:class:`~roadbank.estimators.layout.RollBlock`, so a block's offset is ``getattr(row, name)``.
One used sample takes one of three paths (:data:`PATHS`), then :data:`OUTPUT`:

* ``restart`` (first sample, or after a gap): ``x = J e``;
* ``fixed`` (the interval is the fixed rate's): ``x = Gam0 e- + Gam1 e + Phi x``;
* ``general`` (any other interval): the trapezoidal rule on ``F, G`` (:class:`Trapezoid`);
* then ``y = D e + H x``, and ``e`` becomes ``e-``.

A :class:`Sum` fixes the order of the floating-point operations, which is part of the
description: per output row ``s = 0``, then for each group in turn and each column ``k`` of it,
``s += (product_1[k] + product_2[k] + ...)`` (one product: ``s += B[p, k] v[k]``). The kernels
(:func:`roadbank.estimators.kernels.lpv.observer_update` and ``fixed3``,
:func:`roadbank.estimators.kernels.sample.finish`) add in this order, the C generator
(:mod:`roadbank.export.ccode`) writes its loops from these objects, and tests/test_update_spec.py
checks the kernels against :func:`evaluate` bit for bit. The schedule at ``vx`` is
:func:`grid_point` and :func:`interpolate` (the blocks a path reads: :func:`blocks_read`,
:func:`row_ranges`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, NamedTuple, Sequence

import numpy as np

#: the vectors a product can read: the state, the inputs and the previous sample's inputs
VECTORS = ("x", "e", "e_prev")


class Product(NamedTuple):
    """``block @ vector``: a block of the system (a field name of ``LpvRow`` / ``RollBlock``) times
    one of :data:`VECTORS`."""

    block: str
    vector: str


@dataclass(frozen=True)
class Sum:
    """``target = sum of the groups' products`` in a fixed order (see the module doc).

    ``target`` is ``"x"`` (the new state, one row per state) or ``"y"`` (the output, one row);
    ``groups``: the products of a group share the column index and are added together before
    the running sum; ``equation``: the formula, for comments in generated code.
    """

    target: str
    groups: tuple[tuple[Product, ...], ...]
    equation: str

    def blocks(self) -> tuple[str, ...]:
        """The blocks the sum reads, in order."""
        return tuple(p.block for g in self.groups for p in g)


@dataclass(frozen=True)
class Trapezoid:
    """``x' = F x + G e`` over ``dt`` by the trapezoidal rule: ``nsub = max(1, ceil(dt / max_sub
    - 1e-9))`` substeps of ``h = dt / nsub``, ``e`` linear in time from ``e-`` to ``e``; each
    substep solves ``(I - h/2 F) x+ = x + h/2 (F x + G (e_k + e_k+1))`` (:func:`trapezoid`).
    A solver, not a fixed order of sums: kernels and C may solve it differently (LU, adjugate)."""

    F: str
    G: str
    equation: str


#: restart at the equilibrium of the current inputs
RESTART = Sum("x", ((Product("J", "e"),),), "x = J e")
#: the exact discrete-time map of a sample at the fixed rate (first-order hold on e)
FIXED = Sum("x", ((Product("Gam0", "e_prev"), Product("Gam1", "e")), (Product("Phi", "x"),)),
            "x = Gam0 e- + Gam1 e + Phi x")
#: the general path: any other interval
GENERAL = Trapezoid("F", "G", "x' = F x + G e, trapezoidal rule over dt")
#: the output after the state update
OUTPUT = Sum("y", ((Product("D", "e"),), (Product("H", "x"),)), "y = D e + H x")

#: the state update of each path
PATHS: dict[str, Sum | Trapezoid] = {"restart": RESTART, "fixed": FIXED, "general": GENERAL}


def block_shape(block: str, ns: int, m: int) -> tuple[int, int]:
    """(rows, columns) of a block of a system with ``ns`` states and ``m`` inputs (row-major)."""
    shapes = {"F": (ns, ns), "G": (ns, m), "H": (1, ns), "D": (1, m), "J": (ns, m),
              "Phi": (ns, ns), "Gam0": (ns, m), "Gam1": (ns, m)}
    return shapes[block]


def blocks_read(path: str) -> tuple[str, ...]:
    """The blocks a path's update and the output read (what must be interpolated at ``vx``)."""
    step = PATHS[path]
    own = step.blocks() if isinstance(step, Sum) else (step.F, step.G)
    return tuple(dict.fromkeys(own + OUTPUT.blocks()))


def row_ranges(path: str, row, n: int, m: int) -> list[tuple[int, int]]:
    """The contiguous ranges ``[lo, hi)`` of a table row with block offsets ``row`` (e.g.
    :func:`~roadbank.estimators.layout.lpv_row` of ``n`` states, ``m`` inputs) holding the
    blocks ``path`` reads: what the kernels and the C interpolate at ``vx``."""
    idx = sorted({k for b in blocks_read(path)
                  for k in range(getattr(row, b), getattr(row, b) + math.prod(block_shape(b, n, m)))})
    out: list[tuple[int, int]] = []
    for k in idx:
        if out and out[-1][1] == k:
            out[-1] = (out[-1][0], k + 1)
        else:
            out.append((k, k + 1))
    return out


def evaluate(s: Sum, blocks: Mapping[str, Sequence[float]], vectors: Mapping[str, Sequence[float]],
             ns: int) -> list[float]:
    """The value of ``s`` in its order of operations (pure Python floats: IEEE double, as the kernels).

    Parameters
    ----------
    s : Sum
        The sum.
    blocks : mapping
        Block name -> its entries, row-major (units of the system's blocks).
    vectors : mapping
        ``"x"`` (ns), ``"e"`` and ``"e_prev"`` (m): the state and inputs in the system's units.
    ns : int
        Number of states (the rows of an ``"x"`` target; a ``"y"`` target has one).

    Returns
    -------
    list of float
        The new state (``ns`` entries) or ``[y]``.
    """
    rows = ns if s.target == "x" else 1
    out = []
    for p in range(rows):
        acc = 0.0
        for group in s.groups:
            ncol = len(vectors[group[0].vector])
            for k in range(ncol):
                term = 0.0
                for j, prod in enumerate(group):
                    v = blocks[prod.block][p * ncol + k] * vectors[prod.vector][k]
                    term = v if j == 0 else term + v
                acc += term
        out.append(acc)
    return out


def trapezoid(F: np.ndarray, G: np.ndarray, x: np.ndarray, e0: np.ndarray, e1: np.ndarray, dt: float,
              max_sub: float) -> np.ndarray:
    """:class:`Trapezoid` by dense solves: the state after ``dt`` (s) with substeps of at most
    ``max_sub`` (s); ``F`` (1/s), ``G``, ``x``, ``e0``, ``e1`` in the system's units."""
    n = len(x)
    nsub = max(1, math.ceil(dt / max_sub - 1e-9))
    hh = 0.5 * dt / nsub
    M = np.eye(n) - hh * F
    x = np.asarray(x, float).copy()
    for k in range(nsub):
        a = (2.0 * k + 1.0) / nsub
        x = np.linalg.solve(M, x + hh * (F @ x + G @ (2.0 * e0 + a * (e1 - e0))))
    return x


def grid_point(vx: float, v0: float, dv: float, ng: int) -> tuple[int, float]:
    """Row ``i`` and weight ``a`` of the speed ``vx`` (m/s) on the grid ``v0 + k dv`` (m/s) of ``ng``
    points, clamped at both ends: ``s = (vx - v0) * (1 / dv)``, ``i = floor(s)``, ``a = s - i``."""
    s = (vx - v0) * (1.0 / dv)
    last = ng - 1
    if last == 0 or s <= 0.0:
        return 0, 0.0
    if s >= last:
        return last - 1, 1.0
    i = int(s)
    return i, s - i


def interpolate(row0: Sequence[float], row1: Sequence[float], a: float) -> list[float]:
    """The schedule between two table rows, entry by entry: ``row0 + a (row1 - row0)``."""
    return [r0 + a * (r1 - r0) for r0, r1 in zip(row0, row1)]

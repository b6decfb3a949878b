r"""Memory layout of the compiled estimator kernels: the one place that says what lives where.

The kernels (:mod:`roadbank.estimators.kernels`) work on four flat float64
arrays, so that a call passes no Python objects and nothing is allocated per
sample:

``mem`` — the state of one estimator (written by the kernels, zeroed by ``reset()``)
    ========  ===========================================================
    offset    content
    ========  ===========================================================
    M_INIT    1.0 once initialised
    M_TLAST   time of the last valid sample (s)
    M_W ..    held outputs ``w`` (-), ``theta``, ``phi_b``, ``phi`` (rad)
    M_GATED   DFC: previous gated estimate (-); its states: ``M_DFC_X``, ``M_DFC_IND``
    M_AY      previous lateral acceleration, input of the roll model (m/s^2)
    M_ETA     previous inputs ``eta = [delta_f, ay, r]`` (3)
    M_X       observer states (n), then :func:`roll_states` (nr), then
              :func:`riccati_p` (n*n, Riccati variant only) or
              :func:`adaptive_state` (2, ``adaptive`` family only) or
              :func:`gate_states` (2, ``gated`` family only), then
              :func:`limit_states` (3, a limited low-pass only)
    ========  ===========================================================

``cfg`` — constants of one estimator (built once per design)
    a head of scalars ``C_*``, then the roll model block at :data:`C_ROLL`
    (:func:`roll_block`), then the fixed-rate roll block (:func:`roll_block`
    ``["Phi", "Gam0", "Gam1"]``), then family-specific constants (Riccati:
    ``R^-1``, ``W``, ``Mneg``, :func:`riccati_block`; ``adaptive``: :func:`adaptive_block`;
    ``gated``: :func:`gated_block`).

``tab`` — the speed schedule, one row per grid speed ``v0 + k dv``
    ``lpv`` rows: :func:`lpv_row` (continuous ``F, G, H, D, J``, then the
    discrete ``Phi, Gam0, Gam1`` of the fixed-rate path when a sample rate is
    set); ``adaptive`` (two-dimensional schedule, speed x excitation): the
    continuous part of :func:`lpv_row`, row ``iv * ne + ie`` for speed point
    ``iv`` and excitation point ``ie`` (:func:`adaptive_block`); ``gated``: :func:`lpv_row` of the
    two observers' block-diagonal stack (gate constants: :func:`gated_block`); ``dfc`` rows:
    ``Haw0, Hrw0, Hau0, Hru0`` (``DFC_*``); ``riccati`` rows: :func:`riccati_row`
    (``A, B, C, Dy, J``); the smoother's rows: :func:`smooth_row` (``S, M, b``)
    and :func:`smooth_fixed_row` (``Phi, Gam0, Gam1``).

``work`` — scratch (:func:`work_size`): the ``lpv`` and ``adaptive`` kernels interpolate
    the table row into it at the row's own offsets, scratch after :attr:`LpvRow.end`; the
    Riccati kernel adds its blocks after the row (:func:`riccati_work`).

The fixed offsets are plain integers, which numba folds into the compiled code as
constants; the helpers below compute the variable-size blocks from the state
dimensions and are the same functions in Python and in compiled code
(inlined by numba into each kernel, :func:`_compiled`): the kernels call them (``row = lpv_row(n)``, then
``work[row.H + p]``), Python builds the arrays with them, and the generated C
(:mod:`roadbank.export.ccode`) takes its offsets from them, so no offset is
written down twice. Blocks are stored row-major.
"""

from __future__ import annotations

from typing import NamedTuple

from numba.extending import register_jitable

_overload = register_jitable(inline="always")


def _compiled(fn):
    """The helpers below: plain Python functions that compiled code can call too, inlined into the calling kernel
    with no compiled function of their own.

    numba's untyped inlining pass (before typing) inlines a callee that carries jit options with
    ``inline="always"`` (``targetoptions``) and its Python function (``py_func``), as an ``njit(inline="always")``
    function does, while Python still calls the plain function. ``register_jitable`` alone (the typing fallback,
    kept) would compile each helper on its own to type the call, about 0.03-0.07 s per helper and kernel family
    (``python -m roadbank.bench.cold``).
    """
    fn = _overload(fn)
    fn.__dict__.update(targetoptions={"inline": "always"}, py_func=fn)
    return fn


#: number of inputs ``eta = [delta_f, ay, r]``
NETA = 3

# --- mem ------------------------------------------------------------------------
M_INIT = 0
M_TLAST = 1
M_W = 2
M_THETA = 3
M_PHIB = 4
M_PHI = 5
M_GATED = 6
M_AY = 7
M_ETA = 8
M_X = M_ETA + NETA

# --- cfg head -------------------------------------------------------------------
C_N = 0         # observer states n
C_P = 1         # Riccati: number of measured outputs p
C_V0 = 2        # speed grid: first speed (m/s)
C_DV = 3        #             step (m/s)
C_NG = 4        #             number of points
C_VMIN = 5      # v_min (m/s)
C_SUB = 6       # longest substep of the general path (s)
C_GAP = 7       # longest gap before re-initialisation (s)
C_G = 8         # gravity (m/s^2)
C_NR = 9        # roll-model states nr (0 or 2)
C_USE = 10      # uses delta_f, ay, r: three flags (1.0 / 0.0)
C_AREF = 13     # DFC a_ref (m/s^2)
C_TAU = 14      # DFC low-pass time constant (s)
C_WMAX = 15     # sin(max_angle): a larger |w| is flagged implausible
C_DTFIX = 16    # sample interval of the fixed-rate path (s); 0: no fixed-rate tables
C_DTOL = 17     # relative tolerance on the interval for the fixed-rate path (-)
C_OFAM = 18     # offset of the family-specific constants (after the roll blocks)
C_LIM = 19      # offset of the low-pass's update limit (LimitBlock, the last constants); 0: no limit
C_ROLL = 20     # start of the roll block
NHEAD = C_ROLL

#: relative deviation of a sample interval from the fixed rate's that still uses the fixed-rate path
DT_REL_TOL = 1e-4


class RollBlock(NamedTuple):
    """Offsets in ``cfg`` of the roll model ``z' = F z + G ay``, ``phi = H z + D ay``,
    ``z_eq = J ay`` and of its fixed-rate map ``z+ = Phi z + Gam0 ay- + Gam1 ay``."""

    F: int
    G: int
    H: int
    D: int
    J: int
    Phi: int
    Gam0: int
    Gam1: int
    end: int


@_compiled
def roll_block(nr: int) -> RollBlock:
    """:class:`RollBlock` for ``nr`` roll states (sizes nr*nr, nr, nr, 1, nr, nr*nr, nr, nr)."""
    F = C_ROLL
    G = F + nr * nr
    H = G + nr
    D = H + nr
    J = D + 1
    Phi = J + nr
    Gam0 = Phi + nr * nr
    Gam1 = Gam0 + nr
    return RollBlock(F, G, H, D, J, Phi, Gam0, Gam1, Gam1 + nr)


class RiccatiBlock(NamedTuple):
    """Offsets in ``cfg`` of the Riccati constants ``R^-1`` (p*p), ``W`` (n*n), ``Mneg`` (n*n)."""

    Rinv: int
    W: int
    Mneg: int
    end: int


@_compiled
def riccati_block(n: int, p: int, nr: int) -> RiccatiBlock:
    """:class:`RiccatiBlock` after the roll block of ``nr`` states."""
    o = roll_block(nr).end
    return RiccatiBlock(o, o + p * p, o + p * p + n * n, o + p * p + 2 * n * n)


class RiccatiRow(NamedTuple):
    """Offsets within one ``riccati`` table row (n states, p measured outputs): ``A`` (n*n),
    ``B`` (n*3), ``C`` (p*n), ``Dy`` (p*3) with the innovation ``Dy eta - C x``, ``J`` (n*3,
    the start ``xi = J eta``); ``end`` the row's length."""

    A: int
    B: int
    C: int
    Dy: int
    J: int
    end: int


@_compiled
def riccati_row(n: int, p: int) -> RiccatiRow:
    """:class:`RiccatiRow` for ``n`` states and ``p`` measured outputs."""
    B = n * n
    C = B + n * NETA
    Dy = C + p * n
    J = Dy + p * NETA
    return RiccatiRow(0, B, C, Dy, J, J + n * NETA)


class RiccatiWork(NamedTuple):
    """Offsets in ``work`` of the Riccati kernel's blocks after the interpolated row
    (:func:`riccati_row` ``.end``): the gain ``K`` (n*p), the closed-loop ``F`` (n*n) and ``G``
    (n*3) (``F`` also receives ``P``), the Hamiltonian ``Hm`` (2n x 2n), its trapezoidal
    matrix ``Mw`` (2n x 2n) with pivots ``piv`` (2n), ``Z = [X; Y]`` (2n x n), ``X^T`` at ``Xt``
    (n*n) with pivots ``px`` (n), a column buffer ``col`` (2n + 6), the current inputs ``e``
    (3) and the scratch ``S`` of the roll step."""

    K: int
    F: int
    G: int
    Hm: int
    Mw: int
    piv: int
    Z: int
    Xt: int
    px: int
    col: int
    e: int
    S: int


@_compiled
def riccati_work(n: int, p: int) -> RiccatiWork:
    """:class:`RiccatiWork` for ``n`` states and ``p`` measured outputs."""
    K = riccati_row(n, p).end
    F = K + n * p
    G = F + n * n
    Hm = G + n * NETA
    Mw = Hm + 4 * n * n
    piv = Mw + 4 * n * n
    Z = piv + 2 * n
    Xt = Z + 2 * n * n
    px = Xt + n * n
    col = px + n
    e = col + 2 * n + 2 * NETA
    return RiccatiWork(K, F, G, Hm, Mw, piv, Z, Xt, px, col, e, e + NETA)


class LpvRow(NamedTuple):
    """Offsets within one ``lpv`` table row (n observer states, 3 inputs).

    Continuous: ``F`` (n*n), ``G`` (n*3), ``H`` (n), ``D`` (3), ``J`` (n*3, the
    equilibrium ``xi = J eta``). Fixed rate: ``Phi`` (n*n), ``Gam0``, ``Gam1`` (n*3).
    ``cont`` is the length of the continuous part, ``end`` of the whole row.
    """

    F: int
    G: int
    H: int
    D: int
    J: int
    cont: int
    Phi: int
    Gam0: int
    Gam1: int
    end: int


@_compiled
def lpv_row(n: int) -> LpvRow:
    """:class:`LpvRow` for ``n`` observer states."""
    G = n * n
    H = G + n * NETA
    D = H + n
    J = D + NETA
    cont = J + n * NETA
    Gam0 = cont + n * n
    Gam1 = Gam0 + n * NETA
    return LpvRow(0, G, H, D, J, cont, cont, Gam0, Gam1, Gam1 + n * NETA)


class Batch3Block(NamedTuple):
    """Offsets, within a three-state ``lpv`` row after :func:`lpv_row` ``.end``, of the fixed-rate
    map arranged for the batch loop (:func:`roadbank.estimators.kernels.lpv.lpv3_fixed_run`).

    ``M`` (9 x 4): the columns of ``[Gam0 | Gam1 | Phi]`` in the order the loop sums them,
    ``Gam0[:, 0], Gam1[:, 0], Gam0[:, 1], Gam1[:, 1], Gam0[:, 2], Gam1[:, 2], Phi[:, 0],
    Phi[:, 1], Phi[:, 2]``, each as four lanes (the three state rows, then 0), so that one
    column times one input updates all three states at once (SIMD). ``W`` (8): ``D[0:3], 0,
    H[0:3], 0``. ``dM``, ``dW``: the next grid row's ``M``, ``W`` minus this row's (0 in the
    last row), so that the loop interpolates each entry as ``M + a dM``, the same number
    as ``M[i] + a (M[i+1] - M[i])``.
    """

    M: int
    W: int
    dM: int
    dW: int
    end: int


@_compiled
def batch3_block() -> Batch3Block:
    """:class:`Batch3Block` of a three-state row (starts at ``lpv_row(3).end``)."""
    o = lpv_row(3).end
    return Batch3Block(o, o + 36, o + 44, o + 80, o + 88)


@_compiled
def roll_states(n: int) -> int:
    """Offset in ``mem`` of the roll states (after the ``n`` observer states)."""
    return M_X + n


@_compiled
def riccati_p(n: int, nr: int) -> int:
    """Offset in ``mem`` of the Riccati matrix ``P`` (n*n, row-major)."""
    return M_X + n + nr


class AdaptiveBlock(NamedTuple):
    """Offsets in ``cfg`` of the ``adaptive`` family's excitation grid and filters:
    first grid point ``E0`` (m/s^2), step ``DE`` (m/s^2), number of points ``NE``, release
    time constant ``TAU`` (s) of the excitation's peak follower, time constant ``TF`` (s)
    of the low-pass on ``|ay|`` before it."""

    E0: int
    DE: int
    NE: int
    TAU: int
    TF: int
    end: int


@_compiled
def adaptive_block(nr: int) -> AdaptiveBlock:
    """:class:`AdaptiveBlock` after the roll block of ``nr`` states (at ``cfg[C_OFAM]``)."""
    o = roll_block(nr).end
    return AdaptiveBlock(o, o + 1, o + 2, o + 3, o + 4, o + 5)


@_compiled
def excitation_state(n: int, nr: int) -> int:
    """Offset in ``mem`` of the ``adaptive`` family's excitation (m/s^2), followed by the
    low-passed ``|ay|`` (m/s^2); where a Riccati P would be."""
    return M_X + n + nr


class AdaptiveState(NamedTuple):
    """Offsets in ``mem`` of the ``adaptive`` family's excitation ``E`` (m/s^2) and low-passed
    ``|ay|`` ``AF`` (m/s^2)."""

    E: int
    AF: int


@_compiled
def adaptive_state(n: int, nr: int) -> AdaptiveState:
    """:class:`AdaptiveState` (``E`` is :func:`excitation_state`)."""
    o = excitation_state(n, nr)
    return AdaptiveState(o, o + 1)


class GatedBlock(NamedTuple):
    """Offsets in ``cfg`` of the ``gated`` family's constants: the second observer's output row
    ``HF`` (n, over the stacked states), the yaw-rate low-pass time constant ``TF`` (s), the gate's
    release time constant ``TAU`` (s), the yaw jerk ``ON`` (m/s^3) where it starts to open, the
    ``SPAN`` (m/s^3) over which it opens fully and the lowest speed ``VMIN`` (m/s) at which it counts (then, with a
    limit, its :class:`LimitBlock`)."""

    HF: int
    TF: int
    TAU: int
    ON: int
    SPAN: int
    VMIN: int
    end: int


@_compiled
def gated_block(n: int, nr: int) -> GatedBlock:
    """:class:`GatedBlock` after the roll block of ``nr`` states (at ``cfg[C_OFAM]``)."""
    o = roll_block(nr).end
    return GatedBlock(o, o + n, o + n + 1, o + n + 2, o + n + 3, o + n + 4, o + n + 5)


#: number of constants of a :class:`LimitBlock`
NLIM = 8


class LimitBlock(NamedTuple):
    """Offsets in ``cfg`` of the limit of a kinematic low-pass's update (at ``cfg[C_LIM]``, the last
    :data:`NLIM` constants; :func:`roadbank.estimators.kernels.sample.limited_ay`): ``CLIP`` (-, standard
    deviations), the gravity ``GRAV`` (m/s^2) of its prediction, the noise densities ``QAY``
    ((m/s^2)^2 s) and ``RR`` ((rad/s)^2 s) of its spread, and the running noise estimate's time constant
    ``TN`` (s; 0: none) and reference variance ``REF`` ((m/s^2)^2;
    :func:`roadbank.estimators.kernels.sample.noise_update`), the number ``NLP`` of the low-pass's states
    whose update follows it (:func:`roadbank.estimators.kernels.sample.scale_update`), and the time constant
    ``TS`` (s; 0: ``TN``'s ratio) of the second ratio the limit reads."""

    CLIP: int
    GRAV: int
    QAY: int
    RR: int
    TN: int
    REF: int
    NLP: int
    TS: int


@_compiled
def limit_block(o: int) -> LimitBlock:
    """:class:`LimitBlock` at offset ``o`` (``cfg[C_LIM]``)."""
    return LimitBlock(o, o + 1, o + 2, o + 3, o + 4, o + 5, o + 6, o + 7)


class LimitState(NamedTuple):
    """Offsets in ``mem`` of a limited low-pass's running noise ratio ``NV`` (-), previous kinematic
    acceleration ``KA`` (m/s^2) and the limit's shorter ratio ``NS`` (-)
    (:func:`roadbank.estimators.kernels.sample.noise_update`)."""

    NV: int
    KA: int
    NS: int


@_compiled
def limit_states(n: int, nr: int) -> LimitState:
    """:class:`LimitState` after the ``gated`` family's two states (which a one-observer low-pass leaves free)."""
    o = M_X + n + nr + 2
    return LimitState(o, o + 1, o + 2)


@_compiled
def gate_state(n: int, nr: int) -> int:
    """Offset in ``mem`` of the ``gated`` family's low-passed yaw rate (rad/s), followed by the
    gate (-); where a Riccati P would be."""
    return M_X + n + nr


class GateState(NamedTuple):
    """Offsets in ``mem`` of the ``gated`` family's low-passed yaw rate ``RF`` (rad/s) and gate ``G`` (-)."""

    RF: int
    G: int


@_compiled
def gate_states(n: int, nr: int) -> GateState:
    """:class:`GateState` (``RF`` is :func:`gate_state`)."""
    o = gate_state(n, nr)
    return GateState(o, o + 1)


# --- dfc ------------------------------------------------------------------------
#: ``dfc`` table row: Haw0, Hrw0, Hau0, Hru0 (the gate's transfer-function gains at the grid speed)
DFC_HAW, DFC_HRW, DFC_HAU, DFC_HRU = 0, 1, 2, 3
#: ``dfc`` states in ``mem``: the low-pass output (-), then the DFC indicator (m/s^2)
M_DFC_X = M_X
M_DFC_IND = M_X + 1


# --- smoother -------------------------------------------------------------------

class SmoothRow(NamedTuple):
    """Offsets within one row of the smoother's backward-pass table: ``S`` (n*n), ``M`` (n*n), ``b`` (n)."""

    S: int
    M: int
    b: int
    end: int


@_compiled
def smooth_row(n: int) -> SmoothRow:
    """:class:`SmoothRow` for ``n`` states."""
    return SmoothRow(0, n * n, 2 * n * n, 2 * n * n + n)


class SmoothFixedRow(NamedTuple):
    """Offsets within one row of the smoother's fixed-rate table, inputs ``e = [x_f, ay]``
    (``ne = n + 1``): ``Phi`` (n*n), ``Gam0``, ``Gam1`` (n*ne)."""

    Phi: int
    Gam0: int
    Gam1: int
    ne: int
    end: int


@_compiled
def smooth_fixed_row(n: int) -> SmoothFixedRow:
    """:class:`SmoothFixedRow` for ``n`` states."""
    ne = n + 1
    return SmoothFixedRow(0, n * n, n * n + n * ne, ne, n * n + 2 * n * ne)


@_compiled
def mem_size(n: int, nr: int) -> int:
    """Length of ``mem`` for ``n`` observer and ``nr`` roll states (room for a Riccati ``P``, and for the
    gate's and the limit's states after them)."""
    return M_X + n + nr + n * n + 5


@_compiled
def work_size(n: int) -> int:
    """Length of the scratch array ``work`` for ``n`` observer states (every family)."""
    return 64 + 20 * n * n + 8 * n * NETA + 4 * n

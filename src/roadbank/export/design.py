"""What an exported estimator is made of: its speed-scheduled tables and scalars.

:func:`export_design` reads a designed :class:`~roadbank.estimators.base.Estimator`
(any estimator on the ``lpv`` kernel: a linear observer scheduled on speed) and
returns an :class:`ExportDesign`: the table rows exactly as the Python kernel
interpolates them, the roll model and the sample-handling constants. Nothing
here depends on particular weights: a re-tuned estimator or a new variant on
the same kernel exports the same way.
"""

from __future__ import annotations

import hashlib
import math
import re
from dataclasses import dataclass, field

import numpy as np

from ..estimators.base import Estimator
from ..estimators.gyro import GradeCarry
from ..estimators.layout import C_LIM, DT_REL_TOL, gated_block, limit_block, lpv_row
from ..models.attitude import MAX_SIN_PITCH

#: the constants of a gated module (:attr:`ExportDesign.gate`) and of a limited low-pass
#: (:attr:`ExportDesign.limit`), in the fingerprint's order
GATE_KEYS = ("HF", "tf", "tau", "on", "span")
LIMIT_KEYS = ("clip", "grav", "qay", "rr", "tn", "ref", "nlp", "ts")

#: the target sample rates an export is designed for (Hz), as a channel map's ``rate_hz``: below 1 Hz a car's
#: bank changes between samples, above 10 kHz no vehicle bus or sensor delivers (a typo such as 1e9 is refused)
RATE_RANGE_HZ = (1.0, 10_000.0)

#: why an estimator on another kernel cannot be exported (kernel -> reason)
_NOT_LPV_REASON = {
    "dfc": "DFC gates its estimate by a nonlinear function of the dynamic-factor indicator "
           "(|DFC| / a_ref): it is not a speed-scheduled linear observer",
    "riccati": "this PIF variant integrates the time-varying Riccati equation (paper eq 43) at "
               "every sample, a 6x6 Hamiltonian solve per substep, not a gain schedule; export the "
               "steady-state variant (variant='steady', the default), which is what an ECU runs",
    "adaptive": "pif-adaptive and pif-rate-adaptive schedule their gains on the friction usage (a filtered |ay|) "
                "as well as speed: a two-dimensional table and an excitation filter the generated C (speed-only "
                "schedule) does not have; export pif-modified or pif-rate instead",
}


class NotExportable(ValueError):
    """The estimator's runtime is not a speed-scheduled linear observer."""


@dataclass(frozen=True)
class ExportDesign:
    """Everything the generated C needs, in SI units.

    Attributes
    ----------
    name : str
        Estimator name (e.g. ``"pif-modified"``); ``ident`` is its C identifier.
    n : int
        Observer states; ``nr`` roll-model states (0 static/none, 2 dynamic).
    v0, dv : float
        First speed (m/s) and spacing (m/s) of the schedule's grid.
    table : array (ng, n*n + 3n + n + 3 + 3n)
        One row per grid speed: F (n x n), G (n x 3), H (n), D (3), J (n x 3),
        row-major, at the offsets of :func:`roadbank.estimators.layout.lpv_row` (its continuous
        part); ``xi' = F xi + G eta``, ``w = H xi + D eta``, ``J = -F^-1 G``
        (the equilibrium used at a (re)start).
    roll_F, roll_G, roll_H, roll_D, roll_J : arrays
        Roll model ``z' = F z + G ay``, ``phi = H z + D ay``, ``J = -F^-1 G``.
    uses : tuple of 3 bool
        Which of ``delta_f, ay, r`` the observer reads (others may be NaN).
    v_min, max_substep, max_gap, max_angle, wmax : float
        m/s, s, s, rad and ``sin(max_angle)``.
    rate : float
        Nominal sample rate (Hz) the module is generated for.
    provenance : dict
        Estimator settings and vehicle parameters, for the generated header.
    """

    name: str
    ident: str
    n: int
    nr: int
    v0: float
    dv: float
    table: np.ndarray
    roll_F: np.ndarray
    roll_G: np.ndarray
    roll_H: np.ndarray
    roll_D: float
    roll_J: np.ndarray
    uses: tuple
    v_min: float
    max_substep: float
    max_gap: float
    max_angle: float
    wmax: float
    rate: float
    state_names: tuple = ()
    provenance: dict = field(default_factory=dict)
    #: settling time (s) after a (re)start (:attr:`roadbank.estimators.Estimator.settle_time`), for the header
    settle_s: float = 0.0
    #: fixed-rate tables (``Estimator.discrete_tables(1/rate)``) or None (general path only)
    discrete: dict | None = None
    #: relative tolerance on the interval for the fixed-rate tables
    dt_tol: float = 0.0
    #: ``pif-gated``: the second observer's output row ``HF`` (n,) and the gate's ``tf``, ``tau`` (s),
    #: ``on``, ``span`` (m/s^3) (:func:`roadbank.estimators.kernels.gated_step`); None for one observer
    gate: dict | None = None
    #: a limited low-pass (``kinematic-pif``'s): ``clip`` (-), ``grav`` (m/s^2), ``qay`` ((m/s^2)^2 s), ``rr``
    #: ((rad/s)^2 s) (:func:`roadbank.estimators.kernels.sample.limited_ay`), its running noise's ``tn`` (s; 0:
    #: none) and ``ref`` ((m/s^2)^2), ``nlp`` (its states, :func:`~roadbank.estimators.kernels.sample.noise_update`)
    #: and ``ts`` (s; the limit's shorter ratio, 0: none); None without a limit
    limit: dict | None = None
    #: the observer's first input: ``"delta_f"`` (the steering angle), or ``"p"`` (the gyro-aided filter's roll rate)
    first_input: str = "delta_f"
    #: the gyro-aided filter's grade correction (:class:`~roadbank.estimators.gyro.GradeCarry`): ``window`` and
    #: ``first_span`` (s; inf: none), ``g`` (m/s^2), ``max_sin`` (-, :data:`~roadbank.models.attitude.MAX_SIN_PITCH`),
    #: ``max_gap`` (s: the interval after which the window starts again, the filter's ``max_gap``, in the fingerprint
    #: as that) and ``observer`` (the pitch observer's ``cfg``, :mod:`roadbank.estimators.kernels.attitude`; None: the
    #: window's pitch); None without a correction
    grade: dict | None = None
    #: the vehicle file's identified sensor offsets the module takes off the measured channels (measured minus true,
    #: SI): ``{"r": rad/s, "ay": m/s^2, "delta_f": rad}``, those the file has (:attr:`roadbank.vehicle.Vehicle.
    #: sensor_offsets`, what ``roadbank estimate --vehicle`` removes)
    offsets: dict = field(default_factory=dict)
    #: the online offset learner's ``cfg`` (:mod:`roadbank.estimators.kernels.offsets`) or None without one
    learner: np.ndarray | None = None

    @property
    def running_noise(self) -> bool:
        """Whether a limited low-pass follows a running noise estimate (state members ``nv``, ``ka``, ``ns``)."""
        return self.limit is not None and self.limit["tn"] > 0

    @property
    def ng(self) -> int:
        """Number of grid speeds (table rows)."""
        return int(self.table.shape[0])

    @property
    def nk(self) -> int:
        """Floats per table row."""
        return int(self.table.shape[1])

    @property
    def nsub_max(self) -> int:
        """Most trapezoidal substeps one sample can need (a step never exceeds ``max_gap``)."""
        return max(1, int(math.ceil(self.max_gap / self.max_substep - 1e-9)))

    @property
    def nsub_nominal(self) -> int:
        """Substeps per sample at the nominal rate."""
        return max(1, int(math.ceil((1.0 / self.rate) / self.max_substep - 1e-9)))

    def table_bytes(self, float32: bool = False) -> int:
        """Flash taken by the ``static const`` tables (bytes): schedule plus roll constants."""
        nroll = self.roll_F.size + self.roll_G.size + self.roll_H.size + 1 + self.roll_J.size
        if self.discrete is not None:
            x = self.discrete
            nroll += x["Phi_r"].size + x["Gam0_r"].size + x["Gam1_r"].size
            nroll += x["Phi"].size + x["Gam0"].size + x["Gam1"].size
        return (self.table.size + nroll) * (4 if float32 else 8)

    def state_bytes(self, float32: bool = False) -> int:
        """Size (bytes) of the generated state struct where ``double`` is 8-byte aligned
        (x86-64, ARM EABI): int flag, double time, then reals."""
        r = 4 if float32 else 8
        fields = [(4, 4), (8, 8), (r, r), (3 * r, r)] + ([(self.n * r, r)] if self.n else []) \
            + ([(self.nr * r, r)] if self.nr else []) + [(r, r)] * (5 + (2 if self.gate else 0)
                                                                    + (3 if self.running_noise else 0))
        size = 0
        for nbytes, align in fields:
            size = -(-size // align) * align + nbytes
        return -(-size // 8) * 8

    def fingerprint(self, float32: bool = False) -> str:
        """SHA-256 (first 16 hex digits) of the tables and constants, the offsets, the learner's settings and the
        precision (``float32``): identifies a generated module (a design without offsets, learner or float32 keeps
        the fingerprint it had before they counted)."""
        h = hashlib.sha256()
        for a in (self.table, self.roll_F, self.roll_G, self.roll_H, self.roll_J,
                  np.array([self.roll_D, self.v0, self.dv, self.v_min, self.max_substep,
                            self.max_gap, self.wmax], float), np.array(self.uses, float),
                  *([] if self.discrete is None else
                    [np.asarray(self.discrete[k], float) for k in ("Phi", "Gam0", "Gam1", "Phi_r", "Gam0_r",
                                                                   "Gam1_r", "dt")]),
                  *([] if self.gate is None else
                    [np.asarray(self.gate[k], float) for k in GATE_KEYS]),
                  *([] if self.limit is None else [np.asarray(self.limit[k], float) for k in LIMIT_KEYS]),
                  *([] if self.first_input == "delta_f" else [np.array([1.0])]),
                  *([] if self.grade is None else
                    [np.array([self.grade[k] for k in ("window", "first_span", "g", "max_sin")], float),
                     np.zeros(0) if self.grade["observer"] is None else np.asarray(self.grade["observer"], float)]),
                  *([] if not any(self.offsets.values()) else
                    [np.array([self.offsets.get(k, 0.0) for k in ("r", "ay", "delta_f")], float)]),
                  *([] if self.learner is None else [np.array([2.0]), np.asarray(self.learner, float)]),
                  *([np.array([32.0])] if float32 else [])):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        return h.hexdigest()[:16]


def c_identifier(name: str) -> str:
    """C identifier of an estimator name: ``"pif-modified"`` -> ``"pif_modified"``."""
    ident = re.sub(r"[^0-9A-Za-z_]", "_", name).strip("_").lower()
    if not ident:
        raise ValueError(f"estimator name {name!r} has no usable characters for a C identifier")
    return ident if not ident[0].isdigit() else f"e_{ident}"


def check_exportable(est) -> None:
    """Raise :class:`NotExportable` (saying why) unless ``est`` is causal and runs on the ``lpv`` kernel
    (or the ``gated`` one: that kernel's observer plus a gate on its output)."""
    if not isinstance(est, Estimator):
        raise TypeError(f"expected a roadbank Estimator, got {type(est).__name__}")
    kernel = str(getattr(est, "kernel", ""))
    if getattr(est, "offline", False):
        raise NotExportable(f"{est.name}: not exportable: an offline estimator (its run() smooths with the "
                            "samples after each instant); an ECU runs its forward filter: export "
                            f"{getattr(est, 'forward_filter', 'pif-modified')} with the same weights")
    if kernel not in ("lpv", "gated"):
        why = _NOT_LPV_REASON.get(kernel, f"its runtime is the {kernel!r} kernel, not a "
                                          "speed-scheduled linear observer")
        raise NotExportable(f"{est.name}: not exportable: {why}")
    if getattr(est, "start_hold", 0.0) > 0 or getattr(est, "start_span", 0.0) > 0:
        raise NotExportable(f"{est.name}: not exportable with start_hold or start_span: those starts of the "
                            "offset state run in Python around the kernel, not in the C step (the defaults have "
                            "neither)")


def export_design(est, rate: float, module_name: str | None = None, *,
                  discrete: bool | None = None) -> ExportDesign:
    """Read the tables of a designed estimator (see :class:`ExportDesign`).

    Parameters
    ----------
    est : Estimator
        A designed estimator on the ``lpv`` kernel.
    rate : float
        Nominal sample rate (Hz) of the target.
    module_name : str, optional
        Name of the C module (files and symbols ``roadbank_<module_name>_*``); default
        the estimator's name. Two designs of one estimator in one program need two names.
    discrete : bool or None
        Add the fixed-rate tables for ``rate`` (the kernels' fixed-rate path,
        ``Estimator.discrete_tables``): samples ``1/rate`` apart then cost one small
        matrix update; other intervals, gaps and restarts take the general path.
        None (default): as the estimator runs in Python -- with the tables when it
        uses its fixed-rate path (``sample_rate="auto"``, the default, or a set rate),
        without them when it was built with ``sample_rate=None``.

    Raises
    ------
    NotExportable
        For estimators whose runtime is not a scheduled linear observer.
    ValueError
        For a rate (Hz) that is not a number within :data:`RATE_RANGE_HZ`, tables that are not finite, or an
        estimator whose fixed rate (``set_sample_rate``) is not ``rate``.
    """
    check_exportable(est)
    lo, hi = RATE_RANGE_HZ
    if not (math.isfinite(rate) and lo <= rate <= hi):
        raise ValueError(f"rate must be {lo:g} to {hi:g} Hz, got {rate:g}")
    n = int(est._nstate)
    # the continuous-time schedule (the kernels' general path), kept apart from the
    # fixed-rate tables the estimator appends for its sample rate
    table = np.array(est._tab_cont, dtype=np.float64, copy=True)
    nk = lpv_row(n).cont
    if table.ndim != 2 or table.shape[1] != nk:
        raise NotExportable(f"{est.name}: not exportable: its table rows have {table.shape[-1]} "
                            f"entries, the scheduled-observer layout needs {nk} for {n} states")
    if not np.all(np.isfinite(table)):
        raise ValueError(f"{est.name}: the designed tables are not finite; cannot export")
    vgrid = np.asarray(est.vgrid, float)
    if len(vgrid) < 2:
        raise ValueError(f"{est.name}: the speed grid needs at least two points")
    F, G, H, D = est._roll
    nr = F.shape[0]
    # the same expressions as Estimator._build_cfg, so the constants are the same bits
    J = -np.linalg.solve(F, G).ravel() if nr else np.zeros(0)
    if est.fixed_dt is not None and abs(est.fixed_dt * rate - 1.0) > DT_REL_TOL:
        raise ValueError(f"{est.name}: the estimator runs its fixed-rate path at {1.0 / est.fixed_dt:g} Hz, "
                         f"not at the export rate {rate:g} Hz")
    if discrete is None:    # as in Python: est._auto_rate is the sample_rate="auto" setting
        discrete = est.fixed_dt is not None or bool(getattr(est, "_auto_rate", False))
    disc, dt_tol = None, 0.0
    if discrete:
        disc = est.discrete_tables(1.0 / rate)
        dt_tol = float(DT_REL_TOL)
    p = est.params
    provenance = {"estimator": repr(est), "class": type(est).__name__,
                  "settings": {k: v for k, v in vars(est).items()
                               if not k.startswith("_") and k not in ("vgrid", "params")},
                  "vehicle": {k: getattr(p, k) for k in p.__dataclass_fields__}
                  if hasattr(p, "__dataclass_fields__") else repr(p)}
    return ExportDesign(
        name=est.name, ident=c_identifier(module_name or est.name), n=n, nr=int(nr),
        v0=float(vgrid[0]), dv=float(vgrid[1] - vgrid[0]), table=table,
        roll_F=np.array(F, float), roll_G=np.array(G, float).ravel(), roll_H=np.array(H, float).ravel(),
        roll_D=float(np.ravel(D)[0]), roll_J=np.array(J, float),
        uses=tuple(bool(u) for u in est.uses), v_min=float(est.v_min),
        max_substep=float(est.max_substep), max_gap=float(est.max_gap),
        max_angle=float(est.max_angle), wmax=float(np.sin(est.max_angle)), rate=float(rate),
        state_names=tuple(getattr(est, "state_names", ())), provenance=provenance, settle_s=float(est.settle_time),
        discrete=disc, dt_tol=dt_tol, gate=_gate(est, n, nr), limit=_limit(est),
        first_input=str(getattr(est, "first_input", "delta_f")), grade=_grade(est))


def _gate(est, n: int, nr: int) -> dict | None:
    """The ``gated`` kernel's constants as its ``cfg`` holds them (None for another kernel)."""
    if est.kernel != "gated":
        return None
    b = gated_block(n, nr)
    cfg = est._cfg
    return {"HF": np.array(cfg[b.HF:b.TF], float), "tf": float(cfg[b.TF]), "tau": float(cfg[b.TAU]),
            "on": float(cfg[b.ON]), "span": float(cfg[b.SPAN]), "v_min": float(cfg[b.VMIN])}


def _grade(est) -> dict | None:
    """The gyro-aided filter's grade correction (:attr:`ExportDesign.grade`; None without one)."""
    carry = getattr(est, "grade", None)
    if not isinstance(carry, GradeCarry) or carry.window <= 0:
        return None
    return {"window": carry.window, "first_span": carry.first_span, "g": carry.g, "max_sin": MAX_SIN_PITCH,
            "max_gap": carry.max_gap,
            "observer": None if carry.pitch is None else np.array(carry.pitch.cfg, float)}


def _limit(est) -> dict | None:
    """The limit of a low-pass's update as the kernels' ``cfg`` holds it (None without one)."""
    o = int(est._cfg[C_LIM])
    if o <= 0:
        return None
    b = limit_block(o)
    return {k: float(est._cfg[i]) for k, i in zip(LIMIT_KEYS, (b.CLIP, b.GRAV, b.QAY, b.RR, b.TN, b.REF, b.NLP,
                                                               b.TS))}

"""The shared estimator interface: batch ``run()``, streaming ``step()``, ``reset()``.

Every estimator of roadbank is an :class:`Estimator`. A design is a value: the inputs of an
estimator's tables are a frozen dataclass (:class:`DesignInputs` and one subclass per estimator
family, its fields the whole cache key), from which ``_design()`` builds the tables (Python,
once per value: memoised in the process and on disk). The per-sample recursion runs the tables
in one of the compiled kernels of :mod:`roadbank.estimators.kernels`, the same code for
``run()`` and ``step()``, so streaming and batch give identical numbers.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from typing import Any, NamedTuple, cast

import numpy as np
import numpy.typing as npt

from .. import cache
from ..constants import MAX_GAP_S
from ..models.bicycle import augment, disturbance_output, modified_model, original_model
from ..models.roll import roll_state_space
from ..params import VehicleParams
from ..signals import Estimate, Signals, interval_rate, spread_rate
from . import kernels as K
from . import layout as L
from ._buffers import OutputBuffers
from .discretise import foh, foh_grid
from .settle import settled_flags, settling_time
from .synthesis import NoStabilisingSolution, using_reference_solvers

#: Default speed grid of the gain schedules (m/s): v_min .. V_GRID_MAX.
V_GRID_MAX = 100.0
V_GRID_STEP = 0.25
#: the most speeds a schedule's grid may have (``(v_max - v_min) / v_step``; the default 0.25 m/s to 100 m/s: 400): each
#: is a table row and a design, so 0.0001 m/s took gigabytes and minutes before it was refused
MAX_GRID_SPEEDS = 4000
#: speeds (m/s) of the grid at which :attr:`Estimator.settle_time` is read: at most this many, spread from the lowest
#: to :data:`SETTLE_V_MAX` (a car's road speeds; the grid reaches further so that no speed falls off it)
SETTLE_SPEEDS = 8
SETTLE_V_MAX = 40.0

#: designed tables by design key (:meth:`Estimator._design_key`), or the NoStabilisingSolution raised
_DESIGN_CACHE: dict = {}
#: the keyword options of :class:`Estimator` itself, which every estimator takes
ESTIMATOR_OPTIONS = ("v_min", "roll", "max_substep", "max_gap", "max_angle", "v_step", "v_max", "sample_rate")
#: kernel families with the fixed-rate path (``lpv`` rows; ``gated`` steps them through ``lpv_step``)
FIXED_RATE_KERNELS = ("lpv", "gated")
_DISCRETE_CACHE: dict = {}
#: settling times (s) by design key (:attr:`Estimator.settle_time`)
_SETTLE_CACHE: dict = {}
#: entries each in-process memo keeps, the least recently used going first
MEMO_SIZE = 512


def _memo_get(memo: dict, key):
    """``memo[key]`` (None if absent), marked as the most recently used."""
    hit = memo.pop(key, None)
    if hit is not None:
        memo[key] = hit
    return hit


def _memo_put(memo: dict, key, value) -> None:
    """Store ``value``; beyond :data:`MEMO_SIZE` entries the least recently used one goes."""
    memo[key] = value
    while len(memo) > MEMO_SIZE:
        memo.pop(next(iter(memo)))


@dataclasses.dataclass(frozen=True)
class DesignInputs:
    """What an estimator's tables are built from: the car and the speed grid of the gain schedules.

    Every estimator family extends it with its own design settings (weights, gains, time
    constants). Its fields are the whole key of the design caches: two estimators of one class
    with equal design inputs share one design, and nothing else about an estimator (the roll
    model, ``max_angle``, settings that only enter its kernel) changes the tables.

    Parameters
    ----------
    params : VehicleParams
        The estimator's model of the car (SI).
    v_min, v_step, v_max : float
        Start, spacing and end (m/s) of the speed grid (:func:`speed_grid`).
    """

    params: VehicleParams
    v_min: float
    v_step: float
    v_max: float

    @property
    def vgrid(self) -> np.ndarray:
        """The speed grid (m/s): :func:`speed_grid` of ``v_min``, ``v_max``, ``v_step``."""
        return speed_grid(self.v_min, self.v_max, self.v_step)


def frozen_array(a: npt.ArrayLike) -> Any:
    """``a`` (array-like of floats, any shape) as nested tuples of floats: a design-input field
    that compares and hashes by value (units those of ``a``)."""
    a = np.asarray(a, dtype=float)
    return float(a) if a.ndim == 0 else tuple(frozen_array(x) for x in a)


class NoSteeringWarning(RuntimeWarning):
    """An estimator that reads the steering angle ran on a log without one (every sample invalid)."""


class Tables(NamedTuple):
    """What a design builds: ``tab`` (grid points, k) float64, ``nstate`` the number of observer
    states, ``extra`` the estimator's further cfg floats (layout: :mod:`roadbank.estimators.layout`)."""

    tab: np.ndarray
    nstate: int
    extra: np.ndarray


class StepResult(NamedTuple):
    """Output of :meth:`Estimator.step` for one sample (immutable).

    ``w`` (-), ``theta`` and ``phi_b`` (rad), ``valid`` (bool), ``settled`` (bool: valid and at least
    :attr:`Estimator.settle_time` after the last (re)start, as :attr:`roadbank.signals.Estimate.settled` of a run).
    A named tuple rather than a dataclass: building it costs about 0.15 us instead of 0.6 us,
    a third of the whole ``step()`` call.
    """

    w: float
    theta: float
    phi_b: float
    valid: bool
    settled: bool = False


_new_result = tuple.__new__


def speed_grid(v_min: float, v_max: float = V_GRID_MAX, step: float = V_GRID_STEP) -> np.ndarray:
    """Uniform speed grid (m/s) of the gain schedules, from ``v_min`` to at least ``v_max``."""
    n = int(np.ceil((v_max - v_min) / step)) + 1
    return v_min + step * np.arange(n)


class Wrapper:
    """An estimator in front of another, ``inner`` (the online offset learner, the reading of a held log): its name
    and every attribute it does not have are the inner estimator's."""

    inner: "Estimator"

    def __getattr__(self, name):
        if name == "inner":          # not yet set (copy/pickle): no recursion
            raise AttributeError(name)
        return getattr(self.inner, name)

    @property
    def name(self) -> str:
        return self.inner.name


class Estimator:
    """Base class of all bank-angle estimators.

    Parameters
    ----------
    params : VehicleParams
        Design parameters (the estimator's model of the car).
    v_min : float, optional
        Minimum speed (m/s); below it the outputs are held and flagged not valid. Default the
        class's :attr:`default_v_min` (5 m/s; the kinematic estimators' is lower).
    roll : {"static", "dynamic", "none"}, default "static"
        Roll model used to separate the body roll from ``theta`` (docs/estimators.md, Roll separation).
    max_substep : float, default 0.02
        Longest integration substep (s) of the discretisation.
    max_gap : float, default 1.0
        A gap between valid samples longer than this (s) re-initialises the state.
    max_angle : float, default 60 deg (rad)
        Largest plausible |theta| = |bank + roll| (rad). A larger estimate means
        the estimator's model has failed; it is output but flagged not valid.
        60 deg leaves room for the steepest banked test-track lanes (~40 deg).
    sample_rate : float, "auto" or None, default "auto"
        Sample rate (Hz) of the fixed-rate path (``lpv`` family): samples whose
        interval is ``1/sample_rate`` (relative tolerance
        :data:`~roadbank.estimators.layout.DT_REL_TOL`) are processed with the
        exact discrete-time tables of :meth:`discrete_tables`, all others with
        the general trapezoidal path. ``"auto"``: the first positive interval
        between time stamps after a reset sets the rate, by the rule of
        :func:`roadbank.signals.interval_rate` (same rule in :meth:`run` and
        :meth:`step`, so both give identical numbers), kept until the next
        :meth:`reset`; :meth:`set_sample_rate` fixes a rate instead (no more
        detection). ``None``: general path only.
    v_step, v_max : float, default 0.25, 100 m/s
        Spacing and end of the speed grid of the gain schedules; above ``v_max``
        the gains of ``v_max`` are held. A coarse, short grid designs faster
        (``roadbank tune`` searches on one).

    Subclasses set ``name``, ``kernel`` ("lpv", "adaptive", "gated", "dfc" or "riccati") and the
    channel usage, name their design inputs (:attr:`design_type`, a frozen dataclass extending
    :class:`DesignInputs`, filled by :meth:`_design_fields` from the settings they validated
    before calling ``Estimator.__init__``) and build the :class:`Tables` of :attr:`design` in
    ``_design()``. Only the design inputs key the design caches.
    """

    name = "base"
    kernel = "lpv"
    #: which of (delta_f, ay, r) the estimator reads; others may be NaN
    uses = (True, True, True)
    #: the :class:`~roadbank.signals.Signals` channel of the first input slot (``p``, the roll rate, for the
    #: gyro-aided estimators, which read no steering)
    first_input = "delta_f"
    #: names of the observer states reported in Estimate.states
    state_names: tuple[str, ...] = ()
    #: the frozen dataclass of this estimator's design inputs (:attr:`design`)
    design_type: type[DesignInputs] = DesignInputs
    #: ``v_min`` (m/s) when none is given
    default_v_min: float = 5.0
    #: whether a three-state ``lpv`` observer's batch run takes its fixed-rate samples through the three-state loop
    #: (:func:`roadbank.estimators.kernels.entries`: ``lpv3_run``, compiled on its first use); False: the general
    #: ``lpv_run``, the same output to the bit
    batch3_loop: bool = True

    def __init__(self, params: VehicleParams | None = None, *, v_min: float | None = None,
                 roll: str = "static", max_substep: float = 0.02, max_gap: float = MAX_GAP_S,
                 max_angle: float = np.deg2rad(60.0), v_step: float = V_GRID_STEP,
                 v_max: float = V_GRID_MAX, sample_rate: float | str | None = "auto"):
        self.params = params if params is not None else VehicleParams()
        v_min = self.default_v_min if v_min is None else v_min
        if not isinstance(self.params, VehicleParams):
            raise TypeError("params must be a roadbank.VehicleParams")
        for label, v in (("v_min", v_min), ("max_substep", max_substep), ("max_gap", max_gap)):
            if not np.isfinite(v) or v <= 0:
                raise ValueError(f"{self.name}: {label} must be > 0, got {v}")
        if not (np.isfinite(v_max) and v_max > v_min and 0 < v_step <= v_max - v_min):
            raise ValueError(f"{self.name}: need v_min < v_max, both finite (got {v_min}, {v_max} m/s), and "
                             f"0 < v_step <= v_max - v_min (got {v_step} m/s)")
        if (v_max - v_min) / v_step > MAX_GRID_SPEEDS:
            raise ValueError(f"{self.name}: v_step {v_step:g} m/s gives {(v_max - v_min) / v_step:.0f} grid speeds "
                             f"from {v_min:g} to {v_max:g} m/s, more than {MAX_GRID_SPEEDS} (a table of each, and "
                             f"its design); use a v_step of at least {(v_max - v_min) / MAX_GRID_SPEEDS:.3g} m/s")
        self.v_step, self.v_max = float(v_step), float(v_max)
        self.v_min = float(v_min)
        self.roll = roll
        self.max_substep = float(max_substep)
        self.max_gap = float(max_gap)
        if not 0 < max_angle <= np.pi / 2:
            raise ValueError(f"{self.name}: max_angle must be in (0, pi/2] rad, got {max_angle}")
        self.max_angle = float(max_angle)
        self._roll = roll_state_space(self.params, roll)
        self.vgrid = speed_grid(self.v_min, self.v_max, self.v_step)
        self._inputs = self.design_type(params=self.params, v_min=self.v_min, v_step=self.v_step,
                                        v_max=self.v_max, **self._design_fields())
        self._tab_cont, self._nstate, self._extra = self._designed()
        self._run_fn, self._step_fn = K.entries(self.kernel, self.batch3_loop and self._nstate == 3
                                                and self._roll[0].shape[0] in (0, 2))
        self._work = np.zeros(L.work_size(self._nstate))
        self._buffers = OutputBuffers()     # the last run()'s output arrays, reused when dropped
        self.fixed_dt: float | None = None
        self._tab = self._tab_cont
        self._cfg = self._build_cfg(None)
        self._auto_rate = sample_rate == "auto" and self.kernel in FIXED_RATE_KERNELS
        if sample_rate is not None and sample_rate != "auto":
            self.set_sample_rate(cast(float, sample_rate))  # any other string fails there
        self.reset()

    #: rate (Hz) of the data-sheet sensor whose noise set this estimator's weights (set by
    #: :func:`roadbank.estimators.make` for the sensor-weighted PIFs); None: weights given
    sheet_rate: float | None = None
    #: last finite time stamp (s) seen by the automatic rate detector (NaN: none since reset)
    _det_t: float

    def _check_log_rate(self, t) -> None:
        """Warn (once) when a log's rate is far from :attr:`sheet_rate`: the weights then do not
        describe its sensors (:func:`roadbank.vehicle.for_log` designs for the log). The rate is read from an even
        sample of the log's intervals (:func:`roadbank.signals.spread_rate`): every ``run`` pays for it."""
        self._warn_rate(spread_rate(t), 4)

    def _warn_rate(self, rate: float, stacklevel: int) -> None:
        """The warning of :meth:`_check_log_rate` for samples at ``rate`` (Hz), once (``sheet_rate`` set to None)."""
        if self.sheet_rate is not None and np.isfinite(rate) and abs(rate / self.sheet_rate - 1.0) > 0.25:
            warnings.warn(f"{self.name}: its weights are the data sheet's {self.sheet_rate:.0f} Hz sensor's, "
                          f"this log is sampled at {rate:.3g} Hz; roadbank.vehicle.for_log({self.name!r}, "
                          "signals) designs for the log's rate and road noise, as `roadbank estimate` does",
                          RuntimeWarning, stacklevel=stacklevel)
            self.sheet_rate = None

    def _check_steering(self, delta_f) -> None:
        """Warn when this estimator reads the steering angle and the log has none (``delta_f`` all NaN, rad): every
        sample is then held and flagged invalid, which a caller averaging without ``valid`` would read as 0 deg."""
        if self.uses[0] and self.first_input == "delta_f" and len(delta_f) and not np.isfinite(delta_f).any():
            warnings.warn(f"{self.name}: the log has no steering angle (Signals.delta_f all NaN) and this estimator "
                          "reads it: every sample is held and flagged invalid (kinematic-pif, pif-modified and the "
                          "kinematic family need none)", NoSteeringWarning, stacklevel=3)

    @property
    def design(self) -> DesignInputs:
        """This estimator's design inputs (a frozen :attr:`design_type`): what its tables are built from."""
        return self._inputs

    # -- to implement ------------------------------------------------------
    def _design_fields(self) -> dict:
        """The fields of :attr:`design_type` beyond those of :class:`DesignInputs`, from the
        settings the subclass validated before ``Estimator.__init__`` (none here)."""
        return {}

    def _design(self):  # pragma: no cover - abstract
        """The :class:`Tables` ``(tab, nstate, extra)`` of :attr:`design` (a function of it alone)."""
        raise NotImplementedError

    def _initial_memory(self, mem: np.ndarray) -> None:
        """Hook to set estimator-specific initial memory (e.g. Riccati P0)."""

    def _designed(self):
        """The tables of :attr:`design` (:meth:`_tables_of`); a subclass may choose another design
        value first (a PIF halves a default ``th`` that has no stabilising solution)."""
        return self._tables_of(self._inputs)

    def _tables_of(self, inputs: DesignInputs):
        """The :class:`Tables` of the design value ``inputs``, which becomes :attr:`design`.

        ``_design()`` memoised on the estimator class and the design inputs: building the same
        estimator again costs nothing. Also kept on disk (:mod:`roadbank.cache`), so a new
        process reads the tables instead of solving one ARE per grid speed again. A design
        without a stabilising solution is remembered too and raises again."""
        self._inputs = inputs
        return self._cached_design()

    def _table_inputs(self) -> DesignInputs:
        """The design inputs that ``_design()`` reads: :attr:`design`. A family whose tables read less of the car
        narrows them, so that designs for cars that differ only elsewhere share one memo and cache entry."""
        return self._inputs

    def _cached_design(self):
        """``_design()`` of :attr:`design` through the memo and the on-disk cache (:meth:`_tables_of`), both keyed
        on :meth:`_table_inputs`."""
        key = (type(self), cache.canonical(self._table_inputs()))
        hit = _memo_get(_DESIGN_CACHE, key)
        if hit is None:
            try:
                hit = self._disk_design()
            except NoStabilisingSolution as exc:    # remembered too: a retry with a smaller th follows
                hit = exc
            _memo_put(_DESIGN_CACHE, key, hit)
        if isinstance(hit, NoStabilisingSolution):
            raise NoStabilisingSolution(str(hit))
        return hit

    def _disk_design(self):
        """``_design()`` through the on-disk cache, keyed on the class and the exact design inputs."""
        key = self._disk_key()
        if key is None:
            return Tables(*self._design())
        z = cache.load("design", key)
        if z is not None and "unsolvable" in z:
            raise NoStabilisingSolution(str(z["unsolvable"]))
        if z is not None and {"tab", "nstate", "extra"} <= z.keys():
            return Tables(z["tab"], int(z["nstate"]), z["extra"])
        try:
            tab, nstate, extra = hit = Tables(*self._design())
        except NoStabilisingSolution as exc:
            # as expensive as a solution (up to one ARE per grid point), and as deterministic
            cache.store("design", key, {"unsolvable": np.array(str(exc))})
            raise
        if (isinstance(tab, np.ndarray) and tab.dtype == np.float64 and isinstance(extra, np.ndarray)
                and extra.dtype == np.float64 and isinstance(nstate, (int, np.integer))):
            cache.store("design", key, {"tab": tab, "nstate": np.int64(nstate), "extra": extra})
        return hit

    def _disk_key(self) -> str | None:
        """Key of this estimator's design in the on-disk cache (:mod:`roadbank.cache`): the class
        and the exact values of the design inputs its tables read (:meth:`_table_inputs`); None for a
        class whose source has no identity (then nothing is cached on disk)."""
        cls = type(self)
        stamp = cache.code_stamp(cls)       # a subclass outside roadbank: its file's identity
        if stamp is None:
            return None
        return cache.canonical((f"{cls.__module__}.{cls.__qualname__}", stamp, self._table_inputs()))

    def _design_key(self) -> tuple:
        """Key of this estimator's design in the process: the class and the exact design inputs."""
        return (type(self), cache.canonical(self._inputs))

    # -- configuration -----------------------------------------------------
    def _build_cfg(self, roll_discrete) -> np.ndarray:
        """``cfg`` (layout: :mod:`roadbank.estimators.layout`); ``roll_discrete`` is the roll
        model's fixed-rate ``(Phi, Gam0, Gam1)`` or None."""
        F, G, H, D = self._roll
        nr = F.shape[0]
        J = -np.linalg.solve(F, G).ravel() if nr else np.zeros(0)
        if roll_discrete is None:
            roll_discrete = (np.zeros((nr, nr)), np.zeros(nr), np.zeros(nr))
        head = np.zeros(L.NHEAD)
        head[L.C_N] = self._nstate
        head[L.C_V0] = self.vgrid[0]
        head[L.C_DV] = self.vgrid[1] - self.vgrid[0]
        head[L.C_NG] = len(self.vgrid)
        head[L.C_VMIN] = self.v_min
        head[L.C_SUB] = self.max_substep
        head[L.C_GAP] = self.max_gap
        head[L.C_WMAX] = np.sin(self.max_angle)
        head[L.C_G] = self.params.g
        head[L.C_NR] = nr
        head[L.C_USE:L.C_USE + 3] = [float(u) for u in self.uses]
        head[L.C_DTFIX] = self.fixed_dt or 0.0
        head[L.C_DTOL] = L.DT_REL_TOL
        head[L.C_OFAM] = L.roll_block(nr).end
        if self.limited:        # the limit's constants end the design's extra; its ay in the steering's slot
            head[L.C_LIM] = L.roll_block(nr).end + len(self._extra) - L.NLIM
            head[L.C_USE] = 1.0
        self._fill_cfg_head(head)
        roll = np.concatenate([F.ravel(), G.ravel(), H.ravel(), D.ravel(), J]
                              + [np.ravel(m) for m in roll_discrete])
        return np.ascontiguousarray(np.concatenate([head, roll, np.asarray(self._extra, float).ravel()]))

    # -- fixed-rate path -----------------------------------------------------
    def discrete_tables(self, dt: float) -> dict[str, np.ndarray]:
        """Exact discrete-time observer per grid speed for the sample interval ``dt`` (s).

        What the fixed-rate path runs (see :mod:`roadbank.estimators.kernels`),
        as plain arrays for export (e.g. to an ECU). Per sample, with the
        matrices interpolated linearly in ``vx`` between grid speeds::

            xi  = Phi xi + Gam0 eta_prev + Gam1 eta,   w = H xi + D eta
            z   = Phi_r z + Gam0_r ay_prev + Gam1_r ay, phi = H_r z + D_r ay

        and at a (re)start ``xi = J eta``, ``z = J_r ay``;
        ``eta = [delta_f, ay, r]`` (rad, m/s^2, rad/s) with unused channels set to 0.

        Returns
        -------
        dict
            ``vgrid`` (g,) m/s; ``Phi`` (g, n, n); ``Gam0``, ``Gam1``, ``J`` (g, n, 3);
            ``H`` (g, n); ``D`` (g, 3); ``Phi_r`` (nr, nr); ``Gam0_r``, ``Gam1_r``,
            ``H_r``, ``J_r`` (nr,); ``D_r`` (); ``uses`` (3,) 0/1 flags; ``dt`` (s).
            The scheduled linear observers only (:data:`FIXED_RATE_KERNELS`).
        """
        if self.kernel not in FIXED_RATE_KERNELS:
            raise ValueError(f"{self.name}: fixed-rate tables exist for the scheduled linear observers only "
                             f"(this estimator runs the {self.kernel!r} kernel)")
        dt = float(dt)
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"{self.name}: sample interval must be > 0 s, got {dt}")
        key = (self._design_key(), self.roll, dt)      # the roll model's tables are in there too
        hit = _memo_get(_DISCRETE_CACHE, key)
        if hit is None:
            hit = self._discretise(dt)
            _memo_put(_DISCRETE_CACHE, key, hit)
        return {k: v.copy() for k, v in hit.items()}

    def _discretise(self, dt: float) -> dict[str, np.ndarray]:
        n = self._nstate
        row = L.lpv_row(n)
        tab = self._tab_cont
        g = tab.shape[0]
        F = tab[:, row.F:row.G].reshape(g, n, n)
        G = tab[:, row.G:row.H].reshape(g, n, L.NETA)
        out = {"vgrid": self.vgrid.copy(), "dt": np.float64(dt),
               "H": tab[:, row.H:row.D].copy(), "D": tab[:, row.D:row.J].copy(),
               "J": tab[:, row.J:row.cont].reshape(g, n, L.NETA).copy(),
               "uses": np.array([float(u) for u in self.uses])}
        if using_reference_solvers():      # the per-point loop that the one batched call replaced
            disc = [foh(F[k], G[k], dt) for k in range(g)]
            out["Phi"] = np.array([d[0] for d in disc]).reshape(g, n, n)
            out["Gam0"] = np.array([d[1] for d in disc]).reshape(g, n, L.NETA)
            out["Gam1"] = np.array([d[2] for d in disc]).reshape(g, n, L.NETA)
        else:
            out["Phi"], out["Gam0"], out["Gam1"] = foh_grid(F, G, dt)
        Fr, Gr, Hr, Dr = self._roll
        Phi_r, G0r, G1r = foh(Fr, Gr, dt)
        out.update(Phi_r=Phi_r, Gam0_r=G0r.ravel(), Gam1_r=G1r.ravel(), H_r=np.ravel(Hr).copy(),
                   D_r=np.float64(np.ravel(Dr)[0]) if np.size(Dr) else np.float64(0.0),
                   J_r=(-np.linalg.solve(Fr, Gr).ravel() if Fr.shape[0] else np.zeros(0)))
        return out

    def set_sample_rate(self, rate: float | None) -> None:
        """Use the fixed-rate path for samples ``1/rate`` seconds apart (Hz); ``None`` switches it off.

        Builds (or takes from the cache) :meth:`discrete_tables`. Does not
        reset the state. Ends the automatic detection of ``sample_rate="auto"``: the rate set here stays
        over resets. Only the :data:`FIXED_RATE_KERNELS` have a fixed-rate path; for the
        others this records nothing.
        """
        self._auto_rate = self._detect = False
        self._use_rate(rate)

    def _use_rate(self, rate: float | None) -> None:
        """:meth:`set_sample_rate` without ending the detection (the detector's own call); a rate already in use
        costs nothing (a reset's detection finds the last log's rate again)."""
        if rate is not None and self.fixed_dt is not None and rate > 0 and self.fixed_dt == 1.0 / float(rate):
            return
        if rate is None or self.kernel not in FIXED_RATE_KERNELS:
            self.fixed_dt = None
            self._tab = self._tab_cont
            self._cfg = self._build_cfg(None)
            return
        if not (np.isfinite(rate) and rate > 0):
            raise ValueError(f"{self.name}: sample_rate must be > 0 Hz, got {rate}")
        dt = 1.0 / float(rate)
        d = self.discrete_tables(dt)
        g, n = d["Phi"].shape[0], self._nstate
        self.fixed_dt = dt
        parts = [self._tab_cont, d["Phi"].reshape(g, n * n), d["Gam0"].reshape(g, -1), d["Gam1"].reshape(g, -1)]
        if n == 3:
            parts.append(batch3_rows(d))
        self._tab = np.ascontiguousarray(np.hstack(parts))
        self._cfg = self._build_cfg((d["Phi_r"], d["Gam0_r"], d["Gam1_r"]))

    def _observe_time(self, t: float) -> None:
        """Automatic rate (``sample_rate="auto"``), one sample: the first positive interval
        between finite time stamps sets the rate (:func:`roadbank.signals.interval_rate` of it)."""
        if not math.isfinite(t):
            return
        if t > self._det_t:                     # False while _det_t is NaN
            rate = interval_rate(t - self._det_t)
            self._warn_rate(rate, 4)            # step()'s samples (run() has warned already, from the whole log)
            self._use_rate(rate)
            self._detect = False
        self._det_t = t

    def _first_interval(self, t: np.ndarray) -> int:
        """Index of the sample at which :meth:`_observe_time` would set the rate (``len(t)``:
        none); updates the detector to the end of ``t`` when there is none.

        ``t`` is a :class:`~roadbank.signals.Signals`' time base, finite and strictly increasing, so the first later
        time is among its first two samples: only they are read (a scan of the whole log had cost 3 of the PIF
        batch run's 21 ns/sample)."""
        head = np.asarray(t[:2], dtype=np.float64)
        tf = np.concatenate([[self._det_t], head])
        with np.errstate(invalid="ignore"):
            hit = np.flatnonzero(np.diff(tf) > 0)
        if hit.size:
            self._det_t = float(tf[hit[0]])          # the detector just before that sample
            return int(hit[0])
        if head.size:
            self._det_t = float(tf[-1])
        return len(t)

    def _fill_cfg_head(self, head: np.ndarray) -> None:
        """Hook for estimator scalars stored in the cfg head (e.g. DFC a_ref)."""

    #: whether a kinematic low-pass's update is limited (:class:`~roadbank.estimators.lowpass.KinematicLowPass`):
    #: then the design's extra ends with :meth:`limit_constants` and the kernel reads the limited ``ay`` in
    #: the steering's slot (:func:`roadbank.estimators.kernels.sample.limited_ay`)
    limited = False

    def limit_constants(self) -> list[float]:
        """The :class:`~roadbank.estimators.layout.LimitBlock` ``[clip, g, Q_ay, R, noise_tau, noise_ref, nlp,
        limit_tau]`` of a limited estimator (-, m/s^2, (m/s^2)^2 s, (rad/s)^2 s, s, (m/s^2)^2, -, s); empty
        otherwise."""
        return []

    # -- public API ----------------------------------------------------------
    def reset(self) -> None:
        """Forget all history: the next sample initialises the estimator."""
        self._mem = np.zeros(L.mem_size(self._nstate, self._roll[0].shape[0]))
        self._initial_memory(self._mem)
        self._det_t = math.nan     # automatic rate detector (sample_rate="auto"): last finite time
        self._detect = self._auto_rate      # whether the next positive interval sets the rate
        self._settle_last = (math.nan, math.nan)   # settle.settled_flags' carry: last valid time, last restart

    def _carried(self) -> tuple:
        """What one :meth:`run` hands the next (``reset=False``): the memory (a copy), the rate
        detector, the rate's tables and the settling flags' carry; :meth:`_carry_on` puts it back (an offline
        estimator's pass over its lookahead leaves no trace)."""
        return (self._mem.copy(), self._det_t, self._detect, self.fixed_dt, self._tab, self._cfg, self._settle_last)

    def _carry_on(self, carried: tuple) -> None:
        """Back to what :meth:`_carried` returned."""
        self._mem[:] = carried[0]
        self._det_t, self._detect, self.fixed_dt, self._tab, self._cfg, self._settle_last = carried[1:]

    def step(self, t: float, vx: float, ay: float, r: float, delta_f: float = float("nan"),
             p: float | None = None, ax: float | None = None, q: float | None = None) -> StepResult:
        """Process one sample: time (s), vx (m/s), ay (m/s^2), r (rad/s), delta_f (rad); the roll rate ``p``
        (rad/s), ``ax`` (m/s^2) and pitch rate ``q`` (rad/s), which the roll-rate estimators
        (:data:`roadbank.estimators.GYRO`) read, are ignored here, so that one loop that gives every channel it has
        serves whichever estimator :func:`roadbank.vehicle.for_log` returns.

        Returns the estimate after this sample. An unusable sample (NaN/inf,
        ``vx < v_min``, beyond a car's limits (:data:`roadbank.constants.AY_MAX`, ``YAW_RATE_MAX``, ``SPEED_MAX``),
        time not after the last valid sample) leaves the state
        unchanged and returns the held outputs with ``valid=False``. An output
        beyond ``max_angle`` (the model has failed, e.g. a saturated front tyre in
        an original-model observer; ``|w| > 1`` has no angle and theta is clipped
        to +-90 deg) is returned with ``valid=False``.
        """
        # One compiled call returns the outputs (no numpy scalar reads afterwards);
        # float() keeps numpy scalars / ints from triggering a new compilation.
        try:
            t, vx, delta_f, ay, r = float(t), float(vx), float(delta_f), float(ay), float(r)
        except TypeError as exc:                        # an array, None: not one sample (the state untouched)
            raise not_one_sample(self.name, exc) from None
        if self._detect:
            self._observe_time(t)
        w, theta, phi_b, valid = self._step_fn(self._mem, self._cfg, self._tab, self._work, t, vx, delta_f, ay, r)
        if not valid:                   # settle.settled_flags of one sample, inline (a call costs a fifth of the step)
            return _new_result(StepResult, (w, theta, phi_b, False, False))
        last, since = self._settle_last
        if not t - last <= self.max_gap:        # NaN last: the first sample, a restart
            since = t
        self._settle_last = (t, since)
        settle = self._settle_s if self._settle_s is not None else self.settle_time
        return _new_result(StepResult, (w, theta, phi_b, True, t >= since + settle))

    def run(self, signals: Signals, *, reset: bool = True, lookahead: Signals | None = None) -> Estimate:
        """Estimate over a whole log.

        Parameters
        ----------
        signals : Signals
            The log (SI, ISO 8855).
        reset : bool, default True
            Start from scratch. ``reset=False`` continues from the current state,
            so a log processed in consecutive chunks equals one run.
        lookahead : Signals, optional
            The samples that follow ``signals`` (a streamed log's next chunk). A causal
            estimator ignores them; an offline one (:data:`roadbank.estimators.OFFLINE`) uses
            them as later samples without advancing its state.

        With ``sample_rate="auto"`` the first positive interval sets the rate,
        exactly as in :meth:`step`.

        Returns
        -------
        Estimate
            ``t`` is ``signals.t`` itself (read-only, not copied); the other arrays are
            the caller's. Their memory may be that of an earlier result of this
            estimator whose arrays (and views of them) were all dropped; arrays still
            referenced are never written again.
        """
        if not isinstance(signals, Signals):
            raise TypeError("run() expects a roadbank.Signals")
        if self.sheet_rate is not None:
            self._check_log_rate(signals.t)
        if reset:
            self._check_steering(signals.delta_f)
            self.reset()
        n = len(signals)
        w, theta, phib, phi, valid, xs = self._outputs(n)
        k = self._first_interval(signals.t) if self._detect else n
        first = getattr(signals, self.first_input)
        a = 0
        while a < n:
            if a == k:
                self._observe_time(float(signals.t[k]))   # sets the rate (and the detector)
            b = self._segment_end(signals, a, k if a < k else n)
            self._run_fn(self._mem, self._cfg, self._tab, self._work, signals.t[a:b], signals.vx[a:b],
                         first[a:b], signals.ay[a:b], signals.r[a:b], w[a:b], theta[a:b],
                         phib[a:b], phi[a:b], valid[a:b], xs[a:b])
            self._after_segment(signals, a, b)
            a = b
        states = {name: xs[:, i] for i, name in enumerate(self.state_names)}
        states["phi"] = phi
        return Estimate(self.name, signals.t, w, theta, phib, valid, states, self._settled(signals.t, valid))

    def _segment_end(self, signals: Signals, a: int, end: int) -> int:
        """Where the compiled run over ``signals`` that starts at sample ``a`` stops (at most ``end``): :meth:`run`
        calls the kernel segment by segment and :meth:`_after_segment` after each. Every sample at once here; an
        estimator that acts between samples (:class:`~roadbank.estimators.gyro.KinematicGyro`'s start) cuts
        shorter."""
        return end

    def _after_segment(self, signals: Signals, a: int, b: int) -> None:
        """What the estimator does to its memory after the samples ``a:b`` of ``signals`` in :meth:`run` (and a
        :meth:`step` that calls it with its one sample): nothing here."""

    #: :attr:`settle_time` once read (None: not yet)
    _settle_s: float | None = None

    @property
    def settle_time(self) -> float:
        """Settling time (s) of the estimate after a (re)start (:mod:`roadbank.estimators.settle`): the longest
        :func:`~roadbank.estimators.settle.settling_time` of the observer's output over its speed schedule; 0 for
        an estimator without states."""
        if self._settle_s is None:
            key = self._design_key()
            hit = _memo_get(_SETTLE_CACHE, key)
            self._settle_s = self._settling_time() if hit is None else hit
            _memo_put(_SETTLE_CACHE, key, self._settle_s)
        return self._settle_s

    def _settling_time(self) -> float:
        """:attr:`settle_time` of the ``lpv`` table's continuous observer, at up to :data:`SETTLE_SPEEDS` speeds of
        the grid spread from the lowest to :data:`SETTLE_V_MAX` (a family with another table overrides it)."""
        n = self._nstate
        row = L.lpv_row(n)
        top = max(int(np.searchsorted(self.vgrid, SETTLE_V_MAX, side="right")), 1)
        picks = np.unique(np.linspace(0, top - 1, min(SETTLE_SPEEDS, top)).round().astype(int))
        out = 0.0
        for k in picks:
            r = self._tab_cont[k]
            out = max(out, settling_time(r[row.F:row.G].reshape(n, n), r[row.G:row.H].reshape(n, L.NETA),
                                         r[row.H:row.D], r[row.D:row.J]))
        return out

    def _settled(self, t, valid) -> np.ndarray:
        """:func:`~roadbank.estimators.settle.settled_flags` of a run's outputs, carried over chunks (``run(...,
        reset=False)``) as the estimator's state is."""
        flags, self._settle_last = settled_flags(t, valid, self.settle_time, self.max_gap, self._settle_last)
        return flags

    def _outputs(self, n: int):
        """Output arrays of :meth:`run` for ``n`` samples: ``w, theta, phi_b, phi, valid, xs``.

        Those of the last :meth:`run` once nothing else refers to them (every array of that
        run's :class:`~roadbank.signals.Estimate` dropped, views included), else new ones
        (:class:`~roadbank.estimators._buffers.OutputBuffers`).
        """
        return self._buffers.take(n, max(self._nstate, 2))

    def transition_matrix(self, vx: float, dt: float) -> np.ndarray:
        """Per-sample map of the observer state with zero inputs, measured on the compiled kernel.

        Runs one step of ``dt`` seconds at speed ``vx`` from each unit state and
        returns the columns; its eigenvalues are the discrete error dynamics.
        This is the fixed-rate map when ``dt`` is the estimator's fixed interval,
        else the general (trapezoidal) one. Resets the estimator.
        """
        n = self._nstate
        phi = np.zeros((n, n))
        for i in range(n):
            self.reset()
            self._step_fn(self._mem, self._cfg, self._tab, self._work, 0.0, float(vx), 0.0, 0.0, 0.0)
            self._mem[L.M_X:L.M_X + n] = np.eye(n)[i]
            self._step_fn(self._mem, self._cfg, self._tab, self._work, float(dt), float(vx),
                          0.0, 0.0, 0.0)
            phi[:, i] = self._mem[L.M_X:L.M_X + n]
        self.reset()
        return phi

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r} v_min={self.v_min} roll={self.roll!r}>"


def not_one_sample(name: str, exc: Exception) -> TypeError:
    """The error of a ``step()`` given something else than one number per channel (an array, None)."""
    return TypeError(f"{name}.step() takes one sample, a number per channel: t (s), vx (m/s), ay (m/s^2), r (rad/s), "
                     f"delta_f (rad) ({exc}); run(Signals(...)) takes arrays")


def sample_floats(name: str, *values) -> tuple[float, ...]:
    """``values`` of one ``step()`` sample as floats, or :func:`not_one_sample`'s error."""
    try:
        return tuple(float(v) for v in values)
    except TypeError as exc:
        raise not_one_sample(name, exc) from None


def batch3_rows(d: dict) -> np.ndarray:
    """The batch loop's block (:func:`roadbank.estimators.layout.batch3_block`) of every grid row,
    from :meth:`Estimator.discrete_tables` ``d`` of a three-state observer: (g, 88)."""
    blk = L.batch3_block()
    o = blk.M                                   # where the block starts in the row
    g = d["Phi"].shape[0]
    M = np.zeros((g, 2 * L.NETA + 3, 4))        # the loop's columns, four lanes each (three states, 0)
    for q in range(L.NETA):
        M[:, 2 * q, :3] = d["Gam0"][:, :, q]
        M[:, 2 * q + 1, :3] = d["Gam1"][:, :, q]
    for j in range(3):
        M[:, 2 * L.NETA + j, :3] = d["Phi"][:, :, j]
    out = np.zeros((g, blk.end - o))
    out[:, blk.M - o:blk.W - o] = M.reshape(g, -1)
    out[:, blk.W - o:blk.W - o + 3] = d["D"]    # W: D, 0, H, 0
    out[:, blk.W - o + 4:blk.W - o + 7] = d["H"]
    B = out[:, :blk.dM - o]                     # M and W; then dM and dW
    out[:-1, blk.dM - o:] = B[1:] - B[:-1]      # the same subtraction as the kernels' tab[i + 1] - tab[i]
    return out


def equilibrium_map(F: np.ndarray, G: np.ndarray) -> np.ndarray:
    """Equilibrium ``xi = -F^{-1} G eta`` of ``xi' = F xi + G eta`` (F nonsingular)."""
    if F.shape[0] == 0:
        return np.zeros((0, G.shape[1]))
    return -np.linalg.solve(F, G)


class ScheduledObserver(Estimator):
    """A linear observer whose matrices are scheduled on speed (``lpv`` kernel).

    Subclasses implement :meth:`observer(vx)` returning ``(F, G, H, D)`` of
    ``xi' = F xi + G eta``, ``w = H xi + D eta`` with ``eta = [delta_f, ay, r]``.
    """

    kernel = "lpv"

    def observer(self, vx: float):  # pragma: no cover - abstract
        """``(F, G, H, D)`` of the observer at the speed ``vx`` (m/s): ``F`` (1/s), inputs ``[delta_f, ay, r]``."""
        raise NotImplementedError

    def _grid_design(self):
        """The table of :meth:`_design` computed for the whole grid at once, or None (then the
        grid speeds are designed one by one). The Riccati-designed observers provide it
        (:mod:`roadbank.estimators.grid_design`: the same table, in milliseconds)."""
        return None

    def _design(self):
        fast = self._grid_design()
        if fast is not None:
            return fast
        return scheduled_tables(self.observer, self.design.vgrid)

    def error_dynamics(self, vx: float) -> np.ndarray:
        """Continuous-time matrix ``F(vx)`` (1/s) governing the estimation error at the speed ``vx`` (m/s)."""
        return self.observer(vx)[0]


def scheduled_tables(observer, vgrid: np.ndarray) -> Tables:
    """The ``lpv`` :class:`Tables` of a speed-scheduled observer: rows ``[F, G, H, D, J]`` of
    ``observer(vx) -> (F, G, H, D)`` at each speed of ``vgrid`` (m/s), ``J`` its equilibrium map."""
    rows = []
    n = None
    for v in vgrid:
        F, G, H, D = observer(float(v))
        n = F.shape[0]
        J = equilibrium_map(F, G)
        rows.append(np.concatenate([F.ravel(), G.ravel(), np.ravel(H), np.ravel(D), J.ravel()]))
    return Tables(np.ascontiguousarray(np.array(rows)), n, np.zeros(0))  # type: ignore[arg-type]  # vgrid is not empty


def embed_inputs(cols: dict[int, npt.ArrayLike], n_rows: int) -> np.ndarray:
    """Matrix with columns placed at eta positions {0: delta_f, 1: ay, 2: r}."""
    M = np.zeros((n_rows, L.NETA))
    for j, c in cols.items():
        M[:, j] = np.ravel(c)
    return M


def augmented_design_model(params, vx: float, model: str):
    """``(A, B, C, Dy, Lw, Ew)`` of the augmented model with inputs embedded in ``eta = [delta_f, ay, r]``.

    The innovation is ``Dy eta - C x`` (measured outputs minus model outputs). ``vx`` in m/s.
    Memoised (the estimators of one car design on the same speeds; each caller gets its own
    copies of the arrays).
    """
    return tuple(a.copy() for a in _augmented_design_model(params, float(vx), model))


@functools.lru_cache(maxsize=4096)
def _augmented_design_model(params, vx: float, model: str):
    if model == "modified":
        A, Bm, Ew, C, _ = augment(modified_model(params, vx))
        B = embed_inputs({1: Bm}, 3)
        Dy = embed_inputs({2: [1.0]}, 1)                      # y = r
    elif model == "original":
        A, Bo, Ew, C, D = augment(original_model(params, vx))
        B = embed_inputs({0: Bo}, 3)
        Dy = embed_inputs({0: -D[:, 0], 1: [1.0, 0.0], 2: [0.0, 1.0]}, 2)  # y = [ay, r] - D delta
    else:
        raise ValueError(f"model must be 'modified' or 'original', got {model!r}")
    return A, B, C, Dy, disturbance_output(A.shape[0]), Ew

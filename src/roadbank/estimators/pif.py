r"""PIF — the proportional-integral H-infinity filter (paper eq 33-44, Table 4).

The filter runs on a model augmented with ``w = sin(theta)`` as a state
(docs/models.md, augmented model):

.. math::
    \dot{\hat x}_w = A_w \hat x_w + B_w u + P C_w^T R^{-1}(y - C_w \hat x_w - D u),\qquad
    \hat w = L_w \hat x_w

    \dot P = A_w P + P A_w^T + E_w Q E_w^T - P (C_w^T R^{-1} C_w - \theta L_w^T S L_w) P,
    \quad P(0) = P_0

* ``model="modified"`` (``pif-modified``, the paper's method): states
  ``[vy, r, w]``, input ``u = ay``, output ``y = r`` — no front cornering stiffness.
* ``model="original"`` (``pif-original``, paper Fig 4e/7d): the original
  bicycle model, input ``delta_f``, outputs ``[ay, r]``.

Variants: ``variant="steady"`` (default) uses the stabilising solution of the
algebraic Riccati equation (eq 44) per speed as a gain schedule — what an ECU
would run; ``variant="riccati"`` integrates the Riccati ODE (eq 43) from
``P0``. Both start at the observer equilibrium for the first inputs.

Tunings (``tuning=``; explicit ``Q``, ``R``, ``S``, ``th``, ``P0`` override the preset):

* ``"paper"``: Table 4 read in SI, ``Q = 0.1, R = 0.0035, S = 1, th = 1,
  P0 = diag(0, 0, 0.5)`` — what ``roadbank reproduce`` checks the paper's claims with,
  and the default of ``pif-original``.
* ``"paper-deg"``: Table 4 with R read in (deg/s)^2 (:data:`R_TABLE4_DEG_UNITS`).
* ``"default"`` (the default of ``pif-modified``): ``R`` is the noise density of the
  yaw-rate sensor, (noise variance + resolution^2/12) / sample rate
  (:func:`yaw_rate_noise_density`, paper ESP sensor: 0.1 deg/s noise, 0.3 deg/s
  resolution, 100 Hz), and ``Q``, ``th`` come from ``roadbank tune`` on the default
  car (:data:`DEFAULT_TUNING`, docs/estimators.md). ``Q`` is then the spectral
  density of the bank rate (1/s), ``R`` of the yaw-rate noise ((rad/s)^2 s). The
  tuning also chose the dynamic roll model for the roll separation (``roll="dynamic"``
  unless given). Where the default ``th`` has no stabilising solution for a car, it is
  halved until it has (explicit ``th`` values still raise).

For the original model the second output (ay) needs a weight the paper does not
give: ``R_ay = 0.307`` = R scaled by the squared ratio of the sensors'
resolutions ((0.005 g)/(0.3 deg/s))^2 (interpretation).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..params import ESP_AY_NOISE, ESP_AY_RESOLUTION, ESP_R_NOISE, ESP_R_RESOLUTION, ESP_RATE
from . import grid_design, layout
from .base import (DesignInputs, ScheduledObserver, _augmented_design_model, augmented_design_model,
                   equilibrium_map, frozen_array)
from .synthesis import NoStabilisingSolution, game_are

#: paper Table 4
TABLE4: dict[str, Any] = dict(Q=0.1, R=0.0035, S=1.0, th=1.0, P0=(0.0, 0.0, 0.5))
#: Table 4's R read in the ESP sensor's own unit, (deg/s)^2, converted to (rad/s)^2: an
#: alternative interpretation of the paper's units (see docs/estimators.md); not the default.
R_TABLE4_DEG_UNITS = 0.0035 * (np.pi / 180.0) ** 2
#: weight of the lateral-acceleration output of the original-model PIF (see module doc)
R_AY_ORIGINAL = 0.0035 * (ESP_AY_RESOLUTION / np.float64(ESP_R_RESOLUTION)) ** 2


def yaw_rate_noise_density(noise_std: float, resolution: float, rate: float) -> float:
    """Noise density ``R`` ((rad/s)^2 s) of a sampled yaw-rate sensor for the continuous filter.

    ``(noise_std^2 + resolution^2 / 12) / rate``: white noise of standard deviation
    ``noise_std`` (rad/s) plus uniform quantisation error of step ``resolution`` (rad/s),
    sampled at ``rate`` (Hz); a sampled white sequence of variance ``v`` acts on a
    continuous filter like white noise of spectral density ``v / rate``. The same formula
    in m/s^2 gives the density ``Q_ay`` ((m/s^2)^2 s) of the lateral accelerometer.
    """
    if not (noise_std >= 0 and resolution >= 0 and rate > 0) or noise_std + resolution == 0:
        raise ValueError("yaw_rate_noise_density: need noise_std, resolution >= 0 (not both 0) "
                         f"and rate > 0, got {noise_std}, {resolution}, {rate}")
    return (noise_std**2 + resolution**2 / 12.0) / rate


#: estimators whose default ``R`` is the yaw-rate sensor's noise density (set by the caller
#: that knows the sensor: :meth:`roadbank.vehicle.Vehicle.make`, the real-data validation)
SENSOR_R_ESTIMATORS = ("pif-modified", "pif-rate", "pif-adaptive", "pif-rate-adaptive", "pif-gated", "pif-smoother",
                       "kinematic-pif")


def with_sensor_noise(name: str, options: dict, R: float, Q_ay: float | None = None) -> dict:
    """``make(name, ...)`` options with the sensors' noise densities: ``R`` ((rad/s)^2 s, yaw
    rate) and ``Q_ay`` ((m/s^2)^2 s, lateral acceleration; None: the estimator's default)
    when ``name`` is a default-tuned PIF (:data:`SENSOR_R_ESTIMATORS`) given no ``R``;
    otherwise ``options`` unchanged (an explicit ``R`` means the caller's own weights, whose
    ``Q_ay`` is then as given or the tuning's). A ``Q_ay`` in ``options`` is kept.

    A ``th`` given with them (a ``[tuning]`` table from ``roadbank tune``, which writes ``Q`` and
    ``th`` relative to the sensor and no ``R``) adapts like the default's: at a log rate whose
    ``R`` leaves no stabilising solution it is halved until there is one (``adapt_th``).
    """
    if name not in SENSOR_R_ESTIMATORS or options.get("tuning", "default") != "default" or "R" in options:
        return options
    sensor = {"R": R} if Q_ay is None else {"R": R, "Q_ay": Q_ay}
    if "th" in options:
        sensor["adapt_th"] = True
    return {**sensor, **options}


#: R of the paper's ESP yaw-rate sensor (0.1 deg/s noise, 0.3 deg/s resolution, 100 Hz; a numpy
#: float, as the tunings made from it)
R_ESP = yaw_rate_noise_density(np.float64(ESP_R_NOISE), np.float64(ESP_R_RESOLUTION), ESP_RATE)
#: Q_ay of the paper's ESP lateral accelerometer (0.03 m/s^2 noise, 0.005 g resolution, 100 Hz):
#: the noise density of the filter's ay input ((m/s^2)^2 s), same formula as R
Q_AY_ESP = yaw_rate_noise_density(ESP_AY_NOISE, ESP_AY_RESOLUTION, ESP_RATE)

#: Q (1/s), th (-) and the roll model found by ``roadbank tune`` (seed 0, budget 240) for the
#: default car and sensors with R = R_ESP, S = 1 (docs/estimators.md: the run and its scores).
#: In Table 4's scale (R = 0.0035) this is Q = 12.8, th = 2.64. The default uses a quarter of
#: the tuned th: any th in [0, th_tuned] scores within 0.1 % on the training set, and the tuned
#: value sits at the edge of solvability (no stabilising solution near 98 m/s for the shipped
#: compact, sedan and van).
DEFAULT_TUNING: dict[str, Any] = dict(Q=1.9512492264850162e-04, th=0.25 * 1.7309294384267123e05, roll="dynamic")


def _scaled_p0(R: float) -> tuple:
    """Table 4's P0 scaled like P (P scales with R when Q/R and th R are kept)."""
    k = R / TABLE4["R"]
    return tuple(k * p for p in TABLE4["P0"])


def _sensor_tuning(tuned: dict) -> dict:
    """The ``"default"`` named tuning from ``tuned`` weights (``Q``, ``th``, ``roll``, found with
    R = R_ESP, S = 1): ``R`` of the ESP yaw-rate sensor, ``Q_ay`` of its accelerometer and
    Table 4's ``P0`` scaled to ``R``."""
    return dict(Q=tuned["Q"], R=R_ESP, S=1.0, th=tuned["th"], P0=_scaled_p0(R_ESP), roll=tuned["roll"],
                Q_ay=Q_AY_ESP)


#: named tunings (``tuning=`` of :class:`PIF`)
TUNINGS = {
    "paper": dict(TABLE4),
    "paper-deg": dict(TABLE4, R=R_TABLE4_DEG_UNITS),
    "default": _sensor_tuning(DEFAULT_TUNING),
}


@dataclass(frozen=True)
class PIFDesign(DesignInputs):
    """Design inputs of a :class:`PIF`: the model (``"modified"``, ``"original"``), the variant
    (``"steady"``, ``"riccati"``) and the weights ``Q`` (1/s), ``R`` (the diagonal, (m/s^2)^2 s and
    (rad/s)^2 s), ``S`` (-), ``th`` (-), ``Q_ay`` ((m/s^2)^2 s) the tables are built with."""

    model: str
    variant: str
    Q: float
    R: tuple
    S: float
    th: float
    Q_ay: float

    @property
    def R_matrix(self) -> np.ndarray:
        """``R`` as the diagonal matrix of the Riccati equation."""
        return np.diag(np.asarray(self.R, dtype=float))


def solvable_th(design: PIFDesign, tables_of, to_zero: bool = True):
    """``tables_of(d)`` of the first design ``d`` with a stabilising solution, from ``design`` on
    with ``th`` halved each time (below ``th/1000``: 0, the Kalman filter, always solvable).

    A default ``th`` adapts so to the car and the sensor. ``tables_of`` raises
    :class:`NoStabilisingSolution` for a design without one; the last such error is raised when
    even ``th = 0`` has none. ``to_zero=False`` (a ``th`` the user gave, e.g. a ``[tuning]`` table's): below
    ``th/1000`` it raises instead, naming the ``th`` (a value a thousand times too large had become the
    Kalman filter, in silence).
    """
    floor = design.th / 1000.0
    given = design.th
    while True:
        try:
            return tables_of(design)
        except NoStabilisingSolution as exc:
            if design.th == 0.0:
                raise
            if design.th <= floor and not to_zero:
                raise NoStabilisingSolution(f"th = {given:g} has no stabilising solution down to th/1000 "
                                            f"({design.th:g}) for this sensor and rate: far too large ({exc})"
                                            ) from None
            design = replace(design, th=design.th / 2.0 if design.th > floor else 0.0)


class PIF(ScheduledObserver):
    """Proportional-integral H-infinity filter (see module docstring).

    Parameters
    ----------
    params : VehicleParams
    model : {"modified", "original"}
    variant : {"steady", "riccati"}
    tuning : {"default", "paper", "paper-deg"}, optional
        Named weights (:data:`TUNINGS`, module docstring). Default: ``"default"`` for
        the modified model, ``"paper"`` (Table 4) for the original model.
    Q, R, S, th : float, optional
        Weights overriding the preset: Q (1/s), R ((rad/s)^2 s), S (-), th (-); ``R``
        may be a 2-vector for the original model (``[R_ay, R_r]``), a scalar R means
        ``[R_AY_ORIGINAL, R]`` there.
    Q_ay : float, optional
        Noise density of the lateral-acceleration input ((m/s^2)^2 s; modified model): process
        noise ``Q_ay b b^T`` on the states the ``ay`` input drives (``b``, its column of ``B``).
        The default tuning: the ESP accelerometer's :data:`Q_AY_ESP`; Table 4: 0 (as published).
    P0 : sequence of 3 floats, optional
        Diagonal of the initial Riccati matrix (``riccati`` variant).
    adapt_th : bool, optional
        Halve ``th`` until the Riccati equation has a stabilising solution at every grid
        speed (down to ``th/1000``, then 0: the Kalman filter), instead of raising. Default:
        only for the default tuning's own ``th``; :func:`with_sensor_noise` sets it for a given
        ``th`` whose ``R`` comes from the sensor at a log's rate.
    **kw
        Common options of :class:`~roadbank.estimators.base.Estimator`.

    Raises
    ------
    NoStabilisingSolution
        when the Riccati equation has no stabilising solution at some speed of
        the grid (``th`` too large); the message names the speed.
    """

    uses = (False, True, True)
    state_names: tuple[str, ...] = ("vy", "r", "w")
    #: estimator name (None: ``pif-<model>``) and named tunings, for subclasses
    label: str | None = None
    tunings = TUNINGS
    #: kernel family of the steady-state variant
    steady_kernel = "lpv"
    design_type: type[PIFDesign] = PIFDesign
    if TYPE_CHECKING:
        @property
        def design(self) -> PIFDesign: ...     # an instance of design_type

    def __init__(self, params=None, *, model="modified", variant="steady", tuning=None, Q=None,
                 R=None, S=None, th=None, P0=None, adapt_th=None, Q_ay=None, **kw):
        if variant not in ("steady", "riccati"):
            raise ValueError(f"variant must be 'steady' or 'riccati', got {variant!r}")
        tuning = tuning or ("default" if model == "modified" else "paper")
        if tuning not in self.tunings:
            raise ValueError(f"tuning must be one of {', '.join(self.tunings)}, got {tuning!r}")
        preset = self.tunings[tuning]
        if "roll" in preset:
            kw.setdefault("roll", preset["roll"])
        auto_th = (tuning == "default" and th is None) if adapt_th is None else bool(adapt_th)
        self._th_given = th is not None
        Q, R, S, th, P0 = (preset[k] if v is None else v
                           for k, v in (("Q", Q), ("R", R), ("S", S), ("th", th), ("P0", P0)))
        self.model = model
        self.variant = variant
        self.name = self.label or f"pif-{model}"
        self.kernel = self.steady_kernel if variant == "steady" else "riccati"
        self.uses = (False, True, True) if model == "modified" else (True, True, True)
        Rv = np.atleast_1d(np.asarray(R, dtype=float))
        if model == "original" and Rv.size == 1:
            Rv = np.array([R_AY_ORIGINAL, Rv[0]])
        Q_ay = float(preset.get("Q_ay", 0.0) if Q_ay is None else Q_ay)
        if np.any(Rv <= 0) or Q < 0 or S <= 0 or not Q_ay >= 0:
            raise ValueError("PIF: R and S must be > 0 and Q, Q_ay >= 0")
        self.Q, self.R, self.S, self.th = float(Q), np.diag(Rv), float(S), float(th)
        self.Q_ay = Q_ay
        self.P0 = np.diag(np.asarray(P0, dtype=float))
        self._adapt_th = auto_th
        super().__init__(params, **kw)
        self.th = self.design.th            # as designed: a default th may have been halved

    def _design_fields(self) -> dict:
        return dict(model=self.model, variant=self.variant, Q=self.Q, R=frozen_array(np.diag(self.R)), S=self.S,
                    th=self.th, Q_ay=self.Q_ay)

    def _designed(self):
        if not self._adapt_th:
            return super()._designed()
        # the default th adapts to the car and the sensor: halved until the Riccati equation is
        # solvable at every speed
        return solvable_th(self.design, self._tables_of, to_zero=not self._th_given)

    def riccati_solution(self, vx: float) -> np.ndarray:
        """Stabilising solution ``P`` of the algebraic Riccati equation (eq 44) at ``vx`` (m/s).

        At a speed of the grid of a steady-state filter designed on the whole grid at once, the
        solution its table was built from (:func:`~roadbank.estimators.grid_design.pif_solution`);
        elsewhere solved at ``vx``.
        """
        if self._grid_design_applies():
            P = grid_design.pif_solution(self, self._own_noise(), float(vx))
            if P is not None:
                return P
        return self._riccati(self.design_model(vx), vx)

    def design_model(self, vx: float):
        """``(A, B, C, Dy, Lw, Ew)`` of the filter's design model at ``vx`` (m/s)."""
        return self._model_at(self.design.params, vx)

    def _model_at(self, params, vx: float):
        """The design model for the car ``params`` at ``vx`` (m/s)."""
        return augmented_design_model(params, vx, self.design.model)

    def process_noise(self, Ew: np.ndarray) -> np.ndarray:
        """Process-noise density ``W`` of the Riccati equation (``Q Ew Ew^T``: noise on ``w`` only)."""
        return self.design.Q * Ew @ Ew.T

    def process_density(self, model) -> np.ndarray:
        """``W`` of the Riccati equation for the design ``model`` ``(A, B, C, Dy, Lw, Ew)``:
        :meth:`process_noise` plus ``Q_ay b b^T``, ``b`` the column of ``B`` of the ``ay`` input."""
        A, B, C, Dy, Lw, Ew = model
        b = B[:, 1]
        return self.process_noise(Ew) + self.design.Q_ay * np.outer(b, b)

    def _riccati(self, model, vx: float) -> np.ndarray:
        A, B, C, Dy, Lw, Ew = model
        d = self.design
        return game_are(A, C, Lw, self.process_density(model), d.R_matrix, np.atleast_2d(d.S), d.th,
                        where=f"at vx={vx:.2f} m/s ({self.name})")

    def _observer(self, model, vx: float):
        A, B, C, Dy, Lw, _ = model
        Kg = self._riccati(model, vx) @ C.T @ np.linalg.inv(self.design.R_matrix)
        return A - Kg @ C, B + Kg @ Dy, Lw, np.zeros((1, 3))

    def observer(self, vx: float):
        """``(F, G, H, D)`` of the steady-state filter at ``vx`` (m/s; see ScheduledObserver)."""
        return self._observer(self.design_model(vx), vx)

    def _builds_as_pif(self) -> bool:
        """The steady-state observer is built as this class builds it (the whole-grid design applies)."""
        cls = type(self)
        return (self.design.variant == "steady" and cls._observer is PIF._observer and cls._riccati is PIF._riccati
                and cls.design_model is PIF.design_model)

    def _own_noise(self) -> bool:
        """The process noise is PIF's own (or the bank-rate state's): it does not use ``th``."""
        cls = type(self)
        return cls.process_density is PIF.process_density and cls.process_noise in (PIF.process_noise,
                                                                                    PIFRate.process_noise)

    def _grid_design_applies(self) -> bool:
        """The table is designed on the whole grid at once (:func:`~roadbank.estimators.grid_design.pif_speed`)."""
        return self._builds_as_pif() and type(self).observer is PIF.observer and type(self)._design is PIF._design

    def _grid_design(self):
        if self._builds_as_pif() and type(self).observer is PIF.observer:
            return grid_design.pif_speed(self, self._own_noise())
        return None

    def _design(self):
        d = self.design
        if d.variant == "steady":
            return super()._design()
        # Riccati ODE: the kernel needs the model; J (start at the equilibrium of
        # the steady-state filter) also checks that the ARE is solvable everywhere.
        rows = []
        for v in d.vgrid:
            model = self.design_model(float(v))
            F, G, _, _ = self._observer(model, float(v))
            A, B, C, Dy, Lw, Ew = model
            rows.append(np.concatenate([A.ravel(), B.ravel(), C.ravel(), Dy.ravel(),
                                        equilibrium_map(F, G).ravel()]))
        extra = np.concatenate([np.linalg.inv(d.R_matrix).ravel(), self.process_density(model).ravel(),
                                (d.th * d.S * Lw.T @ Lw).ravel()])
        return np.ascontiguousarray(np.array(rows)), A.shape[0], extra

    def _fill_cfg_head(self, head):
        head[layout.C_P] = self.R.shape[0]

    def _initial_memory(self, mem):
        if self.variant == "riccati":
            n = self._nstate
            o = layout.riccati_p(n, self._roll[0].shape[0])
            mem[o:o + n * n] = self.P0.ravel()          # P, n x n row-major


def modified_steady(label: str, kw: dict) -> dict:
    """``kw`` with ``model="modified"``, ``variant="steady"``: the options of a PIF variant that
    exists on that model and variant only (``label`` names it in the error when ``kw`` sets either)."""
    if "model" in kw or "variant" in kw:
        raise ValueError(f"{label}: model and variant are fixed (modified, steady)")
    return {**kw, "model": "modified", "variant": "steady"}


#: tuning of :class:`PIFRate`: differential evolution on ``roadbank tune``'s training set (seed 0,
#: 48 drives; docs/estimators.md), R = R_ESP, S = 1
RATE_TUNING: dict[str, Any] = dict(Q=R_ESP * 10**2.88025985, Q_rate=R_ESP * 10**3.97104448, th=10**-2.10630825 / R_ESP,
                   roll="dynamic")
#: named tunings of :class:`PIFRate`
RATE_TUNINGS = {"default": _sensor_tuning(RATE_TUNING)}


@dataclass(frozen=True)
class BankRateDesign(PIFDesign):
    """Design inputs of :class:`PIFRate`: those of :class:`PIFDesign` and ``Q_rate`` (1/s^3)."""

    Q_rate: float


class _BankRateState:
    """The bank *rate* as a fourth filter state (mixin of :class:`PIFRate`, :class:`PIFRateAdaptive`).

    States ``[vy, r, w, w_rate]``, ``w' = w_rate + n_w``, ``w_rate' = n_rate``; process-noise
    densities ``Q`` (1/s) on ``w`` and ``Q_rate`` (1/s^3) on ``w_rate``.
    """

    state_names: tuple[str, ...] = ("vy", "r", "w", "w_rate")
    # of the PIF this mixes into
    label: str
    options_default: dict[str, Any]
    if TYPE_CHECKING:
        @property
        def design(self) -> BankRateDesign | RateAdaptiveDesign: ...

    def _set_rate_noise(self, Q_rate) -> None:
        self.Q_rate = float(self.options_default["Q_rate"] if Q_rate is None else Q_rate)
        if not self.Q_rate >= 0:
            raise ValueError(f"{self.label}: Q_rate must be >= 0, got {Q_rate}")

    def _design_fields(self) -> dict:
        # super() is the PIF after this mixin in the subclass's MRO
        return {**super()._design_fields(), "Q_rate": self.Q_rate}  # type: ignore[misc]

    def _model_at(self, params, vx: float):
        """The augmented modified model for ``params`` at ``vx`` (m/s) with ``w_rate`` appended (``w' = w_rate``)."""
        A3, B3, C3, Dy, _, _ = _augmented_design_model(params, float(vx), "modified")     # (copied below)
        A = np.zeros((4, 4))
        A[:3, :3] = A3
        A[2, 3] = 1.0
        B = np.zeros((4, B3.shape[1]))
        B[:3] = B3
        C = np.zeros((C3.shape[0], 4))
        C[:, :3] = C3
        Lw = np.zeros((1, 4))
        Lw[0, 2] = 1.0
        Ew = np.zeros((4, 2))
        Ew[2, 0] = Ew[3, 1] = 1.0
        return A, B, C, Dy.copy(), Lw, Ew

    def process_noise(self, Ew: np.ndarray) -> np.ndarray:
        """``Ew diag(Q, Q_rate) Ew^T``: noise on ``w`` and on ``w_rate``."""
        d = self.design
        return Ew @ np.diag([d.Q, d.Q_rate]) @ Ew.T


class PIFRate(_BankRateState, PIF):
    r"""``pif-rate`` (beyond the paper): the PIF on the modified model with the bank *rate* as a
    state — an integrated random walk instead of the paper's random walk for ``w``.

    States ``[vy, r, w, w_rate]``, ``w' = w_rate + n_w``, ``w_rate' = n_rate``; process-noise
    densities ``Q`` (1/s) on ``w`` and ``Q_rate`` (1/s^3) on ``w_rate``. A bank that changes at
    a constant rate (a superelevation transition, a lane change onto a banked lane) is then
    followed without the constant lag of the paper's model, which only knows steps. Same
    input (ay), output (yaw rate), H-infinity Riccati design and speed schedule (``lpv``
    kernel); steady-state variant only. Defaults :data:`RATE_TUNING` (``R`` from the
    yaw-rate sensor as for ``pif-modified``; ``th`` halved where it has no solution).

    Parameters
    ----------
    Q_rate : float, optional
        Process-noise density of the bank rate's derivative (1/s^3).
    Q, R, S, th, tuning, **kw
        As :class:`PIF` (``model`` and ``variant`` are fixed).
    """

    label = "pif-rate"
    design_type = BankRateDesign
    if TYPE_CHECKING:
        @property
        def design(self) -> BankRateDesign: ...
    tunings = RATE_TUNINGS
    #: defaults of the options beyond the weights
    options_default = RATE_TUNING

    def __init__(self, params=None, *, tuning=None, Q_rate=None, **kw):
        self._set_rate_noise(Q_rate)
        super().__init__(params, **modified_steady(self.label, kw), tuning=tuning)


#: excitation grid of :class:`PIFAdaptive` (m/s^2 of low-passed ``|ay|``): 0 to 10 m/s^2 in steps of
#: 1 m/s^2; above it the last point's design holds
EXCITATION_GRID = tuple(float(a) for a in range(11))
#: default speed-grid step of :class:`PIFAdaptive` (m/s): coarser than the speed-only PIF's, as
#: the design solves one Riccati equation per grid point (the gains are smooth in speed)
ADAPTIVE_V_STEP = 1.0
#: tuning of :class:`PIFAdaptive`: Q, th and the roll model of ``pif-modified``'s default (so that without
#: the schedule it is that filter); mu from a scan on ``roadbank tune``'s training set (seed 0, 48 drives;
#: optimum 0.85-0.9, the upper end for margin: a smaller mu overestimates the usage and costs more,
#: docs/estimators.md); tau and tf chosen, not tuned
ADAPTIVE_TUNING: dict[str, Any] = dict(Q=DEFAULT_TUNING["Q"], th=DEFAULT_TUNING["th"], mu=0.9, tau=0.5, tf=0.1,
                       roll=DEFAULT_TUNING["roll"])
#: named tunings of :class:`PIFAdaptive`
ADAPTIVE_TUNINGS = {"default": _sensor_tuning(ADAPTIVE_TUNING)}


def secant_stiffness_ratio(usage):
    """Secant cornering stiffness of a brush tyre over its linear stiffness, ``F/(C alpha)`` (-),
    at the friction usage ``u = |F|/(mu Fz)`` (-; clipped to [0, 1]).

    The brush model with a parabolic pressure distribution gives
    ``u = 1 - (1 - sigma)^3``, ``sigma = C |alpha| / (3 mu Fz)`` up to full sliding
    (``sigma = 1``), so ``sigma = 1 - (1 - u)^(1/3)`` and ``F/(C alpha) = 1 - sigma + sigma^2/3``:
    1 for small forces, 1/3 at the friction limit.
    """
    u = np.clip(np.asarray(usage, dtype=float), 0.0, 1.0)
    sigma = 1.0 - np.cbrt(1.0 - u)
    return 1.0 - sigma + sigma**2 / 3.0


@dataclass(frozen=True)
class AdaptiveDesign(PIFDesign):
    """Design inputs of :class:`PIFAdaptive`: those of :class:`PIFDesign`, the design friction
    coefficient ``mu`` (-), the time constants ``tau``, ``tf`` (s) and the excitation grid
    ``egrid`` (m/s^2)."""

    mu: float
    tau: float
    tf: float
    egrid: tuple


class PIFAdaptive(PIF):
    r"""``pif-adaptive`` (beyond the paper): the steady-state PIF on the modified model with the
    rear cornering stiffness scheduled on the friction usage as well as speed.

    The modified model's yaw equation uses the rear axle force ``Cr alpha_r``. Near the tyre
    limit the real force falls well below it (about 25 % at ``|ay| = 0.7 g``, 40-50 % while
    the steering ramps to the limit), and a filter designed on ``Cr`` reads the mismatch as
    a bank change. In quasi-steady cornering the rear axle carries ``m ay Lf / L`` on a load of
    about ``m g Lf / L``, so its friction usage is ``|ay| / (mu g)``; the filter is designed
    with the secant stiffness ``Cr_eff = Cr * secant_stiffness_ratio(e / (mu g))``
    (:func:`secant_stiffness_ratio`, brush tyre) at the excitation ``e``: ``|ay|`` low-passed
    with time constant ``tf`` (the force builds up with a lag) through a peak follower with
    release time constant ``tau`` (see :func:`roadbank.estimators.kernels.adaptive_step`).
    The H-infinity design (eq 44, same Q, R, S, th) is solved on a speed x excitation grid
    (:data:`EXCITATION_GRID`) and interpolated bilinearly by the ``adaptive`` kernel. ``mu``
    is the design friction coefficient: ``mu = inf`` (no scheduling) gives ``pif-modified``
    with the same weights. General (trapezoidal) path only: no fixed-rate tables
    (``sample_rate`` is ignored) and no C export.

    Parameters
    ----------
    mu : float, optional
        Design friction coefficient (-; > 0, ``inf`` switches the schedule off).
    tau : float, optional
        Release time constant of the excitation's peak follower (s).
    tf : float, optional
        Time constant of the low-pass on ``|ay|`` (s).
    Q, R, S, th, tuning, **kw
        As :class:`PIF` (``model`` and ``variant`` are fixed: modified, steady).
    """

    label = "pif-adaptive"
    tunings = ADAPTIVE_TUNINGS
    #: defaults of the schedule's options (mu, tau, tf)
    options_default = ADAPTIVE_TUNING
    steady_kernel = "adaptive"
    design_type: type[AdaptiveDesign] = AdaptiveDesign
    if TYPE_CHECKING:
        @property
        def design(self) -> AdaptiveDesign: ...

    def __init__(self, params=None, *, tuning=None, mu=None, tau=None, tf=None, **kw):
        kw = modified_steady(self.label, kw)
        d = self.options_default
        self.mu, self.tau, self.tf = (float(d[k] if v is None else v)
                                      for k, v in (("mu", mu), ("tau", tau), ("tf", tf)))
        if not (self.mu > 0 and self.tau > 0 and self.tf > 0) or np.isnan(self.tau + self.tf):
            raise ValueError(f"{self.label}: need mu, tau, tf > 0; got {self.mu}, {self.tau}, {self.tf}")
        self.egrid = EXCITATION_GRID
        kw.setdefault("v_step", ADAPTIVE_V_STEP)
        super().__init__(params, tuning=tuning, **kw)

    def _design_fields(self) -> dict:
        return {**super()._design_fields(), "mu": self.mu, "tau": self.tau, "tf": self.tf,
                "egrid": tuple(self.egrid)}

    def rear_stiffness(self, e: float) -> float:
        """Rear axle cornering stiffness (N/rad) of the design at excitation ``e`` (m/s^2)."""
        d = self.design
        return d.params.Cr * float(secant_stiffness_ratio(e / (d.mu * d.params.g)))

    def observer_at(self, vx: float, e: float):
        """``(F, G, H, D)`` of the steady-state filter at speed ``vx`` (m/s) and excitation ``e`` (m/s^2)."""
        return self._observer(self._model_at(replace(self.design.params, Cr=self.rear_stiffness(e)), vx), vx)

    def _design(self):
        if self._builds_as_pif() and type(self).observer_at is PIFAdaptive.observer_at:
            fast = grid_design.pif_adaptive(self, self._own_noise())     # the whole grid at once
            if fast is not None:
                return fast
        d = self.design
        rows = []
        for v in d.vgrid:
            for e in d.egrid:
                F, G, H, D = self.observer_at(float(v), e)
                rows.append(np.concatenate([F.ravel(), G.ravel(), np.ravel(H), np.ravel(D),
                                            equilibrium_map(F, G).ravel()]))
        eg = d.egrid
        extra = [eg[0], (eg[1] - eg[0]) if len(eg) > 1 else 1.0, float(len(eg)), d.tau, d.tf]
        return np.ascontiguousarray(np.array(rows)), len(self.state_names), np.array(extra)


#: tuning of :class:`PIFRateAdaptive`: ``pif-rate``'s weights and ``pif-adaptive``'s schedule
RATE_ADAPTIVE_TUNING: dict[str, Any] = dict(Q=RATE_TUNING["Q"], Q_rate=RATE_TUNING["Q_rate"], th=RATE_TUNING["th"],
                            mu=ADAPTIVE_TUNING["mu"], tau=ADAPTIVE_TUNING["tau"], tf=ADAPTIVE_TUNING["tf"],
                            roll=RATE_TUNING["roll"])
#: named tunings of :class:`PIFRateAdaptive`
RATE_ADAPTIVE_TUNINGS = {"default": _sensor_tuning(RATE_ADAPTIVE_TUNING)}


@dataclass(frozen=True)
class RateAdaptiveDesign(AdaptiveDesign):
    """Design inputs of :class:`PIFRateAdaptive`: those of :class:`AdaptiveDesign` and ``Q_rate`` (1/s^3)."""

    Q_rate: float


class PIFRateAdaptive(_BankRateState, PIFAdaptive):
    r"""``pif-rate-adaptive`` (beyond the paper): both extensions of the PIF on the modified model —
    the bank-rate state of :class:`PIFRate` (no lag behind banks that change at a steady rate)
    and the friction-usage schedule of the rear cornering stiffness of :class:`PIFAdaptive`
    (no false bank near the tyre limit).

    The H-infinity design (eq 44 with the four-state model) is solved on the speed x
    excitation grid and run by the ``adaptive`` kernel, as for ``pif-adaptive``; general
    (trapezoidal) path only, no C export. Defaults :data:`RATE_ADAPTIVE_TUNING`.

    Parameters
    ----------
    Q_rate : float, optional
        Process-noise density of the bank rate's derivative (1/s^3).
    mu, tau, tf : float, optional
        As :class:`PIFAdaptive`.
    Q, R, S, th, tuning, **kw
        As :class:`PIF` (``model`` and ``variant`` are fixed: modified, steady).
    """

    label = "pif-rate-adaptive"
    design_type = RateAdaptiveDesign
    if TYPE_CHECKING:
        @property
        def design(self) -> RateAdaptiveDesign: ...
    tunings = RATE_ADAPTIVE_TUNINGS
    options_default = RATE_ADAPTIVE_TUNING

    def __init__(self, params=None, *, Q_rate=None, **kw):
        self._set_rate_noise(Q_rate)
        super().__init__(params, **kw)

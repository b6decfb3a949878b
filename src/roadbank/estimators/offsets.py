r"""Online sensor offsets: learn the yaw-rate and steering offsets while driving, as ESP software does.

A constant yaw-rate offset :math:`b_r` is unobservable from ``ay``, ``r`` and ``vx``: along a
run at constant speed it reads as a bank of :math:`v_x b_r / g`. Two situations tell it apart:

Standstill
    With :math:`|v_x| <` ``v_stop`` for longer than ``stop_settle`` the car does not turn, so
    the measured yaw rate *is* its offset. :math:`b_r` is the mean of ``r`` over the
    standstill evidence, the evidence before the current stop weighing at most ``tau_stop``
    seconds (a plain mean at first, then close to a first-order filter of that time
    constant). The speed threshold is low (0.2 m/s) and the end of every stop teaches
    nothing (``stop_trail``; the stop's sums are kept in two snapshots, and the one at least
    ``stop_trail`` s old is committed when the car drives off): a car creeping off a stop
    in a tight turn yaws before its speed says it moves. Samples with
    :math:`|r - b_r| \ge` ``stop_r_max`` (a turntable, a ferry) teach nothing.
Straight driving
    Off by default (``straight_ay`` 0): a crowned road and an accelerometer offset both put a constant ``ay`` on a
    straight that does not yaw, and no relation of these channels tells them apart (the fifty-second stage,
    docs/estimators.md). Turned on (``straight_ay`` > 0), with a steering angle, while the car drives straight and
    steadily (``vx >= v_straight``;
    low-passed :math:`|a_y|`, :math:`|\delta_f - b_\delta|` and :math:`|r - b_r|` below
    ``straight_ay``, ``straight_delta``, ``straight_r``; low yaw acceleration and steering
    rate; all of it for longer than ``straight_settle``) the linear single-track model holds
    in its steady state, its understeer term on the tyres' lateral force, which the accelerometer measures (the
    low-passed :math:`a_y`, less ``ay_offset``) whatever the road's cross slope:

    .. math:: \delta_f = \frac{L\,r}{v_x} + K_{us}\,a_y

    (on a flat road in a steady turn :math:`a_y = v_x r`: :math:`r = v_x \delta_f / (L + K_{us} v_x^2)`; on a crowned
    straight the car steers into the slope without yawing, which that flat-road form read as a yaw rate: the
    fifty-first stage, docs/estimators.md; :math:`K_{us}` the understeer gradient of the car's parameters,
    :func:`roadbank.models.bicycle.understeer_gradient`). Until a standstill has taught the
    yaw-rate offset, straight driving teaches it against this kinematic yaw rate (the same
    running mean, time constant ``tau_straight``; slower evidence: it is flagged learnt after
    ``min_straight`` s). Once the standstill has taught it, straight driving teaches the
    steering offset instead, against the steering angle the corrected yaw rate needs. The two
    are never learnt from the same relation at once: on a straight at one speed only the
    combination :math:`b_r - v_x b_\delta / L` is observable, so the
    steering offset waits for the standstill. Without a steering angle (NaN), or with one that has never changed
    (a logger's zeros for a signal it lacks), straight driving teaches nothing: a yaw-rate offset cannot be told from
    a gentle curve there.
Lateral accelerometer
    Not learnt. At standstill and on a straight, an accelerometer offset enters ``ay``
    exactly as the road's bank does (:math:`g \sin\phi_b + b_{a_y}`), so any online estimate
    of it would remove the mean bank of the roads driven, the very quantity estimated (the
    right-hand lane of a crowned road has the same sign of bank for hours). A known offset
    (``ay_offset``, e.g. from ``roadbank identify`` with its stated assumption of the mean
    bank of the straights) is subtracted as given.

Each learnt offset has a flag: ``r_offset_learnt`` once it has ``min_standstill`` s of
standstill or ``min_straight`` s of straight-driving evidence, ``delta_offset_learnt`` once the
steering offset has ``min_straight`` s. The estimator's own ``valid`` output is left as it is.

:func:`with_online_offsets` wraps any estimator: it corrects ``r``, ``ay`` and ``delta_f`` with
the offsets learnt up to each sample (causal) before the estimator sees them. The per-sample
step is one compiled function (:mod:`.kernels.offsets`), the same for ``run`` and ``step``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..constants import MAX_GAP_S
from ..models.bicycle import understeer_gradient
from ..params import VehicleParams
from ..signals import Estimate, Signals
from .kernels import offsets as K
from .base import Estimator, StepResult, Wrapper, sample_floats
from .held import AtSource


@dataclass(frozen=True)
class OffsetSettings:
    """Rules of the online offset learner (SI: m/s, s, rad, rad/s, m/s^2).

    Attributes
    ----------
    v_stop : float
        Speed below which the car stands still (m/s).
    stop_settle : float
        Seconds of standstill before its samples teach (the car settles after stopping).
    tau_stop : float
        Time constant (s) of the standstill filter once ``tau_stop`` s of evidence exist.
    min_standstill : float
        Standstill evidence (s) after which the yaw-rate offset is flagged learnt.
    stop_r_max : float
        Largest ``|r - b_r|`` (rad/s) at standstill that teaches.
    stop_trail : float
        The last ``stop_trail`` to ``2 stop_trail`` s of a standstill teach nothing (s): a car
        that creeps off turns before its speed reaches ``v_stop``.
    v_straight : float
        Lowest speed of straight-driving evidence (m/s).
    straight_ay, straight_delta, straight_r : float
        Largest low-passed ``|ay|`` (m/s^2), ``|delta_f - b_delta|`` (rad) and ``|r - b_r|``
        (rad/s) of straight driving. ``straight_ay`` 0 (the default) turns straight-driving evidence off: a crowned
        road and an accelerometer offset both put a constant ``ay`` on a straight that does not yaw, and no relation
        tells them apart (the fifty-second stage, docs/estimators.md); 0.3 m/s^2 turns it on, for a log whose
        accelerometer offset is known (``ay_offset``).
    straight_r_dot, straight_delta_dot : float
        Largest low-passed yaw acceleration (rad/s^2) and steering rate (rad/s).
    straight_settle : float
        Seconds the straight conditions hold before the samples teach.
    tau_straight : float
        Time constant (s) of the straight-driving filter.
    min_straight : float
        Straight-driving evidence (s) after which an offset is flagged learnt.
    prefilter : float
        Time constant (s) of the low-pass of ``r``, ``delta_f`` and ``ay`` the straight test reads.
    r_limit, delta_limit : float
        Largest learnt yaw-rate (rad/s) and steering (rad) offset magnitudes (clamps).
    ay_offset : float
        Known accelerometer offset subtracted from ``ay`` (m/s^2); not learnt.
    max_gap : float
        A gap between samples longer than this (s) restarts the standstill and straight timers.
    """

    v_stop: float = 0.2
    stop_settle: float = 1.0
    tau_stop: float = 5.0
    min_standstill: float = 0.8
    stop_r_max: float = math.radians(3.0)
    stop_trail: float = 0.5
    v_straight: float = 5.0
    straight_ay: float = 0.0
    straight_delta: float = math.radians(0.5)
    straight_r: float = math.radians(2.0)
    straight_r_dot: float = math.radians(1.0)
    straight_delta_dot: float = math.radians(0.5)
    straight_settle: float = 2.0
    tau_straight: float = 30.0
    min_straight: float = 10.0
    prefilter: float = 0.5
    r_limit: float = math.radians(5.0)
    delta_limit: float = math.radians(5.0)
    ay_offset: float = 0.0
    max_gap: float = MAX_GAP_S

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not math.isfinite(v) or (f.name != "ay_offset" and v < 0):
                raise ValueError(f"OffsetSettings.{f.name} must be a finite number >= 0, got {v}")
        for name in ("tau_stop", "tau_straight", "prefilter", "r_limit", "delta_limit", "max_gap"):
            if getattr(self, name) <= 0:
                raise ValueError(f"OffsetSettings.{name} must be > 0, got {getattr(self, name)}")

    def cfg(self, params: VehicleParams) -> np.ndarray:
        """The kernel's settings array (:mod:`.kernels.offsets` ``C_*``) for the car ``params``."""
        c = np.zeros(K.N_CFG)
        c[K.C_VSTOP], c[K.C_TSTOP], c[K.C_TAUSTOP] = self.v_stop, self.stop_settle, self.tau_stop
        c[K.C_NSTOP], c[K.C_RSTOP], c[K.C_TRAIL] = self.min_standstill, self.stop_r_max, self.stop_trail
        c[K.C_VSTR], c[K.C_AYSTR], c[K.C_DSTR] = self.v_straight, self.straight_ay, self.straight_delta
        c[K.C_RSTR], c[K.C_RDOT], c[K.C_DDOT] = self.straight_r, self.straight_r_dot, self.straight_delta_dot
        c[K.C_TSTR], c[K.C_TAUSTR], c[K.C_NSTR] = self.straight_settle, self.tau_straight, self.min_straight
        c[K.C_L], c[K.C_KUS] = params.L, understeer_gradient(params)
        c[K.C_TAUF], c[K.C_RMAX], c[K.C_DMAX] = self.prefilter, self.r_limit, self.delta_limit
        c[K.C_AYOFF], c[K.C_GAP] = self.ay_offset, self.max_gap
        return c


class OnlineOffsets(Wrapper):
    """An estimator whose inputs are corrected by the online offset learner (module docstring).

    Parameters
    ----------
    inner : Estimator
        Any roadbank estimator; it sees ``r - b_r``, ``ay - ay_offset``, ``delta_f - b_delta``.
    params : VehicleParams, optional
        The car of the kinematic yaw rate (wheelbase, understeer gradient); default the
        estimator's design parameters.
    settings : OffsetSettings, optional

    ``run(signals) -> Estimate`` adds to ``Estimate.states`` the offsets learnt up to each
    sample (``r_offset`` rad/s, ``delta_offset`` rad) and their flags
    (``r_offset_learnt``, ``delta_offset_learnt``: 1.0 learnt, 0.0 not yet).
    ``step(t, vx, ay, r, delta_f)`` returns the inner estimator's :class:`StepResult`; the
    learner's latest values are :attr:`offsets`. Every other attribute is the inner estimator's.
    """

    def __init__(self, inner: Estimator, params: VehicleParams | None = None,
                 settings: OffsetSettings | None = None):
        if isinstance(inner, OnlineOffsets):
            raise ValueError(f"{inner.name}: already learns its offsets online")
        if not hasattr(inner, "step") or not hasattr(inner, "run"):
            raise TypeError("with_online_offsets() expects a roadbank estimator")
        self.inner = inner
        self.offset_params = params if params is not None else inner.params
        self.settings = settings if settings is not None else OffsetSettings()
        self._ocfg = self.settings.cfg(self.offset_params)
        self._omem = K.new_memory()
        self._oout = np.zeros(K.N_OUT)

    def reset(self) -> None:
        """Forget all history of the estimator and of the learner (the offsets too)."""
        self.inner.reset()
        self._omem = K.new_memory()
        self._oout = np.zeros(K.N_OUT)

    @property
    def offsets(self) -> dict:
        """The learner after the last sample: ``r`` (rad/s), ``delta_f`` (rad), ``ay`` (m/s^2, the
        given one) and the flags ``r_learnt``, ``delta_f_learnt``."""
        o = self._oout
        return {"r": float(o[K.O_BR]), "delta_f": float(o[K.O_BD]), "ay": float(self._ocfg[K.C_AYOFF]),
                "r_learnt": bool(o[K.O_RLEARNT]), "delta_f_learnt": bool(o[K.O_DLEARNT])}

    def correct(self, signals: Signals, *, reset: bool = True) -> tuple[Signals, np.ndarray]:
        """Run the learner over ``signals``: the corrected signals and the learner's output rows
        ``(n, 7)`` (:mod:`.kernels.offsets` ``O_*``). ``reset=False`` continues from its state."""
        if reset:
            self._omem = K.new_memory()
        n = len(signals)
        out = np.empty((n, K.N_OUT))
        f = np.ascontiguousarray
        K.offsets_run(self._omem, self._ocfg, f(signals.t, float), f(signals.vx, float), f(signals.delta_f, float),
                      f(signals.ay, float), f(signals.r, float), out)
        if n:
            self._oout[:] = out[-1]
        return dataclasses.replace(signals, ay=out[:, K.O_AY].copy(), r=out[:, K.O_R].copy(),
                                   delta_f=out[:, K.O_D].copy()), out

    def _apply(self, signals: Signals) -> Signals:
        """``signals`` corrected by the current offsets, the learner not advanced."""
        o = self._omem
        return dataclasses.replace(signals, ay=signals.ay - self._ocfg[K.C_AYOFF], r=signals.r - o[K.M_BR],
                                   delta_f=signals.delta_f - o[K.M_BD])

    def run(self, signals: Signals, *, reset: bool = True, lookahead: Signals | None = None) -> Estimate:
        """Estimate over a whole log with the offsets learnt online (see the class docstring).

        ``lookahead`` (an offline estimator's later samples) is corrected by the offsets learnt
        up to the end of ``signals``.
        """
        if not isinstance(signals, Signals):
            raise TypeError("run() expects a roadbank.Signals")
        if reset:
            self.inner.reset()
        fixed, out = self.correct(signals, reset=reset)
        kw = {} if lookahead is None else {"lookahead": self._apply(lookahead)}
        est = self.inner.run(fixed, reset=False, **kw)
        est.states["r_offset"] = out[:, K.O_BR].copy()
        est.states["delta_offset"] = out[:, K.O_BD].copy()
        est.states["r_offset_learnt"] = out[:, K.O_RLEARNT].copy()
        est.states["delta_offset_learnt"] = out[:, K.O_DLEARNT].copy()
        return est

    def step(self, t: float, vx: float, ay: float, r: float, delta_f: float = float("nan"),
             **more: float) -> StepResult:
        """One sample: time (s), vx (m/s), ay (m/s^2), r (rad/s), delta_f (rad), and ``more`` the inner estimator
        reads as they are (``p``, ``ax``, ``q``: the roll rate in rad/s, m/s^2, the pitch rate in rad/s, of
        :data:`roadbank.estimators.GYRO`; ignored by the others); the inner
        estimator's result for the corrected sample."""
        o = self._oout
        K.offsets_step(self._omem, self._ocfg, *sample_floats(self.name, t, vx, delta_f, ay, r), o)
        return self.inner.step(t, vx, o[K.O_AY], o[K.O_R], o[K.O_D], **more)

    def __repr__(self) -> str:
        return f"<OnlineOffsets of {self.inner!r}>"


def with_online_offsets(est: Estimator, params: VehicleParams | None = None,
                        settings: OffsetSettings | None = None) -> OnlineOffsets | AtSource:
    """``est`` behind the online offset learner (:class:`OnlineOffsets`); an estimator that reads a held log at its
    source's rate (:class:`~roadbank.estimators.held.AtSource`) keeps doing so, the learner behind it (it learns
    from the rows taken, whose values the learner's corrections would otherwise make look new).

    Parameters
    ----------
    est : Estimator
        Any roadbank estimator.
    params : VehicleParams, optional
        The car whose wheelbase and understeer gradient give the kinematic yaw rate
        (default ``est.params``).
    settings : OffsetSettings, optional
        The learner's rules (default :class:`OffsetSettings()`).
    """
    if isinstance(est, AtSource):
        return AtSource(OnlineOffsets(est.inner, params, settings))
    return OnlineOffsets(est, params, settings)

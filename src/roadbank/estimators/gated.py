r"""Two filters blended by the yaw acceleration: ``pif-gated`` and ``kinematic-pif`` (:class:`KinematicPIF`,
the default of every command: ``kinematic-ff`` on real roads, the default PIF in hard transients).

``pif-gated`` — the default PIF, switched to a fast bank-rate PIF while the yaw accelerates.

A causal estimator beyond the paper. A PIF must trade lag behind bank changes against the
noise it passes: the default ``pif-modified`` is quiet and lags a bank that changes within a
second (lane changes onto a banked lane, the crease between two lanes), a fast filter with the
bank rate as a state follows them and passes more noise. Roads put bank changes where the
curvature changes (superelevation runoff along a transition curve, lane changes), i.e. where
the yaw rate changes; on a straight or a steady curve the bank changes slowly. So both filters
run, and the output moves to the fast one while the yaw part of the lateral jerk
:math:`v_x |\dot r|` is large:

.. math::
    w = w_s + g\,(w_f - w_s), \qquad \theta = \arcsin w, \qquad \phi_b = \theta - \phi

* slow: :class:`~roadbank.estimators.pif.PIF` on the modified model with the default weights
  (or a vehicle file's ``[tuning.pif-modified]``), states ``[vy, r, w]``;
* fast: :class:`~roadbank.estimators.pif.PIFRate` (``[vy, r, w, w_rate]``) with ten times the
  bank-rate noise of ``pif-rate``'s default and ``th = 0`` (its Kalman form);
* the gate ``g`` (:func:`roadbank.estimators.kernels.gated_step`): the yaw rate low-passed
  (0.05 s), its rate of change times the speed, a ramp from 2 to 6 m/s^3 and a peak follower
  that releases in 0.5 s.

The fast weights and the gate were chosen together on ``roadbank tune``'s training set (seed 0,
48 drives; docs/estimators.md), not on the paper cells or the validation set. Both filters
share the sensors' ``R`` and ``Q_ay`` and one roll model; their states are stacked into one
block-diagonal observer on the speed schedule (``gated`` kernel: the ``lpv`` step, fixed-rate
path included, plus the gate), so ``run`` equals ``step`` and a chunked ``run`` equals one run.
With the gate held shut it is ``pif-modified``, held open the fast filter (tested). The C
export (:mod:`roadbank.export`) writes the stacked observer and the gate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..params import ESP_RATE
from . import layout
from .base import ESTIMATOR_OPTIONS, DesignInputs, ScheduledObserver
from .kinematic import KINEMATIC_V_MIN
from .lowpass import KinematicFeedForward
from .pif import PIF, RATE_TUNING, PIFRate

#: the fast filter's weights and the gate (chosen on the training set, see module docstring):
#: ``fast_Q`` (1/s), ``fast_Q_rate`` (1/s^3), ``fast_th`` (-), ``gate_tf``, ``gate_release`` (s),
#: ``gate_on``, ``gate_span`` (m/s^3)
GATED_TUNING = dict(fast_Q=float(RATE_TUNING["Q"]), fast_Q_rate=10.0 * float(RATE_TUNING["Q_rate"]), fast_th=0.0,
                    gate_tf=0.05, gate_release=0.5, gate_on=2.0, gate_span=4.0)

#: options of :class:`~roadbank.estimators.base.Estimator` that both filters share (each runs on the pair's rate)
_COMMON = tuple(k for k in ESTIMATOR_OPTIONS if k != "sample_rate")


@dataclass(frozen=True)
class GatedDesign(DesignInputs):
    """Design inputs of a gated pair: the two filters' design inputs (``slow``, ``fast``) and the
    gate's ``gate_tf``, ``gate_release`` (s), ``gate_on``, ``gate_span`` (m/s^3), ``gate_v_min`` (m/s)."""

    slow: DesignInputs
    fast: DesignInputs
    gate_tf: float
    gate_release: float
    gate_on: float
    gate_span: float
    gate_v_min: float


class _GatedPair(ScheduledObserver):
    """Two scheduled linear observers stacked into one, their outputs blended by the yaw-acceleration
    gate (``gated`` kernel). Subclasses build ``self._slow`` (any :class:`ScheduledObserver`) and
    ``self._fast`` (a :class:`~roadbank.estimators.pif.PIF`, whose ``w`` is a state) and set the
    gate's ``gate_tf``, ``gate_release``, ``gate_on``, ``gate_span`` before ``super().__init__``;
    the two filters' designs and the gate are its design inputs (:class:`GatedDesign`)."""

    kernel = "gated"
    uses = (False, True, True)
    design_type = GatedDesign
    # set by the subclass before ``super().__init__``
    _slow: ScheduledObserver
    _fast: PIF
    gate_tf: float
    gate_release: float
    gate_on: float
    gate_span: float
    gate_v_min: float = 0.0
    if TYPE_CHECKING:
        @property
        def design(self) -> GatedDesign: ...     # an instance of design_type

    def _design_fields(self) -> dict:
        return dict(slow=self._slow.design, fast=self._fast.design, gate_tf=self.gate_tf,
                    gate_release=self.gate_release, gate_on=self.gate_on, gate_span=self.gate_span,
                    gate_v_min=self.gate_v_min)

    @property
    def slow(self) -> ScheduledObserver:
        """The filter the output follows while the gate is shut."""
        return self._slow

    @property
    def fast(self) -> PIF:
        """The PIF the output moves to while the gate is open."""
        return self._fast

    @property
    def limited(self) -> bool:           # type: ignore[override]
        """Whether the slow filter's update is limited (a limited low-pass, ``kinematic-pif``'s)."""
        return self._slow.limited

    def limit_constants(self) -> list[float]:
        return self._slow.limit_constants()

    def observer(self, vx: float):
        """``(F, G, H, D)`` of the stacked observer at ``vx`` (m/s): block-diagonal ``F``, stacked
        ``G``; ``H``, ``D`` give the slow filter's ``w`` (the fast one's is :meth:`fast_output`)."""
        return _stack(self._slow.observer(vx), self._fast.observer(vx))

    def fast_output(self) -> np.ndarray:
        """``H_f`` (n,): the fast filter's ``w`` from the stacked states (constant)."""
        ns = self._slow._nstate
        h = np.zeros(len(self.state_names))
        h[ns:] = np.ravel(self._fast.design_model(self.design.vgrid[0])[4])     # L_w: w is a state
        return h

    def _design(self):
        # the two filters' tables (designed from design.slow and design.fast) stacked at every grid speed: no
        # Riccati equation solved again
        d = self.design
        g, ns, nf = len(d.vgrid), self._slow._nstate, self._fast._nstate
        (Fs, Gs, Hs, Ds, Js), (Ff, Gf, _, _, Jf) = (_blocks(e._tab_cont[:g], e._nstate)
                                                    for e in (self._slow, self._fast))
        F = np.zeros((g, ns + nf, ns + nf))     # what _stack gives at each grid speed, all speeds at once
        F[:, :ns, :ns] = Fs
        F[:, ns:, ns:] = Ff
        H = np.zeros((g, 1, ns + nf))
        H[:, :, :ns] = Hs
        G, J = np.concatenate([Gs, Gf], axis=1), np.concatenate([Js, Jf], axis=1)
        rows = np.concatenate([a.reshape(g, -1) for a in (F, G, H, Ds, J)], axis=1)
        extra = np.concatenate([self.fast_output(), [d.gate_tf, d.gate_release, d.gate_on, d.gate_span, d.gate_v_min],
                                self.limit_constants()])
        return np.ascontiguousarray(rows), len(self.state_names), extra



class PIFGated(_GatedPair):
    """``pif-gated``: the default PIF and a fast bank-rate PIF, blended on the yaw acceleration.

    Parameters
    ----------
    params : VehicleParams
    tuning, Q, R, S, th, Q_ay, adapt_th : optional
        The slow filter's, as :class:`~roadbank.estimators.pif.PIF` (modified model);
        ``R`` ((rad/s)^2 s), ``S`` and ``Q_ay`` ((m/s^2)^2 s) are the fast filter's too.
    fast_Q, fast_Q_rate, fast_th : float, optional
        The fast filter's ``Q`` (1/s), ``Q_rate`` (1/s^3) and ``th`` (-)
        (:class:`~roadbank.estimators.pif.PIFRate`); defaults :data:`GATED_TUNING`.
    gate_tf, gate_release : float, optional
        Time constants (s) of the yaw rate's low-pass and of the gate's release.
    gate_on, gate_span : float, optional
        The gate opens from ``v_x |r'|`` = ``gate_on`` (m/s^3) and is fully open ``gate_span``
        (m/s^3) above.
    **kw
        Common options of :class:`~roadbank.estimators.base.Estimator` (both filters).
    """

    name = "pif-gated"
    state_names = ("vy", "r", "w", "vy_fast", "r_fast", "w_fast", "w_rate_fast")

    def __init__(self, params=None, *, tuning=None, Q=None, R=None, S=None, th=None, Q_ay=None, adapt_th=None,
                 fast_Q=None, fast_Q_rate=None, fast_th=None, gate_tf=None, gate_release=None, gate_on=None,
                 gate_span=None, **kw):
        d = GATED_TUNING
        opt = {k: float(d[k] if v is None else v) for k, v in (
            ("fast_Q", fast_Q), ("fast_Q_rate", fast_Q_rate), ("fast_th", fast_th), ("gate_tf", gate_tf),
            ("gate_release", gate_release), ("gate_on", gate_on), ("gate_span", gate_span))}
        _check_gate(self.name, opt)
        common = {k: kw[k] for k in _COMMON if k in kw}
        self._slow = PIF(params, model="modified", tuning=tuning, Q=Q, R=R, S=S, th=th, Q_ay=Q_ay,
                         adapt_th=adapt_th, sample_rate=None, **common)
        common.setdefault("roll", self._slow.roll)      # one roll model: the slow filter's tuning chose it
        kw["roll"] = common["roll"]
        self._fast = PIFRate(params, R=R, S=S, Q_ay=Q_ay, Q=opt["fast_Q"], Q_rate=opt["fast_Q_rate"],
                             th=opt["fast_th"], sample_rate=None, **common)
        # every setting behind the stacked table is public (it keys the design caches): the slow
        # filter's weights as designed (th may have been halved to be solvable), the fast one's, the gate
        self.Q, self.th, self.R, self.S, self.Q_ay = (self._slow.Q, self._slow.th, self._slow.R, self._slow.S,
                                                      self._slow.Q_ay)
        for k, v in opt.items():
            setattr(self, k, v)
        super().__init__(params, **kw)



def _check_gate(label: str, opt: dict) -> None:
    if not (opt["gate_tf"] > 0 and opt["gate_release"] > 0 and opt["gate_span"] > 0
            and np.isfinite(opt["gate_on"])):
        raise ValueError(f"{label}: need gate_tf, gate_release, gate_span > 0 and a finite gate_on; got "
                         f"{opt['gate_tf']}, {opt['gate_release']}, {opt['gate_span']}, {opt['gate_on']}")
    v = opt.get("gate_v_min", 0.0)
    if not (np.isfinite(v) and v >= 0):
        raise ValueError(f"{label}: gate_v_min must be a speed >= 0 (m/s), got {v}")


#: the gate of :class:`KinematicPIF` (chosen by the rule of :mod:`roadbank.tuning.real`):
#: ``gate_tf``, ``gate_release`` (s), ``gate_on``, ``gate_span`` (m/s^3)
KINEMATIC_PIF_GATE = dict(gate_tf=0.05, gate_release=8.0, gate_on=4.0, gate_span=1.0)
#: the lowest speed (m/s) at which :class:`KinematicPIF`'s gate measure counts (0: every speed; the sixty-sixth stage of
#: :mod:`roadbank.tuning.real`)
KINEMATIC_PIF_GATE_V_MIN = 0.0
#: root-mean-square bank rate of roads (rad/s) that schedules :class:`KinematicPIF`'s low-pass on the
#: log's noise (:func:`roadbank.estimators.lowpass.cutoff_for_noise`; the rule of :mod:`roadbank.tuning.real`)
KINEMATIC_PIF_BANK_RATE = float(np.radians(0.6))
#: exponent (-) of the speed in that prior, ``bank_rate (vx / 10 m/s)^p`` (0: a rate in time; the rule of
#: :mod:`roadbank.tuning.real`, fourteenth stage)
KINEMATIC_PIF_BANK_SPEED_EXP = 0.0
#: :class:`KinematicPIF`'s centripetal feed-forward gain (-; the same rule)
KINEMATIC_PIF_KAPPA = 0.2
#: :class:`KinematicPIF`'s lowest speed (m/s; the same rule): the blend runs through the slow part of a
#: stop instead of starting again from one noisy sample when the car pulls away
KINEMATIC_PIF_V_MIN = KINEMATIC_V_MIN
#: :class:`KinematicPIF`'s sampled-data lead (sample intervals; the same rule): its low-pass lags as the
#: first-order filter of the samples does (:mod:`roadbank.estimators.lowpass`); ``lead`` (s) is this many
#: intervals of the log (:func:`roadbank.vehicle.make_estimator`), by default of the data sheet's rate
KINEMATIC_PIF_LEAD_SAMPLES = 0.5
#: :class:`KinematicPIF`'s limit of its low-pass's update (-, standard deviations of the input's white noise as
#: the cut-off is designed for; 0: linear; the rule of :mod:`roadbank.tuning.real`, tenth stage): road
#: vibration is heavy-tailed, and a pothole's spike moves the estimate by at most this much
KINEMATIC_PIF_CLIP = 3.0
#: time constant (s) of the running noise estimate that :class:`KinematicPIF`'s limited low-pass follows
#: (:func:`roadbank.estimators.kernels.sample.noise_update`; 0: the design span's noise throughout; the rule of
#: :mod:`roadbank.tuning.real`, twelfth stage): a long drive changes roads after the minute it was designed on
KINEMATIC_PIF_NOISE_TAU = 60.0
#: time constant (s) of the shorter running noise ratio that the limit alone reads (0: the gain's; the rule of
#: :mod:`roadbank.tuning.real`, thirteenth stage): the limit is for the heavy tail, and a burst of vibration
#: that lasts seconds is the road's noise, not a pothole
KINEMATIC_PIF_LIMIT_TAU = 8.0


class KinematicPIF(_GatedPair):
    r"""``kinematic-pif``: ``kinematic-ff`` on real roads, the default PIF while the yaw accelerates.

    In ordinary driving the sideslip acceleration that the kinematic estimate neglects is tiny and
    a model of the car's tyres (which nobody may have described) only adds error: the output is
    :class:`~roadbank.estimators.lowpass.KinematicFeedForward`. In a hard transient (a lane change,
    an S-curve near the limit) the sideslip acceleration :math:`\dot v_y` is large exactly while the
    yaw rate changes fast, and the PIF on the modified model (default weights, :class:`PIF`), which
    estimates it, is right: the output moves to it with the gate of ``pif-gated`` on the yaw part
    of the lateral jerk :math:`v_x |\dot r|` (:func:`roadbank.estimators.kernels.gated_step`):
    :math:`w = w_{ff} + g (w_{PIF} - w_{ff})`. The gate's settings were chosen by the rule of
    :mod:`roadbank.tuning.real` on training data (:data:`KINEMATIC_PIF_GATE`). Stacked states
    ``[k_lp, a_lp, vy, r, w]`` (the low-pass in its split form, :mod:`~roadbank.estimators.lowpass`: the
    kinematic estimate and the centripetal term low-passed apart, so that the kinematic estimate's
    innovation, which carries the road's noise, can be limited alone: ``clip``); ``run`` equals ``step``;
    C export as ``pif-gated``.

    This class is the blend. Every command (:func:`roadbank.vehicle.make_estimator`) builds it for a
    log whose ``ay`` the road shakes; on a quiet log, which carries little more noise than its data
    sheet says (:func:`roadbank.vehicle.is_quiet`), the model is worth more than the low-pass and
    ``kinematic-pif`` is :data:`roadbank.vehicle.QUIET_FILTER` (``pif-adaptive``) under this name.

    Parameters
    ----------
    params : VehicleParams
    cutoff, kappa : float, optional
        The low-pass's cut-off (Hz) and centripetal gain (-, default :data:`KINEMATIC_PIF_KAPPA`),
        as ``kinematic-ff``. Without a
        ``cutoff`` it is scheduled on the noise of the kinematic estimate that the PIF's ``Q_ay``
        and ``R`` (the log's, when built for a log) give, with the road prior ``bank_rate``.
    bank_rate : float, optional
        Root-mean-square bank rate of roads (rad/s); default :data:`KINEMATIC_PIF_BANK_RATE`.
    bank_speed_exp : float, optional
        Its exponent of the speed (-; default :data:`KINEMATIC_PIF_BANK_SPEED_EXP`;
        :class:`~roadbank.estimators.lowpass.KinematicLowPass`).
    lead : float, optional
        The low-pass's sampled-data lead (s, :class:`~roadbank.estimators.lowpass.KinematicLowPass`);
        default :data:`KINEMATIC_PIF_LEAD_SAMPLES` intervals of the data sheet's sensors
        (:data:`roadbank.params.ESP_RATE`; a log's own, built for it).
    tuning, Q, R, S, th, Q_ay, adapt_th : optional
        The PIF's, as :class:`~roadbank.estimators.pif.PIF` (modified model; a vehicle file's
        ``[tuning.pif-modified]`` applies).
    gate_tf, gate_release, gate_on, gate_span : float, optional
        As :class:`PIFGated`; defaults :data:`KINEMATIC_PIF_GATE`.
    gate_v_min : float, optional
        The gate's measure counts only at ``vx >= gate_v_min`` (m/s; default :data:`KINEMATIC_PIF_GATE_V_MIN`).
    clip : float, optional
        The low-pass's update limit (-, >= 0; default :data:`KINEMATIC_PIF_CLIP`; 0: linear): the low-pass
        reads ``ay`` less what its innovation exceeds ``clip`` standard deviations of the white noise
        :math:`(Q_{ay} + v_x^2 R)/\Delta t` by (:func:`roadbank.estimators.kernels.sample.limited_ay`), a
        Huber-type update: heavy-tailed road vibration (a pothole, a kerb) moves it by at most that much
        per sample, a bank or a turn that lasts passes as before. The PIF reads ``ay`` as it is. With
        ``Q_ay = 0`` (no ``ay`` noise to measure against) the low-pass is linear.
    noise_tau, noise_ref, limit_tau : float, optional
        The limited low-pass's running noise estimate (:class:`~roadbank.estimators.lowpass.KinematicLowPass`):
        its time constant (s; default :data:`KINEMATIC_PIF_NOISE_TAU`), the design span's noise variance
        ((m/s^2)^2) it is relative to, and the time constant (s; default :data:`KINEMATIC_PIF_LIMIT_TAU`) of
        the shorter one the limit reads; without ``noise_ref`` (a log's, built for it:
        :func:`roadbank.vehicle.make_estimator`) there is none.
    **kw
        Common options of :class:`~roadbank.estimators.base.Estimator` (both filters).
    """

    name = "kinematic-pif"
    state_names = ("k_lp", "a_lp", "vy", "r", "w")
    default_v_min = KINEMATIC_PIF_V_MIN

    def __init__(self, params=None, *, cutoff=None, kappa=None, bank_rate=None, lead=None, tuning=None, Q=None, R=None,
                 S=None, th=None, Q_ay=None, adapt_th=None, gate_tf=None, gate_release=None, gate_on=None,
                 gate_span=None, clip=None, noise_tau=None, noise_ref=None, limit_tau=None, bank_speed_exp=None,
                 gate_v_min=None, **kw):
        d = KINEMATIC_PIF_GATE
        if clip is not None and not (np.isfinite(clip) and clip >= 0):
            raise ValueError(f"{self.name}: clip must be >= 0 (standard deviations), got {clip}")
        opt = {k: float(d[k] if v is None else v) for k, v in (
            ("gate_tf", gate_tf), ("gate_release", gate_release), ("gate_on", gate_on), ("gate_span", gate_span),
            ("gate_v_min", KINEMATIC_PIF_GATE_V_MIN if gate_v_min is None else gate_v_min))}
        _check_gate(self.name, opt)
        kw.setdefault("v_min", self.default_v_min)       # both filters' (one schedule, one validity)
        common = {k: kw[k] for k in _COMMON if k in kw}
        self._fast = PIF(params, model="modified", tuning=tuning, Q=Q, R=R, S=S, th=th, Q_ay=Q_ay,
                         adapt_th=adapt_th, sample_rate=None, **common)
        common.setdefault("roll", self._fast.roll)
        kw["roll"] = common["roll"]
        # the low-pass's noise: the PIF's densities schedule its cut-off (unless one is given) and set its limit
        noise = dict(Q_ay=self._fast.Q_ay, R=float(self._fast.R[-1, -1]))
        if cutoff is None:
            noise["bank_rate"] = KINEMATIC_PIF_BANK_RATE if bank_rate is None else bank_rate
            noise["bank_speed_exp"] = KINEMATIC_PIF_BANK_SPEED_EXP if bank_speed_exp is None else bank_speed_exp
        self._slow = KinematicFeedForward(params, cutoff=cutoff, kappa=KINEMATIC_PIF_KAPPA if kappa is None else kappa,
                                          lead=KINEMATIC_PIF_LEAD_SAMPLES / ESP_RATE if lead is None else lead,
                                          split=True, clip=KINEMATIC_PIF_CLIP if clip is None else clip,
                                          noise_tau=KINEMATIC_PIF_NOISE_TAU if noise_tau is None else noise_tau,
                                          noise_ref=noise_ref,
                                          limit_tau=KINEMATIC_PIF_LIMIT_TAU if limit_tau is None else limit_tau,
                                          sample_rate=None, **noise, **common)
        self.cutoff, self.kappa, self.bank_rate = self._slow.cutoff, self._slow.kappa, self._slow.bank_rate
        self.bank_speed_exp = self._slow.bank_speed_exp
        self.lead, self.clip = self._slow.lead, self._slow.clip
        self.noise_tau, self.noise_ref, self.limit_tau = (self._slow.noise_tau, self._slow.noise_ref,
                                                          self._slow.limit_tau)
        self.Q, self.th, self.R, self.S, self.Q_ay = (self._fast.Q, self._fast.th, self._fast.R, self._fast.S,
                                                      self._fast.Q_ay)
        for k, v in opt.items():
            setattr(self, k, v)
        super().__init__(params, **kw)


def _blocks(tab: np.ndarray, n: int) -> tuple[np.ndarray, ...]:
    """``(F, G, H, D, J)`` of an ``lpv`` table ``tab`` of ``n`` states, one per grid row: arrays ``(g, n, n)``,
    ``(g, n, NETA)``, ``(g, 1, n)``, ``(g, 1, NETA)``, ``(g, n, NETA)`` (views of ``tab``)."""
    row, g, e = layout.lpv_row(n), tab.shape[0], layout.NETA
    return (tab[:, row.F:row.G].reshape(g, n, n), tab[:, row.G:row.H].reshape(g, n, e),
            tab[:, row.H:row.D].reshape(g, 1, n), tab[:, row.D:row.J].reshape(g, 1, e),
            tab[:, row.J:row.cont].reshape(g, n, e))


def _stack(slow, fast):
    """Block-diagonal ``F``, stacked ``G``, the slow filter's ``H`` (zero on the fast states) and ``D``."""
    Fs, Gs, Hs, Ds = slow
    Ff, Gf, _, _ = fast
    ns, nf = Fs.shape[0], Ff.shape[0]
    F = np.zeros((ns + nf, ns + nf))
    F[:ns, :ns] = Fs
    F[ns:, ns:] = Ff
    H = np.zeros((1, ns + nf))
    H[0, :ns] = np.ravel(Hs)
    return F, np.vstack([Gs, Gf]), H, np.atleast_2d(Ds)

r"""The kinematic estimate through a causal first-order low-pass (``kinematic-lp``, ``kinematic-ff``).

On real roads the lateral accelerometer carries far more than a data sheet says: road
vibration, aliased into a 10 Hz log, of 0.1-0.35 m/s^2 above 1 Hz on the shared KITTI
drives, while the sideslip acceleration :math:`\dot v_y` that the kinematic estimate
(paper eq 9) neglects is a few hundredths of that in ordinary driving. Smoothing the
kinematic estimate is then the estimator to beat; ``kinematic-lp`` is it:

.. math::
    \tau \dot x = -x + \frac{a_y - v_x r}{g}, \qquad \hat w = x, \qquad \tau = \frac{1}{2\pi f_c}

``kinematic-ff`` keeps the part of :math:`\theta` that follows the centripetal acceleration
out of the low-pass, so that it has no lag: body roll (the sprung mass rolls out of the
turn, in proportion to the lateral acceleration) and the superelevation that roads build
into curves both move with :math:`v_x r`, which the yaw-rate gyro measures almost without
noise. With :math:`a = v_x r / g` and a gain :math:`\kappa` (-, ``w`` per g of centripetal
acceleration):

.. math::
    \tau \dot x = -x + \frac{a_y - v_x r}{g} - \kappa a, \qquad \hat w = x + \kappa a

Both are linear, scheduled on speed (``lpv`` kernel: fixed-rate tables, ``step()``, the C
export); they read ``ay``, ``r`` and ``vx`` only. :math:`f_c` and :math:`\kappa` were chosen
by a written rule on training data only — the KITTI training drives and ``roadbank tune``'s
simulated training drives of the four shipped cars, built without the car
(:func:`roadbank.tuning.real.choose_lowpass`, docs/estimators.md): they describe roads and
passenger cars, not one car's tyres. In a steady turn the feed-forward cancels
(:math:`\hat w` = the low-passed kinematic estimate); it acts only while :math:`v_x r` changes,
as a lead :math:`\kappa\, \tau s/(\tau s + 1)\, a`.

**Sampled-data lead** (``lead``, s; 0 by default). The filter runs on samples. The
continuous-time low-pass, exact on a signal linear between samples, lags its input by
:math:`\tau` at low frequencies. The first-order filter of the samples themselves, the one-line
low-pass :math:`x_k = x_{k-1} + K (u_k - x_{k-1})` with the same pole
(:math:`K = 1 - e^{-h/\tau}`, :math:`h` the sample interval), weighs the newest sample more and
lags by :math:`h (1-K)/K = \tau - h/2 + O(h^2/\tau)`. Both are written as one continuous-time
filter, with a share :math:`c` of its input passed straight through, its zero at :math:`-1/(c\tau)`:

.. math::
    \hat w = (1 - c)\, x + c\, u + \kappa a, \qquad u = \frac{a_y - v_x r}{g} - \kappa a,
    \qquad \frac{\hat w - \kappa a}{u} = \frac{c \tau s + 1}{\tau s + 1},

which lags by :math:`(1 - c)\tau`. With :math:`z = 2\,\mathrm{lead}/\tau`,

.. math::
    c = 1 - \frac{z e^{-z}}{1 - e^{-z}} \;(= \mathrm{lead}/\tau + O(z^2)), \qquad c = 0 \text{ at lead} = 0,

so ``lead = h/2`` lags exactly as the sampled filter, a small lead shortens the lag by itself,
and a long one (a slow log) never passes the input through unfiltered (:math:`c < 1`).
``kinematic-pif`` takes ``lead = h/2`` (:data:`roadbank.estimators.gated.KINEMATIC_PIF_LEAD_SAMPLES`).

**Split form** (``split=True``, ``kinematic-pif``'s). The same filter with two states, the kinematic
estimate and the centripetal term low-passed apart (:math:`\mathrm{LP}(u) = \mathrm{LP}(k) - \kappa\,
\mathrm{LP}(a)`, :math:`k = (a_y - v_x r)/g`):

.. math::
    \hat w = (1 - c)\,(x_k - \kappa x_a) + c\,k + (1 - c)\,\kappa a,

so that the first state's innovation :math:`k - x_k` is the kinematic estimate's alone, which carries the
road's noise; the centripetal term's steps (a turn's entry) are not in it. ``kinematic-pif`` limits it
(:func:`roadbank.estimators.kernels.sample.limited_ay`).

**Running noise** (``noise_tau``, s; with a limit). The cut-off is designed for the noise of the log's first
minute; a long drive changes roads. With ``noise_tau > 0`` and the design span's noise ``noise_ref``, the
limited update follows a running estimate of the noise (:func:`roadbank.estimators.kernels.sample.noise_update`:
the ratio :math:`m` of the kinematic acceleration's first differences, time constant ``noise_tau``, to their
variance ``noise_ref`` on the design span): its limit scales with :math:`\sqrt m`, and the update of its states
(both, in the split form) with :math:`m^{-1/3}`, as the cut-off :func:`cutoff_for_noise` gives :math:`m` times
the designed noise (:func:`roadbank.estimators.kernels.sample.scale_update`). With ``limit_tau > 0`` the limit
reads a second ratio of the same measure with that (shorter) time constant: the limit, whose job is the
heavy tail, follows a burst within seconds; the gain, whose job is the road's noise level, over a minute.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..params import VehicleParams
from .base import DesignInputs, ScheduledObserver
from .kinematic import KINEMATIC_V_MIN

#: ``kinematic-lp``'s cut-off (Hz): the rule of :mod:`roadbank.tuning.real` with kappa = 0
LP_CUTOFF_HZ = 0.5
#: ``kinematic-ff``'s cut-off (Hz) and centripetal gain (-): the rule of :mod:`roadbank.tuning.real`
FF_CUTOFF_HZ = 0.6
FF_KAPPA = 0.2
#: bounds (Hz) of a cut-off scheduled on the noise (:func:`cutoff_for_noise`)
CUTOFF_MIN_HZ, CUTOFF_MAX_HZ = 0.05, 5.0
#: the speed (m/s) at which a bank-rate prior that grows with speed (``bank_speed_exp``) is the design's ``bank_rate``
BANK_SPEED_REF = 10.0


def cutoff_for_noise(noise_density: float, bank_rate: float) -> float:
    r"""Cut-off (Hz) of the first-order low-pass that best trades noise against lag.

    The input is the bank signal plus white noise of two-sided density :math:`q`
    (``noise_density``, rad^2 s: a sampled white sequence of variance :math:`v` at rate
    :math:`f_s` has :math:`q = v / f_s`); the bank changes at a root-mean-square rate
    :math:`\omega_b` (``bank_rate``, rad/s). The low-pass passes the noise variance
    :math:`q \pi f_c` and lags by :math:`\tau = 1/(2\pi f_c)`, an error of variance
    :math:`\omega_b^2 \tau^2`. Their sum is least at

    .. math::
        f_c = \left(\frac{\omega_b^2}{2 \pi^3 q}\right)^{1/3},

    clipped to [:data:`CUTOFF_MIN_HZ`, :data:`CUTOFF_MAX_HZ`]. A quiet 100 Hz sensor then gets
    a fast filter and a 10 Hz log shaken by the road a slow one, from the same road prior.
    """
    if not (noise_density > 0 and np.isfinite(noise_density)):
        return CUTOFF_MAX_HZ
    fc = (bank_rate ** 2 / (2.0 * np.pi ** 3 * noise_density)) ** (1.0 / 3.0)
    return float(np.clip(fc, CUTOFF_MIN_HZ, CUTOFF_MAX_HZ))


@dataclass(frozen=True)
class LowPassDesign(DesignInputs):
    """Design inputs of :class:`KinematicLowPass`: the cut-off ``cutoff`` (Hz; None: scheduled on the
    noise), the centripetal feed-forward gain ``kappa`` (-), and for a scheduled cut-off the bank rate
    of roads ``bank_rate`` (rad/s), the noise densities ``Q_ay`` ((m/s^2)^2 s) and ``R`` ((rad/s)^2 s),
    the sampled-data lead ``lead`` (s; module docstring), ``split``: the two-state form (module
    docstring), the update's limit ``clip`` (-, standard deviations of ``Q_ay`` and ``R``; 0: linear) and its
    running noise estimate's time constant ``noise_tau`` (s; 0: none) and reference variance ``noise_ref``
    ((m/s^2)^2), and the time constant ``limit_tau`` (s; 0: ``noise_tau``'s) of the one its limit reads (module
    docstring)."""

    cutoff: float | None
    kappa: float
    bank_rate: float | None = None
    Q_ay: float | None = None
    R: float | None = None
    lead: float = 0.0
    split: bool = False
    clip: float = 0.0
    noise_tau: float = 0.0
    noise_ref: float = 0.0
    limit_tau: float = 0.0
    bank_speed_exp: float = 0.0


def lowpass_cutoff(d: LowPassDesign, vx: float) -> float:
    """The cut-off (Hz) at ``vx`` (m/s): ``d.cutoff``, or :func:`cutoff_for_noise` of the kinematic
    estimate's noise density :math:`(Q_{ay} + v_x^2 R)/g^2` and the bank rate
    ``d.bank_rate (vx / BANK_SPEED_REF)^d.bank_speed_exp`` (``vx`` taken as at least 0.1 m/s)."""
    if d.cutoff is not None:
        return d.cutoff
    # a design without a cut-off has the bank rate and both noise densities
    bank = float(d.bank_rate) * (max(vx, 0.1) / BANK_SPEED_REF) ** d.bank_speed_exp  # type: ignore[arg-type]
    return cutoff_for_noise((d.Q_ay + vx * vx * d.R) / d.params.g ** 2, bank)  # type: ignore[operator]


def lead_share(lead_per_tau: float) -> float:
    """The share ``c`` (-) of the low-pass's input passed straight through for a lead of ``lead_per_tau``
    time constants: ``1 - z e^-z / (1 - e^-z)``, ``z = 2 lead_per_tau`` (module docstring; 0 at 0)."""
    z = 2.0 * lead_per_tau
    if z < 1e-8:
        return lead_per_tau                     # the series' first term, exact to 1e-16
    return 1.0 - z * math.exp(-z) / -math.expm1(-z)


def lowpass_observer(d: LowPassDesign, vx: float):
    """``(F, G, H, D)`` of the low-passed kinematic estimate at ``vx`` (m/s); inputs ``[delta_f, ay, r]``;
    the share ``c`` of the input passed through is :func:`lead_share` of ``2 pi f_c lead`` (module docstring).
    ``d.split``: the states are the kinematic estimate and the centripetal term low-passed apart (module
    docstring), the same filter."""
    g, wc, k = d.params.g, 2.0 * np.pi * lowpass_cutoff(d, vx), d.kappa
    c = lead_share(wc * d.lead)
    ff = np.array([[0.0, 0.0, k * vx / g]])                   # the feed-forward kappa a per eta
    # a limited low-pass reads its ay in the steering's slot (kernels.sample.limited_ay)
    iay = 0 if d.clip > 0 else 1
    kin = np.zeros((1, 3))
    kin[0, iay], kin[0, 2] = 1.0 / g, -vx / g                 # the kinematic estimate per eta
    if d.split:
        u = np.vstack([kin, [[0.0, 0.0, vx / g]]])
        return -wc * np.eye(2), wc * u, np.array([[1.0 - c, -k * (1.0 - c)]]), c * kin + (1.0 - c) * ff
    u = np.zeros((1, 3))
    u[0, iay], u[0, 2] = 1.0 / g, -(1.0 + k) * vx / g         # the filter's input per eta
    F = np.array([[-wc]])
    return F, wc * u, np.array([[1.0 - c]]), c * u + ff


class KinematicLowPass(ScheduledObserver):
    """The kinematic estimate low-passed, optionally with the centripetal feed-forward (module docstring).

    Parameters
    ----------
    params : VehicleParams, optional
        Only ``g`` and the roll model (for ``phi_b``) are used.
    cutoff : float, optional
        Cut-off frequency ``f_c`` of the first-order low-pass (Hz, > 0).
    kappa : float, optional
        Centripetal feed-forward gain (-: ``w`` per g of ``vx r``); 0 gives ``kinematic-lp``.
    bank_rate : float, optional
        With it and no ``cutoff``, the cut-off is scheduled on speed from the noise of the
        kinematic estimate, :math:`(Q_{ay} + v_x^2 R)/g^2`, and this root-mean-square bank rate
        of roads (rad/s) by :func:`cutoff_for_noise`.
    bank_speed_exp : float, optional
        With ``bank_rate``: the bank rate at ``vx`` is ``bank_rate (vx / BANK_SPEED_REF)^bank_speed_exp``
        (-, >= 0; default 0: a rate in time; 1: a gradient along the road, crossed faster at speed).
    Q_ay, R : float, optional
        Noise densities of ``ay`` ((m/s^2)^2 s) and of the yaw rate ((rad/s)^2 s) for the
        scheduled cut-off and the limit (default 0: only the other counts).
    lead : float, optional
        Sampled-data lead (s, >= 0; default 0): about ``lead`` less lag than the low-pass's
        ``1/(2 pi f_c)`` (exactly that of the sampled filter at ``lead = h/2``; module docstring).
    split : bool, optional
        Two states, the kinematic estimate and the centripetal term each low-passed (``k_lp``,
        ``a_lp``), instead of one: the same filter, whose first state's innovation is the kinematic
        estimate's alone (what ``kinematic-pif`` limits; module docstring). Default False.
    clip : float, optional
        The update's limit (-, >= 0; default 0, linear): the low-pass reads ``ay`` less what the kinematic
        estimate's innovation exceeds ``clip`` standard deviations of the white noise
        :math:`(Q_{ay} + v_x^2 R)/\\Delta t` by (:func:`roadbank.estimators.kernels.sample.limited_ay`), a
        Huber-type update for heavy-tailed road vibration. Needs ``Q_ay > 0`` (without it: linear) and no
        feed-forward in the one-state form (``kappa = 0`` or ``split``: the feed-forward's own steps would be
        in the innovation).
    noise_tau, noise_ref : float, optional
        With a limit: the time constant (s, >= 0; default 0, none) of the running noise estimate that the limit
        and the gain follow, and the variance ((m/s^2)^2, > 0) of the kinematic acceleration's noise on the
        design span it is relative to (:func:`roadbank.signals.diff_noise_std` squared; module docstring). Without
        ``noise_ref`` (or without a limit) there is none.
    limit_tau : float, optional
        With a running noise estimate: the time constant (s, >= 0; default 0: ``noise_tau``'s estimate) of a
        second, shorter one that the limit reads (module docstring): the limit follows a burst of vibration
        within seconds, the gain the road over a minute.
    **kw
        Common options of :class:`~roadbank.estimators.base.Estimator`; ``v_min`` (m/s) defaults to
        :data:`~roadbank.estimators.kinematic.KINEMATIC_V_MIN` (the estimate holds at any speed).
    """

    uses = (False, True, True)
    default_v_min = KINEMATIC_V_MIN
    state_names = ("w_lp",)
    label = "kinematic-lp"
    defaults = dict(cutoff=LP_CUTOFF_HZ, kappa=0.0)
    design_type = LowPassDesign
    if TYPE_CHECKING:
        @property
        def design(self) -> LowPassDesign: ...     # an instance of design_type

    def __init__(self, params=None, *, cutoff=None, kappa=None, bank_rate=None, Q_ay=None, R=None, lead=None,
                 split=False, clip=None, noise_tau=None, noise_ref=None, limit_tau=None, bank_speed_exp=None, **kw):
        scheduled = cutoff is None and bank_rate is not None
        self.split = bool(split)
        if self.split:
            self.state_names = ("k_lp", "a_lp")
        self.cutoff = None if scheduled else float(self.defaults["cutoff"] if cutoff is None else cutoff)
        self.kappa = float(self.defaults["kappa"] if kappa is None else kappa)
        self.bank_rate = float(bank_rate) if scheduled else None
        bexp = float(0.0 if bank_speed_exp is None else bank_speed_exp)
        if not (np.isfinite(bexp) and bexp >= 0):
            raise ValueError(f"{self.label}: bank_speed_exp must be >= 0, got {bank_speed_exp}")
        self.bank_speed_exp = bexp if scheduled else 0.0
        clip = float(self.defaults.get("clip", 0.0) if clip is None else clip)
        if not (np.isfinite(clip) and clip >= 0):
            raise ValueError(f"{self.label}: clip must be >= 0 (standard deviations), got {clip}")
        noise = scheduled or (clip > 0 and Q_ay is not None)        # the densities take part in the design
        self.Q_ay = float(Q_ay or 0.0) if noise else None
        self.R = float(R or 0.0) if noise else None
        # no ay noise to measure the innovation against: the linear low-pass, not a frozen one
        self.clip = clip if (self.Q_ay or 0.0) > 0 else 0.0
        if self.clip > 0 and self.kappa != 0 and not self.split:
            raise ValueError(f"{self.label}: a limit needs kappa = 0 or the split form (split=True)")
        tau = float(self.defaults.get("noise_tau", 0.0) if noise_tau is None else noise_tau)
        ref = float("nan") if noise_ref is None else float(noise_ref)
        if not (np.isfinite(tau) and tau >= 0) or not (np.isnan(ref) or ref > 0 and np.isfinite(ref)):
            raise ValueError(f"{self.label}: need noise_tau >= 0 s and noise_ref > 0 (m/s^2)^2, got {noise_tau}, "
                             f"{noise_ref}")
        # a running noise estimate needs the limit it scales and the design span's noise it is relative to
        running = self.clip > 0 and tau > 0 and ref > 0
        self.noise_tau, self.noise_ref = (tau, ref) if running else (0.0, 0.0)
        ltau = float(self.defaults.get("limit_tau", 0.0) if limit_tau is None else limit_tau)
        if not (np.isfinite(ltau) and ltau >= 0):
            raise ValueError(f"{self.label}: limit_tau must be >= 0 s, got {limit_tau}")
        self.limit_tau = ltau if running else 0.0
        if not scheduled and not (np.isfinite(self.cutoff) and self.cutoff > 0):
            raise ValueError(f"{self.label}: cutoff must be > 0 Hz, got {cutoff}")
        if scheduled and not (self.bank_rate > 0 and np.isfinite(self.bank_rate) and self.Q_ay >= 0
                              and self.R >= 0 and np.isfinite(self.Q_ay + self.R)):
            raise ValueError(f"{self.label}: need bank_rate > 0 and Q_ay, R >= 0, got {bank_rate}, {Q_ay}, {R}")
        if not np.isfinite(self.kappa):
            raise ValueError(f"{self.label}: kappa must be finite, got {kappa}")
        self.lead = float(0.0 if lead is None else lead)
        if not (np.isfinite(self.lead) and self.lead >= 0):
            raise ValueError(f"{self.label}: lead must be >= 0 s, got {lead}")
        self.name = self.label
        super().__init__(params, **kw)

    def _design_fields(self) -> dict:
        return dict(cutoff=self.cutoff, kappa=self.kappa, bank_rate=self.bank_rate, Q_ay=self.Q_ay, R=self.R,
                    lead=self.lead, split=self.split, clip=self.clip, noise_tau=self.noise_tau,
                    noise_ref=self.noise_ref, limit_tau=self.limit_tau, bank_speed_exp=self.bank_speed_exp)

    def _table_inputs(self) -> LowPassDesign:
        """:attr:`design` with the car reduced to its ``g``, all that the tables read (:func:`lowpass_observer`,
        :meth:`limit_constants`): the shipped cars share one low-pass design (:func:`roadbank.vehicle.design_car`
        builds the default for each of them on every log whose car is not described)."""
        return dataclasses.replace(self.design, params=VehicleParams(g=self.params.g))

    @property
    def limited(self) -> bool:           # type: ignore[override]
        """Whether the update is limited (``clip > 0`` with an ``ay`` noise density)."""
        return self.clip > 0

    def limit_constants(self) -> list[float]:
        if not self.limited:
            return []
        return [self.clip, float(self.params.g), float(self.Q_ay or 0.0), float(self.R or 0.0), self.noise_tau,
                self.noise_ref, float(len(self.state_names)), self.limit_tau]

    def _design(self):
        tab, n, extra = super()._design()
        return tab, n, np.concatenate([np.asarray(extra, float), self.limit_constants()])

    def cutoff_at(self, vx: float) -> float:
        """The low-pass's cut-off (Hz) at ``vx`` (m/s): fixed, or scheduled on the noise (:func:`lowpass_cutoff`)."""
        return lowpass_cutoff(self.design, vx)

    def observer(self, vx: float):
        """``(F, G, H, D)`` at ``vx`` (m/s); inputs ``[delta_f, ay, r]`` (:func:`lowpass_observer`)."""
        return lowpass_observer(self.design, vx)


class KinematicFeedForward(KinematicLowPass):
    """``kinematic-ff``: :class:`KinematicLowPass` with the centripetal feed-forward (:data:`FF_KAPPA`)."""

    label = "kinematic-ff"
    defaults = dict(cutoff=FF_CUTOFF_HZ, kappa=FF_KAPPA)

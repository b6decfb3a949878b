r"""``kinematic-smoother`` — the kinematic estimate low-passed forward and backward over the whole log.

An *offline* estimator (beyond the paper), the offline counterpart of ``kinematic-lp``: for
post-processing, bank maps and reference signals, where the whole log is known before the bank
is needed. A causal low-pass must trade lag against noise; run over the log once forward and
once backward (in reversed time) and averaged, the two lags cancel:

.. math::
    \hat w = \tfrac12 \left( \mathrm{LP}_{\rightarrow}(u) + \mathrm{LP}_{\leftarrow}(u) \right),
    \qquad u = \frac{a_y - v_x r}{g},

with :math:`\mathrm{LP}` the first-order low-pass of ``kinematic-lp`` (:mod:`.lowpass`, cut-off
:math:`f_c`, :math:`\tau = 1/(2\pi f_c)`). For a first-order filter the average of the two passes
is the zero-phase filter :math:`\mathrm{Re}\, H(j\omega) = |H(j\omega)|^2 = 1/(1 + \omega^2\tau^2)`:
what running it forward and then backward over its own output (``filtfilt``) gives, without the
second pass's start at the first pass's transient. Its cut-off was chosen by a written rule on
training data only (:func:`roadbank.tuning.real.choose_smoother`, docs/estimators.md).

Interface as ``pif-smoother``: :meth:`KinematicSmoother.run` returns the smoothed estimate of the
log given; :meth:`~roadbank.estimators.base.Estimator.step` is the forward filter's (the smoothed
estimate of the newest sample given the samples so far). A log processed in chunks
(``run(reset=False)``) is smoothed as a whole when each chunk comes with the next one as
``lookahead`` (covering :attr:`KinematicSmoother.lookahead_s` or reaching the log's end). Invalid
samples (``vx < v_min``, non-finite inputs) are stepped over by both passes, each restarting after
a gap longer than ``max_gap``; the output is valid where both passes are, and held (0 before the
first such sample) where either is not. The body roll (for
``phi_b``) is the forward pass's. Not for an ECU: no C export.
"""

from __future__ import annotations

import numpy as np

from ..signals import Estimate, Signals, concat_signals
from .lowpass import KinematicLowPass

#: ``kinematic-smoother``'s cut-off (Hz): the rule of :func:`roadbank.tuning.real.choose_smoother`
SMOOTHER_CUTOFF_HZ = 0.5
#: ``kinematic-smoother``'s limit of each pass's update (-, standard deviations of the log's noise; the
#: eleventh stage of :mod:`roadbank.tuning.real`); acts where the log's noise is given (``Q_ay``, as
#: :func:`roadbank.vehicle.make_estimator` gives it)
SMOOTHER_CLIP = 2.5


class KinematicSmoother(KinematicLowPass):
    """``kinematic-smoother``: :class:`~roadbank.estimators.lowpass.KinematicLowPass` forward and backward,
    averaged (module docstring).

    Parameters
    ----------
    params : VehicleParams, optional
        Only ``g`` and the roll model (for ``phi_b``) are used.
    cutoff : float, optional
        Cut-off (Hz) of each pass; default :data:`SMOOTHER_CUTOFF_HZ`.
    **kw
        The other options of :class:`~roadbank.estimators.lowpass.KinematicLowPass` (``kappa`` 0
        by default; ``clip`` :data:`SMOOTHER_CLIP`, acting with the log's ``Q_ay`` and ``R``), for both passes.
    """

    label = "kinematic-smoother"
    defaults = dict(cutoff=SMOOTHER_CUTOFF_HZ, kappa=0.0, clip=SMOOTHER_CLIP)
    #: the outputs of :meth:`run` use later samples (not causal)
    offline = True
    #: the causal estimator of its forward pass (what an ECU runs instead)
    forward_filter = "kinematic-lp"

    def __init__(self, params=None, **kw):
        super().__init__(params, **kw)
        opts = {**kw, "kappa": self.kappa, "lead": self.lead, "clip": self.clip, "Q_ay": self.Q_ay, "R": self.R}
        if self.cutoff is not None:
            opts["cutoff"] = self.cutoff
        # the same design, run in reversed time; on the forward pass's fixed rate (not one detected anew
        # in each chunk's reversed time, which would make a streamed log differ from one run)
        self._reverse = KinematicLowPass(self.params, **{**opts, "sample_rate": None})
        self._reverse_dt: float | None = None

    @property
    def lookahead_s(self) -> float:
        """Samples after a log's end (s) that make :meth:`run` agree with smoothing the whole: :func:`lookahead_of`
        the low-pass."""
        return lookahead_of(self)

    def reset(self) -> None:
        """Forget all history, the last output held for the next chunk too (:func:`both_ways`)."""
        super().reset()
        self._held = None

    def run(self, signals: Signals, *, reset: bool = True, lookahead: Signals | None = None) -> Estimate:
        """Smoothed estimate over the log ``signals`` (module docstring); ``reset`` as
        :meth:`~roadbank.estimators.base.Estimator.run`. Units: ``w`` (-), angles (rad).

        ``lookahead``: the samples that follow ``signals``, of which the first :attr:`lookahead_s`
        seconds are the later samples of the backward pass; the forward state stays that at the end
        of ``signals``, so consecutive chunks, each with the next one as ``lookahead``, give what one
        run over the whole log gives (to about 1e-10) when each covers :attr:`lookahead_s` or reaches
        the log's end.
        """
        return both_ways(self, super().run(signals, reset=reset), signals, lookahead, reset)


def lookahead_of(est) -> float:
    """The lookahead (s) of a two-way smoother whose pass is the ``lpv`` observer ``est``: 25 time constants of its
    slowest pole over the speed grid, after which a later sample's influence is below 1e-10."""
    n = est._nstate
    F = est._tab_cont[:, :n * n].reshape(-1, n, n)
    return 25.0 / float(np.min(-np.linalg.eigvals(F).real))


def reversed_in_time(s: Signals) -> Signals:
    """``s`` in reversed time (``t' = t_end - t``): every channel's samples in reverse order, the roll rate negated
    (the rate of the angle read backwards); ``ay``, ``r`` and ``vx`` as they are, the kinematic estimate being a
    function of each sample."""
    t = s.t
    return Signals(t[-1] - t[::-1], s.vx[::-1], s.ay[::-1], s.r[::-1], s.delta_f[::-1],
                   None if s.p is None else -s.p[::-1])


def both_ways(est, fwd: Estimate, signals: Signals, lookahead: Signals | None, reset: bool = True) -> Estimate:
    """The smoothed estimate of an offline estimator ``est`` (its ``_reverse``: the same design run in reversed
    time, and its ``lookahead_s``; ``_reverse_dt``: the rate the reverse pass was last set to) from its forward pass
    ``fwd`` over ``signals`` and the samples ``lookahead`` that follow them: the two passes averaged where both are
    valid, held where either is not (before the first such sample: 0 after ``reset``, else the last output of the
    previous chunk, ``est._held``, so that chunks are one run); the body roll is the forward pass's, the
    forward state ``w_*`` kept and the backward one beside it (``<state>_backward``). Units: ``w`` (-), angles (rad)."""
    n = len(signals)
    whole = signals
    if lookahead is not None and len(lookahead):
        m = np.flatnonzero(lookahead.t > signals.t[-1] + est.lookahead_s)
        whole = concat_signals([signals, lookahead[:m[0] + 1] if m.size else lookahead])
    if est._reverse_dt != est.fixed_dt:
        est._reverse.set_sample_rate(None if est.fixed_dt is None else 1.0 / est.fixed_dt)
        est._reverse_dt = est.fixed_dt
    back = est._reverse.run(reversed_in_time(whole))
    wb, valid_b = back.w[::-1][:n], back.valid[::-1][:n]
    both = fwd.valid & valid_b
    w = np.where(both, 0.5 * (fwd.w + wb), 0.0)
    settled_b = back.settled[::-1][:n]
    alone = getattr(est, "passes", "average") == "settled"   # where one pass has settled and the other not: that one
    if alone:
        w = np.where(both & fwd.settled & ~settled_b, fwd.w, np.where(both & settled_b & ~fwd.settled, wb, w))
    settled = fwd.settled | settled_b if alone or getattr(est, "settled_by", "forward") == "either" else fwd.settled
    last = np.maximum.accumulate(np.where(both, np.arange(n), -1))
    held = ~both & (last >= 0)
    w[held] = w[last[held]]                   # held where a pass does not use the sample, 0 before the first
    phi = fwd.states["phi"].copy()
    phi[held] = phi[last[held]]
    before = ~both & (last < 0)
    if not reset and getattr(est, "_held", None) is not None:
        w[before], phi[before] = est._held    # ... or the previous chunk's last output
    est._held = (float(w[-1]), float(phi[-1]))
    theta = np.arcsin(np.clip(w, -1.0, 1.0))
    valid = both & (np.abs(w) <= np.sin(est.max_angle))
    first = est.state_names[0]
    states = {first: fwd.states[first].copy(), f"{first}_backward": wb.copy(), "phi": phi}
    return Estimate(est.name, fwd.t, w, theta, theta - phi, valid, states, valid & settled)

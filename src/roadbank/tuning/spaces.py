"""Search spaces of the tunable estimators: which options ``roadbank tune`` varies, and how.

Each :class:`SearchSpace` maps a point ``x`` of a box (the optimiser's coordinates, mostly
log10 of a weight) to the keyword options of :func:`roadbank.estimators.make`, and knows the
point of the estimator's current default (the optimiser's start).

* ``pif-modified``: ``R`` is fixed to the yaw-rate sensor's noise density
  (:func:`roadbank.estimators.pif.yaw_rate_noise_density`); ``x = (log10(Q/R), log10(th R))``.
  Scaling ``(Q, R, th)`` to ``(kQ, kR, th/k)`` scales ``P`` by ``k`` and leaves the filter
  unchanged, so fixing ``R`` loses nothing; ``S = 1`` (only ``th S`` enters).
* ``pif-rate``: as ``pif-modified`` plus ``log10(Q_rate/R)``.
* ``pif-adaptive``: as ``pif-modified`` plus the design friction coefficient ``mu`` of its
  rear-stiffness schedule (not in :data:`TUNABLE`: tuned on request, ``names=``).
* ``pif-rate-adaptive``: as ``pif-rate`` plus ``mu`` and ``log10(tau / s)``, the release time
  constant of the excitation's peak follower (on request).
* ``pif-gated``: as ``pif-modified`` (its slow filter) plus ``log10(fast_Q_rate/R)``, the fast
  filter's bank-rate noise, the yaw jerk ``gate_on`` (m/s^3) where the gate starts to open and
  ``log10(gate_span / (m/s^3))`` (on request; the fast filter's ``Q`` and ``th`` and the gate's time
  constants stay at :data:`roadbank.estimators.gated.GATED_TUNING`).
* ``kalman``: ``R`` stays at its default; ``x = log10`` of the three process-noise densities.
* ``pio-modified``: poles ``-10^a (1, 1 + b, (1 + b)(1 + c))``, ``x = (a, b, c)``.
* ``dfc``: ``x = log10(a_ref / (m/s^2))``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..estimators import TUNED_AS, dfc, kalman, pio
from ..estimators.gated import GATED_TUNING
from ..estimators.pif import (ADAPTIVE_TUNING, DEFAULT_TUNING, Q_AY_ESP, R_ESP, RATE_ADAPTIVE_TUNING, RATE_TUNING,
                              yaw_rate_noise_density)

_PIF_FAMILY = ("pif-modified", "pif-rate", "pif-adaptive", "pif-rate-adaptive", "pif-gated")
_DEFAULTS = {"pif-modified": DEFAULT_TUNING, "pif-rate": RATE_TUNING, "pif-adaptive": ADAPTIVE_TUNING,
             "pif-rate-adaptive": RATE_ADAPTIVE_TUNING, "pif-gated": {**DEFAULT_TUNING, **GATED_TUNING}}
#: coordinates of the PIF variants after ``log10(Q/R), log10(th R)``: label -> (option, option
#: at coordinate ``x`` for the sensor's ``R``, coordinate of option value ``v``)
_PIF_EXTRA = {
    "log10(Q_rate/R)": ("Q_rate", lambda x, R: R * 10.0 ** x, lambda v, R: np.log10(v / R)),
    "mu": ("mu", lambda x, R: x, lambda v, R: v),
    "log10(tau/s)": ("tau", lambda x, R: 10.0 ** x, lambda v, R: np.log10(v)),
    "log10(fast_Q_rate/R)": ("fast_Q_rate", lambda x, R: R * 10.0 ** x, lambda v, R: np.log10(v / R)),
    "gate_on": ("gate_on", lambda x, R: x, lambda v, R: v),
    "log10(gate_span)": ("gate_span", lambda x, R: 10.0 ** x, lambda v, R: np.log10(v)),
}


@dataclass(frozen=True)
class SearchSpace:
    """Options of one estimator as a function of a point in a box.

    Attributes
    ----------
    name : str
        Estimator (one of :data:`roadbank.estimators.NAMES`).
    labels : tuple of str
        Meaning of each coordinate.
    bounds : tuple of (lo, hi)
    fixed : dict
        Options that do not vary (e.g. the PIF's ``R``).
    """

    name: str
    labels: tuple
    bounds: tuple
    fixed: dict

    def options(self, x) -> dict:
        """Keyword options of :func:`roadbank.estimators.make` at ``x``."""
        x = [float(v) for v in x]
        f = self.fixed
        if self.name in _PIF_FAMILY:
            R = f["R"]
            out = {"Q": R * 10.0 ** x[0], "R": R, "S": 1.0, "th": 10.0 ** x[1] / R}
            for label, v in zip(self.labels[2:], x[2:]):
                option, to_option, _ = _PIF_EXTRA[label]
                out[option] = to_option(v, R)
            return out
        if self.name == "kalman":
            return {"q": [10.0 ** v for v in x], "R": list(f["R"])}
        if self.name == "pio-modified":
            p1 = 10.0 ** x[0]
            p2 = p1 * (1.0 + x[1])
            return {"poles": [-p1, -p2, -p2 * (1.0 + x[2])]}
        if self.name == "dfc":
            return {"a_ref": 10.0 ** x[0]}
        raise ValueError(f"no search space for {self.name!r}")

    def start(self) -> np.ndarray:
        """The point of the estimator's current default (clipped into the box)."""
        if self.name in _PIF_FAMILY:
            d = _DEFAULTS[self.name]
            x = [np.log10(d["Q"] / R_ESP), np.log10(d["th"] * R_ESP)]       # Q/R and th R as tuned
            for label in self.labels[2:]:
                option, _, to_x = _PIF_EXTRA[label]
                x.append(to_x(d[option], R_ESP))
        elif self.name == "kalman":
            x = list(np.log10(kalman.DEFAULT_Q))
        elif self.name == "pio-modified":
            p = sorted(-np.asarray(pio.DEFAULT_POLES_MODIFIED))
            x = [np.log10(p[0]), p[1] / p[0] - 1.0, p[2] / p[1] - 1.0]
        else:
            x = [np.log10(dfc.A_REF)]
        lo, hi = np.array(self.bounds).T
        return np.clip(np.array(x, float), lo, hi)


#: estimators ``roadbank tune`` tunes, in order
TUNABLE = ("pif-modified", "pif-rate", "kalman", "pio-modified", "dfc")
#: further estimators ``roadbank tune --estimators`` accepts (not tuned by default: each design
#: solves a Riccati equation per speed *and* excitation point, about 5x the time of pif-modified;
#: pif-gated designs two filters and runs a 7-state observer)
ON_REQUEST = ("pif-adaptive", "pif-rate-adaptive", "pif-gated")


def search_space(name: str, sensors=None) -> SearchSpace:
    """The :class:`SearchSpace` of ``name`` for a car with ``sensors``
    (:class:`roadbank.sim.SensorConfig`; default the paper's ESP sensors)."""
    if name in _PIF_FAMILY:
        # the sensors' noise densities, held fixed (the weights are searched relative to R)
        fixed = {"R": R_ESP, "Q_ay": Q_AY_ESP} if sensors is None else {
            "R": yaw_rate_noise_density(sensors.yaw_rate.noise_std, sensors.yaw_rate.resolution, sensors.rate),
            "Q_ay": yaw_rate_noise_density(sensors.ay.noise_std, sensors.ay.resolution, sensors.rate)}
        if name == "pif-modified":
            return SearchSpace(name, ("log10(Q/R)", "log10(th R)"), ((1.0, 7.0), (-7.0, -1.5)), fixed)
        if name == "pif-gated":
            return SearchSpace(name, ("log10(Q/R)", "log10(th R)", "log10(fast_Q_rate/R)", "gate_on",
                                      "log10(gate_span)"),
                               ((1.0, 7.0), (-7.0, -1.5), (-2.0, 8.0), (0.0, 10.0), (-0.5, 1.5)), fixed)
        if name == "pif-adaptive":
            return SearchSpace(name, ("log10(Q/R)", "log10(th R)", "mu"), ((1.0, 7.0), (-7.0, -1.5), (0.8, 2.0)),
                               fixed)
        rate = (("log10(Q/R)", "log10(th R)", "log10(Q_rate/R)"), ((1.0, 7.0), (-7.0, -1.5), (-2.0, 8.0)))
        if name == "pif-rate-adaptive":
            return SearchSpace(name, rate[0] + ("mu", "log10(tau/s)"), rate[1] + ((0.8, 2.0), (-1.5, 0.5)),
                               fixed)
        return SearchSpace(name, *rate, fixed)
    if name == "kalman":
        return SearchSpace(name, ("log10 q_vy", "log10 q_r", "log10 q_w"),
                           ((-2.0, 3.0), (-4.0, 1.0), (-5.0, 0.0)), {"R": tuple(kalman.DEFAULT_R)})
    if name == "pio-modified":
        return SearchSpace(name, ("log10 |p1|", "p2/p1 - 1", "p3/p2 - 1"),
                           ((-1.5, 1.5), (0.05, 3.0), (0.05, 3.0)), {})
    if name == "dfc":
        return SearchSpace(name, ("log10 a_ref",), ((-0.5, 1.7),), {})
    if name in TUNED_AS:
        raise ValueError(f"{name!r} is not tuned on its own: it runs {TUNED_AS[name]} with that one's weights "
                         f"(a vehicle file's [tuning.{TUNED_AS[name]}] table); tune {TUNED_AS[name]}")
    raise ValueError(f"{name!r} is not tunable; tunable: {', '.join(TUNABLE + ON_REQUEST)}")

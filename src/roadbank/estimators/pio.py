r"""PIO — proportional-integral observers (paper eq 26-32, Table 3).

Both run on a model augmented with ``w`` as an integral state:

.. math::
    \dot{\hat x} = A \hat x + B u + K_1 (y - \hat y) + E \hat w,\qquad
    \dot{\hat w} = K_2 (y - \hat y)

i.e. a Luenberger observer on the augmented model with gain ``[K1; K2]``.

* ``pio-original``: original model (input ``delta_f``, outputs ``[ay, r]``).
  ``gains="table3"`` (default, faithful) uses Table 3 with recovered signs,
  ``K1 = [[1, +vx^2], [0, +(Cf Lf^2 + Cr Lr^2)/(2 Iz vx)]]``, ``K2 = [0, -2]``:
  the ``+vx^2`` sign is forced (with ``-vx^2`` the error dynamics are unstable
  at every speed); for ``K1[1,1]`` both signs are stable and ``+`` is the
  better damped (poles -10.1 +- 54.3j vs -3.4 +- 55.1j at 22 m/s). The slowest
  pole is about -0.039 1/s at 22 m/s. ``gains="placed"`` places the poles at
  ``poles`` instead.
* ``pio-modified``: modified model (input ``ay``, output ``r``); the paper gives
  no gains, so they are placed per speed (default poles ``(-2, -4, -6)`` 1/s,
  of the order of the PIF's dominant poles at highway speed).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .base import DesignInputs, ScheduledObserver, augmented_design_model
from .synthesis import place_observer

DEFAULT_POLES_MODIFIED = (-2.0, -4.0, -6.0)
DEFAULT_POLES_ORIGINAL = (-2.0, -4.0, -6.0)


def table3_gain(params, vx: float) -> np.ndarray:
    """Table 3 gain ``[K1; K2]`` (3 x 2) of the original-model PIO with recovered signs."""
    p = params
    k22 = (p.Cf * p.Lf**2 + p.Cr * p.Lr**2) / (2.0 * p.Iz * vx)
    return np.array([[1.0, vx**2], [0.0, k22], [0.0, -2.0]])


@dataclass(frozen=True)
class PIODesign(DesignInputs):
    """Design inputs of :class:`PIO`: the model, the gains (``"table3"``, ``"placed"``) and the poles (1/s)."""

    model: str
    gains: str
    poles: tuple


def pio_gain(d: PIODesign, model, vx: float) -> np.ndarray:
    """Observer gain ``[K1; K2]`` at ``vx`` (m/s) for the augmented design ``model``."""
    if d.gains == "table3":
        return table3_gain(d.params, vx)
    return place_observer(model[0], model[2], d.poles)


class PIO(ScheduledObserver):
    """Proportional-integral observer on the original or the modified model.

    Parameters
    ----------
    model : {"original", "modified"}
    gains : {"table3", "placed"}
        Original model only: the paper's Table 3 gains or pole placement.
    poles : sequence of 3 floats (1/s)
        Observer poles for pole placement (distinct, negative real parts).
    """

    state_names = ("vy", "r", "w")
    design_type = PIODesign
    if TYPE_CHECKING:
        @property
        def design(self) -> PIODesign: ...     # an instance of design_type

    def __init__(self, params=None, *, model="original", gains=None, poles=None, **kw):
        if model not in ("original", "modified"):
            raise ValueError(f"model must be 'original' or 'modified', got {model!r}")
        gains = gains or ("table3" if model == "original" else "placed")
        if gains not in ("table3", "placed") or (model == "modified" and gains == "table3"):
            raise ValueError(f"gains {gains!r} not available for the {model} model")
        self.model, self.gains = model, gains
        default = DEFAULT_POLES_ORIGINAL if model == "original" else DEFAULT_POLES_MODIFIED
        self.poles = tuple(float(x) for x in (poles if poles is not None else default))
        if len(self.poles) != 3 or max(self.poles) >= 0:
            raise ValueError(f"poles must be 3 negative numbers, got {self.poles}")
        self.name = f"pio-{model}"
        self.uses = (model == "original", True, True)
        super().__init__(params, **kw)

    def _design_fields(self) -> dict:
        return dict(model=self.model, gains=self.gains, poles=self.poles)

    def gain(self, vx: float) -> np.ndarray:
        """Observer gain ``[K1; K2]`` at ``vx`` (m/s)."""
        return self._gain(augmented_design_model(self.design.params, vx, self.design.model), vx)

    def _gain(self, model, vx: float) -> np.ndarray:
        return pio_gain(self.design, model, vx)

    def observer(self, vx: float):
        """``(F, G, H, D)`` of the observer at ``vx`` (m/s; see ScheduledObserver)."""
        model = augmented_design_model(self.design.params, vx, self.design.model)
        A, B, C, Dy, Lw, _ = model
        Kg = self._gain(model, vx)
        return A - Kg @ C, B + Kg @ Dy, Lw, np.zeros((1, 3))

"""Result containers of the identification: one :class:`Quantity` per identified number."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from ..params import VehicleParams


@dataclass(frozen=True)
class Quantity:
    """One identified quantity, or the reason it was refused.

    Parameters
    ----------
    name : str
        Key, e.g. ``"Cr"``.
    value, std : float or None
        Estimate and its standard uncertainty (one sigma) in ``unit``; None when refused.
    unit : str
        SI unit (``"N/rad"``, ``"rad"``, ``"rad/s"``, ``"m/s^2"``, ``"rad s^2/m"``).
    note : str
        How it was obtained (method, data used, assumptions).
    refused : str or None
        Why the log(s) cannot tell this quantity (what excitation is missing).
    """

    name: str
    value: float | None
    std: float | None
    unit: str
    note: str = ""
    refused: str | None = None

    @property
    def ok(self) -> bool:
        """True when the quantity was identified (``value`` and ``std`` are finite)."""
        return (self.refused is None and self.value is not None and self.std is not None
                and math.isfinite(self.value) and math.isfinite(self.std))

    def as_identified(self) -> dict[str, float | str]:
        """``{"value", "std", "unit", "note"}`` for a vehicle file's ``[identified]`` table."""
        if not self.ok:
            raise ValueError(f"{self.name} was not identified: {self.refused}")
        # ok: value and std are floats
        return {"value": float(self.value), "std": float(self.std),  # type: ignore[arg-type]
                "unit": self.unit, "note": self.note}


def refused(name: str, unit: str, reason: str) -> Quantity:
    """A :class:`Quantity` that the data cannot tell, with the reason."""
    return Quantity(name, None, None, unit, refused=reason)


def measured(name: str, value: float, std: float, unit: str, note: str) -> Quantity:
    """A :class:`Quantity`, or a refusal when ``std`` is not finite (the data cannot bound the error)."""
    if not (math.isfinite(value) and math.isfinite(std)):
        return refused(name, unit, "uncertainty cannot be bounded: a channel never changes in a log, so its "
                                   "resolution (and how far quantisation biases its mean) cannot be told")
    return Quantity(name, float(value), float(std), unit, note)


@dataclass
class LogReport:
    """What one log contributed.

    ``used`` is False when the log could not be read or has no usable driving;
    ``problem`` then says why (for a used log, what it could not give: a log without a
    steering angle). ``seconds`` holds durations (s) of the kinds of
    driving found (``usable``, ``straight``, ``corners``) and ``n_corners``.
    """

    source: Path
    used: bool
    problem: str = ""
    seconds: dict = field(default_factory=dict)
    n_corners: int = 0
    speed_range: tuple = (math.nan, math.nan)


@dataclass
class IdentificationResult:
    """Identified quantities of a car from one or more logs.

    Attributes
    ----------
    quantities : dict name -> Quantity
        ``Cf``, ``Cr`` (N/rad), ``Kus`` (rad s^2/m), ``steering_offset`` (rad,
        road-wheel angle), ``yaw_rate_offset`` (rad/s), ``ay_offset`` (m/s^2),
        ``roll_gain`` (rad per m/s^2); each identified or refused.
    logs : list of LogReport
    params : VehicleParams
        The base parameters with ``Cf``, ``Cr`` replaced by the identified
        values where both were identified, or by one identified and the other derived from ``Kus`` (see
        ``derived``), and ``k_roll`` (N m/rad) by the one that gives the identified
        roll gain (``ms``, ``h_roll`` kept).
    derived : dict name -> Quantity
        A refused axle stiffness derived from the identified ``Kus`` and the other axle's, so that ``params``
        agrees with the identified understeer gradient (:mod:`.pair`); its ``note`` says from what. Empty when
        none was.
    warnings : list of str
        What the caller must know about ``params``: the base car's ``Cf``, ``Cr`` kept although their
        understeer gradient contradicts the identified one (both named).
    """

    quantities: dict
    logs: list
    params: VehicleParams
    derived: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)

    def identified(self) -> dict[str, dict[str, float | str]]:
        """The identified quantities as ``{name: {"value", "std", "unit", "note"}}``."""
        return {k: q.as_identified() for k, q in self.quantities.items() if q.ok}

    def refusals(self) -> dict[str, str]:
        """``{name: reason}`` of the quantities the logs could not tell."""
        return {k: q.refused for k, q in self.quantities.items() if not q.ok}

    @property
    def complete(self) -> bool:
        """True when every quantity was identified and every log was used for all it could give (a log without
        a steering angle gives the offsets only)."""
        return not self.refusals() and all(r.used and not r.problem for r in self.logs)

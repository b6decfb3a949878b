"""The axle cornering stiffnesses the result (and the vehicle file) gets: a pair that agrees with the
identified understeer gradient.

With both ``Cf`` and ``Cr`` identified the pair is theirs. When the regression identifies ``Kus`` and one
stiffness but refuses the other (too few yaw transients: its relative uncertainty is above the limit), the
base vehicle's guessed pair would contradict the identified ``Kus`` and every estimator reading the file would
use the guessed steady-state gain (docs/identification.md: the SUV's file gives 3.58 deg/g, a simulated SUV with
twice its ``Cr`` was identified at 4.11 +- 0.04 deg/g). The refused stiffness is then derived from ``Kus`` and
the identified one (bicycle model, paper eq 15, :func:`~roadbank.models.bicycle.understeer_gradient`), which is
the regression's own value for it, reported as derived, not identified, with its uncertainty. A derived value
that is not positive, or that the caller's check refuses (the vehicle file's plausible ranges and stability,
which ``roadbank identify`` passes), is not used: the base pair is kept, with a warning naming both understeer
gradients when they disagree by more than :data:`CONTRADICTS_SIGMA`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from ..constants import G
from ..models.bicycle import understeer_gradient
from ..params import VehicleParams
from .results import Quantity

#: the base pair's understeer gradient contradicts the identified one beyond this many of the identified one's sigmas
CONTRADICTS_SIGMA = 2.0

#: rad s^2/m -> deg/g, the unit the messages print an understeer gradient in
_DEG_PER_G = math.degrees(G)

#: formula of the derived stiffness, by its name
FORMULA = {"Cr": "Lf / (Lr/Cf - L Kus/m)", "Cf": "Lr / (L Kus/m + Lf/Cr)"}

#: a check of a candidate pair: ``params`` -> "" if it may be written, else why not
PairCheck = Callable[[VehicleParams], str]


def _value(q: Quantity) -> tuple[float, float]:
    """``(value, std)`` of an identified quantity."""
    if not q.ok or q.value is None or q.std is None:
        raise ValueError(f"{q.name} was not identified: {q.refused}")
    return float(q.value), float(q.std)


def derive_stiffness(name: str, kus: Quantity, other: Quantity, p: VehicleParams) -> tuple[float, float]:
    """The axle cornering stiffness ``name`` (``"Cf"`` or ``"Cr"``, N/rad) that gives the understeer gradient
    ``kus`` (rad s^2/m) with the ``other`` axle's identified stiffness (N/rad), and its standard uncertainty.

    :data:`FORMULA` (``m``, ``Lf``, ``Lr`` of ``p``); the uncertainty is propagated to first order from those of
    ``kus`` and ``other``, taken as independent (on simulated drives within 10 % of the regression's own spread
    of the refused value). Returns ``(value, std)``; the value is negative (or infinite) when the two imply no
    positive stiffness.
    """
    k, sk = _value(kus)
    c, sc = _value(other)
    a = p.L / p.m               # Kus enters as L Kus / m
    if name == "Cr":            # Lf / Cr = Lr / Cf - L Kus / m
        lever, d, sd = p.Lf, p.Lr / c - a * k, math.hypot(p.Lr * sc / c**2, a * sk)
    elif name == "Cf":          # Lr / Cf = L Kus / m + Lf / Cr
        lever, d, sd = p.Lr, a * k + p.Lf / c, math.hypot(a * sk, p.Lf * sc / c**2)
    else:
        raise ValueError(f"not an axle cornering stiffness: {name!r}")
    if d == 0:
        return math.inf, math.inf
    return lever / d, lever * sd / d**2


def _kn(x: float) -> str:
    return f"{x / 1e3:.4g} kN/rad"


def _deg_g(x: float) -> str:
    return f"{x * _DEG_PER_G:.3g} deg/g"


def _contradiction(p: VehicleParams, kus: Quantity, why: str) -> list[str]:
    """The warning that the base pair of ``p``, kept because ``why``, contradicts the identified ``kus`` (none
    when they agree within :data:`CONTRADICTS_SIGMA`)."""
    k, sk = _value(kus)
    base = understeer_gradient(p)
    z = (base - k) / sk
    if abs(z) <= CONTRADICTS_SIGMA:
        return []
    return [f"Cf, Cr kept at the base car's {_kn(p.Cf)} and {_kn(p.Cr)} ({why}); their understeer gradient "
            f"{_deg_g(base)} contradicts the identified Kus {k * _DEG_PER_G:.3g} +- {sk * _DEG_PER_G:.2g} deg/g "
            f"({z:+.0f} sigma): the "
            f"estimators reading the file use the base car's steady-state response, not the one measured; give "
            f"the base vehicle a Cf, Cr that fit, or identify from logs with more yaw transients (corner entries "
            f"and exits, lane changes)"]


def stiffness_pair(quantities: dict[str, Quantity], p: VehicleParams, check: PairCheck | None = None
                   ) -> tuple[VehicleParams, dict[str, Quantity], list[str]]:
    """The ``Cf``, ``Cr`` the result gets: ``(params, derived, warnings)``.

    Parameters
    ----------
    quantities : dict name -> Quantity
        The identification's ``Cf``, ``Cr`` (N/rad) and ``Kus`` (rad s^2/m), identified or refused.
    p : VehicleParams
        The base vehicle (its ``m``, ``Lf``, ``Lr``, and the pair kept when none can be written).
    check : callable, optional
        ``params -> ""`` when a pair may be written, else the reason (``roadbank identify`` passes the vehicle
        file's checks: plausible ranges, stability). Default: positive values only.

    Returns
    -------
    params : VehicleParams
        ``p`` with the identified pair; or with one identified stiffness and the other derived from ``Kus``
        (:func:`derive_stiffness`) when that one was refused and the derived value is positive and passes
        ``check``; else ``p`` (its pair kept).
    derived : dict name -> Quantity
        The derived stiffness (its ``note`` says from what, and why it was refused on its own); empty when none.
    warnings : list of str
        The base pair kept although it contradicts the identified ``Kus``: both understeer gradients, and why.
    """
    cf, cr, kus = quantities.get("Cf"), quantities.get("Cr"), quantities.get("Kus")
    if cf is None or cr is None:
        return p, {}, []
    if cf.ok and cr.ok:
        return p.replace(Cf=_value(cf)[0], Cr=_value(cr)[0]), {}, []
    if kus is None or not kus.ok:
        return p, {}, []
    if not cf.ok and not cr.ok:
        return p, {}, _contradiction(p, kus, "Cf and Cr were both refused; the identified Kus alone gives neither")
    known, gone = (cf, cr) if cf.ok else (cr, cf)
    name = gone.name
    value, std = derive_stiffness(name, kus, known, p)
    implied = f"{name} was refused and the identified Kus and {known.name} imply {name} = {_kn(value)}"
    if not (math.isfinite(value) and value > 0):
        return p, {}, _contradiction(p, kus, f"{implied}: no positive {name} gives that understeer gradient")
    pair = {"Cf": _value(known)[0], "Cr": value} if name == "Cr" else {"Cf": value, "Cr": _value(known)[0]}
    try:
        candidate = p.replace(**pair)
        problem = check(candidate) if check is not None else ""
    except ValueError as exc:
        problem = str(exc)
    if problem:
        return p, {}, _contradiction(p, kus, f"{implied}, which the vehicle file does not accept: {problem}")
    k, _ = _value(kus)
    c, _ = _value(known)
    note = (f"derived, not identified: {name} = {FORMULA[name]} from the identified Kus {_deg_g(k)} and "
            f"{known.name} {_kn(c)} (m, Lf, Lr of the base vehicle), so that the pair gives the identified "
            f"understeer gradient; std propagated from theirs (first order); refused on its own: {gone.refused}")
    return candidate, {name: Quantity(name, value, std, "N/rad", note)}, []

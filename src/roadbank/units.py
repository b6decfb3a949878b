"""Physical units roadbank reads, and their conversion to SI: one table for every input.

A unit belongs to a dimension (mass, length, speed, angular rate, ...) and converts to the
dimension's SI unit (:data:`SI_UNIT`) by a pure scale factor, no offset:
``value_si = value * UNITS[dimension][unit]``. A unit is accepted only for its dimension, so a
speed declared in ``deg`` is an error, not a silent nonsense factor. Two inputs name units,
both through :data:`UNITS`:

* a vehicle file's ``"value unit"`` strings (:func:`parse_quantity`): any unit of the key's
  dimension, spelled as SI writes it (case matters: ``"kN/rad"``, ``"mg"``); blanks, ``*``,
  ``·`` and ``^`` between unit parts are ignored, ``²`` is ``2`` and ``°`` is ``deg``;
* a log's channel map (:func:`factor`): the units of the channel's kind in
  :data:`FACTORS` -- the few a logger writes, spelled in any case, with common aliases
  (``kph``, ``deg/sec``, ``m/s**2``; :func:`normalise_unit`). A kind is a dimension
  written as an identifier (``angular_rate`` is the dimension ``angular rate``).
"""

from __future__ import annotations

import difflib
import math
import re

from .constants import G

__all__ = ["UNITS", "SI_UNIT", "parse_quantity", "FACTORS", "CHANNEL_SI_UNIT", "factor", "normalise_unit",
           "dimension_of_kind"]

#: one degree in radians (rad)
DEG = math.pi / 180.0
#: one "per degree" in "per radian" (1/rad)
PER_DEG = 180.0 / math.pi
#: one km/h in m/s
KMH = 1.0 / 3.6
#: one mile per hour in m/s
MPH = 0.44704

#: dimension -> {unit: factor to SI}. Unit keys are normalised (:func:`_norm_unit`): blanks,
#: ``*``, ``.`` between units and ``^`` removed, ``²`` -> ``2``.
UNITS: dict[str, dict[str, float]] = {
    "mass": {"kg": 1.0, "t": 1000.0},
    "length": {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "km": 1e3},
    "inertia": {"kgm2": 1.0},
    "angle": {"rad": 1.0, "mrad": 1e-3, "deg": DEG},
    "angular rate": {"rad/s": 1.0, "mrad/s": 1e-3, "deg/s": DEG},
    "acceleration": {"m/s2": 1.0, "g": G, "mg": 1e-3 * G},
    "speed": {"m/s": 1.0, "km/h": KMH, "kph": KMH, "mph": MPH},
    "cornering stiffness": {"N/rad": 1.0, "kN/rad": 1e3, "N/deg": PER_DEG, "kN/deg": 1e3 * PER_DEG},
    "roll stiffness": {"Nm/rad": 1.0, "kNm/rad": 1e3, "Nm/deg": PER_DEG, "kNm/deg": 1e3 * PER_DEG},
    "roll damping": {"Nms/rad": 1.0, "kNms/rad": 1e3, "Nms/deg": PER_DEG},
    "frequency": {"Hz": 1.0, "kHz": 1e3},
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9},
    "power": {"W": 1.0, "kW": 1e3},
    "torque": {"Nm": 1.0, "kNm": 1e3},
    "area": {"m2": 1.0},
    "density": {"kg/m3": 1.0},
    "dimensionless": {"": 1.0, "-": 1.0, "%": 0.01},
}

#: SI unit each dimension is stored in (for messages and documentation)
SI_UNIT = {"mass": "kg", "length": "m", "inertia": "kg m^2", "angle": "rad", "angular rate": "rad/s",
           "acceleration": "m/s^2", "speed": "m/s", "cornering stiffness": "N/rad",
           "roll stiffness": "N m/rad", "roll damping": "N m s/rad", "frequency": "Hz", "time": "s",
           "power": "W", "torque": "N m", "area": "m^2", "density": "kg/m^3", "dimensionless": "-"}

_UNIT_DIM = {u: dim for dim, table in UNITS.items() for u in table}
_NUMBER = re.compile(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(.*?)\s*$")


def _norm_unit(unit: str) -> str:
    """A unit as :data:`UNITS` spells it (blanks, ``*``, ``^``, ``·`` dropped; ``²`` -> ``2``, ``°`` -> ``deg``)."""
    u = unit.strip().replace("²", "2").replace("³", "3").replace("°", "deg").replace("·", "")
    u = re.sub(r"[\s*^]", "", u)
    return u.replace("degree", "deg").replace("degs", "deg")


def _a(word: str) -> str:
    return f"{'an' if word[0] in 'aeiou' else 'a'} {word}"


def parse_quantity(value: str, dimension: str) -> float:
    """Convert a ``"value unit"`` string (e.g. ``"0.3 deg/s"``) to SI for ``dimension``.

    Parameters
    ----------
    value : str
        Number, optional whitespace, unit from :data:`UNITS` (``"1687 kg"``, ``"115 kN/rad"``).
    dimension : str
        Key of :data:`UNITS` the quantity must have.

    Returns
    -------
    float
        The value in the SI unit of ``dimension`` (:data:`SI_UNIT`).

    Raises
    ------
    ValueError
        Not a number followed by a unit, an unknown unit, or a unit of another dimension.
    """
    m = _NUMBER.match(value)
    if m is None:
        raise ValueError("expected a number or a \"value unit\" string such as \"1687 kg\"")
    number, unit = float(m.group(1)), _norm_unit(m.group(2))
    if unit in UNITS[dimension]:
        return number * UNITS[dimension][unit]
    accepted = ", ".join(repr(u) for u in UNITS[dimension] if u)
    other = _UNIT_DIM.get(unit)
    if other is None:
        close = difflib.get_close_matches(unit, list(_UNIT_DIM), n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise ValueError(f"unknown unit '{m.group(2)}'{hint}; {dimension} accepts {accepted or 'no unit'}")
    raise ValueError(f"unit '{m.group(2)}' is {_a(other)}, this key needs {_a(dimension)} "
                     f"({accepted or 'a plain number'})")


# ---------------------------------------------------------------------------------------------
# a log's channel units

#: the units a channel map may declare, by kind, as a channel map spells them
_CHANNEL_UNITS = {"time": ("s", "ms", "us", "ns"), "speed": ("m/s", "km/h", "kph", "mph"),
                  "acceleration": ("m/s^2", "m/s2", "g"), "angular_rate": ("rad/s", "deg/s"),
                  "angle": ("rad", "deg"), "length": ("m", "km")}


def dimension_of_kind(kind: str) -> str:
    """The :data:`UNITS` dimension of a channel kind (``"angular_rate"`` -> ``"angular rate"``)."""
    return kind.replace("_", " ")


#: kind -> {unit spelling: factor to SI}: the units a log's channel map may declare
FACTORS: dict[str, dict[str, float]] = {
    kind: {u: UNITS[dimension_of_kind(kind)][_norm_unit(u)] for u in spellings}
    for kind, spellings in _CHANNEL_UNITS.items()}

#: the SI unit of each channel kind
CHANNEL_SI_UNIT = {kind: SI_UNIT[dimension_of_kind(kind)] for kind in FACTORS}

_CHANNEL_ALIASES = {"sec": "s", "second": "s", "seconds": "s", "kmh": "km/h", "km/hr": "km/h",
                    "mps": "m/s", "degree": "deg", "degrees": "deg", "radian": "rad", "radians": "rad",
                    "deg/sec": "deg/s", "rad/sec": "rad/s", "°": "deg", "°/s": "deg/s",
                    "ms^-2": "m/s^2", "m/s²": "m/s^2", "µs": "us", "m/sec": "m/s", "m/s/s": "m/s^2",
                    "m/sec^2": "m/s^2", "ms-2": "m/s^2", "dps": "deg/s", "°/sec": "deg/s"}


def normalise_unit(unit: str) -> str:
    """Canonical spelling of a channel map's unit string (case and blanks ignored; ``m/s**2`` -> ``m/s^2``)."""
    low = str(unit).strip().replace(" ", "").replace("**", "^").lower()
    return _CHANNEL_ALIASES.get(low, low)


def factor(kind: str, unit: str) -> float:
    """Scale factor from a channel map's ``unit`` to SI for a channel of ``kind`` (a key of :data:`FACTORS`).

    Raises
    ------
    ValueError
        If the unit is unknown for that kind (the message lists the accepted ones).
    """
    table = FACTORS[kind]
    u = normalise_unit(unit)
    if u not in table:
        raise ValueError(f"unit '{unit}' is not a {dimension_of_kind(kind)} unit "
                         f"(accepted: {', '.join(table)})")
    return table[u]


def reads_as_number(text: str) -> bool:
    """True if ``text`` reads as a number as ``float()`` reads it (``"1e3"``, ``" 2.5"``, ``"nan"``, ``"inf"``)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def describe_offsets(offsets) -> str:
    """Sensor offsets by channel (a mapping, :attr:`roadbank.vehicle.Vehicle.sensor_offsets`, SI: ``r`` rad/s, ``ay``
    m/s^2, ``delta_f`` rad) in words and display units, e.g. ``"yaw rate +0.500 deg/s, ay +0.150 m/s^2"``."""
    words = {"r": lambda v: f"yaw rate {math.degrees(v):+.3f} deg/s", "ay": lambda v: f"ay {v:+.3f} m/s^2",
             "delta_f": lambda v: f"steering {math.degrees(v):+.3f} deg (road wheel)"}
    return ", ".join(words[c](v) for c, v in offsets.items())

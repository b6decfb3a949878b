"""Physical units accepted in channel maps and their conversion to SI.

Every quantity roadbank reads has a *kind* (time, speed, acceleration, angular
rate, angle); a unit is accepted only for its kind, so a speed declared in
``deg`` is an error, not a silent nonsense factor. Conversion is a pure scale
factor (no offsets): ``value_si = value * FACTORS[kind][unit]``.
"""

from __future__ import annotations

import math

#: Standard gravity used to convert ``g`` to m/s^2 (the same 9.81 as roadbank.G).
G_UNIT = 9.81

#: kind -> {unit spelling: factor to SI}
FACTORS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9},
    "speed": {"m/s": 1.0, "km/h": 1.0 / 3.6, "kph": 1.0 / 3.6, "mph": 0.44704},
    "acceleration": {"m/s^2": 1.0, "m/s2": 1.0, "g": G_UNIT},
    "angular_rate": {"rad/s": 1.0, "deg/s": math.pi / 180.0},
    "angle": {"rad": 1.0, "deg": math.pi / 180.0},
    "length": {"m": 1.0, "km": 1000.0},
}

#: the SI unit of each kind
SI_UNIT = {"time": "s", "speed": "m/s", "acceleration": "m/s^2",
           "angular_rate": "rad/s", "angle": "rad", "length": "m"}


def normalise_unit(unit: str) -> str:
    """Canonical spelling of a unit string (case and blanks ignored; ``m/s**2`` -> ``m/s^2``)."""
    u = str(unit).strip().replace(" ", "").replace("**", "^")
    low = u.lower()
    aliases = {"sec": "s", "second": "s", "seconds": "s", "kmh": "km/h", "km/hr": "km/h",
               "mps": "m/s", "degree": "deg", "degrees": "deg", "radian": "rad", "radians": "rad",
               "deg/sec": "deg/s", "rad/sec": "rad/s", "°": "deg", "°/s": "deg/s",
               "ms^-2": "m/s^2", "m/s²": "m/s^2", "µs": "us"}
    return aliases.get(low, low)


def factor(kind: str, unit: str) -> float:
    """Scale factor from ``unit`` to SI for a quantity of ``kind``.

    Raises
    ------
    ValueError
        If the unit is unknown for that kind (the message lists the accepted ones).
    """
    table = FACTORS[kind]
    u = normalise_unit(unit)
    if u not in table:
        raise ValueError(f"unit '{unit}' is not a {kind.replace('_', ' ')} unit "
                         f"(accepted: {', '.join(table)})")
    return table[u]

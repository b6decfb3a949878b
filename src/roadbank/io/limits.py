"""Physical limits of a passenger car's channels: a sample beyond them is a glitch, read as a dropout.

A corrupt sample (a bit error on the bus, a logger's glitch: ``ay`` = 300 m/s^2 in one frame) is not
what the car did. Left in, it would move the estimate as far as a low-pass lets one sample move it, and
the noise measured for the design (:func:`roadbank.vehicle.log_conditions`) with it, for the whole log.
So a value beyond :data:`LIMITS` (SI, ISO 8855) becomes NaN, as a dropout: the estimators hold their
output there and flag it (``valid`` False), and the log's reader warns once, naming the file, the
channel, the count and the first time. The unit check (:func:`roadbank.io.channels.check_plausible`) reads
percentiles and stays what refuses a whole channel in a wrong unit; these limits read single samples.
"""

from __future__ import annotations

import numpy as np

from ..constants import G
from .errors import channel_text

#: (lowest, highest) value of each channel role a passenger car can have (SI): speed (m/s; reversing
#: included), lateral acceleration (m/s^2: 3 g, beyond the tyres' grip with any bank and roll; an ESP
#: sensor's range is about 2 g) and yaw rate (rad/s: 5, beyond a spin; an ESP sensor's range is 1.7-2.6)
LIMITS = {"speed": (-30.0, 120.0), "lateral_acceleration": (-3.0 * G, 3.0 * G), "yaw_rate": (-5.0, 5.0),
          "roll_rate": (-5.0, 5.0), "pitch_rate": (-5.0, 5.0), "longitudinal_acceleration": (-3.0 * G, 3.0 * G)}


class Dropouts:
    """Counts the samples of one log set to NaN by :meth:`apply` and words the warning (:meth:`warnings`)."""

    def __init__(self, source, columns: dict):
        self.source, self.columns = source, columns
        self.count: dict = {}
        self.first: dict = {}

    def apply(self, role: str, t: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``v`` (SI) with its samples beyond the role's limits NaN (a copy where any is; ``v`` itself
        otherwise); ``t`` (s) their times."""
        if role not in LIMITS or not len(v):
            return v
        lo, hi = LIMITS[role]
        with np.errstate(invalid="ignore"):
            bad = (v < lo) | (v > hi)
        n = int(np.count_nonzero(bad))
        if n:
            v = np.where(bad, np.nan, v)
            if role not in self.first:
                self.first[role] = float(np.asarray(t)[np.argmax(bad)])
            self.count[role] = self.count.get(role, 0) + n
        return v

    def warnings(self) -> list[str]:
        """One warning per channel that had samples beyond its limits; [] for a clean log."""
        return [channel_text(self.source, role, self.columns.get(role),
                             f"{n} sample(s) outside [{LIMITS[role][0]:g}, {LIMITS[role][1]:g}] (SI), impossible for "
                             f"a car, read as dropouts (the first at t = {self.first[role]:.3f} s)")
                for role, n in self.count.items()]

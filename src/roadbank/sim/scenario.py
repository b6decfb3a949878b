"""A manoeuvre to simulate: road, driver, duration and start (:class:`Scenario`).

Its own module so that the paper's scenarios (:mod:`.scenarios`) and the further drives
(:mod:`.drives`) both build on it without importing each other.
"""

from __future__ import annotations

from dataclasses import dataclass

from .driver import Driver
from .road import Road


@dataclass(frozen=True)
class Scenario:
    """A manoeuvre: road, driver, duration and start position.

    Parameters
    ----------
    name : str
    road : Road
    driver : Driver
    duration : float
        Simulated time after the pre-roll (s).
    start_s, start_n : float
        Path distance and lateral offset (m) of the CG at t = 0.
    pre_roll : float
        Settling time simulated before t = 0 and discarded (s).
    description : str
    """

    name: str
    road: Road
    driver: Driver
    duration: float
    start_s: float = 0.0
    start_n: float = 0.0
    pre_roll: float = 5.0
    description: str = ""

    def __post_init__(self) -> None:
        if not self.duration > 0:
            raise ValueError("Scenario.duration must be > 0")
        if not self.pre_roll >= 0:
            raise ValueError("Scenario.pre_roll must be >= 0")

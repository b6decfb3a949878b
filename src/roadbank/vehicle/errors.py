"""The one error a vehicle file or a vehicle built in code raises."""

from __future__ import annotations

__all__ = ["VehicleFileError"]


class VehicleFileError(ValueError):
    """A vehicle file (or a vehicle built in code) is malformed; the message names file and key."""

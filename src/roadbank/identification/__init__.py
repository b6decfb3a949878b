"""roadbank.identification: what driving logs can tell about a car.

``identify(logs, params)`` returns the understeer gradient, the front and rear
axle cornering stiffnesses, the steering, yaw-rate and lateral-acceleration
offsets and (with a roll reference) the roll gain, each with a block-bootstrap
standard uncertainty, or the reason the logs cannot tell it. Method, assumptions
and accuracy: docs/identification.md.
"""

from .identify import identify
from .results import IdentificationResult, LogReport, Quantity
from .settings import IdentifySettings

__all__ = ["identify", "IdentificationResult", "IdentifySettings", "LogReport", "Quantity"]

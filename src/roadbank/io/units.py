"""The units a log's channel map may declare: :mod:`roadbank.units` under the names the readers use.

Every unit roadbank reads, with its factor to SI, is in the one table :data:`roadbank.units.UNITS`;
a channel's kind accepts the units of :data:`FACTORS`.
"""

from __future__ import annotations

from ..constants import G as G_UNIT
from ..units import CHANNEL_SI_UNIT as SI_UNIT
from ..units import FACTORS, dimension_of_kind, factor, normalise_unit

__all__ = ["FACTORS", "SI_UNIT", "G_UNIT", "dimension_of_kind", "factor", "normalise_unit"]

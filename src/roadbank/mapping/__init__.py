"""Bank maps: settled bank estimates attached to GNSS positions and aggregated per road cell.

* :mod:`.geo` -- the local East/North projection of the map (equirectangular about an origin).
* :mod:`.grid` -- :class:`BankMap`: square cells x heading sectors, running mean / spread / count;
  Parquet, GeoJSON and PNG output.
* :mod:`.build` -- :func:`map_logs`: stream logs, estimate, attach, aggregate (bounded memory).
* :mod:`.simulated` -- GNSS positions of a simulated run from the road's geometry (for checks).

See docs/io.md ("Bank maps") for the grid, the heading sectors and why they exist.
"""

from .build import map_logs
from .geo import LocalProjection
from .grid import BankMap

__all__ = ["BankMap", "LocalProjection", "map_logs"]
